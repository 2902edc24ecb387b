"""Motion graphs that keep what the user tagged and never dead-end, in one run against the baseline
of the earlier builder:

- dead ends: 2000 random candidate-transition sets pruned by the baseline rule (nodes at a
  transition's target frame, the largest strongly connected component) and by the current one
  (nodes where the k-frame blend ends, the component covering most tags): how many pruned graphs
  leave a frame play can arrive at with no way on;
- tags kept: the issue's graph (the shared CMU walk and wave re-rooted onto a static floor joint,
  walk + mirror + two gestures, two layers) at the fixed default quantile against the builder's
  choice: tags that keep frames.

    python benchmarks/graph_keep.py
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from bipedsim.motion import load_bvh, write_bvh
from bipedsim.motion.reroot import add_static_root
from bipedsim.synthesis.graph.build import ClipSpec, GraphConfig, PartSpec, build_graph
from bipedsim.synthesis.graph.prune import DEFAULT_QUANTILE, Transition, prune

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh" / "human"


def baseline_prune(trans: list[Transition], lengths: list[int]) -> list[Transition]:
    """The earlier rule: entry nodes at the target frame, the largest strongly connected component."""
    nodes: dict[int, set[int]] = {c: set() for c in range(len(lengths))}
    for t in trans:
        nodes[t.src].add(t.src_frame)
        nodes[t.dst].add(t.dst_frame)
    index = {(c, f): i for i, (c, f) in enumerate((c, f) for c in sorted(nodes) for f in sorted(nodes[c]))}
    if not index:
        return []
    rows, cols = [], []
    for c in nodes:
        fs = sorted(nodes[c])
        rows += [index[(c, a)] for a in fs[:-1]]
        cols += [index[(c, b)] for b in fs[1:]]
    rows += [index[(t.src, t.src_frame)] for t in trans]
    cols += [index[(t.dst, t.dst_frame)] for t in trans]
    _, lab = connected_components(csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(index),) * 2),
                                  directed=True, connection="strong")
    big = np.bincount(lab).argmax()
    return [t for t in trans if lab[index[(t.src, t.src_frame)]] == big == lab[index[(t.dst, t.dst_frame)]]]


def dead_end(keep: list[Transition], k: int) -> bool:
    return any(not any(u.src == t.dst and u.src_frame >= t.dst_frame + k for u in keep) for t in keep)


def random_set(rng: np.random.Generator, k: int) -> tuple[list[Transition], list[int]]:
    lengths = [int(rng.integers(3 * k, 12 * k)) for _ in range(int(rng.integers(1, 6)))]
    trans = []
    for _ in range(int(rng.integers(1, 40))):
        a, b = (int(x) for x in rng.integers(len(lengths), size=2))
        trans.append(Transition(a, int(rng.integers(0, lengths[a] - k + 1)), b,
                                int(rng.integers(0, lengths[b] - 2 * k + 1)), float(rng.uniform()), 0.0))
    return trans, lengths


def main() -> int:
    rng = np.random.default_rng(0)
    n, old, new = 2000, 0, 0
    for _ in range(n):
        k = int(rng.integers(2, 8))
        trans, lengths = random_set(rng, k)
        old += dead_end(baseline_prune(trans, lengths), k)
        new += dead_end(prune(trans, lengths, k)[0], k)
    print(f"random graphs with a reachable dead end after pruning: baseline {old}/{n}, now {new}/{n}")
    walk, wave = SHARED / "cmu_02_01_walk__holden31_crlf.bvh", SHARED / "cmu_141_16_wave_hello__holden31_crlf.bvh"
    if not walk.is_file():
        print(f"tags kept: skipped, shared BVH data not found at {SHARED}")
        return 0
    with tempfile.TemporaryDirectory() as d:
        for src, dst in ((walk, "walk.bvh"), (wave, "wave.bvh")):
            write_bvh(add_static_root(load_bvh(src)).with_up("y").scaled(100.0), Path(d) / dst, precision=6)
        clips = (ClipSpec("walk", "walk.bvh", ("WALK",)), ClipSpec("walk_mirror", "walk.bvh", ("WALK",), mirror=True),
                 ClipSpec("wave", "wave.bvh", ("WAVE_HAND",)), ClipSpec("call", "wave.bvh", ("CALL",), mirror=True))
        parts = {"Upper-Body": PartSpec(root="Spine1")}
        for label, q in (("fixed default quantile (baseline)", DEFAULT_QUANTILE), ("builder's choice", None)):
            g = build_graph(GraphConfig(name="keep", clips=clips, parts=parts, threshold_quantile=q), Path(d))
            kept = {name: sum(e["kept_frames"] > 0 for e in ly.report["tags"].values())
                    for name, ly in g.layers.items()}
            print(f"tags keeping frames, {label}: " + ", ".join(f"{n} {v}/3" for n, v in kept.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
