"""Headings and the heading frame of a creature: its yaw about world Z (rad), measured along a body axis
(a creature's root frame need not point forward: the dog's x axis points backward)."""

from __future__ import annotations

import math

import numpy as np

from bipedsim.control.base import FloatArray


def rot_z(a: float) -> FloatArray:
    """The rotation matrix of ``a`` rad about world Z."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def axis_heading(r: FloatArray, fwd: FloatArray) -> float:
    """The heading (rad about world Z) of body axis ``fwd`` (root frame) under root rotation ``r``."""
    d = r @ fwd
    return math.atan2(d[1], d[0])


def yaw_between(r: FloatArray, r_ref: FloatArray) -> float:
    """The heading turn (rad, about world Z) that best carries orientation ``r_ref`` onto ``r``."""
    e = r @ r_ref.T
    return math.atan2(e[1, 0] - e[0, 1], e[0, 0] + e[1, 1])


__all__ = ["axis_heading", "rot_z", "yaw_between"]
