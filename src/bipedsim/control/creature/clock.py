"""The planned creature gait's clock: when each leg swings, measured from the clip.

The legs swing one after another in the order the clip lifts them (``swing_share``/n of the cycle
each: with four legs at least three feet are down), or in the clip's own pattern (``phases: clip``,
e.g. a trot's diagonal pairs); the cycle period is chosen so a stride is at most ``stride_fraction`` x
the leg length at ``speed_fraction`` x the clip's speed (a clip in place steps in place), and later held
to the legs' measured reach (:meth:`GaitClock.hold_to_reach`). The walk starts at ``t_walk`` (s) and
its speed ramps up over ``speed_ramp_s``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.reference.clip import ReferenceClip

#: a clip whose root travels slower than this (m/s, mean over the loop) walks in place
IN_PLACE_MPS = 0.1
#: standard gravity (m/s^2): the swing time of a clip without lift-offs, and of a gravity-free model
STANDARD_GRAVITY = 9.81


def loop_speed(clip: ReferenceClip, loop: tuple[int, int]) -> float:
    """The clip's mean horizontal root speed (m/s) along its path over the frames ``loop`` [a, b)."""
    a, b = loop
    path = np.linalg.norm(np.diff(clip.qpos[a:b, :2], axis=0), axis=1).sum()
    return float(path / max((b - a - 1) * clip.frame_time, 1e-9))


def forward_axis(clip: ReferenceClip, loop: tuple[int, int], speed: float) -> FloatArray:
    """The body's forward axis (unit, root frame): the mean of the root velocity seen from the root over
    ``loop``; walking in place (``speed`` under IN_PLACE_MPS), the root frame's axis that is most
    horizontal on average (the axis from the hind legs' roots to the front ones' is as good as any)."""
    a, b = loop
    rots = Rotation.from_quat(clip.qpos[a:b, 3:7], scalar_first=True).as_matrix()
    v = clip.qvel[a:b, 0:3].copy()
    v[:, 2] = 0.0
    local = np.einsum("fji,fj->fi", rots, v)  # R^T v per frame
    fwd = local.mean(axis=0)
    fwd[2] = 0.0 if abs(fwd[2]) < np.linalg.norm(fwd[:2]) else fwd[2]
    if np.linalg.norm(fwd) < 1e-6 or speed < IN_PLACE_MPS:
        horiz = np.abs(rots[:, 2, :]).mean(axis=0)
        fwd = np.eye(3)[int(np.argmin(horiz))]
    return fwd / np.linalg.norm(fwd)


