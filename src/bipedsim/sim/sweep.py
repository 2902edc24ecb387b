"""Sweeps: every rollout of an experiment, in parallel (local processes or Ray), written to
``results.csv`` as each finishes -- so an interrupted sweep resumes where it stopped with nothing lost
and nothing run twice -- then ``summary.json`` and ``push_polar.png``.

When the sweep completes, ``results.csv`` is rewritten in row order, so the same experiment and seed
give the same file whatever order the workers finished in (apart from the ``wall_seconds`` column).
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from bipedsim.errors import BipedsimError
from bipedsim.sim.experiment import Experiment, Row

RESULT_COLUMNS = ["index", "key", "controller", "magnitude", "direction", "duration", "state", "fraction", "start",
                  "vertical", "body", "repeat", "seed", "outcome", "fall_time_s", "fall_reason", "foot_strikes",
                  "distance_m", "mean_speed_mps", "tracking_rmse_rad", "recovery_time_s", "peak_com_deviation_m",
                  "steps_to_recover", "sim_seconds", "wall_seconds"]
TIMING_COLUMNS = ("wall_seconds",)

_CACHE: dict[Any, Any] = {}


def _scenario(reference: str | None, controller: str | None) -> Any:
    from bipedsim.sim.runner import load_scenario

    key = (reference, controller)
    if key not in _CACHE:
        _CACHE[key] = load_scenario(controller, reference)
    return _CACHE[key]


def run_row(task: tuple[Row, str | None, float, float, dict[str, Any]]) -> dict[str, Any]:
    """Run one rollout of an experiment (in whichever process); returns its result row."""
    from bipedsim.sim.rollout import FallCriteria, RolloutSpec
    from bipedsim.sim.runner import run_scenario

    row, reference, seconds, init_noise, fall = task
    sc = _scenario(reference, row.controller)
    spec = RolloutSpec(seconds=seconds, seed=row.seed, init_noise=init_noise, fall=FallCriteria(**fall))
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


def read_results(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        return []
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return [r for r in rows if r.get("key") and r.get("outcome")]


def _append(path: Path, row: dict[str, Any]) -> None:
    new = not path.exists() or path.stat().st_size == 0
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=RESULT_COLUMNS)
        if new:
            w.writeheader()
        w.writerow({k: row.get(k, "") for k in RESULT_COLUMNS})
        f.flush()
        os.fsync(f.fileno())


def _tasks(exp: Experiment, rows: list[Row]) -> list[tuple[Row, str | None, float, float, dict[str, Any]]]:
    from dataclasses import asdict

    s = exp.spec
    return [(r, exp.resolve(s.reference), s.seconds, s.init_noise, asdict(s.fall.criteria())) for r in rows]


def _ignore_sigint() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _local(tasks: list, workers: int) -> Iterator[dict[str, Any]]:
    if workers <= 1:
        for t in tasks:
            yield run_row(t)
        return
    import multiprocessing as mp

    ctx = mp.get_context("spawn")  # a clean interpreter per worker: no inherited MuJoCo or GL state
    # workers leave Ctrl-C to the parent, which stops the pool (no traceback from every worker)
    with ctx.Pool(workers, initializer=_ignore_sigint) as pool:
        yield from pool.imap_unordered(run_row, tasks)


def _ray(tasks: list, workers: int) -> Iterator[dict[str, Any]]:
    try:
        import ray
    except ImportError:
        raise BipedsimError("the Ray backend needs the ray package: pip install 'bipedsim[ray]'") from None
    started = False
    if not ray.is_initialized():
        ray.init(num_cpus=max(1, workers), include_dashboard=False, log_to_driver=False,
                 ignore_reinit_error=True)
        started = True
    try:
        remote = ray.remote(run_row)
        pending = [remote.remote(t) for t in tasks]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        if started:
            ray.shutdown()


BACKENDS: dict[str, Callable[[list, int], Iterator[dict[str, Any]]]] = {"local": _local, "ray": _ray}


def run_sweep(exp: Experiment, out_dir: str | os.PathLike[str], workers: int = 1, backend: str = "local",
              progress: bool = True) -> dict[str, Any]:
    """Run every rollout not already in ``out_dir/results.csv``; returns the summary."""
    if backend not in BACKENDS:
        raise BipedsimError(f"unknown backend {backend!r}; choose {', '.join(BACKENDS)}")
    if workers < 1:
        raise BipedsimError(f"--workers must be at least 1, got {workers}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results = out / "results.csv"
    rows = exp.rows()
    done = {r["key"] for r in read_results(results)}
    todo = [r for r in rows if r.key not in done]
    (out / "experiment.json").write_text(json.dumps({"name": exp.spec.name, "file": str(exp.path),
                                                     "rollouts": len(rows)}, indent=2))
    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=len(rows), initial=len(rows) - len(todo), unit="rollout", desc=exp.spec.name)
    for res in BACKENDS[backend](_tasks(exp, todo), workers):
        _append(results, res)
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    final = read_results(results)
    keys = {r.key for r in rows}
    final = sorted((r for r in final if r["key"] in keys), key=lambda r: int(r["index"]))
    _rewrite(results, final)
    summary = summarise(final, sector=exp.spec.random.sector if exp.spec.random else None)
    summary.update({"experiment": exp.spec.name, "rollouts": len(final)})
    from bipedsim.io import atomic_write_json

    atomic_write_json(out / "summary.json", summary)
    polar_plot(final, out / "push_polar.png", fan=exp.spec.random is None)
    return summary


def _rewrite(path: Path, rows: list[dict[str, str]]) -> None:
    import io

    from bipedsim.io import atomic_write_text

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
    start time counts as one phase, "random start"."""
    groups: dict[tuple[str, float, str], list[tuple[float, bool]]] = {}

    def direction(r: dict[str, str]) -> float:
        d = float(r["direction"])
        return d if sector is None else (round(d / sector) * sector) % 360.0

    for r in rows:
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
    for r in rows:
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
    import numpy as np

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
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.1), fontsize=8)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    os.replace(tmp, path)
