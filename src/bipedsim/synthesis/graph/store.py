"""Reading a motion graph file (``.npz`` from ``bipedsim graph build``) without trusting it.

A graph file may come from anyone, so every part is checked before it is used: the archive holds only
``.npy`` arrays of numbers (no Python objects), each array's declared dtype and shape are read from its
header and compared with what the graph's description says before its data is read (so no declared size
can make the reader allocate more than a graph this project builds), every number is finite (a path
cost may be infinite: no route) and within range, rotations are unit quaternions, and every index --
joints, clips, frames, layers, predecessors -- points inside what it indexes. A file that fails any
check is refused with one line naming the file and the part.
"""

from __future__ import annotations

import json
import math
import os
import zipfile
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim import config
from bipedsim.errors import BipedsimError, InputError
from bipedsim.files import check_input_file
from bipedsim.motion.motion import Motion
from bipedsim.motion.skeleton import Skeleton
from bipedsim.synthesis.graph.build import (
    FULL,
    MAX_CANDIDATES,
    MAX_COORD_M,
    UNIT_QUAT_TOL,
    GraphConfig,
    Layer,
    MotionGraph,
    max_graph_frames,
)
from bipedsim.synthesis.graph.prune import Transition

FORMAT = "bipedsim.MotionGraph/1"
#: Longest description (JSON characters) a graph file may hold: a graph of 100 clips describes itself in
#: well under a megabyte.
MAX_META_CHARS = 16 * 2**20
#: Most joints a graph's skeleton may have (motion capture skeletons have 20-100).
MAX_GRAPH_JOINTS = 1000
#: Most End Sites (one per chain end, each joint at most one in practice).
MAX_END_SITES = 1000
#: Predecessor value scipy's Floyd-Warshall writes where there is no route.
NO_PREDECESSOR = -9999
#: The dtypes an array in a graph file may have.
FLOAT_KINDS = ("f",)
INT_KINDS = ("i",)

HOW_TO_MAKE = "graph files are written by `bipedsim graph build GRAPH.yaml -o GRAPH.npz`"


class GraphFileError(BipedsimError):
    """A file that is not a usable motion graph: names the file and the part that is wrong."""

    def __init__(self, path: str | os.PathLike[str], why: str) -> None:
        self.path, self.reason = str(path), why
        super().__init__(f"{path}: not a bipedsim motion graph ({why}); {HOW_TO_MAKE}")


def _need(ok: bool, why: str) -> None:
    if not ok:
        raise ValueError(why)


def _int(v: Any, what: str, lo: int = 0, hi: int | None = None) -> int:
    _need(isinstance(v, int) and not isinstance(v, bool), f"{what} is not a whole number")
    _need(v >= lo and (hi is None or v < hi), f"{what} = {v} is out of range")
    return int(v)


def _num(v: Any, what: str, allow_none: bool = False) -> float | None:
    if v is None and allow_none:
        return None
    _need(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v),
          f"{what} is not a finite number")
    return float(v)


def _str_list(v: Any, what: str) -> list[str]:
    _need(isinstance(v, list) and all(isinstance(x, str) for x in v), f"{what} is not a list of names")
    return list(v)


# ---------------------------------------------------------------------- the archive
def _headers(zf: zipfile.ZipFile) -> dict[str, tuple[tuple[int, ...], np.dtype[Any]]]:
    """Each member's array name, declared shape and dtype, from the ``.npy`` headers alone."""
    out = {}
    for info in zf.infolist():
        name = info.filename
        _need(name.endswith(".npy"), f"member {name!r} is not an array")
        with zf.open(info) as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, _, dtype = np.lib.format.read_array_header_2_0(f)
            else:
                raise ValueError(f"array {name!r} has an unknown .npy version {version}")
        _need(not dtype.hasobject, f"array {name[:-4]!r} holds Python objects")
        out[name[:-4]] = (tuple(int(n) for n in shape), dtype)
    return out


