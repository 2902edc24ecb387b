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
    rule = summary.get("rule")
    by = f" by {rule['survive']} of {rule['replicas']} replicas" if rule else ""
    for d, v in summary["largest_survived_per_direction_n"].items():
        c = counts.get(d, {"survived": 0, "rollouts": 0})
        every = (f"every {what} survived up to {v:g} N{by}" if v is not None
                 else f"no magnitude survived{by} in every {what}")
        lines.append(f"  direction {d:>5}{width} deg: {c['survived']}/{c['rollouts']} survived; {every}")
    for label, per_dir in summary.get("largest_survived_per_setting_n", {}).items():
        shown = ", ".join(f"{d} deg {'-' if v is None else f'{v:g} N'}" for d, v in per_dir.items())
        lines.append(f"  {label}: {shown}")
    extra = ", thresholds.md" if rule else ""
    lines.append(f"wrote {out_dir}/results.csv, summary.json, push_polar.png{extra}")
    return "\n".join(lines)


def _phase_label(r: dict[str, str]) -> str:
    return f"state {r['state']} at {float(r['fraction']):.2f}" if r["state"] else f"t={float(r['start']):.2f}s"


#: One group of a sweep's rows: (controller, body, ground, duration s, vertical N, direction deg, phase label).
GroupKey = tuple[str, str, str, float, float, float, str]


def _setting(ctl: str, body: str, duration: float, vertical: float, several_controllers: bool,
             ground: str | None = None) -> str:
    """A label for what a group's pushes share besides direction and phase: the body, the duration (s),
    the vertical force (N, when any), the controller (when the sweep has several) and the ground (when
    the sweep has several: ``ground``, else None)."""
    label = f"{body} {duration:g} s"
    if vertical:
        label += f" vertical {vertical:g} N"
    if several_controllers:
        label += f" {Path(ctl).stem if ctl != 'default' else ctl}"
    if ground is not None:
        label += f" on {ground}"
    return label


def _grounds(groups: list[dict[str, Any]]) -> bool:
    """Whether a summary's groups walk on more than one ground."""
    return len({g.get("ground", "flat") for g in groups}) > 1


def _group_setting(g: dict[str, Any], several: bool, grounds: bool) -> str:
    """:func:`_setting` of one summary group."""
    return _setting(g["controller"], g["body"], g["duration_s"], g["vertical_n"], several,
                    g.get("ground", "flat") if grounds else None)


def threshold(ladder: dict[float, list[bool]], survive: int | None) -> float | None:
    """The largest magnitude (N) of ``ladder`` (magnitude -> the outcomes of its rows, True survived)
    survived at it and at every lower magnitude: at least ``survive`` rows survived each (None: every
    row); None when the lowest magnitude already fails."""
    best = None
    for m in sorted(ladder):
        oks = ladder[m]
        need = len(oks) if survive is None else survive
        if sum(oks) < need:
            break
        best = m
    return best


def summarise(rows: list[dict[str, str]], sector: float | None = None, survive: int | None = None,
              replicas: int | None = None) -> dict[str, Any]:
    """Per controller, body, duration, direction and phase: the largest magnitude survived, and the
    threshold: the largest magnitude survived at it and at every lower magnitude, by at least
    ``survive`` of the rows at each (a replicated grid's replicas; None: by every row). With ``sector``
    (random pushes), directions are binned into sectors that wide, centred on multiples of it, and every
    start time counts as one phase, "random start". Rollouts whose push did not happen
    (``push_not_applied``) count only in ``outcomes``: they neither survived nor failed a push.
    ``replicas``: how many each cell has, recorded with the rule."""
    groups: dict[GroupKey, dict[float, list[bool]]] = {}

    def direction(r: dict[str, str]) -> float:
        d = float(r["direction"])
        return d if sector is None else (round(d / sector) * sector) % 360.0

    pushed = [r for r in rows if r["outcome"] != PUSH_NOT_APPLIED]  # no push: nothing survived
    for r in pushed:
        k = (r["controller"], r["body"], r.get("ground") or "flat", float(r["duration"]), float(r["vertical"]),
             direction(r), _phase_label(r) if sector is None else "random start")
        groups.setdefault(k, {}).setdefault(float(r["magnitude"]), []).append(r["outcome"] == "no_fall")
    several = len({k[0] for k in groups}) > 1
    grounds = len({k[2] for k in groups}) > 1
    out: dict[str, Any] = {"by_direction_and_phase": [], "outcomes": {}}
    per_setting: dict[str, dict[str, float | None]] = {}
    for (ctl, body, gnd, dur, vert, d, ph), ladder in sorted(groups.items()):
        survived = [m for m, oks in ladder.items() if any(oks)]
        thr = threshold(ladder, survive)
        entry: dict[str, Any] = {"controller": ctl, "direction_deg": d, "phase": ph, "body": body, "ground": gnd,
                                 "duration_s": dur, "vertical_n": vert,
                                 "largest_survived_n": max(survived) if survived else None,
                                 "survived_all_up_to_n": threshold(ladder, None), "threshold_n": thr,
                                 "rollouts": sum(len(v) for v in ladder.values())}
        if survive is not None:
            entry["survived_of"] = {f"{m:g}": f"{sum(oks)}/{len(oks)}" for m, oks in sorted(ladder.items())}
        out["by_direction_and_phase"].append(entry)
        per_dir = per_setting.setdefault(_setting(ctl, body, dur, vert, several, gnd if grounds else None), {})
        key = f"{d:g}"
        cur = per_dir.get(key, float("inf"))
        per_dir[key] = None if thr is None or cur is None else min(cur, thr)
    for r in rows:
        out["outcomes"][r["outcome"]] = out["outcomes"].get(r["outcome"], 0) + 1
    merged: dict[str, float | None] = {}
    for per_dir in per_setting.values():
        for key, v in per_dir.items():
            cur = merged.get(key, float("inf"))
            merged[key] = None if v is None or cur is None else min(cur, v)
    out["largest_survived_per_direction_n"] = merged
    if len(per_setting) > 1:
        out["largest_survived_per_setting_n"] = per_setting
    counts: dict[str, dict[str, int]] = {}
    for r in pushed:
        c = counts.setdefault(f"{direction(r):g}", {"survived": 0, "rollouts": 0})
        c["rollouts"] += 1
        c["survived"] += r["outcome"] == "no_fall"
    out["survived_per_direction"] = counts
    if sector is not None:
        out["direction_sector_deg"] = sector
    if survive is not None:
        out["rule"] = {"survive": survive, "replicas": replicas}
    return out


