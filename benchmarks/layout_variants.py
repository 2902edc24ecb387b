"""The same clips in other file layouts: a probe for the files users bring that we do not have.

Each BVH file given is read as bipedsim reads it and written again in every layout below, into ``OUT``
(``<name>__<variant>.bvh``); run those through a benchmark to see whether a capability depends on how a
file is written rather than on the motion in it:

    python benchmarks/layout_variants.py /tmp/variants ../shared/data/bvh/human/cmu_02_01_walk__holden31_crlf.bvh
    python benchmarks/real_walks.py --files /tmp/variants/*.bvh        # humans
    python benchmarks/creatures.py --animals /tmp/variants             # creatures (every BVH in the folder)

Variants (each one change from the file as read):
- ``30fps``, ``60fps``, ``120fps``: resampled (slerp / linear), skipped at the file's own rate;
- ``up``: the other up axis (Y up <-> Z up);
- ``metres``, ``cm``, ``inch``: the lengths in another unit, skipped for the file's own one (a creature
  file in inches reads as a smaller animal: nothing in it tells its unit);
- ``static_root``: under a new static root joint at the floor, the old root a 6-channel child (the layout
  of many game exports);
- ``in_place``: the travelling joint's horizontal translation held at its first frame (a walk in place,
  as game-animation exports often are);
- ``mirrored``: left and right exchanged.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from bipedsim.errors import BipedsimError
from bipedsim.motion.bvh import read_bvh, write_bvh
from bipedsim.motion.motion import Motion
from bipedsim.motion.reroot import add_static_root

UNITS = {"metres": 1.0, "cm": 0.01, "inch": 0.0254}


def _in_place(m: Motion) -> Motion:
    h = [i for i in range(3) if "xyz"[i] != m.up]
    out = m.copy()
    tj = m.travel_joint()
    if tj == 0:
        out.root_translation[:, h] = m.root_translation[0, h]
        if out.translations is not None:
            out.translations[:, 0, h] = m.root_translation[0, h]
    else:
        assert out.translations is not None
        out.translations[:, tj, h] = m.translations[0, tj, h]  # type: ignore[index]
    return out


def variants(m: Motion) -> dict[str, Callable[[], Motion]]:
    """The layouts of ``m`` (as read), by name; each made only when called."""
    out: dict[str, Callable[[], Motion]] = {}
    fps = 1.0 / m.frame_time
    for f in (30, 60, 120):
        if abs(fps - f) > 1.0:
            out[f"{f}fps"] = lambda f=f: m.resample(f)
    out["up"] = lambda: m.with_up("z" if m.up == "y" else "y")
    for name, unit in UNITS.items():
        if not np.isclose(m.unit, unit, rtol=0.02):
            out[name] = lambda unit=unit: m.in_metres().scaled(1.0 / unit)
    out["static_root"] = lambda: add_static_root(m)
    out["in_place"] = lambda: _in_place(m)
    out["mirrored"] = lambda: m.mirrored()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="folder for the variant files (made if missing)")
    ap.add_argument("files", nargs="+", help="BVH files")
    ap.add_argument("--only", nargs="*", default=None, help="only these variants (default: all)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for f in args.files:
        m, info = read_bvh(f)
        for name, make in variants(m).items():
            if args.only and name not in args.only:
                continue
            p = out / f"{Path(f).stem}__{name}.bvh"
            try:
                write_bvh(make(), p)
            except BipedsimError as exc:  # e.g. no left/right pairs to mirror
                print(f"{p}  skipped: {exc}")
                continue
            print(f"{p}  ({info.unit_scale:g} m per unit, {m.up} up, {1 / m.frame_time:.0f} fps as read)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
