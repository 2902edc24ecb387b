"""The tile world in physics (``bipedsim world ... --simulate``): a walking creature's synthesised
crossing tracked by its body in MuJoCo, on the world's terrain.

- **terrain**: the world's heights (tiles, mountains, walls, water beds, gaps cut) sampled onto one
  MuJoCo height field (:func:`world_grid`; :mod:`bipedsim.model.ground_grid`), in place of the body's
  flat floor: the fall rule counts it as floor and the controller's terrain queries read it;
- **body and controller**: the creature body built from the synthesised motion (the creature profile)
  and the creature controller tracking it, as ``bipedsim run --bvh OUT.bvh --profile creature`` does
  (:func:`bipedsim.sim.runner.load_scenario`), started where the world starts it;
- **steering**: the planned gait walks a straight path; each control period the body is turned toward
  the point ahead of it on the synthesised path (pure pursuit: :attr:`SimulateSettings.lookahead_m`, or
  its walking speed x :attr:`SimulateSettings.lookahead_s` where longer), at most
  :attr:`SimulateSettings.max_turn_rate` rad/s and at most what its feet carry at its speed (the
  lateral acceleration v x rate within :attr:`SimulateSettings.turn_share` x g x the support's
  half-width over its height), so it follows the path's turns and is steered back when it strays; the
  walk slows for a sharp turn ahead (:attr:`SimulateSettings.slow_for_turns`);
- **the end**: the body has reached the path's end (within :attr:`SimulateSettings.goal_radius_m` of
  its progress), it fell, or the run outlasted :attr:`SimulateSettings.time_factor` x the synthesised
  motion's duration (at least :attr:`SimulateSettings.min_seconds`).

The result (the report's ``simulated`` block, :func:`simulate_crossing`) says how it ended and where the
physical body left the synthesised path and by how much. Lengths in m, times in s, world frame, Z up.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.control.base import Controller
from bipedsim.control.settings import load_controller
from bipedsim.errors import ConfigError
from bipedsim.model.build import BuiltModel, build_model
from bipedsim.model.ground_grid import HeightGrid, with_height_grid
from bipedsim.reference.retarget import retarget
from bipedsim.sim.recorder import Recorder, Trajectory
from bipedsim.sim.rollout import Rollout, RolloutSpec
from bipedsim.sim.runner import Scenario
from bipedsim.synthesis.world.creature_file import Creature
from bipedsim.synthesis.world.synth import Curve, Synthesis
from bipedsim.synthesis.world.tiles import World

FloatArray = npt.NDArray[np.float64]

#: the travel modes a body is simulated in (the creature controller walks; it neither flies nor swims)
SIMULATED_MODES = ("walk",)


@dataclass(frozen=True)
class SimulateSettings:
    """How a crossing is simulated (lengths m, times s, rates rad/s)."""

    #: samples of the terrain per tile side (the gap of a jump event is a tenth of a tile or more)
    samples_per_tile: int = 20
    #: the steering target lies this far ahead (m) of the body's progress on the path: about a body
    #: length, so a corner is cut by little and a stray body turns back gently
    lookahead_m: float = 1.0
    #: the fastest turn (rad/s) the steering commands: the synthesised path turns a quarter circle over
    #: about half a tile, which a walking body takes in about 1-2 s
    max_turn_rate: float = 1.5
    #: ... and at least the body's walking speed x this (s) ahead: pure pursuit's lookahead, so a faster
    #: body starts its turn sooner and spreads it over a longer arc
    lookahead_s: float = 1.5
    #: the turn rate is also held to what the feet carry at the walking speed v: v x rate at most this
    #: share of g x the support's half-width over its height (``CreatureController.turn_support``),
    #: the rest left for the gait's own sway
    turn_share: float = 0.15
    #: the walk slows for a turn ahead: its speed at most sqrt(a / k), a the lateral acceleration above
    #: (``turn_share`` x g x the support's ratio) and k the path's sharpest mean curvature (1/m) over a
    #: lookahead-long arc within the lookahead plus the braking distance ahead; it changes by at most a
    #: (m/s^2), up to the gait's own speed (``CreatureController.set_walk_speed``)
    slow_for_turns: bool = True
    #: the walking speed the two above read is the body's horizontal speed low-passed over this (s):
    #: the steps make it swing by half within a stride
    speed_filter_s: float = 0.5
    #: the crossing has ended when the body's progress is within this (m) of the path's end
    goal_radius_m: float = 0.25
    #: the run ends at the latest after this many times the synthesised motion's duration (the body
    #: walks at the speed its legs allow, which may be below the clip's)
    time_factor: float = 3.0
    #: ... and at least this long (s): the gait settles and ramps up its speed over its first seconds
    min_seconds: float = 5.0
    #: the body has left the path where it is farther than this (m) from it
    off_path_m: float = 0.5
    #: samples per second of the recorded trajectory (a video's)
    record_hz: float = 30.0
    #: how far (m) past the last progress the closest path point is searched for (a path that comes
    #: back near itself is not jumped along)
    progress_window_m: float = 3.0
    #: the body leaps at each jump event of its path (``CreatureController.leap``, the plan's take-off
    #: velocity along the path's heading), timed so its take-off comes at the plan's take-off point
    leap: bool = True
    #: the take-off angle (degrees above the path) the body's leap is asked for, at the speed that flies
    #: the distance its feet need (:meth:`Leaps.velocity`): 45 is the slowest take-off over level
    #: ground, the least a short-legged push must give (the plan's own angle, chosen for the least force
    #: of a fixed-time push, asks more speed); None: the plan's angle, speed and take-off point
    leap_angle_deg: float | None = 45.0
    #: the leap's margins at either edge of a gap, a share of the body's footprint (its feet's reach from
    #: the foremost to the hindmost, in its neutral stance): the front feet are planted this far short
    #: of the near edge, the hind feet land this far past the far one
    leap_margin: float = 0.25
    #: the take-off speed asked is this x the speed that just flies that distance: a push reaches about
    #: nine tenths of the velocity it is asked for (its feet leave the floor as the legs straighten)
    leap_speed_margin: float = 1.15

    def validate(self) -> None:
        """Each value in its range (a :class:`ConfigError` naming the key)."""
        for key, lo, hi in (("samples_per_tile", 2, 100), ("lookahead_m", 0.05, 20.0),
                            ("lookahead_s", 0.0, 20.0), ("turn_share", 0.01, 1.0), ("speed_filter_s", 0.0, 10.0),
                            ("max_turn_rate", 0.01, 20.0), ("goal_radius_m", 0.01, 50.0),
                            ("time_factor", 0.1, 20.0), ("min_seconds", 0.0, 600.0), ("off_path_m", 0.01, 50.0),
                            ("record_hz", 1.0, 500.0),
                            ("progress_window_m", 0.1, 100.0), ("leap_angle_deg", 5.0, 85.0),
                            ("leap_margin", 0.0, 5.0), ("leap_speed_margin", 1.0, 3.0)):
            v = getattr(self, key)
            if key == "leap_angle_deg" and v is None:
                continue
            if not (isinstance(v, (int, float)) and lo <= v <= hi):
                raise ConfigError(f"must lie in [{lo:g}, {hi:g}], got {v!r}", key=f"simulate.{key}")


def world_grid(world: World, samples_per_tile: int = SimulateSettings.samples_per_tile) -> HeightGrid:
    """The world's terrain heights (m) sampled ``samples_per_tile`` times per tile side over the whole
    map, row 0 at its south edge (y = -rows x tile), column 0 at its west edge (x = 0)."""
    rows, cols = world.shape
    xs = np.linspace(0.0, cols * world.tile, cols * samples_per_tile + 1)
    ys = np.linspace(-rows * world.tile, 0.0, rows * samples_per_tile + 1)
    gx, gy = np.meshgrid(xs, ys)
    h = world.terrain(np.stack([gx, gy], axis=-1))
    return HeightGrid(heights=h, x0=0.0, y0=float(-rows * world.tile), dx=float(xs[1] - xs[0]),
                      dy=float(ys[1] - ys[0]))


def world_body(syn: Synthesis, world: World, settings: SimulateSettings) -> Scenario:
    """The creature body built from the synthesised motion (creature profile) on the world's terrain,
    its reference retargeted, with the controller's default settings."""
    motion = syn.motion
    cfg = load_controller(None)
    built = build_model(motion, "creature", name="world")
    clip = retarget(motion, built.model, plan=built.plan, xml=built.xml, source="bipedsim world")
    on_terrain: BuiltModel = with_height_grid(built, world_grid(world, settings.samples_per_tile))
    return Scenario(built=on_terrain, clip=clip, cfg=cfg, source_path="bipedsim world", config_path=None,
                    motion=motion, creature_cfg=cfg.creature)


