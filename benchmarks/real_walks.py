"""Real motion-capture walks tracked by the humanoid controller: every human file in
``../shared/data/bvh/human/`` converted, retargeted and tracked for ``--seconds`` (default 20) with the
default controller (or ``--config``). Per file: outcome, fall time, achieved mean speed against the
clip's own average horizontal speed (the baseline: the ratio is the acceptance measure, >= 0.7), the
the COM's progress along the reference's own course over the run (``course_ratio``: against the clip's
speed; ``off_m``: its offset across the course at the end, a walk crabbing off its line walks a
displacement ratio well above its course ratio), the reference loop's speed, tracking RMSE and foot
strikes; a file that cannot be tracked (no gait cycle:
not a walk) is listed as refused with the reason. A table on stdout and, with ``--csv``, a CSV written
row by row (``--resume`` keeps the rows already there).

Then the run against the clip over the clip's own duration (bipedsim.sim.fidelity, what ``bipedsim run``
prints as ``fidelity``): ``clip_s`` the clip's seconds from the run's start frame, ``covered`` the share of
them simulated before a fall, ``path_max_m`` / ``path_final_m`` the largest and final distance between the
root paths (smoothed over 1 s, aligned at the start), ``path_pct`` the body's path length in % of the
clip's (goal 70-150 %), ``clip_speed_x`` the body's mean horizontal speed over the clip's, ``joint_cm`` the
mean joint-position error relative to the pelvis (heading frame), and ``path_ok`` whether the goal was met
(the whole clip simulated, within max(0.5 m, 10 % of the clip's path) of it, covering 70-150 % of it).

    python benchmarks/real_walks.py                 # ~1-3 min on one core
    python benchmarks/real_walks.py --seconds 60 --csv /tmp/walks.csv
    python benchmarks/real_walks.py --feasible      # the legs made feasible first (reference/feasible.py)
    python benchmarks/real_walks.py --seeds 3       # seeds 0-2 (0.02 rad/s of initial noise on 1, 2): medians

With ``--seeds N`` each file is walked N times (seed 0 without noise, seeds 1..N-1 with 0.02 rad/s of
initial velocity noise): the row's outcome is a fall if any run fell (its fall time the earliest), the
speeds and ratios are the runs' medians and ``runs_ok`` counts the runs that walked the whole time at
>= 70 % of the clip's speed (the fidelity figures are the runs' medians, ``path_ok`` counts the runs that
met the path goal). Single runs of a capture vary (CMU 02_01 at seed 0 crabs off its line at
0.66 of its speed, seeds 1-5 walk at 0.77-0.82), so the goal column counts a file by its median.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from rows import Rows  # the benchmarks' resumable CSV (benchmarks/rows.py)

from bipedsim.control.humanoid.sources import clip_speed
from bipedsim.control.settings import load_controller
from bipedsim.errors import BipedsimError
from bipedsim.sim import runner
from bipedsim.sim.fidelity import Fidelity
from bipedsim.sim.outputs import run_fidelity
from bipedsim.sim.recorder import Recorder
from bipedsim.sim.rollout import Outcome, RolloutSpec

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"
FIELDS = ["file", "outcome", "fall_time_s", "speed_mps", "clip_speed_mps", "speed_ratio", "course_ratio", "off_m",
          "loop_speed_mps",
          "rmse_rad", "strikes", "runs_ok", "wall_s", "reason",
          "clip_s", "covered", "path_max_m", "path_final_m", "clip_path_m", "path_pct", "clip_speed_x", "joint_cm",
          "path_ok"]


def run_recorded(sc: runner.Scenario, seconds: float, seeds: int) -> list[tuple[Outcome, Fidelity | None]]:
    """:func:`runner.run_seeds`'s rollouts (seed 0 as the clip starts, later seeds with its initial noise),
    each recorded and judged against the clip (None: nothing to compare, or key poses)."""
    noise = runner.SEED_NOISE.get(sc.profile, runner.SEED_NOISE["humanoid"])
    feet = len(sc.foot_names())
    out = []
    for s in range(seeds):
        rec = Recorder(sc.built.model, seconds=seconds, feet=feet)
        o, ctrl = runner.run_scenario(sc, RolloutSpec(seconds=seconds, seed=s, init_noise=noise if s else 0.0),
                                      hooks=[rec])
        out.append((o, run_fidelity(sc, rec, float(ctrl.start_frame()) if sc.tracks_clip else None, o)))
    return out


def fidelity_columns(fids: list[Fidelity | None]) -> dict[str, object]:
    """The fidelity columns: each figure's median over the runs that have it, and the runs meeting the goal."""
    got = [f for f in fids if f is not None]
    if not got:
        return {}

    def med(name: str, scale: float = 1.0, digits: int = 2) -> object:
        xs = [getattr(f, name) for f in got if getattr(f, name) is not None]
        if not xs:
            return ""
        v = round(scale * float(np.median(xs)), digits)
        return int(v) if digits == 0 else v

    return {"clip_s": med("clip_seconds"), "covered": med("covered"), "path_max_m": med("path_max_m"),
            "path_final_m": med("path_final_m"), "clip_path_m": med("clip_path_m"),
            "path_pct": med("path_ratio", 100.0, 0), "clip_speed_x": med("speed_ratio"),
            "joint_cm": med("joint_error_cm", digits=1), "path_ok": f"{sum(f.path_ok for f in got)}/{len(fids)}"}


