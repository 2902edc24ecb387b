"""Sweeps: every rollout of an experiment, in parallel (local processes or Ray), written to
``results.csv`` as each finishes -- so an interrupted sweep resumes where it stopped with nothing lost
and nothing run twice -- then ``summary.json`` and ``push_polar.png``.

When the sweep completes, ``results.csv`` is rewritten in row order, so the same experiment and seed
give the same file whatever order the workers finished in (apart from the ``wall_seconds`` column).
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import multiprocessing as mp
import os
import signal
import sys
from collections.abc import Callable, Iterator
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from bipedsim.errors import BipedsimError, ConfigError, InputError, OutputError
from bipedsim.io import (
    atomic_write_text,
    os_reason,
    prepare_output_dir,
    progress_bar,
    read_input_bytes,
    read_input_text,
    save_figure,
)
from bipedsim.sim.experiment import Experiment, Row
from bipedsim.sim.rollout import OUTCOMES, PUSH_NOT_APPLIED, FallCriteria, RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

RESULT_COLUMNS = ["index", "key", "controller", "magnitude", "direction", "duration", "state", "fraction", "start",
                  "vertical", "body", "repeat", "seed", "outcome", "fall_time_s", "fall_reason", "foot_strikes",
                  "distance_m", "mean_speed_mps", "tracking_rmse_rad", "recovery_time_s", "peak_com_deviation_m",
                  "steps_to_recover", "sim_seconds", "wall_seconds"]
TIMING_COLUMNS = ("wall_seconds",)

_CACHE: dict[Any, Any] = {}
#: What a job asked to run on Ray says when the ``ray`` package is not installed.
RAY_MISSING = "the Ray backend needs the ray package: pip install 'bipedsim[ray]'"


#: one rollout for a worker: (row, (reference, profile, support), seconds, init_noise, fall criteria)
Task = tuple[Row, tuple[str | None, str, bool], float, float, dict[str, Any] | None]


def _scenario(body: tuple[str | None, str, bool], controller: str | None) -> Any:
    """The scenario of a (reference, profile, support) body and a controller, built once per process."""
    reference, profile, support = body
    key = (reference, profile, support, controller)
    if key not in _CACHE:
        _CACHE[key] = load_scenario(controller, reference, profile=profile, support=support)
    return _CACHE[key]


def run_row(task: Task) -> dict[str, Any]:
    """Run one rollout of an experiment (in whichever process); returns its result row."""
    row, body, seconds, init_noise, fall = task
    sc = _scenario(body, row.controller)
    crit = None if fall is None else FallCriteria(**fall)
    spec = RolloutSpec(seconds=seconds, seed=row.seed, init_noise=init_noise, fall=crit)
    out, _ = run_scenario(sc, spec, pushes=[row.push])
    e = out.extra
    res = row.params()
    res.update({"outcome": out.outcome, "fall_time_s": out.fall_time_s, "fall_reason": out.fall_reason or "",
                "foot_strikes": out.foot_strikes, "distance_m": round(out.distance_m, 6),
                "mean_speed_mps": round(out.mean_speed_mps, 6), "tracking_rmse_rad": round(out.tracking_rmse_rad, 6),
                "recovery_time_s": e.get("recovery_time_s"), "peak_com_deviation_m": e.get("peak_com_deviation_m"),
                "steps_to_recover": e.get("steps_to_recover"), "sim_seconds": round(out.sim_seconds, 6),
                "wall_seconds": round(out.wall_seconds, 3)})
    return {k: ("" if v is None else v) for k, v in res.items()}


#: Columns that always hold a finite number, and those that may be empty (a push at a start time has
#: no state; a survived rollout no fall time).
NUMERIC_COLUMNS = ("index", "magnitude", "direction", "duration", "vertical", "repeat", "seed", "foot_strikes",
                   "distance_m", "mean_speed_mps", "tracking_rmse_rad", "sim_seconds", "wall_seconds")
OPTIONAL_NUMERIC_COLUMNS = ("state", "fraction", "start", "fall_time_s", "recovery_time_s", "peak_com_deviation_m",
                            "steps_to_recover")
#: Columns that must equal the experiment's row of the same key (else the row is from an edited experiment).
PARAM_COLUMNS = ("index", "magnitude", "direction", "duration", "state", "fraction", "start", "vertical", "body",
                 "repeat", "seed")
#: Malformed rows named in the one-line report (the rest are counted).
_REPORT_ROWS = 3


def read_results(path: Path) -> list[dict[str, str]]:
    """The rows of ``path`` that have a key and an outcome, for counting (an interrupted sweep's
    message); [] when there is no readable file. :func:`load_results` checks them properly."""
    if not path.exists():
        return []
    try:
        text = read_input_bytes(path, "csv").decode("utf-8", errors="replace")
        rows = list(csv.DictReader(io.StringIO(text, newline="")))
    except (BipedsimError, csv.Error):
        return []
    return [r for r in rows if r.get("key") and r.get("outcome")]


def _row_problem(rec: dict[str, str], expected: dict[str, Row]) -> str | None:
    """Why a results.csv record cannot stand for a rollout of this experiment, or None."""
    for col in NUMERIC_COLUMNS + OPTIONAL_NUMERIC_COLUMNS:
        v = rec[col]
        if v == "" and col in OPTIONAL_NUMERIC_COLUMNS:
            continue
        try:
            ok = math.isfinite(float(v))
        except ValueError:
            ok = False
        if not ok:
            return f"{col} is not a number: {v!r}"
    if rec["outcome"] not in OUTCOMES:
        return f"unknown outcome {rec['outcome']!r} (outcomes: {', '.join(OUTCOMES)})"
    row = expected.get(rec["key"])
    if row is None:
        return f"key {rec['key']!r} is not a rollout of this experiment"
    want = row.params()
    for col in PARAM_COLUMNS:
        w, v = want[col], rec[col]
        same = v == str(w) if isinstance(w, str) else v != "" and float(v) == float(w)
        if not same:
            return f"{col} {v!r} is not this experiment's {w!r} for key {rec['key']} (the experiment was edited?)"
    return None


def load_results(path: Path, rows: list[Row]) -> tuple[list[dict[str, str]], list[tuple[int, str]]]:
    """The rows of ``path`` (a sweep's results.csv) that are whole rollouts of this experiment, and
    (line number, why) for every other record: a torn last line (a crash or a full disk mid-write), a
    wrong column count, an unparsable number, an unknown outcome, a key not in the experiment or
    parameters that differ from it, a second row for one key. Raises :class:`BipedsimError` when the
    file cannot be read (:class:`~bipedsim.errors.InputError`: a folder, a device, above the size limit
    for CSV files), or is not a results file (its header is not :data:`RESULT_COLUMNS`)."""
    if not path.exists():
        return [], []
    raw = read_input_bytes(path, "csv")
    text = raw.decode("utf-8", errors="replace")  # a byte torn in a character shows as a bad value
    records: list[tuple[int, list[str]]] = []
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        for rec in reader:
            records.append((reader.line_num, rec))
    except csv.Error as exc:  # e.g. a NUL byte from a crash: keep what was read, the rest is torn
        records.append((reader.line_num, [f"<{exc}>"]))
    if not records:
        return [], []
    (_, header), body = records[0], records[1:]
    torn_last = bool(text) and not text.endswith(("\n", "\r"))
    if header != RESULT_COLUMNS:
        if not body:  # a header torn while the first row was written: nothing to keep
            return [], [(1, "the header line is incomplete")]
        raise BipedsimError(f"{path}: not a results file of this version of bipedsim sweep: its columns are "
                            f"{', '.join(header[:4])}, ...; expected {', '.join(RESULT_COLUMNS[:4])}, ...; move it "
                            "away or give another --out")
    expected = {r.key: r for r in rows}
    good: list[dict[str, str]] = []
    seen: dict[str, int] = {}
    problems: list[tuple[int, str]] = []
    for i, (line, rec) in enumerate(body):
        if i == len(body) - 1 and torn_last:
            problems.append((line, "the last line is cut short (an interrupted write)"))
            continue
        if len(rec) != len(RESULT_COLUMNS):
            problems.append((line, f"{len(rec)} columns, expected {len(RESULT_COLUMNS)}"))
            continue
        d = dict(zip(RESULT_COLUMNS, rec))
        why = _row_problem(d, expected)
        if why is None and d["key"] in seen:
            why = f"a second row for key {d['key']} (line {seen[d['key']]} has it)"
        if why is not None:
            problems.append((line, why))
            continue
        seen[d["key"]] = line
        good.append(d)
    return good, problems


def _report_dropped(path: Path, problems: list[tuple[int, str]]) -> str:
    shown = "; ".join(f"line {line}: {why}" for line, why in problems[:_REPORT_ROWS])
    more = f"; and {len(problems) - _REPORT_ROWS} more" if len(problems) > _REPORT_ROWS else ""
    return (f"{path}: dropped {len(problems)} malformed row(s), their rollouts run again ({shown}{more})")


def _append(path: Path, row: dict[str, Any]) -> None:
    try:
        new = not path.exists() or path.stat().st_size == 0
        with open(path, "a", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
            if new:
                w.writeheader()
            w.writerow({k: row.get(k, "") for k in RESULT_COLUMNS})
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {os_reason(exc)}; the rows written before are kept "
                          "(run the same command again to resume)") from None


def _tasks(exp: Experiment, rows: list[Row]) -> list[Task]:
    s = exp.spec
    fall = None if s.fall is None else asdict(s.fall)
    body = (exp.resolve(s.reference), s.profile, s.support)
    return [(r, body, s.seconds, s.init_noise, fall) for r in rows]


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _local(tasks: list, workers: int, fn: Callable[[Any], Any] | None = None) -> Iterator[Any]:
    """``fn`` (default :func:`run_row`) of every task, as each finishes: in this process (1 worker) or a
    pool of ``workers``."""
    fn = fn or run_row  # looked up at call time (tests replace run_row)
    if workers <= 1:
        for t in tasks:
            yield fn(t)
        return
    ctx = mp.get_context("spawn")  # a clean interpreter per worker: no inherited MuJoCo or GL state
    # workers leave Ctrl-C to the parent, which stops the pool (no traceback from every worker)
    with ctx.Pool(workers, initializer=_ignore_sigint) as pool:
        yield from pool.imap_unordered(fn, tasks)


def check_backend(backend: str) -> None:
    """Refuse, before anything is written, a backend that is not known or cannot run here: Ray when the
    ``ray`` package is not installed (:class:`ConfigError` naming ``--backend`` and the fix)."""
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; choose {', '.join(BACKENDS)}", key="--backend")
    if backend == "ray":
        try:
            import ray  # noqa: F401 - imported only to learn whether it can be
        except ImportError:
            raise ConfigError(RAY_MISSING, key="--backend") from None


@contextlib.contextmanager
def ray_session(workers: int) -> Iterator[Any]:
    """The ``ray`` module, initialised for ``workers`` CPUs unless it already is (and then shut down
    on leaving); :class:`BipedsimError` when Ray is not installed. A long job that sends work to Ray
    in several rounds holds one session around them all."""
    try:
        import ray
    except ImportError:
        raise BipedsimError(RAY_MISSING) from None
    started = False
    if not ray.is_initialized():
        ray.init(num_cpus=max(1, workers), include_dashboard=False, log_to_driver=False,
                 ignore_reinit_error=True)
        started = True
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


def _ray(tasks: list, workers: int, fn: Callable[[Any], Any] | None = None) -> Iterator[Any]:
    with ray_session(workers) as ray:
        remote = ray.remote(fn or run_row)
        pending = [remote.remote(t) for t in tasks]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])


@contextlib.contextmanager
def backend_session(backend: str, workers: int) -> Iterator[Callable[[list, Callable[[Any], Any]], Iterator[Any]]]:
    """``run(tasks, fn)`` -> ``fn``'s result of each task as it finishes, for a job that sends work in
    several rounds (a tune's generations): the workers start once and keep what they have built (each
    process's cached bodies and clips) from one round to the next -- one pool of ``workers`` spawned
    processes (local; in this process for 1), or one Ray session."""
    if backend == "ray":
        with ray_session(workers):
            yield lambda tasks, fn: _ray(tasks, workers, fn)
    elif workers <= 1:
        yield lambda tasks, fn: (fn(t) for t in tasks)
    else:
        with mp.get_context("spawn").Pool(workers, initializer=_ignore_sigint) as pool:
            yield lambda tasks, fn: pool.imap_unordered(fn, tasks)


#: backend name -> (tasks, workers, fn) -> fn's result of each task, in the order they finish
BACKENDS: dict[str, Callable[..., Iterator[dict[str, Any]]]] = {"local": _local, "ray": _ray}


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the system has one, e.g. in a container)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def worker_count(requested: int, rollouts: int, cpus: int | None = None) -> tuple[int, str | None]:
    """Workers to start: ``requested`` capped at the rollouts left and the CPUs (more only adds
    start-up: each worker imports MuJoCo and builds the body, seconds each, and they share the CPUs),
    and a one-line note when capped. ``requested`` >= 1 (:func:`run_sweep` checks it)."""
    cpus = usable_cpus() if cpus is None else cpus
    n = max(1, min(requested, rollouts, cpus))
    if n == requested or rollouts == 0:
        return requested, None
    why = f"{rollouts} rollout(s) left" if rollouts <= cpus else f"{cpus} CPU(s)"
    return n, f"using {n} worker(s), not {requested}: {why}"


def _say(message: str) -> None:
    print(f"bipedsim sweep: {message}", file=sys.stderr)


def run_sweep(exp: Experiment, out_dir: str | os.PathLike[str], workers: int = 1, backend: str = "local",
              progress: bool = True, say: Callable[[str], None] = _say) -> dict[str, Any]:
    """Run every rollout not already in ``out_dir/results.csv``; returns the summary.

    ``progress``: a progress bar on stderr (the command line asks for one when stderr is a terminal).
    ``say`` gets one-line notes: malformed rows dropped from results.csv (they are run again), workers
    capped. Errors (an unwritable folder, a results.csv that is not one, another run setup's results)
    are :class:`BipedsimError` before any rollout; a backend that cannot run here (Ray not installed)
    and a worker count below 1, before anything is written."""
    check_backend(backend)
    if workers < 1:
        raise ConfigError(f"must be at least 1, got {workers}", key="--workers")
    out = prepare_output_dir(out_dir, "--out")
    results = out / "results.csv"
    rows = exp.rows()
    _check_setup(out, exp)
    done, problems = load_results(results, rows)
    if problems and not done:
        _check_not_foreign(results, exp, rows)
    if problems:
        _rewrite(results, done)  # before anything is appended: a torn last line would swallow the next row
        say(_report_dropped(results, problems))
    done_keys = {r["key"] for r in done}
    todo = [r for r in rows if r.key not in done_keys]
    record = {"name": exp.spec.name, "file": str(exp.path), "rollouts": len(rows), "setup": _setup(exp)}
    atomic_write_text(out / "experiment.json", json.dumps(record, indent=2) + "\n")
    n_workers, note = worker_count(workers, len(todo))
    if note:
        say(note)
    bar = None
    if progress and todo:
        # io's bar: sized even where the terminal reports 0 columns (tqdm alone drew nothing there)
        bar = progress_bar(len(rows), exp.spec.name, "rollout", force=True, leave=True)
        bar.update(len(rows) - len(todo))
    try:
        for res in BACKENDS[backend](_tasks(exp, todo), n_workers):
            _append(results, res)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    final, _ = load_results(results, rows)
    final.sort(key=lambda r: int(r["index"]))
    _rewrite(results, final)
    summary = summarise(final, sector=exp.spec.random.sector if exp.spec.random else None)
    summary.update({"experiment": exp.spec.name, "rollouts": len(final)})
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    try:
        polar_plot(final, out / "push_polar.png", fan=exp.spec.random is None)
    except OSError as exc:
        raise OutputError(f"cannot write {out / 'push_polar.png'}: {os_reason(exc)}") from None
    return summary


def format_summary(summary: dict[str, Any], out_dir: str | os.PathLike[str]) -> str:
    """The lines ``bipedsim sweep`` prints for a :func:`run_sweep` summary: the outcome counts, per
    push direction (degrees; +- half the sector for random pushes) the rollouts survived and the
    largest magnitude (N) survived in every push or phase, and the files written into ``out_dir``."""
    lines = [f"{summary['rollouts']} rollouts: "
             + ", ".join(f"{k} {v}" for k, v in sorted(summary["outcomes"].items()))]
    counts = summary.get("survived_per_direction", {})
    sector = summary.get("direction_sector_deg")
    width = f" +-{sector / 2:g}" if sector else ""
    what = "push" if sector else "phase"
    for d, v in summary["largest_survived_per_direction_n"].items():
        c = counts.get(d, {"survived": 0, "rollouts": 0})
        every = f"every {what} survived up to {v:g} N" if v is not None else f"no magnitude survived in every {what}"
        lines.append(f"  direction {d:>5}{width} deg: {c['survived']}/{c['rollouts']} survived; {every}")
    lines.append(f"wrote {out_dir}/results.csv, summary.json, push_polar.png")
    return "\n".join(lines)


def interrupted_message(exp: Experiment, out_dir: str | os.PathLike[str]) -> str:
    """What an interrupted sweep of ``exp`` into ``out_dir`` has kept and how to finish it (resuming
    runs only the rollouts not yet in ``results.csv``)."""
    n = len(read_results(Path(out_dir) / "results.csv"))
    return (f"interrupted; {out_dir}/results.csv holds {n} of {len(exp.rows())} rollouts; "
            "run the same command again to finish the rest")


def _check_not_foreign(results: Path, exp: Experiment, rows: list[Row]) -> None:
    """Refuse to drop a results file none of whose rows is a rollout of ``exp``: another experiment's
    results, which resuming would delete."""
    keys = {r.key for r in rows}
    theirs = read_results(results)
    if theirs and not any(r["key"] in keys for r in theirs):
        raise BipedsimError(f"--out {results.parent}: {results.name} holds {len(theirs)} row(s), none of them a "
                            f"rollout of experiment {exp.spec.name!r} ({exp.path}): another experiment's results? "
                            "Give another --out, or remove the file to start again")


def _setup(exp: Experiment) -> dict[str, Any]:
    """What every rollout of ``exp`` shares but a row's key does not hold: rows made under another
    setup are not rows of this one."""
    s = exp.spec
    return {"seconds": s.seconds, "reference": exp.resolve(s.reference), "profile": s.profile, "support": s.support,
            "init_noise": s.init_noise,
            "fall": None if s.fall is None else asdict(s.fall)}


def _read_setup(path: Path) -> dict[str, Any] | None:
    """The setup an ``experiment.json`` records; None when there is none to check against (no file, or
    an older record without one); :class:`InputError` for a file that is not a sweep's record."""
    if not path.exists():
        return None
    try:
        record = json.loads(read_input_text(path, "json"))
    except (ValueError, RecursionError) as exc:  # RecursionError: nesting deeper than json's parser goes
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(_not_a_record(f"not JSON: {why}"), path) from None
    if not isinstance(record, dict):
        raise InputError(_not_a_record(f"a JSON {json_kind(record)}, not an object"), path)
    if "setup" not in record:
        return None
    if not isinstance(record["setup"], dict):
        raise InputError(_not_a_record("its setup is not an object"), path)
    return record["setup"]


def json_kind(value: Any) -> str:
    """What a parsed JSON value is, in JSON's words (for a message about a file holding the wrong kind)."""
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    kinds = {dict: "object", list: "array", str: "string", int: "number", float: "number"}
    return kinds.get(type(value), type(value).__name__)


def _not_a_record(why: str) -> str:
    return (f"not a sweep's record ({why}), so the results beside it cannot be checked against this "
            "experiment; remove it to resume without that check, or remove results.csv to start again")


def _check_setup(out: Path, exp: Experiment) -> None:
    """Refuse to resume into results made with another run length, reference, noise or fall criteria
    (``experiment.json`` records them; an older record without them is not checked: it is rewritten;
    a file that is not a record at all is refused, as resuming would trust rows it cannot check)."""
    if not read_results(out / "results.csv"):
        return
    old = _read_setup(out / "experiment.json")
    if old is None:
        return
    new = json.loads(json.dumps(_setup(exp)))  # tuples as lists, as the record has them
    diff = [k for k in new if old.get(k) != new[k]]
    if diff:
        k = diff[0]
        raise BipedsimError(f"--out {out}: holds results made with {k} {old.get(k)}, this experiment has {k} "
                            f"{new[k]}; give another --out, or remove {out / 'results.csv'} to start again")


def _rewrite(path: Path, rows: list[dict[str, str]]) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=RESULT_COLUMNS)
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k, "") for k in RESULT_COLUMNS})
    atomic_write_text(path, buf.getvalue())


