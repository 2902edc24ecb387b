"""Motion synthesis along a path: a creature's loops chained tile by tile, transitions at key frames
(time warp of the two intervals to one length m, then the P(n) = n^2/m^2 blend), the root carried
along a smoothed path through the tile centres (heading blended, not snapped), terrain events applied,
no point of the body below the terrain.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation

from bipedsim.config import limit_from_env
from bipedsim.errors import BipedsimError
from bipedsim.model.source import motion_points
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.synthesis.world.blend import WEIGHTS, slerp, warp_times
from bipedsim.synthesis.world.creature_file import Creature, ModeClip, retarget_default
from bipedsim.synthesis.world.events import JumpPlan, plan_jump, push_ik
from bipedsim.synthesis.world.path import Path
from bipedsim.synthesis.world.tiles import World, WorldError

FloatArray = npt.NDArray[np.float64]

#: Curve sampling (fraction of a tile) and corner smoothing window (tiles): the heading turns over about
#: half a tile instead of snapping at a tile centre.
CURVE_STEP_TILES = 0.02
CORNER_WINDOW_TILES = 0.5
#: Seconds of the idle clip played at the goal (creatures that have one).
IDLE_END_S = 2.0
#: Clearance (m) kept between a flying creature's lowest point and the highest terrain under its flight.
FLY_CLEARANCE_M = 0.3
#: Safety stop: at most this many times the frames the path needs at the slowest clip speed.
MAX_FRAMES_FACTOR = 4.0
#: Most frames one creature's motion may have: about 5 KB each while it is made, so 100 000 frames take
#: about 500 MB (30 min of motion at 55 fps). Raised with ``BIPEDSIM_MAX_WORLD_FRAMES``.
MAX_WORLD_FRAMES = 100_000


def max_world_frames() -> int:
    """:data:`MAX_WORLD_FRAMES`, or ``BIPEDSIM_MAX_WORLD_FRAMES`` where set."""
    return limit_from_env("world_frames", MAX_WORLD_FRAMES)


@dataclass
class Curve:
    """The root's path: points (N, 2) every ``step`` m of arc, their arc length and heading (rad)."""

    xy: FloatArray
    s: FloatArray
    yaw: FloatArray
    tile_s: FloatArray  #: arc length at each path tile's centre

    @property
    def length(self) -> float:
        return float(self.s[-1])

    def at(self, s: FloatArray) -> tuple[FloatArray, FloatArray]:
        s = np.clip(s, 0.0, self.length)
        xy = np.stack([np.interp(s, self.s, self.xy[:, 0]), np.interp(s, self.s, self.xy[:, 1])], axis=-1)
        return xy, np.interp(s, self.s, self.yaw)


