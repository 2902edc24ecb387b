"""A BVH file's channel values and a :class:`~bipedsim.motion.motion.Motion`, both ways: Euler angles
(degrees, any order) to quaternions and position channels to local translations, and back.
"""

from __future__ import annotations

import warnings

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton

FloatArray = npt.NDArray[np.float64]


def _quat_mul(a: FloatArray, b: FloatArray) -> FloatArray:
    """Hamilton product of scalar-last quaternions, broadcasting."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def euler_to_quat(order: str, degrees: FloatArray) -> FloatArray:
    """Intrinsic Euler angles (degrees, last axis in ``order``) to scalar-last quaternions.

    Same result as ``Rotation.from_euler(order.upper(), ..., degrees=True)`` (tested), composed from
    elementary half-angle quaternions because scipy's general path is ~40x slower on the
    tens of thousands of rotations a mocap file holds.
    """
    half = np.radians(degrees) * 0.5
    out = None
    for k, axis in enumerate(order.upper()):
        q = np.zeros(half.shape[:-1] + (4,))
        q[..., "XYZ".index(axis)] = np.sin(half[..., k])
        q[..., 3] = np.cos(half[..., k])
        out = q if out is None else _quat_mul(out, q)
    assert out is not None
    return out


def _column_starts(sk: Skeleton) -> list[int]:
    col, c = [], 0
    for ch in sk.channels:
        col.append(c)
        c += len(ch)
    return col


#: Frames converted to rotations at a time: the temporaries of the Euler-to-quaternion products stay a
#: few MiB however long the clip (a whole clip at once would need several times the rotations' size).
FRAME_BLOCK = 1024


def _channels_to_motion(sk: Skeleton, frame_time: float, data: FloatArray) -> Motion:
    t, j = data.shape[0], sk.num_joints
    col = _column_starts(sk)
    quats = np.zeros((t, j, 4))
    quats[..., 3] = 1.0
    by_order: dict[str, list[int]] = {}
    for i in range(j):
        order = sk.rotation_order(i)
        if order:
            by_order.setdefault(order, []).append(i)
    columns = {order: np.array([[col[i] + k for k, c in enumerate(sk.channels[i]) if c in ROTATION_CHANNELS]
                                for i in joints]) for order, joints in by_order.items()}  # (n, len(order))
    for s in range(0, t, FRAME_BLOCK):
        block = quats[s:s + FRAME_BLOCK]
        for order, joints in by_order.items():
            block[:, joints] = euler_to_quat(order, data[s:s + FRAME_BLOCK][:, columns[order]])
        block[:] = canonical_quat(block)
    moving = [i for i in range(1, j) if sk.has_positions(i)]
    # local translations of every joint only where a joint below the root moves: else the root's alone
    trans = np.broadcast_to(sk.offsets, (t, j, 3)).copy() if moving else np.tile(sk.offsets[0], (t, 1))[:, None]
    for i in range(j):
        if not sk.has_positions(i):
            continue
        vals = trans[:, i]  # a view: written in place
        vals[:] = sk.offsets[i]  # in either mode an axis without a channel keeps the OFFSET component
        for k, c in enumerate(sk.channels[i]):
            if c in POSITION_CHANNELS:
                a = POSITION_CHANNELS.index(c)
                vals[:, a] = data[:, col[i] + k] + (sk.offsets[i][a] if sk.position_modes[i] == "add" else 0.0)
    return Motion(skeleton=sk, frame_time=frame_time, root_translation=trans[:, 0].copy(),
                  rotations=quats, translations=trans if moving else None, unit=1.0, up="y")


def _euler(q: FloatArray, order: str) -> FloatArray:
    """Euler angles (degrees) for intrinsic ``order`` of 1-3 axes; (N, len(order))."""
    r = Rotation.from_quat(q)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: angles stay valid
        if len(order) == 3:
            return r.as_euler(order.upper(), degrees=True)
        if len(order) == 2:
            rest = next(a for a in "XYZ" if a not in order.upper())
            return r.as_euler(order.upper() + rest, degrees=True)[:, :2]
    axis = "XYZ".index(order.upper())
    ang = 2.0 * np.arctan2(q[:, axis], q[:, 3])
    return np.degrees((ang + np.pi) % (2 * np.pi) - np.pi)[:, None]


def motion_to_channels(motion: Motion) -> FloatArray:
    """(T, C) channel values of a motion, in the skeleton's channel order and the motion's units."""
    sk = motion.skeleton
    col = _column_starts(sk)
    n_ch = sum(len(c) for c in sk.channels)
    out = np.zeros((motion.num_frames, n_ch))
    trans = motion.local_translations()
    for j in range(sk.num_joints):
        order = sk.rotation_order(j)
        if order:
            ang = _euler(motion.rotations[:, j], order)
            rk = [k for k, c in enumerate(sk.channels[j]) if c in ROTATION_CHANNELS]
            out[:, [col[j] + k for k in rk]] = ang
        for k, c in enumerate(sk.channels[j]):
            if c in POSITION_CHANNELS:
                a = POSITION_CHANNELS.index(c)
                v = trans[:, j, a]
                if sk.position_modes[j] == "add":
                    v = v - sk.offsets[j, a]
                out[:, col[j] + k] = v
    return out
