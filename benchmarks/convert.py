"""Model building: build time (BVH skeleton -> MJCF text) and MuJoCo compile time per model, plus
retargeting time, in one run. Baseline: compiling the same XML with MuJoCo (the ratio says how much
bipedsim adds on top of MuJoCo's own work).

    python benchmarks/convert.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import mujoco

from bipedsim.data import BUILTIN_WALK
from bipedsim.model import build_model
from bipedsim.motion import load_bvh
from bipedsim.reference import retarget

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"


def best(fn, repeat: int = 3) -> float:
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def main() -> int:
    jobs = [(BUILTIN_WALK, "humanoid")]
    if SHARED.is_dir():
        jobs += [(p, "humanoid") for p in sorted(SHARED.glob("human/*.bvh"))]
        jobs += [(p, "creature") for p in sorted(SHARED.glob("animal/*.bvh"))]
    else:
        print(f"(shared BVH data not found at {SHARED}: built-in walk only)")
    print(f"{'file':44s} {'profile':9s} {'bodies':>6s} {'build ms':>9s} {'compile ms':>10s} "
          f"{'build/compile':>13s} {'retarget ms':>11s} {'frames':>6s}")
    for path, prof in jobs:
        m = load_bvh(path)
        built = build_model(m, prof)
        t_build = best(lambda m=m, prof=prof: build_model(m, prof))
        t_comp = best(lambda built=built: mujoco.MjModel.from_xml_string(built.xml))
        t_ret = best(lambda m=m, built=built: retarget(m, built.model, plan=built.plan))
        print(f"{path.name[:44]:44s} {prof:9s} {built.summary()['bodies']:6d} {t_build * 1e3:9.1f} "
              f"{t_comp * 1e3:10.1f} {t_build / t_comp:13.1f} {t_ret * 1e3:11.1f} {m.num_frames:6d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
