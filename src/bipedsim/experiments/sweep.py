"""Sweeps: every rollout of an experiment, in parallel (local processes or Ray), written to
``results.csv`` as each finishes -- so an interrupted sweep resumes where it stopped with nothing lost
and nothing run twice -- then ``summary.json`` and ``push_polar.png``.

When the sweep completes, ``results.csv`` is rewritten in row order, so the same experiment and seed
give the same file whatever order the workers finished in (apart from the ``wall_seconds`` column).

The backends (local processes, Ray) are :mod:`~bipedsim.experiments.backends`; reading a folder's results back and
checking them, :mod:`~bipedsim.experiments.sweep_folder`; the summary and the polar plot,
:mod:`~bipedsim.experiments.sweep_summary`.
"""

from __future__ import annotations

import csv
import json
import os
import sys
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

from bipedsim.errors import ConfigError, OutputError
from bipedsim.experiments.backends import BACKENDS, backend_session, check_backend, worker_count
from bipedsim.experiments.experiment import Experiment, Row
from bipedsim.experiments.sweep_folder import (
    RESULT_COLUMNS,
    TIMING_COLUMNS,
    _check_not_foreign,
    _check_setup,
    _report_dropped,
    _rewrite,
    _setup,
    load_results,
    read_results,
)
from bipedsim.experiments.sweep_summary import format_summary, polar_plot, summarise, threshold_table
from bipedsim.files import (
    atomic_write_text,
    os_reason,
    prepare_output_dir,
    progress_bar,
)
from bipedsim.model.ground import Ground
from bipedsim.sim.rollout import FallCriteria, RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

__all__ = ["RESULT_COLUMNS", "TIMING_COLUMNS", "backend_session", "check_backend", "format_summary",
           "interrupted_message", "load_results", "run_row", "run_sweep", "summarise", "worker_count"]

_CACHE: dict[Any, Any] = {}


#: one rollout for a worker: (row, (reference, profile, support[, ground terms]), seconds, init_noise, fall
#: criteria)
Task = tuple[Row, tuple[Any, ...], float, float, dict[str, Any] | None]


def _scenario(body: tuple[Any, ...], controller: str | None) -> Any:
    """The scenario of a (reference, profile, support[, ground terms]) body and a controller, built once per
    process."""
    reference, profile, support = body[:3]
    ground = tuple(body[3]) if len(body) > 3 else ()
    key = (reference, profile, support, ground, controller)
    if key not in _CACHE:
        _CACHE[key] = load_scenario(controller, reference, profile=profile, support=support,
                                    ground=Ground.parse(list(ground), key="ground"))
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
    body: tuple[Any, ...] = (exp.resolve(s.reference), s.profile, s.support)
    return [(r, body + ((tuple(r.ground),) if r.ground else ()), s.seconds,
             s.init_noise if r.init_noise is None else r.init_noise, fall) for r in rows]


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
    tasks = _tasks(exp, todo)
    if n_workers > 1:  # each body made here first: a clip's correction is searched once, not once per worker
        for body, ctl in dict.fromkeys((t[1], t[0].controller) for t in tasks):
            _scenario(body, ctl)
    bar = None
    if progress and todo:
        # io's bar: sized even where the terminal reports 0 columns (tqdm alone drew nothing there)
        bar = progress_bar(len(rows), exp.spec.name, "rollout", force=True, leave=True)
        bar.update(len(rows) - len(todo))
    try:
        # run_row looked up at call time (tests replace it)
        for res in BACKENDS[backend](tasks, n_workers, run_row):
            _append(results, res)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    final, _ = load_results(results, rows)
    final.sort(key=lambda r: int(r["index"]))
    _rewrite(results, final)
    rep = exp.spec.replicas
    summary = summarise(final, sector=exp.spec.random.sector if exp.spec.random else None,
                        survive=None if rep is None else rep.survive, replicas=None if rep is None else rep.count)
    summary.update({"experiment": exp.spec.name, "rollouts": len(final)})
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    if rep is not None:
        atomic_write_text(out / "thresholds.md", threshold_table(summary))
    try:
        polar_plot(final, out / "push_polar.png", fan=exp.spec.random is None,
                   survive=None if rep is None else rep.survive)
    except OSError as exc:
        raise OutputError(f"cannot write {out / 'push_polar.png'}: {os_reason(exc)}") from None
    return summary


def interrupted_message(exp: Experiment, out_dir: str | os.PathLike[str]) -> str:
    """What an interrupted sweep of ``exp`` into ``out_dir`` has kept and how to finish it (resuming
    runs only the rollouts not yet in ``results.csv``)."""
    n = len(read_results(Path(out_dir) / "results.csv"))
    return (f"interrupted; {out_dir}/results.csv holds {n} of {len(exp.rows())} rollouts; "
            "run the same command again to finish the rest")
