"""Motion-graph build time for about 3000 frames of clips (the method's database size), two layers
(full body + upper body), and the per-frame-pair cost, in one run. Reference: fairmotion's motion
graph needed about 53 s for a 266-frame clip on this kind of machine; target: under 30 s.

    python benchmarks/graph_build.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from bipedsim.synthesis.graph.build import ClipSpec, GraphConfig, PartSpec, build_graph

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh" / "human"


def main() -> int:
    walk, wave = SHARED / "cmu_02_01_walk__holden31_crlf.bvh", SHARED / "cmu_141_16_wave_hello__holden31_crlf.bvh"
    if not walk.is_file():
        print(f"skipped: shared BVH data not found at {SHARED}")
        return 0
    clips = []
    for name, f, tags in (("walk", walk, ("WALK",)), ("wave", wave, ("WAVE_HAND",))):
        for mirror in (False, True):
            for speed in (1.0, 0.75, 1.25):
                clips.append(ClipSpec(name=f"{name}{'_m' if mirror else ''}_{speed}", file=str(f), tags=tags,
                                      mirror=mirror, speed=speed))
    cfg = GraphConfig(name="bench", fps=120.0, k=20, clips=tuple(clips), parts={"Upper-Body": PartSpec(root="Spine1")})
    t0 = time.perf_counter()
    g = build_graph(cfg, Path("."))
    total = time.perf_counter() - t0
    frames = g.timings["frames"]
    windows = sum(c.num_frames - cfg.k + 1 for c in g.clips)
    pairs = windows ** 2
    print(f"clips: {len(clips)}, frames: {frames} at {cfg.fps:g} fps, window k = {cfg.k}, "
          f"joints {g.skeleton.num_joints}")
    for name, ly in g.layers.items():
        print(f"layer {name:11s}: {ly.build_seconds:6.2f} s, {len(ly.transitions)} transitions after pruning")
    print(f"total build (load + 2 layers): {total:.2f} s  (target < 30 s; fairmotion ~53 s for 266 frames)")
    print(f"per frame pair (both layers): {(total - g.timings['load_s']) / pairs * 1e9:.1f} ns over {pairs:,} pairs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