class Leaps:
    """The rollout hook that starts the body's leap over each jump of the synthesised path, at
    :attr:`angle_deg` (see :meth:`velocity`): the leap is asked for when the body's progress
    (:class:`Steering`'s) plus its speed times the walked crouch (``ctrl.leap_set_s()``) reaches the
    set point, where the front feet stand ``margin`` x the footprint short of the gap's near edge
    (``ctrl.leap_footprint()``). With ``angle_deg`` None, the plan's take-off velocity is asked, timed
    so the take-off comes at the plan's take-off point (``ctrl.leap_lead_s``). A controller without
    ``leap`` is left walking."""

    def __init__(self, jumps: list[Any], curve: Curve, steering: Steering, angle_deg: float | None = None,
                 world: World | None = None, margin: float = SimulateSettings.leap_margin,
                 speed_margin: float = SimulateSettings.leap_speed_margin) -> None:
        self.jumps, self.curve, self.steering, self.world = jumps, curve, steering, world
        #: the take-off angle asked (degrees; None: each plan's own) and the margin (share of the footprint)
        self.angle_deg, self.margin, self.speed_margin = angle_deg, margin, speed_margin
        #: per jump: the time (s) its leap was asked for (None: not yet)
        self.asked: list[float | None] = [None] * len(jumps)
        #: per jump: where its leap was planned (arc lengths m, flight distance m, height change m)
        self.planned: list[dict[str, float] | None] = [None] * len(jumps)

    def _height(self, s: float) -> float:
        """The terrain's height (m) under the path at arc length ``s`` (m); 0 without a world."""
        if self.world is None:
            return 0.0
        xy, _ = self.curve.at(np.array(s))
        return float(self.world.terrain(np.asarray(xy)[None, :])[0])

    def edges(self, k: int) -> tuple[float, float]:
        """Jump ``k``'s gap: its near and far edges (arc lengths, m; the plan's take-off and landing lie
        symmetrically about its middle)."""
        j = self.jumps[k]
        mid = 0.5 * (j.s_takeoff + j.s_land)
        return mid - j.width / 2, mid + j.width / 2

    def set_point(self, k: int, ctrl: Controller) -> float:
        """Where (arc length, m) the root stands when the feet are planted for jump ``k``'s push: the
        front feet ``margin`` x the footprint short of the near edge."""
        front, hind = ctrl.leap_footprint()
        near, _ = self.edges(k)
        return near - front - self.margin * (front - hind)

    def velocity(self, k: int, ctrl: Controller | None = None, speed: float = 0.0) -> FloatArray:
        """Jump ``k``'s take-off velocity (m/s, world) along the path's heading there. At :attr:`angle_deg`,
        ``speed_margin`` x the speed that flies the root from its take-off (the set point, plus the set
        and the push at the walking ``speed``, m/s) to where the hind feet land ``margin`` x the
        footprint past the far edge, d (m), rising dh (m, the terrain's change):
        v^2 = g d^2 / (2 cos^2 a (d tan a - dh)); without a controller that has a footprint, the plan's
        take-off-to-landing distance. With ``angle_deg`` None, the plan's velocity."""
        j = self.jumps[k]
        _, yaw = self.curve.at(np.array(j.s_takeoff))
        vx, vz = j.vx, j.vz
        if self.angle_deg is not None:
            a = math.radians(self.angle_deg)
            g = getattr(j, "g", 9.81)
            if ctrl is not None and hasattr(ctrl, "leap_footprint"):
                front, hind = ctrl.leap_footprint()
                _, far = self.edges(k)
                s_set = self.set_point(k, ctrl)
                s_land = far - hind + self.margin * (front - hind)
                v = math.sqrt(g * (s_land - s_set))
                for _ in range(2):  # the set and the push move the root on before the take-off
                    u = np.array([math.cos(a), 0.0, math.sin(a)]) * v
                    s_to = s_set + speed * (ctrl.leap_lead_s(u) - ctrl.leap_set_s())
                    d, dh = s_land - s_to, self._height(s_land) - self._height(s_to)
                    v = math.sqrt(g * d * d / (2.0 * math.cos(a) ** 2 * max(d * math.tan(a) - dh, 1e-3)))
                    v *= self.speed_margin
                self.planned[k] = {"s_set_m": s_set, "s_takeoff_m": s_to, "s_land_m": s_land, "flight_m": d,
                                   "rise_m": dh}
            else:
                v = math.sqrt(g * (j.s_land - j.s_takeoff) / math.sin(2 * a))
            vx, vz = v * math.cos(a), v * math.sin(a)
        return np.array([vx * math.cos(float(yaw)), vx * math.sin(float(yaw)), vz])

    def __call__(self, t: float, data: Any, ctrl: Controller) -> None:
        leap = getattr(ctrl, "leap", None)
        if leap is None or not getattr(ctrl, "can_leap", lambda: False)() or ctrl.leaping:
            return
        speed = float(np.linalg.norm(data.qvel[0:2]))
        for k, j in enumerate(self.jumps):
            if self.asked[k] is not None or self.steering.progress > j.s_land:
                continue
            if self.angle_deg is None or not hasattr(ctrl, "leap_footprint"):
                v = self.velocity(k)
                due = self.steering.progress + speed * ctrl.leap_lead_s(v) >= j.s_takeoff
            else:
                due = self.steering.progress + speed * ctrl.leap_set_s() >= self.set_point(k, ctrl)
                v = self.velocity(k, ctrl, speed) if due else None
            if due:
                leap(t, v)
                self.asked[k] = t
            return


