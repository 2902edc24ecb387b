"""Misuse of sweeps, suites and pushes: torn or foreign results files, --update on any YAML layout,
meaningless settings refused before any rollout (file and key, or flag and value, in the message),
pushes that did not happen never counted as survived, worker caps, progress, unwritable outputs."""

from __future__ import annotations

import csv
import errno
import json
from pathlib import Path

import pytest

from bipedsim.cli import main
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.experiments import sweep
from bipedsim.experiments.experiment import MAX_ROLLOUTS, load_experiment, load_suite
from bipedsim.experiments.regress import run_suite, update_expectations
from bipedsim.experiments.sweep import RESULT_COLUMNS, load_results, run_sweep, worker_count
from bipedsim.sim.limits import MAX_ROLLOUT_S
from bipedsim.sim.push import MAX_PUSH_N, Push, check_pushes
from bipedsim.sim.rollout import PUSH_NOT_APPLIED, RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

#: Two quick rollouts (1.5 s each, pushed at 1 s for 0.1 s).
SMALL = "name: small\nseconds: 1.5\ngrid: {magnitude: [50, 100], direction: [0], duration: [0.1], start: [1.0]}\n"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario()


def write_results(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in RESULT_COLUMNS})


def fake_rows(exp, outcome: str = "no_fall") -> list[dict]:
    """Result rows as a finished sweep writes them, without running anything."""
    out = []
    for r in exp.rows():
        d = r.params()
        d.update(outcome=outcome, fall_time_s="", fall_reason="", foot_strikes=3, distance_m=1.25,
                 mean_speed_mps=0.9, tracking_rmse_rad=0.1, recovery_time_s=0.2, peak_com_deviation_m=0.01,
                 steps_to_recover=1, sim_seconds=1.5, wall_seconds=0.1)
        out.append(d)
    return out