class GaitClock:
    """Each leg's swing in the gait cycle (see the module text): ``period`` (s), ``swing_frac`` (a leg's
    swing as a share of the cycle), ``offsets`` (each leg's lift-off as a share of the cycle),
    ``leg_order`` (legs by lift-off), ``v_des`` (the walking speed, m/s) and ``clip_speed`` (the clip's
    over its loop, m/s)."""

    def __init__(self, clip: ReferenceClip, loop: tuple[int, int], legs: LegSet, bal: CreatureBalanceConfig,
                 gravity: float) -> None:
        self.bal = bal
        self.clip_speed = loop_speed(clip, loop)
        self.v_des = 0.0 if self.clip_speed < IN_PLACE_MPS else bal.speed_fraction * self.clip_speed
        #: the shortest swing (s): ``min_swing_froude`` sqrt(L/g), at least ``min_swing_s``
        g = gravity or STANDARD_GRAVITY
        self.min_swing = max(bal.min_swing_s, bal.min_swing_froude * math.sqrt(legs.height / g))
        #: the time (s) the walk starts (set per rollout)
        self.t_walk = 0.0
        self._measure(clip, loop, legs)

    def _measure(self, clip: ReferenceClip, loop: tuple[int, int], legs: LegSet) -> None:
        """Leg order, swing share and cycle period from the clip's lift-offs and landings over ``loop``."""
        (a, b), b_, n = loop, self.bal, len(legs)
        # lift-off phase of each leg in the clip (first swing frame after a stance frame)
        starts = []
        swing_times, strides = [], []
        #: whether the clip lifts each leg at all over its loop
        self.clip_lifts = np.zeros(n, dtype=bool)
        for i in range(n):
            down = np.array([legs.clip_down(clip, f, i) for f in range(a, b)])
            lifts = np.flatnonzero(down[:-1] & ~down[1:])
            lands = np.flatnonzero(~down[:-1] & down[1:])
            self.clip_lifts[i] = len(lifts) > 0
            starts.append(float(lifts[0]) if len(lifts) else float(i * (b - a) / max(n, 1)))
            strides.extend(np.diff(lifts) * clip.frame_time)
            for lf in lifts:
                after = lands[lands > lf]
                if len(after):
                    swing_times.append((after[0] - lf) * clip.frame_time)
        self.leg_order = [int(i) for i in np.argsort(starts, kind="stable")]
        swing = float(np.median(swing_times)) if swing_times else 0.5 * math.sqrt(legs.height / STANDARD_GRAVITY)
        stride = float(np.median(strides)) if strides else 4.0 * swing
        self.offsets = np.zeros(n)
        if b_.phases == "clip" and strides:
            # the clip's own footfall pattern (a trot's diagonal pairs), its swing share capped
            self.swing_frac = float(np.clip(swing / stride, 0.2, b_.max_swing_fraction))
            period = stride
            for i in range(n):
                self.offsets[i] = ((starts[i] - starts[self.leg_order[0]]) * clip.frame_time / stride) % 1.0
        else:
            self.swing_frac = min(b_.swing_share / max(n, 1), b_.max_swing_fraction)
            period = swing / self.swing_frac
            for rank, i in enumerate(self.leg_order):
                self.offsets[i] = rank / max(n, 1)
        if self.v_des > 0:  # a stride of at most stride_fraction x the leg length
            period = min(period, b_.stride_fraction * legs.height / self.v_des)
        self.period = max(period, self.min_swing / self.swing_frac)

    def wave_order(self, hips: FloatArray) -> None:
        """Where the clip lifts none of the legs (its contact labels empty: a bred child's blended feet
        never stand still), the sequence gait's footfall order is the lateral-sequence walk of walking
        quadrupeds: one side's legs from the hindmost forward, then the other side's
        (``footfall_fallback: wave``; ``legs``: the legs' own order). ``hips``: (n, 3) the legs' roots
        relative to the body's root (m, heading frame)."""
        n = len(self.offsets)
        if (self.bal.footfall_fallback != "wave" or n <= 2 or self.clip_lifts.any()
                or self.bal.phases == "clip"):
            return
        side = hips[:, 1] - hips[:, 1].mean()
        self.leg_order = sorted(range(n), key=lambda i: (bool(side[i] > 0), float(hips[i, 0])))
        for rank, i in enumerate(self.leg_order):
            self.offsets[i] = rank / n

    def hold_to_reach(self, reach: float, longest_stride: float) -> None:
        """The stance's sweep, speed x stance time, at most 2 x ``reach`` (m): the cycle is shortened,
        and where the shortest swing does not allow that, the speed lowered (and held to
        ``longest_stride`` m per cycle)."""
        if self.v_des <= 0:
            return
        stance = 1.0 - self.swing_frac
        self.period = min(self.period, max(2.0 * reach, 1e-6) / (stance * self.v_des))
        shortest = self.min_swing / self.swing_frac
        if self.period < shortest:
            # the shortest cycle: the speed held to the reach
            self.period = shortest
            self.v_des = min(self.v_des, 2.0 * reach / (stance * shortest))
        # and to the longest stride at the cycle it walks (a cycle the clip's swing sets already fits it;
        # the shortest cycle may not)
        self.v_des = min(self.v_des, longest_stride / self.period)

    # ------------------------------------------------------------------ in time
    def cycle_phase(self, t: float, i: int) -> float:
        """Leg ``i``'s place in its cycle at ``t`` (s): 0 at lift-off, in [0, 1)."""
        return ((t - self.t_walk) / self.period - self.offsets[i]) % 1.0

    def phase(self, t: float, i: int) -> float:
        """Leg ``i``'s swing progress in [0, 1), or -1 while in stance."""
        if t < self.t_walk:
            return -1.0
        p = self.cycle_phase(t, i)
        return p / self.swing_frac if p < self.swing_frac else -1.0

    def next_swing(self, t: float) -> int:
        """The leg swinging now, or the next to lift off (-1 before the walk)."""
        if t < self.t_walk:
            return -1
        best, who = 2.0, -1
        for i in range(len(self.offsets)):
            p = self.cycle_phase(t, i)
            if p < self.swing_frac:
                return i
            wait = 1.0 - p
            if wait < best:
                best, who = wait, i
        return who

    def speed_at(self, t: float) -> float:
        """The walking speed (m/s) at ``t``: ramped up from the walk's start over ``speed_ramp_s``."""
        tw = max(t - self.t_walk, 0.0)
        return self.v_des * min(1.0, tw / self.bal.speed_ramp_s)

    def stance_progress(self, t: float, i: int) -> float:
        """Leg ``i``'s stance progress in [0, 1) at ``t``, or -1 while it swings or before the walk."""
        if t < self.t_walk or self.phase(t, i) >= 0:
            return -1.0
        p = self.cycle_phase(t, i)
        return (p - self.swing_frac) / max(1.0 - self.swing_frac, 1e-9)

    def wait_for(self, t: float, i: int) -> float:
        """The time (s) until leg ``i`` next lifts off."""
        return (self.offsets[i] - (t - self.t_walk) / self.period) % 1.0 * self.period


__all__ = ["IN_PLACE_MPS", "GaitClock", "forward_axis", "loop_speed"]
