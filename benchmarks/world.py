"""Motion-tile worlds: synthesis speed, and transition quality of the P(n) = n^2/m^2 blend against a linear
cross-fade and a smoothstep, in one run.

Scenarios: the flying horse (bred for the example world from the shipped horse and pterosaur) on a long
straight strip with its mode forced to alternate walk / fly every 3 tiles (many transitions), and the
shared dog crossing the example ridge (walk, a jump, walk -> idle at the goal; skipped when the shared
data is absent). Per blend:

- synthesis speed: seconds of motion made per second of compute (path finding + synthesis);
- joint-acceleration jump: the largest summed joint angular acceleration (rad/s^2, root excluded) within
  two frames of a transition window, over the median outside the windows (1 = no jump);
- foot skating (m/s) of the feet near the ground inside the transition windows (ground-to-ground
  transitions), against the whole motion's.

    python benchmarks/world.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.synthesis.world import load_creature, load_world, parse_world
from bipedsim.synthesis.world.breeding import breed_world_files
from bipedsim.synthesis.world.creature_file import _foot_points
from bipedsim.synthesis.world.path import Path as TilePath
from bipedsim.synthesis.world.run import foot_skate
from bipedsim.synthesis.world.synth import Synthesis, synthesize

REPO = Path(__file__).resolve().parents[1]
WORLDS = REPO / "examples" / "worlds"
BLENDS = ("quadratic", "linear", "smoothstep")
#: Frames on either side of a transition window counted as the transition.
MARGIN = 2


def joint_acceleration(syn: Synthesis) -> np.ndarray:
    """(T,) summed angular acceleration (rad/s^2) of every non-root joint, local rotations."""
    m = syn.motion
    q = m.rotations[:, 1:]
    t, j = q.shape[:2]
    rel = Rotation.from_quat(q[:-1].reshape(-1, 4)).inv() * Rotation.from_quat(q[1:].reshape(-1, 4))
    w = rel.as_rotvec().reshape(t - 1, j, 3) / m.frame_time
    a = np.linalg.norm(np.diff(w, axis=0), axis=-1).sum(axis=1) / m.frame_time
    return np.concatenate([[a[0]], a, [a[-1]]])


def windows(syn: Synthesis) -> np.ndarray:
    mask = np.zeros(syn.motion.num_frames, bool)
    for tr in syn.transitions:
        mask[max(0, tr.frame - MARGIN):tr.frame + tr.m + 1 + MARGIN] = True
    return mask


def quality(syn: Synthesis, creature) -> dict[str, float]:  # noqa: ANN001
    acc = joint_acceleration(syn)
    win = windows(syn)
    base = float(np.median(acc[~win])) if (~win).any() else float(np.median(acc))
    _, idx = _foot_points(syn.motion, creature.feet)
    from bipedsim.synthesis.world.synth import body_points

    tips = body_points(syn.motion)[:, idx]
    ground = np.array([not lab.startswith("fly") and not lab.endswith("fly") for lab in syn.mode])
    dt = syn.motion.frame_time
    return {"acc_jump": float(acc[win].max() / base) if win.any() else float("nan"),
            "acc_excess": blend_excess(syn, acc),
            "skate_win": foot_skate(tips, 0.0, dt, win & ground) if (win & ground).any() else float("nan"),
            "skate_all": foot_skate(tips, 0.0, dt, ground), "transitions": len(syn.transitions)}


def _acc(q: np.ndarray, dt: float) -> np.ndarray:
    """(n,) summed angular acceleration (rad/s^2) of rotations (n, J, 4), padded at the ends."""
    n, j = q.shape[:2]
    rel = Rotation.from_quat(q[:-1].reshape(-1, 4)).inv() * Rotation.from_quat(q[1:].reshape(-1, 4))
    w = rel.as_rotvec().reshape(n - 1, j, 3) / dt
    a = np.linalg.norm(np.diff(w, axis=0), axis=-1).sum(axis=1) / dt
    return np.concatenate([[a[0]], a, [a[-1]]])


def blend_excess(syn: Synthesis, acc: np.ndarray) -> float:
    """Mean over transitions of the largest joint acceleration the blend adds (rad/s^2): the output's
    minus the P-weighted mix of the two time-warped intervals' own accelerations."""
    from bipedsim.synthesis.world.blend import WEIGHTS, warp_times

    clips = syn.clips
    out = []
    for t in syn.transitions:
        p = WEIGHTS[syn.blend](t.m)
        fi = np.array([clips[t.src].sample(x)[0] for x in warp_times(t.k_from, t.m_from, t.m)])[:, 1:]
        ti = np.array([clips[t.dst].sample(x)[0] for x in warp_times(t.k_to, t.m_to, t.m)])[:, 1:]
        dt = syn.motion.frame_time
        expect = p * _acc(fi, dt) + (1 - p) * _acc(ti, dt)
        got = acc[t.frame:t.frame + t.m + 1][1:-1]
        out.append(float(np.max(got - expect[1:len(got) + 1])))
    return float(np.mean(out)) if out else float("nan")


