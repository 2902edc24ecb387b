"""Bodies of other sizes (docs/controller.md, "Bodies of any size"): the shared walks that the default
controller walks at their own size, each remade as the walk of a body ``--sizes`` times as large at the
same Froude number (``Motion.similar``: lengths x s, time x sqrt(s)), tracked for ``--seconds`` with the
default controller, its settings scaled to the body (``body: {scale: true}``, the default) and, the
baseline, as written (``body: {scale: false}``). Per walk and size: runs at the goal (no fall, >= 70 % of
the clip's speed) and the mean time walked, both ways; the last line gives the totals and their ratio.
Inside the measured legs (0.78-0.94 m) nothing is scaled, so the two columns agree there.

    python benchmarks/body_sizes.py                      # 4 walks x 5 sizes x 2 seeds x 2 ways: ~2-4 min on 2 cores
    python benchmarks/body_sizes.py --sizes 0.7 1.4 --seeds 3 --csv /tmp/sizes.csv
    python benchmarks/body_sizes.py --config point.yaml  # e.g. body: {leg_min: 0.82, leg_max: 0.82}
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

from rows import Rows  # the benchmarks' resumable CSV (benchmarks/rows.py)

from bipedsim.motion.bvh import load_bvh, write_bvh

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh" / "human"
WALKS = ["cmu_02_01_walk__holden31_crlf.bvh", "cmu_02_02_walk__19joint_Hip_Abdomen.bvh", "cmu_02_02_walk__daz43.bvh",
         "games105_walk60__metres_crlf.bvh"]
FIELDS = ["file", "size", "scaled", "legs_m", "runs_ok", "runs", "mean_walked_s", "ratios"]


def run_one(job: tuple[str, float, bool, float, int, str, str | None]) -> dict[str, object]:
    from bipedsim.control.humanoid.simbicon import leg_length
    from bipedsim.control.humanoid.sources import clip_speed
    from bipedsim.control.settings import load_controller
    from bipedsim.sim import runner

    name, size, scaled, seconds, seeds, tmp, config = job
    path = Path(tmp) / f"{Path(name).stem}_x{size:g}.bvh"  # written by main
    cfg = load_controller(config)
    if not scaled:
        cfg = replace(cfg, body=replace(cfg.body, scale=False))
    sc = runner.load_scenario(cfg, path)
    outs = runner.run_seeds(sc, seconds, seeds)
    cv = clip_speed(sc.clip)
    ok = sum(o.outcome == "no_fall" and o.mean_speed_mps >= 0.7 * cv for o in outs)
    walked = [seconds if o.fall_time_s is None else o.fall_time_s for o in outs]
    return {"file": name, "size": size, "scaled": scaled, "legs_m": round(leg_length(sc.built.model), 3),
            "runs_ok": ok, "runs": len(outs), "mean_walked_s": round(sum(walked) / len(walked), 2),
            "ratios": " ".join(f"{o.mean_speed_mps / cv:.2f}" for o in outs)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[0.8, 0.9, 1.0, 1.1, 1.25])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--seeds", type=int, default=2, help="seed 0, then seeds with initial noise (default 2)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--config", default=None,
                    help="controller YAML (default: the default controller); its body: section sets the measured legs")
    ap.add_argument("--csv", default=None, help="also write the rows to this CSV, one at a time")
    ap.add_argument("--resume", action="store_true", help="keep the CSV's rows and run only the missing ones")
    args = ap.parse_args(argv)
    walks = [w for w in WALKS if (SHARED / w).exists()]
    if not walks:
        print(f"no shared walks found at {SHARED}")
        return 1

    def key(r: dict[str, object]) -> str:
        return f"{r['file']}|{float(r['size']):g}|{r['scaled']}"  # type: ignore[arg-type]

    rows = Rows(args.csv, FIELDS, args.resume, key=key)
    with tempfile.TemporaryDirectory() as tmp:
        jobs = [(w, s, sc, args.seconds, args.seeds, tmp, args.config)
                for w in walks for s in args.sizes for sc in (True, False)]
        todo = [j for j in jobs if key({"file": j[0], "size": j[1], "scaled": j[2]}) not in rows.done]
        for w, s in {(j[0], j[1]) for j in todo}:  # each similar walk written once, before the workers read it
            write_bvh(load_bvh(SHARED / w).similar(s), Path(tmp) / f"{Path(w).stem}_x{s:g}.bvh")
        with ProcessPoolExecutor(max(1, args.workers)) as ex:
            new = list(ex.map(run_one, todo))
    for r in new:
        rows.add(r)
    rows.close()
    got = {key(r): r for r in [*rows.done.values(), *new]}
    print(f"{'walk':34s} {'size':>5s} {'legs m':>6s}   {'scaled: goal, walked s':24s} "
          f"{'as written: goal, walked s':26s}")
    tot = {True: [0, 0, 0.0], False: [0, 0, 0.0]}
    for w in walks:
        for s in args.sizes:
            cells = []
            for sc in (True, False):
                r = got[key({"file": w, "size": s, "scaled": sc})]
                n, ok, mw = int(r["runs"]), int(r["runs_ok"]), float(r["mean_walked_s"])  # type: ignore[arg-type]
                tot[sc][0] += ok
                tot[sc][1] += n
                tot[sc][2] += mw * n
                cells.append(f"{ok}/{n}, {mw:5.1f} ({r['ratios']})")
            legs = got[key({"file": w, "size": s, "scaled": True})]["legs_m"]
            print(f"{w[:34]:34s} {s:5.2f} {float(legs):6.3f}   {cells[0]:24s} {cells[1]:26s}")  # type: ignore[arg-type]
    (g1, n1, w1), (g0, n0, w0) = tot[True], tot[False]
    print(f"total: scaled {g1}/{n1} at the goal, {w1:.1f} s walked; as written {g0}/{n0}, {w0:.1f} s; "
          f"walked ratio {w1 / max(w0, 1e-9):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
