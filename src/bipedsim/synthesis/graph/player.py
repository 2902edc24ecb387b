"""Playing a Motion Script on a multi-layered motion graph, producing a Motion.

The full-body layer moves along its graph: to reach a motion it follows the Floyd-Warshall route
between motions and, within the current clip, takes the nearest transition ahead on that route
(breadth-first over frames). A transition is a linear blend over k frames (root position lerp,
joint rotations slerp), with the target clip turned and shifted on the floor so its window matches
the source window (the closed-form 2-D alignment).

Child layers (``X with Y``) replace the joints of their part with a part motion: the part starts
where its graph has a transition from the body's current motion (searched up to
``SYNC_SEARCH_S`` ahead, else a forced blend), loops through its own graph, and blends back to the
body's motion before the body switches to another motion (rule 2). A part may only switch when the
body's current motion is in the part's graph (rule 1).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.config import limit_from_env
from bipedsim.errors import BipedsimError
from bipedsim.files import progress_bar
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.synthesis.graph.build import FULL, Layer, MotionGraph, Transition
from bipedsim.synthesis.graph.distance import align_2d, apply_2d
from bipedsim.synthesis.graph.prune import describe_loss, kept_span
from bipedsim.synthesis.graph.script import Command, Target

FloatArray = npt.NDArray[np.float64]
#: How far ahead (s) a child layer may wait for a real transition before a forced blend.
SYNC_SEARCH_S = 1.0
#: Most frames one play may produce: about 5 KB each (a 20-joint skeleton) while playing and writing, so
#: 100 000 frames take about 500 MB; 55 min at 30 fps, 7 min at 240 fps. Raised with
#: ``BIPEDSIM_MAX_PLAY_FRAMES``.
MAX_PLAY_FRAMES = 100_000
#: Frames between two updates of the progress bar.
PROGRESS_EVERY = 100


def max_play_frames() -> int:
    """:data:`MAX_PLAY_FRAMES`, or ``BIPEDSIM_MAX_PLAY_FRAMES`` where set."""
    return limit_from_env("play_frames", MAX_PLAY_FRAMES)


class PlayError(BipedsimError):
    """A script the graph cannot play: names the script file and line (``FILE:LINE: ...``, as a
    :class:`~bipedsim.synthesis.graph.script.ScriptError` does; ``line N: ...`` when the file is not known)."""

    def __init__(self, message: str, line: int | None = None, source: str | None = None) -> None:
        self.reason, self.line, self.source = message, line, source
        if line is None:
            where = ""
        elif source:
            where = f"{source}:{line}: "
        else:
            where = f"line {line}: "
        super().__init__(f"{where}{message}")


@dataclass
class Event:
    time_s: float
    layer: str
    kind: str  #: "transition", "layer_start", "layer_end", "forced_blend", "skipped"
    detail: str
    cost: float | None = None


@dataclass
class PartState:
    layer: Layer
    tags: set[int]
    clip: int
    frame: int
    weight: float = 0.0  #: 0 = the body's motion, 1 = the part's
    fading: int = 0  #: +1 fading in, -1 fading out
    exit: Transition | None = None  #: the part graph's transition this part will take next
    blend_from: tuple[int, int] | None = None  #: (clip, frame) being blended out of
    blend_step: int = 0
    fade_frames: int = 0  #: frames a fade takes (0: the graph's k)


@dataclass
class Player:
    graph: MotionGraph
    start: str | None = None
    clip: int = 0
    frame: int = 0
    xf: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: (theta, x0, y0) clip -> world
    roots: list[FloatArray] = field(default_factory=list)
    rots: list[FloatArray] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    parts: dict[str, PartState] = field(default_factory=dict)
    #: the script's file name, put before the line number in errors (``FILE:LINE: ...``)
    source: str | None = None
    _bar: Any = field(default=None, init=False, repr=False)  #: the progress bar while :meth:`run` plays

    def __post_init__(self) -> None:
        g = self.graph
        full = g.layers[FULL]
        if not full.kept_clips:
            raise PlayError("the full-body graph has no motion left after pruning")
        if self.start is not None:
            cands = [i for i in (g.clip_index(self.start) if self.start in g.clip_names else -1,) if i >= 0]
            cands = cands or g.clips_with(self.start)
            cands = [c for c in cands if c in full.kept_clips]
            if not cands:
                raise PlayError(f"--start {self.start!r}: no such motion or tag in the full-body graph; motions: "
                                f"{', '.join(g.clip_names)}")
            self.clip = cands[0]
        else:
            self.clip = full.kept_clips[0]
        self.k = g.config.k
        self.fps = g.config.fps
        self.max_frames = max_play_frames()
        span = kept_span(full.transitions, self.clip, g.clips[self.clip].num_frames, self.k)
        self.frame = 0 if span is None else span[0]  # a frame with a way on

    # ------------------------------------------------------------------ frames
    @property
    def time(self) -> float:
        return len(self.roots) / self.fps

    def _pose(self, clip: int, frame: int, xf: tuple[float, float, float]) -> tuple[FloatArray, FloatArray]:
        m = self.graph.clips[clip]
        theta, x0, y0 = xf
        root = apply_2d(m.root_translation[frame][None], theta, x0, y0)[0]
        rot = m.rotations[frame].copy()
        rot[0] = (Rotation.from_rotvec([0.0, 0.0, theta]) * Rotation.from_quat(rot[0])).as_quat()
        return root, rot

    def _emit(self, root: FloatArray, rot: FloatArray) -> None:
        for name, ps in list(self.parts.items()):
            if ps.fading:
                ps.weight = float(np.clip(ps.weight + ps.fading / ((ps.fade_frames or self.k) + 1), 0.0, 1.0))
            w = ps.weight
            if w > 0:
                pm = self.graph.clips[ps.clip]
                f = min(ps.frame, pm.num_frames - 1)
                j = ps.layer.joints
                a = Rotation.from_quat(rot[j])
                b = Rotation.from_quat(pm.rotations[f, j])
                if ps.blend_from is not None:  # a part transition: blend its k frames linearly
                    oc, of = ps.blend_from
                    om = self.graph.clips[oc]
                    old = Rotation.from_quat(om.rotations[min(of, om.num_frames - 1), j])
                    al = (ps.blend_step + 1) / (self.k + 1)
                    b = old * Rotation.from_rotvec(al * (old.inv() * b).as_rotvec())
                rel = (a.inv() * b).as_rotvec()
                rot[j] = (a * Rotation.from_rotvec(w * rel)).as_quat()
                self._advance_part(ps)
            if ps.fading < 0 and ps.weight <= 0:
                del self.parts[name]
                self.events.append(Event(self.time, name, "layer_end", "back on the body's motion"))
        if len(self.roots) >= self.max_frames:
            raise PlayError(self._too_long(len(self.roots) + 1))
        self.roots.append(root)
        self.rots.append(canonical_quat(rot))
        if self._bar is not None and len(self.roots) % PROGRESS_EVERY == 0:
            self._bar.update(PROGRESS_EVERY)

    def _too_long(self, frames: int) -> str:
        return (f"the motion passes {self.max_frames} frames here ({frames / self.fps:.0f} s at {self.fps:g} fps), "
                "the most one play writes; shorten the script or set BIPEDSIM_MAX_PLAY_FRAMES to allow more")

    def _play_frames(self, n: int) -> None:
        for _ in range(n):
            root, rot = self._pose(self.clip, self.frame, self.xf)
            self._emit(root, rot)
            self.frame += 1

    def _cloud(self, clip: int, frame: int, xf: tuple[float, float, float]) -> FloatArray:
        m = self.graph.clips[clip][frame:frame + self.k]
        p = m.fk()[0]
        theta, x0, y0 = xf
        return apply_2d(p.reshape(-1, 3), theta, x0, y0)

    def _transition(self, t: Transition, layer: str = FULL) -> None:
        """Play the source up to the blend window, then blend k frames into the target."""
        self._play_frames(t.src_frame - self.frame)
        src = self._cloud(self.clip, t.src_frame, self.xf)
        dst = self._cloud(t.dst, t.dst_frame, (0.0, 0.0, 0.0))
        theta, x0, y0, _ = align_2d(src, dst)
        new_xf = (theta, x0, y0)
        for m in range(self.k):
            a = (m + 1) / (self.k + 1)
            ra, qa = self._pose(self.clip, t.src_frame + m, self.xf)
            rb, qb = self._pose(t.dst, t.dst_frame + m, new_xf)
            # slerp of every joint at once: qa * exp(a log(qa^-1 qb)), as scipy's Slerp computes it
            r0 = Rotation.from_quat(qa)
            q = (r0 * Rotation.from_rotvec(a * (r0.inv() * Rotation.from_quat(qb)).as_rotvec())).as_quat()
            self._emit((1 - a) * ra + a * rb, q)
        self.events.append(Event(self.time, layer, "transition",
                                 f"{self.graph.clip_names[self.clip]}[{t.src_frame}] -> "
                                 f"{self.graph.clip_names[t.dst]}[{t.dst_frame}]", t.cost))
        self.clip, self.frame, self.xf = t.dst, t.dst_frame + self.k, new_xf

    # ------------------------------------------------------------------ parts
    def _part_exit(self, ps: PartState) -> Transition | None:
        """The last transition of the part's graph ahead in its clip toward a wanted motion."""
        n = self.graph.clips[ps.clip].num_frames
        ahead = [t for t in ps.layer.transitions if t.src == ps.clip and t.dst in ps.tags
                 and ps.frame <= t.src_frame <= n - self.k]
        if not ahead:
            return None
        last = max(t.src_frame for t in ahead)
        return min((t for t in ahead if t.src_frame >= last - 2), key=lambda t: t.cost)

    def _advance_part(self, ps: PartState) -> None:
        ps.frame += 1
        if ps.blend_from is not None:
            ps.blend_from = (ps.blend_from[0], ps.blend_from[1] + 1)
            ps.blend_step += 1
            if ps.blend_step >= self.k:
                ps.blend_from, ps.blend_step = None, 0
                ps.exit = self._part_exit(ps)
            return
        if ps.exit is None:
            ps.exit = self._part_exit(ps)
        n = self.graph.clips[ps.clip].num_frames
        if ps.exit is not None and ps.frame >= ps.exit.src_frame:
            t = ps.exit
            ps.blend_from, ps.blend_step = (ps.clip, ps.frame), 0
            ps.clip, ps.frame, ps.exit = t.dst, t.dst_frame, None
        elif ps.exit is None and ps.frame >= n - self.k:  # no way on in the graph: blend to a restart
            ps.blend_from, ps.blend_step = (ps.clip, ps.frame), 0
            ps.clip, ps.frame = sorted(ps.tags)[0], 0

    def _start_part(self, layer: Layer, wanted: list[int]) -> None:
        name = layer.name
        if self.clip not in layer.kept_clips:  # rule 1
            self.events.append(Event(self.time, name, "skipped", f"the body's motion "
                                     f"{self.graph.clip_names[self.clip]} is not in the {name} graph"))
            return
        last = self._last_exit_frame()  # the body must still have a way on after the wait
        ahead = [t for t in layer.transitions if t.src == self.clip and t.dst in wanted and
                 0 <= t.src_frame - self.frame <= SYNC_SEARCH_S * self.fps and t.src_frame <= last]
        if ahead:
            t = min(ahead, key=lambda t: (t.src_frame, t.cost))
            self._play_frames(t.src_frame - self.frame)
            clip, frame, kind = t.dst, t.dst_frame, "layer_start"
        else:
            clip, frame, kind = wanted[0], 0, "forced_blend"
        self.parts[name] = PartState(layer=layer, tags=set(wanted), clip=clip, frame=frame, weight=0.0, fading=+1)
        self.events.append(Event(self.time, name, kind, f"{name} plays {self.graph.clip_names[clip]}[{frame}]"))

    def _last_exit_frame(self) -> int:
        """The last frame of the current clip the full-body graph leaves from (play must not pass it)."""
        ends = [t.src_frame for t in self.graph.layers[FULL].transitions if t.src == self.clip]
        return max(ends) if ends else self.frame

    def _end_parts(self) -> None:
        # let them blend out on the body's motion before it moves on (rule 2) -- in the frames left
        # before the body's last way out of its clip, so the body never runs into a dead end
        room = max(self._last_exit_frame() - self.frame, 0)
        for ps in self.parts.values():
            if ps.fading >= 0:
                ps.fading = -1
            ps.fade_frames = max(1, min(self.k, int(np.ceil(ps.weight * room)) - 1))
        while self.parts and self.frame < self._last_exit_frame():
            self._play_frames(1)
        self.parts.clear()

    # ------------------------------------------------------------------ commands
    def _targets(self, layer: Layer, tag: str) -> list[int]:
        return [c for c in self.graph.clips_with(tag) if c in layer.kept_clips]

    def _lost(self, layer: Layer, tag: str, line: int) -> PlayError | None:
        """The error for a tag the graph has clips for but whose frames ``layer`` dropped when it was
        built (None when the graph has no such clip)."""
        if not self.graph.clips_with(tag):
            return None
        rep = layer.report
        label = tag.upper()
        names = ", ".join(self.graph.clip_names[c] for c in self.graph.clips_with(tag))
        lost = describe_loss(rep, label) if label in rep.get("tags", {}) else names
        q = rep.get("keeps_every_tag_from_quantile")
        fix = f" or set threshold_quantile: {q:g}" if q is not None else ""
        how = rep.get("chosen", "given threshold")
        return PlayError(f"{tag!r} ({names}) was dropped from the {layer.name} graph when it was built "
                         f"({how}, threshold {layer.threshold:.4g}): {lost}. To keep it, rebuild without "
                         f"threshold/threshold_quantile (the builder then keeps every tag){fix}", line, self.source)

    def _child_layer_for(self, target: Target) -> Layer | None:
        g = self.graph
        if target.layer is not None:
            if target.layer not in g.layers:
                raise PlayError(f"no layer {target.layer!r}; layers: {', '.join(g.layers)}")
            return g.layers[target.layer]
        children = [ly for ly in g.layers.values() if ly.parent == FULL]
        children += [ly for ly in g.layers.values() if ly.parent not in (None, FULL)]
        for ly in children:
            if self._targets(ly, target.tag):
                return ly
        return None

    def run(self, commands: list[Command]) -> Motion:
        """Play ``commands``; a script whose ``for N sec`` durations alone pass the frame limit is refused
        before playing, at the line where they do. A progress bar shows on a terminal."""
        asked = 0.0
        for cmd in commands:
            asked += (cmd.seconds or 0.0) * self.fps
            if asked > self.max_frames:
                raise PlayError(self._too_long(int(asked)), cmd.line, self.source)
        # in frames: out of those asked when every command says how long, else counted as they come
        self._bar = progress_bar(int(asked) if all(c.seconds for c in commands) else None, "playing", "frame")
        try:
            for cmd in commands:
                try:
                    self.command(cmd)
                except PlayError as exc:  # name the script's file and the command's line
                    if exc.line is not None and exc.source == self.source:
                        raise
                    raise PlayError(exc.reason, cmd.line if exc.line is None else exc.line, self.source) from None
        finally:
            if self._bar is not None:
                self._bar.close()
                self._bar = None
        return self.motion()

    def command(self, cmd: Command) -> None:
        g, full = self.graph, self.graph.layers[FULL]
        main = cmd.main
        extra = cmd.extra
        if cmd.mode == "and" and extra is not None:
            both = [c for c in self._targets(full, main.tag) if c in g.clips_with(extra.tag)]
            if both:
                self._play_target(full, both, cmd.seconds)
                return
        targets = self._targets(full, main.tag) if main.layer in (None, FULL) else []
        if main.layer not in (None, FULL):  # `Upper-Body TALK` alone: a part on the current motion
            layer = g.layers.get(main.layer)
            if layer is None:
                raise PlayError(f"no layer {main.layer!r}; layers: {', '.join(g.layers)}", cmd.line, self.source)
            self._play_layer_only(layer, main.tag, cmd.seconds)
            return
        if not targets:
            raise self._lost(full, main.tag, cmd.line) or PlayError(
                f"no motion named or tagged {main.tag!r} in the full-body graph; "
                f"tags: {sorted({t for ts in g.tags for t in ts})}", cmd.line, self.source)
        if extra is not None:
            layer = self._child_layer_for(extra)
            wanted = [] if layer is None else self._targets(layer, extra.tag)
            if not wanted:
                parts = [ly for ly in g.layers.values() if ly.parent is not None]
                lost = next((e for ly in parts if (e := self._lost(ly, extra.tag, cmd.line))), None)
                raise lost or PlayError(f"no child layer has a motion tagged {extra.tag!r}", cmd.line,
                                        self.source)
            self._reach(full, targets)
            self._start_part(layer, wanted)  # type: ignore[arg-type]
            self._play_target(full, targets, cmd.seconds, keep_parts=True)
            self._end_parts()
            return
        self._play_target(full, targets, cmd.seconds)

    def _play_layer_only(self, layer: Layer, tag: str, seconds: float | None) -> None:
        wanted = self._targets(layer, tag)
        if not wanted:
            raise PlayError(f"no motion tagged {tag!r} in layer {layer.name}")
        current = [self.clip]
        self._start_part(layer, wanted)
        self._play_target(self.graph.layers[FULL], current, seconds, keep_parts=True)
        self._end_parts()

    def _reach(self, layer: Layer, targets: list[int]) -> None:
        """Follow the route to the nearest target motion."""
        guard = 0
        while self.clip not in targets:
            guard += 1
            if guard > 50:
                raise PlayError("could not reach the motion (the graph has no route)")
            if self.parts:
                self._end_parts()
            best = min(targets, key=lambda c: layer.path_cost[self.clip, c])
            route = layer.path(self.clip, best)
            nxt = route[1] if len(route) > 1 else best
            t = self._next_exit(layer, {nxt}) or self._next_exit(layer, None)
            if t is None:
                raise PlayError(f"dead end in {self.graph.clip_names[self.clip]} at frame {self.frame}")
            self._transition(t)

    def _next_exit(self, layer: Layer, to: set[int] | None, latest: bool = False) -> Transition | None:
        """The nearest transition ahead (breadth-first over frames) -- or, with ``latest``, the last
        one before the clip runs out, to stay on the current motion as long as it lasts."""
        ahead = [t for t in layer.transitions if t.src == self.clip and t.src_frame >= self.frame
                 and (to is None or t.dst in to)]
        if not ahead:
            return None
        if latest:
            last = max(t.src_frame for t in ahead)
            return min((t for t in ahead if t.src_frame >= last - 2), key=lambda t: t.cost)
        return min(ahead, key=lambda t: (t.src_frame, t.cost))

    def _play_target(self, layer: Layer, targets: list[int], seconds: float | None, keep_parts: bool = False) -> None:
        if not keep_parts and self.parts:
            self._end_parts()
        self._reach(layer, targets)
        n_total = int(round((seconds if seconds is not None else
                             self.graph.clips[self.clip].duration) * self.fps))
        end = len(self.roots) + n_total
        while len(self.roots) < end:
            t = self._next_exit(layer, set(targets), latest=True)
            if t is None:
                t = self._next_exit(layer, None, latest=True)
            if t is None:
                raise PlayError(f"dead end in {self.graph.clip_names[self.clip]} at frame {self.frame}")
            room = t.src_frame - self.frame
            left = end - len(self.roots)
            if room >= left:
                self._play_frames(left)
                break
            if t.dst not in targets and self.parts:
                self._end_parts()  # rule 2: children end before the body switches motion
            self._transition(t)
            if self.clip not in targets:
                self._reach(layer, targets)

    def motion(self) -> Motion:
        if not self.roots:
            raise PlayError("the script produced no frames")
        return Motion(skeleton=self.graph.skeleton, frame_time=1.0 / self.fps, root_translation=np.array(self.roots),
                      rotations=np.array(self.rots), unit=1.0, up="z")

    def report(self) -> dict[str, Any]:
        return {"frames": len(self.roots), "seconds": self.time, "events": [asdict(e) for e in self.events]}
