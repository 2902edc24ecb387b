"""Pushes, fall and divergence detection, recovery metrics, sweeps (resume, determinism, Ray) and
regression suites."""

from __future__ import annotations

import csv
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bipedsim.cli import main
from bipedsim.errors import ConfigError
from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import RESULT_COLUMNS, TIMING_COLUMNS, run_sweep
from bipedsim.sim.push import Push, random_pushes
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

REPO = Path(__file__).resolve().parents[2]
EXP = REPO / "experiments"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario()


def test_push_parse_and_errors() -> None:
    p = Push.parse("200:90:0.2:2.5")
    assert (p.magnitude, p.direction, p.duration, p.start) == (200.0, 90.0, 0.2, 2.5) and p.impulse == 40.0
    q = Push.parse("150:0:0.1:s3.25")
    assert q.state == 3 and q.fraction == 0.25 and q.start is None
    for bad, msg in (("200:90:0.2", "expected MAG:DIR:DUR:START"), ("a:90:0.2:1", "must be numbers"),
                     ("200:90:-0.2:1", "duration"), ("200:90:0.2:s7.5", "FSM states are 1-4")):
        with pytest.raises(ConfigError, match=msg):
            Push.parse(bad)
    assert main(["run", "--seconds", "0.1", "--push", "1:2:3"]) == 2


def test_push_is_applied_then_cleared(scenario) -> None:
    seen = []

    def watch(t, data, ctrl) -> None:
        seen.append((t, float(np.linalg.norm(data.xfrc_applied[scenario.built.model.body("torso").id, :3])),
                     ctrl.force_active))

    push = Push(magnitude=150.0, direction=90.0, duration=0.2, start=1.0)
    run_scenario(scenario, RolloutSpec(seconds=1.6), pushes=[push], hooks=[watch])
    on = [(t, f) for t, f, _ in seen if f > 0]
    tol = (scenario.cfg.control_dt or 0.0) + 0.003  # hooks see the state on control steps
    assert on and min(t for t, _ in on) == pytest.approx(1.0, abs=tol)
    assert max(t for t, _ in on) == pytest.approx(1.2, abs=tol) and all(f == pytest.approx(150.0) for _, f in on)
    assert all(a == (f > 0) for _, f, a in seen)  # the controller is told while it acts
    assert seen[-1][1] == 0.0


def test_push_direction_is_relative_to_heading(scenario) -> None:
    forces = []

    def watch(t, data, ctrl) -> None:
        f = data.xfrc_applied[scenario.built.model.body("torso").id, :3].copy()
        if f.any():
            r = data.xmat[1].reshape(3, 3)
            forces.append((f, np.arctan2(r[1, 0], r[0, 0])))

    run_scenario(scenario, RolloutSpec(seconds=1.3), pushes=[Push(magnitude=100, direction=90, duration=0.1,
                                                                  start=1.0)], hooks=[watch])
    f, heading = forces[0]
    assert np.degrees(np.arctan2(f[1], f[0]) - heading) == pytest.approx(90.0, abs=1.0)


def test_big_push_falls_within_2s_and_metrics(scenario) -> None:
    push = Push(magnitude=2000.0, direction=0.0, duration=0.2, start=2.5)
    out, _ = run_scenario(scenario, RolloutSpec(seconds=6.0), pushes=[push])
    assert out.outcome == "fall" and 2.5 < out.fall_time_s <= 4.5
    devs = []
    for mag in (0.0, 20.0, 60.0):
        small = Push(magnitude=mag, direction=90.0, duration=0.2, state=2, fraction=0.5)
        out, _ = run_scenario(scenario, RolloutSpec(seconds=6.0), pushes=[small])
        e = out.extra
        assert out.outcome == "no_fall" and e["push_start_s"] >= 2.0
        assert e["recovery_time_s"] is not None and e["recovery_time_s"] < 2.0 and e["steps_to_recover"] is not None
        devs.append(e["peak_com_deviation_m"])
    # measured against the same rollout without the push: zero for no push, growing with the push
    assert devs[0] == 0.0 and 0.0 < devs[1] < devs[2] < 1.5