def rows_of(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture
def small(tmp_path: Path):
    spec = tmp_path / "small.yaml"
    spec.write_text(SMALL)
    return load_experiment(spec)


# ---------------------------------------------------------------------- results.csv: torn and malformed rows
def test_torn_last_row_is_dropped_reported_and_run_again(tmp_path: Path, small, monkeypatch) -> None:
    """A crash mid-write cuts the last line in the middle of a number: the next run says so in one
    line, rewrites the file without it and runs that rollout again (was: ValueError on every rerun)."""
    out = tmp_path / "out"
    out.mkdir()
    results = out / "results.csv"
    write_results(results, fake_rows(small))
    text = results.read_text()
    results.write_text(text[: text.rindex(",1.5,") + 3])  # "...,1." : sim_seconds cut, no line end
    ran = []
    real = sweep.run_row
    monkeypatch.setattr(sweep, "run_row", lambda task: ran.append(task[0].index) or real(task))
    said: list[str] = []
    summary = run_sweep(small, out, progress=False, say=said.append)
    assert ran == [1]
    assert len(said) == 1 and "dropped 1 malformed row(s)" in said[0] and "line 3" in said[0]
    assert "cut short" in said[0] and str(results) in said[0]
    rows = rows_of(results)
    assert [r["index"] for r in rows] == ["0", "1"] and all(float(r["sim_seconds"]) == 1.5 for r in rows)
    assert summary["rollouts"] == 2


@pytest.mark.parametrize("column,value,why", [
    ("magnitude", "5x0", "magnitude is not a number: '5x0'"),
    ("distance_m", "nan", "distance_m is not a number"),
    ("outcome", "fell_over", "unknown outcome 'fell_over'"),
    ("key", "0123456789ab", "key '0123456789ab' is not a rollout of this experiment"),
    ("magnitude", "75.0", "magnitude '75.0' is not this experiment's 100.0"),
])
def test_malformed_rows_are_named(tmp_path: Path, small, column: str, value: str, why: str) -> None:
    rows = fake_rows(small)
    rows[1][column] = value
    path = tmp_path / "results.csv"
    write_results(path, rows)
    good, problems = load_results(path, small.rows())
    assert [r["index"] for r in good] == ["0"]
    assert len(problems) == 1 and problems[0][0] == 3 and why in problems[0][1]


def test_wrong_column_count_and_repeated_key(tmp_path: Path, small) -> None:
    rows = fake_rows(small)
    path = tmp_path / "results.csv"
    write_results(path, rows + [rows[0]])
    with open(path, "a") as f:
        f.write("1,2,3\r\n")
    good, problems = load_results(path, small.rows())
    assert len(good) == 2
    assert problems[0][0] == 4 and "a second row for key" in problems[0][1] and "line 2" in problems[0][1]
    assert problems[1] == (5, f"3 columns, expected {len(RESULT_COLUMNS)}")


def test_foreign_or_torn_header(tmp_path: Path, small) -> None:
    path = tmp_path / "results.csv"
    path.write_text("name,score\nbob,3\n")
    with pytest.raises(BipedsimError, match="not a results file of this version"):
        load_results(path, small.rows())
    path.write_text("index,key,contr")  # the first write torn: nothing to keep
    assert load_results(path, small.rows()) == ([], [(1, "the header line is incomplete")])


def test_results_of_another_setup_are_refused(tmp_path: Path, small) -> None:
    """The row key holds the push, not the run length: results made with seconds 1.5 are not rows of
    the same grid run for 3 s, and mixing them would be silent."""
    out = tmp_path / "out"
    out.mkdir()
    write_results(out / "results.csv", fake_rows(small))
    run_sweep(small, out, progress=False)  # nothing to run: records the setup
    longer = tmp_path / "longer.yaml"
    longer.write_text(SMALL.replace("seconds: 1.5", "seconds: 3"))
    with pytest.raises(BipedsimError, match=r"holds results made with seconds 1.5, this experiment has seconds 3"):
        run_sweep(load_experiment(longer), out, progress=False)
    assert len(rows_of(out / "results.csv")) == 2


def test_another_experiments_results_are_not_deleted(tmp_path: Path, small) -> None:
    other = tmp_path / "other.yaml"
    other.write_text(SMALL.replace("magnitude: [50, 100]", "magnitude: [60, 70]"))
    out = tmp_path / "out"
    out.mkdir()
    write_results(out / "results.csv", fake_rows(load_experiment(other)))
    before = (out / "results.csv").read_text()
    with pytest.raises(BipedsimError, match=r"holds 2 row\(s\), none of them a rollout of experiment 'small'"):
        run_sweep(small, out, progress=False)
    assert (out / "results.csv").read_text() == before


# ---------------------------------------------------------------------- output folder and files
def test_unwritable_outputs_are_errors_not_tracebacks(tmp_path: Path, small, monkeypatch) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(BipedsimError, match="is an existing file; give a folder"):
        run_sweep(small, afile, progress=False)
    out = tmp_path / "out"
    (out / "results.csv").mkdir(parents=True)
    with pytest.raises(BipedsimError, match="results.csv: is a folder, not a CSV file"):
        run_sweep(small, out, progress=False)

    # a full disk while a row is appended: the message names the file, the cause and how to resume
    def full(path: Path, mode: str = "r", **kwargs: str):  # open() that fails on appends
        if "a" in mode:
            raise OSError(errno.ENOSPC, "No space left on device")
        return open(path, mode, **kwargs)

    out2 = tmp_path / "out2"
    monkeypatch.setattr(sweep, "open", full, raising=False)
    with pytest.raises(BipedsimError, match=r"results.csv: cannot write: No space left on device.*resume"):
        run_sweep(small, out2, progress=False)
    monkeypatch.undo()
    # a corrupt summary.json is simply rewritten; a garbled experiment.json beside results is refused (the
    # rows could not be checked against this experiment's setup), and once removed the sweep resumes; a
    # folder in summary.json's place is an error
    out3 = tmp_path / "out3"
    out3.mkdir()
    write_results(out3 / "results.csv", fake_rows(small))
    (out3 / "summary.json").write_bytes(b"\x00{not json")
    (out3 / "experiment.json").write_text("[1, 2")
    with pytest.raises(BipedsimError, match=r"experiment.json: not a sweep's record \(not JSON: .*\), so the results "
                                            "beside it cannot be checked"):
        run_sweep(small, out3, progress=False)
    (out3 / "experiment.json").unlink()
    assert run_sweep(small, out3, progress=False)["rollouts"] == 2
    assert json.loads((out3 / "summary.json").read_text())["rollouts"] == 2
    (out3 / "summary.json").unlink()
    (out3 / "summary.json").mkdir()
    with pytest.raises(BipedsimError, match="summary.json"):
        run_sweep(small, out3, progress=False)


# ---------------------------------------------------------------------- workers and progress
def test_workers_are_capped_and_zero_is_an_error(tmp_path: Path, small, capsys) -> None:
    assert worker_count(64, 4, cpus=2) == (2, "using 2 worker(s), not 64: 2 CPU(s)")
    assert worker_count(64, 4, cpus=16) == (4, "using 4 worker(s), not 64: 4 rollout(s) left")
    assert worker_count(2, 10, cpus=4) == (2, None)
    for bad in (0, -3):
        with pytest.raises(ConfigError, match=f"--workers: must be at least 1, got {bad}"):
            run_sweep(small, tmp_path / "o", workers=bad, progress=False)
    assert main(["sweep", str(small.path), "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    assert "--workers: must be at least 1, got 0" in capsys.readouterr().err
    assert not (tmp_path / "o" / "results.csv").exists()


def test_progress_bar_on_stderr_and_capped_workers_said(tmp_path: Path, small, capsys) -> None:
    """progress=True (what the command line passes when stderr is a terminal) draws a tqdm bar on
    stderr; 8 workers for the one rollout left start one (in this process), and say so."""
    out = tmp_path / "out"
    out.mkdir()
    write_results(out / "results.csv", fake_rows(small)[:1])
    said: list[str] = []
    run_sweep(small, out, workers=8, progress=True, say=said.append)
    err = capsys.readouterr().err
    assert "small" in err and "2/2" in err and "rollout" in err
    assert said == ["using 1 worker(s), not 8: 1 rollout(s) left"]
    assert len(rows_of(out / "results.csv")) == 2


@pytest.mark.slow  # a sweep in a pseudo-terminal
def test_progress_bar_shows_on_a_terminal_that_reports_no_width(tmp_path: Path, small) -> None:
    """A pseudo-terminal that reports 0 columns (some consoles do): tqdm alone printed an empty line
    for the whole sweep; the bar must still show."""
    pty = pytest.importorskip("pty", reason="needs a POSIX pseudo-terminal")
    import os
    import subprocess
    import sys

    out = tmp_path / "out"
    out.mkdir()
    write_results(out / "results.csv", fake_rows(small)[:1])
    code = ("import sys\nfrom bipedsim.experiments.experiment import load_experiment\n"
            "from bipedsim.experiments.sweep import run_sweep\n"
            f"run_sweep(load_experiment({str(small.path)!r}), {str(out)!r}, progress=sys.stderr.isatty())")
    main_fd, sub_fd = pty.openpty()  # a fresh pty: 0 rows x 0 columns
    proc = subprocess.Popen([sys.executable, "-c", code], stderr=sub_fd, stdout=subprocess.DEVNULL)
    os.close(sub_fd)
    seen = b""
    while True:
        try:
            chunk = os.read(main_fd, 4096)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        seen += chunk
    assert proc.wait(timeout=120) == 0
    os.close(main_fd)
    assert b"2/2" in seen and b"small" in seen, seen[-300:]


# ---------------------------------------------------------------------- pushes against the run length
@pytest.mark.parametrize("push,seconds,flag,words", [
    ("200:0:0.2:50", "3", "--push", "push 200:0:0.2:50 starts at 50 s, after the run ends at 3 s"),
    ("200:0:0.2:2.9", "3", "--push", "a push must end within the run"),
    ("200:0:0.2:s2.5", "2", "--push", "waits until 2 s of walking (after) for its gait phase, but the run ends at 2 s"),
    ("1e9:0:0.2:1", "3", "--push", f"magnitude: must be 0-{MAX_PUSH_N:g} N"),
    ("nan:0:0.2:1", "3", "--push", "magnitude"),
    ("100:0:0.2:1", "1e12", "--seconds", f"must be a run length in (0, {MAX_ROLLOUT_S:g}] s"),
])
def test_run_refuses_pushes_outside_the_run(tmp_path: Path, capsys, push: str, seconds: str, flag: str,
                                            words: str) -> None:
    out = tmp_path / "run"
    assert main(["run", "--seconds", seconds, "--push", push, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"bipedsim run: error: {flag}: ") and words in err and "\n" not in err
    assert not (out / "outcome.json").exists()


def test_check_pushes_in_the_rollout_itself(scenario) -> None:
    """API callers go through the same check (run_scenario), before anything runs."""
    with pytest.raises(ConfigError, match="after the run ends at 2 s"):
        run_scenario(scenario, RolloutSpec(seconds=2.0), pushes=[Push(magnitude=100, start=2.5)])
    with pytest.raises(ConfigError, match="not both"):
        check_pushes([Push(magnitude=100, start=1.0, state=2)], 3.0)
    check_pushes([Push(magnitude=100, start=2.8, duration=0.2)], 3.0)  # ends exactly at the end: fine


def test_describe_reads_back() -> None:
    for text in ("200:90:0.2:2.5", "150:0:0.1:s3.25", "0:45:0.3:s1.0", "99.5:-30:0.05:0"):
        p = Push.parse(text)
        assert Push.parse(p.describe()) == p


def state_arrivals(scenario, after: float = 2.0, seconds: float = 4.0) -> dict[int, float]:
    """The first time (s) at or after ``after`` s of the unpushed walk that the FSM is in each state
    (a state-timed push at fraction 0 starts then): measured, so the tests below do not hang on the
    gait's timing."""
    from bipedsim.sim.recorder import Recorder

    rec = Recorder(scenario.built.model, record_hz=500.0)
    run_scenario(scenario, RolloutSpec(seconds=seconds), hooks=[rec])
    tr = rec.trajectory({})
    out: dict[int, float] = {}
    for k in range(tr.num_samples):
        s = int(tr.fsm_state[k])
        if tr.time[k] >= after and s not in out:
            out[s] = float(tr.time[k])
    return out


def test_phase_push_that_never_came_is_not_survived(scenario) -> None:
    """Built-in walk, pushes at the start of a state (after 2 s of walking): a run that ends before
    the state comes never pushes, one that ends within the push cuts it short -- neither counts as a
    survived push; one that ends after it is an ordinary no_fall."""
    arrive = state_arrivals(scenario)
    late = max(arrive, key=arrive.__getitem__)  # the last state to come after 2 s
    assert arrive[late] - 0.01 >= 2.2
    out, _ = run_scenario(scenario, RolloutSpec(seconds=arrive[late] - 0.01),
                          pushes=[Push(magnitude=200, duration=0.2, state=late, fraction=0.0)])
    assert out.outcome == PUSH_NOT_APPLIED and out.fall_time_s is None
    assert "never started" in out.extra["pushes_not_applied"][0] and out.extra["push_start_s"] is None
    cut = max(2.2, arrive[late] + 0.1)
    out, _ = run_scenario(scenario, RolloutSpec(seconds=cut),
                          pushes=[Push(magnitude=200, duration=0.2, state=late, fraction=0.0)])
    assert out.outcome == PUSH_NOT_APPLIED and "cut short by the end of the run" in out.extra["pushes_not_applied"][0]
    out, _ = run_scenario(scenario, RolloutSpec(seconds=arrive[late] + 0.5),
                          pushes=[Push(magnitude=200, duration=0.2, state=late, fraction=0.0)])
    assert out.outcome == "no_fall" and "pushes_not_applied" not in out.extra


def test_sweep_leaves_pushes_not_applied_out_of_survival(scenario, tmp_path: Path) -> None:
    arrive = state_arrivals(scenario)
    first, late = min(arrive, key=arrive.__getitem__), max(arrive, key=arrive.__getitem__)
    seconds = round(arrive[late] - 0.01, 3)  # the first state's push fits, the last state never comes
    assert arrive[first] + 0.2 < seconds
    spec = tmp_path / "late.yaml"
    spec.write_text(f"name: late\nseconds: {seconds}\nruns:\n"
                    f"  - {{magnitude: 50, direction: 0, state: {first}, fraction: 0.0}}\n"
                    f"  - {{magnitude: 50, direction: 90, state: {late}, fraction: 0.0}}\n")
    summary = run_sweep(load_experiment(spec), tmp_path / "out", progress=False)
    rows = rows_of(tmp_path / "out" / "results.csv")
    assert [r["outcome"] for r in rows] == ["no_fall", PUSH_NOT_APPLIED]
    assert summary["outcomes"] == {"no_fall": 1, PUSH_NOT_APPLIED: 1}
    assert summary["survived_per_direction"] == {"0": {"survived": 1, "rollouts": 1}}
    assert [g["direction_deg"] for g in summary["by_direction_and_phase"]] == [0.0]


# ---------------------------------------------------------------------- experiment and suite files
@pytest.mark.parametrize("text,key,words", [
    ("name: x\nseconds: 1e12\ngrid: {start: [1.0]}\n", "seconds", f"must be <= {MAX_ROLLOUT_S}"),
    ("name: x\nrandom: {count: 1000000000000}\n", "random.count",
     f"asks for 1000000000000 rollouts (count 1000000000000 x 1 controller(s) x 1 repeat(s)); at most {MAX_ROLLOUTS}"),
    ("name: x\nrepeats: 200000\ngrid: {start: [1.0]}\n", "repeats", "asks for 200000 rollouts"),
    ("name: x\ngrid: {magnitude: [" + ", ".join(map(str, range(400))) + "], direction: ["
     + ", ".join(map(str, range(300))) + "], start: [1.0]}\n", "grid", "asks for 120000 rollouts (a grid of 120000"),
    ("name: x\nseed: -1\ngrid: {start: [1.0]}\n", "seed", "must be >= 0"),
    ("name: x\nseconds: 3\ngrid: {start: [50]}\n", "grid", "starts at 50 s, after the run ends at 3 s"),
    ("name: x\nseconds: 3\ngrid: {start: [2.9]}\n", "grid", "must end within the run"),
    ("name: x\nseconds: 3\nafter: 3\ngrid: {phase: [[2, 0.5]]}\n", "grid", "waits until 3 s of walking (after)"),
    ("name: x\nseconds: 3\nrandom: {count: 4, window: [2, 5]}\n", "random.window", "may start at 5 s"),
    ("name: x\ngrid: {magnitude: [100, 100], start: [1.0]}\n", "grid.magnitude", "100.0 is listed twice"),
    ("name: x\ngrid: {phase: [[2, 0.5], [2, 0.5]]}\n", "grid.phase", "[2, 0.5] is listed twice"),
    ("name: x\nruns: [{magnitude: 100, start: 1}, {magnitude: 100, start: 1}]\n", "runs[1]", "the same as runs[0]"),
    ("name: x\nruns: [{magnitude: 100, start: 1, state: 2}]\n", "runs[0].start", "not both"),
    ("name: x\nruns: [{magnitude: 100, start: 1, fraction: 0.3}]\n", "runs[0].fraction", "only with state"),
    ("name: x\nruns: [{magnitude: 100}]\n", "runs[0].start", "give a start time"),
    ("name: x\nruns: [{magnitude: 1.0e9, start: 1}]\n", "runs[0]", f"must be 0-{MAX_PUSH_N:g} N"),
    ("name: x\nruns: [{magnitude: .nan, start: 1}]\n", "runs[0].magnitude", "finite"),
    ("name: x\nfall: {torso_tilt: 4}\ngrid: {start: [1.0]}\n", "fall.torso_tilt", "must be <= 3.14"),
    ("name: x\nfall: {check_every: 5}\ngrid: {start: [1.0]}\n", "fall.check_every", "must be <= 1.0"),
])
def test_meaningless_experiments_fail_before_any_rollout(tmp_path: Path, text: str, key: str, words: str) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_experiment(p)
    msg = str(exc.value)
    assert msg.startswith(f"{p}: {key}: ") and words in msg, msg


def test_bad_experiment_exits_2_without_results(tmp_path: Path, capsys) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text("name: x\nrandom: {count: 1000000000000}\n")
    assert main(["sweep", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "random.count" in err and "1000000000000 rollouts" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "results.csv").exists()


@pytest.mark.parametrize("scenario_text,key,words", [
    ("{name: a, seconds: 1e12}", "scenarios[0].seconds", f"must be <= {MAX_ROLLOUT_S}"),
    ("{name: a, seed: -2}", "scenarios[0].seed", "must be >= 0"),
    ("{name: a, seconds: 3, pushes: [{magnitude: 200, start: 50}]}", "scenarios[0].pushes",
     "starts at 50 s, after the run ends at 3 s"),
    ("{name: a, pushes: [{magnitude: 200, start: 1, controller: x.yaml}]}", "scenarios[0].pushes[0].controller",
     "give controller on the scenario"),
    ("{name: a, controller: nope.yaml}", "scenarios[0].controller", "no such controller file"),
    ("{name: a, reference: nope.bvh}", "scenarios[0].reference", "no such file"),
    ("{name: a}\n  - {name: a}", "scenarios[1].name", "'a' is also scenarios[0]'s name"),
    ("{name: a, expect: push_not_applied}", "scenarios[0].expect", "must be one of"),
])
def test_meaningless_suites_fail_before_any_rollout(tmp_path: Path, capsys, scenario_text: str, key: str,
                                                   words: str) -> None:
    p = tmp_path / "suite.yaml"
    p.write_text(f"name: s\nscenarios:\n  - {scenario_text}\n")
    with pytest.raises(ConfigError) as exc:
        load_suite(p)
    msg = str(exc.value)
    assert msg.startswith(f"{p}: {key}: ") and words in msg, msg
    assert main(["regress", str(p)]) == 2
    assert "scenario  expected" not in capsys.readouterr().out  # nothing ran


# ---------------------------------------------------------------------- regress --update
SUITE = """# my suite: keep this comment
name: s
scenarios:
- {name: quick, seconds: 2, expect: fall}   # flow mapping
- name: other
  seconds: 2
  expect: 'fall'  # quoted
"""


def test_update_writes_flow_mappings_and_counts_what_changed(tmp_path: Path, capsys) -> None:
    """Both scenarios walk 2 s without falling; --update rewrites both expectations in their own
    layouts, keeps the comments, and the count printed is what changed in the file."""
    p = tmp_path / "suite.yaml"
    p.write_text(SUITE)
    assert run_suite(p) == 1
    assert run_suite(p, update=True) == 0
    out = capsys.readouterr().out
    assert "updated 2 expectation(s)" in out and "quick, other" in out
    text = p.read_text()
    assert text.startswith("# my suite: keep this comment\n")
    assert "- {name: quick, seconds: 2, expect: no_fall}" in text and "# flow mapping" in text
    assert "  expect: 'no_fall'" in text and "# quoted" in text
    assert run_suite(p) == 0


def test_update_matches_scenarios_by_name(tmp_path: Path) -> None:
    p = tmp_path / "suite.yaml"
    p.write_text(SUITE + "- name: third\n  seconds: 2\n")
    # only 'third' and 'other' change; 'third' had no expect key (default no_fall) and gets one
    assert update_expectations(p, {"third": "fall", "other": "fall", "quick": "fall"}) == ["third"]
    text = p.read_text()
    assert text.endswith("- name: third\n  seconds: 2\n  expect: fall\n")
    assert text.startswith(SUITE)
    assert update_expectations(p, {"third": "fall"}) == []  # nothing to change: file untouched
    assert [s.expect for s in load_suite(p).scenarios] == ["fall", "fall", "fall"]


def test_update_does_not_enshrine_a_push_that_never_happened(tmp_path: Path, capsys) -> None:
    p = tmp_path / "suite.yaml"
    # the built-in walk's cycle looped from its right strike reaches no mid-swing of state 2 between its
    # 2 s of walking and the run's end: the push never starts
    (tmp_path / "cycle.yaml").write_text("source: cycle\n")
    p.write_text("name: s\nscenarios:\n  - name: late\n    seconds: 2.25\n    controller: cycle.yaml\n"
                 "    pushes: [{magnitude: 100, state: 2, fraction: 0.5}]\n")
    before = p.read_text()
    assert run_suite(p, update=True) == 1
    out = capsys.readouterr().out
    assert "push_not_applied" in out and "never started" in out
    assert "updated 0 expectation(s)" in out and "not updated: late: a push did not happen" in out
    assert p.read_text() == before
