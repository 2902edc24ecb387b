"""Whole-clip tracking against the looped cycle, on every clip given: the table of docs/results.md.

    python benchmarks/whole_clips.py CLIP.bvh ... [--dir DIR] [--jobs N] [--csv F] [--config YAML]

Per clip, three ways, each run for max(20 s, the clip's duration) with the default settings (or those of a
controller file, ``--config``, layered over them as ``bipedsim run CONFIG`` does):

- ``cycle``: the clip's best gait cycle looped from its first strike (``source: cycle``), no search --
  what ``bipedsim run --bvh`` did before whole-clip tracking;
- ``whole``: the whole clip, then its cycle looped (``source: clip``), feedback alone (``--no-reconstruct``);
- ``default``: what ``bipedsim run --bvh`` does: the whole clip with its searched feed-forward
  correction where that tracks better, the looped cycle where the whole clip falls sooner, and the
  search's CPU time.

Printed per clip and way: the outcome (or the fall time), and the fidelity over the clip's own duration
(sim/fidelity.py): the largest distance of the root path from the clip's (m), the share of the clip's
path covered (%), the speed ratio, the joint-position error (cm) and whether the issue's goal is met (no
fall, the path within max(0.5 m, 10 % of the clip's path), 70-150 % of it). Clips run in ``--jobs``
processes (each search on one); the summary counts the clips meeting the goal each way.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

from bipedsim.control.settings import load_controller
from bipedsim.errors import BipedsimError
from bipedsim.sim.fidelity import measure_fidelity
from bipedsim.sim.recorder import Recorder
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

WAYS = ("cycle", "whole", "default")
#: the shortest run (s): a clip shorter than this is run on past its end (the loop, or standing)
MIN_RUN_S = 20.0


#: the controller file the ways run with (``--config``; None: the defaults), set before the workers fork
CONFIG: str | None = None


def one(job: tuple[str, str]) -> dict[str, object]:
    """One clip one way: its row."""
    path, way = job
    row: dict[str, object] = {"clip": Path(path).name, "way": way}
    c0 = time.process_time()
    try:
        base = load_controller(CONFIG)
        cfg = replace(base, source="cycle") if way == "cycle" else base
        if way == "default":
            cfg = replace(cfg, reconstruct=replace(cfg.reconstruct, workers=1))
        sc = load_scenario(cfg, path, reconstruct=way == "default")
        row["search_cpu_s"] = round(time.process_time() - c0, 1) if way == "default" else ""
        row["search"] = sc.extra.get("reconstruct", "")
        seconds = max(MIN_RUN_S, sc.clip.duration)
        rec = Recorder(sc.built.model, seconds=seconds)  # at bipedsim run's rate: its fidelity, to the cm
        out, ctrl = run_scenario(sc, RolloutSpec(seconds=seconds), hooks=[rec])
        tr = rec.trajectory()
        fid = measure_fidelity(sc.built.model, tr.time, tr.qpos, sc.clip.qpos, sc.clip.frame_time,
                               ctrl.start_frame(), run_seconds=out.sim_seconds)
        row.update(clip_s=round(sc.clip.duration, 1), run_s=round(seconds, 1), outcome=out.outcome,
                   fall_s=out.fall_time_s if out.fall_time_s is None else round(out.fall_time_s, 2))
        if fid is not None:
            row.update(path_max_m=round(fid.path_max_m, 2), path_pct=round(100 * (fid.path_ratio or 0.0)),
                       speed_x=round(fid.speed_ratio or 0.0, 2), joint_cm=round(fid.joint_error_cm, 1),
                       goal=bool(fid.path_ok and out.outcome == "no_fall"))
    except Exception as exc:  # a clip the project refuses is a row saying why, not the end of the table
        row.update(outcome="error", error=f"{type(exc).__name__}: {exc}"[:300])
    row["cpu_s"] = round(time.process_time() - c0, 1)
    return row


def _line(r: dict[str, object]) -> str:
    if r.get("outcome") == "error":
        return f"{r['clip'][:40]:40s} {r['way']:6s} error: {r.get('error')}"
    out = "no fall" if r.get("outcome") == "no_fall" else f"fell {r.get('fall_s')} s"
    return (f"{r['clip'][:40]:40s} {r['way']:6s} {out:12s} path {r.get('path_max_m', '-')} m "
            f"{r.get('path_pct', '-')} % speed x{r.get('speed_x', '-')} joints {r.get('joint_cm', '-')} cm "
            f"goal {'met' if r.get('goal') else 'missed'}"
            + (f"  (search {r['search_cpu_s']} CPU s)" if r.get("search_cpu_s") not in ("", None) else ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("clips", nargs="*", help="BVH files")
    ap.add_argument("--dir", action="append", default=[], help="also every .bvh under this folder (recursive)")
    ap.add_argument("--ways", nargs="*", default=list(WAYS), choices=WAYS)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--csv", default=None, help="write the rows here too")
    ap.add_argument("--jsonl", default=None, help="append each row here as it is done (one JSON object a line)")
    ap.add_argument("--config", default=None, help="a controller YAML layered over the defaults, as `bipedsim run "
                    "CONFIG` takes it: every way runs with it (default: the defaults)")
    args = ap.parse_args()
    global CONFIG
    CONFIG = args.config
    try:
        load_controller(CONFIG)  # a bad file is refused here, once, not in every row
    except BipedsimError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    files = list(args.clips) + [str(p) for d in args.dir for p in sorted(Path(d).rglob("*.bvh"))]
    if not files:
        ap.error("no clips: give BVH files or --dir")
    jobs = [(f, w) for f in files for w in args.ways]
    # the longest clips first, so they do not finish last alone
    jobs.sort(key=lambda j: -os.path.getsize(j[0]) * (4 if j[1] == "default" else 1))
    rows = []
    with multiprocessing.get_context("fork").Pool(max(1, args.jobs)) as pool:
        for r in pool.imap_unordered(one, jobs):
            rows.append(r)
            print(_line(r), flush=True)
            if args.jsonl:
                with open(args.jsonl, "a") as f:
                    f.write(json.dumps(r) + "\n")
    rows.sort(key=lambda r: (str(r["clip"]), WAYS.index(str(r["way"]))))
    print()
    for w in args.ways:
        mine = [r for r in rows if r["way"] == w]
        print(f"{w:6s}: goal met on {sum(bool(r.get('goal')) for r in mine)} of {len(mine)} clips, no fall on "
              f"{sum(r.get('outcome') == 'no_fall' for r in mine)}")
    if args.csv:
        keys = sorted({k for r in rows for k in r})
        with open(args.csv, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=keys)
            wr.writeheader()
            wr.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
