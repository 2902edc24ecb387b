"""The planned gait's rules on two legs (a bird, a bred biped): a dynamic walk where the quasi-static
one of :class:`~bipedsim.control.creature.many_legs.ManyLegs` cannot stand.

On four legs three feet stay down while one swings: the quasi-static plan rests the body on a support
polygon. On two legs the support while a leg swings is one foot, so the body is an inverted pendulum
and its steps must catch it (SIMBICON's foot placement, here by the capture point):

- **feet are soles** (:mod:`bipedsim.model.creature_sole`: a flat box under each foot spanning its toes,
  measured from the skeleton): the IK places each sole's bottom centre, **flat** (its normal vertical,
  its toes along the sole's own heading in the clip), not a toe tip;
- **the root is free**: walking, the IK's root is where the body is (the stance leg holds the root's
  height and attitude; the stance legs' virtual wrench adds gravity compensation and a velocity PD toward
  the wanted speed), so the body moves like a pendulum over its stance foot;
- **the swing foot lands at the capture point** its stance foot p lets the centre of mass reach by
  touch-down, xi_T = p + (xi - p) e^(w t_left), xi = c + v/w, w = sqrt(g/h) (h: the centre of mass's
  height), less the offsets of a steady walk at the wanted speed v_d with steps of T s and feet W
  apart: v_d T / (e^(wT) - 1) behind it and W / (e^(wT) + 1) out to the leg's side;
- **before the first step** the body moves ``pre_shift`` of the way over its first stance sole;
- **a stance ankle's torque** is held to ``ankle_cap`` x the body's weight x the sole's half size;
- **the clock**: the clip's median swing, at most ``max_swing`` sqrt(L/g), and a double support of
  ``double_support`` sqrt(L/g); the speed the planned gait's, held by the legs' reach.

Every length is scaled by the standing root height L and every time by sqrt(L/g) (:class:`BipedGaitConfig`,
which also holds the planned gait's settings that differ on two legs): no per-clip settings, no joint
names.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.clock import GaitClock
from bipedsim.control.creature.frames import axis_heading, rot_z
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.planner import GaitPlanner
from bipedsim.control.creature.reference import LoopedReference
from bipedsim.control.creature.settings import BipedGaitConfig, CreatureBalanceConfig
from bipedsim.control.creature.tracking import CreatureBody, ball_joints
from bipedsim.model.plan import BodyPlanSet

#: a sole's orientation is measured over the loop's frames where it is lowest: this percentile of its height
LOW_SOLE_PERCENTILE = 25


def smootherstep(s: float) -> float:
    """The quintic ease 6s^5 - 15s^4 + 10s^3 on [0, 1]: zero slope and curvature at both ends."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (s * (6.0 * s - 15.0) + 10.0)


