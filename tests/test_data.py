"""Shipped data is what the package's generators make."""

from __future__ import annotations

from generated import assert_text_close

from bipedsim.data import BUILTIN_WALK, SHIPPED_BVH_PRECISION, builtin_walk_text
from bipedsim.motion import read_bvh
from bipedsim.motion.gaitgen import WalkParams


def test_builtin_walk_regenerates_identically() -> None:
    assert_text_close(BUILTIN_WALK.read_text(), builtin_walk_text(), SHIPPED_BVH_PRECISION)


def test_builtin_walk_reads_as_about_50_frames_per_cycle() -> None:
    m, info = read_bvh(BUILTIN_WALK)
    assert info.unit_name == "cm" and info.up == "y"
    cycle_s = 2 * 60.0 / WalkParams().resolved()[2]
    assert round(cycle_s / m.frame_time) == 50
