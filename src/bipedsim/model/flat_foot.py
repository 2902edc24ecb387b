"""The frame in which a foot segment's sole lies level: found on the frames where the motion has the
segment flat on the floor (not in the rest pose, which need not stand flat-footed), with the sole's pitch
and roll as the model's hinges can give them."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.model.humanoid_bones import MIN_BONE_M
from bipedsim.model.source import SourcePoints

FloatArray = npt.NDArray[np.float64]


#: Stance frames for the flat-foot frame: foot points within this height (m) of their lowest level and
#: the joint slower than FLAT_SPEED (m/s); tilts under FLAT_MIN_TILT (rad) are left at the rest frame.
FLAT_HEIGHT_M = 0.02
FLAT_SPEED = 0.3
FLAT_MIN_TILT = 0.02
#: Largest sole pitch (rad) against the rest pose.
MAX_SOLE_PITCH = 0.6
#: Smallest knee bend (rad) at which the hip-knee-ankle plane defines the foot's lateral axis.
MIN_PLANE_BEND = 0.05


def _flat_frame(moving: SourcePoints, joint: str, points: list[str], forward: FloatArray,
                hinge_plane: tuple[str, str, str] | None = None, hinge_axis: FloatArray | None = None,
                hinge_world: FloatArray | None = None) -> FloatArray:
    """Axes (columns, body coordinates) of a foot segment's sole. The sole must be level when the
    motion has the segment flat on the floor (all ``points`` at their lowest level and ``joint``
    still), not in the rest pose, which need not stand flat-footed.

    On those frames the segment's orientation is the one the model can give it: its forward bone
    ``forward`` (rest pose) turned onto ``points[0] -> points[1]``, and its lateral axis ``hinge_axis``
    (the knee's, rest pose; the ankle and toe hinges are parallel to it) onto the normal of the leg's
    plane ``hinge_plane`` (hip, knee, ankle), where the twobone fit puts the knee hinge. A 1-DOF
    ankle cannot roll the foot, so the leg's plane on the floor sets the sole's roll: the sole is the
    rest frame turned so that its normal is vertical on the mean flat frame (pitch and roll, at
    most MAX_SOLE_PITCH). Without ``hinge_plane`` (or where the leg is too straight to define its
    plane) only the pitch is corrected. Identity when the correction is under FLAT_MIN_TILT or the
    motion never shows the segment flat (one-frame files). ``hinge_world`` (T, 3): where the motion
    puts ``hinge_axis`` on each frame, given when the segment's roll is not the leg plane's (a 2-DOF
    ankle rolls the foot as the capture does: :meth:`_HumanoidBuilder._foot_hinge_world`)."""
    eye = np.eye(3)
    flat = _flat_frames(moving, joint, points)
    if flat is None:
        return eye
    bone = moving[points[1]][flat] - moving[points[0]][flat]
    if float(np.median(np.linalg.norm(bone, axis=1))) < MIN_BONE_M:
        return eye
    f_rest = np.asarray(forward, dtype=float)
    lateral_rest = np.cross([0.0, 0.0, 1.0], f_rest)
    if np.linalg.norm(lateral_rest) < 1e-6:
        return eye
    plane = None
    if hinge_world is not None and hinge_axis is not None:
        plane = hinge_world[flat] / np.linalg.norm(hinge_world[flat], axis=1, keepdims=True), bone
    elif hinge_plane is not None and hinge_axis is not None:
        plane = _leg_plane_normals(moving, flat, hinge_plane, bone)
    if plane is None:
        normal, y_rest = _pitch_normals(bone, lateral_rest), lateral_rest
    else:
        (normal, bone), y_rest = plane, np.asarray(hinge_axis, dtype=float)
    return _levelling_rotation(f_rest, y_rest, bone, normal)


def _flat_frames(moving: SourcePoints, joint: str, points: list[str]) -> npt.NDArray[np.bool_] | None:
    """Frames (T,) on which a foot segment lies flat: every one of ``points`` within FLAT_HEIGHT_M (m)
    of its lowest level (its 10th height percentile) and ``joint`` still; None when fewer than 3
    frames (or fewer than 3 in the motion) qualify."""
    pos = moving.positions
    if pos.ndim != 3 or pos.shape[0] < 3:
        return None
    h = np.stack([moving[p][:, 2] for p in points], axis=1)
    low = np.all(h < np.percentile(h, 10, axis=0) + FLAT_HEIGHT_M, axis=1)
    j = moving[joint]
    speed = np.zeros(len(j))
    speed[1:] = np.linalg.norm(np.diff(j, axis=0), axis=1)
    # frame time is not known here: "still" = moving less than FLAT_SPEED at 120 fps, or 10 % of the
    # median per-frame motion for slower captures
    still = speed <= max(FLAT_SPEED / 120.0, 0.1 * float(np.median(speed[1:])))
    flat = low & still
    if flat.sum() < 3:
        return None
    return flat


def _leg_plane_normals(moving: SourcePoints, flat: npt.NDArray[np.bool_], hinge_plane: tuple[str, str, str],
                       bone: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """Unit normals (N, 3, world frame) of the leg's plane ``hinge_plane`` (hip, knee, ankle) on the
    flat frames where the knee bends at least MIN_PLANE_BEND, turned to the foot's left, with the foot
    bones ``bone`` of those frames; None when fewer than 3 frames bend enough."""
    a, b, c = (moving[n][flat] for n in hinge_plane)
    n = np.cross(b - a, c - b)
    size = np.linalg.norm(n, axis=1) / np.maximum(np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1),
                                                  1e-12)
    ok = size > np.sin(MIN_PLANE_BEND)
    if ok.sum() < 3:
        return None
    normal, bone = n[ok] / np.linalg.norm(n[ok], axis=1, keepdims=True), bone[ok]
    # the knee bends one way: the normal on the foot's left-hand side (a straightened or
    # over-extended knee would flip the plane's orientation)
    left = np.cross([0.0, 0.0, 1.0], bone)
    return np.where(np.sum(normal * left, axis=1, keepdims=True) < 0, -normal, normal), bone


def _pitch_normals(bone: FloatArray, lateral_rest: FloatArray) -> FloatArray:
    """Horizontal unit lateral axes (N, 3, world frame) normal to the foot bones ``bone``, on the side
    of ``lateral_rest``: the sole keeps its roll and only its pitch (the bone's dip against the rest
    pose's) is corrected."""
    normal = np.cross(bone, [0.0, 0.0, 1.0])
    normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    return np.where((normal @ lateral_rest)[:, None] < 0, -normal, normal)


def _levelling_rotation(f_rest: FloatArray, y_rest: FloatArray, bone: FloatArray, normal: FloatArray) -> FloatArray:
    """Rotation (3, 3, body coordinates) that levels the sole: turns the world vertical, averaged over
    the flat frames where the rest frame (``f_rest``, ``y_rest``) is carried onto (``bone``,
    ``normal``), back onto +z; at most MAX_SOLE_PITCH (rad), identity under FLAT_MIN_TILT."""
    # per flat frame: G = B A^T carries the rest frame A = (forward, lateral, ...) onto B = (bone, normal, ...)
    rest_frame = _frame_from(f_rest[None], y_rest[None])[0]
    frames = _frame_from(bone, normal)
    # the world vertical in body coordinates, G^T z = A B^T z, on each flat frame
    up_b = np.einsum("ij,tkj,k->ti", rest_frame, frames, np.array([0.0, 0.0, 1.0]))
    s = up_b.mean(axis=0)
    s = s / np.linalg.norm(s)
    angle = float(np.arccos(np.clip(s[2], -1.0, 1.0)))
    if angle < FLAT_MIN_TILT:
        return np.eye(3)
    axis = np.cross([0.0, 0.0, 1.0], s)
    axis = axis / np.linalg.norm(axis)
    return Rotation.from_rotvec(axis * min(angle, MAX_SOLE_PITCH)).as_matrix()


def _frame_from(x: FloatArray, y: FloatArray) -> FloatArray:
    """(T, 3, 3) right-handed frames (columns) with y along ``y`` and x along ``x`` made normal to it."""
    y = y / np.linalg.norm(y, axis=1, keepdims=True)
    x = x - np.sum(x * y, axis=1, keepdims=True) * y
    x = x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-12)
    return np.stack([x, y, np.cross(x, y)], axis=2)
