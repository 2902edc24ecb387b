"""The planned gait's plan in time: where the trunk goes and where each foot stands or swings, the legs
solved by IK, re-planned every ``plan_dt_s``.

- **trunk**: the root moves along a straight path at the wanted speed (ramped up over
  ``speed_ramp_s``); the path drifts after the body (``path_follow_s``), so a body that lags or strays
  is walked on from where it is;
- **feet**: a stance foot stays where it landed (pressed ``stance_press`` L into the floor); a swing
  foot moves from lift-off to its landing point on a smoothstep, lifted ``step_height`` L on a sine;
- **legs by IK** for a root attitude at most ``ik_tilt_limit`` rad from the real one (more than two
  legs): posed for the upright plan, a body rolled onto one side has its low side's feet driven into
  the floor and its high side's held off it;
- **the catch** (more than two legs, ``capture_step``): while the centre of mass's capture point lies
  out to one side beyond that side's outermost stance foot, that side's next leg starts its swing now.

What differs with the number of legs -- where a swing lands, where the root goes, which velocity the
placement reads -- is the strategy's (:class:`LegRules`:
:class:`~bipedsim.control.creature.many_legs.ManyLegs`, the two-legged
:class:`~bipedsim.control.creature.biped.BipedRules`). Lengths in m, times in s, world frame.
"""

from __future__ import annotations

import math
from typing import Protocol

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.clock import GaitClock
from bipedsim.control.creature.frames import rot_z
from bipedsim.control.creature.ik import LegIK
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.reach import Reach
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.control.creature.stance import Stance
from bipedsim.control.creature.tracking import CreatureBody


def smoothstep(s: float) -> float:
    """The cubic ease 3s^2 - 2s^3 on [0, 1]: zero slope at both ends."""
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


class LegRules(Protocol):
    """What the planned gait does differently for a number of legs
    (:class:`~bipedsim.control.creature.many_legs.ManyLegs`, and two legs'
    :class:`~bipedsim.control.creature.biped.BipedRules`)."""

    #: the controller's name in the outcome
    name: str

    def balance(self, bal: CreatureBalanceConfig) -> CreatureBalanceConfig:
        """The balance settings the gait runs with, given the configured ``bal``."""

    def foot_sites(self, legs: LegSet) -> list[int]:
        """The site each leg's foot is placed by."""

    def held_feet(self, legs: LegSet, i: int) -> tuple[str, ...]:
        """The bodies of leg ``i`` whose own joints the IK leaves at the neutral pose."""

    def site_heights(self, default: FloatArray) -> FloatArray:
        """Each foot site's height (m) when its foot stands, given the measured ``default``."""

    def foot_attitude(self, i: int, fwd: FloatArray, yaw: float, data: mujoco.MjData) -> FloatArray | None:
        """The world orientation leg ``i``'s foot site is aimed at by the IK; None: its position only."""

    def time_clock(self, clock: GaitClock, omega0: float) -> None:
        """The clock as measured from the clip, adjusted."""

    def hold_clock(self, clock: GaitClock, reach: float) -> None:
        """The clock once held to the legs' reach (m), adjusted."""

    def reset(self, plan: GaitPlanner, data: mujoco.MjData, t: float) -> None:
        """Before the first plan of a rollout starting at ``t``."""

    def start(self, plan: GaitPlanner, t: float) -> None:
        """After the start pose is planned."""

    def body_velocity(self, plan: GaitPlanner, data: mujoco.MjData) -> FloatArray:
        """The body's horizontal velocity (m/s) the foot placement reads."""

    def plan_root(self, plan: GaitPlanner, t: float, data: mujoco.MjData, feet: FloatArray,
                  swinging: list[int]) -> FloatArray:
        """The root's target (m, world xy)."""

    def landing(self, plan: GaitPlanner, t: float, i: int, data: mujoco.MjData) -> FloatArray:
        """Where leg ``i``'s swing ends (m, world)."""

    def limit_torques(self, plan: GaitPlanner, t: float, tau: FloatArray) -> FloatArray:
        """The control step's torques (N*m by actuator), limited as the feet can carry them."""


