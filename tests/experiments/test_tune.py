"""bipedsim tune: the tune file's checks, the objective's terms, CMA-ES's determinism and resuming,
several references and creature bodies. Tunes here are tiny (2-3 s rollouts, a handful of candidates)
so that each takes seconds."""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from bipedsim.cli import main
from bipedsim.control.settings import load_controller
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.experiments.tune import Objective, load_tune, run_tune
from bipedsim.experiments.tune import cmaes as tune_cmaes
from bipedsim.experiments.tune.objective import DEVIATION_CAP, TERMS, Cadence, GaitMeter, push_terms, walk_terms
from bipedsim.sim.runner import load_scenario

REPO = Path(__file__).resolve().parents[2]
BROKEN = REPO / "experiments" / "controllers" / "no_balance_feedback.yaml"
HORSE = REPO / "src" / "bipedsim" / "data" / "horse_walk.bvh"

TINY = {"name": "tiny", "controller": str(BROKEN),
        "parameters": {"balance.sagittal.cd": [0.0, 1.5], "balance.coronal.cd": [0.0, 1.5]},
        "evaluations": 5, "popsize": 3, "seed": 3,
        "experiment": {"seconds": 2.5, "after": 1.0,
                       "grid": {"magnitude": [150], "direction": [90], "duration": [0.2], "start": [1.2]}}}


def write_tune(folder: Path, data: dict, name: str = "tune.yaml") -> Path:
    p = folder / name
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def with_(base: dict, **changes: object) -> dict:
    out = yaml.safe_load(yaml.safe_dump(base, sort_keys=False))
    out.update(changes)
    return out


# ---------------------------------------------------------------------- the tune file's checks
@pytest.mark.parametrize("changes, key, text", [
    ({"bogus": 1}, "bogus", "unknown key; allowed keys here:"),
    ({"parameters": {"balance.sagittal.cd": [1.0, 0.5]}}, "parameters.balance.sagittal.cd",
     "[low, high] must have low < high, got [1, 0.5]"),
    ({"parameters": {"balance.sagittal.kx": [0.0, 1.0]}}, "parameters.balance.sagittal.kx",
     "the humanoid controller has no key 'balance.sagittal.kx'"),
    ({"parameters": {"pd.gains.tail.kp": [0.0, 1.0]}}, "parameters.pd.gains.tail.kp",
     "the humanoid controller has no key 'pd.gains.tail'"),
    ({"parameters": {"balance.enabled": [0.0, 1.0]}}, "parameters.balance.enabled",
     "is True in the start controller, not a number"),
    ({"parameters": {"pd.gains.hip.kp": [-10.0, 500.0]}}, "parameters.pd.gains.hip.kp",
     "the controller refuses -10 here (must be >= 0.0, got -10.0)"),
    ({"parameters": {}}, "parameters", "name at least one controller key"),
    ({"parameters": {"balance.sagittal.cd": [0.0, "high"]}}, "parameters.balance.sagittal.cd[1]",
     "expected a number"),
    ({"controller": "nowhere.yaml"}, "controller", "no such controller file"),
    ({"reference": "nowhere.bvh"}, "reference", "no such file"),
    ({"reference": [None, "nowhere.bvh"]}, "reference", "expected"),
    ({"evaluations": 0}, "evaluations", "must be >= 1"),
    ({"sigma": 2.0}, "sigma", "must be <= 1.0"),
    ({"objective": {"walk_fall": -1}}, "objective.walk_fall", "must be >= 0.0"),
    ({"objective": {"walks": 1}}, "objective.walks", "unknown key"),
    ({"experiment": None}, "experiment", "give the experiment whose rollouts score each candidate"),
    ({"experiment": {"seconds": 2.5, "reference": "x.bvh", "grid": TINY["experiment"]["grid"]}},
     "experiment.reference", "belongs to the tune, not its experiment"),
    ({"experiment": {"seconds": 2.5, "grid": {**TINY["experiment"]["grid"], "controller": ["a.yaml"]}}},
     "experiment.grid", "a tune scores its own candidates"),
    ({"experiment": {"seconds": 1.0, "grid": TINY["experiment"]["grid"]}}, "experiment.grid", "1 s"),
    ({"experiment": {"seconds": 2.5, "grid": {**TINY["experiment"]["grid"], "magnitude": [-5]}}},
     "experiment.grid.magnitude", "must be >= 0 N"),
    ({"experiment": {"seconds": 2.5, "body": "tail", "grid": TINY["experiment"]["grid"]}}, "experiment.body",
     "unknown body 'tail'"),
    ({"profile": "creature"}, "reference", "the creature profile needs a motion"),
    ({"profile": "creature", "reference": str(HORSE), "controller": "nowhere.yaml"}, "controller",
     "no such controller file"),
    ({"support": True}, "support", "needs profile: creature"),
])
def test_tune_file_errors_name_the_file_and_key(tmp_path: Path, changes: dict, key: str, text: str) -> None:
    p = write_tune(tmp_path, with_(TINY, **changes))
    with pytest.raises(ConfigError) as err:
        load_tune(p)
    assert err.value.path == str(p)
    assert err.value.key == key
    assert text in err.value.reason


