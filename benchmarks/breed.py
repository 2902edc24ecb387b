"""Breeding time for parents the size of the method's published ones (151 frames x 48 joints and
121 frames x 36 joints), against the paper's reported times (crossover 0.016 s, mutation 0.016 s,
survivor 1.235 s). Target: the whole breeding under 0.1 s.

    python benchmarks/breed.py
"""

from __future__ import annotations

import sys
import time

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.motion import Motion, Skeleton
from bipedsim.synthesis.breed.evolve import breed

PAPER_S = {"crossover": 0.016, "mutation": 0.016, "survivor": 1.235}


def creature(joints: int, frames: int, seed: int, prefix: str) -> Motion:
    """A random tree (shared names for the first half, so the parents overlap) with sinusoid motion."""
    rng = np.random.default_rng(seed)
    names = ["Hips"] + [f"J{i}" if i < joints // 2 else f"{prefix}{i}" for i in range(1, joints)]
    parents = [-1] + [int(rng.integers(0, i)) if i > 1 else 0 for i in range(1, joints)]
    offsets = rng.normal(scale=0.15, size=(joints, 3))
    offsets[0] = 0
    sk = Skeleton(names=tuple(names), parents=np.array(parents), offsets=offsets,
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),)
                  + (("Zrotation", "Yrotation", "Xrotation"),) * (joints - 1),
                  end_site_parents=np.array([j for j in range(joints) if j not in parents]),
                  end_site_offsets=np.tile([0.0, 0.0, -0.1], (sum(j not in parents for j in range(joints)), 1)))
    t = np.arange(frames)[:, None, None] / 30.0
    rv = rng.uniform(0, 0.5, (1, joints, 3)) * np.sin(2 * np.pi * rng.uniform(0.5, 2, (1, joints, 3)) * t)
    q = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(frames, joints, 4)
    root = np.tile([0.0, 0.0, 1.5], (frames, 1))
    return Motion(skeleton=sk, frame_time=1 / 30, root_translation=root, rotations=q, up="z")


def main() -> int:
    a, b = creature(48, 151, 1, "A"), creature(36, 121, 2, "B")
    best: dict[str, float] = {}
    total = []
    for _ in range(5):
        t0 = time.perf_counter()
        _, rep = breed(a, b, x=0.5, mutations=5)
        total.append(time.perf_counter() - t0)
        for k, v in rep.timings_s.items():
            best[k] = min(best.get(k, 1e9), v)
    print(f"parents: {a.num_joints} joints x {a.num_frames} frames, {b.num_joints} joints x {b.num_frames} frames")
    for k in ("crossover", "mutation", "survivor", "constraint"):
        paper = PAPER_S.get(k)
        ratio = f"  paper {paper:.3f} s -> {paper / best[k]:.0f}x faster" if paper else ""
        print(f"{k:10s}: {best[k] * 1000:8.2f} ms{ratio}")
    print(f"whole breeding (best of 5): {min(total) * 1000:.1f} ms  (target < 100 ms; paper total "
          f"{sum(PAPER_S.values()):.3f} s -> {sum(PAPER_S.values()) / min(total):.0f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
