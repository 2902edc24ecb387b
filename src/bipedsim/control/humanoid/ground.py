"""The reference adapted to the ground under the feet (``modulation.ground``; SIMBICON's slopes and
steps as the starting point).

The controller asks one :class:`~bipedsim.model.ground.Terrain` (height at world x, y) for three
corrections, each in the heading frame (x forward, z up):

- the swing foot over the ground ahead: its ankle target raised (or lowered) by the ground's rise from
  under the stance foot, by two-link leg IK (:func:`~bipedsim.control.humanoid.modulation.two_link`);
- the feet tilted to the ground under them, heel to toe and side to side;
- the torso leaned into a slope.

Lengths m, angles rad, torques N*m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import axis_rotation
from bipedsim.control.humanoid.modulation import raise_swing_ankle
from bipedsim.control.humanoid.settings import GroundConfig
from bipedsim.control.humanoid.sources import SIDES
from bipedsim.control.humanoid.tables import HumanoidTables
from bipedsim.model.ground import Terrain

FloatArray = npt.NDArray[np.float64]

#: where a foot's sole meets the ground, from its ankle along the heading (m): heel and toe, where
#: the ground under it is sampled
FOOT_SPAN_M = (-0.05, 0.15)
#: half the sole's width (m), where the ground's roll under a foot is sampled
FOOT_HALF_WIDTH_M = 0.05
#: points sampled over the swing foot's look-ahead
LOOKAHEAD_SAMPLES = 8
#: how fast (per unit of swing phase) a climb over an edge ahead is raised to its full height
CLIMB_RATE = 3.0
#: the spacing (m) of the samples along the heading where a step's edge is looked for
EDGE_SAMPLE_M = 0.01
#: the share of each footfall's miss (against the foreseen one) taken into the running bias
BIAS_RATE = 0.5
_Y, _X = np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])


def _height(terrain: Terrain, x: float, y: float, c: float, s: float, ahead: float, left: float = 0.0) -> float:
    """The ground's height (m) ``ahead`` m along the heading (cos ``c``, sin ``s``) and ``left`` m to its
    left of (x, y)."""
    return terrain.height(x + ahead * c - left * s, y + ahead * s + left * c)


def ground_under(terrain: Terrain, x: float, y: float, c: float, s: float) -> float:
    """The ground's height (m) under a foot whose ankle is at (x, y): its sole's mean."""
    a, b = FOOT_SPAN_M
    return 0.5 * (_height(terrain, x, y, c, s, a) + _height(terrain, x, y, c, s, b))


def swing_raise(cfg: GroundConfig, terrain: Terrain, t: HumanoidTables, data: mujoco.MjData, swing: str,
                stance: str, phase: float, c: float, s: float, short: tuple[float, float] | None = None,
                over: tuple[float, float] | None = None) -> float:
    """How far (m) the swing ankle's target rises above the reference's: the ground's rise from under
    the stance foot to the highest point from the swing toe to ``lookahead`` m past the farther of the
    two toes (the step to come), plus the clearance while that rise is up and the climb over an edge
    the swing foot is below; a drop, over the step's first half; within the limits. ``short``: a
    footfall planned short of an edge (world x, y of its ankle, m) caps that look-ahead at half
    ``edge_margin`` past its toe, so the edge beyond does not lift the foot; ``over``: one planned past
    an edge extends it to that footfall, so the foot lifts in time."""
    sx, sy, _ = data.xpos[t.foot_body[stance]].tolist()
    wx, wy, _ = data.xpos[t.foot_body[swing]].tolist()
    base = ground_under(terrain, sx, sy, c, s)
    # from the swing toe to lookahead m past it or past the stance toe, whichever is farther
    toe = FOOT_SPAN_M[1]
    stance_ahead = (sx - wx) * c + (sy - wy) * s
    reach = max(0.0, max(0.0, stance_ahead) + cfg.lookahead)
    if short is not None:
        reach = max(0.0, min(reach, (short[0] - wx) * c + (short[1] - wy) * s + 0.5 * cfg.edge_margin))
    elif over is not None:
        reach = max(reach, (over[0] - wx) * c + (over[1] - wy) * s)
    ahead = max(_height(terrain, wx, wy, c, s, toe + reach * k / (LOOKAHEAD_SAMPLES - 1))
                for k in range(LOOKAHEAD_SAMPLES))
    rise = ahead - base
    # what the swing foot must climb beyond the rise (a trailing foot below an edge the stance foot is over)
    climb = max(0.0, ahead - ground_under(terrain, wx, wy, c, s) - max(rise, 0.0))
    ph = min(max(phase, 0.0), 1.0)
    if rise <= 0.0 and climb <= 0.0:
        dz = rise * min(1.0, 2.0 * ph)
    else:
        dz = max(rise, 0.0) + cfg.clearance * math.sin(math.pi * ph) + climb * min(1.0, CLIMB_RATE * ph)
    return min(max(dz, -cfg.max_drop), cfg.max_raise)


def swing_over_ground(cfg: GroundConfig, terrain: Terrain, t: HumanoidTables, data: mujoco.MjData,
                      leg: tuple[float, float, float] | None, phase: float | None, swing: str, stance: str,
                      c: float, s: float, akp: FloatArray, q_d: FloatArray, tau: FloatArray,
                      short: tuple[float, float] | None = None, over: tuple[float, float] | None = None) -> float:
    """The swing leg over the ground ahead: the reference's leg ``leg`` (ankle from hip, forward and up,
    heading frame) reaching :func:`swing_raise` higher (``short``, ``over`` as there). The knee target
    in ``q_d`` (its torque in ``tau``
    at stiffness ``akp``) bends by the difference; returns the angle (rad, forward) that turns the swing
    thigh's world target to keep the ankle over the same point."""
    if leg is None or phase is None:
        return 0.0
    dz = swing_raise(cfg, terrain, t, data, swing, stance, phase, c, s, short, over)
    if dz == 0.0:
        return 0.0
    x, z, _ = leg
    return raise_swing_ankle(t, q_d, tau, akp, swing, x, z, dz)


