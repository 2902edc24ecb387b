"""A creature leap's settings and plan (:mod:`~bipedsim.control.creature.leap`): the settings, the push's
force shared over the feet within their friction cones, the legs' stroke and the push's and the
leap's lead times. Lengths in m, times in s, velocities in m/s, forces in N; world frame, Z up."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy.optimize import nnls

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.gait import PlannedGait
from bipedsim.errors import ConfigError


@dataclass(frozen=True)
class LeapSettings:
    """How a creature leaps (lengths in units of L, the gait's standing height; times in sqrt(L/g))."""

    #: the root sinks this x L before the push: the start of the push's stroke
    crouch: float = field(default=0.25, metadata={"min": 0.0, "max": 0.6})
    #: the push ends with the legs straightened to this share of their length (the bones from the leg's
    #: root to its foot, end to end), or as they stand where that is straighter: the stroke's top
    straight: float = field(default=0.92, metadata={"gt": 0.0, "max": 1.0})
    #: the crouch is walked over this x sqrt(L/g): the gait steps on while its root is lowered, so its
    #: feet stay under the body and the walking speed is carried into the push
    crouch_time: float = field(default=2.0, metadata={"gt": 0.0, "max": 20.0})
    #: then every foot is set down where it is and held there for this x sqrt(L/g), the root at the
    #: crouch's depth: the push starts on all its feet
    set_time: float = field(default=0.4, metadata={"min": 0.0, "max": 5.0})
    #: the share of the walking speed (along the leap's heading) the root keeps at the set's end: the
    #: feet stay planted, so a trunk that keeps walking rides over its front feet (0: it comes to rest;
    #: its sideways sway is always brought to rest)
    crouch_carry: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})
    #: a foot within this x L of its standing height counts as on the floor in the set and the push
    touch: float = field(default=0.02, metadata={"min": 0.0, "max": 0.2})
    #: in the set and the push, a foot off the floor is reached this x L below it (its leg extends to
    #: find the floor rather than hang where the trunk's tilt lifted it)
    press: float = field(default=0.1, metadata={"min": 0.0, "max": 0.5})
    #: in the set and the push, an error of the root's moment weighs this x an equal force at L (a
    #: push that cannot carry both gives up force rather than leave the floor spinning)
    moment_weight: float = field(default=1.0, metadata={"gt": 0.0, "max": 100.0})
    #: in the push, a leg stretched past this share of its length is given a smaller share of the force,
    #: down to a twentieth at ``straight`` (a nearly straight leg makes a fraction of the force asked)
    bent: float = field(default=0.75, metadata={"gt": 0.0, "max": 1.0})
    #: a leg with a ball joint turned to within this (rad) of its range's end stops pushing
    limit_margin: float = field(default=0.05, metadata={"min": 0.0, "max": 1.0})
    #: friction pyramid edges per foot in the push's force sharing (more: nearer the cone)
    cone_edges: int = field(default=4, metadata={"min": 3, "max": 16})
    #: the legs' joint damping during the push, a share of the full (the gait's kd): the damping that
    #: steadies a standing leg would swallow much of a push that straightens it in a tenth of a second
    push_damping: float = field(default=0.0, metadata={"min": 0.0, "max": 1.0})
    #: the legs' joint stiffness during the push, a share of full (the crouch holds them at full): the
    #: virtual force through the legs does the pushing, the joints' PD only keeps the legs' shape
    push_stiffness: float = field(default=0.3, metadata={"gt": 0.0, "max": 1.0})
    #: the attitude PD's frequency in the set and the push, x the gait's: the spin the body leaves the
    #: floor with is kept through the flight
    push_attitude: float = field(default=1.0, metadata={"gt": 0.0, "max": 20.0})
    #: the push brings the body's angular momentum to rest over its remaining time, as it brings the
    #: velocity to the take-off's (False: the attitude PD's damping only): the spin the walk leaves the
    #: body with (a walking body sways and turns) would otherwise be kept through the flight
    push_spin_stop: bool = True
    #: the push's remaining time is taken as at least this x sqrt(L/g) (its acceleration bounded near
    #: the stroke's top)
    push_min_left: float = field(default=0.05, metadata={"gt": 0.0, "max": 1.0})
    #: the push ends at the latest after this x its planned time (a body that cannot reach the take-off
    #: velocity leaves the ground with what it reached)
    push_overrun: float = field(default=1.5, metadata={"min": 1.0, "max": 5.0})
    #: the moment (about the centre of mass) the body gets beyond the feet's planned one is estimated from
    #: its angular momentum's rate, low-passed over this x sqrt(L/g), and taken off the moment asked in the
    #: set, the push and the landing (0: not): a push whose forces come out lopsided leaves the floor spinning
    bias_time: float = field(default=0.05, metadata={"min": 0.0, "max": 5.0})
    #: past the flight's apex each foot reaches this x v / sqrt(g/L) ahead of its neutral place along the
    #: horizontal velocity v (the capture point's offset: the landing's braking force passes nearer the
    #: centre of mass; the legs' reach bounds it)
    land_reach: float = field(default=0.3, metadata={"min": 0.0, "max": 2.0})
    #: the landing's catch decelerates the body horizontally by at most this share of what the friction
    #: cone allows under the force that stops its fall
    land_friction: float = field(default=0.8, metadata={"min": 0.0, "max": 1.0})
    #: in the landing, an error of the root's moment weighs this x an equal force at L (a landing that
    #: cannot both brake and keep its attitude brakes less rather than tip over its front feet)
    land_moment_weight: float = field(default=3.0, metadata={"gt": 0.0, "max": 100.0})
    #: the landing brings the horizontal velocity to this share of the walking speed along the leap's
    #: heading (0: to rest; the gait then restarts as a walk from rest)
    land_carry: float = field(default=0.0, metadata={"min": 0.0, "max": 1.0})
    #: the legs' joint stiffness while they reach for the ground and at touch-down, a share of full
    land_stiffness: float = field(default=0.4, metadata={"gt": 0.0, "max": 1.0})
    #: the landing lasts this x sqrt(L/g) from the first foot down, the stiffness back to full over it
    land_time: float = field(default=3.0, metadata={"gt": 0.0, "max": 20.0})
    #: the landing goes on past ``land_time`` until the body has settled (all its feet but one on the
    #: floor, its vertical speed under ``settle_speed`` x sqrt(g L), its mean spin under ``settle_spin``
    #: x sqrt(g/L): a gait restarted on a body still bouncing steps from feet in the air), for at most
    #: this x sqrt(L/g) in all (or ``land_time``, where that is longer)
    land_max: float = field(default=8.0, metadata={"gt": 0.0, "max": 50.0})
    #: settled: the vertical speed under this x sqrt(g L)
    settle_speed: float = field(default=0.1, metadata={"gt": 0.0, "max": 10.0})
    #: settled: the mean spin (angular momentum over inertia) under this x sqrt(g/L)
    settle_spin: float = field(default=0.2, metadata={"gt": 0.0, "max": 10.0})
    #: the flight ends (the landing starts) at the latest this x the ballistic flight time of the take-off
    #: velocity: a body that never touches down again stops waiting
    flight_overrun: float = field(default=3.0, metadata={"min": 1.0, "max": 10.0})

    def validate(self) -> None:
        """Each value in its range (a :class:`ConfigError` naming the key)."""
        for f in self.__dataclass_fields__.values():
            v, meta = getattr(self, f.name), f.metadata
            ok = isinstance(v, (int, float)) and math.isfinite(v)
            ok = ok and v >= meta.get("min", -math.inf) and v <= meta.get("max", math.inf)
            ok = ok and ("gt" not in meta or v > meta["gt"])
            if not ok:
                raise ConfigError(f"out of range, got {v!r}", key=f"leap.{f.name}")


