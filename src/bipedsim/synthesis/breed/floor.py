"""4. The floor constraint: no joint or End Site below the floor -- each one lifted by the smallest
rotation of the bone above it (a one-joint IK step, parents first), what remains by lifting the whole
body. Heights in m, project frame (Z up)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.synthesis.breed.alignment import (
    _min_rot,
)

FloatArray = npt.NDArray[np.float64]


# ---------------------------------------------------------------------- 4. floor constraint
#: Passes of the one-bone IK per frame before the rest of a frame's penetration is taken out by
#: lifting the whole body (turning one bone can push a sibling under the floor).
FLOOR_PASSES = 3


def floor_constraint(motion: Motion, floor: float = 0.0) -> tuple[Motion, int]:
    """Lift joints and End Sites below ``floor`` by turning the bone above each one (parents first,
    up to :data:`FLOOR_PASSES` passes); what is still below afterwards is lifted with the whole body.
    Returns the corrected motion and how many (frame, point) corrections were made. Frames already
    above the floor are unchanged."""
    m = motion.copy()
    fixes = 0
    low = _lowest(m)
    for t in np.flatnonzero(low < floor - 1e-9):
        frame = m[t:t + 1]
        for _ in range(FLOOR_PASSES):
            moved = _lift_pass(frame, floor)
            fixes += moved
            if not moved:
                break
        rest = floor - float(_lowest(frame)[0])
        if rest > 1e-9:
            frame.root_translation[0, 2] += rest
            fixes += 1
        m.rotations[t] = frame.rotations[0]
        m.root_translation[t] = frame.root_translation[0]
    return m, fixes


def _lowest(m: Motion) -> FloatArray:
    """(T,) height of the lowest joint or End Site per frame."""
    z = m.fk()[0][..., 2].min(axis=1)
    if len(m.skeleton.end_site_parents):
        z = np.minimum(z, m.end_site_positions()[..., 2].min(axis=1))
    return z


def _lift_pass(frame: Motion, floor: float) -> int:
    """One pass over a one-frame motion's joints, then End Sites: each one below the floor is lifted
    (the root by moving it, others by turning the bone above them). Returns how many were lifted."""
    sk = frame.skeleton
    moved = 0
    points = [(j, -1) for j in range(sk.num_joints)] + [(int(p), e) for e, p in enumerate(sk.end_site_parents)]
    p, g = frame.fk()
    for j, e in points:
        point = p[0, j] if e < 0 else p[0, j] + g[0, j] @ sk.end_site_offsets[e]
        if point[2] >= floor - 1e-9:
            continue
        if e < 0 and j == 0:
            frame.root_translation[0, 2] += floor - point[2]
            moved += 1
        else:
            moved += _turn_bone(frame, int(sk.parents[j]) if e < 0 else j, point, p, g, floor)
        p, g = frame.fk()  # only after a change: the checks use the current pose
    return moved


def _turn_bone(frame: Motion, par: int, point: FloatArray, p: FloatArray, g: FloatArray, floor: float) -> int:
    """Turn joint ``par`` by the smallest rotation that brings ``point`` (below the floor, carried by
    ``par``) up to the floor; when the bone is too short to reach, lift the whole frame instead."""
    sk = frame.skeleton
    v = point - p[0, par]
    length = float(np.linalg.norm(v))
    if length < 1e-12:
        return 0
    need = floor - p[0, par, 2]  # target vertical component of the bone
    if abs(need) > length:  # the joint itself is too low to reach: lift the whole frame
        frame.root_translation[0, 2] += floor - point[2]
        return 1
    horiz = np.hypot(v[0], v[1])
    new_h = np.sqrt(max(length ** 2 - need ** 2, 0.0))
    d = np.array([v[0], v[1]]) / horiz if horiz > 1e-12 else np.array([1.0, 0.0])
    r = _min_rot(v, np.array([d[0] * new_h, d[1] * new_h, need]))
    gp = g[0, par]
    new_local = r @ gp if sk.parents[par] < 0 else g[0, int(sk.parents[par])].T @ r @ gp
    frame.rotations[0, par] = canonical_quat(Rotation.from_matrix(new_local).as_quat())
    return 1
