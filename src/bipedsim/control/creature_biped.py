"""The planned gait for a creature on two legs (a bird, a bred biped): the quasi-static planned gait of
:mod:`~bipedsim.control.creature_gait`, changed where two legs differ from four.

On four legs three feet stay down while one swings: the body rests on a support polygon. On two legs
the support while a leg swings is the other foot alone, so

- **feet are soles** (:mod:`bipedsim.model.creature_sole`: a flat box under each foot spanning its toes,
  measured from the skeleton): the IK places each sole's bottom centre, **flat** (its normal vertical,
  its toes along the sole's own heading in the clip), not a toe tip;
- **the centre of mass moves over the stance sole** before the other leg lifts: a double support of
  ``double_support`` sqrt(L/g) s between the swings, in which the centre of mass's sideways target
  moves from the foot that carried the last swing to the one that carries the next with a quintic
  ease (zero velocity and acceleration at both ends: the pendulum's ZMP, c - c''/w^2, stays between the
  feet); during the swing it stays over the stance sole;
- **the swing** lasts the clip's median swing time, at most ``max_swing`` sqrt(L/g) s;
- everything else -- the swing foot's placement with the inverted-pendulum correction on the velocity
  error (SIMBICON's c_v, sagittal and coronal), the stance legs' virtual wrench (gravity, root position
  and attitude through J^T), the legs' reach, the speed -- is the planned gait's.

Every length is scaled by the standing root height L and every time by sqrt(L/g): no per-clip settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature import CreatureControlConfig
from bipedsim.control.creature_balance import CreatureBalanceConfig, _rz
from bipedsim.control.creature_gait import GAITS_BY_LEGS, CreatureGaitController, _heading
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.creature import creature_legs
from bipedsim.model.plan import BodyPlanSet


@dataclass(frozen=True)
class BipedGaitConfig:
    """Timing of the two-legged planned gait, in units of sqrt(L/g) (L: the standing root height)."""

    #: double support between the swings, in which the centre of mass moves over the next stance sole
    double_support: float = field(default=2.0, metadata={"gt": 0.0})
    #: longest swing (the clip's median swing otherwise)
    max_swing: float = field(default=3.0, metadata={"gt": 0.0})
    #: integral of the centre of mass's sideways and forward error, rate x sqrt(g/L)
    com_integral: float = field(default=0.0, metadata={"min": 0.0})
    #: a stance ankle's torque at most this x body weight x the sole's half size (0: no cap)
    ankle_cap: float = field(default=1.0, metadata={"min": 0.0})


def smootherstep(s: float) -> float:
    """The quintic ease 6s^5 - 15s^4 + 10s^3 on [0, 1]: zero slope and curvature at both ends."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (s * (6.0 * s - 15.0) + 10.0)


class CreatureBipedController(CreatureGaitController):
    """The planned gait on two legs standing on soles (see the module text)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                 cfg: CreatureControlConfig | None = None, balance: CreatureBalanceConfig | None = None,
                 biped: BipedGaitConfig | None = None) -> None:
        self.biped = biped or BipedGaitConfig()
        soles = plan.extra.get("soles", {})
        self._sole_names = [soles.get(leg.root) for leg in creature_legs(plan)]
        super().__init__(model, plan, clip, cfg, balance)

    # ------------------------------------------------------------------ soles
    def _foot_sites(self) -> list[int]:
        """Each leg's sole site (the middle of its sole's bottom), or its toe's touch site without one."""
        base = super()._foot_sites()
        return [self.model.site(s).id if s else base[i] for i, s in enumerate(self._sole_names)]

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
        """The planned gait's clock, with a double support between the swings: swing the clip's (at most
        ``max_swing`` sqrt(L/g)), double support ``double_support`` sqrt(L/g), legs half a cycle apart."""
        super()._measure_gait()
        t0 = 1.0 / self.omega0
        swing = min(self.swing_frac * self.period, self.biped.max_swing * t0)
        swing = max(swing, self.bal.min_swing_s)
        self.period = 2.0 * (swing + self.biped.double_support * t0)
        self.swing_frac = swing / self.period
        if self.v_des > 0:  # a stride of at most stride_fraction x the leg length
            self.v_des = min(self.v_des, self.bal.stride_fraction * self.leg_height / self.period)

    def _support_shift(self, t: float, centroid: FloatArray, com_path: FloatArray) -> FloatArray:
        """Over the stance sole while the other leg swings; in double support, from the sole that carried
        the last swing to the one that carries the next (quintic ease); standing, from between the feet
        to the first stance sole."""
        n = len(self.legs)
        if n != 2:
            return super()._support_shift(t, centroid, com_path)
        com_path = self._com_path(t)
        feet = [self._planted[i][0:2] for i in range(n)]
        first = self.leg_order[0]
        if t < self._t_walk:  # standing: from between the feet over the first stance sole
            s = (t - self._t_start) / max(self._t_walk - self._t_start, 1e-6)
            start, end = 0.5 * (feet[0] + feet[1]), feet[1 - first]
        else:
            u = ((t - self._t_walk) / self.period) % 1.0  # leg `first` swings in [0, swing_frac)
            half = 0.5
            if u < self.swing_frac:
                return self._track_com(feet[1 - first], com_path)
            if half <= u < half + self.swing_frac:
                return self._track_com(feet[first], com_path)
            if u < half:  # `first` has landed: over it before the other lifts
                s = (u - self.swing_frac) / (half - self.swing_frac)
                start, end = feet[1 - first], feet[first]
            else:
                s = (u - half - self.swing_frac) / (half - self.swing_frac)
                start, end = feet[first], feet[1 - first]
        target = start + smootherstep(s) * (end - start)
        return self._track_com(target, com_path)

    def _track_com(self, target: FloatArray, com_path: FloatArray) -> FloatArray:
        """The shift that puts the centre of mass on ``target`` (m, world xy), with an integral of the
        measured centre of mass's error (rate ``com_integral`` sqrt(g/L)): the stance leg's PD sags
        under the body's weight, and a few centimetres are the sole's half width."""
        data = self._data
        com = data.subtree_com[self.root_body][0:2]
        v_target = (target - self._com_target) / self._dt_plan if self._com_target is not None else np.zeros(2)
        self._com_target = target.copy()
        self._com_vel_target += min(1.0, self._dt_plan / 0.1) * (v_target - self._com_vel_target)
        self._com_int += self.biped.com_integral * self.omega0 * self._dt_plan * (target - com)
        return self.bal.com_shift * (target - com_path) + self._com_int

    def _plan(self, t: float, data: mujoco.MjData) -> FloatArray:
        self._data = data
        return super()._plan(t, data)

    def _velocity_error(self, t: float) -> FloatArray:
        """Against the planned centre of mass's velocity (its moves over the stance sole are no error)."""
        return self._v_filt - self._com_vel_target

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        self._com_int = np.zeros(2)
        self._com_target: FloatArray | None = None
        self._com_vel_target = np.zeros(2)
        super().reset(data, frame, t)

    def _com_path(self, t: float) -> FloatArray:
        """Where the centre of mass is on the path (m, world xy): the path plus the centre of mass's
        offset from the root in the last planned pose (a swinging leg moves it: a bird's leg is a
        third of its mass)."""
        d = self.ik_data
        d.qpos[:] = self._ik_q
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        return self._root_path(t) + (d.subtree_com[self.root_body] - d.xpos[self.root_body])[0:2]

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
            box = [g for g in range(m.ngeom) if m.geom_bodyid[g] == body and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
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
