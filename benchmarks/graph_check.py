"""The multi-layered motion graph method's check, reproduced, and transition time against the number of
layers -- both printed as tables.

1. Choosing a part motion by overall motion similarity: the upper body of a walk (the replaced part
   motion, from a random start) is replaced by a WAVE_HAND part motion, chosen either by the lowest
   overall motion similarity to the walk or at random among the candidates; we sum the point-cloud
   distance between the two part motions over 3, 10 and 20 s (20 runs each, for seeds 0-3). Both
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

from bipedsim.graph.build import FULL, ClipSpec, GraphConfig, PartSpec, build_graph, part_positions
from bipedsim.graph.distance import distance_matrix
from bipedsim.graph.player import Player
from bipedsim.graph.script import parse

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh" / "human"
WALK = SHARED / "cmu_02_01_walk__holden31_crlf.bvh"
WAVE = SHARED / "cmu_141_16_wave_hello__holden31_crlf.bvh"


def clips() -> tuple[ClipSpec, ...]:
    return (ClipSpec("walk", str(WALK), ("WALK",)), ClipSpec("walk_mirror", str(WALK), ("WALK",), mirror=True),
            ClipSpec("wave", str(WAVE), ("WAVE_HAND",)), ClipSpec("wave_left", str(WAVE), ("WAVE_HAND",), mirror=True),
            ClipSpec("wave_slow", str(WAVE), ("WAVE_HAND",), speed=0.8),
            ClipSpec("wave_left_fast", str(WAVE), ("WAVE_HAND",), mirror=True, speed=1.25))


def summed_distance(g, replaced: int, start: int, chosen: int, seconds: float, joints: list[int]) -> float:
    """Sum over consecutive k-frame windows of the part point-cloud distance between the two part
    motions, each looped, over ``seconds``."""
    k, fps = g.config.k, g.config.fps
    n = int(seconds * fps)
    a = part_positions(g.clips[replaced], joints, True)
    b = part_positions(g.clips[chosen], joints, True)
    # the chosen part motion enters where it best matches the replaced one's first window (the
    # player's local search enters a motion at a transition point, not at its first frame)
    ia = (start + np.arange(n)) % len(a)
    first = distance_matrix(a[ia[:k]], np.concatenate([b, b[:k]]), k)[0, :len(b)]
    ib = (int(np.argmin(first)) + np.arange(n)) % len(b)
    total = 0.0
    for s in range(0, n - k + 1, k):
        total += float(distance_matrix(a[ia[s:s + k]], b[ib[s:s + k]], k)[0, 0])
    return total


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
    print(f"   the replaced walk upper body; 20 runs per seed; similarity picks {g.clip_names[by_sim]!r})")
    print(f"   {'seed':>4s} | {'duration':>8s} | {'by similarity':>22s} | {'random choice':>22s} | lower with similarity")
    for seed in range(4):
        rng = np.random.default_rng(seed)
        for seconds in (3.0, 10.0, 20.0):
            sim_d, rnd_d = [], []
            for _ in range(20):
                start = int(rng.integers(g.clips[walk].num_frames))
                sim_d.append(summed_distance(g, walk, start, by_sim, seconds, ub.joints))
                rnd_d.append(summed_distance(g, walk, start, int(rng.choice(cands)), seconds, ub.joints))
            print(f"   {seed:4d} | {seconds:6.0f} s | {np.mean(sim_d):10.1f} +- {np.std(sim_d):8.1f} | "
                  f"{np.mean(rnd_d):10.1f} +- {np.std(rnd_d):8.1f} | "
                  f"{'yes' if np.mean(sim_d) < np.mean(rnd_d) else 'no'}")
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

        def timed(t, layer=FULL, _orig=orig):  # noqa: ANN001
            t1 = time.perf_counter()
            _orig(t, layer)
            times.append(time.perf_counter() - t1)

        pl._transition = timed  # type: ignore[method-assign]
        pl.run(parse(text, layers=tuple(g2.layers)))
        print(f"   {len(g2.layers):6d} | {t_build:7.2f} | {len(times):11d} | {np.mean(times) * 1000:17.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
