"""Multi-layered motion graphs: clips, transitions, pruning, layers, similarity, shortest paths.

A *layer* is a motion graph over a set of joints: the full body, or a body part (a joint subtree from
the YAML, e.g. the upper body). A part layer is the child of the nearest layer above it on the
skeleton. For every layer:

- distance matrices between all clip pairs (windows of k frames, :mod:`bipedsim.synthesis.graph.distance`);
- transitions: local minima below the threshold, cost t = 1 - exp(-D / sigma), played as a linear
  blend over k frames (at playback, not stored);
- pruning: the graph whose nodes are each clip's departure frames (where a blend starts) and arrival
  frames (where a blend has ended: the target frame + k, where playing goes on) -- edges forward in the
  clip and the transitions -- keeps one strongly connected component (``scipy.sparse.csgraph``; the
  one covering most tags): every arrival then has a departure ahead in its clip, so play never
  reaches a dead end (:mod:`bipedsim.synthesis.graph.prune`);
- the threshold: ``threshold`` if given, else the ``threshold_quantile`` of the candidates' distances;
  with neither given the builder starts at :data:`bipedsim.synthesis.graph.prune.DEFAULT_QUANTILE` and raises
  the quantile until every tag keeps frames in the layer, with a warning -- never silently dropping
  what the user tagged. The build report (:attr:`Layer.report`) lists per clip and tag the frames
  kept and dropped and why;
- the overall motion similarity of every clip pair, (sum_i sum_j min D over segment pair (i, j)) /
  ((m/s)(n/s)) with segments of s frames;
- shortest paths between motions (Floyd-Warshall over the motion-level graph: edge weight = the
  cheapest transition + the pair's normalised similarity).

Part clouds are taken relative to the root's position and heading, so a part is compared by its own
motion, not by where the body walks.
"""

from __future__ import annotations

import io
import json
import os
import re
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import floyd_warshall

from bipedsim import config
from bipedsim.config import limit_from_env
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.files import atomic_write_bytes
from bipedsim.motion.bvh import load_bvh
from bipedsim.motion.motion import Motion
from bipedsim.motion.reroot import fold_static_root
from bipedsim.motion.skeleton import Skeleton
from bipedsim.synthesis.graph.distance import distance_matrix
from bipedsim.synthesis.graph.prune import Transition, choose_threshold, labels_of

FloatArray = npt.NDArray[np.float64]
FULL = "Full-Body"

# ---------------------------------------------------------------------- limits
#: Highest graph frame rate (frames/s): motion capture runs at 30-240 fps; the distances between clips
#: grow with the square of the frames, so a higher rate only costs memory and time.
MAX_GRAPH_FPS = 240.0
#: Longest comparison window k (frames): a third of a second is usual; 120 frames is half a second at 240 fps.
MAX_K_FRAMES = 120
#: Longest similarity segment (frames); a segment longer than a clip covers the clip.
MAX_SEGMENT_FRAMES = 1000
#: Largest blend playback rate change of a derived clip (``speed``; its inverse is the smallest).
MAX_CLIP_SPEED = 10.0
#: Most clips in a graph: every pair of clips is compared, per layer.
MAX_GRAPH_CLIPS = 100
#: Most part layers: each one compares every pair of clips again.
MAX_GRAPH_PARTS = 8
#: Most frames (all clips, at the graph's fps) a graph holds: the distance matrices take 8 bytes per pair
#: of frames and time with the square of the frames (6000 frames, 200 s of motion at 30 fps: about 500 MB
#: and half a minute per layer). Raised with ``BIPEDSIM_MAX_GRAPH_FRAMES``.
MAX_GRAPH_FRAMES = 6000
#: Most candidate transitions (local minima of the distances) per layer: real clips give a few per
#: hundred frames; noise gives one in every few pairs of frames, and pruning them all takes minutes.
MAX_CANDIDATES = 200_000
#: Longest clip name or tag (characters).
MAX_LABEL_CHARS = 64
#: A part layer's name: a word of the Motion Script (:mod:`bipedsim.synthesis.graph.script`), at most 64 characters.
PART_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]{0,63}")
#: Largest root coordinate (m) and joint offset (m) a graph file may hold.
MAX_COORD_M = 1e6
#: How far a rotation stored in a graph file may be from a unit quaternion.
UNIT_QUAT_TOL = 1e-3


def max_graph_frames() -> int:
    """:data:`MAX_GRAPH_FRAMES`, or ``BIPEDSIM_MAX_GRAPH_FRAMES`` where set."""
    return limit_from_env("graph_frames", MAX_GRAPH_FRAMES)