def _phase_label(r: dict[str, str]) -> str:
    return f"state {r['state']} at {float(r['fraction']):.2f}" if r["state"] else f"t={float(r['start']):.2f}s"


def summarise(rows: list[dict[str, str]], sector: float | None = None) -> dict[str, Any]:
    """Per controller, direction and phase: the largest magnitude survived, and the largest below
    which every push was survived (the recovery threshold on this grid). With ``sector`` (random
    pushes), directions are binned into sectors that wide, centred on multiples of it, and every
    start time counts as one phase, "random start". Rollouts whose push did not happen
    (``push_not_applied``) count only in ``outcomes``: they neither survived nor failed a push."""
    groups: dict[tuple[str, float, str], list[tuple[float, bool]]] = {}

    def direction(r: dict[str, str]) -> float:
        d = float(r["direction"])
        return d if sector is None else (round(d / sector) * sector) % 360.0

    pushed = [r for r in rows if r["outcome"] != PUSH_NOT_APPLIED]  # no push: nothing survived
    for r in pushed:
        k = (r["controller"], direction(r), _phase_label(r) if sector is None else "random start")
        groups.setdefault(k, []).append((float(r["magnitude"]), r["outcome"] == "no_fall"))
    out: dict[str, Any] = {"by_direction_and_phase": [], "outcomes": {}}
    for (ctl, d, ph), vals in sorted(groups.items()):
        vals.sort()
        survived = [m for m, ok in vals if ok]
        threshold = 0.0
        for m, ok in vals:
            if not ok:
                break
            threshold = m
        out["by_direction_and_phase"].append({"controller": ctl, "direction_deg": d, "phase": ph,
                                              "largest_survived_n": max(survived) if survived else None,
                                              "survived_all_up_to_n": threshold if vals[0][1] else None,
                                              "rollouts": len(vals)})
    for r in rows:
        out["outcomes"][r["outcome"]] = out["outcomes"].get(r["outcome"], 0) + 1
    per_dir: dict[str, float | None] = {}
    for g in out["by_direction_and_phase"]:
        key = f"{g['direction_deg']:g}"
        v = g["survived_all_up_to_n"]
        cur = per_dir.get(key, float("inf"))
        per_dir[key] = None if v is None or cur is None else min(cur, v)
    out["largest_survived_per_direction_n"] = per_dir
    counts: dict[str, dict[str, int]] = {}
    for r in pushed:
        c = counts.setdefault(f"{direction(r):g}", {"survived": 0, "rollouts": 0})
        c["rollouts"] += 1
        c["survived"] += r["outcome"] == "no_fall"
    out["survived_per_direction"] = counts
    if sector is not None:
        out["direction_sector_deg"] = sector
    return out


