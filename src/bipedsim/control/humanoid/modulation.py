"""Reference modulation for real captures (Lee, Kim & Lee 2010; ``modulation:``).

Two corrections of the reference to the body, on where the clip's legs were re-solved for it:

- swing-foot height by two-link leg IK (``modulation.swing_foot``): the swing ankle's target, the
  reference's hip-to-ankle vector, is raised while the foot is lower than the reference's; the knee target
  bends to shorten the leg and the swing thigh turns to keep the ankle over the same point;
- stance-ankle feedback (``modulation.stance_ankle``): the stance foot's world target tilted toe down
  (centre of pressure forward) while the COM runs ahead of the reference's, outer edge down while it
  runs outward.

Lengths m, angles rad, torques N*m.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import axis_rotation
from bipedsim.control.humanoid.settings import StanceAnkleConfig, SwingFootConfig
from bipedsim.control.humanoid.tables import HumanoidTables

FloatArray = npt.NDArray[np.float64]


def swing_foot_ik(sf: SwingFootConfig, t: HumanoidTables, data: mujoco.MjData, leg: tuple[float, float, float] | None,
                  phase: float | None, swing: str, stance: str, akp: FloatArray, q_d: FloatArray,
                  tau: FloatArray) -> float:
    """Swing-foot height by two-link IK: the reference's leg ``leg`` (ankle from hip, forward and up in the
    heading frame; the foot's height above the other foot) at ``phase`` (0-1 through the step) raised by
    dz (see :class:`~bipedsim.control.settings.SwingFootConfig`). The knee target in ``q_d`` (and its torque
    in ``tau``, at the stiffness ``akp``) changes by the knee angle that shortens the leg so; the returned
    angle (rad, forward) turns the swing thigh's world target to keep the ankle on the raised point."""
    if leg is None or phase is None:
        return 0.0
    x, z, h_ref = leg
    zs = data.xpos[:, 2]
    h = min(float(zs[b]) for b in t.foot_pts[swing]) - min(float(zs[b]) for b in t.foot_pts[stance])
    ph = min(max(phase, 0.0), 1.0)
    err = h_ref - h
    if sf.deadband > 0.0:
        # only a foot lower than its reference by more than the band is raised (the lift phased in
        # over one more band), so a swing that clears the floor as its reference does is left alone
        w = min(max((err - sf.deadband) / sf.deadband, 0.0), 1.0)
        if w == 0.0:
            return 0.0
        err -= sf.deadband
        lift = w * sf.lift
    else:
        lift = sf.lift
    dz = min(max(sf.height_gain * err + lift * math.sin(math.pi * ph), -sf.max_drop), sf.max_raise)
    return raise_swing_ankle(t, q_d, tau, akp, swing, x, z, dz)


def raise_swing_ankle(t: HumanoidTables, q_d: FloatArray, tau: FloatArray, akp: FloatArray, swing: str, x: float,
                      z: float, dz: float) -> float:
    """The swing leg's hip-to-ankle vector (``x`` forward, ``z`` up, m, heading frame) raised by ``dz`` m
    by two-link IK: the knee's target in ``q_d`` bent to match (within its range; its PD torque in ``tau``
    moved with it, gains ``akp``) and the change of the thigh's angle returned (rad)."""
    l1, l2 = t.leg_len[swing]
    k0, b0 = two_link(l1, l2, math.hypot(x, z))
    k1, b1 = two_link(l1, l2, math.hypot(x, z + dz))
    i = t.knee[swing]
    new = min(max(float(q_d[i]) + k1 - k0, t.tlo_l[i]), t.thi_l[i])
    tau[i] += akp[i] * (new - float(q_d[i]))
    q_d[i] = new
    return math.atan2(x, -(z + dz)) - math.atan2(x, -z) + b1 - b0


def two_link(l1: float, l2: float, reach: float) -> tuple[float, float]:
    """A two-link leg (thigh ``l1``, shin ``l2``, m) reaching ``reach`` m from hip to ankle: the knee's
    flexion and the thigh's angle ahead of the hip-ankle line (rad), the reach clamped to what the
    links can span."""
    r = min(max(reach, abs(l1 - l2) + 1e-3), 0.9999 * (l1 + l2))
    knee = math.pi - math.acos(min(max((l1 * l1 + l2 * l2 - r * r) / (2 * l1 * l2), -1.0), 1.0))
    thigh = math.acos(min(max((l1 * l1 + r * r - l2 * l2) / (2 * l1 * r), -1.0), 1.0))
    return knee, thigh


def stance_tilt(sa: StanceAnkleConfig, com: tuple[float, float, float, float], d_ref: FloatArray,
                v_ref: FloatArray) -> FloatArray:
    """Stance-ankle feedback: the heading-frame rotation applied to the stance foot's target, from the
    COM ``com`` (d forward, d left, v forward, v left; m, m/s) against the reference's own ``d_ref`` and
    ``v_ref`` on this frame: pitched toe down by kv (v - v_ref) + kd (d - d_ref) forward, rolled
    likewise sideways, each at most ``max_angle``."""
    d0, d1, v0, v1 = com
    lim = sa.max_angle
    a = min(max(sa.kv * (v0 - float(v_ref[0])) + sa.kd * (d0 - float(d_ref[0])), -lim), lim)
    b = min(max(-(sa.kv * (v1 - float(v_ref[1])) + sa.kd * (d1 - float(d_ref[1]))), -lim), lim)
    return axis_rotation(np.array([0.0, 1.0, 0.0]), a).dot(axis_rotation(np.array([1.0, 0.0, 0.0]), b))
