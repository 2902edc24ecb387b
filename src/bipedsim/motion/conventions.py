"""Axis and unit conventions, in one place.

The project's frame is **Z up, metres**. BVH files are usually Y up and come in many length units; this
module names those units, builds the change-of-basis matrices between up axes, and guesses a file's
unit and up axis from the body it describes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

#: Metres per file unit for the length units BVH files occur in.
UNIT_SCALES: dict[str, float] = {
    "m": 1.0,
    "dm": 0.1,
    "cm": 0.01,
    "mm": 0.001,
    "inch": 0.0254,
    # CMU ASF units: 1 unit = 1/0.45 inch (the CMU database's length multiplier 0.45).
    "cmu": 0.0254 / 0.45,
    "ft": 0.3048,
}

#: Order in which units are tried when guessing: the most common first.
UNIT_GUESS_ORDER = ("m", "cm", "cmu", "inch", "dm", "mm", "ft")

#: Plausible standing height (m) of an upright (human-like) body, used to guess units.
HUMAN_HEIGHT_RANGE_M = (1.0, 2.4)
#: Plausible size (m) -- largest extent -- of any other creature.
CREATURE_SIZE_RANGE_M = (0.15, 6.0)
#: A body is "upright" when its vertical extent is at least this fraction of its horizontal extent.
UPRIGHT_RATIO = 0.6

PROJECT_UP = "z"
AXES = ("x", "y", "z")

#: Name fragments of joints that carry the body's weight (used to find "down").
FOOT_TOKENS = ("foot", "toe", "ankle", "heel")


def axis_index(axis: str) -> int:
    a = axis.lower()
    if a not in AXES:
        raise ValueError(f"axis must be one of {AXES}, got {axis!r}")
    return AXES.index(a)


def up_basis(src_up: str, dst_up: str) -> npt.NDArray[np.float64]:
    """Proper rotation matrix ``C`` taking vectors in a ``src_up`` frame to a ``dst_up`` frame.

    Y-up -> Z-up is a +90 degree rotation about X: ``(x, y, z) -> (x, -z, y)``; Z-up -> Y-up is its
    inverse. Positions map as ``p' = C p`` and rotations as ``R' = C R C^T``.
    """
    s, d = src_up.lower(), dst_up.lower()
    if s == d:
        return np.eye(3)
    y_to_z = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    if (s, d) == ("y", "z"):
        return y_to_z
    if (s, d) == ("z", "y"):
        return y_to_z.T
    raise ValueError(f"up-axis conversion {src_up!r} -> {dst_up!r} is not supported (use 'y' or 'z')")


def horizontal_axes(up: str) -> tuple[int, int]:
    """Indices of the two horizontal axes for a given up axis."""
    u = axis_index(up)
    return tuple(i for i in range(3) if i != u)  # type: ignore[return-value]


@dataclass(frozen=True)
class UpGuess:
    axis: str
    reason: str


@dataclass(frozen=True)
class UnitGuess:
    name: str
    scale: float  # metres per file unit
    height_m: float  # body height (upright) or size (otherwise) in metres under this unit
    upright: bool
    reason: str


def guess_up_axis(names: tuple[str, ...], positions: npt.NDArray[np.float64]) -> UpGuess:
    """Guess the up axis: the axis along which the root sits above the feet, on average.

    ``positions``: (F, J, 3) joint positions of a few frames in file axes.
    """
    positions = np.asarray(positions).reshape(-1, len(names), 3)
    feet = [i for i, n in enumerate(names) if any(t in n.lower() for t in FOOT_TOKENS)]
    if not feet:
        return UpGuess("y", "no foot/toe/ankle joints to find 'down'; assumed the BVH default Y up")
    v = (positions[:, 0] - positions[:, feet].mean(axis=1)).mean(axis=0)
    k = int(np.argmax(np.abs(v)))
    if k == 0 or v[k] <= 0:
        return UpGuess("y", "root is not above the feet along Y or Z; assumed the BVH default Y up")
    return UpGuess(AXES[k], f"root is {abs(v[k]):.4g} units above the feet along {AXES[k].upper()}")


def body_extent(positions: npt.NDArray[np.float64], up: str) -> tuple[float, float]:
    """(vertical extent, largest horizontal extent) of a body's points, in file units: the median
    over the given frames. ``positions``: (F, N, 3) or (N, 3)."""
    pts = np.asarray(positions).reshape((-1,) + np.shape(positions)[-2:])
    u = axis_index(up)
    span = pts.max(axis=1) - pts.min(axis=1)  # (F, 3)
    h = np.max(np.delete(span, u, axis=1), axis=1)
    return float(np.median(span[:, u])), float(np.median(h))


def guess_unit(positions: npt.NDArray[np.float64], up: str) -> UnitGuess:
    """Guess metres per file unit from the body's size (median over the given frames).

    An upright body (vertical extent >= ``UPRIGHT_RATIO`` x horizontal) is taken as human-like and its
    height must land in ``HUMAN_HEIGHT_RANGE_M``; any other body's largest extent must land in
    ``CREATURE_SIZE_RANGE_M``. Units are tried in ``UNIT_GUESS_ORDER``; the first that fits wins.
    """
    vert, horiz = body_extent(positions, up)
    upright = vert >= UPRIGHT_RATIO * horiz
    size = vert if upright else max(vert, horiz)
    lo, hi = HUMAN_HEIGHT_RANGE_M if upright else CREATURE_SIZE_RANGE_M
    what = "height" if upright else "size"
    if size <= 0:
        return UnitGuess("m", 1.0, 0.0, upright, "body has no extent; assumed metres")
    for name in UNIT_GUESS_ORDER:
        s = UNIT_SCALES[name]
        if lo <= size * s <= hi:
            return UnitGuess(name, s, size * s, upright,
                             f"{what} {size:.4g} units = {size * s:.3g} m in {name}, "
                             f"within the plausible {lo}-{hi} m")
    # Nothing fits: choose the unit whose result is closest (in log) to the middle of the range.
    mid = np.sqrt(lo * hi)
    name = min(UNIT_GUESS_ORDER, key=lambda n: abs(np.log(size * UNIT_SCALES[n] / mid)))
    s = UNIT_SCALES[name]
    return UnitGuess(name, s, size * s, upright,
                     f"{what} {size:.4g} units fits no unit's plausible range; closest is {name} "
                     f"({size * s:.3g} m) -- pass an explicit scale if this is wrong")