def run_one(path: Path, seconds: float, config: str | None, feasible: bool = False,
            seeds: int = 1) -> dict[str, object]:
    t0 = time.perf_counter()
    try:
        cfg = load_controller(config)
        if feasible:  # as `reference: {feasible: true}` in the config
            cfg = replace(cfg, reference=replace(cfg.reference, feasible=True))
        sc = runner.load_scenario(cfg, path)
        runs = run_recorded(sc, seconds, max(1, seeds))
    except BipedsimError as exc:
        return {"file": path.name, "outcome": "refused", "reason": str(exc)[:200],
                "wall_s": round(time.perf_counter() - t0, 1)}
    outs = [o for o, _ in runs]
    cv = clip_speed(sc.clip)
    falls = [o for o in outs if o.outcome != "no_fall"]
    first = min(falls, key=lambda o: o.fall_time_s or 0.0) if falls else outs[0]

    def med(xs: list[float]) -> float:
        return float(np.median(xs))

    courses = [o.course_speed_mps for o in outs if o.course_speed_mps is not None]
    offsets = [o.course_offset_m for o in outs if o.course_offset_m is not None]
    ok = sum(o.outcome == "no_fall" and cv > 0 and o.mean_speed_mps >= 0.7 * cv for o in outs)
    return {"file": path.name, "outcome": first.outcome,
            "fall_time_s": "" if first.fall_time_s is None else round(first.fall_time_s, 2),
            "speed_mps": round(med([o.mean_speed_mps for o in outs]), 3), "clip_speed_mps": round(cv, 3),
            "speed_ratio": round(med([o.mean_speed_mps for o in outs]) / cv, 2) if cv > 0 else "",
            "course_ratio": round(med(courses) / cv, 2) if cv > 0 and courses else "",
            "off_m": round(med(offsets), 2) if offsets else "",
            "loop_speed_mps": round(outs[0].reference_speed_mps, 3),
            "rmse_rad": round(med([o.tracking_rmse_rad for o in outs]), 3),
            "strikes": int(med([o.foot_strikes for o in outs])), "runs_ok": f"{ok}/{len(outs)}",
            "wall_s": round(time.perf_counter() - t0, 1), "reason": first.fall_reason or "",
            **fidelity_columns([f for _, f in runs])}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per walk (default 20)")
    ap.add_argument("--config", default=None, help="controller YAML (default: the default controller)")
    ap.add_argument("--feasible", action="store_true",
                    help="track the feasible lower-body reference (as `reference: {feasible: true}` in the config)")
    ap.add_argument("--csv", default=None, help="also write the rows to this CSV, one at a time")
    ap.add_argument("--resume", action="store_true", help="keep the CSV's rows and run only the files missing")
    ap.add_argument("--files", nargs="*", default=None, help="only these BVH files (default: every shared human)")
    ap.add_argument("--seeds", type=int, default=1,
                    help="runs per file: seed 0, then seeds 1..N-1 with 0.02 rad/s of initial noise (medians)")
    args = ap.parse_args(argv)
    files = [Path(f) for f in args.files] if args.files else sorted(SHARED.glob("human/*.bvh"))
    if not files:
        print(f"no BVH files (shared data not found at {SHARED})")
        return 1
    rows = Rows(args.csv, FIELDS, args.resume, key=lambda r: r["file"])
    done = rows.done
    print(f"{'file':46s} {'outcome':8s} {'fall s':>6s} {'m/s':>5s} {'clip':>5s} {'ratio':>5s} {'course':>6s} "
          f"{'off m':>6s} {'loop':>5s} {'RMSE':>6s} {'strk':>4s} {'runs':>5s} {'wall s':>6s} "
          f"{'clip s':>6s} {'cov':>4s} {'path m':>6s} {'final':>5s} {'path%':>5s} {'spd x':>5s} {'jnt cm':>6s} "
          f"{'goal':>4s}")
    ok = on_path = 0
    for p in files:
        row: dict[str, object] = (dict(done[p.name]) if p.name in done
                                  else run_one(p, args.seconds, args.config, args.feasible, args.seeds))
        if p.name not in done:
            rows.add(row)
        ratio = row.get("speed_ratio")
        if row["outcome"] == "no_fall" and ratio not in ("", None) and float(ratio) >= 0.7:  # type: ignore[arg-type]
            ok += 1
        goal = str(row.get("path_ok") or "")
        if goal and goal.split("/")[0] == goal.split("/")[1]:  # every run of the file met the path goal
            on_path += 1
        print(f"{p.name[:46]:46s} {row['outcome']!s:8s} {row.get('fall_time_s', '')!s:>6s} "
              f"{row.get('speed_mps', '')!s:>5s} {row.get('clip_speed_mps', '')!s:>5s} "
              f"{row.get('speed_ratio', '')!s:>5s} {row.get('course_ratio', '')!s:>6s} {row.get('off_m', '')!s:>6s} "
              f"{row.get('loop_speed_mps', '')!s:>5s} "
              f"{row.get('rmse_rad', '')!s:>6s} {row.get('strikes', '')!s:>4s} {row.get('runs_ok', '')!s:>5s} "
              f"{row.get('wall_s', '')!s:>6s} "
              f"{row.get('clip_s', '')!s:>6s} {row.get('covered', '')!s:>4s} {row.get('path_max_m', '')!s:>6s} "
              f"{row.get('path_final_m', '')!s:>5s} {row.get('path_pct', '')!s:>5s} "
              f"{row.get('clip_speed_x', '')!s:>5s} {row.get('joint_cm', '')!s:>6s} {row.get('path_ok', '')!s:>4s}"
              + (f"  {row['reason']}" if row.get("reason") and row["outcome"] == "refused" else ""))
    rows.close()
    print(f"{ok} of {len(files)} files walked {args.seconds:g} s without a fall at >= 70 % of the clip's speed")
    print(f"{on_path} of {len(files)} files followed the clip's root path over its duration (within max(0.5 m, "
          f"10 % of its path), covering 70-150 % of it)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
