"""The feet in the world frame: each ankle aims its foot at the reference foot's heading-frame orientation.

So a foot lands and stays flat whatever the leg's tilt. The ankle has one hinge (flexion) or two
(flexion and roll); their angles are the ones that best reproduce the target in the shin's frame.
Torques N*m per hinge, angles rad.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import euler_from_matrix
from bipedsim.control.humanoid.sources import SIDES, GaitSource
from bipedsim.control.humanoid.tables import HumanoidTables

FloatArray = npt.NDArray[np.float64]


def feet_world(t: HumanoidTables, data: mujoco.MjData, src: GaitSource, frame: float, state: int, stance: str,
               ry: FloatArray, tilt: FloatArray | None, q: FloatArray, qd: FloatArray, q_d: FloatArray,
               qd_d: FloatArray, tau: FloatArray, fade: float, ff: FloatArray | None,
               offsets: FloatArray | None = None, ground: dict[str, FloatArray] | None = None) -> None:
    """Ankle torques (into ``tau``, targets into ``q_d``) aiming each foot at the reference's orientation
    in the heading frame (``ry``: its rotation); ``tilt``: a heading-frame rotation applied to the stance
    foot's target (stance-ankle feedback; None: none); ``fade`` scales the PD part; ``ff``: the gravity
    feedforward added (None: none); ``offsets``: per hinge, added to the ankles' angles (a correction's;
    None: none); ``ground``: per foot, a heading-frame rotation tilting its target to the ground under
    it (:func:`~bipedsim.control.humanoid.ground.feet_tilts`; None: level ground)."""
    kp, kd, tlo, thi = t.kp_l, t.kd_l, t.tlo_l, t.thi_l
    ref_vel, implicit = t.ref_vel, t.implicit
    for side in SIDES:
        r_f = src.foot_target(frame, state, side)
        if r_f is None:
            continue
        if tilt is not None and side == stance:
            r_f = tilt.dot(r_f)
        if ground is not None:
            r_f = ground[side].dot(r_f)
        ankle = t.ankle[side]
        local = data.xmat[t.shin_body[side]].reshape(3, 3).T.dot(ry.dot(r_f))
        ang = hinge_angles_small(local, ankle.axes, ankle.basis)
        for k, i in enumerate(ankle.idx):
            v = ang[k] if offsets is None else ang[k] + float(offsets[i])
            v = min(max(v, tlo[i]), thi[i])
            q_d[i] = v
            t_i = fade * kp[i] * (v - float(q[i]))
            if ref_vel or not implicit:
                vel = (0.0 if implicit else float(qd[i])) - (float(qd_d[i]) if ref_vel else 0.0)
                t_i -= fade * kd[i] * vel
            if ff is not None:
                t_i += float(ff[i])
            tau[i] = t_i


def hinge_angles_small(local: FloatArray, axes: list[tuple[float, float, float]],
                       basis: FloatArray | None = None) -> tuple[float, ...]:
    """Angles of 1 or 2 hinges (unit axes, applied in order) best reproducing a local rotation matrix.
    Two hinges off x, y and z (a flexion axis along a bone's) take their ``basis``
    (:func:`bipedsim.reference.retarget.hinge_basis`: the first axis, the second, their cross product)."""
    if len(axes) == 1:
        x, y, z = axes[0]
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = local.ravel().tolist()
        # twist of the rotation about the axis (swing-twist): sin from the skew part along the axis,
        # cos from the trace less the axis's own component (2 cos(theta) restricted to the plane)
        aw = x * (m21 - m12) + y * (m02 - m20) + z * (m10 - m01)
        ama = x * (m00 * x + m01 * y + m02 * z) + y * (m10 * x + m11 * y + m12 * z) + z * (m20 * x + m21 * y + m22 * z)
        return (math.atan2(aw, m00 + m11 + m22 - ama),)
    if basis is not None:  # the rotation in the hinges' own basis: about its x, then its y
        a, b, _ = euler_from_matrix(basis.T.dot(local).dot(basis), (0, 1, 2))
        return a, b
    order = tuple(int(np.argmax(np.abs(x))) for x in axes)
    signs = [1.0 if x[k] > 0 else -1.0 for x, k in zip(axes, order)]
    third = next(k for k in range(3) if k not in order)
    ang = euler_from_matrix(local, (order[0], order[1], third))
    return ang[0] * signs[0], ang[1] * signs[1]