def timed(world, creature, path, modes, blend: str, reps: int = 3):  # noqa: ANN001, ANN201
    best, syn = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        syn = synthesize(world, creature, path, modes, weights=blend)
        best = min(best, time.perf_counter() - t0)
    return syn, best


def scenarios(tmp: Path) -> list[tuple[str, object, object, object, list[str]]]:
    out = []
    child = tmp / "child.yaml"
    breed_world_files(WORLDS / "horse.yaml", WORLDS / "pterosaur.yaml", WORLDS / "ridge.yaml", child)
    strip = parse_world({"tile": 2.0, "rows": ["S" + "." * 22 + "G"]}, "strip")
    tiles = [(0, c) for c in range(24)]
    modes = [("walk", "fly")[(c // 3) % 2] for c in range(24)]
    out.append(("flying horse, strip", strip, load_creature(child), TilePath(tiles, list(modes), 0.0), modes))
    dog_file = WORLDS / "dog.yaml"
    try:
        dog = load_creature(dog_file)
    except Exception as exc:  # the shared clip lives beside the repository
        print(f"dog scenario skipped: {exc}")
        return out
    from bipedsim.synthesis.world.path import find_path, path_modes

    ridge = load_world(WORLDS / "ridge.yaml")
    p = find_path(ridge, dog.travel_modes, dog.name)
    out.append(("dog, ridge", ridge, dog, p, path_modes(ridge, p, dog.travel_modes)))
    return out


def main() -> int:
    with tempfile.TemporaryDirectory(prefix="bipedsim-world-bench-") as tmp:
        rows = []
        for name, world, creature, path, modes in scenarios(Path(tmp)):
            for blend in BLENDS:
                syn, secs = timed(world, creature, path, modes, blend)
                q = quality(syn, creature)
                rows.append((name, blend, syn.motion.duration, secs, q))
    print(f"{'scenario':22s} {'blend':11s} {'motion s':>8s} {'compute s':>9s} {'x real time':>11s} "
          f"{'trans':>5s} {'acc jump':>8s} {'blend acc+':>10s} {'skate in win':>12s} {'skate all':>9s}")
    for name, blend, dur, secs, q in rows:
        print(f"{name:22s} {blend:11s} {dur:8.2f} {secs:9.3f} {dur / secs:11.1f} {q['transitions']:5d} "
              f"{q['acc_jump']:8.2f} {q['acc_excess']:10.0f} {q['skate_win']:12.3f} {q['skate_all']:9.3f}")
    print("\nratios against the linear cross-fade (same scenario):")
    for name in dict.fromkeys(r[0] for r in rows):
        base = next(r for r in rows if r[0] == name and r[1] == "linear")[4]
        for r in rows:
            if r[0] == name and r[1] != "linear":
                q = r[4]
                print(f"  {name:22s} {r[1]:11s} acc jump x{q['acc_jump'] / base['acc_jump']:.2f}, "
                      f"acc added by the blend x{q['acc_excess'] / base['acc_excess']:.2f}, "
                      f"skate in windows x{q['skate_win'] / base['skate_win']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