def make_curve(world: World, path: Path) -> Curve:
    """A smoothed curve through the path's tile centres (moving average over :data:`CORNER_WINDOW_TILES`,
    the ends kept)."""
    centres = np.array([world.centre(r, c) for r, c in path.tiles])
    step = CURVE_STEP_TILES * world.tile
    if len(centres) == 1:
        centres = np.vstack([centres, centres + [step, 0.0]])
    seg = np.linalg.norm(np.diff(centres, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    ss = np.linspace(0.0, cum[-1], max(2, int(np.ceil(cum[-1] / step)) + 1))
    pts = np.stack([np.interp(ss, cum, centres[:, 0]), np.interp(ss, cum, centres[:, 1])], axis=1)
    w = max(1, int(round(CORNER_WINDOW_TILES * world.tile / step)))
    sm = uniform_filter1d(pts, w, axis=0, mode="nearest")
    d = np.linalg.norm(np.diff(sm, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(d)])
    tangent = np.gradient(sm, axis=0)
    yaw = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
    tile_s = np.array([s[int(np.argmin(np.linalg.norm(sm - c, axis=1)))] for c in centres[:len(path.tiles)]])
    return Curve(xy=sm, s=s, yaw=yaw, tile_s=np.maximum.accumulate(tile_s))


@dataclass
class Transition:
    """A blend from clip ``src`` (FI from key frame ``k_from``, ``m_from`` frames) into ``dst`` (TI from
    ``k_to``, ``m_to`` frames), both time-warped to ``m`` output frames, starting at output ``frame``."""

    src: str
    dst: str
    frame: int
    k_from: float
    m_from: int
    k_to: int
    m_to: int
    m: int


@dataclass
class Synthesis:
    """The synthesised motion and what happened on the way."""

    motion: Motion
    curve: Curve
    s: FloatArray  #: arc length of the root per frame (m)
    mode: list[str]  #: clip (or "a>b" during a transition) per frame
    transitions: list[Transition] = field(default_factory=list)
    jumps: list[JumpPlan] = field(default_factory=list)
    lifted_frames: int = 0
    max_lift_m: float = 0.0
    tiles: list[tuple[int, int]] = field(default_factory=list)  #: the path's tiles
    clips: dict[str, ModeClip] = field(default_factory=dict)  #: the clips played (a flying one raised)
    blend: str = "quadratic"  #: the transition weights used


def _mode_clips(world: World, creature: Creature, path: Path, modes: list[str]) -> dict[str, ModeClip]:
    """The creature's clips, a flying clip raised where needed to keep :data:`FLY_CLEARANCE_M` over the
    highest terrain under the tiles it flies over."""
    clips = dict(creature.clips)
    fly_tiles = [t for t, m in zip(path.tiles, modes) if m == "fly"]
    if "fly" in clips and fly_tiles:
        c = clips["fly"]
        top = max(world.kind(r, cc).height for r, cc in fly_tiles)
        need = top + c.below_root + FLY_CLEARANCE_M
        lift = max(0.0, need - float(c.off[:, 2].min()))
        if lift > 0:
            off = c.off.copy()
            off[:, 2] += lift
            clips["fly"] = ModeClip(**{**c.__dict__, "off": off})
    return clips


def _best_key(src: ModeClip, k_from: float, dst: ModeClip) -> int:
    """Key-frame table look-up: the key frame of ``dst`` whose pose is closest to ``src`` at ``k_from``."""
    q, _ = src.sample(k_from)
    d = [float(np.sum(1.0 - np.einsum("jq,jq->j", q, dst.rots[int(k)]) ** 2)) for k in dst.keys]
    return int(dst.keys[int(np.argmin(d))])


class _Player:
    """Plays a creature's clips frame by frame along the curve (all in the travel frame)."""

    def __init__(self, clips: dict[str, ModeClip], first: str, dt: float, weights: str) -> None:
        self.clips, self.cur, self.dt = clips, first, dt
        self.phase = float(clips[first].keys[0])
        self.trans: Transition | None = None
        self.step = 0
        self.weight = WEIGHTS[weights]
        self.armed: tuple[str, float] | None = None  # (target clip, key frame to start at)
        self.done: list[Transition] = []  # every transition made, in order

    def request(self, dst: str) -> None:
        if self.trans is None and dst != self.cur and (self.armed is None or self.armed[0] != dst):
            k, _ = self.clips[self.cur].next_key(self.phase)
            self.armed = (dst, float(k))

    def busy(self) -> bool:
        return self.trans is not None or self.armed is not None

    def next(self, frame: int) -> tuple[FloatArray, FloatArray, float, str]:
        """Rotations, root offset and progress speed (m/s) of the next frame, and its label."""
        if self.trans is None and self.armed is not None and self.phase >= self.armed[1] - 1e-9:
            self._start(frame)
        if self.trans is not None:
            return self._blend()
        c = self.clips[self.cur]
        q, off = c.sample(self.phase)
        self.phase += self.dt / c.frame_time
        return q, off, c.speed, self.cur

    def _start(self, frame: int) -> None:
        assert self.armed is not None
        dst, k = self.armed
        src, to = self.clips[self.cur], self.clips[dst]
        _, m_from = src.next_key(k)
        k_to = _best_key(src, k, to)
        _, m_to = to.next_key(k_to)
        # both intervals time-warped to one length m (output frames): the mean of their durations
        m = max(2, int(round((m_from * src.frame_time + m_to * to.frame_time) / 2 / self.dt)))
        self.trans = Transition(src=self.cur, dst=dst, frame=frame, k_from=k, m_from=m_from, k_to=k_to,
                                m_to=m_to, m=m)
        self.done.append(self.trans)
        self.step = 0
        self.armed = None

    def _blend(self) -> tuple[FloatArray, FloatArray, float, str]:
        t = self.trans
        assert t is not None
        src, dst = self.clips[t.src], self.clips[t.dst]
        fi_t = warp_times(t.k_from, t.m_from, t.m)[self.step]
        ti_t = warp_times(t.k_to, t.m_to, t.m)[self.step]
        p = float(self.weight(t.m)[self.step])  # weight of FI, the clip left
        qf, of = src.sample(fi_t)
        qt, ot = dst.sample(ti_t)
        q = slerp(qt, qf, p)
        off = p * of + (1 - p) * ot
        v = p * src.speed + (1 - p) * dst.speed
        self.step += 1
        label = f"{t.src}>{t.dst}"
        if self.step > t.m:
            self.cur, self.phase, self.trans = t.dst, float(t.k_to + t.m_to) + self.dt / dst.frame_time, None
        return q, off, v, label


def synthesize(world: World, creature: Creature, path: Path, modes: list[str], *, weights: str = "quadratic",
               idle_s: float = IDLE_END_S) -> Synthesis:
    """Chain the creature's clips along ``path`` with the per-tile ``modes`` (see module docstring)."""
    curve = make_curve(world, path)
    clips = _mode_clips(world, creature, path, modes)
    dt = creature.frame_time
    player = _Player(clips, modes[0], dt, weights)
    triggers = _triggers(world, curve, path, modes, clips)
    jumps = [j for j in (plan_jump(world, ev_tile, curve, clips["walk"], creature)
                         for ev_tile in _walk_events(world, path, modes)) if j is not None] if "walk" in clips else []
    speeds = [c.speed for c in clips.values() if c.speed > 0]
    most = max_world_frames()
    needed = (curve.length / min(speeds) + idle_s) / dt  # at the slowest clip's speed
    if needed > most:  # refused before any frame is made
        raise WorldError(f"{creature.name} would need about {needed:.0f} frames ({needed * dt:.0f} s) to cross "
                         f"the {curve.length:.0f} m path at {min(speeds):.3g} m/s; a crossing has at most {most} "
                         "frames: make the world smaller or set BIPEDSIM_MAX_WORLD_FRAMES to allow more",
                         path=world.path, key="rows")
    limit = min(int(MAX_FRAMES_FACTOR * (curve.length / min(speeds) + idle_s + 5.0) / dt) + 10, most)
    rots, offs, ss, labels, jz = [], [], [], [], []
    s, idle_left, frame = 0.0, None, 0
    while frame < limit:
        while triggers and s >= triggers[0][0] - 1e-9:
            player.request(triggers.pop(0)[1])
        if s >= curve.length - 1e-9 and not triggers:
            if "idle" in clips and idle_s > 0 and player.cur != "idle":
                player.request("idle")
            elif not player.busy():
                if idle_left is None:
                    idle_left = int(round(idle_s / dt)) if player.cur == "idle" else 0
                if idle_left <= 0:
                    break
                idle_left -= 1
        q, off, v, label = player.next(frame)
        z_add, v = _jump_state(jumps, s, v, dt)
        rots.append(q)
        offs.append(off)
        ss.append(s)
        labels.append(label)
        jz.append(z_add)
        s = min(s + v * dt, curve.length)
        frame += 1
    if frame >= limit:
        raise BipedsimError(f"{creature.name}: the motion did not reach the goal in {limit} frames"
                            + (" (BIPEDSIM_MAX_WORLD_FRAMES)" if limit == most else ""))
    motion = _place(creature, curve, np.array(rots), np.array(offs), np.array(ss), np.array(jz), dt, world, modes,
                    path)
    ss_arr = np.array(ss)
    for j in jumps:
        frames = np.flatnonzero((ss_arr >= j.s_push) & (ss_arr < j.s_takeoff))
        motion, j.pushing_feet = push_ik(motion, frames, creature.feet, retarget_default("contact_height"))
    motion, lifted, max_lift = keep_above_terrain(motion, world)
    return Synthesis(motion=motion, curve=curve, s=np.array(ss), mode=labels, transitions=player.done, jumps=jumps,
                     lifted_frames=lifted, max_lift_m=max_lift, tiles=list(path.tiles),
                     clips=clips, blend=weights)


def _walk_events(world: World, path: Path, modes: list[str]) -> list[Any]:
    on_path = {t: i for i, t in enumerate(path.tiles)}
    return [(ev, on_path[ev.at]) for ev in world.events if ev.at in on_path and modes[on_path[ev.at]] == "walk"]


def _triggers(world: World, curve: Curve, path: Path, modes: list[str],
              clips: dict[str, ModeClip]) -> list[tuple[float, str]]:
    """Where (arc length, m) each mode change is requested: early enough to have finished at the tile
    boundary when the tile before allows the new mode, else at the boundary."""
    out = []
    for i in range(1, len(modes)):
        if modes[i] == modes[i - 1]:
            continue
        a, b = clips[modes[i - 1]], clips[modes[i]]
        s_b = (curve.tile_s[i - 1] + curve.tile_s[i]) / 2
        r, c = path.tiles[i - 1]
        if world.allows(r, c, modes[i]):
            # wait for a key frame (up to one interval) + the transition (about one interval)
            lead = (a.n / len(a.keys) * a.frame_time * 2 + b.n / len(b.keys) * b.frame_time) * max(a.speed, b.speed)
            s_b = max(s_b - lead, 0.0)
        out.append((s_b, modes[i]))
    return out


def _jump_state(jumps: list[JumpPlan], s: float, v: float, dt: float) -> tuple[float, float]:
    """Height added to the root (m) and progress speed (m/s) at arc length ``s``: the ballistic flight of a
    jump between its take-off and landing, else nothing."""
    for j in jumps:
        if j.s_push <= s < j.s_settle:
            return j.state(s, v)
    return 0.0, v


def _place(creature: Creature, curve: Curve, rots: FloatArray, offs: FloatArray, ss: FloatArray, jz: FloatArray,
           dt: float, world: World, modes: list[str], path: Path) -> Motion:
    """The travel-frame poses put on the curve: root at curve(s) + R(yaw(s)) (x, y), height off z (+ a
    jump's), root rotation turned by yaw(s)."""
    xy, yaw = curve.at(ss)
    c, sn = np.cos(yaw), np.sin(yaw)
    root = np.stack([xy[:, 0] + c * offs[:, 0] - sn * offs[:, 1], xy[:, 1] + sn * offs[:, 0] + c * offs[:, 1],
                     offs[:, 2] + jz], axis=1)
    rots = rots.copy()
    rots[:, 0] = (Rotation.from_euler("z", yaw[:, None]) * Rotation.from_quat(rots[:, 0])).as_quat()
    t = creature.template
    return Motion(skeleton=t.skeleton, frame_time=dt, root_translation=root, rotations=canonical_quat(rots),
                  unit=1.0, up="z")


def body_points(motion: Motion) -> FloatArray:
    """(T, N, 3) joints and End Sites (m)."""
    return motion_points(motion).positions


def keep_above_terrain(motion: Motion, world: World) -> tuple[Motion, int, float]:
    """Lift each frame whose lowest point is below the terrain under it by just that much; returns the
    motion, how many frames were lifted and the largest lift (m)."""
    pts = body_points(motion)
    depth = world.terrain(pts[..., :2]) - pts[..., 2]
    lift = np.maximum(depth.max(axis=1), 0.0)
    if not lift.any():
        return motion, 0, 0.0
    root = motion.root_translation.copy()
    root[:, 2] += lift
    return motion.copy(root_translation=root), int(np.count_nonzero(lift)), float(lift.max())
