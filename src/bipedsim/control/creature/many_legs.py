"""The planned gait's quasi-static rules, for any number of legs but two (four: a dog, a horse, a bred
quadruped): the body rests on the support polygon of the feet that stay down while one leg swings.

- **feet**: placed by their toes' touch sites, their own joints held at the neutral pose -- except a
  foot the body stands on along its length (a sole or palm with its toes or fingers folded in: the
  plan's ``extra["folded_feet"]``), whose own joint (the ankle, the wrist) the IK turns as well: held,
  the sole would tip onto its heel or toes as the leg sweeps under the body;
- **trunk**: on its path, the centre of mass shifted toward the centroid of the feet that carry the
  next swing (sideways only, by ``lateral_only``), by the share an inverted pendulum follows at the
  gait's cycle (:func:`shift_share`);
- **landing**: half a stance ahead of the foot's neutral place at landing time, plus the
  inverted-pendulum correction ``step_placement`` sqrt(L/g) (v - v_d), at most ``max_placement`` L;
  with a catch (``capture_step``), out to the side the capture point went (at most the leg's reach).

Lengths in m, times in s, world frame.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.clock import GaitClock
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.planner import GaitPlanner
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.control.creature.stance import Stance


def shift_share(bal: CreatureBalanceConfig, period: float, stance: Stance, height: float, gravity: float) -> float:
    """The share of the way the centre of mass moves toward the next support's centroid: ``com_shift``,
    with ``com_shift_dynamic`` scaled by the inverted pendulum's response at the gait's frequency. The
    supports' centroid sways once per cycle (``period`` s); a centre of mass at height h over the feet
    swaying by a at w = 2 pi / period needs its centre of pressure to sway by a (1 + w^2 h / g)
    (x'' = g / h (x - p)), so with the pressure held to the support's own sway the centre of mass
    follows 1 / (1 + w^2 h / g) of it: a fast cycle of a tall body little of the way (shifted all the
    way, it rocks onto the swinging leg's corner), a slow walk nearly all of it."""
    if not bal.com_shift_dynamic or not math.isfinite(period) or period <= 0:
        return bal.com_shift
    h = height  # the centre of mass's height over the feet
    if len(stance.feet):
        h = max(float(stance.com[2] - stance.feet[:, 2].mean()), 1e-3)
    w = 2.0 * math.pi / period
    return bal.com_shift / (1.0 + w * w * h / gravity)


class ManyLegs:
    """The quasi-static rules of the planned gait, for any number of legs but two: feet placed by their
    touch sites, the root on its path with its centre of mass shifted toward the feet that carry the
    next swing, a swing landing half a stance ahead of its neutral place plus the inverted-pendulum
    correction ``step_placement`` sqrt(L/g) (v - v_d) (and out to the side by a catch)."""

    name = "creature_gait"

    def __init__(self, folded_feet: tuple[str, ...] = ()) -> None:
        #: the support shift's share for this walk (:func:`shift_share`), set per rollout
        self.share = 0.0
        #: the feet the body stands on along their length (soles, palms): their own joints are not held
        self.folded_feet = folded_feet

    def balance(self, bal: CreatureBalanceConfig) -> CreatureBalanceConfig:
        return bal

    def foot_sites(self, legs: LegSet) -> list[int]:
        """Each leg's first foot's touch site."""
        return [s[0] for s in legs.sites]

    def held_feet(self, legs: LegSet, i: int) -> tuple[str, ...]:
        """The leg's feet, less the soles and palms (:attr:`folded_feet`)."""
        return tuple(f for f in legs.legs[i].feet if f not in self.folded_feet)

    def site_heights(self, default: FloatArray) -> FloatArray:
        return default

    def foot_attitude(self, i: int, fwd: FloatArray, yaw: float, data: mujoco.MjData) -> FloatArray | None:
        return None

    def time_clock(self, clock: GaitClock, omega0: float) -> None:
        pass

    def hold_clock(self, clock: GaitClock, reach: float) -> None:
        pass

    def reset(self, plan: GaitPlanner, data: mujoco.MjData, t: float) -> None:
        """The support shift's share, constant over a walk (the period and the stance are fixed)."""
        g = -float(plan.body.model.opt.gravity[2])
        self.share = shift_share(plan.bal, plan.clock.period, plan.stance, plan.legs.height, g)

    def start(self, plan: GaitPlanner, t: float) -> None:
        pass

    def body_velocity(self, plan: GaitPlanner, data: mujoco.MjData) -> FloatArray:
        """The root's horizontal velocity (m/s, world)."""
        return data.qvel[0:2]

    def plan_root(self, plan: GaitPlanner, t: float, data: mujoco.MjData, feet: FloatArray,
                  swinging: list[int]) -> FloatArray:
        """On the path, the centre of mass shifted toward the feet that carry the next swing (sideways
        only, by ``lateral_only``; not on two legs: a line of two feet is no support polygon)."""
        n, bal = len(plan.legs), plan.bal
        nxt = plan.clock.next_swing(t)
        support = [i for i in range(n) if i != nxt] or list(range(n))
        centroid = np.mean([plan.planted[i][0:2] if i not in swinging else feet[i, 0:2] for i in support], axis=0)
        path = plan.root_path(t)
        com_path = path + (plan.heading_rot() @ plan.stance.com)[0:2]
        want = self.share * (centroid - com_path) if n > 2 else np.zeros(2)
        side = plan.left()
        want = (1.0 - bal.lateral_only) * want + bal.lateral_only * float(want @ side) * side
        a = min(1.0, plan.dt_plan / max(bal.shift_time_s, 1e-6))
        plan.shift += a * (want - plan.shift)
        return path + plan.shift

    def landing(self, plan: GaitPlanner, t: float, i: int, data: mujoco.MjData) -> FloatArray:
        """Leg ``i``'s neutral point half a stance ahead at landing time, plus the inverted-pendulum
        correction on the velocity error (at most ``max_placement`` L); with ``capture_step``, a foot on
        the side the capture point went out to lands further out (at most its measured reach out)."""
        clock, bal, legs = plan.clock, plan.bal, plan.legs
        s = clock.phase(t, i)
        t_land = t + (1.0 - s) * clock.swing_frac * clock.period
        stance_t = (1.0 - clock.swing_frac) * clock.period
        ahead = clock.speed_at(t_land) * stance_t / 2.0 * plan.dir
        p = plan.foot_home(t_land, i)
        p[0:2] += ahead
        dv = plan.v_filt - clock.speed_at(t) * plan.dir
        shift = bal.step_placement / legs.omega0 * dv
        cap = bal.max_placement * legs.height
        size = float(np.linalg.norm(shift))
        if size > cap:
            shift *= cap / size
        p[0:2] += shift
        if bal.capture_step > 0 and plan.reach.out[i] > 0:
            side = plan.left()
            beyond = plan.stance.side[i] * float((plan.xi - p[0:2]) @ side)
            if beyond > 0:
                p[0:2] += plan.stance.side[i] * min(bal.capture_step * beyond, float(plan.reach.out[i])) * side
        return p

    def limit_torques(self, plan: GaitPlanner, t: float, tau: FloatArray) -> FloatArray:
        return tau


__all__ = ["ManyLegs", "shift_share"]