def cone_share(maps: FloatArray, wrench: FloatArray, friction: float, edges: int = 4,
               reg: float = 1e-4, capacity: FloatArray | None = None) -> FloatArray:
    """(n, 3) contact forces (N, world), each inside its friction cone (a pyramid of ``edges`` edges of
    slope ``friction`` inscribed in it) and pushing (f_z >= 0), whose images through ``maps`` ((n, 6, 3):
    each foot's force to six wrench rows) sum nearest ``wrench`` (6,): non-negative least squares on
    the edges' weights, ``reg`` x their squares added (a share spread over the feet, not flung from one
    to another between steps)."""
    n = len(maps)
    ang = 2.0 * math.pi * np.arange(edges) / edges
    e = np.stack([friction * np.cos(ang), friction * np.sin(ang), np.ones(edges)])  # (3, edges)
    cap = np.ones(n) if capacity is None else np.asarray(capacity, dtype=float)
    a = np.concatenate([cap[i] * np.asarray(m) @ e for i, m in enumerate(maps)], axis=1) if n else np.zeros((6, 0))
    k = n * edges
    c, _ = nnls(np.vstack([a, math.sqrt(reg) * np.eye(k)]), np.concatenate([wrench, np.zeros(k)]), maxiter=50 * k)
    return cap[:, None] * (e @ c.reshape(n, edges).T).T


