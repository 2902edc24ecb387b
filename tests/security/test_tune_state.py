"""A tune's and a sweep's saved state read back safely: ``state.json`` is JSON of numbers, checked before
use, and never a pickle (a crafted ``state.pkl`` is refused unopened: its code never runs); a garbled or
foreign state is one line and exit 2; a resumed tune equals an uninterrupted one exactly; the state
grows with the candidates evaluated, not the population; population and budget are bounded; a Ray
backend that is not installed is refused before any file is written. Candidates here are scored by a
stand-in for the rollouts (a quadratic in the tuned values), so each tune takes a fraction of a second."""

from __future__ import annotations

import copy
import csv
import json
import os
import pickle
import sys
from pathlib import Path

import pytest
import yaml

from bipedsim.cli import main
from bipedsim.config import from_dict
from bipedsim.errors import ConfigError
from bipedsim.experiments import sweep
from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import RESULT_COLUMNS, run_sweep
from bipedsim.experiments.tune import cmaes as tune_cmaes
from bipedsim.experiments.tune import load_tune, run_tune
from bipedsim.experiments.tune.objective import TERMS
from bipedsim.experiments.tune.spec import MAX_POPSIZE, MAX_STATE_VALUES, TuneSpec

REPO = Path(__file__).resolve().parents[2]
BROKEN = REPO / "experiments" / "controllers" / "no_balance_feedback.yaml"
KEYS = ("balance.sagittal.cd", "balance.coronal.cd")
TUNE = {"name": "stand-in", "controller": str(BROKEN), "parameters": {k: [0.0, 1.5] for k in KEYS},
        "evaluations": 10, "popsize": 3, "seed": 3,
        "experiment": {"seconds": 2.5, "after": 1.0,
                       "grid": {"magnitude": [150], "direction": [90], "duration": [0.2], "start": [1.2]}}}
#: the one line every refused state file gets (with the file's path before it)
NOT_A_STATE = "not a state file of this version of bipedsim tune"


def write_tune(folder: Path, name: str = "tune.yaml", **changes: object) -> Path:
    p = folder / name
    p.write_text(yaml.safe_dump({**TUNE, **changes}, sort_keys=False))
    return p


def stand_in(task: tuple) -> dict:
    """A candidate's row without rollouts: its score a quadratic in the tuned values (minimum inside
    the ranges), every term 0."""
    number, settings, _ = task
    b = settings["balance"]
    score = (b["sagittal"]["cd"] - 0.9) ** 2 + (b["coronal"]["cd"] - 0.4) ** 2
    return {"candidate": number, "score": score, **dict.fromkeys(TERMS, 0.0), "survived": 1, "rollouts": 1,
            "walk_s": 2.5, "wall_seconds": 0.0}


@pytest.fixture
def quick(monkeypatch):
    """Candidates scored by :func:`stand_in`, no convergence plot; returns the list of candidates scored."""
    scored: list[int] = []

    def scoring(task: tuple) -> dict:
        scored.append(task[0])
        return stand_in(task)

    monkeypatch.setattr(tune_cmaes, "evaluate", scoring)
    monkeypatch.setattr(tune_cmaes, "convergence_plot", lambda *a, **k: None)
    return scored


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    return err[0]


def snapshot(folder: Path) -> dict[str, bytes]:
    return {f.name: f.read_bytes() for f in folder.iterdir()} if folder.exists() else {}