class Steering:
    """The rollout hook that follows the synthesised path (see the module text) and measures how far
    the body strays from it: its progress along the path (m), the largest distance from it (m) and
    where that and the first departure beyond :attr:`SimulateSettings.off_path_m` happened."""

    def __init__(self, curve: Curve, settings: SimulateSettings, world: World) -> None:
        self.curve, self.settings, self.world = curve, settings, world
        self.progress = 0.0
        self.yaw: float | None = None
        self.t_last = 0.0
        self.max_off = 0.0
        self.max_off_at: dict[str, Any] | None = None
        self.left_at: dict[str, Any] | None = None
        #: the body's horizontal speed (m/s), low-passed over ``speed_filter_s``
        self.speed = 0.0
        #: the last turn-rate limit (rad/s) and the largest commanded turn rate (rad/s)
        self.rate_limit = settings.max_turn_rate
        #: the gait's own walking speed (m/s; None: not read yet, or no planned gait), the speed commanded
        #: now (m/s) and the lowest commanded (m/s)
        self.walk_speed: float | None = None
        self.speed_cmd: float | None = None
        self.min_speed_cmd: float | None = None
        self.max_rate = 0.0

    def _closest(self, xy: FloatArray) -> tuple[float, float]:
        """The body's progress (m of arc, searched from :attr:`progress` back a little to
        ``progress_window_m`` ahead) and its distance (m) from the path there."""
        c, w = self.curve, self.settings.progress_window_m
        keep = (c.s >= self.progress - w / 4) & (c.s <= self.progress + w)
        pts, ss = c.xy[keep], c.s[keep]
        d = np.linalg.norm(pts - xy, axis=1)
        k = int(np.argmin(d))
        return float(ss[k]), float(d[k])

    def ahead(self, s: float) -> FloatArray:
        """The path's point at arc length ``s`` (m), past its end continued straight along its last heading
        (a target short of the body near the end would turn it about)."""
        c = self.curve
        xy, yaw = c.at(np.array(min(s, c.length)))
        beyond = max(s - c.length, 0.0)
        return xy + beyond * np.array([math.cos(float(yaw)), math.sin(float(yaw))])

    def where(self, t: float, xy: FloatArray, off: float) -> dict[str, Any]:
        r, c = self.world.tile_of(xy)
        return {"t_s": round(t, 3), "xy_m": [round(float(v), 3) for v in xy], "tile": [int(r), int(c)],
                "off_m": round(off, 4), "progress_m": round(self.progress, 3)}

    def __call__(self, t: float, data: Any, ctrl: Controller) -> None:
        xy = data.qpos[0:2].copy()
        s, off = self._closest(xy)
        self.progress = max(self.progress, s)
        if off > self.max_off:
            self.max_off, self.max_off_at = off, self.where(t, xy, off)
        if off > self.settings.off_path_m and self.left_at is None:
            self.left_at = self.where(t, xy, off)
        if self.yaw is None:
            self.yaw = ctrl.heading(data)
        dt = max(t - self.t_last, 0.0)
        st = self.settings
        v = float(np.linalg.norm(data.qvel[0:2]))
        self.speed += (v - self.speed) * (min(dt / st.speed_filter_s, 1.0) if st.speed_filter_s > 0 else 1.0)
        look = max(st.lookahead_m, st.lookahead_s * self.speed)
        target = self.ahead(self.progress + look)
        want = math.atan2(float(target[1] - xy[1]), float(target[0] - xy[0]))
        # the pursuit's own curvature, 2 sin(a) / lookahead, a off the body's heading; a leap sets its own speeds
        if st.slow_for_turns and not getattr(ctrl, "leaping", False):
            self.slow(t, dt, ctrl, look, 2.0 * abs(math.sin(want - ctrl.heading(data))) / look)
        turn = math.remainder(want - self.yaw, 2 * math.pi)
        model = getattr(ctrl, "model", None)
        self.rate_limit = self.turn_limit(ctrl, 9.81 if model is None else -float(model.opt.gravity[2]))
        most = self.rate_limit * dt
        step = max(-most, min(most, turn))
        if dt > 0:
            self.max_rate = max(self.max_rate, abs(step) / dt)
        self.yaw += step
        self.t_last = t
        steer = getattr(ctrl, "steer", None)
        if steer is not None:
            steer(t, self.yaw)

    def curvature(self, look: float, within: float) -> float:
        """The path's sharpest mean curvature (1/m): its heading change over a ``look``-long arc (m), for
        arcs starting from the body's progress to ``within`` (m) ahead of it."""
        c = self.curve
        s0 = np.arange(self.progress, min(self.progress + within, c.length) + 1e-9, 0.1)
        if s0.size == 0:
            return 0.0
        _, y0 = c.at(s0)
        _, y1 = c.at(np.minimum(s0 + look, c.length))
        turn = np.abs(np.remainder(np.asarray(y1) - np.asarray(y0) + math.pi, 2 * math.pi) - math.pi)
        return float(np.max(turn)) / max(look, 1e-6)

    def slow(self, t: float, dt: float, ctrl: Controller, look: float, pursuit: float = 0.0) -> None:
        """Set the walk's speed for the turns ahead (``slow_for_turns``, see :class:`SimulateSettings`):
        the path's curvature ahead, or the ``pursuit`` curvature (1/m) the body is turning at toward its
        target, whichever is sharper (a body still turning out of a corner stays slow)."""
        support, setter = getattr(ctrl, "turn_support", lambda: None)(), getattr(ctrl, "set_walk_speed", None)
        if support is None or setter is None:
            return
        if self.walk_speed is None:
            self.walk_speed = ctrl.walk_speed()
            self.speed_cmd = self.min_speed_cmd = self.walk_speed
        if not self.walk_speed or self.speed_cmd is None:
            return
        model = getattr(ctrl, "model", None)
        g = 9.81 if model is None else -float(model.opt.gravity[2])
        a = self.settings.turn_share * g * support
        v = self.speed_cmd
        k = max(self.curvature(look, look + v * v / (2.0 * a)), pursuit)
        want = min(self.walk_speed, math.sqrt(a / k) if k > 1e-9 else self.walk_speed)
        v += max(-a * dt, min(a * dt, want - v))
        if v != self.speed_cmd:
            setter(t, v)
            self.speed_cmd = v
            self.min_speed_cmd = min(self.min_speed_cmd or v, v)

    def turn_limit(self, ctrl: Controller, g: float = 9.81) -> float:
        """The fastest turn (rad/s) steered now: ``max_turn_rate``, and at the walking speed v (m/s,
        :attr:`speed`) at most ``turn_share`` x g x ``ctrl.turn_support()`` / v (a controller without
        it: ``max_turn_rate`` only)."""
        st = self.settings
        support = getattr(ctrl, "turn_support", lambda: None)()
        if support is None or self.speed <= 1e-6:
            return st.max_turn_rate
        return min(st.max_turn_rate, st.turn_share * g * support / self.speed)

    @property
    def reached(self) -> bool:
        return self.progress >= self.curve.length - self.settings.goal_radius_m