def test_fall_criteria_and_divergence_checks(scenario) -> None:
    """Each fall criterion on hand-made states, and NaN/instability as divergence, never a fall."""
    import mujoco

    from bipedsim.sim.rollout import FallCriteria, FallDetector, diverged

    m = scenario.built.model
    d = mujoco.MjData(m)
    d.qpos[:] = scenario.clip.qpos[0]
    mujoco.mj_forward(m, d)
    det = FallDetector(m, scenario.built.plan, FallCriteria(), d)
    assert det.check(d) is None and diverged(d) is None
    # lying on its back, just touching the floor: the torso (not a foot) is in contact
    d.qpos[3:7] = [np.cos(np.pi / 4), 0.0, -np.sin(np.pi / 4), 0.0]  # pitched 90 degrees back
    d.qpos[2] = 0.12
    mujoco.mj_forward(m, d)
    assert d.ncon > 0
    why = det.check(d)
    assert why is not None and why.endswith("touched the ground") and "foot" not in why
    # without the contact criterion the pelvis height and the torso tilt still catch it
    only_height = FallDetector(m, scenario.built.plan, FallCriteria(non_foot_contact=False, torso_tilt=3.1), d)
    only_height.min_height = 0.5
    assert "pelvis below" in only_height.check(d)
    only_tilt = FallDetector(m, scenario.built.plan, FallCriteria(non_foot_contact=False,
                                                                   pelvis_height_fraction=0.0), d)
    assert "tilted" in only_tilt.check(d)
    d.qvel[4] = np.nan
    assert "non-finite" in diverged(d)
    d.qvel[4] = 0.0
    d.warning[int(mujoco.mjtWarning.mjWARN_BADQACC)].number = 1
    assert "BADQACC" in diverged(d)


def test_random_pushes_are_seeded() -> None:
    assert random_pushes(4, 3) == random_pushes(4, 3)
    assert random_pushes(4, 3) != random_pushes(5, 3)


def test_absurd_gains_diverge_not_fall(tmp_path: Path, monkeypatch, capfd) -> None:
    """Diverged, never a fall; MuJoCo's own warning text goes into the reason instead of being printed
    and appended to a MUJOCO_LOG.TXT in the working directory, and MuJoCo's handler is put back."""
    import mujoco

    monkeypatch.chdir(tmp_path)
    sc = load_scenario(EXP / "controllers" / "absurd_gains.yaml")
    out, _ = run_scenario(sc, RolloutSpec(seconds=1.0))
    assert out.outcome == "diverged" and "instability" in out.fall_reason
    assert "The simulation is unstable" in out.fall_reason
    assert "unstable" not in capfd.readouterr().out and not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert mujoco.get_mju_user_warning() is None


