"""Motion data: :class:`Skeleton`, :class:`Motion`, forward kinematics and BVH input/output.

Everything here is plain numpy/scipy; this package never imports MuJoCo.
"""

from __future__ import annotations

from bipedsim.motion.bvh import BVHInfo, bvh_text, load_bvh, read_bvh, write_bvh
from bipedsim.motion.conventions import UNIT_SCALES, up_basis
from bipedsim.motion.motion import (
    Motion,
    canonical_quat,
    concatenate,
    forward_kinematics,
    left_right_pairs,
)
from bipedsim.motion.skeleton import Skeleton

__all__ = [
    "UNIT_SCALES",
    "BVHInfo",
    "Motion",
    "Skeleton",
    "bvh_text",
    "canonical_quat",
    "concatenate",
    "forward_kinematics",
    "left_right_pairs",
    "load_bvh",
    "read_bvh",
    "up_basis",
    "write_bvh",
]
