"""Multi-layered motion graphs: clips, transitions, pruning, layers, similarity, shortest paths.

A *layer* is a motion graph over a set of joints: the full body, or a body part (a joint subtree from
the YAML, e.g. the upper body). A part layer is the child of the nearest layer above it on the
skeleton. For every layer:

- distance matrices between all clip pairs (windows of k frames, :mod:`bipedsim.graph.distance`);
- transitions: local minima below the threshold, cost t = 1 - exp(-D / sigma), played as a linear
  blend over k frames (at playback, not stored);
- pruning: the graph whose nodes are each clip's departure frames (where a blend starts) and arrival
  frames (where a blend has ended: the target frame + k, where playing goes on) -- edges forward in the
  clip and the transitions -- keeps one strongly connected component (``scipy.sparse.csgraph``; the
  one covering most tags): every arrival then has a departure ahead in its clip, so play never
  reaches a dead end (:mod:`bipedsim.graph.prune`);
- the threshold: ``threshold`` if given, else the ``threshold_quantile`` of the candidates' distances;
  with neither given the builder starts at :data:`bipedsim.graph.prune.DEFAULT_QUANTILE` and raises
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
import time
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import floyd_warshall

from bipedsim import config
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.graph.distance import distance_matrix
from bipedsim.graph.prune import Transition, choose_threshold, labels_of
from bipedsim.motion.motion import Motion
from bipedsim.motion.reroot import fold_static_root
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]
FULL = "Full-Body"


@dataclass(frozen=True)
class ClipSpec:
    name: str
    file: str
    tags: tuple[str, ...] = ()
    mirror: bool = False
    start: float | None = None  #: s
    end: float | None = None  #: s
    speed: float = 1.0  #: playback rate of the source (a derived slower or faster clip)


@dataclass(frozen=True)
class PartSpec:
    root: str  #: the part is this joint's subtree
    weight: float = 1.0


@dataclass(frozen=True)
class GraphConfig:
    name: str = "graph"
    fps: float = field(default=30.0, metadata={"gt": 0.0})
    k: int = field(default=20, metadata={"min": 2})
    #: None: start at DEFAULT_QUANTILE and raise it until every tag keeps frames (with a warning)
    threshold_quantile: float | None = field(default=None, metadata={"gt": 0.0, "max": 1.0})
    threshold: float | None = field(default=None, metadata={"gt": 0.0})
    sigma: float | None = field(default=None, metadata={"gt": 0.0})
    segment: int = field(default=10, metadata={"min": 1})
    clips: tuple[ClipSpec, ...] = ()
    parts: dict[str, PartSpec] = field(default_factory=dict)

    def validate(self) -> None:
        if not self.clips:
            raise ValueError("clips: give at least one clip")
        names = [c.name for c in self.clips]
        if len(set(names)) != len(names):
            raise ValueError("clips: clip names must be unique")
        if FULL in self.parts:
            raise ValueError(f"parts: {FULL!r} is the whole body's layer; name parts otherwise")


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

    def exits(self, clip: int) -> list[Transition]:
        return sorted((t for t in self.transitions if t.src == clip), key=lambda t: t.src_frame)

    def path(self, a: int, b: int) -> list[int]:
        """Clips on the cheapest route from motion a to motion b (a and b included)."""
        if a == b:
            return [a]
        if not np.isfinite(self.path_cost[a, b]):
            return []
        out = [b]
        while out[-1] != a:
            out.append(int(self.predecessors[a, out[-1]]))
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
        from bipedsim.io import atomic_write_bytes

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

    @staticmethod
    def load(path: str | os.PathLike[str]) -> MotionGraph:
        if not Path(path).is_file():
            raise BipedsimError(f"{path}: no such motion graph file (make one with `bipedsim graph build "
                                "GRAPH.yaml -o GRAPH.npz`)")
        try:
            if not zipfile.is_zipfile(path):
                raise ValueError("not an .npz archive")
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                if meta.get("format") != "bipedsim.MotionGraph/1":
                    raise ValueError("not a motion graph")
                cfg = config.from_dict(GraphConfig, meta["config"])
                s = meta["skeleton"]
                sk = Skeleton(names=tuple(s["names"]), parents=np.array(s["parents"]), offsets=np.array(s["offsets"]),
                              channels=tuple(tuple(c) for c in s["channels"]),
                              end_site_parents=np.array(s["end_site_parents"], dtype=np.int64),
                              end_site_offsets=np.array(s["end_site_offsets"]).reshape(-1, 3))
                clips = [Motion(skeleton=sk, frame_time=1.0 / cfg.fps, root_translation=z[f"clip{i}_root"],
                                rotations=z[f"clip{i}_rot"], unit=1.0, up="z") for i in range(len(cfg.clips))]
                layers = {}
                for name, d in meta["layers"].items():
                    layers[name] = Layer(name=name, joints=d["joints"], parent=d["parent"],
                                         transitions=[Transition(**t) for t in d["transitions"]],
                                         similarity=z[f"{name}_similarity"], path_cost=z[f"{name}_path_cost"],
                                         predecessors=z[f"{name}_predecessors"], threshold=d["threshold"],
                                         sigma=d["sigma"], kept_clips=d["kept_clips"], scc_nodes=d["scc_nodes"],
                                         build_seconds=d.get("build_seconds", 0.0), report=d.get("report", {}))
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            why = "it holds Python objects" if "allow_pickle" in str(exc) else str(exc)
            raise BipedsimError(f"{path}: not a bipedsim motion graph ({why}); graph files are written by "
                                "`bipedsim graph build GRAPH.yaml -o GRAPH.npz`") from None
        return MotionGraph(config=cfg, skeleton=sk, clips=clips, tags=meta["tags"], layers=layers,
                           timings=meta.get("timings", {}), folded_roots=meta.get("folded_roots", {}))


# ---------------------------------------------------------------------- building
def load_graph_config(path: str | os.PathLike[str]) -> GraphConfig:
    return config.load(GraphConfig, path)


def load_clips(cfg: GraphConfig, base: Path, folded: dict[str, dict[str, str]] | None = None) -> list[Motion]:
    """The clips of ``cfg`` (files relative to ``base``) in the project frame at the graph's fps, a
    static root at the floor folded into the joint carrying the motion (recorded in ``folded``)."""
    from bipedsim.motion.bvh import load_bvh

    clips = []
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
    pad = np.pad(d, 1, constant_values=np.inf)
    core = pad[1:-1, 1:-1]
    m = np.ones_like(d, dtype=bool)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                m &= core <= pad[1 + di:pad.shape[0] - 1 + di, 1 + dj:pad.shape[1] - 1 + dj]
    return m


def _segment_min(d: FloatArray, s: int) -> FloatArray:
    na, nb = int(np.ceil(d.shape[0] / s)), int(np.ceil(d.shape[1] / s))
    padded = np.full((na * s, nb * s), np.inf)
    padded[:d.shape[0], :d.shape[1]] = d
    return padded.reshape(na, s, nb, s).min(axis=(1, 3))


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
        if a == b:  # no trivial self-transitions
            ii, jj = np.indices(d.shape)
            mins &= np.abs(ii - jj) >= k
        # the blend runs k frames into the target and must leave room to go on
        mins[:, max(d.shape[1] - k, 0):] = False
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
