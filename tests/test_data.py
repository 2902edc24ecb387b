"""Shipped data is what the package's generators make."""

from __future__ import annotations

from generated import assert_text_close

from bipedsim.data import BUILTIN_WALK, SHIPPED_BVH_PRECISION
from bipedsim.model import builtin
from bipedsim.motion import read_bvh
from bipedsim.motion.gaitgen import WalkParams
from bipedsim.motion.samples import builtin_walk_text


def test_builtin_walk_regenerates_identically() -> None:
    assert_text_close(BUILTIN_WALK.read_text(), builtin_walk_text(), SHIPPED_BVH_PRECISION)


def test_builtin_walk_reads_as_about_50_frames_per_cycle() -> None:
    m, info = read_bvh(BUILTIN_WALK)
    assert info.unit_name == "cm" and info.up == "y"
    cycle_s = 2 * 60.0 / WalkParams().resolved()[2]
    assert round(cycle_s / m.frame_time) == 50


def test_an_installed_package_builds_the_humanoid_into_a_cache_named_by_its_inputs(tmp_path, monkeypatch) -> None:
    """Without the checkout's models/mjcf/humanoid.xml the body is built into the user's cache, under a
    name that hashes the release, the profile, the walk and the builder's code (a stale copy is never
    reused); it is the builder's body."""
    import re

    from generated import assert_xml_close

    import bipedsim.data as data

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(data, "BUILTIN_HUMANOID", tmp_path / "absent.xml")
    path = builtin.builtin_humanoid_path()
    assert path.parent == tmp_path / "bipedsim" and re.fullmatch(r"humanoid-[0-9a-f]{12}\.xml", path.name)
    assert_xml_close(path.read_text(), builtin.builtin_humanoid_xml())
    assert builtin.builtin_humanoid_path() == path  # found again, not rebuilt under another name
