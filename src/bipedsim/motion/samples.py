"""Sample creatures the project makes itself: a horse-like quadruped walk and a pterosaur-like
flapping flight (plus the built-in human walk), so breeding works on a fresh machine.

Both use shared joint names where the bodies correspond (Hips, Spine, Chest, Neck, Head, Tail1,
Left/RightUpLeg, Left/RightLeg, Left/RightFoot) so they cross over by name. Frame: metres, Z up,
moving along +X.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.data import HORSE_WALK, PTEROSAUR_FLIGHT, SHIPPED_BVH_PRECISION
from bipedsim.motion.bvh_write import bvh_text
from bipedsim.motion.gaitgen import walk_bvh_motion
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.skeleton import Skeleton

ROOT_CH = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")
ROT_CH = ("Zrotation", "Yrotation", "Xrotation")


def _skeleton(joints: list[tuple[str, str | None, tuple[float, float, float]]],
              ends: list[tuple[str, tuple[float, float, float]]]) -> Skeleton:
    names = tuple(n for n, _, _ in joints)
    return Skeleton(names=names, parents=np.array([-1 if p is None else names.index(p) for _, p, _ in joints]),
                    offsets=np.array([o for _, _, o in joints], dtype=float),
                    channels=tuple(ROOT_CH if p is None else ROT_CH for _, p, _ in joints),
                    end_site_parents=np.array([names.index(n) for n, _ in ends]),
                    end_site_offsets=np.array([o for _, o in ends], dtype=float))


def _rot(axis: str, ang: np.ndarray) -> np.ndarray:
    return Rotation.from_euler(axis, np.asarray(ang)[:, None]).as_quat()


def horse_skeleton() -> Skeleton:
    j = [("Hips", None, (0.0, 0.0, 0.0)), ("Spine", "Hips", (0.35, 0.0, 0.02)), ("Chest", "Spine", (0.35, 0.0, 0.02)),
         ("Neck", "Chest", (0.25, 0.0, 0.20)), ("Neck2", "Neck", (0.20, 0.0, 0.22)),
         ("Head", "Neck2", (0.10, 0.0, 0.05)),
         ("Tail1", "Hips", (-0.15, 0.0, 0.02)), ("Tail2", "Tail1", (-0.20, 0.0, -0.10))]
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        j += [(f"{side}UpLeg", "Hips", (-0.05, s * 0.15, -0.10)), (f"{side}Leg", f"{side}UpLeg", (0.05, 0.0, -0.40)),
              (f"{side}Foot", f"{side}Leg", (-0.05, 0.0, -0.40)),
              (f"{side}Arm", "Chest", (0.15, s * 0.15, -0.15)), (f"{side}ForeArm", f"{side}Arm", (0.0, 0.0, -0.40)),
              (f"{side}Hand", f"{side}ForeArm", (0.0, 0.0, -0.37))]
    ends = [("Head", (0.40, 0.0, -0.15)), ("Tail2", (-0.25, 0.0, -0.25)), ("LeftFoot", (0.06, 0.0, -0.08)),
            ("RightFoot", (0.06, 0.0, -0.08)), ("LeftHand", (0.06, 0.0, -0.08)), ("RightHand", (0.06, 0.0, -0.08))]
    return _skeleton(j, ends)


def horse_walk(cycles: int = 3, frames_per_cycle: int = 60, speed: float = 1.4) -> Motion:
    """A four-beat walk: legs swing in the order left hind, left fore, right hind, right fore."""
    sk = horse_skeleton()
    cycle_s = 1.1
    n = cycles * frames_per_cycle + 1
    dt = cycle_s / frames_per_cycle
    t = np.arange(n) * dt
    ph = 2 * np.pi * t / cycle_s
    q = np.tile([0.0, 0.0, 0.0, 1.0], (n, sk.num_joints, 1))
    idx = {name: i for i, name in enumerate(sk.names)}
    offsets = {"LeftUpLeg": 0.0, "LeftArm": 0.25, "RightUpLeg": 0.5, "RightArm": 0.75}
    for hip, off in offsets.items():
        side = hip[:-5] if hip.endswith("UpLeg") else hip[:-3]
        p = ph - 2 * np.pi * off
        swing = 0.35 * np.sin(p)  # +: leg forward = negative rotation about y
        lift = np.maximum(np.sin(p + np.pi / 2), 0.0) ** 2  # flex during the forward swing
        q[:, idx[hip]] = _rot("y", -swing)
        if hip.endswith("UpLeg"):
            q[:, idx[f"{side}Leg"]] = _rot("y", -0.5 * lift)
            q[:, idx[f"{side}Foot"]] = _rot("y", 0.4 * lift)
        else:
            q[:, idx[f"{side}ForeArm"]] = _rot("y", 0.7 * lift)
            q[:, idx[f"{side}Hand"]] = _rot("y", -0.3 * lift)
    q[:, idx["Neck"]] = _rot("y", 0.08 * np.sin(2 * ph))
    q[:, idx["Head"]] = _rot("y", -0.05 * np.sin(2 * ph))
    q[:, idx["Tail1"]] = _rot("z", 0.15 * np.sin(ph))
    q[:, idx["Tail2"]] = _rot("z", 0.2 * np.sin(ph - 0.5))
    root = np.stack([speed * t, np.zeros(n), 0.93 + 0.015 * np.cos(2 * ph)], axis=1)
    return Motion(skeleton=sk, frame_time=dt, root_translation=root, rotations=canonical_quat(q), unit=1.0, up="z")


def pterosaur_skeleton() -> Skeleton:
    j = [("Hips", None, (0.0, 0.0, 0.0)), ("Spine", "Hips", (0.15, 0.0, 0.0)), ("Chest", "Spine", (0.15, 0.0, 0.0)),
         ("Neck", "Chest", (0.15, 0.0, 0.08)), ("Head", "Neck", (0.15, 0.0, 0.05)),
         ("Crest", "Head", (-0.05, 0.0, 0.08)),
         ("Tail1", "Hips", (-0.10, 0.0, 0.0))]
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        j += [(f"{side}Wing1", "Chest", (0.0, s * 0.08, 0.02)), (f"{side}Wing2", f"{side}Wing1", (0.0, s * 0.30, 0.0)),
              (f"{side}Wing3", f"{side}Wing2", (0.0, s * 0.35, 0.0)),
              (f"{side}WingFinger", f"{side}Wing3", (0.0, s * 0.10, 0.0)),
              (f"{side}UpLeg", "Hips", (0.0, s * 0.05, -0.05)), (f"{side}Leg", f"{side}UpLeg", (0.0, 0.0, -0.15)),
              (f"{side}Foot", f"{side}Leg", (0.0, 0.0, -0.15))]
    ends = [("Head", (0.35, 0.0, -0.02)), ("Crest", (-0.20, 0.0, 0.10)), ("Tail1", (-0.15, 0.0, 0.0)),
            ("LeftWingFinger", (0.0, 0.60, 0.0)), ("RightWingFinger", (0.0, -0.60, 0.0)),
            ("LeftFoot", (0.05, 0.0, -0.03)), ("RightFoot", (0.05, 0.0, -0.03))]
    return _skeleton(j, ends)


def pterosaur_flight(cycles: int = 4, frames_per_cycle: int = 40, speed: float = 6.0, altitude: float = 3.0) -> Motion:
    """Flapping flight: the wings beat (shoulder roll +-0.7 rad, elbow and wrist folding on the
    upstroke), legs trail behind, the body rises on each downstroke."""
    sk = pterosaur_skeleton()
    beat_s = 0.5
    n = cycles * frames_per_cycle + 1
    dt = beat_s / frames_per_cycle
    t = np.arange(n) * dt
    ph = 2 * np.pi * t / beat_s
    q = np.tile([0.0, 0.0, 0.0, 1.0], (n, sk.num_joints, 1))
    idx = {name: i for i, name in enumerate(sk.names)}
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        q[:, idx[f"{side}Wing1"]] = _rot("x", s * 0.7 * np.sin(ph))
        fold = np.maximum(-np.cos(ph), 0.0)
        q[:, idx[f"{side}Wing2"]] = _rot("z", s * 0.6 * fold)
        q[:, idx[f"{side}Wing3"]] = _rot("z", -s * 0.8 * fold)
        q[:, idx[f"{side}UpLeg"]] = _rot("y", np.full(n, 1.2))  # legs trail backward
    q[:, idx["Neck"]] = _rot("y", 0.05 * np.sin(ph))
    root = np.stack([speed * t, np.zeros(n), altitude + 0.05 * np.sin(ph)], axis=1)
    return Motion(skeleton=sk, frame_time=dt, root_translation=root, rotations=canonical_quat(q), unit=1.0, up="z")


def builtin_walk_text() -> str:
    """The text of the built-in walk BVH (:data:`bipedsim.data.BUILTIN_WALK`), generated afresh."""
    return bvh_text(walk_bvh_motion(), precision=SHIPPED_BVH_PRECISION)


def sample_texts() -> dict[Path, str]:
    """The sample creatures' BVH texts (:data:`bipedsim.data.HORSE_WALK`, ``PTEROSAUR_FLIGHT``), generated
    afresh."""
    return {HORSE_WALK: bvh_text(horse_walk().with_up("y").scaled(100.0), precision=SHIPPED_BVH_PRECISION),
            PTEROSAUR_FLIGHT: bvh_text(pterosaur_flight().with_up("y").scaled(100.0),
                                       precision=SHIPPED_BVH_PRECISION)}