def rows_of(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def without_timing(path: Path) -> list[list[str]]:
    rows = rows_of(path)
    return [[r[c] for c in RESULT_COLUMNS if c not in TIMING_COLUMNS] for r in rows]


def test_sweep_goes_on_after_divergence_and_summarises(tmp_path: Path) -> None:
    exp = load_experiment(EXP / "smoke.yaml")
    summary = run_sweep(exp, tmp_path, workers=2, progress=False)
    rows = rows_of(tmp_path / "results.csv")
    assert len(rows) == 4 and [int(r["index"]) for r in rows] == [0, 1, 2, 3]
    by = {(Path(r["controller"]).stem, float(r["magnitude"])): r["outcome"] for r in rows}
    assert by[("absurd_gains", 150.0)] == "diverged" and by[("absurd_gains", 2000.0)] == "diverged"
    assert by[("default", 150.0)] in ("no_fall", "fall") and by[("default", 2000.0)] == "fall"
    assert summary["outcomes"]["diverged"] == 2
    # per direction: how many of its rollouts survived, out of how many
    counts = summary["survived_per_direction"]
    assert sum(c["rollouts"] for c in counts.values()) == 4
    assert sum(c["survived"] for c in counts.values()) == sum(r["outcome"] == "no_fall" for r in rows)
    assert (tmp_path / "push_polar.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow  # 32 rollouts of 5 s: the grid's own check (benchmarks/sweep.py prints it too)
def test_default_walk_recovers_from_every_200n_push(tmp_path: Path) -> None:
    """The issue's check, experiments/push_200n.yaml: 200 N x 0.2 s on the torso at 8 directions x 4
    gait states (mid-state), every one survived on the default walk and controller."""
    exp = load_experiment(EXP / "push_200n.yaml")
    summary = run_sweep(exp, tmp_path, workers=2, progress=False)
    rows = rows_of(tmp_path / "results.csv")
    assert len(rows) == 32
    fell = [(r["direction"], r["state"], r["outcome"]) for r in rows if r["outcome"] != "no_fall"]
    assert not fell
    assert summary["largest_survived_per_direction_n"] == {str(d): 200.0 for d in range(0, 360, 45)}


@pytest.mark.slow  # a random-push sweep; the other sweep tests cover the sweep in the default run
def test_random_push_experiment(tmp_path: Path) -> None:
    """random: one push per rollout, magnitude / direction / start uniform in the given ranges, drawn
    from the seed (the same pushes for every controller); summary.json bins directions into sectors."""
    spec = tmp_path / "rand.yaml"
    ctl = [REPO / "controllers" / "default.yaml", EXP / "controllers" / "absurd_gains.yaml"]
    text = ("name: rand\nseconds: 2.2\nseed: {seed}\nrandom:\n  count: 6\n  magnitude: [50, 150]\n"
            f"  direction: [-90, 90]\n  window: [1.0, 2.0]\n  controller: [{ctl[0]}, {ctl[1]}]\n")
    spec.write_text(text.format(seed=3))
    rows = load_experiment(spec).rows()
    assert len(rows) == 12
    pushes = [r.push for r in rows]
    assert all(50 <= p.magnitude <= 150 and (p.direction >= 270 or p.direction <= 90) and 1.0 <= p.start <= 2.0
               and p.state is None for p in pushes)
    # the same six pushes under each controller
    assert [p for r, p in zip(rows, pushes) if r.controller == str(ctl[0])] == \
        [p for r, p in zip(rows, pushes) if r.controller == str(ctl[1])]
    assert [r.push for r in load_experiment(spec).rows()] == pushes
    spec.write_text(text.format(seed=4))
    assert [r.push for r in load_experiment(spec).rows()] != pushes
    spec.write_text(text.format(seed=3))
    summary = run_sweep(load_experiment(spec), tmp_path / "out", workers=2, progress=False)
    assert summary["direction_sector_deg"] == 45.0
    sectors = summary["survived_per_direction"]
    assert set(sectors) <= {"0", "45", "90", "270", "315"}
    assert sum(c["rollouts"] for c in sectors.values()) == 12
    assert summary["outcomes"]["diverged"] == 6
    assert {g["phase"] for g in summary["by_direction_and_phase"]} == {"random start"}


@pytest.mark.slow  # starts a local Ray instance (about 8 s); the 2-worker local sweep runs in the default
# run (test_killed_sweep_resumes_without_loss_or_repeats and others)
@pytest.mark.xdist_group("ray")  # one local Ray instance at a time
def test_same_seed_same_results_any_workers_and_ray(tmp_path: Path) -> None:
    exp = load_experiment(EXP / "smoke.yaml")
    run_sweep(exp, tmp_path / "a", workers=1, progress=False)
    run_sweep(exp, tmp_path / "b", workers=2, progress=False)
    assert without_timing(tmp_path / "a" / "results.csv") == without_timing(tmp_path / "b" / "results.csv")
    pytest.importorskip("ray", reason="the Ray backend needs ray (pip install 'bipedsim[ray]')")
    run_sweep(exp, tmp_path / "c", workers=2, backend="ray", progress=False)
    assert without_timing(tmp_path / "a" / "results.csv") == without_timing(tmp_path / "c" / "results.csv")


def test_terminated_sweep_stops_cleanly_and_says_how_to_resume(tmp_path: Path) -> None:
    """SIGTERM (kill, a scheduler) on a 2-worker sweep: exit 130, a one-line message naming the rows
    kept, no worker tracebacks; the same command then finishes the rest."""
    spec = tmp_path / "term.yaml"
    spec.write_text("name: term\nseconds: 2.5\nafter: 1.0\ngrid:\n  magnitude: [50, 100]\n"
                    "  direction: [0, 90, 180]\n  phase: [[2, 0.5]]\n")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "bipedsim.cli", "sweep", str(spec), "--out", str(out), "--workers", "2"]
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    results = out / "results.csv"
    deadline = time.time() + 300
    while time.time() < deadline and not (results.exists() and len(rows_of(results)) >= 2):
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    kept = len(rows_of(results))
    assert kept < 6 and "Traceback" not in err
    assert f"holds {kept} of 6 rollouts" in err and "run the same command again" in err
    assert main(["sweep", str(spec), "--out", str(out), "--workers", "2"]) == 0
    rows = rows_of(results)
    assert sorted(int(r["index"]) for r in rows) == list(range(6))


@pytest.mark.slow  # a sweep killed and resumed; the terminated sweep's resume runs in the default run
def test_killed_sweep_resumes_without_loss_or_repeats(tmp_path: Path) -> None:
    spec = tmp_path / "resume.yaml"
    spec.write_text("name: resume\nseconds: 2.5\nafter: 1.0\ngrid:\n  magnitude: [50, 100, 150]\n"
                    "  direction: [0, 90, 180, 270]\n  phase: [[2, 0.5]]\n")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "bipedsim.cli", "sweep", str(spec), "--out", str(out), "--workers", "1"]
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    results = out / "results.csv"
    deadline = time.time() + 300
    while time.time() < deadline:
        if results.exists() and len(rows_of(results)) >= 3:
            break
        time.sleep(0.05)
    p.send_signal(signal.SIGKILL)
    p.wait()
    partial = len(rows_of(results))
    assert 3 <= partial < 12
    assert subprocess.run(cmd, capture_output=True, check=False).returncode == 0
    rows = rows_of(results)
    keys = [r["key"] for r in rows]
    assert len(rows) == 12 and len(set(keys)) == 12
    assert sorted(int(r["index"]) for r in rows) == list(range(12))