# ---------------------------------------------------------------------- never a pickle
class _Payload:
    """Unpickled, it creates the file ``marker`` (as a crafted pickle could run any command)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


def test_the_payload_runs_code_when_unpickled(tmp_path: Path) -> None:
    """The crafted file below is live: unpickling it creates its marker (so the refusals can fail)."""
    marker = tmp_path / "ran"
    pickle.loads(pickle.dumps(_Payload(marker))).close()
    assert marker.exists()


@pytest.mark.parametrize("name", ["state.pkl", "state.json"])
def test_a_crafted_pickle_is_refused_and_never_runs(tmp_path: Path, quick, capsys, name: str) -> None:
    marker = tmp_path / "ran"
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_bytes(pickle.dumps(_Payload(marker)))
    (out / "history.csv").write_text("candidate,generation\n")
    before = snapshot(out)
    assert main(["tune", str(write_tune(tmp_path)), "--out", str(out)]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"bipedsim tune: error: {out / name}: ")
    if name == "state.pkl":
        assert "a Python pickle, which this version never opens" in line
    assert not marker.exists()
    assert quick == [] and snapshot(out) == before


def test_an_old_state_pkl_is_refused_even_beside_a_good_state(tmp_path: Path, quick, capsys) -> None:
    p = write_tune(tmp_path, evaluations=3)
    run_tune(load_tune(p), tmp_path / "out", progress=False)
    (tmp_path / "out" / "state.pkl").write_bytes(pickle.dumps({"version": 2}))
    assert main(["tune", str(p), "--out", str(tmp_path / "out")]) == 2
    assert "state.pkl: a tune state of an earlier bipedsim" in one_error_line(capsys)


# ---------------------------------------------------------------------- garbled or foreign state files
@pytest.fixture
def finished(tmp_path: Path, quick) -> tuple[Path, Path, dict]:
    """A finished stand-in tune: (tune file, its folder, its state.json)."""
    p = write_tune(tmp_path)
    run_tune(load_tune(p), tmp_path / "done", progress=False)
    return p, tmp_path / "done", json.loads((tmp_path / "done" / "state.json").read_text())


def _text(text: str):
    return lambda state: text


def _edit(change):
    """The finished tune's state with ``change`` made to a copy of it, as JSON text."""
    def make(state: dict) -> str:
        s = copy.deepcopy(state)
        change(s)
        return json.dumps(s)
    return make


def _set(path: tuple, value: object):
    def change(s: dict) -> None:
        for k in path[:-1]:
            s = s[k]
        s[path[-1]] = value
    return _edit(change)


#: case -> (the state file's text made from a good state, what the refusal says)
GARBLED = {
    "empty": (_text(""), "not JSON"),
    "torn": (lambda s: json.dumps(s)[:-40], "not JSON"),
    "deep": (_text("[" * 200_000), "not JSON"),
    "a list": (_text("[1, 2, 3]"), 'no "format"'),
    "foreign JSON": (_text('{"name": "something else"}'), 'no "format"'),
    "older version": (_set(("version",), 2), "format version 2; this bipedsim reads version 3"),
    "extra key": (_set(("code",), "__import__('os')"), "unknown key 'code'"),
    "missing key": (_edit(lambda s: s.pop("generations")), "missing key 'generations'"),
    "x0 too short": (_set(("strategy", "x0"), [0.1]), "strategy.x0: expected a list of 2 numbers in [0, 1]"),
    "x outside the box": (_set(("generations", 0, "candidates", 1, 0), 1.5),
                          "generations[0].candidates[1][0]: expected a finite number in [0, 1], got 1.5"),
    "infinite x": (lambda s: json.dumps(s).replace(repr(s["generations"][0]["candidates"][0][0]), "1e400", 1),
                   "generations[0].candidates[0][0]: expected a finite number in [0, 1], got inf"),
    "NaN score": (_set(("generations", 1, "scores", 0), float("nan")),
                  "generations[1].scores[0]: expected a finite number, got nan"),
    "huge integer": (_set(("generations", 1, "scores", 0), 10**400), "generations[1].scores[0]: expected a finite"),
    "popsize a boolean": (_set(("strategy", "popsize"), True), "strategy.popsize: expected an integer"),
    "popsize huge": (_set(("strategy", "popsize"), 10**9),
                     f"strategy.popsize: expected an integer in [1, {MAX_POPSIZE}]"),
    "more candidates than popsize": (_edit(lambda s: s["generations"][0]["candidates"].append([0.5, 0.5])),
                                     "generations[0].candidates: expected a list of 1 to 3 (popsize) candidates"),
    "a score short": (_edit(lambda s: s["generations"][0]["scores"].pop()),
                      "generations[0].scores: expected a list of 3 scores"),
    "fingerprint a number": (_set(("fingerprint",), 7), "fingerprint: expected a string, got a JSON number"),
    "a generation a string": (_set(("generations", 0), "x"),
                              "generations[0]: expected an object, got a JSON string"),
}