def cone_forces(force: FloatArray, torque: FloatArray, points: FloatArray, com: FloatArray, friction: float,
                lever: float, edges: int = 4, capacity: FloatArray | None = None) -> FloatArray:
    """(n, 3) contact forces (N) at ``points`` (n, 3; m, world), each in its friction cone and pushing
    (:func:`cone_share`), whose sum and moment about ``com`` come nearest ``force`` (N) and ``torque``
    (N*m), the moment's error counted over the ``lever`` (m; the body's height: a moment error of
    F x lever weighs as a force error of F)."""
    maps = []
    for p in points:
        r = np.asarray(p, dtype=float) - com
        rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        maps.append(np.vstack([np.eye(3), rx / lever]))
    return cone_share(np.array(maps), np.concatenate([force, np.asarray(torque, dtype=float) / lever]), friction, edges,
                      capacity=capacity)


def leg_lengths(gait: PlannedGait) -> FloatArray:
    """Each leg's length (m): its bones from the leg's root body to its foot site, end to end, as posed
    in ``gait``'s neutral stance."""
    model, legs, ik = gait.body.model, gait.legs, gait.ik
    d = mujoco.MjData(model)
    d.qpos[:] = gait.stance.q
    mujoco.mj_kinematics(model, d)
    out = []
    for i, leg in enumerate(legs):
        pts = np.array([d.xpos[model.body(b).id] for b in leg.bodies] + [d.site_xpos[ik.sites[i]]])
        out.append(float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()))
    return np.array(out)


def leg_extension(gait: PlannedGait, straight: float) -> float:
    """The least room (m) any leg of ``gait``'s body has to straighten from its neutral stance: per leg,
    ``straight`` x its length (its bones from the leg's root body to its foot site, end to end, as
    posed in the stance) less the distance from its root to its foot site as it stands; at least 0."""
    model, legs, ik = gait.body.model, gait.legs, gait.ik
    d = mujoco.MjData(model)
    d.qpos[:] = gait.stance.q
    mujoco.mj_kinematics(model, d)
    room = math.inf
    for i, leg in enumerate(legs):
        pts = np.array([d.xpos[model.body(b).id] for b in leg.bodies] + [d.site_xpos[ik.sites[i]]])
        length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        room = min(room, straight * length - float(np.linalg.norm(pts[-1] - pts[0])))
    return max(room, 0.0) if math.isfinite(room) else 0.0


def stroke(gait: PlannedGait, settings: LeapSettings) -> float:
    """The push's stroke (m): the root's rise from the crouch (``crouch`` x L below standing) to the
    legs straightened (:func:`leg_extension`)."""
    return settings.crouch * gait.legs.height + leg_extension(gait, settings.straight)


def push_time(stroke_m: float, velocity: FloatArray) -> float:
    """The push's planned duration (s) for a take-off ``velocity`` (m/s, world; its z part > 0) over a
    stroke of ``stroke_m`` (m) at constant vertical acceleration from rest to v_z: 2 stroke / v_z."""
    vz = float(velocity[2])
    if not (math.isfinite(vz) and vz > 0.0):
        raise ConfigError(f"a leap's take-off velocity must rise (its z part > 0 m/s), got {vz!r}",
                          key="leap.velocity")
    return 2.0 * stroke_m / vz


def lead_time(gait: PlannedGait, velocity: FloatArray, settings: LeapSettings) -> float:
    """The time (s) from a leap's start to its planned take-off: the crouch, the set and the push."""
    return (settings.crouch_time + settings.set_time) / gait.legs.omega0 + push_time(stroke(gait, settings), velocity)
