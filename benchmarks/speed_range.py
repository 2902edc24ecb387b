"""The humanoid controller's speed range: generated walks (``motion.gaitgen.WalkParams``) over
speeds, cadences and step widths, each written as a BVH, read, built, retargeted and tracked for
``--seconds`` (default 20) with the default controller (or ``--config``), exactly as ``bipedsim run --bvh``
does. Per walk: outcome, fall time, achieved mean speed against the walk's own speed (the baseline: the
ratio is the acceptance measure, >= 0.7, ideally within +-25 %), tracking RMSE. A walk the generator
cannot make (a footprint out of the leg's reach) is listed as infeasible. These generated walks are the
controller's training set; the shared real walks (``benchmarks/real_walks.py``) are its test set.

A table on stdout and, with ``--csv``, a CSV written row by row (``--resume`` keeps the rows already
there).

    python benchmarks/speed_range.py                       # 32 walks, ~1-2 min on one core
    python benchmarks/speed_range.py --csv /tmp/speed.csv --resume
    python benchmarks/speed_range.py --config my.yaml --speeds 1.2 1.5 --cadences 110 129
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from rows import Rows

from bipedsim.errors import BipedsimError, ModelError
from bipedsim.motion.bvh import bvh_text
from bipedsim.motion.gaitgen import WalkParams, walk_bvh_motion
from bipedsim.sim import runner
from bipedsim.sim.rollout import RolloutSpec

SPEEDS = (0.6, 0.8, 1.0, 1.2, 1.35, 1.5)  #: m/s, the range of the shared human walks (0.5-1.5 m/s)
CADENCES = (100.0, 110.0, 120.0, 129.0, 135.0)  #: steps/min (the generator refuses 115, 132, 140 at >= 1 m/s)
WIDTHS = (0.2,)  #: m between the footprints (the generator's default)
#: extra walks at other step widths: (speed, cadence, width)
EXTRA = ((0.8, 110.0, 0.12), (0.8, 110.0, 0.25), (1.2, 129.0, 0.12), (1.2, 129.0, 0.25),
         (1.5, 110.0, 0.12), (1.5, 110.0, 0.25))
FIELDS = ["speed_mps", "cadence", "width_m", "outcome", "fall_time_s", "achieved_mps", "speed_ratio", "rmse_rad",
          "strikes", "wall_s", "reason"]


def key(speed: float, cadence: float, width: float) -> str:
    return f"{speed:g}/{cadence:g}/{width:g}"


def run_one(speed: float, cadence: float, width: float, seconds: float, config: str | None, folder: Path
            ) -> dict[str, object]:
    """One generated walk tracked for ``seconds``: the row of the table."""
    t0 = time.perf_counter()
    row: dict[str, object] = {"speed_mps": speed, "cadence": cadence, "width_m": width}
    try:
        motion = walk_bvh_motion(WalkParams(speed=speed, step_length=None, cadence=cadence, step_width=width))
    except ModelError as exc:
        return {**row, "outcome": "infeasible", "reason": str(exc)[:120]}
    path = folder / f"walk_{speed:g}_{cadence:g}_{width:g}.bvh"
    path.write_text(bvh_text(motion))
    try:
        sc = runner.load_scenario(config, path)
        out, _ = runner.run_scenario(sc, RolloutSpec(seconds=seconds))
    except BipedsimError as exc:
        return {**row, "outcome": "refused", "reason": str(exc)[:120], "wall_s": round(time.perf_counter() - t0, 1)}
    return {**row, "outcome": out.outcome, "fall_time_s": "" if out.fall_time_s is None else round(out.fall_time_s, 2),
            "achieved_mps": round(out.mean_speed_mps, 3), "speed_ratio": round(out.mean_speed_mps / speed, 2),
            "rmse_rad": round(out.tracking_rmse_rad, 3), "strikes": out.foot_strikes,
            "wall_s": round(time.perf_counter() - t0, 1), "reason": out.fall_reason or ""}


def passed(row: dict[str, object]) -> bool:
    """Walked the whole run at >= 70 % of the walk's speed."""
    ratio = row.get("speed_ratio")
    return row["outcome"] == "no_fall" and ratio not in ("", None) and float(ratio) >= 0.7  # type: ignore[arg-type]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per walk (default 20)")
    ap.add_argument("--config", default=None, help="controller YAML (default: the default controller)")
    ap.add_argument("--speeds", type=float, nargs="*", default=list(SPEEDS), help="m/s")
    ap.add_argument("--cadences", type=float, nargs="*", default=list(CADENCES), help="steps/min")
    ap.add_argument("--widths", type=float, nargs="*", default=list(WIDTHS), help="m between the footprints")
    ap.add_argument("--no-extra", action="store_true", help="leave out the extra step widths")
    ap.add_argument("--csv", default=None, help="also write the rows to this CSV, one at a time")
    ap.add_argument("--resume", action="store_true", help="keep the CSV's rows and run only the walks missing")
    args = ap.parse_args(argv)
    walks = [(v, c, w) for w in args.widths for v in args.speeds for c in args.cadences]
    walks += [x for x in ([] if args.no_extra else EXTRA) if x not in walks]
    rows = Rows(args.csv, FIELDS, args.resume, lambda r: key(float(r["speed_mps"]), float(r["cadence"]),
                                                             float(r["width_m"])))
    print(f"{'m/s':>5s} {'steps/min':>9s} {'width':>5s} {'outcome':10s} {'fall s':>6s} {'achieved':>8s} "
          f"{'ratio':>5s} {'RMSE':>6s} {'strk':>4s}")
    ok = feasible = 0
    with tempfile.TemporaryDirectory(prefix="bipedsim-speed-") as tmp:
        for v, c, w in walks:
            k = key(v, c, w)
            if k in rows.done:
                row: dict[str, object] = dict(rows.done[k])
            else:
                row = run_one(v, c, w, args.seconds, args.config, Path(tmp))
                rows.add(row)
            feasible += row["outcome"] != "infeasible"
            ok += passed(row)
            print(f"{float(v):5.2f} {float(c):9g} {float(w):5.2f} {row['outcome']!s:10s} "
                  f"{row.get('fall_time_s', '')!s:>6s} {row.get('achieved_mps', '')!s:>8s} "
                  f"{row.get('speed_ratio', '')!s:>5s} {row.get('rmse_rad', '')!s:>6s} {row.get('strikes', '')!s:>4s}")
    rows.close()
    print(f"{ok} of {feasible} feasible walks walked {args.seconds:g} s without a fall at >= 70 % of their speed "
          f"({len(walks) - feasible} infeasible for the generator)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
