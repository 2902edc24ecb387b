"""Pruning a motion graph layer without dead ends, keeping what the user tagged, and saying what went.

The frame graph of a layer has two kinds of node per clip: *departures* (clip, f) where a transition's
blend starts (its source frame) and *arrivals* (clip, f + k) where a transition's k-frame blend into
frame f has ended and playing goes on. Edges run forward within a clip (each node to the next one in
the same clip) and along transitions (departure -> arrival). The player only ever stands on such a
node or between a node and the next one ahead, so keeping one strongly connected component (SCC) of
this graph means every frame play can reach has a way on: no dead ends, by construction.

Of the SCCs the one covering the most labels (tags, or the clip's name for an untagged clip) is kept,
then the largest. :func:`choose_threshold` raises the distance threshold, when the user left it to the
builder, until every label keeps frames; :func:`frames_report` lists per clip and label the frames
kept and dropped and why.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from bipedsim.errors import BipedsimError

#: The quantile of the candidate transitions' distances the threshold starts from when the YAML gives
#: neither ``threshold`` nor ``threshold_quantile``.
DEFAULT_QUANTILE = 0.25
#: How far the builder raises the quantile per try when a label would lose all its frames.
QUANTILE_STEP = 0.05


@dataclass
class Transition:
    src: int  #: clip index
    src_frame: int  #: first frame of the blend window in the source
    dst: int
    dst_frame: int
    distance: float
    cost: float


def prune(trans: list[Transition], lengths: list[int], k: int,
          labels: list[list[str]] | None = None) -> tuple[list[Transition], list[int], int]:
    """The transitions inside the kept strongly connected component of the frame graph (see the module
    docstring), the clips with frames in it, and its number of nodes. ``lengths``: frames per clip;
    ``k``: blend frames; ``labels``: per clip, its tags (the component covering most wins)."""
    nodes: dict[int, set[int]] = {c: set() for c in range(len(lengths))}
    for t in trans:
        nodes[t.src].add(t.src_frame)
        nodes[t.dst].add(t.dst_frame + k)
    index: dict[tuple[int, int], int] = {}
    for c in sorted(nodes):
        for f in sorted(nodes[c]):
            index[(c, f)] = len(index)
    n = len(index)
    if n == 0:
        return [], [], 0
    rows, cols = [], []
    for c in nodes:
        fs = sorted(nodes[c])
        for a, b in zip(fs, fs[1:]):  # playing forward within a clip
            rows.append(index[(c, a)])
            cols.append(index[(c, b)])
    for t in trans:
        rows.append(index[(t.src, t.src_frame)])
        cols.append(index[(t.dst, t.dst_frame + k)])
    g = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    n_comp, comp = connected_components(g, directed=True, connection="strong")
    clip_of = np.array([c for (c, _) in index])
    sizes = np.bincount(comp, minlength=n_comp)

    def score(label: int) -> tuple[int, int]:
        inside = set(clip_of[comp == label].tolist())
        covered = {x for c in inside for x in labels[c]} if labels else set()
        return len(covered), int(sizes[label])

    # only components with at least one transition inside can be played in a loop
    live = sorted({int(comp[index[(t.src, t.src_frame)]]) for t in trans
                   if comp[index[(t.src, t.src_frame)]] == comp[index[(t.dst, t.dst_frame + k)]]})
    if not live:
        return [], [], 0
    big = max(live, key=score)
    keep = [t for t in trans
            if comp[index[(t.src, t.src_frame)]] == big and comp[index[(t.dst, t.dst_frame + k)]] == big]
    clips = sorted({t.src for t in keep} | {t.dst for t in keep})
    return keep, clips, int(sizes[big])


def kept_span(trans: list[Transition], clip: int, length: int, k: int) -> tuple[int, int] | None:
    """Frames [a, b) of ``clip`` that play can pass through: from the first blend into it (or the first
    departure) to the end of the last blend out of it. None: none."""
    starts = [t.dst_frame for t in trans if t.dst == clip] + [t.src_frame for t in trans if t.src == clip]
    ends = [t.src_frame + k for t in trans if t.src == clip]
    if not starts or not ends:
        return None
    return min(starts), min(max(ends), length)


def labels_of(names: list[str], tags: list[list[str]]) -> list[list[str]]:
    """What a script may name each clip by: its tags, or its name when it has none (upper case)."""
    return [[t.upper() for t in ts] or [n.upper()] for n, ts in zip(names, tags)]


def frames_report(kept: list[Transition], candidates: list[Transition], thr: float, names: list[str],
                  labels: list[list[str]], lengths: list[int], k: int) -> dict[str, Any]:
    """Per clip: its frames, the span kept and the frames dropped with the reason; per label: frames
    kept and dropped over its clips."""
    clips: dict[str, Any] = {}
    for c, (name, n) in enumerate(zip(names, lengths)):
        span = kept_span(kept, c, n, k)
        dropped = []
        if span is None:
            near = [t.distance for t in candidates if c in (t.src, t.dst)]
            below = [t for t in candidates if c in (t.src, t.dst) and t.distance <= thr]
            if not below:
                why = (f"no transition at or below the threshold {thr:.4g} leads into or out of it"
                       + (f" (its closest candidate: {min(near):.4g})" if near else " (no candidate at all)"))
            else:
                why = (f"its {len(below)} transitions at or below the threshold {thr:.4g} do not lead back to the "
                       "strongly connected graph (it would be a dead end)")
            dropped.append({"from": 0, "to": n, "why": why})
        else:
            a, b = span
            if a > 0:
                dropped.append({"from": 0, "to": a, "why": "before the first transition into the clip"})
            if b < n:
                dropped.append({"from": b, "to": n, "why": "after the last transition out of the clip"})
        kept_n = 0 if span is None else span[1] - span[0]
        clips[name] = {"frames": n, "kept_frames": kept_n, "kept": None if span is None else list(span),
                       "dropped": dropped}
    tags: dict[str, Any] = {}
    for c, name in enumerate(names):
        for lab in labels[c]:
            e = tags.setdefault(lab, {"kept_frames": 0, "dropped_frames": 0, "clips": []})
            e["kept_frames"] += clips[name]["kept_frames"]
            e["dropped_frames"] += lengths[c] - clips[name]["kept_frames"]
            e["clips"].append(name)
    return {"clips": clips, "tags": tags}


def starved(report: dict[str, Any]) -> list[str]:
    """Labels that kept no frame."""
    return sorted(t for t, e in report["tags"].items() if e["kept_frames"] == 0)


def describe_loss(report: dict[str, Any], label: str) -> str:
    """Which clip frames a label lost and why, in one line."""
    e = report["tags"][label]
    parts = []
    for name in e["clips"]:
        for d in report["clips"][name]["dropped"]:
            parts.append(f"{name} frames {d['from']}-{d['to'] - 1} ({d['why']})")
    return "; ".join(parts)


@dataclass
class Choice:
    threshold: float
    quantile: float | None
    how: str  #: "given threshold", "given quantile", "default quantile", "raised from the default quantile"
    kept: list[Transition]
    kept_clips: list[int]
    nodes: int
    report: dict[str, Any]
    warnings: list[str]
    #: the smallest quantile (steps of QUANTILE_STEP) that keeps every label; None: none does
    keeps_every_label_from: float | None


def choose_threshold(layer: str, candidates: list[Transition], names: list[str], labels: list[list[str]],
                     lengths: list[int], k: int, threshold: float | None,
                     quantile: float | None) -> Choice:
    """Prune at the user's threshold (or quantile) or, when neither is given, at the smallest quantile
    from :data:`DEFAULT_QUANTILE` up that keeps frames of every label (warning when it had to rise).
    Raises :class:`BipedsimError` with the fix when no threshold keeps every label and the choice was
    the builder's."""
    vals = np.array([t.distance for t in candidates])

    def at(thr: float) -> tuple[list[Transition], list[int], int, dict[str, Any]]:
        keep, clips, n = prune([t for t in candidates if t.distance <= thr], lengths, k, labels)
        return keep, clips, n, frames_report(keep, candidates, thr, names, labels, lengths, k)

    def first_keeping_all(q: float) -> tuple[float, float] | None:
        while True:
            thr = float(np.quantile(vals, q))
            if not starved(at(thr)[3]):
                return q, thr
            if q >= 1.0:
                return None
            q = min(1.0, round(q + QUANTILE_STEP, 10))

    auto = threshold is None and quantile is None
    q = None if threshold is not None else (quantile if quantile is not None else DEFAULT_QUANTILE)
    thr = threshold if threshold is not None else float(np.quantile(vals, q))
    keep, clips, n, rep = at(thr)
    lost = starved(rep)
    found = first_keeping_all(q if q is not None else DEFAULT_QUANTILE) if lost else (q, thr)
    warnings: list[str] = []
    how = "given threshold" if threshold is not None else ("given quantile" if quantile is not None
                                                           else "default quantile")
    if lost and auto:
        if found is None:
            raise BipedsimError(
                f"layer {layer}: no threshold keeps every tag -- even with all {len(candidates)} candidate "
                f"transitions, {', '.join(repr(x) for x in lost)} lose every frame: "
                + "; ".join(describe_loss(rep, x) for x in lost)
                + f". Fix: add a clip that moves between these motions, lower k (now {k}: windows of k frames "
                "must match), or give that clip its own graph")
        q, thr = found
        keep, clips, n, rep = at(thr)
        warnings.append(f"layer {layer}: the default quantile {DEFAULT_QUANTILE} would drop every frame of "
                        f"{', '.join(lost)}; threshold raised to quantile {q:g} ({thr:.4g}) to keep every tag")
        how = "raised from the default quantile"
    elif lost:
        fix = (f"threshold_quantile: {found[0]:g} keeps every tag" if found is not None
               else "no threshold keeps every tag (add a clip that moves between these motions, or lower k)")
        warnings.append(f"layer {layer}: the {how.split()[1]} {thr if threshold is not None else q:g} drops every "
                        f"frame of {', '.join(lost)}: {'; '.join(describe_loss(rep, x) for x in lost)}. To keep "
                        f"them, remove threshold/threshold_quantile (the builder then chooses one that keeps "
                        f"every tag) or set {fix}")
    return Choice(threshold=thr, quantile=q, how=how, kept=keep, kept_clips=clips, nodes=n, report=rep,
                  warnings=warnings, keeps_every_label_from=None if found is None else found[0])
