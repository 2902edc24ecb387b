"""The torso law: the pelvis held in the world frame, toward a heading the course law steers.

SIMBICON controls the pelvis in the world frame, not relative to its parent. Its target is the
reference pelvis's orientation in its own heading frame, turned to a heading target; the world torque
on the pelvis is a PD law per heading-frame axis (roll, pitch, yaw). The heading target is the
reference's course heading, turned back toward the course when the body has left it
(:class:`CourseSteering`), and kept within ``balance.stance_yaw_limit`` of the loaded stance foot's yaw
(:func:`torso_heading`). Frames: world, Z up; the heading frame is the world turned about Z by a
heading (x forward, y left). Torques N*m, angles rad.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import beyond, course_turn, heading_of, yaw_matrix, yaw_within
from bipedsim.control.humanoid.settings import BalanceConfig, CourseConfig
from bipedsim.control.humanoid.sources import Course, CourseTracker, GaitSource

FloatArray = npt.NDArray[np.float64]
Vec3 = tuple[float, float, float]


#: m/s: a COM slower than this (low-passed) has no direction of travel to measure a crab by
MIN_CRAB_SPEED = 0.1


class CourseSteering:
    """Course control (``balance.course``): the torso law's heading target from the reference's course.

    At :meth:`reset` the course is laid on the body's root and heading. Each :meth:`steer` places the
    centre of mass on it: the lateral offset e (m, positive left) and its rate (m/s, low-passed over
    ``rate_filter`` s) turn the course's heading back toward it beyond a deadband,
    ``h_ref + clamp(-steer_gain e_b - steer_damping e_dot, +-max_turn)``. Without steering the heading
    target stays the pelvis's heading at the start."""

    def __init__(self, course: Course, cc: CourseConfig) -> None:
        self.tracker = CourseTracker(course)
        self.cc = cc
        self.start: tuple[float, float] | None = None  #: the COM's place on the course at reset
        self.rate_f = 0.0  #: the offset's rate, low-passed (m/s)
        self.offset = 0.0  #: the COM's lateral offset from the course at the last step (m, positive left)
        self.heading_target = 0.0  #: rad, world
        self.crab = 0.0  #: rad, the compensated crab (the body's less the reference's, low-passed)
        self._v = (0.0, 0.0)  #: the COM velocity low-passed (m/s, world)
        self._h = (1.0, 0.0)  #: the pelvis heading's cosine and sine low-passed
        self.r_heading = np.eye(3)  #: the heading target's yaw rotation (refilled in place)

    def reset(self, source: GaitSource, frame: float, data: mujoco.MjData, pelvis: int) -> None:
        """Start at the pelvis's heading, the course laid from the reference's ``frame`` onto the body."""
        self.heading_target = heading_of(data.xmat[pelvis].reshape(3, 3))
        self.r_heading = yaw_matrix(self.heading_target)
        ref_pose, seg = source.course_start(frame)
        self.tracker.reset(ref_pose, (float(data.qpos[0]), float(data.qpos[1]), self.heading_target), seg)
        cx, cy, _ = data.subtree_com[pelvis].tolist()
        self.start = self.tracker.locate(cx, cy)
        self.rate_f = 0.0
        self.crab = 0.0
        self._v = (float(data.subtree_linvel[pelvis][0]), float(data.subtree_linvel[pelvis][1]))
        self._h = (math.cos(self.heading_target), math.sin(self.heading_target))

    def steer(self, cx: float, cy: float, vx: float, vy: float, hc: float, hs: float, dt: float) -> None:
        """The COM at (cx, cy) m moving at (vx, vy) m/s (world), the pelvis heading's cosine ``hc`` and
        sine ``hs``, after a control step of ``dt`` s: the heading target becomes the course's heading
        turned back toward it and against the walk's crab."""
        cc = self.cc
        offset, rate, h_ref = self.tracker.update(cx, cy, vx, vy)
        if cc.crab_filter_s > 0.0 and self.tracker.moving:
            self._measure_crab(vx, vy, hc, hs, min(1.0, dt / cc.crab_filter_s))
        self.offset = offset
        # the rate is low-passed: the walk's own sway swings it by about 0.1 m/s within every cycle
        a = dt / cc.rate_filter
        self.rate_f += (a if a < 1.0 else 1.0) * (rate - self.rate_f)
        # inside the band the law is silent (damping included): the balance law keeps the walk's sway
        offset = beyond(offset, cc.deadband)
        rate = self.rate_f if offset != 0.0 else 0.0
        h_t = h_ref + course_turn(offset, rate, cc.steer_gain, cc.steer_damping, cc.max_turn) - self.crab
        self.heading_target = h_t
        rh, ch, sh = self.r_heading, math.cos(h_t), math.sin(h_t)
        rh[0, 0], rh[0, 1], rh[1, 0], rh[1, 1] = ch, -sh, sh, ch

    def _measure_crab(self, vx: float, vy: float, hc: float, hs: float, a: float) -> None:
        """Low-pass the COM velocity (vx, vy) m/s and the pelvis heading (its cosine ``hc`` and sine
        ``hs``) by the share ``a``, and move :attr:`crab` that share toward the angle between them less the
        reference's own crab."""
        v0, v1 = self._v
        v0, v1 = v0 + a * (vx - v0), v1 + a * (vy - v1)
        c, s = self._h
        c, s = c + a * (hc - c), s + a * (hs - s)
        self._v, self._h = (v0, v1), (c, s)
        if v0 * v0 + v1 * v1 < MIN_CRAB_SPEED * MIN_CRAB_SPEED:  # too slow to have a direction
            return
        body = math.remainder(math.atan2(v1, v0) - math.atan2(s, c), 2.0 * math.pi)
        m = self.cc.max_crab
        err = max(-m, min(m, math.remainder(body - self.tracker.crab(), 2.0 * math.pi)))
        self.crab += a * (err - self.crab)

    def progress(self, cx: float, cy: float) -> tuple[float, float] | None:
        """The COM at (cx, cy)'s progress (m) along the course since :meth:`reset` and its lateral offset
        (m, positive left) now; None for a walk in place."""
        now = self.tracker.locate(cx, cy)
        if now is None or self.start is None:
            return None
        return now[0] - self.start[0], now[1]


