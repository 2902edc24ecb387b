"""The hips: the swing hip's world-frame target (eq. 6 applied) and the split of the torso's torque (eq. 2-5).

The swing thigh's target is the reference thigh's orientation in the heading frame, turned by the
feedback angles about the heading frame's axes, expressed in the pelvis's frame and decomposed onto the
hip's flexion and abduction hinges; its twist hinge keeps the reference's joint-space twist (turning a
leg about itself places no foot). The stance hip then takes what the torso needs less what the swing
hip gives, shared by the feet's loads. Torques N*m (world vectors or per hinge), angles rad.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import (
    euler_from_matrix,
    hinges_to_world,
    hinges_to_world3,
    hip_torques,
    stance_share,
    world_to_hinges,
)
from bipedsim.control.humanoid.tables import HumanoidTables

FloatArray = npt.NDArray[np.float64]
Vec3 = tuple[float, float, float]


def swing_hip_torques(t: HumanoidTables, data: mujoco.MjData, swing: str, thigh_ref: FloatArray, r_p: FloatArray,
                      ry: FloatArray, r_fb: FloatArray, fs: float, fc: float, q: FloatArray, qd: FloatArray,
                      q_d: FloatArray, qd_d: FloatArray, fade: float, gravity: bool) -> list[float]:
    """The swing hip's hinge torques (N*m) toward the world-frame thigh target: the reference thigh
    ``thigh_ref`` (heading frame) turned by the feedback angles ``fs`` (sagittal, positive forward) and
    ``fc`` (coronal, positive left) about the heading frame's axes (``ry``: its rotation), relative to the
    pelvis (``r_p``). The flexion and abduction targets are written into ``q_d``; ``fade`` scales the PD
    part; ``gravity`` adds MuJoCo's bias force. ``r_fb``: a 3x3 scratch."""
    hip = t.hip[swing]
    idx_b, order_b, sign_b, sl_b = hip.idx_l, hip.order, hip.signs, hip.sel
    kp, kd, tlo, thi = t.kp_l, t.kd_l, t.tlo_l, t.thi_l
    ref_vel, implicit = t.ref_vel, t.implicit
    # r_fb = ry R_y(-fs) R_x(fc) ry^T (feedback about the heading frame's axes), so
    # pelvis^T r_fb ry thigh_ref = pelvis^T ry R_y(-fs) R_x(fc) thigh_ref
    cs, ss, cc, sc = math.cos(fs), math.sin(fs), math.cos(fc), math.sin(fc)
    r_fb[0, 0], r_fb[0, 1], r_fb[0, 2] = cs, -ss * sc, -ss * cc
    r_fb[1, 1], r_fb[1, 2] = cc, -sc
    r_fb[2, 0], r_fb[2, 1], r_fb[2, 2] = ss, cs * sc, cs * cc
    ang = euler_from_matrix(r_p.T.dot(ry).dot(r_fb.dot(thigh_ref)), order_b)
    # the world target sets where the thigh points; its twist about its own axis (the last hinge, applied
    # after flexion and abduction) stays the reference's: turning the leg about itself does not place the
    # foot, it only yaws the body
    i0, i1, i2 = idx_b
    v0 = min(max(ang[0] * sign_b[0], tlo[i0]), thi[i0])
    v1 = min(max(ang[1] * sign_b[1], tlo[i1]), thi[i1])
    q_d[i0], q_d[i1] = v0, v1
    qb = q[sl_b].tolist() if isinstance(sl_b, slice) else [float(q[i]) for i in idx_b]
    tb = [kp[i0] * (v0 - qb[0]), kp[i1] * (v1 - qb[1]), kp[i2] * (float(q_d[i2]) - qb[2])]
    if not implicit or ref_vel:
        for k, i in enumerate(idx_b):
            vel = (0.0 if implicit else float(qd[i])) - (float(qd_d[i]) if ref_vel else 0.0)
            tb[k] -= kd[i] * vel
    tb = [fade * x for x in tb]
    if gravity:
        bias = data.qfrc_bias
        tb = [x + float(bias[d]) for x, d in zip(tb, hip.dadr)]
    return tb


def split_hip_torques(t: HumanoidTables, data: mujoco.MjData, tau: FloatArray, tau_torso: Vec3, tb: list[float],
                      forces: dict[str, float], stance: str, swing: str, redistribute: bool) -> float:
    """Eq. 2-5: the swing hip keeps its world torque (from its hinge torques ``tb``), the stance hip takes
    the torso's ``tau_torso`` less the swing hip's, the remainder shared by the feet's loads (``forces``,
    N); both written into ``tau`` as hinge torques. Returns the stance foot's share gamma."""
    jid_b, jid_a = t.hip[swing].jid_sel, t.hip[stance].jid_sel
    axes_b = data.xaxis[jid_b].tolist()
    t_b = hinges_to_world3(axes_b, tb)
    if t_b is None:
        t_b = tuple(hinges_to_world(np.array(axes_b), np.array(tb)).tolist())
    gamma = stance_share(forces[stance], forces[swing])
    t_a, t_b_total = hip_torques(tau_torso, t_b, gamma, redistribute)
    tau[t.hip[stance].sel] = world_to_hinges(data.xaxis[jid_a].tolist(), t_a)
    tau[t.hip[swing].sel] = world_to_hinges(axes_b, t_b_total)
    return gamma