def can_simulate(modes: list[str]) -> str | None:
    """None where every tile of a path is walked; else why the crossing is not simulated."""
    other = sorted(set(modes) - set(SIMULATED_MODES))
    if other:
        return (f"the path uses {', '.join(other)}: only walking is simulated (the creature controller walks; "
                "it neither flies nor swims)")
    return None


def simulate_crossing(world: World, creature: Creature, syn: Synthesis, modes: list[str], *,
                      settings: SimulateSettings | None = None, seed: int = 0) -> dict[str, Any]:
    """Simulate a walking creature's crossing (see the module text); returns the report's ``simulated``
    block: ``outcome`` (``reached``, ``fell``, ``diverged``, ``stopped``: out of time, or ``skipped``
    with ``why`` for a path that is not walked), ``end_to_goal_m`` (the root's final distance to the
    goal tile's centre), ``max_off_path_m`` and where (``max_off_path_at``: time, position, tile,
    progress), ``left_path`` (the first time the body was farther than ``off_path_m`` from the path, or
    None), ``progress_m`` of ``path_length_m``, ``sim_s``, ``fall_reason`` and ``fell_at``,
    ``speed_m_s`` (mean over the run), ``steering`` (the gait's walking speed, the slowest it was walked
    for a turn, m/s, and the fastest turn steered, rad/s), the jumps on the path and the settings."""
    return run_crossing(world, creature, syn, modes, settings=settings, seed=seed)[0]