class GaitPlanner:
    """The plan of one rollout (see the module text): the path's origin and direction, the support
    shift, the filtered body velocity and capture point, each foot's lift-off and planted place, and the
    real foot strikes."""

    def __init__(self, body: CreatureBody, legs: LegSet, ik: LegIK, clock: GaitClock, stance: Stance,
                 reach: Reach, bal: CreatureBalanceConfig, rules: LegRules) -> None:
        self.body, self.legs, self.ik, self.clock = body, legs, ik, clock
        self.stance, self.reach, self.bal, self.rules = stance, reach, bal, rules
        n = len(legs)
        leg_dofs = set(np.concatenate(legs.dofs).tolist()) if n else set()
        #: qpos indices of the leg joints' quaternions (the part of a plan the IK solves)
        self.leg_q = np.array([a for k, qa in enumerate(body.qadr) if int(body.dadr[k]) in leg_dofs
                               for a in range(qa, qa + 4)], dtype=np.int64)
        #: the plan's heading (rad) and walking direction (unit, world xy)
        self.yaw = 0.0
        self.dir = np.array([1.0, 0.0])
        #: the path's origin (m, world xy), the time (s) the rollout started, the support shift (m)
        self.origin = np.zeros(2)
        self.t_start = 0.0
        self.shift = np.zeros(2)
        #: the body velocity (m/s) low-passed for the foot placement; the capture point (m, world xy)
        self.v_filt = np.zeros(2)
        self.xi = np.zeros(2)
        #: steps started by the catch
        self.catches = 0
        self.dt_plan = bal.plan_dt_s
        #: per leg: where its swing lifted off (None in stance), where it stands (m, world)
        self.lift: list[FloatArray | None] = [None] * n
        self.planted: list[FloatArray] = []
        #: the root height offset (m) that put the start pose's lowest point on the floor
        self.z_offset = 0.0
        #: the last plan's foot targets (legs, 3; m, world)
        self.feet_target = np.zeros((n, 3))
        #: (time s, leg root) of every planned landing
        self.strikes: list[tuple[float, str]] = []

    def reset(self, data: mujoco.MjData, t: float, fwd_heading: float) -> None:
        """A rollout starting at ``t`` from the pose in ``data``, heading ``fwd_heading`` rad."""
        n = len(self.legs)
        self.strikes = []
        self.yaw = fwd_heading
        self.dir = np.array([math.cos(self.yaw), math.sin(self.yaw)])
        self.origin = data.qpos[0:2].copy()
        self.clock.t_walk = t + self.bal.settle_s
        self.t_start = t
        self.shift = np.zeros(2)
        self.v_filt = np.zeros(2)
        self.xi = np.zeros(2)
        self.catches = 0
        self.dt_plan = self.bal.plan_dt_s
        self.lift = [None] * n
        self.planted = [self.foot_home(t, i) for i in range(n)]
        self.ik.q = self.stance.q.copy()
        self.z_offset = 0.0

    # ------------------------------------------------------------------ the path
    def root_path(self, t: float) -> FloatArray:
        """The root's planned horizontal position (m, world) at time ``t``."""
        tw = max(t - self.clock.t_walk, 0.0)
        ramp = self.bal.speed_ramp_s
        dist = self.clock.v_des * (tw * tw / (2 * ramp) if tw < ramp else tw - ramp / 2)
        return self.origin + dist * self.dir

    def turn_to(self, t: float, yaw: float) -> None:
        """Walk on toward heading ``yaw`` (rad about world Z) from time ``t`` (s): the path turns about
        where it is at ``t``, so the root's planned position does not jump (a steering command)."""
        before = self.root_path(t)
        self.yaw = float(yaw)
        self.dir = np.array([math.cos(self.yaw), math.sin(self.yaw)])
        self.origin += before - self.root_path(t)

    def set_speed(self, t: float, speed: float) -> None:
        """Walk on at ``speed`` (m/s, the speed past the ramp) from time ``t`` (s): the path's origin moves
        so the root's planned position does not jump (a steering command)."""
        before = self.root_path(t)
        self.clock.v_des = max(float(speed), 0.0)
        self.origin += before - self.root_path(t)

    def heading_rot(self) -> FloatArray:
        """The plan's heading frame (3x3): world turned by :attr:`yaw`."""
        return rot_z(self.yaw)

    def foot_home(self, t: float, i: int) -> FloatArray:
        """Leg ``i``'s neutral foot position (world) for a root on its planned path at time ``t``."""
        p = self.root_path(t)
        h = self.heading_rot() @ self.stance.feet[i]
        return np.array([p[0] + h[0], p[1] + h[1], self.stance.site_ground[i]])

    def left(self) -> FloatArray:
        """The unit vector (world xy) to the left of the walking direction."""
        return np.array([-self.dir[1], self.dir[0]])

    # ------------------------------------------------------------------ the catch
    def catch(self, model: mujoco.MjModel, data: mujoco.MjData, t: float) -> None:
        """The centre of mass's capture point :attr:`xi` (m, world xy), c + v / w (w = sqrt(g / h), h its
        height over the feet), and the catch: while it lies out to one side beyond that side's outermost
        stance foot (by ``capture_margin`` x the stance's half-width) and no leg of that side swings, the
        gait's clock moves on to that side's leg that lifts soonest (the legs between keep their feet
        where they are; the planned path is held where it was)."""
        root, clock, stance = self.body.root_body, self.clock, self.stance
        mujoco.mj_subtreeVel(model, data)
        com, v = data.subtree_com[root], data.subtree_linvel[root]
        g = -float(model.opt.gravity[2])
        w = math.sqrt(g / max(float(com[2] - stance.site_ground.mean()), 1e-3))
        self.xi = com[0:2] + v[0:2] / w
        if t < clock.t_walk:
            return
        n = len(self.legs)
        side = self.left()
        xi = float(self.xi @ side)
        for s in (1.0, -1.0):
            legs = [i for i in range(n) if stance.side[i] == s]
            if not legs or any(clock.phase(t, i) >= 0 for i in legs):
                continue
            edge = max(s * float(self.planted[i][0:2] @ side) for i in legs)
            if s * xi <= edge + self.bal.capture_margin * stance.half_width:
                continue
            wait = {i: clock.wait_for(t, i) for i in legs}
            i = min(wait, key=wait.get)
            before = self.root_path(t)
            clock.t_walk -= wait[i] + 1e-9
            self.origin -= self.root_path(t) - before
            self.catches += 1
            return

    # ------------------------------------------------------------------ the plan
    def plan(self, t: float, data: mujoco.MjData, fwd: FloatArray) -> FloatArray:
        """The target pose (qpos) at time ``t``: root from the path and the support shift, feet from the
        gait, legs by IK (``fwd``: the body's forward axis, for the feet's attitude)."""
        clock, stance, bal = self.clock, self.stance, self.bal
        # the body's velocity, low-passed over a quarter swing, for the foot placement: a landing point
        # that jumps with every bounce makes the swing leg's IK target jump
        a_v = min(1.0, self.dt_plan / max(0.25 * clock.swing_frac * clock.period, 1e-6))
        self.v_filt += a_v * (self.rules.body_velocity(self, data) - self.v_filt)
        if bal.path_follow_s > 0 and t > self.t_start:
            # the planned path drifts after the body (time constant path_follow_s): a body that lags or
            # strays is walked on from where it is, not pulled back by its stance legs like a spring
            lag = data.qpos[0:2] - (self.root_path(t) + self.shift)
            self.origin += min(1.0, self.dt_plan / bal.path_follow_s) * lag
        feet, swinging = self.plan_feet(t, data)
        q = stance.q.copy()
        q[0:2] = self.rules.plan_root(self, t, data, feet, swinging)
        q[2] = stance.height + self.z_offset
        q[3:7] = Rotation.from_matrix(self.heading_rot() @ stance.att).as_quat(scalar_first=True)
        q[self.leg_q] = self.ik.q[self.leg_q]
        q_ik = q.copy()
        q_ik[3:7] = self.ik_attitude(data, q[3:7]) if t > self.t_start else q[3:7]
        self.ik.solve(q_ik, feet, stance.q, bal.posture_pull,
                      attitude=lambda i: self.rules.foot_attitude(i, fwd, self.yaw, self.ik.data))
        q[self.leg_q] = q_ik[self.leg_q]
        self.feet_target = feet
        return q

    def ik_attitude(self, data: mujoco.MjData, planned: FloatArray) -> FloatArray:
        """The root attitude (quaternion) the legs are solved for: the ``planned`` one turned toward the
        real root's until its tilt (roll and pitch; heading kept) is within ``ik_tilt_limit`` rad of it.
        Off on two legs (their steps catch a tilt)."""
        lim = self.bal.ik_tilt_limit
        if lim <= 0 or len(self.legs) <= 2:
            return planned
        plan = Rotation.from_quat(planned, scalar_first=True)
        err = (Rotation.from_quat(data.qpos[3:7], scalar_first=True) * plan.inv()).as_rotvec()
        err[2] = 0.0
        size = float(np.linalg.norm(err))
        if size <= lim:
            return planned
        return (Rotation.from_rotvec(err * (1.0 - lim / size)) * plan).as_quat(scalar_first=True)

    def plan_feet(self, t: float, data: mujoco.MjData) -> tuple[FloatArray, list[int]]:
        """Each foot's target (m, world) at time ``t`` and the legs in swing: a stance foot where it
        landed, a swinging one on its way from lift-off to its landing, lifted on a sine."""
        n, bal, height = len(self.legs), self.bal, self.legs.height
        ground = self.stance.site_ground
        feet = np.zeros((n, 3))
        swinging = []
        for i in range(n):
            s = self.clock.phase(t, i)
            if s < 0:
                if self.lift[i] is not None:  # just landed: plant where the foot is
                    self.strikes.append((t, self.legs.legs[i].root))
                    p = data.site_xpos[self.ik.sites[i]].copy()
                    self.planted[i] = np.array([p[0], p[1], ground[i]])
                    self.lift[i] = None
                feet[i] = self.planted[i]
                feet[i, 2] -= bal.stance_press * height
            else:
                if self.lift[i] is None:
                    self.lift[i] = self.planted[i].copy()
                p0, p1 = self.lift[i], self.rules.landing(self, t, i, data)
                e = smoothstep(s)
                feet[i] = p0 + e * (p1 - p0)
                feet[i, 2] = ground[i] + bal.step_height * height * math.sin(math.pi * s)
                swinging.append(i)
        return feet, swinging


__all__ = ["GaitPlanner", "LegRules", "smoothstep"]