class BipedRules:
    """The planned gait on two legs standing on soles (see the module text)."""

    name = "creature_biped"

    def __init__(self, plan: BodyPlanSet, body: CreatureBody, legs: LegSet, ref: LoopedReference,
                 cfg: BipedGaitConfig) -> None:
        self.model, self.body, self.ref, self.cfg = body.model, body, ref, cfg
        soles = plan.extra.get("soles", {})
        #: per leg, its sole's site name (None: a leg without a sole)
        self.sole_names: list[str | None] = [soles.get(leg.root) for leg in legs.legs]
        self._flat_key: tuple[float, ...] | None = None
        self._flat: list[FloatArray | None] = []
        #: the swing and the step (swing plus double support) in s, set with the clock
        self.swing_s = self.step_s = 0.0
        # per rollout: the pendulum frequency of the centre of mass (rad/s), each leg's side (+1 left),
        # the feet's width (m), the sideways move before the first step (m), the last centre of mass (m)
        self.omega_com = 1.0
        self.side = np.zeros(len(legs))
        self.width = 0.0
        self.pre_shift = np.zeros(2)
        self._com_prev: FloatArray | None = None
        self._ankle_acts: list[np.ndarray | None] = []
        self._sole_half: list[float] = []

    def balance(self, bal: CreatureBalanceConfig) -> CreatureBalanceConfig:
        """``bal`` with the settings that differ on two legs taken from :class:`BipedGaitConfig`."""
        b = self.cfg
        return replace(bal, height_fraction=b.height_fraction, posture_pull=b.posture_pull,
                       step_height=b.step_height, speed_fraction=b.speed_fraction, body_freq=b.body_freq)

    # ------------------------------------------------------------------ soles
    def foot_sites(self, legs: LegSet) -> list[int]:
        """Each leg's sole site (the middle of its sole's bottom), or its toe's touch site without one;
        the ankles (the soles' joints) found with them."""
        sites = [self.model.site(s).id if s else legs.sites[i][0] for i, s in enumerate(self.sole_names)]
        self._ankles(sites)
        return sites

    def held_feet(self, legs: LegSet, i: int) -> tuple[str, ...]:
        """A sole is kept flat by its own joint (the ankle): the IK turns it; toes below it stay held."""
        sole = self.sole_names[i]
        if not sole:
            return legs.legs[i].feet
        seg = self.model.body(int(self.model.site_bodyid[self.model.site(sole).id])).name
        return tuple(f for f in legs.legs[i].feet if f != seg)

    def site_heights(self, default: FloatArray) -> FloatArray:
        """A sole site lies on the floor when its foot stands."""
        return np.array([0.0 if s else default[i] for i, s in enumerate(self.sole_names)])

    def _flat_soles(self, fwd: FloatArray, sites: list[int], data: mujoco.MjData) -> list[FloatArray | None]:
        """Per leg, the sole's orientation (heading frame) when it stands: its mean over the loop's
        frames with the sole low, turned minimally so its normal is vertical; measured for forward axis
        ``fwd`` on ``data`` (posed here) and kept while ``fwd`` stays."""
        key = tuple(fwd)
        if self._flat_key == key:
            return self._flat
        clip, (a, b), model = self.ref.clip, self.ref.loop, self.model
        flat: list[FloatArray | None] = []
        for i, sid in enumerate(sites):
            if not self.sole_names[i]:
                flat.append(None)
                continue
            rots, heights = [], []
            for f in range(a, b):
                data.qpos[:] = clip.qpos[f]
                mujoco.mj_kinematics(model, data)
                h = rot_z(axis_heading(data.xmat[self.body.root_body].reshape(3, 3), fwd)).T
                rots.append(h @ data.site_xmat[sid].reshape(3, 3))
                heights.append(data.site_xpos[sid][2])
            low = np.asarray(heights) <= np.percentile(heights, LOW_SOLE_PERCENTILE)
            mean = Rotation.from_matrix(np.asarray(rots)[low]).mean().as_matrix()
            z = mean[:, 2]
            level = Rotation.align_vectors([[0.0, 0.0, 1.0]], [z])[0].as_matrix()
            flat.append(level @ mean)
        self._flat_key, self._flat = key, flat
        return flat

    def foot_attitude(self, i: int, fwd: FloatArray, yaw: float, data: mujoco.MjData) -> FloatArray | None:
        """A sole's standing orientation turned to heading ``yaw``; None for a leg without a sole."""
        att = self._flat_soles(fwd, self._sites, data)[i]
        return None if att is None else rot_z(yaw) @ att

    def _ankles(self, sites: list[int]) -> None:
        """Per leg: the actuators of its sole's joint (the ankle) and the sole's half length and width (m)."""
        m = self.model
        ball_of = {int(m.jnt_bodyid[j]): k for k, j in enumerate(ball_joints(m))}
        self._sites = sites
        self._ankle_acts, self._sole_half = [], []
        for i, name in enumerate(self.sole_names):
            body = int(m.site_bodyid[sites[i]]) if name else -1
            k = ball_of.get(body)
            self._ankle_acts.append(None if k is None else self.body.acts[k])
            box = [g for g in range(m.ngeom)
                   if m.geom_bodyid[g] == body and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
            self._sole_half.append(float(min(m.geom_size[box[0]][0:2])) if box else 0.0)

    # ------------------------------------------------------------------ timing
    def time_clock(self, clock: GaitClock, omega0: float) -> None:
        """The clock of a walk: the clip's median swing, at most ``max_swing`` sqrt(L/g), then a double
        support of ``double_support`` sqrt(L/g); the legs half a cycle apart."""
        t0 = 1.0 / omega0
        swing = max(min(clock.swing_frac * clock.period, self.cfg.max_swing * t0), clock.bal.min_swing_s)
        self.swing_s, self.step_s = swing, swing + self.cfg.double_support * t0
        clock.period = 2.0 * self.step_s
        clock.swing_frac = swing / clock.period

    def hold_clock(self, clock: GaitClock, reach: float) -> None:
        """The clock kept; the speed held so a stance sweeps at most 2 x ``reach`` (m)."""
        clock.period = 2.0 * self.step_s
        clock.swing_frac = self.swing_s / clock.period
        if clock.v_des > 0 and math.isfinite(reach):
            clock.v_des = min(clock.v_des, 2.0 * reach / (clock.period - self.swing_s))

    # ------------------------------------------------------------------ balance: the capture point
    def reset(self, plan: GaitPlanner, data: mujoco.MjData, t: float) -> None:
        """The centre of mass's pendulum frequency over the neutral stance, the legs' sides and width."""
        stance = plan.stance
        g = -float(self.model.opt.gravity[2])
        self.omega_com = math.sqrt(g / max(stance.height + float(stance.com[2]), 1e-3))
        self.side = stance.side
        self.width = float(np.ptp(stance.feet[:, 1]))
        self.pre_shift = np.zeros(2)
        self._com_prev = None

    def start(self, plan: GaitPlanner, t: float) -> None:
        """Before the first lift the body moves sideways over its first stance sole (``pre_shift`` of the
        way), in ``start_s`` sqrt(L/g) s (or the gait's ``settle_s``, the longer): from between the feet,
        the first swing would fall toward the lifted leg."""
        clock = plan.clock
        clock.t_walk = t + max(plan.bal.settle_s, self.cfg.start_s / plan.legs.omega0)
        stance = 1 - clock.leg_order[0]
        side = plan.left()
        mid = 0.5 * (plan.planted[0][0:2] + plan.planted[1][0:2])
        self.pre_shift = self.cfg.pre_shift * float((plan.planted[stance][0:2] - mid) @ side) * side
        self._com_prev = None  # the start posed the body: measure from here
        plan.v_filt = np.zeros(2)

    def body_velocity(self, plan: GaitPlanner, data: mujoco.MjData) -> FloatArray:
        """The centre of mass's horizontal velocity (m/s, world): a swinging leg moves it against the root."""
        com = data.subtree_com[self.body.root_body][0:2].copy()
        prev, self._com_prev = self._com_prev, com
        return np.zeros(2) if prev is None else (com - prev) / plan.dt_plan

    def plan_root(self, plan: GaitPlanner, t: float, data: mujoco.MjData, feet: FloatArray,
                  swinging: list[int]) -> FloatArray:
        """Walking, the root goes where its pendulum takes it (the stance leg holds its height and
        attitude, the steps catch it); standing, it moves over its first stance sole."""
        t_walk = plan.clock.t_walk
        if t < t_walk:
            s = (t - plan.t_start) / max(t_walk - plan.t_start, 1e-6)
            return plan.origin + smootherstep(s) * self.pre_shift
        return data.qpos[0:2].copy()

    def landing(self, plan: GaitPlanner, t: float, i: int, data: mujoco.MjData) -> FloatArray:
        """Where leg ``i``'s swing ends: at the capture point its stance foot will have let the centre of
        mass reach by touch-down, xi_T = p + (xi - p) e^(w t_left) (xi = c + v/w, w = sqrt(g/h)), less
        the offsets of a steady walk at the wanted speed v_d with steps of T s and feet W apart:
        v_d T / (e^(wT) - 1) behind it, W / (e^(wT) + 1) out to the leg's side. At most
        ``max_placement`` L from the stance foot."""
        s = max(plan.clock.phase(t, i), 0.0)
        w = self.omega_com
        stance = plan.planted[1 - i][0:2] if len(plan.legs) == 2 else plan.planted[i][0:2]
        com = data.subtree_com[self.body.root_body][0:2]
        xi = com + plan.v_filt / w
        t_left = (1.0 - s) * self.swing_s
        xi_t = stance + (xi - stance) * math.exp(w * t_left)
        grow = math.exp(w * self.step_s)
        side = plan.left() * self.side[i]
        v_d = plan.clock.speed_at(t)
        p = xi_t - v_d * self.step_s / (grow - 1.0) * plan.dir + self.width / (grow + 1.0) * side
        step = p - stance
        cap = plan.bal.max_placement * plan.legs.height
        size = float(np.linalg.norm(step))
        if size > cap:
            p = stance + step * (cap / size)
        return np.array([p[0], p[1], plan.stance.site_ground[i]])

    def limit_torques(self, plan: GaitPlanner, t: float, tau: FloatArray) -> FloatArray:
        """Each stance ankle's torque held to what its sole can carry: the body's weight times
        ``ankle_cap`` x the sole's half size (more would roll the foot onto its edge; 0: no cap)."""
        if self.cfg.ankle_cap <= 0:
            return tau
        g = -float(self.model.opt.gravity[2])
        for i, acts in enumerate(self._ankle_acts):
            if acts is None or plan.clock.phase(t, i) >= 0:
                continue
            v = tau[acts]
            size = float(np.linalg.norm(v))
            cap = self.cfg.ankle_cap * self.body.mass * g * self._sole_half[i]
            if size > cap:
                tau[acts] = v * (cap / size)
        return tau


__all__ = ["BipedRules", "smootherstep"]
