"""A sweep's summary: per controller, push direction and phase the largest magnitude survived and the
recovery threshold (``summary.json``), the polar plot of the outcomes (``push_polar.png``), and the lines
``bipedsim sweep`` prints."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from bipedsim.files import (
    save_figure,
)
from bipedsim.sim.rollout import PUSH_NOT_APPLIED


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
