"""Parse + forward kinematics of the largest shared BVH file: bipedsim vs bvhio, in one run.

    python benchmarks/bvh_parse.py [--repeat N]

Prints both times and the ratio (target: bipedsim >= 10x faster than ``bvhio.readAsHierarchy``
followed by reading every joint's world position on every frame).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    files = sorted(SHARED.glob("*/*.bvh"), key=lambda p: p.stat().st_size)
    if not files:
        print(f"skipped: shared BVH data not found at {SHARED}")
        return 0
    path = files[-1]
    from bipedsim.motion import read_bvh

    def ours() -> None:
        m, _ = read_bvh(path)
        m.fk()

    def theirs() -> None:
        import bvhio

        root = bvhio.readAsHierarchy(str(path))
        layout = [j for j, _, _ in root.layout()]
        for f in range(len(root.Keyframes)):
            root.loadPose(f)
            for j in layout:
                j.PositionWorld  # noqa: B018 - evaluates world-space FK

    def best(fn) -> float:
        ts = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        return min(ts)

    t_ours, t_ref = best(ours), best(theirs)
    print(f"file: {path.name} ({path.stat().st_size / 1e6:.2f} MB)")
    print(f"bipedsim read_bvh + fk : {t_ours * 1e3:8.1f} ms")
    print(f"bvhio hierarchy + FK   : {t_ref * 1e3:8.1f} ms")
    print(f"ratio (bvhio / bipedsim): {t_ref / t_ours:.1f}x  (target >= 10x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