def test_missing_reference_in_a_list_names_its_index(tmp_path: Path) -> None:
    from bipedsim.data import BUILTIN_WALK

    p = write_tune(tmp_path, with_(TINY, reference=[str(BUILTIN_WALK), "nowhere.bvh"]))
    with pytest.raises(ConfigError, match=r"reference\[1\]: no such file .*nowhere.bvh"):
        load_tune(p)


def test_cli_refuses_a_bad_tune_file_with_one_line_and_exit_2(tmp_path: Path, capsys) -> None:
    p = write_tune(tmp_path, with_(TINY, parameters={"balance.sagittal.kx": [0, 1]}))
    assert main(["tune", str(p), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith(f"bipedsim tune: error: {p}: parameters.balance.sagittal.kx: the humanoid controller "
                             "has no key")
    assert not (tmp_path / "out").exists()  # nothing written before the checks pass


def test_paths_are_relative_to_the_tune_file(tmp_path: Path) -> None:
    (tmp_path / "ctl").mkdir()
    (tmp_path / "ctl" / "start.yaml").write_text("balance: {sagittal: {cd: 0.25}}\n")
    tune = load_tune(write_tune(tmp_path, with_(TINY, controller="ctl/start.yaml")))
    assert tune.start_values()["balance.sagittal.cd"] == 0.25
    assert tune.start_values()["balance.coronal.cd"] == 0.55  # the default under the file


# ---------------------------------------------------------------------- the objective
def test_score_is_the_weighted_sum_of_the_terms() -> None:
    w = Objective(walk_fall=3.0, pushes=2.0, fall_time=1.0, deviation=3.0, speed=0.5, tracking=4.0, effort=0.1,
                  steps=7.0)
    terms = dict(zip(TERMS, [1.0, 0.5, 0.25, 0.5, 0.2, 0.1, 10.0, 0.5]))
    assert w.score(terms) == pytest.approx(3 + 1 + 0.25 + 1.5 + 0.1 + 0.4 + 1.0 + 3.5)


def _outcome(outcome: str, sim_seconds: float, speed: float = 1.0, ref: float = 1.0, rmse: float = 0.1,
             peak: float | None = None):
    return SimpleNamespace(outcome=outcome, sim_seconds=sim_seconds, mean_speed_mps=speed, reference_speed_mps=ref,
                           tracking_rmse_rad=rmse, extra={"peak_com_deviation_m": peak})


def test_push_terms_count_failures_the_time_lost_and_the_deviation() -> None:
    outs = [(_outcome("no_fall", 8.0, peak=0.5), 5.0), (_outcome("fall", 6.0, peak=0.3), 4.0),
            (_outcome("diverged", 4.0), 4.0), (_outcome("push_not_applied", 8.0), 5.0),
            (_outcome("no_fall", 8.0, peak=9.0), 5.0)]
    t = push_terms(outs, seconds=8.0, height=1.0)
    assert t["pushes"] == 0.6  # a push that never happened is not a push survived
    assert t["fall_time"] == pytest.approx((0.0 + 0.5 + 1.0 + 0.0 + 0.0) / 5)
    # 0.5 root heights; a fall and a divergence count as the cap, as does no measurement and 9 m
    assert t["deviation"] == pytest.approx((0.5 + 4 * DEVIATION_CAP) / 5)
    assert push_terms(outs[:1], seconds=8.0, height=2.0)["deviation"] == 0.25


class _Meter:
    def __init__(self, steps: int, power: float) -> None:
        self.real_steps, self.power = steps, power

    def power_per_kg(self, seconds: float) -> float:
        return self.power


def test_walk_terms_fall_speed_and_step_guard() -> None:
    cad = Cadence(strikes_per_s=2.0, swing_s=0.4)
    w = Objective()  # min_steps 0.5: 8 s x 2 /s x 0.5 = 8 real steps needed
    ok = walk_terms(_outcome("no_fall", 8.0, speed=0.9, ref=1.2), _Meter(16, 3.0), cad, 8.0, w)
    assert ok == {"walk_fall": 0.0, "speed": pytest.approx(0.25), "tracking": 0.1, "effort": 3.0, "steps": 0.0}
    fell = walk_terms(_outcome("fall", 2.0), _Meter(2, 3.0), cad, 8.0, w)
    assert fell["walk_fall"] == pytest.approx(1.75)
    assert fell["steps"] == pytest.approx(0.75)  # 2 of the 8 needed
    slid = walk_terms(_outcome("no_fall", 8.0), _Meter(0, 3.0), cad, 8.0, w)
    assert slid["steps"] == 1.0  # sliding: no real step at all
    in_place = walk_terms(_outcome("no_fall", 8.0, speed=0.05, ref=0.0), _Meter(0, 1.0), Cadence(0.0, 0.0), 8.0, w)
    assert in_place["steps"] == 0.0 and in_place["speed"] == pytest.approx(0.05 / 0.2)


def test_gait_meter_counts_touchdowns_after_enough_air_and_integrates_power() -> None:
    import mujoco

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><joint name='j' type='hinge'/><geom size='0.1' mass='2'/></body></worldbody>"
        "<actuator><motor joint='j'/></actuator></mujoco>")
    weight = float(np.sum(model.body_mass)) * 9.81
    meter = GaitMeter(model, min_air_s=0.1)
    forces = {"f": [weight]}
    ctrl = SimpleNamespace(foot_forces=lambda data: forces["f"])
    data = SimpleNamespace(actuator_force=np.array([2.0]), actuator_velocity=np.array([-3.0]))
    # on the ground, 0.2 s in the air (a step), 0.04 s in the air (a shuffle: no step), 0.12 s (a step)
    schedule = [(0.0, 1.0), (0.1, 1.0), (0.2, 0.0), (0.4, 1.0), (0.5, 0.0), (0.54, 1.0), (0.6, 0.0),
                (0.72, 1.0), (1.0, 1.0)]
    for t, load in schedule:
        forces["f"] = [load * weight]
        meter(t, data, ctrl)
    assert meter.real_steps == 2
    assert meter.energy_j == pytest.approx(6.0 * 1.0)  # |2 N*m x -3 rad/s| over 1 s
    assert meter.power_per_kg(1.0) == pytest.approx(6.0 / meter.mass)


def test_cadence_of_a_clip_from_its_foot_events() -> None:
    clip = SimpleNamespace(frame_time=0.1, duration=4.0,
                           events={"l": {"strike": [10, 30], "liftoff": [5, 25]},
                                   "r": {"strike": [20], "liftoff": [16, 35]}})
    c = Cadence.of_clip(clip)
    assert c.strikes_per_s == 3 / 4.0
    assert c.swing_s == pytest.approx(0.5)  # swings 0.5, 0.5, 0.4 s: median 0.5


# ---------------------------------------------------------------------- tuning runs
def _history(out: Path) -> list[dict[str, str]]:
    with open(out / "history.csv", newline="") as f:
        return list(csv.DictReader(f))


def _without_timing(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows]


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> tuple[Path, Path, dict]:
    folder = tmp_path_factory.mktemp("tiny")
    p = write_tune(folder, TINY)
    summary = run_tune(load_tune(p), folder / "a", progress=False)
    return p, folder / "a", summary


def test_a_tune_writes_its_outputs_and_improves_on_a_broken_start(tiny_run) -> None:
    p, out, summary = tiny_run
    assert {f.name for f in out.iterdir()} >= {"best.yaml", "history.csv", "convergence.png", "summary.json",
                                               "state.json"}
    rows = _history(out)
    assert [int(r["candidate"]) for r in rows] == list(range(6))  # the start + 5 candidates, in order
    assert [int(r["generation"]) for r in rows] == [0, 1, 1, 1, 2, 2]  # popsize 3; the last generation cut to 5
    assert summary["evaluated"] == 5 and summary["best"]["score"] <= summary["start"]["score"]
    best = min(rows, key=lambda r: float(r["score"]))
    assert summary["best"]["candidate"] == int(best["candidate"])
    assert summary["seed"] == 3 and "cma" in summary["versions"] and summary["config"]["parameters"]
    # best.yaml: a complete controller file bipedsim takes, holding the best candidate's values
    text = (out / "best.yaml").read_text()
    assert text.startswith("# Found by `bipedsim tune tune.yaml` (CMA-ES, pycma; seed 3)")
    cfg = load_controller(out / "best.yaml")
    assert cfg.balance.sagittal.cd == float(best["balance.sagittal.cd"])
    assert cfg.balance.coronal.cd == float(best["balance.coronal.cd"])
    assert cfg.balance.sagittal.cv == 0.0  # untuned values stay the start controller's
    for k in ("balance.sagittal.cd", "balance.coronal.cd"):
        assert all(0.0 <= float(r[k]) <= 1.5 for r in rows)


def test_best_yaml_runs(tiny_run, tmp_path: Path, capsys) -> None:
    _, out, _ = tiny_run
    assert main(["run", str(out / "best.yaml"), "--seconds", "1", "--out", str(tmp_path / "run")]) == 0
    assert "simulated" in capsys.readouterr().out


@pytest.mark.slow
def test_same_seed_same_result_and_a_finished_tune_reruns_nothing(tiny_run, tmp_path: Path, monkeypatch) -> None:
    p, first, _ = tiny_run
    summary = run_tune(load_tune(p), tmp_path / "b", progress=False)
    assert (tmp_path / "b" / "best.yaml").read_text() == (first / "best.yaml").read_text()
    assert _without_timing(_history(tmp_path / "b")) == _without_timing(_history(first))
    assert summary["best"] == run_tune(load_tune(p), first, progress=False)["best"]
    # a tune that has finished evaluates nothing when run again
    monkeypatch.setattr(tune_cmaes, "evaluate", lambda task: pytest.fail("evaluated again"))
    run_tune(load_tune(p), tmp_path / "b", progress=False)


def test_a_finished_tune_run_again_says_there_is_nothing_to_do_and_writes_nothing(tiny_run, tmp_path: Path,
                                                                                  monkeypatch, capsys) -> None:
    """It rewrote state.json (and the outputs) and printed the summary again; with evaluations below the
    candidates evaluated it wrote a summary whose budget was below what was evaluated."""
    import shutil

    p, first, _ = tiny_run
    shutil.copytree(first, tmp_path / "t")
    files = {f.name: (f.read_bytes(), f.stat().st_mtime_ns) for f in (tmp_path / "t").iterdir()}
    monkeypatch.setattr(tune_cmaes, "evaluate", lambda task: pytest.fail("evaluated again"))
    assert main(["tune", str(p), "--out", str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("tune already finished (5 candidates evaluated); nothing to do "
                                               "(raise evaluations in tune.yaml to continue)"), out
    fewer = write_tune(tmp_path, with_(TINY, evaluations=3), name="fewer.yaml")
    assert main(["tune", str(fewer), "--out", str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("tune already finished (5 candidates evaluated, more than "
                                               "evaluations: 3 in fewer.yaml); nothing to do"), out
    assert {f.name: (f.read_bytes(), f.stat().st_mtime_ns) for f in (tmp_path / "t").iterdir()} == files
    assert json.loads((tmp_path / "t" / "summary.json").read_text())["budget"] == 5


@pytest.mark.slow  # a second tune: the seed's effect (the same seed's sameness runs by default)
def test_another_seed_samples_other_candidates(tiny_run, tmp_path: Path) -> None:
    p, first, _ = tiny_run
    other = write_tune(tmp_path, with_(TINY, seed=4, evaluations=3))
    run_tune(load_tune(other), tmp_path / "c", progress=False)
    a, b = _history(first), _history(tmp_path / "c")
    assert a[1]["balance.sagittal.cd"] != b[1]["balance.sagittal.cd"]


def interrupt_after(tune_file: Path, out: Path, count: int, monkeypatch) -> list[int]:
    """Run the tune into ``out`` and stop it (as Ctrl-C does) when ``count`` candidates are scored;
    returns the candidates scored (the caller may go on appending to that list)."""
    real, scored = tune_cmaes.evaluate, []

    def stopping(task):
        if len(scored) == count:
            raise KeyboardInterrupt
        scored.append(task[0])
        return real(task)

    monkeypatch.setattr(tune_cmaes, "evaluate", stopping)
    with pytest.raises(KeyboardInterrupt):
        run_tune(load_tune(tune_file), out, progress=False)
    return scored


# inside the first generation; inside the second (with -m slow)
@pytest.mark.parametrize("stop_after", [1, pytest.param(4, marks=pytest.mark.slow)])
def test_interrupted_tune_resumes_without_scoring_any_candidate_twice(tiny_run, tmp_path: Path, monkeypatch,
                                                                       stop_after: int) -> None:
    p, first, _ = tiny_run
    real = tune_cmaes.evaluate
    scored = interrupt_after(p, tmp_path / "r", stop_after, monkeypatch)
    assert len(_history(tmp_path / "r")) == stop_after
    before = list(scored)

    def counting(task):
        scored.append(task[0])
        return real(task)

    monkeypatch.setattr(tune_cmaes, "evaluate", counting)
    run_tune(load_tune(p), tmp_path / "r", progress=False)
    assert sorted(scored) == list(range(6)) and scored[:len(before)] == before  # each candidate once
    assert (tmp_path / "r" / "best.yaml").read_text() == (first / "best.yaml").read_text()
    assert _without_timing(_history(tmp_path / "r")) == _without_timing(_history(first))


def test_cli_interrupt_says_how_to_resume(tmp_path: Path, monkeypatch, capsys) -> None:
    p = write_tune(tmp_path, with_(TINY, evaluations=2, popsize=2))

    def stop(task):
        raise KeyboardInterrupt

    monkeypatch.setattr(tune_cmaes, "evaluate", stop)
    assert main(["tune", str(p), "--out", str(tmp_path / "o")]) == 130
    assert "holds 0 of 3 candidates; run the same command again to resume" in capsys.readouterr().err


def test_a_torn_last_history_line_is_scored_again(tiny_run, tmp_path: Path) -> None:
    import shutil

    p, first, _ = tiny_run
    shutil.copytree(first, tmp_path / "t")
    text = (tmp_path / "t" / "history.csv").read_text()
    (tmp_path / "t" / "history.csv").write_text(text[:-25])  # the last row cut mid-line
    run_tune(load_tune(p), tmp_path / "t", progress=False)
    assert _without_timing(_history(tmp_path / "t")) == _without_timing(_history(first))


def test_a_changed_tune_file_does_not_resume_into_the_old_folder(tiny_run, tmp_path: Path) -> None:
    import shutil

    p, first, _ = tiny_run
    shutil.copytree(first, tmp_path / "t")
    changed = write_tune(tmp_path, with_(TINY, seed=9))
    with pytest.raises(BipedsimError, match="holds a tune of another configuration"):
        run_tune(load_tune(changed), tmp_path / "t", progress=False)
    more = write_tune(tmp_path, with_(TINY, evaluations=6), name="more.yaml")  # a larger budget continues
    summary = run_tune(load_tune(more), tmp_path / "t", progress=False)
    assert summary["evaluated"] == 6


@pytest.mark.slow  # two references' rollouts per candidate
def test_several_references_are_scored_together(tmp_path: Path) -> None:
    from bipedsim.data import BUILTIN_WALK
    from bipedsim.motion.bvh import load_bvh, write_bvh

    write_bvh(load_bvh(BUILTIN_WALK).resample(60.0), tmp_path / "walk60.bvh")
    p = write_tune(tmp_path, with_(TINY, reference=[str(BUILTIN_WALK), "walk60.bvh"], evaluations=2, popsize=2))
    tune = load_tune(p)
    assert tune.references == (str(BUILTIN_WALK), str(tmp_path / "walk60.bvh"))
    summary = run_tune(tune, tmp_path / "o", progress=False)
    assert summary["start"]["rollouts"] == 2  # one push per reference
    assert "walk60.bvh" in (tmp_path / "o" / "best.yaml").read_text().splitlines()[1]


@pytest.mark.slow  # a whole creature tune (the creature controller's settings are checked by load_tune's tests)
def test_a_creature_tune_tunes_its_controller_settings(tmp_path: Path) -> None:
    data = {"name": "horse", "reference": str(HORSE), "profile": "creature", "support": True,
            "parameters": {"support_kp": [5.0, 40.0], "support_kd": [0.5, 4.0]}, "evaluations": 2, "popsize": 2,
            "seed": 0, "experiment": {"seconds": 2.0, "after": 0.5,
                                      "grid": {"magnitude": [100], "direction": [90], "start": [1.0]}}}
    p = write_tune(tmp_path, data)
    with pytest.raises(ConfigError, match="parameters.support: .*not a number"):
        load_tune(write_tune(tmp_path, with_(data, parameters={"support": [0, 1]}), name="bad.yaml"))
    with pytest.raises(ConfigError, match="parameters.support_kp: .*only with root support"):
        load_tune(write_tune(tmp_path, with_(data, support=False), name="unsupported.yaml"))
    summary = run_tune(load_tune(p), tmp_path / "o", progress=False)
    assert summary["profile"] == "creature" and summary["evaluated"] == 2
    best = yaml.safe_load((tmp_path / "o" / "best.yaml").read_text())["creature"]
    assert best["support"] is True and 5.0 <= best["support_kp"] <= 40.0
    # best.yaml is a controller file: its creature: section is what `bipedsim run best.yaml --bvh` uses
    sc = load_scenario(tmp_path / "o" / "best.yaml", bvh=HORSE)
    assert sc.creature_cfg.support is True and sc.creature_cfg.support_kp == best["support_kp"]


def test_a_creature_tune_starts_from_a_controller_files_creature_section(tmp_path: Path) -> None:
    """A creature tune's ``controller:`` is a controller file; its ``creature:`` section is the start, and
    the planned gait's own settings (``balance.*``) are tunable keys."""
    ctl = tmp_path / "slow.yaml"
    ctl.write_text("creature:\n  balance: {speed_fraction: 0.5}\n")
    data = {"name": "horse", "reference": str(HORSE), "profile": "creature", "controller": str(ctl),
            "parameters": {"balance.step_height": [0.08, 0.16]}, "evaluations": 2, "popsize": 2, "seed": 0,
            "experiment": {"seconds": 2.0, "after": 0.5, "grid": {"magnitude": [0], "direction": [0],
                                                                   "start": [1.0]}}}
    tune = load_tune(write_tune(tmp_path, data))
    assert tune.start["balance"]["speed_fraction"] == 0.5 and tune.start["support"] is False


def test_ray_backend_without_ray_is_a_clear_error(tmp_path: Path, monkeypatch) -> None:
    p = write_tune(tmp_path, with_(TINY, evaluations=2, popsize=2))
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(BipedsimError, match=r"the Ray backend needs the ray package: pip install 'bipedsim\[ray\]'"):
        run_tune(load_tune(p), tmp_path / "o", backend="ray", progress=False)


@pytest.mark.xdist_group("ray")  # one local Ray instance at a time
@pytest.mark.slow
def test_two_workers_and_ray_give_the_same_result_as_one(tiny_run, tmp_path: Path) -> None:
    pytest.importorskip("ray")
    p, first, _ = tiny_run
    run_tune(load_tune(p), tmp_path / "w2", workers=2, progress=False)
    run_tune(load_tune(p), tmp_path / "ray", workers=2, backend="ray", progress=False)
    for d in ("w2", "ray"):
        assert (tmp_path / d / "best.yaml").read_text() == (first / "best.yaml").read_text()
        assert _without_timing(_history(tmp_path / d)) == _without_timing(_history(first))


def test_the_shipped_tune_files_load_from_any_folder(monkeypatch, tmp_path: Path) -> None:
    from conftest import HAVE_SHARED, SHARED_BVH

    monkeypatch.chdir(tmp_path)  # paths in a tune file are relative to the file, not the working folder
    broken = load_tune(REPO / "experiments" / "tune_broken_start.yaml")
    assert broken.controller_path == str(BROKEN) and broken.references == (None,)
    assert broken.start_values() == dict.fromkeys(broken.keys, 0.0)
    assert len(broken.experiment().rows()) == 8 and broken.spec.evaluations == 96
    cmu_path = REPO / "experiments" / "tune_cmu_walk.yaml"
    if not HAVE_SHARED:  # its clip read from the generated stand-in; the controller still relative to the file
        (tmp_path / "controllers").symlink_to(REPO / "controllers")
        (tmp_path / "experiments").mkdir()
        text = cmu_path.read_text().replace("../../shared/data/bvh", str(SHARED_BVH))
        cmu_path = tmp_path / "experiments" / cmu_path.name
        cmu_path.write_text(text)
    cmu = load_tune(cmu_path)
    assert Path(cmu.references[0]).name == "cmu_02_01_walk__holden31_crlf.bvh"
    assert cmu.start_values()["balance.sagittal.cd"] == 0.5  # controllers/cmu_walk.yaml's own value


def test_the_docs_table_states_the_default_weights() -> None:
    import dataclasses
    import re

    text = (REPO / "docs" / "tuning.md").read_text()
    rows = dict(re.findall(r"^\| `(\w+)` \| ([0-9.]+) \|", text, re.MULTILINE))
    assert set(rows) == set(TERMS)
    defaults = {f.name: f.default for f in dataclasses.fields(Objective)}
    assert {k: float(v) for k, v in rows.items()} == {k: defaults[k] for k in TERMS}


@pytest.mark.slow  # a tune run twice, once in a new process; resuming in-process is checked in the default
# run (test_interrupted_tune_resumes_without_scoring_any_candidate_twice)
def test_a_tune_resumed_in_a_new_process_ends_as_an_uninterrupted_one(tmp_path: Path, monkeypatch) -> None:
    """Stopped inside its first generation and resumed by another process, which tells that generation
    and asks the next ones: the same history and best.yaml as a tune run in one go (pycma's lookup of
    told solutions hashes them, and the hash differs between processes)."""
    import subprocess

    p = write_tune(tmp_path, with_(TINY, evaluations=7))
    run_tune(load_tune(p), tmp_path / "whole", progress=False)
    interrupt_after(p, tmp_path / "resumed", 2, monkeypatch)
    proc = subprocess.run([sys.executable, "-m", "bipedsim.cli", "tune", str(p), "--out", str(tmp_path / "resumed")],
                          capture_output=True, text=True, timeout=600, check=False,
                          env={**__import__("os").environ, "PYTHONHASHSEED": "12345"})
    assert proc.returncode == 0, proc.stderr
    assert _without_timing(_history(tmp_path / "resumed")) == _without_timing(_history(tmp_path / "whole"))
    assert (tmp_path / "resumed" / "best.yaml").read_text() == (tmp_path / "whole" / "best.yaml").read_text()


def test_each_candidate_is_scored_on_the_reference_its_own_settings_prepare() -> None:
    """The tune's per-process scenario cache is keyed on the ``reference:`` block: a candidate whose
    settings force the feasible reference gets that clip, not the one built for the default settings."""
    import dataclasses

    from bipedsim.control.settings import ControllerConfig
    from bipedsim.experiments.tune import evaluate

    default = ControllerConfig()
    forced = dataclasses.replace(default, reference=dataclasses.replace(default.reference, feasible=True))
    as_is = evaluate._scenario(None, "humanoid", False, default)
    rebuilt = evaluate._scenario(None, "humanoid", False, forced)
    assert evaluate._scenario(None, "humanoid", False, default) is as_is  # built once
    assert "feasible" not in as_is.extra and rebuilt.extra["feasible"] == ["reference: {feasible: true}"]
    assert as_is.clip.qpos.shape == rebuilt.clip.qpos.shape
    assert np.abs(as_is.clip.qpos - rebuilt.clip.qpos).max() > 1e-3  # the legs were re-solved