@dataclass(frozen=True)
class ClipSpec:
    name: str
    file: str
    tags: tuple[str, ...] = ()
    mirror: bool = False
    start: float | None = field(default=None, metadata={"min": 0.0, "unit": "s"})
    end: float | None = field(default=None, metadata={"gt": 0.0, "unit": "s"})
    #: playback rate of the source (a derived slower or faster clip)
    speed: float = field(default=1.0, metadata={"min": 1.0 / MAX_CLIP_SPEED, "max": MAX_CLIP_SPEED})

    def validate(self) -> None:
        if self.start is not None and self.end is not None and not self.end > self.start:
            raise ValueError(f"end: must be after start ({self.start:g} s), got {self.end:g} s")


@dataclass(frozen=True)
class PartSpec:
    root: str  #: the part is this joint's subtree
    weight: float = 1.0


@dataclass(frozen=True)
class GraphConfig:
    name: str = "graph"
    fps: float = field(default=30.0, metadata={"min": 1.0, "max": MAX_GRAPH_FPS, "unit": "frames/s"})
    k: int = field(default=20, metadata={"min": 2, "max": MAX_K_FRAMES, "unit": "frames"})
    #: None (and no threshold): start at DEFAULT_QUANTILE and raise it until every tag keeps frames
    threshold_quantile: float | None = field(default=None, metadata={"gt": 0.0, "max": 1.0})
    threshold: float | None = field(default=None, metadata={"gt": 0.0})
    sigma: float | None = field(default=None, metadata={"gt": 0.0})
    segment: int = field(default=10, metadata={"min": 1, "max": MAX_SEGMENT_FRAMES, "unit": "frames"})
    clips: tuple[ClipSpec, ...] = ()
    parts: dict[str, PartSpec] = field(default_factory=dict)

    def validate(self) -> None:
        if self.threshold is not None and self.threshold_quantile is not None:
            raise ValueError("threshold and threshold_quantile are both given: give one (threshold: a distance; "
                             "threshold_quantile: a share of the candidate transitions) or neither (the builder "
                             "then chooses one that keeps every tag)")
        if not self.clips:
            raise ValueError("clips: give at least one clip")
        if len(self.clips) > MAX_GRAPH_CLIPS:
            raise ValueError(f"clips: {len(self.clips)} clips; a graph holds at most {MAX_GRAPH_CLIPS} (every "
                             "pair is compared)")
        if len(self.parts) > MAX_GRAPH_PARTS:
            raise ValueError(f"parts: {len(self.parts)} parts; a graph has at most {MAX_GRAPH_PARTS} part layers "
                             "(each compares every pair of clips again)")
        names = [c.name for c in self.clips]
        if len(set(names)) != len(names):
            raise ValueError("clips: clip names must be unique")
        for c in self.clips:  # printed in reports and errors: no control characters reach a terminal
            for text in (c.name, *c.tags):
                if not (0 < len(text) <= MAX_LABEL_CHARS and text.isprintable()):
                    raise ValueError(f"clips: {text!r}: a clip's name and tags are printable text of 1 to "
                                     f"{MAX_LABEL_CHARS} characters")
        if FULL in self.parts:
            raise ValueError(f"parts: {FULL!r} is the whole body's layer; name parts otherwise")
        for name in self.parts:  # a part is named in scripts and in the graph file's array names
            if not PART_NAME.fullmatch(name):
                raise ValueError(f"parts: {name!r} cannot be named in a Motion Script: a part's name is a letter "
                                 "or '_', then letters, digits, '_' or '-' (at most 64)")


@dataclass
class Layer:
    name: str
    joints: list[int]
    parent: str | None
    transitions: list[Transition]
    similarity: FloatArray  #: (C, C) overall motion similarity
    path_cost: FloatArray  #: (C, C) Floyd-Warshall costs between motions
    predecessors: npt.NDArray[np.int64]
    threshold: float
    sigma: float
    kept_clips: list[int]  #: clips with frames in the strongly connected component
    scc_nodes: int
    build_seconds: float = 0.0
    #: how the threshold was chosen, warnings, per clip and per tag the frames kept and dropped (why)
    report: dict[str, Any] = field(default_factory=dict)

    def path(self, a: int, b: int) -> list[int]:
        """Clips on the cheapest route from motion a to motion b (a and b included)."""
        if a == b:
            return [a]
        if not np.isfinite(self.path_cost[a, b]):
            return []
        out = [b]
        while out[-1] != a:
            nxt = int(self.predecessors[a, out[-1]])
            if nxt < 0 or len(out) > len(self.predecessors):  # no route, or a loop no shortest path has
                return []
            out.append(nxt)
        return out[::-1]