@pytest.mark.parametrize("case", list(GARBLED))
def test_a_garbled_state_is_refused_with_one_line(finished, capsys, case: str) -> None:
    p, out, state = finished
    make, expected = GARBLED[case]
    (out / "state.json").write_text(make(state))
    before = snapshot(out)
    assert main(["tune", str(p), "--out", str(out)]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"bipedsim tune: error: {out / 'state.json'}: {NOT_A_STATE} (")
    assert expected in line
    assert line.endswith("give another --out, or remove state.json and history.csv to start again")
    assert snapshot(out) == before  # nothing rewritten


def test_a_state_that_is_not_text_or_not_a_file_is_refused(finished, capsys) -> None:
    p, out, _ = finished
    (out / "state.json").write_bytes(b"\x80\x04\x95 binary")
    assert main(["tune", str(p), "--out", str(out)]) == 2
    assert "state.json: line 1: not UTF-8 text" in one_error_line(capsys)
    (out / "state.json").unlink()
    os.mkfifo(out / "state.json")  # opening a FIFO to read it would wait forever
    assert main(["tune", str(p), "--out", str(out)]) == 2
    assert "state.json: is a pipe, not a JSON file" in one_error_line(capsys)


def test_another_tunes_state_is_refused(finished, tmp_path: Path, capsys) -> None:
    p, out, state = finished
    other = write_tune(tmp_path, "other.yaml", seed=4)
    assert main(["tune", str(other), "--out", str(out)]) == 2
    assert "holds a tune of another configuration" in one_error_line(capsys)
    # the fingerprint copied in, the start moved: the strategy CMA-ES would be built with differs
    state["strategy"]["x0"] = [0.5, 0.5]
    (out / "state.json").write_text(json.dumps(state))
    assert main(["tune", str(p), "--out", str(out)]) == 2
    assert "holds a tune of another configuration" in one_error_line(capsys)


def test_a_state_whose_candidates_cma_es_would_not_ask_is_refused(finished, capsys) -> None:
    """Well formed, but a candidate edited: the replay asks another one, so the tune cannot resume exactly."""
    p, out, state = finished
    state["generations"][1]["candidates"][0][1] = 0.5
    (out / "state.json").write_text(json.dumps(state))
    assert main(["tune", str(p), "--out", str(out)]) == 2
    assert ("state.json: generation 2: CMA-ES asks other candidates than the state records"
            in one_error_line(capsys))


