"""What the per-clip reconstruction search costs, against a plain rollout of the same clip, in one run.

    python benchmarks/reconstruct.py [--bvh FILE ...] [--workers N]

For each clip (default: the built-in walk): the search's wall and CPU time, per second of clip, and as a
ratio to one plain rollout over the clip's duration (the controller alone, run in this process first);
then whether a run with the correction and one without walk the clip, with the fidelity of each (root
path's largest distance, share of the clip's path, speed ratio). The issue's budget is 2 minutes for a
10 s clip on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace

from bipedsim.sim.outputs import run_fidelity
from bipedsim.sim.reconstruct import reconstruct, search_span, search_workers
from bipedsim.sim.recorder import Recorder
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


def _run(sc, seconds: float) -> tuple[str, str]:
    rec = Recorder(sc.built.model, seconds=seconds)
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=seconds), hooks=[rec])
    fid = run_fidelity(sc, rec, ctrl.start_frame(), out)
    if fid is None:
        return out.outcome, "-"
    what = (f"path within {fid.path_max_m:.2f} m, {100 * (fid.path_ratio or 0):.0f} % of its path, speed "
            f"x{fid.speed_ratio or 0:.2f}, joints {fid.joint_error_cm:.1f} cm, path goal "
            f"{'met' if fid.path_ok else 'missed'}")
    return (out.outcome if out.outcome == "no_fall" else f"fell {out.fall_time_s:.1f} s"), what


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--bvh", nargs="*", default=[None], help="clips (default: the built-in walk)")
    ap.add_argument("--workers", type=int, default=None, help="search processes (default: the settings')")
    ap.add_argument("--seconds", type=float, default=20.0, help="length of the runs after the search")
    args = ap.parse_args()
    for bvh in args.bvh:
        sc = load_scenario(None, bvh, reconstruct=False)
        rc = sc.cfg.reconstruct if args.workers is None else replace(sc.cfg.reconstruct, workers=args.workers)
        ctrl = sc.controller()
        span = search_span(ctrl)
        t0 = time.perf_counter()
        plain, _ = run_scenario(sc, RolloutSpec(seconds=span))
        plain_s = time.perf_counter() - t0
        w0, c0 = time.perf_counter(), os.times()
        try:
            corr = reconstruct(sc.built.model, ctrl, rc, sc.fall_criteria(), workers=search_workers(rc))
        finally:
            ctrl.restore_model()
        wall = time.perf_counter() - w0
        c1 = os.times()
        cpu = (c1.user - c0.user) + (c1.children_user - c0.children_user)
        name = "built-in walk" if bvh is None else os.path.basename(bvh)
        done = 0.0 if corr is None else len(corr.starts) * rc.window_s
        print(f"{name}: {span:.1f} s of clip searched ({min(done, span):.1f} s walked) in {wall:.1f} s wall, "
              f"{cpu:.1f} s CPU on {search_workers(rc)} processes: {cpu / span:.1f} CPU s per clip second, "
              f"{cpu / max(plain_s, 1e-9):.0f}x a plain rollout of the clip ({plain_s:.2f} s)")
        for label, c in (("without correction", None), ("with correction", corr)):
            outcome, what = _run(replace(sc, correction=c), max(args.seconds, span))
            print(f"  {label:19s}: {outcome:8s} {what}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