@dataclass
class MotionGraph:
    config: GraphConfig
    skeleton: Skeleton
    clips: list[Motion]  #: project frame, resampled to the graph's fps
    tags: list[list[str]]
    layers: dict[str, Layer]
    timings: dict[str, float] = field(default_factory=dict)
    #: per clip name: the static root folded away and the joint that became the root
    folded_roots: dict[str, dict[str, str]] = field(default_factory=dict)

    @property
    def clip_names(self) -> list[str]:
        return [c.name for c in self.config.clips]

    def clip_index(self, name: str) -> int:
        return self.clip_names.index(name)

    def clips_with(self, tag: str) -> list[int]:
        t = tag.upper()
        return [i for i, (c, tags) in enumerate(zip(self.clip_names, self.tags)) if t == c.upper() or t in tags]

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | os.PathLike[str]) -> None:
        arrays: dict[str, Any] = {}
        for i, c in enumerate(self.clips):
            arrays[f"clip{i}_root"] = c.root_translation
            arrays[f"clip{i}_rot"] = c.rotations
        layers = {}
        for name, ly in self.layers.items():
            arrays[f"{name}_similarity"] = ly.similarity
            arrays[f"{name}_path_cost"] = ly.path_cost
            arrays[f"{name}_predecessors"] = ly.predecessors
            layers[name] = {"joints": ly.joints, "parent": ly.parent, "threshold": ly.threshold, "sigma": ly.sigma,
                            "kept_clips": ly.kept_clips, "scc_nodes": ly.scc_nodes, "build_seconds": ly.build_seconds,
                            "transitions": [asdict(t) for t in ly.transitions], "report": ly.report}
        sk = self.skeleton
        meta = {"format": "bipedsim.MotionGraph/1", "config": config.to_dict(self.config), "tags": self.tags,
                "layers": layers, "timings": self.timings, "folded_roots": self.folded_roots,
                "skeleton": {"names": list(sk.names), "parents": sk.parents.tolist(), "offsets": sk.offsets.tolist(),
                             "channels": [list(c) for c in sk.channels],
                             "end_site_parents": sk.end_site_parents.tolist(),
                             "end_site_offsets": sk.end_site_offsets.tolist()}}
        buf = io.BytesIO()
        np.savez_compressed(buf, meta=np.array(json.dumps(meta)), **arrays)
        atomic_write_bytes(path, buf.getvalue())

# ---------------------------------------------------------------------- building
def load_graph_config(path: str | os.PathLike[str]) -> GraphConfig:
    return config.load(GraphConfig, path)


def load_clips(cfg: GraphConfig, base: Path, folded: dict[str, dict[str, str]] | None = None) -> list[Motion]:
    """The clips of ``cfg`` (files relative to ``base``) in the project frame at the graph's fps, a
    static root at the floor folded into the joint carrying the motion (recorded in ``folded``)."""
    clips = []
    total, limit = 0, max_graph_frames()
    for c in cfg.clips:
        p = Path(c.file)
        p = p if p.is_absolute() else (base / p)
        if not p.is_file():
            raise ConfigError(f"no such BVH file {p}", key=f"clips.{c.name}.file")
        m = _folded(c.name, load_bvh(p), folded)
        if c.mirror:
            m = m.mirrored()
        if c.speed != 1.0:
            if not c.speed > 0:
                raise ConfigError("speed must be > 0", key=f"clips.{c.name}.speed")
            m = m.copy(frame_time=m.frame_time / c.speed)
        # counted before resampling, which would allocate them
        span = min(m.duration, np.inf if c.end is None else c.end) - (c.start or 0.0)
        total += int(max(span, 0.0) * cfg.fps) + 1
        if total > limit:
            raise ConfigError(_too_many_frames(cfg, total, limit), key=f"clips.{c.name}")
        m = m.resample(cfg.fps)
        a = 0 if c.start is None else int(round(c.start * cfg.fps))
        b = m.num_frames if c.end is None else int(round(c.end * cfg.fps))
        m = m[a:b]
        if m.num_frames < 2 * cfg.k:
            raise ConfigError(f"clip has {m.num_frames} frames at {cfg.fps} fps; need at least 2k = {2 * cfg.k}",
                              key=f"clips.{c.name}")
        clips.append(m)
    ref = clips[0].skeleton
    for c, m in zip(cfg.clips, clips):
        if not m.skeleton.same_structure(ref):
            raise ConfigError("all clips must share one skeleton (same joints, same tree)", key=f"clips.{c.name}")
    return clips


