"""The built-in humanoid: its MJCF built from the built-in walk's skeleton with the default profile."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from bipedsim import __version__, data
from bipedsim.files import atomic_write_text
from bipedsim.model.build import build_model
from bipedsim.model.profile import PROFILE_DIR
from bipedsim.motion import load_bvh


def builtin_humanoid_xml() -> str:
    """The built-in humanoid's MJCF text, built afresh from the shipped walk."""
    return build_model(load_bvh(data.BUILTIN_WALK), "humanoid", name="humanoid").xml


def builtin_humanoid_path() -> Path:
    """The checked-in ``models/mjcf/humanoid.xml`` when running from a checkout, else a copy built
    into the user's cache folder on first use."""
    if data.BUILTIN_HUMANOID.is_file():
        return data.BUILTIN_HUMANOID
    # named by what it is built from (the release, the profile, the walk and the builder's code), so a
    # change to any of them never reuses a stale copy
    h = hashlib.sha1(__version__.encode() + (PROFILE_DIR / "humanoid.yaml").read_bytes()
                     + data.BUILTIN_WALK.read_bytes())
    for src in sorted(Path(__file__).resolve().parent.glob("*.py")):
        h.update(src.read_bytes())
    key = h.hexdigest()[:12]
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "bipedsim" / f"humanoid-{key}.xml"
    if not cache.is_file():
        atomic_write_text(cache, builtin_humanoid_xml())
    return cache