def edge_up_ahead(cfg: GroundConfig, terrain: Terrain, x: float, y: float, c: float, s: float,
                  foreseen: tuple[float, float]) -> bool:
    """Whether the ground rises by ``edge_height`` m or more between the toe of a foot whose ankle is at
    (x, y) and the toe of the foreseen footfall (world x, y, m) plus ``edge_margin``."""
    toe = FOOT_SPAN_M[1]
    end = (foreseen[0] - x) * c + (foreseen[1] - y) * s + toe + cfg.edge_margin
    if end <= toe:
        return False
    base = _height(terrain, x, y, c, s, toe)
    return any(_height(terrain, x, y, c, s, toe + (end - toe) * k / (LOOKAHEAD_SAMPLES - 1)) - base
               >= cfg.edge_height for k in range(1, LOOKAHEAD_SAMPLES))


def feet_tilts(cfg: GroundConfig, terrain: Terrain, t: HumanoidTables, data: mujoco.MjData, c: float,
               s: float, swing: str | None = None,
               foreseen: tuple[float, float] | None = None) -> dict[str, FloatArray]:
    """Per foot, the heading-frame rotation that tilts its target to the ground under it: pitched toe up
    by the ground's rise heel to toe, rolled by its rise right to left (each times ``foot_tilt``; a rise
    steeper than ``max_tilt``, a step's edge, is not followed). The ``swing`` foot's toe is raised
    ``toe_lift`` rad more while an edge up lies between it and the ``foreseen`` footfall
    (:func:`edge_up_ahead`), so the toe clears the edge."""
    a, b = FOOT_SPAN_M
    lim, k = cfg.max_tilt, cfg.foot_tilt
    out: dict[str, FloatArray] = {}
    for side in SIDES:
        x, y, _ = data.xpos[t.foot_body[side]].tolist()
        mid = 0.5 * (a + b)
        pitch = math.atan2(_height(terrain, x, y, c, s, b) - _height(terrain, x, y, c, s, a), b - a)
        roll = math.atan2(_height(terrain, x, y, c, s, mid, FOOT_HALF_WIDTH_M)
                          - _height(terrain, x, y, c, s, mid, -FOOT_HALF_WIDTH_M), 2 * FOOT_HALF_WIDTH_M)
        # steeper than max_tilt under one sole is a step's edge, not ground to stand flat on
        pitch, roll = (k * v if abs(v) <= lim else 0.0 for v in (pitch, roll))
        if side == swing and foreseen is not None and cfg.toe_lift > 0.0 \
                and edge_up_ahead(cfg, terrain, x, y, c, s, foreseen):
            pitch += cfg.toe_lift
        # toe up is a negative turn about y (x forward, z up); the left edge up, a positive one about x
        out[side] = axis_rotation(_Y, -pitch).dot(axis_rotation(_X, roll))
    return out


def torso_lean(cfg: GroundConfig, terrain: Terrain, t: HumanoidTables, data: mujoco.MjData, stance: str,
               c: float, s: float) -> FloatArray:
    """The heading-frame rotation leaning the torso forward by ``lean`` x the ground's rise (rad) along
    the heading under the stance foot (a step's edge does not count: the rise over the sole, its
    mean over the foot's length either side)."""
    x, y, _ = data.xpos[t.foot_body[stance]].tolist()
    a, b = FOOT_SPAN_M
    span = 2 * (b - a)
    rise = math.atan2(_height(terrain, x, y, c, s, b + (b - a) / 2) - _height(terrain, x, y, c, s, a - (b - a) / 2),
                      span)
    if abs(rise) > cfg.max_tilt:  # an edge, not a slope
        rise = 0.0
    # torso lean forward is a negative rotation about y (x forward, z up)
    return axis_rotation(_Y, -cfg.lean * rise)