def _too_many_frames(cfg: GraphConfig, total: int, limit: int) -> str:
    return (f"the clips up to this one hold {total} frames at {cfg.fps:g} fps; a graph holds at most {limit} "
            "(its distances take memory and time with the square of the frames): lower fps, cut clips with "
            "start/end, or set BIPEDSIM_MAX_GRAPH_FRAMES to allow more")


def _folded(name: str, m: Motion, folded: dict[str, dict[str, str]] | None) -> Motion:
    """``m`` with a static root folded away, recorded under the clip's ``name`` in ``folded``."""
    m, fold = fold_static_root(m)
    if fold is not None and folded is not None:
        folded[name] = {"root": fold.root, "into": fold.into}
    return m


def part_positions(m: Motion, joints: list[int], relative: bool) -> FloatArray:
    """(T, len(joints), 3) positions; with ``relative``, in the root's heading frame about the root."""
    pos = m.fk()[0][:, joints]
    if not relative:
        return pos
    root = m.root_translation
    yaw = m.heading()
    c, s = np.cos(-yaw), np.sin(-yaw)
    d = pos - root[:, None, :]
    out = np.empty_like(d)
    out[..., 0] = c[:, None] * d[..., 0] - s[:, None] * d[..., 1]
    out[..., 1] = s[:, None] * d[..., 0] + c[:, None] * d[..., 1]
    out[..., 2] = d[..., 2]
    return out


def summed_part_distance(g: MotionGraph, replaced: int, start: int, chosen: int, seconds: float,
                         joints: list[int]) -> float:
    """The method's check of a part-motion choice: the summed point-cloud distance, over consecutive
    k-frame windows for ``seconds``, between the replaced part motion (clip ``replaced`` from frame
    ``start``) and the chosen one (clip ``chosen``), both looped. The chosen motion enters at its frame
    best matching the replaced motion's first window, as the player's local search enters a motion at
    a transition point rather than at its first frame."""
    k, fps = g.config.k, g.config.fps
    n = int(seconds * fps)
    a = part_positions(g.clips[replaced], joints, True)
    b = part_positions(g.clips[chosen], joints, True)
    ia = (start + np.arange(n)) % len(a)
    first = distance_matrix(a[ia[:k]], np.concatenate([b, b[:k]]), k)[0, :len(b)]
    ib = (int(np.argmin(first)) + np.arange(n)) % len(b)
    return float(sum(distance_matrix(a[ia[s:s + k]], b[ib[s:s + k]], k)[0, 0] for s in range(0, n - k + 1, k)))


