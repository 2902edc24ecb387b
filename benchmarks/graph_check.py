"""The multi-layered motion graph method's check, reproduced, and transition time against the number of
layers -- both printed as tables.

1. Choosing a part motion by overall motion similarity: the upper body of a walk (the replaced part
   motion, from a random start) is replaced by a WAVE_HAND part motion, chosen either by the lowest
   overall motion similarity to the walk or at random among the candidates (the random pick's exact
   expectation: the mean over all candidates from the same start); we sum the point-cloud distance
   between the two part motions over 3, 10 and 20 s (20 runs each, for seeds 0-3). Both
   choices enter the chosen motion at its frame best matching the walk's first window, as the player's
   local search would (entering at frame 0 made the 3 s comparison a matter of phase luck).
2. Transition time (ms per full-body transition, blend included) with 1, 2 and 3 layers.

    python benchmarks/graph_check.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from bipedsim.synthesis.graph.build import FULL, ClipSpec, GraphConfig, PartSpec, build_graph, summed_part_distance
from bipedsim.synthesis.graph.player import Player
from bipedsim.synthesis.graph.script import parse

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh" / "human"
WALK = SHARED / "cmu_02_01_walk__holden31_crlf.bvh"
WAVE = SHARED / "cmu_141_16_wave_hello__holden31_crlf.bvh"


def clips() -> tuple[ClipSpec, ...]:
    return (ClipSpec("walk", str(WALK), ("WALK",)), ClipSpec("walk_mirror", str(WALK), ("WALK",), mirror=True),
            ClipSpec("wave", str(WAVE), ("WAVE_HAND",)), ClipSpec("wave_left", str(WAVE), ("WAVE_HAND",), mirror=True),
            ClipSpec("wave_slow", str(WAVE), ("WAVE_HAND",), speed=0.8),
            ClipSpec("wave_left_fast", str(WAVE), ("WAVE_HAND",), mirror=True, speed=1.25))


def main() -> int:
    if not WALK.is_file():
        print(f"skipped: shared BVH data not found at {SHARED}")
        return 0
    cfg = GraphConfig(name="check", fps=30.0, k=10, threshold_quantile=0.35, clips=clips(),
                      parts={"Upper-Body": PartSpec(root="Spine1")})
    g = build_graph(cfg, Path("."))
    ub = g.layers["Upper-Body"]
    walk = g.clip_index("walk")
    cands = g.clips_with("WAVE_HAND")
    by_sim = min(cands, key=lambda c: ub.similarity[walk, c])
    print("1. Part motion chosen by overall motion similarity vs at random (summed point-cloud distance to")
    print(f"   the replaced walk upper body; 20 runs per seed; similarity picks {g.clip_names[by_sim]!r}).")
    print("   'random choice' is the exact expectation of a uniform random pick: the mean over every candidate")
    print("   from the same start frames (sampling one pick per run adds a 1-in-4 lottery to a 20-run mean).")
    print(f"   {'seed':>4s} | {'duration':>8s} | {'by similarity':>18s} | {'random choice':>18s} | "
          f"{'runs lower':>10s} | lower with similarity")
    per_cand: dict[float, list[np.ndarray]] = {}
    for seed in range(4):
        rng = np.random.default_rng(seed)
        for seconds in (3.0, 10.0, 20.0):
            runs = []
            for _ in range(20):
                start = int(rng.integers(g.clips[walk].num_frames))
                runs.append([summed_part_distance(g, walk, start, c, seconds, ub.joints) for c in cands])
            d = np.array(runs)  # runs x candidates
            sim_d = d[:, cands.index(by_sim)]
            rnd_d = d.mean(axis=1)
            per_cand.setdefault(seconds, []).append(d.mean(axis=0))
            print(f"   {seed:4d} | {seconds:6.0f} s | {sim_d.mean():8.1f} +- {sim_d.std():6.1f} | "
                  f"{rnd_d.mean():8.1f} +- {rnd_d.std():6.1f} | {int(np.sum(sim_d < rnd_d)):7d}/20 | "
                  f"{'yes' if sim_d.mean() < rnd_d.mean() else 'no'}")
    print("   per candidate (mean over seeds and runs), with its overall motion similarity to the walk:")
    for c_i, c in enumerate(cands):
        vals = "  ".join(f"{s:.0f} s {np.mean([m[c_i] for m in per_cand[s]]):6.1f}" for s in per_cand)
        print(f"     {g.clip_names[c]:16s} similarity {ub.similarity[walk, c]:6.2f} | {vals}")
    print()
    print("2. Transition time against the number of layers")
    print(f"   {'layers':>6s} | {'build s':>7s} | {'transitions':>11s} | {'ms per transition':>17s}")
    parts_sets = [{}, {"Upper-Body": PartSpec(root="Spine1")},
                  {"Upper-Body": PartSpec(root="Spine1"), "Right-Arm": PartSpec(root="RightArm")}]
    for parts in parts_sets:
        c2 = GraphConfig(name="layers", fps=30.0, k=10, threshold_quantile=0.35, clips=clips(), parts=parts)
        t0 = time.perf_counter()
        g2 = build_graph(c2, Path("."))
        t_build = time.perf_counter() - t0
        deepest = list(parts)[-1] if parts else None
        text = f"WALK with {deepest} WAVE_HAND for 20 sec" if deepest else "WALK for 20 sec"
        pl = Player(g2, start="walk")
        times = []
        orig = pl._transition

        def timed(t, layer=FULL, _orig=orig, _times=times):  # noqa: ANN001
            t1 = time.perf_counter()
            _orig(t, layer)
            _times.append(time.perf_counter() - t1)

        pl._transition = timed  # type: ignore[method-assign]
        pl.run(parse(text, layers=tuple(g2.layers)))
        print(f"   {len(g2.layers):6d} | {t_build:7.2f} | {len(times):11d} | {np.mean(times) * 1000:17.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
