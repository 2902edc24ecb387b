"""Data the project generates and ships: the built-in reference walk (and later, sample creatures).

Every file here is made by code in the package; ``tests/test_data.py`` regenerates each one and checks
that it equals the shipped file.
"""

from __future__ import annotations

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent

#: The built-in reference walk, written by :func:`bipedsim.motion.gaitgen.walk_bvh_motion` with the
#: default :class:`~bipedsim.motion.gaitgen.WalkParams`.
BUILTIN_WALK = DATA_DIR / "walk.bvh"

#: Decimals written per value in the shipped BVH files (0.1 micrometre / 1e-6 degree).
SHIPPED_BVH_PRECISION = 6


def builtin_walk_path() -> Path:
    return BUILTIN_WALK


def builtin_walk_text() -> str:
    """The text of the built-in walk BVH, generated afresh."""
    from bipedsim.motion.bvh import bvh_text
    from bipedsim.motion.gaitgen import walk_bvh_motion

    return bvh_text(walk_bvh_motion(), precision=SHIPPED_BVH_PRECISION)


def regenerate(folder: Path = DATA_DIR) -> list[Path]:
    """Write every generated data file into ``folder``; returns the paths written."""
    from bipedsim.io import atomic_write_text

    out = folder / BUILTIN_WALK.name
    atomic_write_text(out, builtin_walk_text())
    return [out]