def polar_plot(rows: list[dict[str, str]], path: Path, fan: bool = True) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    # the phases of one direction fan out around it (in the order listed below the plot), so that
    # every rollout is a visible point instead of several phases stacked on one (not for random
    # pushes: every start time is its own phase and the directions are spread already)
    phases = sorted({_phase_label(r) for r in rows})
    dirs = sorted({float(r["direction"]) for r in rows})
    gap = min((b - a for a, b in zip(dirs, dirs[1:] + [dirs[0] + 360.0])), default=360.0) if dirs else 360.0
    step = min(6.0, 0.5 * gap / len(phases)) if fan and 1 < len(phases) <= 8 else 0.0
    offset = {p: (i - (len(phases) - 1) / 2) * step for i, p in enumerate(phases)}
    for outcome, colour, marker in (("no_fall", "tab:green", "o"), ("fall", "tab:red", "x"),
                                    ("diverged", "tab:purple", "^")):
        sel = [r for r in rows if r["outcome"] == outcome]
        if sel:
            ax.scatter(np.radians([float(r["direction"]) + offset[_phase_label(r)] for r in sel]),
                       [float(r["magnitude"]) for r in sel], c=colour, marker=marker, s=14, label=outcome,
                       alpha=0.8)
    ax.set_theta_zero_location("N")  # forward up
    ax.set_title("push outcomes: direction (0 = forward, 90 = left) x force (N)")
    if step:
        fig.text(0.98, 0.02, "around each direction, counter-clockwise:\n" + "\n".join(phases), ha="right",
                 va="bottom", fontsize=7)
    if ax.get_legend_handles_labels()[0]:  # none when no push happened (every row push_not_applied)
        ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.1), fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
