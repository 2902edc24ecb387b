"""SIMBICON balance equations (the paper's eq. 2-6), as plain functions.

Frames: world, Z up; "heading frame": world turned about Z by the character's heading (x forward,
y left). Torques (N*m) are world vectors unless said otherwise.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.settings import BalanceConfig

FloatArray = npt.NDArray[np.float64]


def feedback_angle(theta0: float, cd: float, cv: float, d: float, v: float, limit: float = np.inf) -> float:
    """Eq. 6: theta_d = theta_d0 + c_d d + c_v v, the feedback part clipped to +-``limit`` rad."""
    fb = cd * float(d) + cv * float(v)
    return theta0 + (limit if fb > limit else -limit if fb < -limit else fb)


def froude(speed: float, leg: float, g: float = 9.81) -> float:
    """The Froude number of a walk, v^2 / (g L): its speed ``speed`` (m/s) against the pendulum speed of a
    leg ``leg`` m long; walks of one Froude number are dynamically alike whatever the body's size."""
    return speed * speed / (g * leg)


def sagittal_cd(balance: BalanceConfig, speed: float, leg: float, g: float = 9.81) -> float:
    """The sagittal c_d (rad per m) for a walk of mean ``speed`` (m/s) on legs ``leg`` m long: the
    configured one, scaled by ``(cd_froude / Fr) ** cd_froude_power`` above the Froude number
    ``balance.cd_froude`` (no scaling when that is null)."""
    cd = balance.sagittal.cd
    if balance.cd_froude is None or leg <= 0.0:
        return cd
    fr = froude(speed, leg, g)
    return cd if fr <= balance.cd_froude else cd * (balance.cd_froude / fr) ** balance.cd_froude_power


def beyond(offset: float, band: float) -> float:
    """The part of ``offset`` outside the band [-band, band] (0 inside it), same units."""
    return offset - band if offset > band else offset + band if offset < -band else 0.0


def course_turn(offset: float, rate: float, gain: float, damping: float, max_turn: float) -> float:
    """Heading correction (rad, positive left) that steers back onto a course:
    ``clamp(-gain offset - damping rate, +-max_turn)``, ``offset`` (m) and ``rate`` (m/s) the lateral
    offset from the course and its rate, positive left; gains in rad/m and rad/(m/s)."""
    turn = -gain * offset - damping * rate
    return max_turn if turn > max_turn else -max_turn if turn < -max_turn else turn


def yaw_within(heading: float, anchor: float, limit: float) -> float:
    """``heading`` (rad) moved to within +-``limit`` rad of ``anchor`` (unchanged when it already is); the
    result differs from ``anchor`` by the wrapped difference, so it may leave [-pi, pi]."""
    dev = math.remainder(heading - anchor, 2.0 * math.pi)
    return anchor + (limit if dev > limit else -limit if dev < -limit else dev)


def stance_share(force_stance: float, force_swing: float) -> float:
    """gamma_f: the share of the vertical ground reaction force carried by the stance foot (A)."""
    total = force_stance + force_swing
    if total <= 1e-9:
        return 1.0
    return min(max(float(force_stance) / total, 0.0), 1.0)


Vec3 = tuple[float, float, float]


def hip_torques(tau_torso: Vec3, tau_swing: Vec3, gamma: float, redistribute: bool = True) -> tuple[Vec3, Vec3]:
    """Eq. 2-5: world torques (stance hip A, swing hip B) the hip actuators apply to the thighs.

    The hips push back on the pelvis with minus those torques, so the pelvis receives ``tau_torso``
    exactly when ``tau_A + tau_B = -tau_torso``. Reading (CONTROLLER.md): the swing hip keeps its
    own tracking torque ``tau_swing`` and adds its share of the remainder,
    ``tau_r = -(tau_torso + tau_swing)``: ``tau_A = gamma tau_r``, ``tau_B = tau_swing + (1-gamma) tau_r``.
    In single support gamma = 1 and this is eq. 2, ``tau_A = -tau_torso - tau_B``. Without
    redistribution the stance hip takes all of ``tau_r`` whatever the load. Plain floats: the
    controller's per-step form.
    """
    g = gamma if redistribute else 1.0
    (x, y, z), (u, v, w) = tau_torso, tau_swing
    rx, ry, rz = -(x + u), -(y + v), -(z + w)
    h = 1.0 - g
    return (g * rx, g * ry, g * rz), (u + h * rx, v + h * ry, w + h * rz)


def world_to_hinges(axes: list[list[float]], tau_world: Vec3) -> list[float]:
    """Hinge torques producing a world torque across a joint: tau_k = a_k . T (a_k world axes, the rows of
    ``axes``). For a torque T applied to the child and -T to the parent, each hinge's generalized force is
    the component of T along its axis (the Jacobian transpose). Plain floats: the per-step form."""
    x, y, z = tau_world
    return [a * x + b * y + c * z for a, b, c in axes]


def hinges_to_world(axes: FloatArray, tau_hinge: FloatArray) -> FloatArray:
    """The world torque whose hinge components are ``tau_hinge`` (inverse of :func:`world_to_hinges`
    for three independent axes; least squares when they are not)."""
    if axes.shape == (3, 3):
        t = hinges_to_world3(axes.tolist(), _floats3(tau_hinge))
        if t is not None:
            return np.array(t)
    return np.linalg.lstsq(axes, tau_hinge, rcond=None)[0]


def hinges_to_world3(axes: list[list[float]], tau_hinge: Vec3) -> Vec3 | None:
    """:func:`hinges_to_world` for three axes on plain floats (Cramer's rule); None when the axes are
    (nearly) dependent."""
    (a, b, c), (d, e, f), (g, h, i) = axes
    x, y, z = tau_hinge
    ei_fh, di_fg, dh_eg = e * i - f * h, d * i - f * g, d * h - e * g
    det = a * ei_fh - b * di_fg + c * dh_eg
    if abs(det) <= 1e-6:
        return None
    return ((x * ei_fh - b * (y * i - f * z) + c * (y * h - e * z)) / det,
            (a * (y * i - f * z) - x * di_fg + c * (d * z - y * g)) / det,
            (a * (e * z - y * h) - b * (d * z - y * g) + x * dh_eg) / det)


def _floats3(v: FloatArray | Vec3) -> Vec3:
    x, y, z = v.tolist() if isinstance(v, np.ndarray) else v
    return float(x), float(y), float(z)


def yaw_matrix(yaw: float) -> FloatArray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def heading_of(r: FloatArray) -> float:
    """Yaw (rad) of a body's x axis projected on the floor."""
    return float(np.arctan2(r[1, 0], r[0, 0]))


def axis_rotation(axis: FloatArray, angle: float) -> FloatArray:
    """Rodrigues: rotation matrix about a unit ``axis`` by ``angle`` rad."""
    x, y, z = (float(v) for v in axis)
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array([[c + x * x * t, x * y * t - z * s, x * z * t + y * s],
                     [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
                     [z * x * t - y * s, z * y * t + x * s, c + z * z * t]])


def euler_from_matrix(r: FloatArray, order: tuple[int, int, int]) -> tuple[float, float, float]:
    """Intrinsic Tait-Bryan angles (a, b, c) with r = R_i(a) R_j(b) R_k(c), axes i, j, k distinct."""
    i, j, k = order
    s = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    m = r.tolist()
    b = math.asin(min(max(s * m[i][k], -1.0), 1.0))
    a = math.atan2(-s * m[j][k], m[k][k])
    c = math.atan2(-s * m[i][j], m[i][i])
    return a, b, c
