"""Axis and unit conventions, in one place.

The project's frame is **Z up, metres**. BVH files are usually Y up and come in many length units; this
module names those units, builds the change-of-basis matrices between up axes, and guesses a file's
unit and up axis from the body it describes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

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
    fits: bool = True  # False: no unit put the body in the plausible range


def guess_up_axis(names: tuple[str, ...], positions: npt.NDArray[np.float64],
                  parents: npt.NDArray[np.int64] | None = None) -> UpGuess:
    """Guess the up axis: the axis along which the legs' root (the feet's deepest common ancestor when
    ``parents`` is given, else the root joint) sits above the feet, on average.

    ``positions``: (F, J, 3) joint positions of a few frames in file axes.
    """
    positions = np.asarray(positions).reshape(-1, len(names), 3)
    feet = foot_joints(names)
    if not feet:
        return UpGuess("y", "no foot/toe/ankle joints to find 'down'; assumed the BVH default Y up")
    hip = legs_root(np.asarray(parents), feet) if parents is not None else 0
    v = (positions[:, hip] - positions[:, feet].mean(axis=1)).mean(axis=0)
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


def guess_unit(positions: npt.NDArray[np.float64], up: str, upright: bool | None = None) -> UnitGuess:
    """Guess metres per file unit from the body's size (median over the given frames).

    An upright body (vertical extent >= ``UPRIGHT_RATIO`` x horizontal) is taken as human-like and its
    height must land in ``HUMAN_HEIGHT_RANGE_M``; any other body's largest extent must land in
    ``CREATURE_SIZE_RANGE_M``. Units are tried in ``UNIT_GUESS_ORDER``; the first that fits wins.
    ``upright``: whether the body is a human-like upright one, when known otherwise (None: by the
    extents; the ratio alone takes a quadruped with its head up for an upright body).
    """
    vert, horiz = body_extent(positions, up)
    if upright is None:
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
                     f"({size * s:.3g} m) -- pass an explicit scale if this is wrong", fits=False)


# ---------------------------------------------------------------------- scoring whole readings
#: A standing or walking body's hip (the legs' branching joint) sits at about this fraction of its leg
#: length (the chain from the hip joint to the lowest foot joint) above the floor.
HIP_HEIGHT_PER_LEG = 0.9
#: Two readings whose plausibility scores differ by less than this are reported as ambiguous.
AMBIGUOUS_SCORE_MARGIN = 0.25
#: A reading shows a body on its legs when its hip (the legs' branching joint) sits at least this many
#: leg lengths above the lowest foot, median over the clip: thighs level over upright shins, a deep squat.
#: Lower, the "floor" that reading finds is a horizontal axis the feet happen to line up along (a body
#: flying level, its feet trailing behind it), and the reading tells nothing about which way is up.
STANDING_HIP_MIN = 0.5
#: The up axis of a BVH file where nothing in the clip tells it: the format's convention.
BVH_DEFAULT_UP = "y"


@dataclass(frozen=True)
class ReadingScore:
    """How plausible one reading (up axis, position-channel mode) makes the body: lower is better.

    ``hip_ratio``: the hip's median height above the lowest foot over the leg length (about
    :data:`HIP_HEIGHT_PER_LEG` for a body on its feet); ``floor_spread``: the spread (10-90 %) of the
    lowest foot's height over the clip, in leg lengths (small: the feet meet one floor);
    ``vertical_travel``: the hip's vertical range over its horizontal range plus a leg (small: the
    body travels along the floor); ``floor_offset``: the floor's distance from a static root joint, in
    leg lengths (0 when the root moves: a static root of a root-on-a-child layout marks the floor).
    """

    score: float
    hip_ratio: float
    floor_spread: float
    vertical_travel: float
    floor_offset: float

    def text(self) -> str:
        return (f"score {self.score:.2f}: hip {self.hip_ratio:.2f} leg lengths above the lowest foot, "
                f"floor spread {self.floor_spread:.2f}, vertical/horizontal travel {self.vertical_travel:.2f}"
                + (f", floor {self.floor_offset:.2f} legs from the static root" if self.floor_offset else ""))


def foot_joints(names: tuple[str, ...]) -> list[int]:
    """Indices of joints named like feet (:data:`FOOT_TOKENS`)."""
    return [i for i, n in enumerate(names) if any(t in n.lower() for t in FOOT_TOKENS)]


def _ancestors(parents: npt.NDArray[np.int64], j: int) -> list[int]:
    out = [j]
    while parents[out[-1]] >= 0:
        out.append(int(parents[out[-1]]))
    return out


def legs_root(parents: npt.NDArray[np.int64], feet: list[int]) -> int:
    """The joint where the legs meet: the deepest common ancestor of the feet."""
    common = set(_ancestors(parents, feet[0]))
    for f in feet[1:]:
        common &= set(_ancestors(parents, f))
    return max(common, key=lambda j: len(_ancestors(parents, j)))


def score_reading(names: tuple[str, ...], parents: npt.NDArray[np.int64], positions: npt.NDArray[np.float64],
                  up: str) -> ReadingScore | None:
    """Plausibility of a reading with ``up`` as the up axis (see :class:`ReadingScore`); None when the
    skeleton has no named feet (nothing to measure). ``positions``: (F, J, 3) joints in file units."""
    feet = foot_joints(names)
    if len(feet) < 2:
        return None
    pos = np.asarray(positions).reshape(-1, len(names), 3)
    u = axis_index(up)
    hz = [i for i in range(3) if i != u]
    hip = legs_root(parents, feet)
    bone = np.median(np.linalg.norm(pos[:, 1:] - pos[:, parents[1:]], axis=2), axis=0)
    bone = np.concatenate([[0.0], bone])
    leg = max(sum(bone[a] for a in _ancestors(parents, f) if a != hip and hip in _ancestors(parents, a))
              for f in feet)
    if leg <= 0:
        return None
    low = pos[:, feet, u].min(axis=1)  # (F,) the lowest foot joint per frame
    hip_u = pos[:, hip, u]
    ratio = float(np.median(hip_u - low)) / leg
    p_hip = abs(np.log(ratio / HIP_HEIGHT_PER_LEG)) if ratio > 0.05 else 5.0
    spread = float(np.percentile(low, 90) - np.percentile(low, 10)) / leg
    hip_h = pos[:, hip][:, hz]
    horiz = float(np.linalg.norm(hip_h.max(axis=0) - hip_h.min(axis=0)))
    vert = float(np.percentile(hip_u, 95) - np.percentile(hip_u, 5))
    travel = vert / (horiz + leg)
    root_moves = float(np.ptp(pos[:, 0], axis=0).max()) > 1e-6 * leg
    floor_off = 0.0 if root_moves or hip == 0 else abs(float(np.median(low)) - float(np.median(pos[:, 0, u]))) / leg
    score = p_hip + spread + travel + 0.5 * min(floor_off, 2.0)
    return ReadingScore(float(score), ratio, spread, travel, floor_off)


#: Hip-joint height as a fraction of standing height (anthropometric tables, Drillis & Contini 1966:
#: greater trochanter 0.530 H).
HIP_PER_STATURE = 0.53


def leg_stature(names: tuple[str, ...], parents: npt.NDArray[np.int64], positions: npt.NDArray[np.float64],
                up: str) -> float:
    """Standing height (file units) estimated from the legs: the legs' root's height above the lowest
    foot joint, at its 95th percentile over the frames (legs straight at mid-stance), over
    :data:`HIP_PER_STATURE`. Unaffected by a stoop or a missing head top; 0 when the skeleton has no
    named feet."""
    feet = foot_joints(names)
    if len(feet) < 2:
        return 0.0
    pos = np.asarray(positions).reshape(-1, len(names), 3)
    u = axis_index(up)
    hip = legs_root(parents, feet)
    h = pos[:, hip, u] - pos[:, feet, u].min(axis=1)
    return max(0.0, float(np.percentile(h, 95))) / HIP_PER_STATURE