@pytest.mark.parametrize("text,key,msg", [
    ("name: x\ngrid: {magnitude: [100], phase: [[2, 0.5]], colour: red}\n", "grid.colour", "unknown key"),
    ("name: x\ngrid: {magnitude: [100], duration: [-0.2], phase: [[2, 0.5]]}\n", "grid", "duration"),
    ("name: x\nbody: tail\ngrid: {magnitude: [100], phase: [[2, 0.5]]}\n", "body", "unknown body 'tail'"),
    ("name: x\ngrid: {magnitude: [], phase: [[2, 0.5]]}\n", "grid", "empty list"),
    ("name: x\n", "", "no rollouts"),
    ("name: x\ngrid: {magnitude: [100], start: [1.0], controller: [nope.yaml]}\n", "grid.controller", "no such"),
    ("name: x\nrandom: {count: 4, magnitude: [300, 100]}\n", "random.magnitude", "reversed"),
    ("name: x\nrandom: {count: 0}\n", "random.count", "must be >= 1"),
    ("name: x\nrandom: {count: 4, window: [-1, 2]}\n", "random.window", "must be >= 0 s"),
    ("name: x\nrandom: {count: 4, controller: [nope.yaml]}\n", "random.controller", "no such"),
    ("name: x\nrandom: {count: 4}\ngrid: {magnitude: [100], start: [1.0]}\n", "random", "not grid and random"),
])
def test_bad_experiment_files_fail_before_running(tmp_path: Path, text: str, key: str, msg: str) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_experiment(p)
    assert str(p) in str(exc.value) and key in str(exc.value) and msg in str(exc.value)
    assert main(["sweep", str(p), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o" / "results.csv").exists()


@pytest.mark.slow  # 13 scenarios, the grounds' 10 s each (the suite mechanism: test_regress_mismatch_and_update)
def test_project_regression_suite() -> None:
    assert main(["regress", str(EXP / "regression.yaml")]) == 0


def test_regress_mismatch_and_update(tmp_path: Path) -> None:
    suite = tmp_path / "s.yaml"
    suite.write_text("name: t\nscenarios:\n  - name: big\n    seconds: 4\n"
                     "    pushes: [{magnitude: 2000, direction: 180, duration: 0.2, start: 2.0}]\n"
                     "    expect: no_fall   # wrong on purpose\n")
    assert main(["regress", str(suite)]) == 1
    assert main(["regress", str(suite), "--update"]) == 0
    # the comment is kept, in its column (ruamel.yaml's round trip)
    assert "expect: fall      # wrong on purpose" in suite.read_text()
    assert main(["regress", str(suite)]) == 0
