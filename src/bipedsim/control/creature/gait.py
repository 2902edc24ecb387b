"""A gait the built body can carry, for any legged skeleton (Coros et al. 2011's planned gait, made
quasi-static): the controller plans where each foot stands and where the trunk is, and solves the legs
by inverse kinematics on the built body every few milliseconds, instead of tracking the clip's joint
angles (a pose that need not be feasible on the built body). Its parts:

- the **neutral stance** measured from the clip and posed on the body
  (:mod:`~bipedsim.control.creature.stance`), and the legs' **reach** from it
  (:mod:`~bipedsim.control.creature.reach`);
- the **gait clock** measured from the clip (:mod:`~bipedsim.control.creature.clock`), its stride held
  to the reach;
- the **plan** in time (:mod:`~bipedsim.control.creature.planner`): trunk path and support shift, feet,
  legs by IK (:mod:`~bipedsim.control.creature.ik`);
- the **control step** here: the legs' joints PD-tracked toward the plan (a swinging leg softer, its
  planned velocity fed forward, its own weight carried), and gravity, the body's position and velocity
  and its attitude held by a virtual wrench through the legs that touch the floor
  (:meth:`~bipedsim.control.creature.legs.LegSet.stance_torques`).

What differs with the number of legs is a strategy chosen at construction
(:class:`~bipedsim.control.creature.many_legs.ManyLegs`, or two legs'
:class:`~bipedsim.control.creature.biped.BipedRules`). The clip's non-leg joints (spine, neck, tail) are
held at the neutral pose.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.balance import balance_metrics
from bipedsim.control.creature.clock import GaitClock, forward_axis
from bipedsim.control.creature.forces import zmp_limited
from bipedsim.control.creature.frames import axis_heading
from bipedsim.control.creature.ik import LegIK
from bipedsim.control.creature.legs import LegSet, geom_bottom
from bipedsim.control.creature.planner import GaitPlanner, LegRules
from bipedsim.control.creature.reach import Reach, measure_reach, measure_reach_out
from bipedsim.control.creature.reference import LoopedReference
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.control.creature.stance import Stance, body_axis, measure_stance
from bipedsim.control.creature.tracking import CreatureBody, Tracking

#: plans made at a rollout's start, each warm-starting the legs' IK from the last
START_PLANS = 6


class PlannedGait:
    """The planned gait of a legged creature (see the module text). ``support``: the root is held (the
    clip is tracked, nothing is planned, the reach not measured)."""

    def __init__(self, body: CreatureBody, legs: LegSet, ref: LoopedReference, track: Tracking,
                 bal: CreatureBalanceConfig, rules: LegRules, support: bool) -> None:
        self.body, self.legs, self.ref, self.track, self.bal, self.rules = body, legs, ref, track, bal, rules
        model, n = body.model, len(legs)
        self.ik = LegIK(model, legs, rules.foot_sites(legs), [rules.held_feet(legs, i) for i in range(n)])
        self.clock = GaitClock(ref.clip, ref.loop, legs, bal, -float(model.opt.gravity[2]))
        rules.time_clock(self.clock, legs.omega0)
        #: the body's forward axis (unit, root frame): its heading is the walking direction
        self.fwd = forward_axis(ref.clip, ref.loop, self.clock.clip_speed)
        self.stance = self._measure_stance()
        axis = body_axis(self.stance)
        if axis is not None:
            self.fwd = axis
            self.stance = self._measure_stance()
        self.clock.wave_order(self.stance.hips)
        self.reach = Reach(ahead=np.zeros(n), behind=np.zeros(n), out=np.zeros(n))
        if n and not support:
            self.reach = measure_reach(self.ik, self.stance, bal, legs.height, self._measuring_attitude)
            self.clock.hold_to_reach(self.reach.half, bal.stride_fraction * legs.height)
        rules.hold_clock(self.clock, self.reach.half)
        if bal.capture_step > 0 and n > 2 and not support:
            self.reach.out = measure_reach_out(self.ik, self.stance, bal, legs.height, self._measuring_attitude)
        self.planner = GaitPlanner(body, legs, self.ik, self.clock, self.stance, self.reach, bal, rules)
        #: per leg, the indices (into the body's balls) of its ball joints
        leg_dof_sets = [set(d.tolist()) for d in legs.dofs]
        self.leg_balls = [[k for k in range(len(body.qadr)) if int(body.dadr[k]) in ds] for ds in leg_dof_sets]
        #: the pose tracked now (a qpos; None before a reset), the next re-planning time (s) and the
        #: plan's joint velocities (dof space)
        self.target: FloatArray | None = None
        self.next_plan = 0.0
        self.qdot_ref = np.zeros(model.nv)
        self._swing_state = [False] * n
        self._kp_now, self._kd_now = body.kp.copy(), body.kd.copy()
        #: (force N, torque N*m) of the virtual wrench at each step with a stance leg
        self.virtual: list[tuple[float, float]] = []

    def _measuring_attitude(self, i: int) -> FloatArray | None:
        """The feet's orientations while the stance and reach are measured: for heading 0."""
        return self.rules.foot_attitude(i, self.fwd, 0.0, self.ik.data)

    def _measure_stance(self) -> Stance:
        return measure_stance(self.body.model, self.body, self.legs, self.ref, self.ik, self.bal, self.fwd,
                              self.rules.site_heights, self._measuring_attitude)

    # ------------------------------------------------------------------ the start
    def reset(self, data: mujoco.MjData, t: float) -> None:
        """Start a walk at ``t`` (s): plan the start pose and put the body in it, at rest, its lowest
        point on the floor (a shin posed below it would be a contact impulse at t = 0)."""
        model, n, planner = self.body.model, len(self.legs), self.planner
        self.virtual = []
        planner.reset(data, t, axis_heading(data.xmat[self.body.root_body].reshape(3, 3), self.fwd))
        self.rules.reset(planner, data, t)
        for _ in range(START_PLANS):
            q = planner.plan(t, data, self.fwd)
        data.qpos[:] = q
        data.qvel[:] = 0.0
        mujoco.mj_kinematics(model, data)
        low = min(geom_bottom(model, data, g) for g in range(model.ngeom) if model.geom_bodyid[g] > 0)
        data.qpos[2] -= low
        planner.z_offset = -low
        self.target = q
        self.target[2] -= low
        self.next_plan = t
        self.qdot_ref = np.zeros(model.nv)
        self._swing_state = [False] * n
        self._kp_now, self._kd_now = self.body.kp.copy(), self.body.kd.copy()
        mujoco.mj_forward(model, data)
        self.rules.start(planner, t)

    # ------------------------------------------------------------------ the control step
    def step(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        """The joint torques (N*m by actuator) at time ``t`` (see the module text)."""
        body, legs, clock, planner = self.body, self.legs, self.clock, self.planner
        down = legs.feet_down(data)
        if self.bal.capture_step > 0 and len(legs) > 2:
            planner.catch(model, data, t)
        if t >= self.next_plan - 1e-9:
            prev = self.target
            self.target = planner.plan(t, data, self.fwd)
            mujoco.mj_differentiatePos(model, self.qdot_ref, planner.dt_plan, prev, self.target)
            self.next_plan = t + planner.dt_plan
        target = self.target
        self.track.frame = self.ref.loop[0] + (t - planner.t_start) / self.ref.clip.frame_time
        e = body.joint_error(data, target)
        self.track.tracking_error = np.linalg.norm(e, axis=1)
        swinging = [clock.phase(t, i) >= 0 for i in range(len(legs))]
        if swinging != self._swing_state:
            self._soften_swing_legs(model, swinging)
        tau_all = np.zeros(model.nu)
        # kd (qdot_ref - qdot): the -kd qdot half is MuJoCo's implicit joint damping; the planned joint
        # velocity half is fed forward, or the damping would hold back the stance legs' sweep
        tau = self._kp_now[:, None] * e
        if self.bal.velocity_feedforward:  # on the swinging legs only: the stance legs move slowly
            ff = np.zeros(model.nv)
            for i, sw in enumerate(swinging):
                if sw:
                    ff[legs.dofs[i]] = self.qdot_ref[legs.dofs[i]]
            tau = tau + self._kd_now[:, None] * ff[body.vel_idx]
        tau_all[body.acts.ravel()] = tau.ravel()
        for i, sw in enumerate(swinging):  # a swinging leg carries its own weight (gravity, Coriolis)
            if sw:
                tau_all[legs.acts[i]] += data.qfrc_bias[legs.dofs[i]]
        stance = [i for i, dn in enumerate(down) if dn and clock.phase(t, i) < 0]
        if stance:
            tau_all += self._body_wrench(data, target, t, stance)
        return self.rules.limit_torques(planner, t, body.clipped(tau_all))

    def _soften_swing_legs(self, model: mujoco.MjModel, swinging: list[bool]) -> None:
        """A swinging leg is softer: its joints' stiffness x ``swing_stiffness``, damping x its square root."""
        body = self.body
        self._swing_state = swinging
        kp_scale = np.ones(len(body.qadr))
        for i, sw in enumerate(swinging):
            if sw:
                kp_scale[self.leg_balls[i]] = self.bal.swing_stiffness
        self._kp_now = body.kp * kp_scale
        kd_now = body.kd * np.sqrt(kp_scale)
        for k, dadr in enumerate(body.dadr):
            model.dof_damping[dadr:dadr + 3] = body.base_damping[dadr:dadr + 3] + kd_now[k]
        self._kd_now = kd_now

    def _body_wrench(self, data: mujoco.MjData, target: FloatArray, t: float, stance: list[int]) -> FloatArray:
        """Joint torques (by actuator) through the stance legs for the body's virtual wrench: gravity
        compensation, a PD of the root toward its planned position and velocity (horizontal and vertical,
        natural frequency ``body_freq`` sqrt(g/L), damping ratio ``damping_ratio``: the body on stiff legs
        is a mass on springs that the legs' own joint damping, sized for the legs, leaves underdamped) and
        a PD of its attitude toward the planned one."""
        b, m, w0, root = self.bal, self.body.mass, self.legs.omega0, self.body.root_body
        g = -float(self.body.model.opt.gravity[2])
        w = b.body_freq * w0
        v_d = np.array([*(self.clock.speed_at(t) * self.planner.dir), 0.0])
        force = m * (w * w * (target[0:3] - data.qpos[0:3]) + 2 * b.damping_ratio * w * (v_d - data.qvel[0:3]))
        force[2] += m * b.gravity_comp * g
        if b.zmp_limit or (self.reach.centred and b.centre_sweep_zmp):
            planted = self.planner.planted
            support = np.array([planted[i] for i in range(len(self.legs)) if self.clock.phase(t, i) < 0])
            force[0:2] = zmp_limited(force[0:2], data.subtree_com[root], support, m * g)
        r = data.xmat[root].reshape(3, 3)
        r_d = Rotation.from_quat(target[3:7], scalar_first=True).as_matrix()
        err = Rotation.from_matrix(r_d @ r.T).as_rotvec()
        wa = b.attitude_freq * w0
        torque = m * self.legs.height ** 2 * (wa * wa * err - 2 * b.damping_ratio * wa * (r @ data.qvel[3:6]))
        self.virtual.append((float(np.linalg.norm(force)), float(np.linalg.norm(torque))))
        return self.legs.stance_torques(data, force, torque, stance, data.subtree_com[root], b.friction)

    # ------------------------------------------------------------------ read-outs
    def contact_state(self, data: mujoco.MjData, t: float) -> tuple[list[bool], list[bool], list[float]]:
        """Per leg at time ``t``: planned in stance, touching the floor, and the stance progress in
        [0, 1) (-1 while swinging or before the first step): what the contact measures read
        (:class:`~bipedsim.sim.contacts.StanceContacts`)."""
        n = len(self.legs)
        planned = [self.clock.phase(t, i) < 0 for i in range(n)]
        down = self.legs.feet_down(data)
        return planned, down, [self.clock.stance_progress(t, i) for i in range(n)]

    def heading(self, data: mujoco.MjData) -> float:
        """The body's heading (rad about world Z): its forward axis, measured from the clip (a root
        frame's x axis may point backward, as in the dog's skeleton), so a push at 90 deg is to its left."""
        return axis_heading(data.xmat[self.body.root_body].reshape(3, 3), self.fwd)

    def reference_speed(self) -> float:
        """The planned walking speed (m/s)."""
        return self.clock.v_des

    def foot_strikes(self) -> list[tuple[float, str]]:
        return list(self.planner.strikes)

    def metrics(self) -> dict[str, object]:
        out = balance_metrics(self.track, self.rules.name, self.legs, 0, self.virtual)
        c = self.clock
        out.update({"controller": self.rules.name, "gait_period_s": c.period, "swing_fraction": c.swing_frac,
                    "target_speed_mps": c.v_des, "clip_speed_mps": c.clip_speed})
        return out


__all__ = ["PlannedGait"]