def torso_heading(rh: FloatArray, scratch: FloatArray, limit: float | None, stance_force: float,
                  foot_ref: FloatArray | None, foot_xmat: FloatArray) -> FloatArray:
    """The torso law's heading rotation: ``rh`` (the heading target's), its yaw kept within ``limit`` rad
    of the stance foot's yaw (``foot_xmat``, its 9 world-rotation entries) less the reference foot's own
    yaw from its pelvis (``foot_ref``: the reference foot in its heading frame), while that foot is loaded
    (``stance_force`` N > 0). The ankles have no yaw hinge and a sole holds little torque about the
    vertical: a pelvis turned far against its feet would spin the stance foot. ``scratch``: a 3x3 filled
    and returned when the limit applies."""
    if limit is None or stance_force <= 0.0 or foot_ref is None:
        return rh
    h = math.atan2(float(rh[1, 0]), float(rh[0, 0]))
    anchor = math.atan2(float(foot_xmat[3]), float(foot_xmat[0])) - math.atan2(float(foot_ref[1, 0]),
                                                                               float(foot_ref[0, 0]))
    h_t = yaw_within(h, anchor, limit)
    if h_t == h:
        return rh
    ch, sh = math.cos(h_t), math.sin(h_t)
    scratch[0, 0], scratch[0, 1], scratch[1, 0], scratch[1, 1] = ch, -sh, sh, ch
    return scratch


def torso_torque(b: BalanceConfig, roll_kp: float, r_heading: FloatArray, pelvis_ref: FloatArray, r_p: FloatArray,
                 pm: list[float], omega_body: list[float], c: float, s: float) -> Vec3:
    """The torso law: the world torque (N*m) turning the pelvis (rotation ``r_p``, ``pm`` its 9 entries row
    by row, angular velocity ``omega_body`` rad/s in its own frame) toward the reference pelvis
    ``pelvis_ref`` (in its heading frame) under the heading rotation ``r_heading``: PD per heading-frame
    axis, roll about forward x with ``roll_kp``, pitch about lateral y with ``torso_kp``, yaw with
    ``heading_kp``, each damped by ``torso_kd``; ``c``, ``s``: cos and sin of the pelvis's heading.
    (ndarray.dot, not @: on 3x3s the matmul ufunc's dispatch costs twice the product.)"""
    w0, w1, w2 = rotvec3(r_heading.dot(pelvis_ref).dot(r_p.T))
    e0, e1 = c * w0 + s * w1, -s * w0 + c * w1
    p00, p01, p02, p10, p11, p12, p20, p21, p22 = pm
    x, y, z = omega_body
    ow0, ow1, ow2 = p00 * x + p01 * y + p02 * z, p10 * x + p11 * y + p12 * z, p20 * x + p21 * y + p22 * z
    o0, o1 = c * ow0 + s * ow1, -s * ow0 + c * ow1
    h0 = roll_kp * e0 - b.torso_kd * o0
    h1 = b.torso_kp * e1 - b.torso_kd * o1
    return (c * h0 - s * h1, s * h0 + c * h1, b.heading_kp * w2 - b.torso_kd * ow2)


def rotvec3(e: FloatArray) -> Vec3:
    """Rotation vector (rad) of a rotation matrix, as three floats."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = e.ravel().tolist()
    cos = min(max((m00 + m11 + m22 - 1.0) * 0.5, -1.0), 1.0)
    ang = math.acos(cos)
    s = math.sin(ang)
    k = 0.5 if s < 1e-6 else ang / (2.0 * s)
    return (m21 - m12) * k, (m02 - m20) * k, (m10 - m01) * k
