"""Balance feedback from the centre of mass: eq. 6's swing-hip angles and velocity tuning's virtual force.

``d`` is the COM's horizontal offset from the stance ankle and ``v`` the COM's velocity, both in the
heading frame (x forward, y left; m and m/s). Eq. 6 turns the swing thigh's target by
``theta = c_d d + c_v v`` (rad) in the sagittal and coronal planes, ``d`` and ``v`` measured against the
walk's own as ``balance.relative`` says. Velocity tuning (Coros et al. 2010) pushes the COM toward the
walk's speed with a virtual force the loaded legs produce.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import beyond, feedback_angle
from bipedsim.control.humanoid.settings import BalanceConfig, CaptureConfig, VelocityConfig
from bipedsim.control.humanoid.sources import SIDES, GaitSource
from bipedsim.control.humanoid.tables import HumanoidTables

FloatArray = npt.NDArray[np.float64]
#: the COM's (d forward, d left, v forward, v left) in the heading frame (m, m/s)
ComState = tuple[float, float, float, float]


def heading_frame_com(dx: float, dy: float, vx: float, vy: float, c: float, s: float) -> ComState:
    """The COM's offset (dx, dy) m from the stance ankle and velocity (vx, vy) m/s (world) in the heading
    frame whose yaw has cosine ``c`` and sine ``s``."""
    return c * dx + s * dy, -s * dx + c * dy, c * vx + s * vy, -s * vx + c * vy


def feedback_angles(b: BalanceConfig, t: HumanoidTables, src: GaitSource, frame: float, stance: str,
                    com: ComState, speed: float) -> tuple[float, float]:
    """Eq. 6's feedback angles (rad), sagittal and coronal: ``c_d d + c_v v`` each clipped to
    ``max_feedback``, the COM ``com`` (:func:`heading_frame_com`) measured as ``balance.relative`` says:
    ``none`` raw; ``mean_velocity`` the sagittal v against the walk's mean speed; ``lateral_reference`` that,
    and the coronal d against the reference's own on this frame (its sway about the stance foot);
    ``full`` d and v against the reference's own on this frame; ``speed`` the walk's speed now (m/s). 0
    without ``balance.feedback``."""
    if not b.feedback:
        return 0.0, 0.0
    d0, d1, v0, v1 = com
    if b.relative == "full":
        d_ref, v_ref = src.com_reference(frame, stance)
        d0, d1, v0, v1 = d0 - float(d_ref[0]), d1 - float(d_ref[1]), v0 - float(v_ref[0]), v1 - float(v_ref[1])
    elif b.relative == "mean_velocity":
        v0 -= speed
    elif b.relative == "lateral_reference":
        d1 -= src.lateral_reference(frame, stance)
        v0 -= speed
    fs = feedback_angle(0.0, t.cd_sagittal, b.sagittal.cv, d0, v0, b.max_feedback)
    fc = feedback_angle(0.0, b.coronal.cd, b.coronal.cv, d1, v1, b.max_feedback)
    return fs, fc


def capture_deviation(com: ComState, ref: tuple[FloatArray, FloatArray], w: float) -> tuple[float, float]:
    """The capture point's deviation from the reference's (m, sagittal and coronal, heading frame):
    ``(d - d_ref) + (v - v_ref) / w`` per plane, ``com`` the COM's state (:func:`heading_frame_com`),
    ``ref`` the reference's own (d_ref, v_ref), ``w`` the linear inverted pendulum's sqrt(g / L) (1/s)."""
    d_ref, v_ref = ref
    return (com[0] - float(d_ref[0]) + (com[2] - float(v_ref[0])) / w,
            com[1] - float(d_ref[1]) + (com[3] - float(v_ref[1])) / w)


def capture_excess(cc: CaptureConfig, deviation: tuple[float, float],
                   bias: tuple[float, float]) -> tuple[float, float]:
    """A capture point ``deviation`` (m, :func:`capture_deviation`) less its running mean ``bias`` (m),
    beyond ``cc.deadband`` (0 inside it), per plane."""
    return (beyond(deviation[0] - bias[0], cc.deadband), beyond(deviation[1] - bias[1], cc.deadband))


def capture_rate(cc: CaptureConfig, excess: tuple[float, float]) -> float:
    """The gait clock's rate (x real time) the capture point's ``excess`` (m, :func:`capture_excess`)
    asks for: ``1 + tempo_gain |excess|``, at most ``max_rate``; 1 when capture stepping is off."""
    if not cc.enabled or cc.tempo_gain <= 0.0:
        return 1.0
    return min(1.0 + cc.tempo_gain * math.hypot(*excess), cc.max_rate)


def virtual_force(vc: VelocityConfig, t: HumanoidTables, data: mujoco.MjData, tau: FloatArray,
                  forces: dict[str, float], c: float, s: float, v_filtered: float, speed: float) -> float:
    """Velocity tuning: the forward virtual force F = kv (v_target - v) (N, heading frame whose yaw has
    cosine ``c`` and sine ``s``, at most ``max_force``) on the centre of mass, ``v_filtered`` the sagittal
    COM velocity low-passed (m/s). The loaded legs produce it with the foot as the chain's fixed end: each
    knee and ankle hinge adds -share a . ((com - anchor) x F) to ``tau`` (Jacobian transpose of the
    reversed chain; a joint's torque acts on its parent, the side toward the body, with the opposite
    sign). ``speed``: the target, the walk's speed now (m/s). Returns F (N)."""
    f0 = t.kv_sagittal * (speed - v_filtered)
    if abs(f0) > vc.max_force:
        f0 = f0 * vc.max_force / abs(f0)
    fx, fy = c * f0, s * f0
    total = forces["left"] + forces["right"]
    if total <= 1e-6:
        return f0
    cx, cy, cz = data.subtree_com[t.pelvis].tolist()
    for side in SIDES:
        share = forces[side] / total
        if share <= 0.0:
            continue
        for i, j in t.vf_joints[side]:
            ax, ay, az = data.xaxis[j].tolist()
            px, py, pz = data.xanchor[j].tolist()
            rx, ry, rz = cx - px, cy - py, cz - pz
            # r x F with F = (fx, fy, 0): (-rz fy, rz fx, rx fy - ry fx)
            tau[i] -= share * (ax * (-rz * fy) + ay * (rz * fx) + az * (rx * fy - ry * fx))
    return f0