def threshold_table(summary: dict[str, Any]) -> str:
    """The thresholds of a grid's summary as Markdown tables, one per setting (body, duration, ...):
    a row per direction (degrees, 0 forward, 90 left), a column per phase; N, ``-`` where the lowest
    magnitude already failed."""
    by_setting: dict[str, dict[float, dict[str, float | None]]] = {}
    phases: dict[str, list[str]] = {}
    several = len({g["controller"] for g in summary["by_direction_and_phase"]}) > 1
    grounds = _grounds(summary["by_direction_and_phase"])
    for g in summary["by_direction_and_phase"]:
        label = _group_setting(g, several, grounds)
        by_setting.setdefault(label, {}).setdefault(g["direction_deg"], {})[g["phase"]] = g["threshold_n"]
        if g["phase"] not in phases.setdefault(label, []):
            phases[label].append(g["phase"])
    rule = summary.get("rule")
    how = (f"at least {rule['survive']} of {rule['replicas']} replicas" if rule else "every rollout")
    lines: list[str] = []
    for label, dirs in by_setting.items():
        cols = sorted(phases[label])
        lines += [f"{label}: largest push (N) survived by {how} at it and at every lower magnitude", "",
                  "| direction (deg) | " + " | ".join(cols) + " | all |",
                  "|---:|" + "---:|" * (len(cols) + 1)]
        for d in sorted(dirs):
            vals = [dirs[d].get(c) for c in cols]
            low = None if any(v is None for v in vals) else min(v for v in vals if v is not None)
            cells = ["-" if v is None else f"{v:g}" for v in vals + [low]]
            lines.append(f"| {d:g} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def polar_plot(rows: list[dict[str, str]], path: Path, fan: bool = True, survive: int | None = None) -> None:
    """The push outcomes in polar form (forward up, force radial, N) into ``path`` (PNG): each rollout a
    point, or with ``survive`` (a replicated grid) each cell's magnitude a point, survived when at least
    ``survive`` replicas survived it, and each phase's threshold per direction as a closed line."""
    if survive is not None:
        _threshold_plot(rows, path, survive)
        return
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


def _threshold_plot(rows: list[dict[str, str]], path: Path, survive: int) -> None:
    """:func:`polar_plot` of a replicated grid (one setting per line style when there are several)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = summarise(rows, survive=survive)
    groups = summary["by_direction_and_phase"]
    phases = sorted({g["phase"] for g in groups})
    several = len({g["controller"] for g in groups}) > 1
    grounds = _grounds(groups)
    settings = sorted({_group_setting(g, several, grounds) for g in groups})
    dirs = sorted({g["direction_deg"] for g in groups})
    gap = min((b - a for a, b in zip(dirs, dirs[1:] + [dirs[0] + 360.0])), default=360.0) if dirs else 360.0
    step = min(6.0, 0.5 * gap / len(phases)) if 1 < len(phases) <= 8 else 0.0
    offset = {p: (i - (len(phases) - 1) / 2) * step for i, p in enumerate(phases)}
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ("-", "--", ":", "-.")
    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    for ok, colour, marker, label in ((True, "tab:green", "o", f"survived by >= {survive} replicas"),
                                      (False, "tab:red", "x", f"survived by < {survive} replicas")):
        th, r = [], []
        for g in groups:
            for m, frac in g["survived_of"].items():
                if (int(frac.split("/")[0]) >= survive) == ok:
                    th.append(np.radians(g["direction_deg"] + offset[g["phase"]]))
                    r.append(float(m))
        if th:
            ax.scatter(th, r, c=colour, marker=marker, s=12, alpha=0.6, label=label)
    for si, setting in enumerate(settings):
        for pi, ph in enumerate(phases):
            sel = {g["direction_deg"]: g["threshold_n"] for g in groups
                   if g["phase"] == ph and _group_setting(g, several, grounds) == setting}
            ds = sorted(sel)
            if not ds:
                continue
            th = np.radians([d + offset[ph] for d in ds] + [ds[0] + offset[ph]])
            rr = [sel[d] or 0.0 for d in ds] + [sel[ds[0]] or 0.0]
            name = ph if len(settings) == 1 else f"{setting}, {ph}"
            ax.plot(th, rr, color=colours[pi % len(colours)], ls=styles[si % len(styles)], lw=1.2,
                    label=f"threshold, {name}")
    ax.set_theta_zero_location("N")  # forward up
    ax.set_title("push thresholds: direction (0 = forward, 90 = left) x force (N)")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="lower left", bbox_to_anchor=(-0.15, -0.15), fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