def run_crossing(world: World, creature: Creature, syn: Synthesis, modes: list[str], *,
                 settings: SimulateSettings | None = None, seed: int = 0
                 ) -> tuple[dict[str, Any], BuiltModel | None, Trajectory | None]:
    """:func:`simulate_crossing`, also returning the body on its terrain and the recorded trajectory
    (what a video draws; None for a crossing not simulated)."""
    settings = settings or SimulateSettings()
    settings.validate()
    why = can_simulate(modes)
    if why is not None:
        return {"outcome": "skipped", "why": why}, None, None
    t0 = time.perf_counter()
    sc = world_body(syn, world, settings)
    ctrl = sc.controller()
    seconds = max(settings.min_seconds, settings.time_factor * syn.motion.duration)
    spec = RolloutSpec(seconds=seconds, seed=seed, start_frame=0.0, fall=sc.fall_criteria())
    steering = Steering(syn.curve, settings, world)
    leaps = Leaps(syn.jumps if settings.leap else [], syn.curve, steering, settings.leap_angle_deg, world,
                  settings.leap_margin, settings.leap_speed_margin)
    rec = Recorder(sc.built.model, record_hz=settings.record_hz, seconds=seconds, feet=len(ctrl.foot_names()))
    t_built = time.perf_counter()
    with Rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=sc.clip.qpos[0].copy(),
                 hooks=[steering, leaps, rec]) as run:
        while run.step():
            if steering.reached:
                break
        out = run.finish()
        final = run.data.qpos[0:3].copy()
    gr, gc = world.goal
    if out.outcome != "no_fall":
        outcome = "fell" if out.outcome == "fall" else out.outcome
    else:
        outcome = "reached" if steering.reached else "stopped"
    sim_s = float(out.sim_seconds)
    result = {"outcome": outcome, "end_to_goal_m": float(np.linalg.norm(final[0:2] - world.centre(gr, gc))),
              "max_off_path_m": steering.max_off, "max_off_path_at": steering.max_off_at,
              "left_path": steering.left_at, "progress_m": steering.progress, "path_length_m": syn.curve.length,
              "sim_s": sim_s, "final_xy_m": [float(final[0]), float(final[1])],
              "fall_reason": out.fall_reason, "speed_m_s": steering.progress / sim_s if sim_s > 0 else 0.0,
              "clip_speed_m_s": syn.curve.length / max(syn.motion.duration, 1e-9),
              "jumps": jump_records(syn.jumps, steering, leaps, getattr(ctrl, "leaps", [])),
              "fell_at": fell_where(world, out.fall_time_s, final) if out.outcome != "no_fall" else None,
              "steering": {"slowest_walk_m_s": steering.min_speed_cmd, "walk_speed_m_s": steering.walk_speed,
                           "fastest_turn_rad_s": steering.max_rate},
              "body_mass_kg": float(sum(sc.built.model.body_mass)), "body_size_m": float(creature.size),
              "settings": asdict(settings),
              "timings_s": {"build": t_built - t0, "rollout": time.perf_counter() - t_built}}
    return result, sc.built, rec.trajectory()