def _array(z: Any, heads: dict[str, tuple[tuple[int, ...], np.dtype[Any]]], name: str,
           shape: tuple[int, ...], kinds: tuple[str, ...]) -> npt.NDArray[Any]:
    """Array ``name`` once its header says it has ``shape`` and a dtype of ``kinds``: read, as float64
    or int64."""
    _need(name in heads, f"array {name!r} is missing")
    got, dtype = heads[name]
    _need(dtype.kind in kinds and dtype.itemsize <= 8, f"array {name!r} has dtype {dtype}, expected "
          + ("numbers" if kinds == FLOAT_KINDS else "integers"))
    _need(got == shape, f"array {name!r} has shape {got}, expected {shape}")
    a = np.asarray(z[name])
    return a.astype(np.float64 if kinds == FLOAT_KINDS else np.int64, copy=False)


def _finite(a: npt.NDArray[Any], name: str, bound: float | None = None) -> None:
    _need(bool(np.all(np.isfinite(a))), f"array {name!r} holds NaN or infinite values")
    if bound is not None and a.size:
        _need(float(np.abs(a).max()) <= bound, f"array {name!r} holds values beyond {bound:g}")


# ---------------------------------------------------------------------- the description
def _skeleton(s: Any) -> Skeleton:
    _need(isinstance(s, dict), "its skeleton is not a mapping")
    names = _str_list(s.get("names"), "skeleton names")
    _need(all(n.isprintable() for n in names), "a skeleton name holds control characters")
    _need(0 < len(names) <= MAX_GRAPH_JOINTS, f"its skeleton has {len(names)} joints (at most {MAX_GRAPH_JOINTS})")
    n = len(names)
    parents = [_int(p, "a skeleton parent", -1, n) for p in s.get("parents") or []]
    offsets = np.array(s.get("offsets"), dtype=np.float64)
    _need(offsets.shape == (n, 3), "skeleton offsets have the wrong shape")
    _finite(offsets, "skeleton offsets", MAX_COORD_M)
    channels = s.get("channels")
    _need(isinstance(channels, list) and len(channels) == n, "skeleton channels have the wrong length")
    channels = [tuple(_str_list(c, "skeleton channels")) for c in channels]
    es_par = s.get("end_site_parents") or []
    _need(isinstance(es_par, list) and len(es_par) <= MAX_END_SITES, "too many End Sites")
    es_par = [_int(p, "an End Site parent", 0, n) for p in es_par]
    es_off = np.array(s.get("end_site_offsets") or [], dtype=np.float64).reshape(-1, 3)
    _need(len(es_off) == len(es_par), "End Site offsets and parents disagree in length")
    _finite(es_off, "End Site offsets", MAX_COORD_M)
    return Skeleton(names=tuple(names), parents=np.array(parents, dtype=np.int64), offsets=offsets,
                    channels=tuple(channels), end_site_parents=np.array(es_par, dtype=np.int64),
                    end_site_offsets=es_off)


def _report(rep: Any, clip_names: list[str], layer: str) -> dict[str, Any]:
    """A layer's build report, checked where the player reads it (lost-tag messages)."""
    what = f"layer {layer!r} report"
    if rep is None:
        return {}
    _need(isinstance(rep, dict), f"{what} is not a mapping")
    _num(rep.get("keeps_every_tag_from_quantile"), f"{what} quantile", allow_none=True)
    _need(isinstance(rep.get("chosen", ""), str), f"{what} 'chosen' is not text")
    clips = rep.get("clips", {})
    _need(isinstance(clips, dict), f"{what} clips are not a mapping")
    for name, e in clips.items():
        _need(isinstance(e, dict) and isinstance(e.get("dropped", []), list), f"{what} clip {name!r} is malformed")
        for d in e.get("dropped", []):
            _need(isinstance(d, dict) and isinstance(d.get("why"), str), f"{what} clip {name!r} is malformed")
            _int(d.get("from"), f"{what} frame")
            _int(d.get("to"), f"{what} frame")
    tags = rep.get("tags", {})
    _need(isinstance(tags, dict), f"{what} tags are not a mapping")
    for tag, e in tags.items():
        _need(isinstance(e, dict), f"{what} tag {tag!r} is malformed")
        _int(e.get("kept_frames"), f"{what} kept frames")
        _int(e.get("dropped_frames"), f"{what} dropped frames")
        for c in _str_list(e.get("clips"), f"{what} tag clips"):
            _need(c in clips and c in clip_names, f"{what} tag {tag!r} names an unknown clip {c!r}")
    return rep


