"""A legged creature's leap (a jump over a gap), for any number of legs: the planned gait walks on
through the crouch, is set aside from the set until the body has landed, then restarts where it landed.

- **crouch** (``crouch_time`` sqrt(L/g) s): walked -- the gait steps on while its root is lowered
  ``crouch`` L, so its feet stay under the body and the walking speed is carried into the push;
- **set** (``set_time`` sqrt(L/g) s): every foot is set down where it is (a swinging one where it hangs,
  on the floor) and held; the root's sideways sway is brought to rest and its speed along the heading
  eased to ``crouch_carry`` of the walk's, at the crouch's depth;
- **push**: every leg on the floor (within ``touch`` L of it: a foot that bounces off for a step still
  pushes) pushes until it straightens to ``straight`` of its length or a joint reaches its range's end
  (``limit_margin``), its share of the force shrinking from ``bent`` of its length on (a nearly straight
  leg makes a fraction of the force asked of it); the stroke's top is where half the legs have
  straightened, moving along the push's mean velocity from the feet as they stand. The force on the body
  is m (a + g), a the constant acceleration that takes the centre of mass from its velocity now to the
  take-off velocity over the rest of the stroke, re-planned every step (a body that falls behind is
  pushed the harder); the torque about the centre of mass turns the root toward level and brings the
  body's angular momentum to rest by the take-off (``push_spin_stop``), less the moment the body gets beyond
  the feet's planned one (the forces as made, not as planned: a leg near straight delivers less, a foot
  slips), estimated from the angular momentum's rate over ``bias_time`` sqrt(L/g). The feet share that wrench each
  inside its friction cone and pushing (:func:`cone_forces`: non-negative least squares on the cones'
  edges), and the joint torques are the body's inverse dynamics with those contact forces and the feet
  fixed (the legs' own masses included: a dog's legs are near half its mass), held as a whole to the
  torque limits (one factor for every joint). The legs' shape is solved by IK for the body where it is,
  so a trunk that tilts does not lift its feet; a foot off the floor is reached ``press`` L below it;
- **flight**: the legs hold the pose they left the floor in while the body rises (a leg swung in flight
  turns the trunk the other way); past the apex they reach for the ground with their stiffness x
  ``land_stiffness``: each foot to its neutral place under the root, moved ahead along the horizontal
  velocity by ``land_reach`` x v / sqrt(g/L) (toward the capture point: the braking force at the feet
  then passes nearer the centre of mass);
- **landing** (``land_time`` sqrt(L/g) s from the first foot down, on until the body has settled, at most
  ``land_max``): the catch, while the body sinks,
  is the push reversed: the force m (a + g), a the constant deceleration that stops the fall at the
  crouch's depth and takes the horizontal velocity toward ``land_carry`` of the walking speed as far as
  ``land_friction`` of the friction cone allows; once the fall has stopped, the standing PD of the gait
  (its ``body_freq``, ``damping_ratio``) holds the root's height and brings the horizontal velocity to
  ``land_carry`` of the walk's; both by the body's inverse dynamics through the feet on the floor (the
  moment weighed ``land_moment_weight`` x), the root levelled and the spin brought to rest, each foot
  held where it came down (the others reach on), the legs' stiffness rising back to full. A body thrown
  back into the air reaches again and is caught anew;
- **resume** (:func:`resume_gait`): the gait's plan restarts from where the body stands, heading as it
  was steered, at the speed the body has along it (from rest: the settle time and the speed ramp).

Every length scales with L, the height the gait works at, and every time with sqrt(L/g): the same
settings serve any body. Lengths in m, times in s, velocities in m/s, forces in N; world frame, Z up.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.gait import PlannedGait
from bipedsim.control.creature.leap_dynamics import LeapDynamics
from bipedsim.control.creature.leap_plan import (
    LeapSettings,
    cone_forces,
    cone_share,
    lead_time,
    leg_extension,
    leg_lengths,
    push_time,
    stroke,
)
from bipedsim.control.creature.planner import smoothstep

__all__ = ["PHASES", "Leap", "LeapSettings", "cone_forces", "cone_share", "lead_time", "leg_extension", "leg_lengths",
           "push_time", "resume_gait", "stroke"]

#: the phases of a leap, in order
PHASES = ("crouch", "set", "push", "flight", "land", "done")


class Leap(LeapDynamics):
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
        #: each leg's length (m)
        self.leg_len = leg_lengths(gait)
        self.push_s = push_time(self.stroke, self.v_to)
        self.crouch_s, self.set_s = s.crouch_time / self.w0, s.set_time / self.w0
        self.t0 = t
        self.t_set = t + self.crouch_s
        self.t_push = self.t_set + self.set_s
        self.flight_s = 2.0 * self.v_to[2] / self.g
        #: the leap's heading (rad about world Z): its horizontal velocity's, or the plan's
        vh = self.v_to[0:2]
        self.yaw = math.atan2(vh[1], vh[0]) if np.linalg.norm(vh) > 1e-6 else gait.planner.yaw
        #: the root's standing height (m) and where the leap starts (m, world) and its velocity (m/s)
        self.z_stand = stance.height + gait.planner.z_offset
        self.p0 = data.qpos[0:3].copy()
        self.v0 = np.array([*data.qvel[0:2], 0.0])
        #: the root's horizontal velocity (m/s) at the crouch's end: crouch_carry of the walk's along the heading
        ahead = np.array([math.cos(self.yaw), math.sin(self.yaw), 0.0])
        self.v1 = self.settings.crouch_carry * max(float(self.v0 @ ahead), 0.0) * ahead
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
        #: the body's mean spin at the take-off (rad/s, world: angular momentum over inertia, about the
        #: centre of mass): the flight keeps it
        self.w_takeoff: FloatArray | None = None
        self.t_land: float | None = None
        self.t_done: float | None = None
        self.apex_z = -math.inf
        self.peak_force = 0.0
        self.peak_torque_share = 0.0
        #: the least factor the push's wrench torques were scaled by to stay within the limits (1: none)
        self.min_push_scale = 1.0
        #: per leg: the time (s) its foot left the floor during the push (None: down to the take-off)
        self.push_lost: list[float | None] = [None] * len(legs)
        #: per leg: its foot on the floor when the push started
        self.push_feet: list[bool] = [False] * len(legs)
        #: the push's planned rise (m): from where it starts to the stroke's top
        self.push_rise = self.stroke
        self.landed_feet: dict[int, FloatArray] = {}
        self.target = gait.target.copy() if gait.target is not None else data.qpos.copy()
        self.next_plan = t
        self._leg_dofs = set(np.concatenate(legs.dofs).tolist()) if len(legs) else set()
        #: per leg: its ball joints (indices into the body's balls); per ball: its joint id
        self._leg_balls = [[k for k in range(len(body.dadr)) if int(body.dadr[k]) in set(d.tolist())]
                           for d in legs.dofs]
        self._ball_joint = [int(np.flatnonzero(body.model.jnt_dofadr == d)[0]) for d in body.dadr]
        #: the gait's root height offset (m) as it walked: lowered by a walked crouch, restored at take-off
        self.z_offset = gait.planner.z_offset
        #: the moment (N*m, world, about the centre of mass) the body gets beyond the feet's planned one
        #: (:meth:`_moment_bias`), the feet's planned moment at the last control step and the last
        #: angular momentum (time s, kg*m^2/s)
        self.moment_bias = np.zeros(3)
        self.planned_moment = np.zeros(3)
        self._angmom: tuple[float, FloatArray] | None = None
        #: whether the landing's catch has stopped the fall (the hold follows)
        self.caught = False
        #: at the first touch-down: the root's tilt from level (rad) and the centre of mass's horizontal
        #: speed (m/s); the horizontal speed when the catch first stopped the fall (m/s)
        self.land_tilt: float | None = None
        self.land_speed: float | None = None
        self.caught_speed: float | None = None

    # ------------------------------------------------------------------ the plan of the root
    def _root_plan(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The root's planned position (m), velocity (m/s) and acceleration (m/s^2) at ``t`` while the
        feet are down (crouch and push)."""
        s, h = self.settings, self.height
        if t < self.t_push:
            # the set: the horizontal velocity eased from the walk's (v0) to crouch_carry of its share
            # along the heading (v1): v = v0 + (v1 - v0) S(u), S the smoothstep, integrated
            T = max(self.set_s, 1e-9)
            u = min(max((t - self.t_set) / T, 0.0), 1.0)
            dv = self.v1 - self.v0
            p = self.p0 + T * (self.v0 * u + dv * (u ** 3 - 0.5 * u ** 4))
            p[2] = self.z_stand - s.crouch * h
            return p, self.v0 + dv * smoothstep(u), dv * 6.0 * u * (1.0 - u) / T
        tau = min(t - self.t_push, self.push_s)
        a = (self.v_to - self.vp) / self.push_s
        return self.pp + self.vp * tau + 0.5 * a * tau * tau, self.vp + a * tau, a

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
    def step(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float = 0.0) -> FloatArray | None:
        """The joint torques (N*m by actuator) at ``t`` (s; ``dt`` the control period, s); None once the
        landing is over (the gait's plan has restarted: the caller steps the gait)."""
        contact = self.gait.legs.feet_down(data)
        down = self._on_floor(data, contact) if self.phase in ("set", "push") else contact
        self._advance(data, t, down, contact)
        if self.phase == "done":
            resume_gait(self.gait, data, t, self.target)
            self.gait.planner.z_offset = self.z_offset
            return None
        if self.phase == "crouch":
            u = (t - self.t0) / self.crouch_s
            self.gait.planner.z_offset = self.z_offset - self.settings.crouch * self.height * smoothstep(u)
            return self.gait.step(model, data, t, dt)
        return self._control(model, data, t, down, contact)

    def _at_limit(self, data: mujoco.MjData, i: int) -> bool:
        """Whether a ball joint of leg ``i`` has turned to within ``limit_margin`` rad of its range (the
        range's end takes the torque a push would put through it)."""
        gait, model = self.gait, self.gait.body.model
        for k in self._leg_balls[i]:
            j = self._ball_joint[k]
            if not model.jnt_limited[j]:
                continue
            q = data.qpos[gait.body.quat_idx[k]]
            angle = 2.0 * math.acos(min(abs(float(q[0])) / max(float(np.linalg.norm(q)), 1e-12), 1.0))
            if angle >= float(model.jnt_range[j][1]) - self.settings.limit_margin:
                return True
        return False

    def _stretch(self, data: mujoco.MjData) -> list[float]:
        """Per leg: the distance from its root body to its foot site as a share of its length."""
        gait, model = self.gait, self.gait.body.model
        out = []
        for i, leg in enumerate(gait.legs):
            hip = data.xpos[model.body(leg.root).id]
            out.append(float(np.linalg.norm(data.site_xpos[gait.ik.sites[i]] - hip)) / self.leg_len[i])
        return out

    def _on_floor(self, data: mujoco.MjData, down: list[bool]) -> list[bool]:
        """Per leg: its foot touches the floor or hangs within ``touch`` L of its standing height (a foot
        pressed on the floor bounces off it for a step now and then: it is still a foot to push on)."""
        gait = self.gait
        tol = self.settings.touch * self.height
        ground = gait.stance.site_ground
        return [dn or float(data.site_xpos[gait.ik.sites[i]][2]) - ground[i] < tol for i, dn in enumerate(down)]

    def _com_velocity(self, data: mujoco.MjData) -> FloatArray:
        """The body's centre-of-mass velocity (m/s, world): what the push gives and the flight keeps
        (the root's own velocity has the body's turning in it)."""
        mujoco.mj_subtreeVel(self.gait.body.model, data)
        return data.subtree_linvel[self.gait.body.root_body].copy()

    def _advance(self, data: mujoco.MjData, t: float, down: list[bool], contact: list[bool]) -> None:
        """Move on to the next phase when its time or event has come (``down``: the feet on the floor,
        within ``touch``; ``contact``: those touching it now)."""
        v_com = self._com_velocity(data)
        vz = float(v_com[2])
        if self.phase == "crouch" and t >= self.t_set:
            self.phase = "set"
            self._start_set(data, v_com, t)
        if self.phase == "set" and t >= self.t_push:
            self.phase = "push"
            self.push_feet = list(down)
            self._damp_legs(self.settings.push_damping)
            self._start_push(data, v_com, t, down)
        if self.phase == "push":
            for i, dn in enumerate(down):
                if not dn and self.push_lost[i] is None and self.push_feet[i]:
                    self.push_lost[i] = t
            reached = vz >= self.v_to[2]
            overrun = t >= self.t_push + self.settings.push_overrun * self.push_s
            # in the air: no foot touches the floor and half the legs have straightened (a foot that
            # bounces off the floor mid-stroke is still pushing)
            stretch = sorted(self._stretch(data))
            top = stretch[len(stretch) // 2] >= self.settings.straight if stretch else True
            lifted = not any(contact) and (top or t >= self.t_push + self.push_s)
            if reached or overrun or lifted:
                self.phase, self.t_takeoff, self.v_takeoff = "flight", t, v_com
                self.w_takeoff = self._mean_spin(data)[1]
                self.gait.body.damp()
        if self.phase == "flight":
            self.apex_z = max(self.apex_z, float(data.qpos[2]))
            late = t >= self.t_takeoff + self.settings.flight_overrun * max(self.flight_s, self.push_s)
            if (any(down) and vz < 0.0) or late:
                self.phase, self.t_land = "land", t
                self.moment_bias, self._angmom = np.zeros(3), None
                r = data.xmat[self.gait.body.root_body].reshape(3, 3) @ self.gait.stance.att.T
                self.land_tilt = float(math.acos(min(max(float(r[2, 2]), -1.0), 1.0)))
                self.land_speed = float(np.linalg.norm(v_com[0:2]))
        if self.phase == "land":
            for i, dn in enumerate(down):
                if dn and i not in self.landed_feet:
                    p = data.site_xpos[self.gait.ik.sites[i]]
                    self.landed_feet[i] = np.array([p[0], p[1], self.gait.stance.site_ground[i]])
            if t >= self.t_land + self.settings.land_time / self.w0 and (
                    self._settled(data, contact, v_com) or t >= self.t_land + self.settings.land_max / self.w0):
                self.phase, self.t_done = "done", t

    def _start_set(self, data: mujoco.MjData, v_com: FloatArray, t: float) -> None:
        """The set from where the walked crouch left the body at ``t`` (s): every foot held where it is (one
        that swings, where it hangs, on the floor), the root from its place and the centre of mass's
        horizontal velocity (m/s) eased to ``crouch_carry`` of its share along the heading, at the
        crouch's depth; every leg at full stiffness and damping."""
        gait = self.gait
        gait.planner.z_offset = self.z_offset
        ground = gait.stance.site_ground
        self.feet = np.array([[*data.site_xpos[gait.ik.sites[i]][0:2], ground[i]] for i in range(len(gait.legs))])
        self.p0 = data.qpos[0:3].copy()
        self.v0 = np.array([v_com[0], v_com[1], 0.0])
        ahead = np.array([math.cos(self.yaw), math.sin(self.yaw), 0.0])
        self.v1 = self.settings.crouch_carry * max(float(self.v0 @ ahead), 0.0) * ahead
        if gait.target is not None:
            self.target = gait.target.copy()
        self.t_set = t
        self.gait.body.damp()

    def _start_push(self, data: mujoco.MjData, v_com: FloatArray, t: float, down: list[bool]) -> None:
        """The push's plan from where the body is at ``t`` (s): from the root's place and the centre of
        mass's velocity (m/s) to the take-off velocity at the stroke's top, at constant acceleration.
        The stroke's top: where, moving along the push's mean velocity, half the legs on the floor have
        straightened to ``straight`` of their length (the feet as they stand: a leg whose foot stands far
        from under its hip straightens early). A body still sinking from the crouch starts its rise from
        at most half the take-off's vertical speed downward."""
        self.pp = data.qpos[0:3].copy()
        self.vp = v_com.copy()
        self.vp[2] = max(float(v_com[2]), -0.5 * float(self.v_to[2]))
        u = self.vp + self.v_to
        u = u / max(float(np.linalg.norm(u)), 1e-9)
        room = sorted(self._room(data, u, i) for i, dn in enumerate(down) if dn)
        if room:
            reach = room[max(math.ceil(len(room) / 2) - 1, 0)]
            rise = max(reach * float(u[2]), 0.25 * self.stroke)
        else:
            rise = self.stroke
        self.push_rise = rise
        self.push_s = 2.0 * rise / (float(self.vp[2]) + float(self.v_to[2]))
        self.t_push = t

    def _control(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, down: list[bool],
                 contact: list[bool]) -> FloatArray:
        gait, body, s = self.gait, self.gait.body, self.settings
        stiff = 1.0
        force = torque = None
        if self.phase in ("set", "push"):
            p, v, a = self._root_plan(t)
            # the legs' shape solved for the body where it is (the wrench moves it along its plan): a
            # trunk that tilts does not lift its feet off the floor
            q_root = data.qpos[0:7].copy()
            feet = self.feet.copy()
            for i, dn in enumerate(down):
                if not dn:
                    feet[i, 2] -= s.press * self.height
            force, torque = self._wrench(data, p, v, a, attitude=s.push_attitude if self.phase == "push" else 1.0)
            if self.phase == "push":
                force = self._push_force(data)
            stiff = s.push_stiffness if self.phase == "push" else 1.0
        elif self.phase == "flight":
            # rising, the legs hold the pose they left the floor in; past the apex they reach ahead
            q_root = data.qpos[0:7].copy()
            rising = self._com_velocity(data)[2] > 0.0
            feet = None if rising else self._reach_feet(data)
            stiff = 1.0 if rising else s.land_stiffness
        else:  # land
            u = (t - self.t_land) / (s.land_time / self.w0)
            stiff = s.land_stiffness + (1.0 - s.land_stiffness) * smoothstep(u)
            p = np.array([data.qpos[0], data.qpos[1], self.z_stand])
            v_land = s.land_carry * gait.clock.v_des * np.array([math.cos(self.yaw), math.sin(self.yaw), 0.0])
            q_root = data.qpos[0:7].copy()
            feet = self._reach_feet(data)
            if not any(contact):  # thrown back into the air: reach again, to be caught anew
                self.landed_feet, self.caught = {}, False
            else:
                feet[:, 2] = gait.stance.site_ground
                for i, f in self.landed_feet.items():
                    feet[i] = f
                for i, dn in enumerate(contact):  # a foot off the floor reaches below it, as in the push
                    if not dn:
                        feet[i, 2] -= s.press * self.height
            force, torque = self._wrench(data, p, v_land, np.zeros(3), horizontal_pd=False)
            force = self._catch_force(data, v_land, force)
        target = self.target if feet is None else self._solve(q_root, feet, data, t)
        e = body.joint_error(data, target)
        tau_all = np.zeros(model.nu)
        tau_all[body.acts.ravel()] = (stiff * body.kp[:, None] * e).ravel()
        # in the crouch every foot is planned down (one that bounces off the floor for a step keeps
        # pressing toward it); in the push only the feet on the floor push: one that has left it is
        # not flung (its leg keeps its shape)
        stance = list(range(len(down))) if self.phase == "set" else [i for i, dn in enumerate(down) if dn]
        if self.phase == "push":  # a leg straightened, or with a joint at its range's end, is done pushing
            stretch = self._stretch(data)
            stance = [i for i in stance if stretch[i] < s.straight and not self._at_limit(data, i)]
        tau_f = np.zeros(model.nu)
        if force is not None and stance:
            self.peak_force = max(self.peak_force, float(np.linalg.norm(force)))
            m = gait.body.mass
            accel = force / m - np.array([0.0, 0.0, self.g])
            alpha = torque / (m * self.height ** 2)
            # the set and the push: the whole body's spin to rest, over its own inertia; the landing: the
            # gait's standing attitude PD (its moment scaled by m L^2), which holds a stance level
            if self.phase == "land":
                torque_c = torque
            else:
                torque_c = self._centroidal_torque(data, attitude=s.push_attitude if self.phase == "push" else 1.0)
            torque_c = torque_c - self._moment_bias(data, t)
            tau_f = self._inverse_torques(data, accel, alpha, torque_c, stance)
        order = body.acts.ravel()
        lim = np.repeat(body.limit, 3)
        if self.phase == "push":
            share = np.abs((tau_all + tau_f)[order]) / np.maximum(lim, 1e-9)
            self.peak_torque_share = max(self.peak_torque_share, float(share.max()))
        # the wrench's torques scaled as a whole (one factor for every leg) so that with the joints' PD
        # no joint passes its limit: a push held to the limits keeps its direction and moment balance
        pd = np.clip(tau_all[order], -lim, lim)
        wf = tau_f[order]
        room = np.where(wf > 0, lim - pd, lim + pd)
        need = np.abs(wf)
        scale = float(np.min(np.where(need > 1e-12, room / np.maximum(need, 1e-12), np.inf), initial=1.0))
        scale = min(max(scale, 0.0), 1.0)
        if self.phase == "push":
            self.min_push_scale = min(self.min_push_scale, scale)
        tau_all[order] = pd + scale * wf
        return body.clipped(tau_all)

    def _solve(self, q_root: FloatArray, feet: FloatArray, data: mujoco.MjData, t: float) -> FloatArray:
        """The legs' joint targets (a qpos) for the root at ``q_root`` and the feet at ``feet``
        (m, world), re-solved every ``plan_dt_s`` (every step in the push: it lasts a few plans)."""
        gait = self.gait
        if self.phase not in ("push", "land") and t < self.next_plan - 1e-9:
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
        of the joint's limit (1: a leg at its torque limit), the root's tilt from level (rad) and the
        horizontal speed (m/s) at touch-down, and the horizontal speed when the catch stopped the fall."""
        weight = self.gait.body.weight
        flight = None if self.t_takeoff is None or self.t_land is None else self.t_land - self.t_takeoff
        return {"phase": self.phase, "t_start_s": self.t0, "push_s": self.push_s, "t_takeoff_s": self.t_takeoff,
                "takeoff_planned_m_s": [float(x) for x in self.v_to],
                "takeoff_reached_m_s": None if self.v_takeoff is None else [float(x) for x in self.v_takeoff],
                "takeoff_spin_rad_s": None if self.w_takeoff is None else [float(x) for x in self.w_takeoff],
                "t_land_s": self.t_land, "flight_s": flight, "ballistic_flight_s": self.flight_s,
                "apex_z_m": None if self.apex_z == -math.inf else self.apex_z,
                "peak_force_n": self.peak_force, "peak_force_body_weights": self.peak_force / weight,
                "peak_torque_share": self.peak_torque_share, "push_scale_min": self.min_push_scale,
                "push_feet": int(sum(self.push_feet)), "push_rise_m": self.push_rise,
                "push_feet_lost_s": [None if x is None else round(x - self.t_push, 4) for x in self.push_lost],
                "land_tilt_rad": self.land_tilt, "land_speed_m_s": self.land_speed,
                "caught_speed_m_s": self.caught_speed}


def resume_gait(gait: PlannedGait, data: mujoco.MjData, t: float, target: FloatArray) -> None:
    """Restart ``gait``'s plan at ``t`` (s) from where the body stands in ``data``: from the root's place,
    along the plan's heading (as steered), at the speed the body has along it (a share u of the walking
    speed is taken as u of the way up the speed ramp; a body at rest walks off after the settle time), each foot
    planted where it is, the legs' IK warm-started from ``target`` (the last pose tracked), every leg at
    full stiffness and damping."""
    planner, clock, body, n = gait.planner, gait.clock, gait.body, len(gait.legs)
    ground = gait.stance.site_ground
    # the plan's speed picks up where the body's is: u of the walking speed along the heading is u of the
    # way up the speed ramp (a body at rest or going back: the settle time first), the path through the
    # root's place now
    along = float(data.qvel[0:2] @ planner.dir)
    u = min(along / max(clock.v_des, 1e-9), 1.0)
    clock.t_walk = t - u * gait.bal.speed_ramp_s if u > 0.0 else t + gait.bal.settle_s
    planner.origin = data.qpos[0:2].copy()
    planner.origin -= planner.root_path(t) - data.qpos[0:2]
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