def _local_minima(d: FloatArray) -> npt.NDArray[np.bool_]:
    """Entries no greater than any of their 8 neighbours (the edges have fewer), compared in place --
    no padded copy of ``d``."""
    n, m = d.shape
    out = np.ones_like(d, dtype=bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                rows, cols = slice(max(0, -di), n - max(0, di)), slice(max(0, -dj), m - max(0, dj))
                nb = d[max(0, di):n - max(0, -di), max(0, dj):m - max(0, -dj)]
                out[rows, cols] &= d[rows, cols] <= nb
    return out


def _segment_min(d: FloatArray, s: int) -> FloatArray:
    """The minimum of each s x s segment of ``d`` (the last ones shorter where ``s`` does not divide)."""
    rows, cols = np.arange(0, d.shape[0], s), np.arange(0, d.shape[1], s)
    return np.minimum.reduceat(np.minimum.reduceat(d, rows, axis=0), cols, axis=1)


def build_layer(name: str, joints: list[int], parent: str | None, clips: list[Motion], cfg: GraphConfig,
                relative: bool) -> Layer:
    """One layer over ``joints`` (see the module docstring); its :attr:`Layer.report` says how the
    threshold was chosen and, per clip and tag, which frames were kept and dropped and why."""
    t0 = time.perf_counter()
    k = cfg.k
    pos = [part_positions(m, joints, relative) for m in clips]
    n = len(clips)
    dmats = {(a, b): distance_matrix(pos[a], pos[b], k) for a in range(n) for b in range(n)}
    cands: list[tuple[int, int, int, int, float]] = []
    for (a, b), d in dmats.items():
        mins = _local_minima(d)
        if a == b:  # no trivial self-transitions: clear the band |i - j| < k, a diagonal at a time
            for off in range(-(k - 1), k):
                np.fill_diagonal(mins[max(0, -off):, max(0, off):], False)
        # the blend runs k frames into the target and must leave room to go on
        mins[:, max(d.shape[1] - k, 0):] = False
        if len(cands) + int(mins.sum()) > MAX_CANDIDATES:
            raise BipedsimError(f"layer {name}: more than {MAX_CANDIDATES} candidate transitions (local minima of "
                                f"the distances; clips {cfg.clips[a].name} and {cfg.clips[b].name} alone give "
                                f"{int(mins.sum())}): the clips are too jittery to compare in windows of k = {k} "
                                "frames; raise k or smooth the clips")
        for i, j in zip(*np.nonzero(mins)):
            cands.append((a, int(i), b, int(j), float(d[i, j])))
    if not cands:
        raise BipedsimError(f"layer {name}: no candidate transitions between the clips")
    vals = np.array([c[4] for c in cands])
    sigma = cfg.sigma if cfg.sigma is not None else max(float(np.median(vals)), 1e-9)
    every = [Transition(a, i, b, j, dist, 1.0 - float(np.exp(-dist / sigma))) for a, i, b, j, dist in cands]
    names = [c.name for c in cfg.clips]
    choice = choose_threshold(name, every, names, labels_of(names, [list(c.tags) for c in cfg.clips]),
                              [m.num_frames for m in clips], k, cfg.threshold, cfg.threshold_quantile)
    trans, kept, n_nodes, thr = choice.kept, choice.kept_clips, choice.nodes, choice.threshold
    sim = np.zeros((n, n))
    for (a, b), d in dmats.items():
        sm = _segment_min(d, cfg.segment)
        sim[a, b] = float(sm.sum() / ((clips[a].num_frames / cfg.segment) * (clips[b].num_frames / cfg.segment)))
    w = np.full((n, n), np.inf)
    scale = max(float(np.max(sim[np.isfinite(sim)])), 1e-9)
    for t in trans:
        if t.src != t.dst:
            w[t.src, t.dst] = min(w[t.src, t.dst], t.cost + sim[t.src, t.dst] / scale)
    np.fill_diagonal(w, 0.0)
    graph = csr_matrix(np.where(np.isfinite(w), w + 1e-12, 0.0))
    cost, pred = floyd_warshall(graph, directed=True, return_predecessors=True)
    report = {"threshold": thr, "quantile": choice.quantile, "chosen": choice.how, "warnings": choice.warnings,
              "keeps_every_tag_from_quantile": choice.keeps_every_label_from, "candidates": len(every),
              **choice.report}
    return Layer(name=name, joints=joints, parent=parent, transitions=trans, similarity=sim, path_cost=cost,
                 predecessors=pred.astype(np.int64), threshold=thr, sigma=sigma, kept_clips=kept, scc_nodes=n_nodes,
                 build_seconds=time.perf_counter() - t0, report=report)


def build_graph(cfg: GraphConfig, base: Path, clips: list[Motion] | None = None) -> MotionGraph:
    """Every layer of the graph ``cfg`` describes, over its clips (loaded from files relative to
    ``base`` unless ``clips`` are given: project frame, the graph's fps, one skeleton)."""
    t0 = time.perf_counter()
    folded: dict[str, dict[str, str]] = {}
    if clips is None:
        clips = load_clips(cfg, base, folded)
    else:
        clips = [_folded(spec.name, m, folded) for spec, m in zip(cfg.clips, clips)]
        total = sum(m.num_frames for m in clips)
        if total > max_graph_frames():
            raise ConfigError(_too_many_frames(cfg, total, max_graph_frames()), key="clips")
    t_load = time.perf_counter() - t0
    sk = clips[0].skeleton
    layers: dict[str, Layer] = {FULL: build_layer(FULL, list(range(sk.num_joints)), None, clips, cfg, relative=False)}
    # parts: the nearest part above on the skeleton is the parent layer
    roots = {}
    for name, p in cfg.parts.items():
        if p.root not in sk.names:
            raise ConfigError(f"no joint {p.root!r}; joints are {', '.join(sk.names)}", key=f"parts.{name}.root")
        roots[name] = sk.index(p.root)
    depth = sk.depth()
    for name in sorted(roots, key=lambda n: depth[roots[n]]):
        j = roots[name]
        anc = set()
        a = j
        while a >= 0:
            anc.add(a)
            a = int(sk.parents[a])
        above = [n for n in roots if n != name and roots[n] in anc]
        parent = max(above, key=lambda n: depth[roots[n]]) if above else FULL
        layers[name] = build_layer(name, sk.subtree(j), parent, clips, cfg, relative=True)
    tags = [[t.upper() for t in c.tags] for c in cfg.clips]
    timings = {"load_s": t_load, "total_s": time.perf_counter() - t0,
               "frames": int(sum(m.num_frames for m in clips))}
    return MotionGraph(config=cfg, skeleton=sk, clips=clips, tags=tags, layers=layers, timings=timings,
                       folded_roots=folded)
