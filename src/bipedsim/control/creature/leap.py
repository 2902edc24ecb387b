"""A legged creature's leap (a jump over a gap), for any number of legs: the planned gait is set
aside from :meth:`Leap.__init__` until the body has landed, then restarted where it landed.

- **crouch** (``crouch_time`` sqrt(L/g) s): every foot is set down where it is (a swinging one where
  it hangs, on the floor) and held there while the root sinks ``crouch`` L, keeping its horizontal
  velocity;
- **push**: every leg touching the floor (a foot that has left it is not pushed on) pushes the virtual
  force that takes the body from where it is and its velocity to the take-off velocity over the rest of
  the stroke, to the legs straightened to ``straight`` of their length (constant acceleration: the push
  lasts 2 x rise / (v_z now + v_z take-off)), F = m (a_plan + g) plus a PD of
  the root toward its planned path, and a PD of the attitude toward level; shared among the feet, each
  share held to the friction cone, made joint torques through each leg's Jacobian transpose (as the
  gait's virtual forces are, :meth:`~bipedsim.control.creature.legs.LegSet.stance_torques`), the legs'
  joints PD-tracking the plan solved by IK with the feet where they stand;
- **flight**: the legs tucked (each foot drawn ``tuck`` L up toward the trunk from its neutral place,
  held in the root's own frame) while the body rises; past the apex they reach for the ground (the
  neutral stance under the root) with their stiffness x ``land_stiffness``;
- **landing** (``land_time`` sqrt(L/g) s from the first foot down): each foot is held where it came
  down (the others reach on), the root's height and attitude are held by the standing PD of the gait
  (its ``body_freq``, ``attitude_freq``, ``damping_ratio``) and its horizontal velocity brought to the
  walking speed along the leap's heading, the legs' stiffness rising back to full;
- **resume** (:func:`resume_gait`): the gait's plan restarts from where the body stands, as a walk
  from rest (its settle time and speed ramp), heading as it was steered.

Every length scales with L, the height the gait works at, and every time with sqrt(L/g): the same
settings serve any body. Lengths in m, times in s, velocities in m/s, forces in N; world frame, Z up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.frames import rot_z
from bipedsim.control.creature.gait import PlannedGait
from bipedsim.control.creature.planner import smoothstep
from bipedsim.errors import ConfigError

#: the phases of a leap, in order
PHASES = ("crouch", "push", "flight", "land", "done")


@dataclass(frozen=True)
class LeapSettings:
    """How a creature leaps (lengths in units of L, the gait's standing height; times in sqrt(L/g))."""

    #: the root sinks this x L before the push: the start of the push's stroke
    crouch: float = field(default=0.25, metadata={"min": 0.0, "max": 0.5})
    #: the push ends with the legs straightened to this share of their length (the bones from the leg's
    #: root to its foot, end to end), or as they stand where that is straighter: the stroke's top
    straight: float = field(default=0.92, metadata={"gt": 0.0, "max": 1.0})
    #: the crouch lasts this x sqrt(L/g): long enough for a swinging foot to come down
    crouch_time: float = field(default=1.2, metadata={"gt": 0.0, "max": 10.0})
    #: the legs' joint damping during the push, a share of the full (the gait's kd): the damping that
    #: steadies a standing leg would swallow much of a push that straightens it in a tenth of a second
    push_damping: float = field(default=0.1, metadata={"min": 0.0, "max": 1.0})
    #: the legs' joint stiffness during the push, a share of full (the crouch holds them at full): the
    #: virtual force through the legs does the pushing, the joints' PD only keeps the legs' shape
    push_stiffness: float = field(default=0.3, metadata={"gt": 0.0, "max": 1.0})
    #: the push ends at the latest after this x its planned time (a body that cannot reach the take-off
    #: velocity leaves the ground with what it reached)
    push_overrun: float = field(default=1.5, metadata={"min": 1.0, "max": 5.0})
    #: in flight, each foot drawn this x L up toward the trunk from its neutral place
    tuck: float = field(default=0.2, metadata={"min": 0.0, "max": 0.6})
    #: the legs' joint stiffness while they reach for the ground and at touch-down, a share of full
    land_stiffness: float = field(default=0.4, metadata={"gt": 0.0, "max": 1.0})
    #: the landing lasts this x sqrt(L/g) from the first foot down, the stiffness back to full over it
    land_time: float = field(default=3.0, metadata={"gt": 0.0, "max": 20.0})
    #: the flight ends (the landing starts) at the latest this x the ballistic flight time of the take-off
    #: velocity: a body that never touches down again stops waiting
    flight_overrun: float = field(default=3.0, metadata={"min": 1.0, "max": 10.0})

    def validate(self) -> None:
        """Each value in its range (a :class:`ConfigError` naming the key)."""
        for f in self.__dataclass_fields__.values():
            v, meta = getattr(self, f.name), f.metadata
            ok = isinstance(v, (int, float)) and math.isfinite(v)
            ok = ok and v >= meta.get("min", -math.inf) and v <= meta.get("max", math.inf)
            ok = ok and ("gt" not in meta or v > meta["gt"])
            if not ok:
                raise ConfigError(f"out of range, got {v!r}", key=f"leap.{f.name}")


def leg_extension(gait: PlannedGait, straight: float) -> float:
    """The least room (m) any leg of ``gait``'s body has to straighten from its neutral stance: per leg,
    ``straight`` x its length (its bones from the leg's root body to its foot site, end to end, as
    posed in the stance) less the distance from its root to its foot site as it stands; at least 0."""
    model, legs, ik = gait.body.model, gait.legs, gait.ik
    d = mujoco.MjData(model)
    d.qpos[:] = gait.stance.q
    mujoco.mj_kinematics(model, d)
    room = math.inf
    for i, leg in enumerate(legs):
        pts = np.array([d.xpos[model.body(b).id] for b in leg.bodies] + [d.site_xpos[ik.sites[i]]])
        length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        room = min(room, straight * length - float(np.linalg.norm(pts[-1] - pts[0])))
    return max(room, 0.0) if math.isfinite(room) else 0.0


def stroke(gait: PlannedGait, settings: LeapSettings) -> float:
    """The push's stroke (m): the root's rise from the crouch (``crouch`` x L below standing) to the
    legs straightened (:func:`leg_extension`)."""
    return settings.crouch * gait.legs.height + leg_extension(gait, settings.straight)


def push_time(stroke_m: float, velocity: FloatArray) -> float:
    """The push's planned duration (s) for a take-off ``velocity`` (m/s, world; its z part > 0) over a
    stroke of ``stroke_m`` (m) at constant vertical acceleration from rest to v_z: 2 stroke / v_z."""
    vz = float(velocity[2])
    if not (math.isfinite(vz) and vz > 0.0):
        raise ConfigError(f"a leap's take-off velocity must rise (its z part > 0 m/s), got {vz!r}",
                          key="leap.velocity")
    return 2.0 * stroke_m / vz


def lead_time(gait: PlannedGait, velocity: FloatArray, settings: LeapSettings) -> float:
    """The time (s) from a leap's start to its planned take-off: the crouch and the push."""
    return settings.crouch_time / gait.legs.omega0 + push_time(stroke(gait, settings), velocity)


class Leap:
    """One leap of ``gait``'s body from time ``t`` (s) toward the take-off ``velocity`` (m/s, world),
    its control step (:meth:`step`: torques by actuator, None once the gait has resumed) and what
    happened (:meth:`record`). See the module text."""

    def __init__(self, gait: PlannedGait, data: mujoco.MjData, t: float, velocity: FloatArray,
                 settings: LeapSettings | None = None) -> None:
        self.gait, self.settings = gait, settings or LeapSettings()
        self.settings.validate()
        legs, body, stance = gait.legs, gait.body, gait.stance
        self.g = -float(body.model.opt.gravity[2])
        self.height, self.w0 = legs.height, legs.omega0
        self.v_to = np.asarray(velocity, dtype=float).reshape(3).copy()
        s = self.settings
        #: the push's stroke (m) and planned duration (s)
        self.stroke = stroke(gait, s)
        self.push_s = push_time(self.stroke, self.v_to)
        self.crouch_s = s.crouch_time / self.w0
        self.t0 = t
        self.t_push = t + self.crouch_s
        self.flight_s = 2.0 * self.v_to[2] / self.g
        #: the leap's heading (rad about world Z): its horizontal velocity's, or the plan's
        vh = self.v_to[0:2]
        self.yaw = math.atan2(vh[1], vh[0]) if np.linalg.norm(vh) > 1e-6 else gait.planner.yaw
        #: the root's standing height (m) and where the leap starts (m, world) and its velocity (m/s)
        self.z_stand = stance.height + gait.planner.z_offset
        self.p0 = data.qpos[0:3].copy()
        self.v0 = np.array([*data.qvel[0:2], 0.0])
        self.phase = "crouch"
        down = legs.feet_down(data)
        ground = stance.site_ground
        #: each foot's place (m, world) while it stands: where it is, set on the floor
        self.feet = np.array([[*data.site_xpos[gait.ik.sites[i]][0:2], ground[i]] for i in range(len(legs))])
        self.down_at_start = list(down)
        # the push's plan at its start: filled when the crouch ends
        self.pp = self.p0.copy()
        self.vp = self.v0.copy()
        self.t_takeoff: float | None = None
        self.v_takeoff: FloatArray | None = None
        self.t_land: float | None = None
        self.t_done: float | None = None
        self.apex_z = -math.inf
        self.peak_force = 0.0
        self.peak_torque_share = 0.0
        self.landed_feet: dict[int, FloatArray] = {}
        self.target = gait.target.copy() if gait.target is not None else data.qpos.copy()
        self.next_plan = t
        self._leg_dofs = set(np.concatenate(legs.dofs).tolist()) if len(legs) else set()
        body.damp()  # full damping on every leg: the gait's softened swing legs are all set down

    # ------------------------------------------------------------------ the plan of the root
    def _root_plan(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The root's planned position (m), velocity (m/s) and acceleration (m/s^2) at ``t`` while the
        feet are down (crouch and push)."""
        s, h = self.settings, self.height
        if t < self.t_push:
            u = (t - self.t0) / self.crouch_s
            p = self.p0 + self.v0 * (t - self.t0)
            p[2] = self.z_stand - s.crouch * h * smoothstep(u)
            return p, self.v0.copy(), np.zeros(3)
        tau = min(t - self.t_push, self.push_s)
        a = (self.v_to - self.vp) / self.push_s
        return self.pp + self.vp * tau + 0.5 * a * tau * tau, self.vp + a * tau, a

    def _attitude(self) -> FloatArray:
        """The root's planned orientation (quaternion w, x, y, z): the stance's, level, at the leap's heading."""
        r = rot_z(self.yaw) @ self.gait.stance.att
        return Rotation.from_matrix(r).as_quat(scalar_first=True)

    def _body_feet(self, data: mujoco.MjData, lift: float) -> FloatArray:
        """Each foot's neutral place under the root as it is now (its own frame), raised ``lift`` m."""
        st = self.gait.stance
        r = data.xmat[self.gait.body.root_body].reshape(3, 3) @ st.att.T
        off = st.feet + np.array([0.0, 0.0, lift])
        return data.qpos[0:3] + off @ r.T

    def _damp_legs(self, share: float) -> None:
        """The legs' joint damping: the model's own plus ``share`` x each ball joint's kd."""
        body = self.gait.body
        body.damp()
        for k, d in enumerate(body.dadr):
            if int(d) in self._leg_dofs:
                body.model.dof_damping[d:d + 3] = body.base_damping[d:d + 3] + share * body.kd[k]

    # ------------------------------------------------------------------ the control step
    def step(self, model: mujoco.MjModel, data: mujoco.MjData, t: float) -> FloatArray | None:
        """The joint torques (N*m by actuator) at ``t`` (s); None once the landing is over (the gait's
        plan has restarted: the caller steps the gait)."""
        down = self.gait.legs.feet_down(data)
        self._advance(data, t, down)
        if self.phase == "done":
            resume_gait(self.gait, data, t, self.target)
            return None
        return self._control(model, data, t, down)

    def _com_velocity(self, data: mujoco.MjData) -> FloatArray:
        """The body's centre-of-mass velocity (m/s, world): what the push gives and the flight keeps
        (the root's own velocity has the body's turning in it)."""
        mujoco.mj_subtreeVel(self.gait.body.model, data)
        return data.subtree_linvel[self.gait.body.root_body].copy()

    def _advance(self, data: mujoco.MjData, t: float, down: list[bool]) -> None:
        """Move on to the next phase when its time or event has come."""
        v_com = self._com_velocity(data)
        vz = float(v_com[2])
        if self.phase == "crouch" and t >= self.t_push:
            self.phase = "push"
            self._damp_legs(self.settings.push_damping)
            self._start_push(data, v_com, t)
        if self.phase == "push":
            reached = vz >= self.v_to[2]
            overrun = t >= self.t_push + self.settings.push_overrun * self.push_s
            lifted = not any(down) and t >= self.t_push + 0.5 * self.push_s
            if reached or overrun or lifted:
                self.phase, self.t_takeoff, self.v_takeoff = "flight", t, v_com
                self.gait.body.damp()
        if self.phase == "flight":
            self.apex_z = max(self.apex_z, float(data.qpos[2]))
            late = t >= self.t_takeoff + self.settings.flight_overrun * max(self.flight_s, self.push_s)
            if (any(down) and vz < 0.0) or late:
                self.phase, self.t_land = "land", t
        if self.phase == "land":
            for i, dn in enumerate(down):
                if dn and i not in self.landed_feet:
                    p = data.site_xpos[self.gait.ik.sites[i]]
                    self.landed_feet[i] = np.array([p[0], p[1], self.gait.stance.site_ground[i]])
            if t >= self.t_land + self.settings.land_time / self.w0:
                self.phase, self.t_done = "done", t

    def _start_push(self, data: mujoco.MjData, v_com: FloatArray, t: float) -> None:
        """The push's plan from where the body is at ``t`` (s): from the root's place and the centre of
        mass's velocity (m/s) to the take-off velocity at the stroke's top (the legs straightened to
        ``straight``), at constant acceleration. A body still sinking from the crouch starts its rise
        from at most half the take-off's vertical speed downward."""
        self.pp = data.qpos[0:3].copy()
        self.vp = v_com.copy()
        self.vp[2] = max(float(v_com[2]), -0.5 * float(self.v_to[2]))
        top = self.z_stand + leg_extension(self.gait, self.settings.straight)
        rise = max(top - float(self.pp[2]), 0.25 * self.stroke)
        self.push_s = 2.0 * rise / (float(self.vp[2]) + float(self.v_to[2]))
        self.t_push = t

    def _control(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, down: list[bool]) -> FloatArray:
        gait, body, legs, s = self.gait, self.gait.body, self.gait.legs, self.settings
        stiff = 1.0
        force = torque = None
        if self.phase in ("crouch", "push"):
            p, v, a = self._root_plan(t)
            q_root = np.concatenate([p, self._attitude()])
            feet = self.feet
            force, torque = self._wrench(data, p, v, a)
            stiff = s.push_stiffness if self.phase == "push" else 1.0
        elif self.phase == "flight":
            q_root = data.qpos[0:7].copy()
            rising = data.qvel[2] > 0.0
            feet = self._body_feet(data, s.tuck * self.height if rising else 0.0)
            stiff = 1.0 if rising else s.land_stiffness
        else:  # land
            u = (t - self.t_land) / (s.land_time / self.w0)
            stiff = s.land_stiffness + (1.0 - s.land_stiffness) * smoothstep(u)
            p = np.array([data.qpos[0], data.qpos[1], self.z_stand])
            v_walk = gait.clock.v_des * np.array([math.cos(self.yaw), math.sin(self.yaw), 0.0])
            q_root = np.concatenate([p, self._attitude()])
            feet = self._body_feet(data, 0.0)
            feet[:, 2] = gait.stance.site_ground
            for i, f in self.landed_feet.items():
                feet[i] = f
            force, torque = self._wrench(data, p, v_walk, np.zeros(3), horizontal_pd=False)
        target = self._solve(q_root, feet, data, t)
        e = body.joint_error(data, target)
        tau_all = np.zeros(model.nu)
        tau_all[body.acts.ravel()] = (stiff * body.kp[:, None] * e).ravel()
        # in the crouch every foot is planned down (one that bounces off the floor for a step keeps
        # pressing toward it); in the push only the feet on the floor push: one that has left it is
        # not flung (its leg keeps its shape)
        stance = list(range(len(down))) if self.phase == "crouch" else [i for i, dn in enumerate(down) if dn]
        if force is not None and stance:
            self.peak_force = max(self.peak_force, float(np.linalg.norm(force)))
            tau_all += legs.stance_torques(data, force, torque, stance, data.subtree_com[body.root_body],
                                           gait.bal.friction)
        if self.phase == "push":
            lim = np.repeat(body.limit, 3)
            share = np.abs(tau_all[body.acts.ravel()]) / np.maximum(lim, 1e-9)
            self.peak_torque_share = max(self.peak_torque_share, float(share.max()))
        return body.clipped(tau_all)

    def _wrench(self, data: mujoco.MjData, p: FloatArray, v: FloatArray, a: FloatArray,
                horizontal_pd: bool = True) -> tuple[FloatArray, FloatArray]:
        """The virtual force (N) and torque (N*m) on the root: the planned acceleration and gravity,
        a PD toward the planned position (horizontal too with ``horizontal_pd``) and velocity, and a
        PD of the attitude toward level at the leap's heading."""
        gait, b = self.gait, self.gait.bal
        m, root = gait.body.mass, gait.body.root_body
        w = b.body_freq * self.w0
        err = p - data.qpos[0:3]
        if not horizontal_pd:
            err[0:2] = 0.0
        force = m * (a + w * w * err + 2 * b.damping_ratio * w * (v - self._com_velocity(data)))
        force[2] += m * self.g
        r = data.xmat[root].reshape(3, 3)
        r_d = rot_z(self.yaw) @ gait.stance.att
        rot = Rotation.from_matrix(r_d @ r.T).as_rotvec()
        wa = b.attitude_freq * self.w0
        torque = m * self.height ** 2 * (wa * wa * rot - 2 * b.damping_ratio * wa * (r @ data.qvel[3:6]))
        return force, torque

    def _solve(self, q_root: FloatArray, feet: FloatArray, data: mujoco.MjData, t: float) -> FloatArray:
        """The legs' joint targets (a qpos) for the root at ``q_root`` and the feet at ``feet``
        (m, world), re-solved every ``plan_dt_s`` (every step in the push: it lasts a few plans)."""
        gait = self.gait
        if self.phase != "push" and t < self.next_plan - 1e-9:
            return self.target
        q = self.target.copy()
        q[0:7] = q_root
        gait.ik.solve(q, feet, gait.stance.q, gait.bal.posture_pull,
                      attitude=lambda i: gait.rules.foot_attitude(i, gait.fwd, self.yaw, gait.ik.data))
        self.target = q
        gait.target = q
        self.next_plan = t + gait.planner.dt_plan
        return q

    # ------------------------------------------------------------------ read-outs
    def record(self) -> dict[str, Any]:
        """What the leap did: its phase now, times (s), the planned and reached take-off velocity
        (m/s), the flight's measured and ballistic duration (s), the root's highest point (m), the push's
        peak virtual force (N, and as a multiple of the body weight) and its peak joint torque as a share
        of the joint's limit (1: a leg at its torque limit)."""
        weight = self.gait.body.weight
        flight = None if self.t_takeoff is None or self.t_land is None else self.t_land - self.t_takeoff
        return {"phase": self.phase, "t_start_s": self.t0, "push_s": self.push_s, "t_takeoff_s": self.t_takeoff,
                "takeoff_planned_m_s": [float(x) for x in self.v_to],
                "takeoff_reached_m_s": None if self.v_takeoff is None else [float(x) for x in self.v_takeoff],
                "t_land_s": self.t_land, "flight_s": flight, "ballistic_flight_s": self.flight_s,
                "apex_z_m": None if self.apex_z == -math.inf else self.apex_z,
                "peak_force_n": self.peak_force, "peak_force_body_weights": self.peak_force / weight,
                "peak_torque_share": self.peak_torque_share}


def resume_gait(gait: PlannedGait, data: mujoco.MjData, t: float, target: FloatArray) -> None:
    """Restart ``gait``'s plan at ``t`` (s) from where the body stands in ``data``: a walk from rest (its
    settle time and speed ramp) from the root's place, along the plan's heading (as steered), each foot
    planted where it is, the legs' IK warm-started from ``target`` (the last pose tracked), every leg at
    full stiffness and damping."""
    planner, clock, body, n = gait.planner, gait.clock, gait.body, len(gait.legs)
    ground = gait.stance.site_ground
    planner.origin = data.qpos[0:2].copy()
    clock.t_walk = t + gait.bal.settle_s
    planner.shift = np.zeros(2)
    planner.v_filt = data.qvel[0:2].copy()
    planner.lift = [None] * n
    planner.planted = [np.array([*data.site_xpos[gait.ik.sites[i]][0:2], ground[i]]) for i in range(n)]
    planner.ik.q = target.copy()
    gait.target = target.copy()
    gait.next_plan = t
    gait.qdot_ref = np.zeros(body.model.nv)
    gait._swing_state = [False] * n
    gait._kp_now, gait._kd_now = body.kp.copy(), body.kd.copy()
    body.damp()


__all__ = ["PHASES", "Leap", "LeapSettings", "lead_time", "leg_extension", "push_time", "resume_gait", "stroke"]