def jump_records(jumps: list[Any], steering: Steering, leaps: Leaps, made: list[Any]) -> list[dict[str, Any]]:
    """Per jump of the path: where (tile, gap width m, take-off and landing arc lengths m), the planned
    take-off speed (m/s), the gap's near and far edges (arc lengths m), whether the body's root got past the
    far edge (``crossed``: over ground beyond the gap, wherever the plan's landing point lies), where the body's
    leap was planned (``leap_planned``: the set, take-off and landing arc lengths m, the flight m, the
    terrain's rise m; :meth:`Leaps.velocity`) and the leap the body made (``leap``:
    :meth:`~bipedsim.control.creature.leap.Leap.record`, its planned and reached take-off velocity and
    spin, flight and peak push; None: no leap was asked for)."""
    out = []
    records = iter(made)
    for k, j in enumerate(jumps):
        leap = next(records, None) if leaps.asked[k] is not None else None
        near, far = leaps.edges(k)
        out.append({"tile": list(j.tile), "width_m": j.width, "s_takeoff_m": j.s_takeoff, "s_land_m": j.s_land,
                    "s_near_edge_m": near, "s_far_edge_m": far,
                    "takeoff_speed_m_s": j.speed, "crossed": steering.progress >= far,
                    "leap_asked_at_s": leaps.asked[k], "leap_planned": leaps.planned[k],
                    "leap": None if leap is None else leap.record()})
    return out


