"""The planned gait for a creature on two legs (a bird, a bred biped), chosen by leg count
(:data:`~bipedsim.control.creature_gait.GAITS_BY_LEGS`): the planned gait of
:mod:`~bipedsim.control.creature_gait` where two legs need the same, a dynamic walk where they differ.

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
from bipedsim.control.creature import CreatureControlConfig
from bipedsim.control.creature_balance import CreatureBalanceConfig, _rz
from bipedsim.control.creature_config import BipedGaitConfig
from bipedsim.control.creature_gait import GAITS_BY_LEGS, CreatureGaitController, _heading
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.creature import creature_legs
from bipedsim.model.plan import BodyPlanSet


def smootherstep(s: float) -> float:
    """The quintic ease 6s^5 - 15s^4 + 10s^3 on [0, 1]: zero slope and curvature at both ends."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (s * (6.0 * s - 15.0) + 10.0)


class CreatureBipedController(CreatureGaitController):
    """The planned gait on two legs standing on soles (see the module text)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                 cfg: CreatureControlConfig | None = None, balance: CreatureBalanceConfig | None = None,
                 biped: BipedGaitConfig | None = None) -> None:
        self.biped = biped or (cfg or CreatureControlConfig()).biped
        b = self.biped
        balance = replace(balance or CreatureBalanceConfig(), height_fraction=b.height_fraction,
                          posture_pull=b.posture_pull, step_height=b.step_height, speed_fraction=b.speed_fraction,
                          body_freq=b.body_freq)
        soles = plan.extra.get("soles", {})
        self._sole_names = [soles.get(leg.root) for leg in creature_legs(plan)]
        super().__init__(model, plan, clip, cfg, balance)

    # ------------------------------------------------------------------ soles
    def _foot_sites(self) -> list[int]:
        """Each leg's sole site (the middle of its sole's bottom), or its toe's touch site without one."""
        base = super()._foot_sites()
        return [self.model.site(s).id if s else base[i] for i, s in enumerate(self._sole_names)]

    def _held_feet(self, i: int) -> tuple[str, ...]:
        """A sole is kept flat by its own joint (the ankle): the IK turns it; toes below it stay held."""
        if not self._sole_names[i]:
            return super()._held_feet(i)
        seg = self.model.body(int(self.model.site_bodyid[self.model.site(self._sole_names[i]).id])).name
        return tuple(f for f in self.legs[i].feet if f != seg)

    def _site_heights(self, rel: FloatArray) -> FloatArray:
        """A sole site lies on the floor when its foot stands."""
        base = super()._site_heights(rel)
        return np.array([0.0 if s else base[i] for i, s in enumerate(self._sole_names)])

    def _flat_soles(self) -> list[FloatArray | None]:
        """Per leg, the sole's orientation (heading frame) when it stands: its mean over the loop's
        frames with the sole low, turned minimally so its normal is vertical."""
        key = tuple(self.fwd)
        if getattr(self, "_flat_key", None) == key:
            return self._flat
        clip, (a, b), model, d = self.clip, self.loop, self.model, self.ik_data
        flat: list[FloatArray | None] = []
        for i, sid in enumerate(self._site_ids):
            if not self._sole_names[i]:
                flat.append(None)
                continue
            rots, heights = [], []
            for f in range(a, b):
                d.qpos[:] = clip.qpos[f]
                mujoco.mj_kinematics(model, d)
                h = _rz(_heading(d.xmat[self.root_body].reshape(3, 3), self.fwd)).T
                rots.append(h @ d.site_xmat[sid].reshape(3, 3))
                heights.append(d.site_xpos[sid][2])
            low = np.asarray(heights) <= np.percentile(heights, 25)
            mean = Rotation.from_matrix(np.asarray(rots)[low]).mean().as_matrix()
            z = mean[:, 2]
            level = Rotation.align_vectors([[0.0, 0.0, 1.0]], [z])[0].as_matrix()
            flat.append(level @ mean)
        self._flat_key, self._flat = key, flat
        return flat

    def _foot_attitude(self, i: int) -> FloatArray | None:
        att = self._flat_soles()[i]
        return None if att is None else _rz(getattr(self, "_yaw", 0.0)) @ att

    # ------------------------------------------------------------------ timing
    def _measure_gait(self) -> None:
        """The clock of a walk: the clip's median swing, at most ``max_swing`` sqrt(L/g), then a double
        support of ``double_support`` sqrt(L/g); the legs half a cycle apart."""
        super()._measure_gait()
        t0 = 1.0 / self.omega0
        swing = max(min(self.swing_frac * self.period, self.biped.max_swing * t0), self.bal.min_swing_s)
        self._swing_s, self._step_s = swing, swing + self.biped.double_support * t0
        self.period = 2.0 * self._step_s
        self.swing_frac = swing / self.period

    def _measure_reach(self) -> None:
        """The legs' reach as the planned gait measures it; the clock kept, the speed held so a stance
        sweeps at most 2 x reach."""
        super()._measure_reach()
        self.period = 2.0 * self._step_s
        self.swing_frac = self._swing_s / self.period
        if self.v_des > 0 and math.isfinite(self.reach):
            self.v_des = min(self.v_des, 2.0 * self.reach / (self.period - self._swing_s))

    # ------------------------------------------------------------------ balance: the capture point
    def _body_velocity(self, data: mujoco.MjData) -> FloatArray:
        """The centre of mass's horizontal velocity (m/s, world): a swinging leg moves it against the root."""
        com = data.subtree_com[self.root_body][0:2].copy()
        prev, self._com_prev = self._com_prev, com
        return np.zeros(2) if prev is None else (com - prev) / self._dt_plan

    def _plan_root(self, t: float, data: mujoco.MjData, feet: FloatArray, swinging: list[int]) -> FloatArray:
        """Walking, the root goes where its pendulum takes it (the stance leg holds its height and
        attitude, the steps catch it); standing, it stays over the middle of its feet."""
        if t < self._t_walk:  # standing: moving over the first stance sole
            s = (t - self._t_start) / max(self._t_walk - self._t_start, 1e-6)
            return self._origin + smootherstep(s) * self._pre_shift
        return data.qpos[0:2].copy()

    def _landing(self, t: float, i: int, data: mujoco.MjData) -> FloatArray:
        """Where leg ``i``'s swing ends: at the capture point its stance foot will have let the centre of
        mass reach by touch-down, xi_T = p + (xi - p) e^(w t_left) (xi = c + v/w, w = sqrt(g/h)), less
        the offsets of a steady walk at the wanted speed v_d with steps of T s and feet W apart:
        v_d T / (e^(wT) - 1) behind it, W / (e^(wT) + 1) out to the leg's side. At most
        ``max_placement`` L from the stance foot."""
        s = max(self._phase(t, i), 0.0)
        w = self._omega_com
        stance = self._planted[1 - i][0:2] if len(self.legs) == 2 else self._planted[i][0:2]
        com = data.subtree_com[self.root_body][0:2]
        xi = com + self._v_filt / w
        t_left = (1.0 - s) * self._swing_s
        xi_t = stance + (xi - stance) * math.exp(w * t_left)
        grow = math.exp(w * self._step_s)
        side = np.array([-self._dir[1], self._dir[0]]) * self._side[i]
        v_d = self._speed_at(t)
        p = xi_t - v_d * self._step_s / (grow - 1.0) * self._dir + self._width / (grow + 1.0) * side
        step = p - stance
        cap = self.bal.max_placement * self.leg_height
        size = float(np.linalg.norm(step))
        if size > cap:
            p = stance + step * (cap / size)
        return np.array([p[0], p[1], self.site_ground[i]])

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        self._com_prev: FloatArray | None = None
        g = -float(self.model.opt.gravity[2])
        self._omega_com = math.sqrt(g / max(self.neutral_height + float(self.neutral_com[2]), 1e-3))
        across = self.neutral_feet[:, 1] - self.neutral_feet[:, 1].mean()
        self._side = np.sign(across)  # each leg's side (heading frame: +1 left)
        self._width = float(np.ptp(self.neutral_feet[:, 1]))
        self._pre_shift = np.zeros(2)
        super().reset(data, frame, t)
        if self.cfg.support:  # held by its root: no walk
            return
        # before the first lift the body moves sideways over its first stance sole (pre_shift of the way):
        # from between the feet, the first swing would fall toward the lifted leg
        self._t_walk = t + max(self.bal.settle_s, self.biped.start_s / self.omega0)
        stance = 1 - self.leg_order[0]
        side = np.array([-self._dir[1], self._dir[0]])
        mid = 0.5 * (self._planted[0][0:2] + self._planted[1][0:2])
        self._pre_shift = self.biped.pre_shift * float((self._planted[stance][0:2] - mid) @ side) * side
        self._com_prev = None  # the reset posed the body: measure from here
        self._v_filt = np.zeros(2)

    def _ankles(self) -> None:
        """Per leg: the actuators of its sole's joint (the ankle) and the sole's half length and width (m)."""
        m = self.model
        ball_of = {int(m.jnt_bodyid[j]): k for k, j in enumerate(
            [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL])}
        self._ankle_acts: list[np.ndarray | None] = []
        self._sole_half: list[float] = []
        for i, name in enumerate(self._sole_names):
            body = int(m.site_bodyid[self._site_ids[i]]) if name else -1
            k = ball_of.get(body)
            self._ankle_acts.append(None if k is None else self.acts[k])
            box = [g for g in range(m.ngeom)
                   if m.geom_bodyid[g] == body and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
            self._sole_half.append(float(min(m.geom_size[box[0]][0:2])) if box else 0.0)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        """The planned gait's torques, each stance ankle's held to what its sole can carry: the body's
        weight times ``ankle_cap`` x the sole's half size (more would roll the foot onto its edge)."""
        tau = super().__call__(model, data, t, dt)
        if self.cfg.support or self.biped.ankle_cap <= 0:
            return tau
        if not hasattr(self, "_ankle_acts"):
            self._ankles()
        g = -float(model.opt.gravity[2])
        for i, acts in enumerate(self._ankle_acts):
            if acts is None or self._phase(t, i) >= 0:
                continue
            v = tau[acts]
            size = float(np.linalg.norm(v))
            cap = self.biped.ankle_cap * self.mass * g * self._sole_half[i]
            if size > cap:
                tau[acts] = v * (cap / size)
        return tau

    def metrics(self) -> dict[str, object]:
        out = super().metrics()
        out["controller"] = "creature_biped"
        return out


GAITS_BY_LEGS[2] = CreatureBipedController

__all__ = ["BipedGaitConfig", "CreatureBipedController", "smootherstep"]
