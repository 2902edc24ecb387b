"""The body dynamics a creature leap (:mod:`~bipedsim.control.creature.leap`) controls with: the push's
and the catch's forces, the feet's reach, the moment bias, and the joint torques by the body's inverse
dynamics through the feet on the floor, as a mixin of :class:`~bipedsim.control.creature.leap.Leap`
(they read and keep its state). Lengths in m, times in s, forces in N; world frame, Z up."""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.frames import rot_z
from bipedsim.control.creature.leap_plan import cone_forces


class LeapDynamics:
    """The forces and torques of a :class:`~bipedsim.control.creature.leap.Leap` (a mixin: its state)."""

    def _push_force(self, data: mujoco.MjData) -> FloatArray:
        """The push's force (N, world) on the body: m (a + g), a the constant acceleration that takes the
        centre of mass from its velocity now to the take-off velocity over the rest of the stroke (re-planned
        every step, so a body that falls behind is pushed the harder: the remaining time is
        2 x the rise left / (v_z now + v_z take-off), at least a control step's worth)."""
        v = self._com_velocity(data)
        a = (self.v_to - v) / self._push_left(data, v)
        return self.gait.body.mass * (a + np.array([0.0, 0.0, self.g]))

    def _push_left(self, data: mujoco.MjData, v: FloatArray) -> float:
        """The push's remaining time (s) at the centre of mass's velocity ``v`` (m/s): 2 x the rise left /
        (v_z now + v_z take-off), at least ``push_min_left`` sqrt(L/g)."""
        left = self.pp[2] + self.push_rise - float(data.qpos[2])
        vz = max(float(v[2]), 0.0) + float(self.v_to[2])
        return max(2.0 * left / vz, self.settings.push_min_left / self.w0)

    def _reach_feet(self, data: mujoco.MjData) -> FloatArray:
        """Each foot's place to land on (m, world): its neutral place under the root (in the root's own
        frame), moved ahead along the centre of mass's horizontal velocity v by ``land_reach`` x v / sqrt(g/L)."""
        v = self._com_velocity(data)
        feet = self._body_feet(data, 0.0)
        feet[:, 0:2] += self.settings.land_reach * v[0:2] / self.w0
        return feet

    def _catch_force(self, data: mujoco.MjData, v_land: FloatArray, hold: FloatArray) -> FloatArray:
        """The landing's force (N, world) on the body. While it sinks (the catch): m (a + g), a the constant
        deceleration that stops the fall over the rest of the stroke down to the crouch's depth (at least
        ``push_min_left`` sqrt(L/g)) and takes the horizontal velocity toward ``v_land`` (m/s), its
        horizontal part at most ``land_friction`` x the friction cone's under that force. Once the fall has
        stopped: ``hold`` (N)."""
        s = self.settings
        v = self._com_velocity(data)
        m = self.gait.body.mass
        if self.caught or v[2] >= 0.0:
            if not self.caught and self.caught_speed is None:
                self.caught_speed = float(np.linalg.norm(v[0:2]))
            self.caught = True
            a = np.asarray(hold, dtype=float) / m - np.array([0.0, 0.0, self.g])
        else:
            low = self.z_stand - s.crouch * self.height
            left = max(float(data.qpos[2]) - low, 1e-3)
            t_left = max(2.0 * left / -float(v[2]), s.push_min_left / self.w0)
            a = (np.array([v_land[0], v_land[1], 0.0]) - v) / t_left
        most = s.land_friction * self.gait.bal.friction * max(float(a[2]) + self.g, 0.0)
        ah = float(np.linalg.norm(a[0:2]))
        if ah > most:
            a[0:2] *= most / ah
        return m * (a + np.array([0.0, 0.0, self.g]))

    def _moment_bias(self, data: mujoco.MjData, t: float) -> FloatArray:
        """The moment (N*m, world) about the centre of mass the body got beyond the feet's planned one: the
        angular momentum's rate less the last plan's moment, low-passed over ``bias_time`` sqrt(L/g)
        (zeros with ``bias_time`` 0)."""
        tc = self.settings.bias_time / self.w0
        if tc <= 0.0:
            return np.zeros(3)
        root = self.gait.body.root_body
        mujoco.mj_subtreeVel(self.gait.body.model, data)
        h = data.subtree_angmom[root].copy()
        if self._angmom is not None and t > self._angmom[0] + 1e-9:
            dt = t - self._angmom[0]
            rate = (h - self._angmom[1]) / dt
            self.moment_bias += min(1.0, dt / tc) * (rate - self.planned_moment - self.moment_bias)
        self._angmom = (t, h)
        return self.moment_bias

    def _settled(self, data: mujoco.MjData, contact: list[bool], v_com: FloatArray) -> bool:
        """Whether the landed body is settled for the gait to walk on: all its feet but one on the floor,
        the centre of mass's vertical speed under ``settle_speed`` x sqrt(g L) and the body's mean spin
        under ``settle_spin`` x sqrt(g/L)."""
        s = self.settings
        if sum(contact) < len(contact) - 1 or abs(float(v_com[2])) > s.settle_speed * self.w0 * self.height:
            return False
        return float(np.linalg.norm(self._mean_spin(data)[1])) <= s.settle_spin * self.w0

    def _room(self, data: mujoco.MjData, u: FloatArray, i: int) -> float:
        """How far (m) the root may move along the unit vector ``u`` before leg ``i`` (its foot where it
        stands) has straightened to ``straight`` of its length; 0 where it already has."""
        gait, model = self.gait, self.gait.body.model
        d = data.xpos[model.body(gait.legs.legs[i].root).id] - data.site_xpos[gait.ik.sites[i]]
        r = self.settings.straight * self.leg_len[i]
        du = float(d @ u)
        disc = du * du - (float(d @ d) - r * r)
        return max(-du + math.sqrt(disc), 0.0) if disc >= 0.0 else 0.0

    def _inverse_torques(self, data: mujoco.MjData, accel: FloatArray, alpha: FloatArray, torque: FloatArray,
                         stance: list[int]) -> FloatArray:
        """Joint torques (N*m by actuator) that give the centre of mass the acceleration ``accel`` (m/s^2,
        world) and the root the angular acceleration ``alpha`` (rad/s^2, world) with the ``stance`` feet
        fixed on the floor and the other joints held (the body's inverse dynamics, its legs' masses
        included): the generalised forces M qacc + bias, the root's share of them carried by the feet's
        contact forces (each in its friction cone and pushing: non-negative least squares on the root's
        rows), the rest by the joints."""
        gait, legs = self.gait, self.gait.legs
        model, body = gait.body.model, gait.body
        nv = model.nv
        if not stance:
            return np.zeros(model.nu)
        r = data.xmat[body.root_body].reshape(3, 3)
        pts = [legs.contact_points[i] for i in stance]
        jacs, drifts = [], []
        for k, i in enumerate(stance):
            jp = np.zeros((3, nv))
            jd = np.zeros((3, nv))
            mujoco.mj_jac(model, data, jp, None, pts[k], legs.feet[i][0])
            mujoco.mj_jacDot(model, data, jd, None, pts[k], legs.feet[i][0])
            jacs.append(jp)
            drifts.append(jd @ data.qvel)

        def qacc_of(lin: FloatArray, ang: FloatArray, drift: bool) -> FloatArray:
            # the feet's points do not accelerate: J_leg qacc_leg = -(J_root qacc_root + Jdot qvel)
            q = np.zeros(nv)
            q[0:3], q[3:6] = lin, r.T @ ang
            for k, i in enumerate(stance):
                dofs = legs.dofs[i]
                rhs = -(jacs[k][:, 0:6] @ q[0:6]) - (drifts[k] if drift else 0.0)
                q[dofs] = np.linalg.lstsq(jacs[k][:, dofs], rhs, rcond=None)[0]
            return q

        def gen_of(q: FloatArray) -> FloatArray:
            out_ = np.zeros(nv)
            mujoco.mj_mulM(model, data, out_, q)
            return out_

        # the root's linear acceleration x that gives the whole body's momentum rate m (accel + g)
        base = qacc_of(np.zeros(3), alpha, True)
        g0 = gen_of(base) + data.qfrc_bias
        cols = [qacc_of(np.eye(3)[k], np.zeros(3), False) for k in range(3)]
        gx = np.stack([gen_of(c)[0:3] for c in cols], axis=1)
        want = body.mass * (np.asarray(accel) + np.array([0.0, 0.0, self.g]))
        x = np.linalg.solve(gx, want - g0[0:3])
        qacc = base + sum(x[k] * cols[k] for k in range(3))
        gen = gen_of(qacc) + data.qfrc_bias
        out = np.zeros(model.nu)
        # the feet's forces: the whole body's momentum rates about its centre of mass, m (accel + g) and
        # torque (N*m), each foot in its friction cone and pushing
        com = data.subtree_com[body.root_body].copy()
        # a leg near straight delivers a fraction of its share: its share shrinks from ``bent`` of its
        # length to ``straight`` (to a twentieth), the others carry the rest with the moment balanced
        s, st = self.settings, self._stretch(data)
        cap = np.array([min(max((s.straight - st[i]) / max(s.straight - s.bent, 1e-6), 0.05), 1.0) for i in stance])
        weight = s.land_moment_weight if self.phase == "land" else s.moment_weight
        fs = cone_forces(body.mass * (np.asarray(accel) + np.array([0.0, 0.0, self.g])), torque, np.array(pts), com,
                         gait.bal.friction, self.height / weight, s.cone_edges, capacity=cap)
        #: the feet's planned contact forces (N, world) at the last control step, by leg
        self.foot_forces = {i: fs[k] for k, i in enumerate(stance)}
        self.planned_moment = sum((np.cross(np.asarray(p) - com, f) for p, f in zip(pts, fs)), np.zeros(3))
        tau = gen.copy()
        for k, jp in enumerate(jacs):
            tau -= jp.T @ fs[k]
        held = np.zeros(nv, dtype=bool)
        for i in stance:
            held[legs.dofs[i]] = True
        out[body.acts.ravel()] = np.where(held[body.vel_idx.ravel()], tau[body.vel_idx.ravel()], 0.0)
        return out

    def _mean_spin(self, data: mujoco.MjData) -> tuple[FloatArray, FloatArray]:
        """The whole body's inertia about its centre of mass (kg*m^2, world) and its mean spin (rad/s,
        world): its angular momentum about the centre of mass over that inertia."""
        model, root = self.gait.body.model, self.gait.body.root_body
        mujoco.mj_subtreeVel(model, data)
        com = data.subtree_com[root]
        inertia = np.zeros((3, 3))
        for k in range(root, model.nbody):
            if model.body_rootid[k] != model.body_rootid[root]:
                continue
            rk = data.ximat[k].reshape(3, 3)
            d = data.xipos[k] - com
            inertia += rk @ np.diag(model.body_inertia[k]) @ rk.T
            inertia += model.body_mass[k] * (float(d @ d) * np.eye(3) - np.outer(d, d))
        return inertia, np.linalg.solve(inertia, data.subtree_angmom[root])

    def _centroidal_torque(self, data: mujoco.MjData, attitude: float = 1.0) -> FloatArray:
        """The torque (N*m, world) about the centre of mass the feet are asked for: the whole body's
        inertia (about its centre of mass) times an angular acceleration that turns the root toward level
        at the leap's heading and brings the body's mean spin (its angular momentum over its inertia) to
        rest (the gait's attitude PD, frequency x ``attitude``); in the push (``push_spin_stop``) the
        angular momentum is brought to rest over the push's remaining time instead of by the PD's damping."""
        gait, b = self.gait, self.gait.bal
        root = gait.body.root_body
        inertia, spin = self._mean_spin(data)
        r = data.xmat[root].reshape(3, 3)
        rot = Rotation.from_matrix(rot_z(self.yaw) @ gait.stance.att @ r.T).as_rotvec()
        wa = attitude * b.attitude_freq * self.w0
        if self.phase == "push" and self.settings.push_spin_stop:
            # the push: the angular momentum brought to rest by the take-off, as the velocity is brought to
            # the take-off's (whatever spin the walk left the body with, it leaves the floor without it)
            t_left = self._push_left(data, self._com_velocity(data))
            return inertia @ (wa * wa * rot) - data.subtree_angmom[root] / t_left
        return inertia @ (wa * wa * rot - 2 * b.damping_ratio * wa * spin)

    def _wrench(self, data: mujoco.MjData, p: FloatArray, v: FloatArray, a: FloatArray,
                horizontal_pd: bool = True, attitude: float = 1.0) -> tuple[FloatArray, FloatArray]:
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
        wa = attitude * b.attitude_freq * self.w0
        torque = m * self.height ** 2 * (wa * wa * rot - 2 * b.damping_ratio * wa * (r @ data.qvel[3:6]))
        return force, torque