def fell_where(world: World, t: float | None, xyz: FloatArray) -> dict[str, Any]:
    """Where a run ended in a fall: time (s), root position (m), tile and its kind, and the root's
    distance (m) from the nearest jump's gap (0: over it; None: the world has no gap)."""
    xy = np.asarray(xyz[0:2], dtype=float)
    r, c = (int(v) for v in world.tile_of(xy))
    to_gap = None
    for ev in world.events:
        centre = world.centre(*ev.at)
        along = abs(float(xy[ev.axis] - centre[ev.axis])) - ev.width / 2
        across = abs(float(xy[1 - ev.axis] - centre[1 - ev.axis])) - world.tile / 2
        d = float(np.hypot(max(along, 0.0), max(across, 0.0)))
        to_gap = d if to_gap is None else min(to_gap, d)
    return {"t_s": None if t is None else round(float(t), 3), "xy_m": [round(float(v), 3) for v in xy],
            "tile": [r, c], "tile_kind": world.kind(r, c).name,
            "to_gap_m": None if to_gap is None else round(to_gap, 3)}


__all__ = ["SIMULATED_MODES", "Leaps", "SimulateSettings", "Steering", "can_simulate", "fell_where", "jump_records",
           "run_crossing", "simulate_crossing", "world_body", "world_grid"]