def edges_along(terrain: Terrain, x: float, y: float, c: float, s: float, a: float, b: float,
                min_height: float) -> list[float]:
    """The edges (m ahead of (x, y) along the heading) from ``a`` to ``b`` m ahead: where the ground
    rises or drops by at least ``min_height`` m from one sample (:data:`EDGE_SAMPLE_M`) to the next."""
    n = max(1, int(math.ceil((b - a) / EDGE_SAMPLE_M)))
    prev = _height(terrain, x, y, c, s, a)
    out: list[float] = []
    for k in range(1, n + 1):
        d = a + (b - a) * k / n
        h = _height(terrain, x, y, c, s, d)
        if abs(h - prev) >= min_height:
            out.append(d - 0.5 * (b - a) / n)
        prev = h
    return out


def step_shift(cfg: GroundConfig, land: float, edges: list[float]) -> float:
    """How far (m, + longer) a footfall foreseen with its ankle at ``land`` moves so that no edge (m,
    the same axis) lies under the foot (:data:`FOOT_SPAN_M`) or within ``edge_margin`` of its heel or
    toe: 0 when none does, else the smallest such move, within +-``max_shift`` (the nearest to clear
    when none within it clears)."""
    heel, toe = FOOT_SPAN_M
    m, lim = cfg.edge_margin, cfg.max_shift

    def clear(at: float) -> bool:
        return all(not at + heel - m < e < at + toe + m for e in edges)

    if lim <= 0.0 or clear(land):
        return 0.0
    # each edge's two ways out: the toe short of it, or the heel past it
    moves = sorted({e - toe - m - land for e in edges} | {e - heel + m - land for e in edges}, key=abs)
    for d in moves:
        if abs(d) <= lim and clear(land + d + math.copysign(1e-6, d)):
            return d
    return max(-lim, min(lim, moves[0]))


@dataclass
class EdgeStep:
    """The step length's change near an edge, planned once per swing (at its first control step) from
    the foreseen footfall; kept until the swing foot changes."""

    swing: str | None = None  #: the swing foot the plan is for (None: none yet)
    shift: float = 0.0  #: m, the step lengthened (+) or shortened (-)
    #: the last footfall foreseen (world x, y, m; None: none)
    foreseen: tuple[float, float] | None = None
    #: m, the footfalls' running mean lead over the foreseen ones along the heading
    bias: float = 0.0
    #: whether an edge up lies between the swing toe and the footfall's toe (and its margin)
    crossing: bool = False

    def reset(self) -> None:
        """No plan (a new rollout)."""
        self.swing, self.shift, self.foreseen, self.bias, self.crossing = None, 0.0, None, 0.0, False

    def angle(self, cfg: GroundConfig, terrain: Terrain, t: HumanoidTables, data: mujoco.MjData, swing: str,
              stance: str, c: float, s: float) -> float:
        """The swing hip's extra forward angle (rad) for this control step: ``shift_gain`` x the planned
        shift, planned when ``swing`` is a new swing foot: the footfall foreseen ``2 gap`` m ahead of the
        swing ankle (``gap``: the stance ankle's lead along the heading), checked against the edges
        (:func:`edges_along`) about it."""
        if swing != self.swing:
            self.swing = swing
            sx, sy, _ = data.xpos[t.foot_body[stance]].tolist()
            wx, wy, _ = data.xpos[t.foot_body[swing]].tolist()
            if self.foreseen is not None:  # where the last swing foot (now the stance foot) landed
                fx, fy = self.foreseen
                self.bias += BIAS_RATE * ((sx - fx) * c + (sy - fy) * s - self.bias)
            gap = (sx - wx) * c + (sy - wy) * s
            land = 2.0 * gap + self.bias
            heel, toe = FOOT_SPAN_M
            reach = cfg.max_shift + cfg.edge_margin
            edges = edges_along(terrain, wx, wy, c, s, min(toe, land + heel - reach), land + toe + reach,
                                cfg.edge_height)
            self.shift = step_shift(cfg, land, edges) if gap > 0.0 else 0.0
            self.foreseen = (wx + (land + self.shift) * c, wy + (land + self.shift) * s)
            h = EDGE_SAMPLE_M
            self.crossing = self.shift >= 0.0 and any(
                toe < e < land + self.shift + toe + cfg.edge_margin
                and _height(terrain, wx, wy, c, s, e + h) > _height(terrain, wx, wy, c, s, e - h) for e in edges)
        return cfg.shift_gain * self.shift

    @property
    def short(self) -> tuple[float, float] | None:
        """The footfall (world x, y of its ankle, m) when this swing's step is shortened; else None."""
        return self.foreseen if self.shift < 0.0 else None

    @property
    def over(self) -> tuple[float, float] | None:
        """The footfall (world x, y of its ankle, m) when this swing's step crosses an edge up; else None."""
        return self.foreseen if self.crossing else None


__all__ = ["EdgeStep", "edge_up_ahead", "edges_along", "feet_tilts", "ground_under", "step_shift",
           "swing_over_ground", "swing_raise", "torso_lean"]
