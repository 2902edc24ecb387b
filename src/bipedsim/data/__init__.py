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


#: The built-in humanoid, built from the built-in walk's skeleton with the default profile.
BUILTIN_HUMANOID = DATA_DIR.parent.parent.parent / "models" / "mjcf" / "humanoid.xml"


def builtin_humanoid_xml() -> str:
    """The built-in humanoid's MJCF text, built afresh from the shipped walk."""
    from bipedsim.model import build_model
    from bipedsim.motion import load_bvh

    return build_model(load_bvh(BUILTIN_WALK), "humanoid", name="humanoid").xml


def builtin_humanoid_path() -> Path:
    """The checked-in ``models/mjcf/humanoid.xml`` when running from a checkout, else a copy built
    into the user's cache folder on first use."""
    if BUILTIN_HUMANOID.is_file():
        return BUILTIN_HUMANOID
    import os

    from bipedsim.io import atomic_write_text

    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "bipedsim" / "humanoid.xml"
    if not cache.is_file():
        atomic_write_text(cache, builtin_humanoid_xml())
    return cache


def regenerate(folder: Path = DATA_DIR, models: Path | None = None) -> list[Path]:
    """Write every generated data file (the walk into ``folder``, the humanoid into ``models``)."""
    from bipedsim.io import atomic_write_text

    out = folder / BUILTIN_WALK.name
    atomic_write_text(out, builtin_walk_text())
    hum = (models or BUILTIN_HUMANOID.parent) / BUILTIN_HUMANOID.name
    atomic_write_text(hum, builtin_humanoid_xml())
    return [out, hum]