def _config(raw: Any) -> Any:
    _need(isinstance(raw, dict), "its config is not a mapping")
    if raw.get("threshold") is not None and raw.get("threshold_quantile") is not None:
        raw = {**raw, "threshold_quantile": None}  # built before both were refused: the threshold won
    try:
        return config.from_dict(GraphConfig, raw)
    except BipedsimError as exc:
        raise ValueError(f"its config: {exc}") from None


# ---------------------------------------------------------------------- the graph
def read_graph(path: str | os.PathLike[str]) -> MotionGraph:
    """The :class:`~bipedsim.synthesis.graph.build.MotionGraph` in the file ``path``, every part checked (see the
    module docstring). Raises :class:`GraphFileError` naming the file and what is wrong."""
    try:
        check_input_file(path, "npz")
    except InputError as exc:
        if exc.reason == "no such file":
            raise BipedsimError(f"{path}: no such motion graph file (make one with `bipedsim graph build "
                                "GRAPH.yaml -o GRAPH.npz`)") from None
        raise GraphFileError(path, exc.reason) from None
    try:
        if not zipfile.is_zipfile(path):
            raise ValueError("not an .npz archive")
        with zipfile.ZipFile(path) as zf:
            heads = _headers(zf)
        _need("meta" in heads, "it has no description")
        shape, dtype = heads["meta"]
        _need(shape == () and dtype.kind == "U" and dtype.itemsize // 4 <= MAX_META_CHARS,
              f"its description is not one text of at most {MAX_META_CHARS} characters")
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            _need(isinstance(meta, dict) and meta.get("format") == FORMAT, "not a motion graph")
            cfg = _config(meta.get("config"))
            sk = _skeleton(meta.get("skeleton"))
            names = [c.name for c in cfg.clips]
            n_clips, n_joints, k = len(names), sk.num_joints, cfg.k
            tags = meta.get("tags")
            _need(isinstance(tags, list) and len(tags) == n_clips, "its tags do not match its clips")
            tags = [_str_list(t, "tags") for t in tags]
            lengths = []
            for i in range(n_clips):
                rk = f"clip{i}_root"
                _need(rk in heads and len(heads[rk][0]) == 2, f"array {rk!r} is missing or not (frames, 3)")
                t = heads[rk][0][0]
                _need(t >= 2 * k, f"clip {names[i]!r} has {t} frames, fewer than 2k = {2 * k}")
                lengths.append(t)
                _need(sum(lengths) <= max_graph_frames(),
                      f"its clips hold more than {max_graph_frames()} frames (BIPEDSIM_MAX_GRAPH_FRAMES)")
            clips = []
            for i, t in enumerate(lengths):
                root = _array(z, heads, f"clip{i}_root", (t, 3), FLOAT_KINDS)
                _finite(root, f"clip{i}_root", MAX_COORD_M)
                rot = _array(z, heads, f"clip{i}_rot", (t, n_joints, 4), FLOAT_KINDS)
                _finite(rot, f"clip{i}_rot")
                _need(bool(np.all(np.abs(np.linalg.norm(rot, axis=-1) - 1.0) <= UNIT_QUAT_TOL)),
                      f"array 'clip{i}_rot' holds rotations that are not unit quaternions")
                clips.append(Motion(skeleton=sk, frame_time=1.0 / cfg.fps, root_translation=root, rotations=rot,
                                    unit=1.0, up="z"))
            raw_layers = meta.get("layers")
            _need(isinstance(raw_layers, dict) and FULL in raw_layers, f"it has no {FULL} layer")
            _need(len(raw_layers) <= 1 + len(cfg.parts) and all(n == FULL or n in cfg.parts for n in raw_layers),
                  "its layers do not match its parts")
            layers = {}
            for name, d in raw_layers.items():
                what = f"layer {name!r}"
                _need(isinstance(d, dict), f"{what} is not a mapping")
                joints = [_int(j, f"{what} joint", 0, n_joints) for j in (d.get("joints") or [])]
                _need(joints and len(set(joints)) == len(joints), f"{what} joints are empty or repeated")
                parent = d.get("parent")
                _need((parent is None) == (name == FULL) and (parent is None or parent in raw_layers),
                      f"{what} parent {parent!r} is not a layer")
                raw_t = d.get("transitions")
                _need(isinstance(raw_t, list), f"{what} transitions are not a list")
                _need(len(raw_t) <= MAX_CANDIDATES, f"{what} has more than {MAX_CANDIDATES} transitions")
                trans = []
                for t in raw_t:
                    _need(isinstance(t, dict) and set(t) == {"src", "src_frame", "dst", "dst_frame", "distance",
                                                             "cost"}, f"{what} transition is malformed")
                    src = _int(t["src"], f"{what} transition clip", 0, n_clips)
                    dst = _int(t["dst"], f"{what} transition clip", 0, n_clips)
                    trans.append(Transition(src=src, src_frame=_int(t["src_frame"], f"{what} transition frame", 0,
                                                                    lengths[src] - k + 1),
                                            dst=dst, dst_frame=_int(t["dst_frame"], f"{what} transition frame", 0,
                                                                    lengths[dst] - k + 1),
                                            distance=_num(t["distance"], f"{what} distance"),  # type: ignore[arg-type]
                                            cost=_num(t["cost"], f"{what} cost")))  # type: ignore[arg-type]
                kept = [_int(c, f"{what} kept clip", 0, n_clips) for c in (d.get("kept_clips") or [])]
                cc = (n_clips, n_clips)
                sim = _array(z, heads, f"{name}_similarity", cc, FLOAT_KINDS)
                _finite(sim, f"{name}_similarity")
                cost = _array(z, heads, f"{name}_path_cost", cc, FLOAT_KINDS)
                _need(not np.any(np.isnan(cost)) and not np.any(cost < 0), f"array '{name}_path_cost' holds NaN "
                      "or negative costs")
                pred = _array(z, heads, f"{name}_predecessors", cc, INT_KINDS)
                _need(bool(np.all((pred == NO_PREDECESSOR) | ((pred >= 0) & (pred < n_clips)))),
                      f"array '{name}_predecessors' points outside the clips")
                layers[name] = Layer(name=name, joints=joints, parent=parent, transitions=trans, similarity=sim,
                                     path_cost=cost, predecessors=pred,
                                     threshold=_num(d.get("threshold"), f"{what} threshold"),  # type: ignore[arg-type]
                                     sigma=_num(d.get("sigma"), f"{what} sigma"),  # type: ignore[arg-type]
                                     kept_clips=kept, scc_nodes=_int(d.get("scc_nodes"), f"{what} nodes"),
                                     build_seconds=_num(d.get("build_seconds", 0.0), f"{what} build time") or 0.0,
                                     report=_report(d.get("report"), names, name))
            timings, folded = meta.get("timings", {}), meta.get("folded_roots", {})
            _need(isinstance(timings, dict) and isinstance(folded, dict), "its timings are malformed")
    except (OSError, KeyError, ValueError, TypeError, EOFError, RecursionError, MemoryError,
            zipfile.BadZipFile) as exc:
        why = "it holds Python objects" if "allow_pickle" in str(exc) else str(exc) or type(exc).__name__
        raise GraphFileError(path, why) from None
    except BipedsimError as exc:  # a skeleton the model cannot hold
        raise GraphFileError(path, str(exc)) from None
    return MotionGraph(config=cfg, skeleton=sk, clips=clips, tags=tags, layers=layers, timings=timings,
                       folded_roots=folded)