# ---------------------------------------------------------------------- resuming exactly; the state's size
@pytest.mark.parametrize("stop_after", [4, 7, 9])  # after generation 1; after generation 2; inside generation 3
def test_a_tune_stopped_and_resumed_equals_one_run_straight(tmp_path: Path, quick, monkeypatch,
                                                            stop_after: int) -> None:
    p = write_tune(tmp_path)
    run_tune(load_tune(p), tmp_path / "straight", progress=False)

    def stopping(task: tuple) -> dict:
        if len(quick) == stop_after:
            raise KeyboardInterrupt
        quick.append(task[0])
        return stand_in(task)

    quick.clear()
    monkeypatch.setattr(tune_cmaes, "evaluate", stopping)
    with pytest.raises(KeyboardInterrupt):
        run_tune(load_tune(p), tmp_path / "resumed", progress=False)
    saved = json.loads((tmp_path / "resumed" / "state.json").read_text())
    assert sum(len(g["candidates"]) for g in saved["generations"]) == 3 * ((stop_after - 1) // 3)
    monkeypatch.setattr(tune_cmaes, "evaluate", stand_in)
    run_tune(load_tune(p), tmp_path / "resumed", progress=False)
    for name in ("state.json", "history.csv", "best.yaml", "summary.json"):
        assert (tmp_path / "resumed" / name).read_text().replace("resumed", "straight") == \
            (tmp_path / "straight" / name).read_text(), name


def test_the_state_grows_with_the_candidates_evaluated_not_the_population(tmp_path: Path, quick) -> None:
    sizes = {}
    for popsize in (2, 40):
        p = write_tune(tmp_path, f"p{popsize}.yaml", evaluations=40, popsize=popsize)
        run_tune(load_tune(p), tmp_path / f"p{popsize}", progress=False)
        state = json.loads((tmp_path / f"p{popsize}" / "state.json").read_text())
        evaluated = sum(len(g["candidates"]) for g in state["generations"])
        assert evaluated == 40
        sizes[popsize] = (tmp_path / f"p{popsize}" / "state.json").stat().st_size
    # about 60 bytes a candidate (two values and a score) and 40 a generation, whatever the population
    assert all(s < 500 + 120 * 40 for s in sizes.values()), sizes
    assert max(sizes.values()) < 1.5 * min(sizes.values()), sizes


# ---------------------------------------------------------------------- population and budget bounded
@pytest.mark.parametrize("changes, key, text", [
    ({"popsize": 1_000_000}, "popsize", f"must be <= {MAX_POPSIZE}, got 1000000"),
    ({"popsize": "1e6"}, "popsize", "expected an integer"),
    ({"popsize": 11}, "popsize", "11 candidates per generation is more than the whole budget (evaluations: 10)"),
    ({"evaluations": 10**9}, "evaluations", "must be <= 100000"),
])
def test_population_and_budget_are_bounded(tmp_path: Path, quick, capsys, changes: dict, key: str,
                                           text: str) -> None:
    p = write_tune(tmp_path, **changes)
    assert main(["tune", str(p), "--out", str(tmp_path / "out")]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"bipedsim tune: error: {p}: {key}: ") and text in line
    assert not (tmp_path / "out").exists() and quick == []


def test_the_values_a_tune_records_are_bounded() -> None:
    many = {f"k{i}": [0.0, 1.0] for i in range(21)}
    with pytest.raises(ConfigError, match=r"evaluations: 100000 candidates x 21 parameters is 2,100,000 values to "
                                          rf"record, above the {MAX_STATE_VALUES:,} a tune holds"):
        from_dict(TuneSpec, {**TUNE, "parameters": many, "evaluations": 100_000, "popsize": None})


def test_a_huge_population_is_refused_within_a_memory_limit(tmp_path: Path) -> None:
    """In a process limited to 1 GiB of address space: one line and exit 2 (the run wrote 164 MB of state
    for 8 candidates before popsize was bounded)."""
    import subprocess

    p = write_tune(tmp_path, popsize=1_000_000)
    proc = subprocess.run(["bash", "-c", f'ulimit -v 1048576; exec "{sys.executable}" -m bipedsim.cli tune "{p}" '
                           f'--out "{tmp_path / "out"}"'], capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == [f"bipedsim tune: error: {p}: popsize: must be <= {MAX_POPSIZE}, "
                                                "got 1000000"]


# ---------------------------------------------------------------------- a Ray backend that is not installed
RAY_LINE = "error: --backend: the Ray backend needs the ray package: pip install 'bipedsim[ray]'"


def test_tune_on_ray_without_ray_writes_nothing(tmp_path: Path, quick, monkeypatch, capsys) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # as if it were not installed
    p = write_tune(tmp_path)
    assert main(["tune", str(p), "--out", str(tmp_path / "new"), "--backend", "ray"]) == 2
    assert one_error_line(capsys) == f"bipedsim tune: {RAY_LINE}"
    assert not (tmp_path / "new").exists()
    # a folder to resume keeps every file as it was
    monkeypatch.undo()
    monkeypatch.setattr(tune_cmaes, "evaluate", stand_in)
    monkeypatch.setattr(tune_cmaes, "convergence_plot", lambda *a, **k: None)
    run_tune(load_tune(write_tune(tmp_path, evaluations=3)), tmp_path / "old", progress=False)
    before = snapshot(tmp_path / "old")
    monkeypatch.setitem(sys.modules, "ray", None)
    assert main(["tune", str(p), "--out", str(tmp_path / "old"), "--backend", "ray"]) == 2
    assert one_error_line(capsys) == f"bipedsim tune: {RAY_LINE}"
    assert snapshot(tmp_path / "old") == before


SMALL = "name: small\nseconds: 1.5\ngrid: {magnitude: [50, 100], direction: [0], duration: [0.1], start: [1.0]}\n"


def test_sweep_on_ray_without_ray_writes_nothing(tmp_path: Path, monkeypatch, capsys) -> None:
    (tmp_path / "small.yaml").write_text(SMALL)
    monkeypatch.setitem(sys.modules, "ray", None)
    monkeypatch.setattr(sweep, "run_row", lambda task: pytest.fail("a rollout ran"))
    with pytest.raises(ConfigError, match="the Ray backend needs the ray package"):
        run_sweep(load_experiment(tmp_path / "small.yaml"), tmp_path / "a", backend="ray", progress=False)
    assert not (tmp_path / "a").exists()
    assert main(["sweep", str(tmp_path / "small.yaml"), "--out", str(tmp_path / "b"), "--backend", "ray"]) == 2
    assert one_error_line(capsys) == f"bipedsim sweep: {RAY_LINE}"
    assert snapshot(tmp_path / "b") == {}  # no experiment.json, no results.csv


# ---------------------------------------------------------------------- a sweep's files read back
def write_results(path: Path, exp) -> None:
    """A finished sweep's results.csv for ``exp``, without running anything."""
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        w.writeheader()
        for r in exp.rows():
            d = r.params()
            d.update(outcome="no_fall", foot_strikes=3, distance_m=1.0, mean_speed_mps=0.9, tracking_rmse_rad=0.1,
                     sim_seconds=1.5, wall_seconds=0.1)
            w.writerow({k: d.get(k, "") for k in RESULT_COLUMNS})


@pytest.mark.parametrize("record, expected", [
    ("[1, 2", "not JSON"),
    ("[" * 200_000, "not JSON"),
    ('"a string"', "a JSON string, not an object"),
    ('{"setup": 5}', "its setup is not an object"),
])
def test_a_garbled_experiment_json_beside_results_is_one_line(tmp_path: Path, monkeypatch, capsys, record: str,
                                                              expected: str) -> None:
    (tmp_path / "small.yaml").write_text(SMALL)
    out = tmp_path / "out"
    out.mkdir()
    write_results(out / "results.csv", load_experiment(tmp_path / "small.yaml"))
    (out / "experiment.json").write_text(record)
    before = snapshot(out)
    monkeypatch.setattr(sweep, "run_row", lambda task: pytest.fail("a rollout ran"))
    assert main(["sweep", str(tmp_path / "small.yaml"), "--out", str(out)]) == 2
    line = one_error_line(capsys)
    assert line.startswith(f"bipedsim sweep: error: {out / 'experiment.json'}: not a sweep's record (")
    assert expected in line and line.endswith("remove results.csv to start again")
    assert snapshot(out) == before


def test_a_results_csv_that_is_a_pipe_is_refused_without_waiting(tmp_path: Path, monkeypatch, capsys) -> None:
    (tmp_path / "small.yaml").write_text(SMALL)
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "results.csv")
    monkeypatch.setattr(sweep, "run_row", lambda task: pytest.fail("a rollout ran"))
    assert main(["sweep", str(tmp_path / "small.yaml"), "--out", str(out)]) == 2
    assert "results.csv: is a pipe, not a CSV file" in one_error_line(capsys)


def test_a_tune_history_that_is_a_pipe_is_refused_without_waiting(tmp_path: Path, quick, capsys) -> None:
    out = tmp_path / "out"
    out.mkdir()
    os.mkfifo(out / "history.csv")
    assert main(["tune", str(write_tune(tmp_path)), "--out", str(out)]) == 2
    assert "history.csv: is a pipe, not a CSV file" in one_error_line(capsys)
    assert sorted(f.name for f in out.iterdir()) == ["history.csv"] and quick == []
