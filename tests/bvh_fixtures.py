"""Generated BVH files standing in for the real samples of ``../shared/data/bvh`` in a clone without them.

Each stand-in is the project's own walk (:func:`bipedsim.motion.gaitgen.generate_walk`, or the shipped
horse) written in the layout of the shared file it stands for: its joint names and tree, channel order,
unit, up axis, frame rate, text quirks (line endings, a tab after ``Frames:``, no final newline) and
rest-pose quirks (splayed legs, feet pointing down, bone-aligned joint frames, position channels on
every joint). A test that asks for a shared file by name (:func:`shared_or_standin`) gets the real file
when ``../shared`` is there and the stand-in otherwise, so it checks what the layout must do either way.
What a stand-in cannot have (a real performer's numbers: strike counts, speeds, seam errors) stays with
the tests that need the real file.

The odd/ folder's stand-ins keep each file's layout (joint count and tree, position channels and their
mode, unit, up axis, line endings) on the generated walk or stand; their performances are not the real
ones (a walk for the crouch, fewer frames than the long takes).

The stand-ins are written once per test session into one folder (``standin_dir``), laid out as
``../shared/data/bvh`` is (``human/``, ``animal/``, ``odd/``).
"""

from __future__ import annotations

import atexit
import functools
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.motion.bvh import bvh_text, read_bvh
from bipedsim.motion.gaitgen import WalkParams, generate_walk, walk_skeleton
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.skeleton import Skeleton

#: metres per unit of the CMU ASF skeletons (1/0.45 inch)
CMU_UNIT_M = 0.0254 / 0.45
#: decimals written per value (0.01 micrometre in metres files)
PRECISION = 6
ROOT6 = ("Xposition", "Yposition", "Zposition")


@dataclass(frozen=True)
class J:
    """One joint of a target layout: it sits at ``at`` (m, in the frame of the generated skeleton's joint
    ``anchor``) and turns with that joint; ``order`` is its rotation channels' order."""

    name: str
    parent: str | None
    anchor: str
    at: tuple[float, float, float] = (0.0, 0.0, 0.0)
    order: str = "ZYX"


@dataclass(frozen=True)
class E:
    """An End Site below joint ``parent``, ``at`` (m) from it in the rest pose."""

    parent: str
    at: tuple[float, float, float]


def _rest_positions(sk: Skeleton) -> np.ndarray:
    p = np.zeros((sk.num_joints, 3))
    for i in range(1, sk.num_joints):
        p[i] = p[sk.parents[i]] + sk.offsets[i]
    return p


def relaid(m: Motion, joints: list[J], ends: list[E]) -> Motion:
    """``m`` (metres, Z up, a rest pose of identity rotations) on another skeleton whose every joint
    follows a joint of ``m``: every target joint's global position and rotation is that of its anchor
    (moved by ``at``), so the motion is the same. Raises if a target bone would stretch."""
    pos, rot = m.fk()
    src = m.skeleton
    rest = _rest_positions(src)
    names = [j.name for j in joints]
    n, t = len(joints), m.num_frames
    gp, gr = np.empty((t, n, 3)), np.empty((t, n, 3, 3))
    trest = np.empty((n, 3))
    for k, j in enumerate(joints):
        a = src.index(j.anchor)
        d = np.asarray(j.at, dtype=float)
        gp[:, k] = pos[:, a] + rot[:, a] @ d
        gr[:, k] = rot[:, a]
        trest[k] = rest[a] + d
    parents = np.array([-1 if j.parent is None else names.index(j.parent) for j in joints])
    offsets = np.zeros((n, 3))
    local = np.empty((t, n, 3, 3))
    local[:, 0] = gr[:, 0]
    for k in range(1, n):
        p = parents[k]
        offsets[k] = trest[k] - trest[p]
        local[:, k] = np.einsum("tba,tbc->tac", gr[:, p], gr[:, k])
        bone = np.einsum("tba,tb->ta", gr[:, p], gp[:, k] - gp[:, p])
        assert np.abs(bone - offsets[k]).max() < 1e-9, f"{joints[k].name}: its bone stretches"
    channels = tuple((ROOT6 if k == 0 else ()) + tuple(f"{a}rotation" for a in j.order) for k, j in enumerate(joints))
    sk = Skeleton(names=tuple(names), parents=parents, offsets=offsets, channels=channels,
                  end_site_parents=np.array([names.index(e.parent) for e in ends], dtype=np.int64),
                  end_site_offsets=np.array([e.at for e in ends], dtype=float).reshape(-1, 3))
    q = Rotation.from_matrix(local.reshape(-1, 3, 3)).as_quat().reshape(t, n, 4)
    return Motion(skeleton=sk, frame_time=m.frame_time, root_translation=gp[:, 0], rotations=canonical_quat(q),
                  unit=1.0, up="z")


def rest_turned(m: Motion, turns: dict[str, Rotation]) -> Motion:
    """The same motion on a rest pose whose named joints' bones turn by ``turns`` (the identity pose then
    has, say, splayed legs or feet pointing down); forward kinematics is unchanged."""
    base = np.tile(np.eye(3), (m.num_joints, 1, 1))
    for name, r in turns.items():
        base[m.skeleton.index(name)] = r.as_matrix().T
    return m.reframed(base)


def six_channels(m: Motion, mode: str = "replace", only: frozenset[str] | None = None) -> Motion:
    """Every joint (or those named in ``only``) with 3 position channels before its rotations: holding its
    OFFSET (``mode`` "replace", absolute) or zero ("add", added to the OFFSET)."""
    sk = m.skeleton
    channels = tuple(ch if sk.has_positions(i) or (only is not None and sk.names[i] not in only) else ROOT6 + ch
                     for i, ch in enumerate(sk.channels))
    modes = tuple("replace" if i == 0 else mode for i in range(len(channels)))
    return m.copy(skeleton=sk.replace(channels=channels, position_modes=modes), translations=m.local_translations())


# ---------------------------------------------------------------------- the generated performances
def _walk(seconds: float = 3.07) -> Motion:
    """``seconds`` of the generated walk (0.93 s a gait cycle) from a tenth of a cycle in: it starts and
    ends mid-step, as a capture does (a clip ending in its first pose would be taken for a loop)."""
    m = generate_walk(WalkParams(cycles=int(seconds / 0.93) + 2))
    return m[5:6 + round(seconds / m.frame_time)]


def _src_rest() -> dict[str, np.ndarray]:
    sk = walk_skeleton()
    return dict(zip(sk.names, _rest_positions(sk)))


def _standing_wave(seconds: float = 2.5, fps: float = 120.0) -> Motion:
    """The generated skeleton standing (its rest pose) with the right arm raised sideways and waved."""
    sk = walk_skeleton()
    n = int(seconds * fps) + 1
    t = np.arange(n) / fps
    rest = _src_rest()
    height = -(rest["LeftToeBase"][2]) + 0.02  # the toes' bottom on the floor
    rot = np.zeros((n, sk.num_joints, 4))
    rot[..., 3] = 1.0
    raise_ = np.clip(np.minimum(t, seconds - t) / 0.6, 0.0, 1.0)  # up over 0.6 s, down over the last 0.6 s
    arm = Rotation.from_euler("X", -2.4 * raise_[:, None])  # sideways, out to the right
    wave = Rotation.from_euler("X", (-0.4 * raise_ * np.sin(2 * np.pi * 2.0 * t))[:, None])
    rot[:, sk.index("RightArm")] = arm.as_quat()
    rot[:, sk.index("RightForeArm")] = wave.as_quat()
    root = np.tile([0.0, 0.0, height], (n, 1))
    return Motion(skeleton=sk, frame_time=1.0 / fps, root_translation=root, rotations=canonical_quat(rot),
                  unit=1.0, up="z")


# ---------------------------------------------------------------------- layouts
def _holden31(toe_tips: bool = False) -> tuple[list[J], list[E]]:
    """D. Holden's CMU skeleton: hip joints and a lower back at the pelvis, neck on the chest joint,
    two-joint hands with a thumb; toes without tips."""
    js = [J("Hips", None, "Hips")]
    ends: list[E] = []
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"{s}HipJoint", "Hips", "Hips"), J(f"{side}UpLeg", f"{s}HipJoint", f"{side}UpLeg"),
               J(f"{side}Leg", f"{side}UpLeg", f"{side}Leg"), J(f"{side}Foot", f"{side}Leg", f"{side}Foot"),
               J(f"{side}ToeBase", f"{side}Foot", f"{side}ToeBase")]
        ends.append(E(f"{side}ToeBase", (0.05, 0.0, 0.0) if toe_tips else (0.0, 0.0, 0.0)))
    js += [J("LowerBack", "Hips", "Hips"), J("Spine", "LowerBack", "Spine"), J("Spine1", "Spine", "Spine1"),
           J("Neck", "Spine1", "Neck"), J("Neck1", "Neck", "Neck", (0.0, 0.0, 0.04)), J("Head", "Neck1", "Head")]
    ends.append(E("Head", (0.0, 0.0, 0.2)))
    for s, side in (("L", "Left"), ("R", "Right")):
        w = 1.0 if side == "Left" else -1.0
        js += [J(f"{side}Shoulder", "Spine1", f"{side}Shoulder"), J(f"{side}Arm", f"{side}Shoulder", f"{side}Arm"),
               J(f"{side}ForeArm", f"{side}Arm", f"{side}ForeArm"), J(f"{side}Hand", f"{side}ForeArm", f"{side}Hand"),
               J(f"{side}FingerBase", f"{side}Hand", f"{side}Hand", (0.0, 0.0, -0.04)),
               J(f"{side}HandIndex1", f"{side}FingerBase", f"{side}Hand", (0.0, 0.0, -0.07)),
               J(f"{s}Thumb", f"{side}Hand", f"{side}Hand", (0.02, w * 0.0, -0.02))]
        ends += [E(f"{side}HandIndex1", (0.0, 0.0, -0.02)), E(f"{s}Thumb", (0.02, 0.0, -0.02))]
    return js, ends


def _hip19() -> tuple[list[J], list[E]]:
    """A 19-joint Poser-style skeleton (Hip, Abdomen, Chest, collars; no toes), mostly ZXY."""
    js = [J("Hip", None, "Hips", order="ZXY"), J("Abdomen", "Hip", "Spine", order="ZXY"),
          J("Chest", "Abdomen", "Spine1", order="ZXY"), J("Neck", "Chest", "Neck", order="ZXY"),
          J("Head", "Neck", "Head", order="ZYX")]
    ends = [E("Head", (0.0, 0.0, 0.2))]
    for side in ("Right", "Left"):
        js += [J(f"{side}Collar", "Chest", f"{side}Shoulder", order="ZXY"),
               J(f"{side}Shoulder", f"{side}Collar", f"{side}Arm", order="ZXY"),
               J(f"{side}Elbow", f"{side}Shoulder", f"{side}ForeArm", order="ZXY"),
               J(f"{side}Wrist", f"{side}Elbow", f"{side}Hand", order="ZXY")]
        ends.append(E(f"{side}Wrist", (0.0, 0.0, -0.08)))
    for side in ("Right", "Left"):
        js += [J(f"{side}Hip", "Hip", f"{side}UpLeg", order="ZXY"),
               J(f"{side}Knee", f"{side}Hip", f"{side}Leg", order="ZXY"),
               J(f"{side}Ankle", f"{side}Knee", f"{side}Foot", order="ZXY")]
        ends.append(E(f"{side}Ankle", (0.17, 0.0, -0.05)))
    return js, ends


def _daz43() -> tuple[list[J], list[E]]:
    """A Daz/Poser 43-joint skeleton: hip, abdomen, chest, eyes, collars, two-joint fingers, buttocks."""
    js = [J("hip", None, "Hips", order="ZXY"), J("abdomen", "hip", "Spine", order="ZXY"),
          J("chest", "abdomen", "Spine1", order="ZXY"), J("neck", "chest", "Neck", order="ZXY"),
          J("head", "neck", "Head", order="ZXY"),
          J("leftEye", "head", "Head", (0.08, 0.03, 0.08), order="ZXY"),
          J("rightEye", "head", "Head", (0.08, -0.03, 0.08), order="ZXY")]
    ends = [E("leftEye", (0.01, 0.0, 0.0)), E("rightEye", (0.01, 0.0, 0.0))]
    for s, side in (("r", "Right"), ("l", "Left")):
        w = 1.0 if s == "l" else -1.0
        js += [J(f"{s}Collar", "chest", f"{side}Shoulder", order="YZX"),
               J(f"{s}Shldr", f"{s}Collar", f"{side}Arm", order="ZYX"),
               J(f"{s}ForeArm", f"{s}Shldr", f"{side}ForeArm", order="YZX"),
               J(f"{s}Hand", f"{s}ForeArm", f"{side}Hand", order="ZYX")]
        for f, (x, y) in enumerate(((0.03, 0.0), (0.015, 0.0), (0.0, 0.0), (-0.015, 0.0), (-0.03, 0.0))):
            fn = ("Thumb", "Index", "Mid", "Ring", "Pinky")[f]
            js += [J(f"{s}{fn}1", f"{s}Hand", f"{side}Hand", (x, w * y, -0.05), order="ZXY"),
                   J(f"{s}{fn}2", f"{s}{fn}1", f"{side}Hand", (x, w * y, -0.08), order="ZXY")]
            ends.append(E(f"{s}{fn}2", (0.0, 0.0, -0.02)))
    for s, side in (("r", "Right"), ("l", "Left")):
        w = 1.0 if s == "l" else -1.0
        js += [J(f"{s}Buttock", "hip", "Hips", (0.0, w * 0.06, -0.04), order="ZXY"),
               J(f"{s}Thigh", f"{s}Buttock", f"{side}UpLeg", order="ZXY"),
               J(f"{s}Shin", f"{s}Thigh", f"{side}Leg", order="ZXY"),
               J(f"{s}Foot", f"{s}Shin", f"{side}Foot", order="YZX")]
        ends.append(E(f"{s}Foot", (0.17, 0.0, -0.05)))
    return js, ends


def _games105() -> tuple[list[J], list[E]]:
    """GAMES-105's course skeleton (RootJoint, lHip, pelvis_lowerback, torso_head ...), XYZ."""
    js = [J("RootJoint", None, "Hips", order="XYZ")]
    ends = []
    for s, side in (("l", "Left"), ("r", "Right")):
        js += [J(f"{s}Hip", "RootJoint", f"{side}UpLeg", order="XYZ"),
               J(f"{s}Knee", f"{s}Hip", f"{side}Leg", order="XYZ"),
               J(f"{s}Ankle", f"{s}Knee", f"{side}Foot", order="XYZ"),
               J(f"{s}ToeJoint", f"{s}Ankle", f"{side}ToeBase", order="XYZ")]
        ends.append(E(f"{s}ToeJoint", (0.05, 0.0, 0.0)))
    js += [J("pelvis_lowerback", "RootJoint", "Spine", order="XYZ"),
           J("lowerback_torso", "pelvis_lowerback", "Spine1", order="XYZ"),
           J("torso_head", "lowerback_torso", "Neck", order="XYZ")]
    ends.append(E("torso_head", (0.0, 0.0, 0.28)))
    for s, side in (("l", "Left"), ("r", "Right")):
        js += [J(f"{s}Torso_Clavicle", "lowerback_torso", f"{side}Shoulder", order="XYZ"),
               J(f"{s}Shoulder", f"{s}Torso_Clavicle", f"{side}Arm", order="XYZ"),
               J(f"{s}Elbow", f"{s}Shoulder", f"{side}ForeArm", order="XYZ"),
               J(f"{s}Wrist", f"{s}Elbow", f"{side}Hand", order="XYZ")]
        ends.append(E(f"{s}Wrist", (0.0, 0.0, -0.08)))
    return js, ends


def _bandai() -> tuple[list[J], list[E]]:
    """Bandai-Namco's joints (Hips, Spine, Chest, ..., Toes_L), position channels on each (added later)."""
    js = [J("Hips", None, "Hips", order="ZXY"), J("Spine", "Hips", "Spine", order="ZXY"),
          J("Chest", "Spine", "Spine1", order="ZXY"), J("Neck", "Chest", "Neck", order="ZXY"),
          J("Head", "Neck", "Head", order="ZXY")]
    ends = [E("Head", (0.0, 0.0, 0.2))]
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"Shoulder_{s}", "Chest", f"{side}Shoulder", order="ZXY"),
               J(f"UpperArm_{s}", f"Shoulder_{s}", f"{side}Arm", order="ZXY"),
               J(f"LowerArm_{s}", f"UpperArm_{s}", f"{side}ForeArm", order="ZXY"),
               J(f"Hand_{s}", f"LowerArm_{s}", f"{side}Hand", order="ZXY")]
        ends.append(E(f"Hand_{s}", (0.0, 0.0, -0.08)))
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"UpperLeg_{s}", "Hips", f"{side}UpLeg", order="ZXY"),
               J(f"LowerLeg_{s}", f"UpperLeg_{s}", f"{side}Leg", order="ZXY"),
               J(f"Foot_{s}", f"LowerLeg_{s}", f"{side}Foot", order="ZXY"),
               J(f"Toes_{s}", f"Foot_{s}", f"{side}ToeBase", order="ZXY")]
        ends.append(E(f"Toes_{s}", (0.0, 0.0, 0.0)))
    return js, ends


def _max31() -> tuple[list[J], list[E]]:
    """cgspeed's 3ds-Max-friendly CMU skeleton (LeftHip, LeftKnee, Chest2, LowerNeck, LeftCollar ...)."""
    js = [J("Hips", None, "Hips")]
    ends: list[E] = []
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"{s}HipJoint", "Hips", "Hips"), J(f"{side}Hip", f"{s}HipJoint", f"{side}UpLeg"),
               J(f"{side}Knee", f"{side}Hip", f"{side}Leg"), J(f"{side}Ankle", f"{side}Knee", f"{side}Foot"),
               J(f"{side}Toe", f"{side}Ankle", f"{side}ToeBase")]
        ends.append(E(f"{side}Toe", (0.05, 0.0, 0.0)))
    js += [J("LowerBack", "Hips", "Hips"), J("Chest", "LowerBack", "Spine"), J("Chest2", "Chest", "Spine1"),
           J("LowerNeck", "Chest2", "Neck"), J("Neck", "LowerNeck", "Neck", (0.0, 0.0, 0.04)),
           J("Head", "Neck", "Head")]
    ends.append(E("Head", (0.0, 0.0, 0.2)))
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"{side}Collar", "Chest2", f"{side}Shoulder", order="ZXY"),
               J(f"{side}Shoulder", f"{side}Collar", f"{side}Arm", order="ZXY"),
               J(f"{side}Elbow", f"{side}Shoulder", f"{side}ForeArm", order="ZXY"),
               J(f"{side}Wrist", f"{side}Elbow", f"{side}Hand", order="ZXY"),
               J(f"{s.lower()}hand", f"{side}Wrist", f"{side}Hand", (0.0, 0.0, -0.04)),
               J(f"{s}Fingers", f"{s.lower()}hand", f"{side}Hand", (0.0, 0.0, -0.07)),
               J(f"{s}Thumb", f"{side}Wrist", f"{side}Hand", (0.02, 0.0, -0.02))]
        ends += [E(f"{s}Fingers", (0.0, 0.0, -0.02)), E(f"{s}Thumb", (0.02, 0.0, -0.02))]
    return js, ends


def _max31_metres() -> tuple[list[J], list[E]]:
    """The same 3ds-Max-friendly skeleton as the repo author's metres copy names it (lowerback, lowerneck)."""
    rename = {"LowerBack": "lowerback", "LowerNeck": "lowerneck"}
    js, ends = _max31()
    js = [J(rename.get(j.name, j.name), rename.get(j.parent, j.parent) if j.parent else None, j.anchor, j.at, j.order)
          for j in js]
    return js, [E(rename.get(e.parent, e.parent), e.at) for e in ends]


def _crouch19() -> tuple[list[J], list[E]]:
    """The mocapbank 19-joint skeleton (Chest, Chest2, collars, LeftHip/Knee/Ankle without toes), ZXY."""
    js = [J("Hips", None, "Hips", order="ZXY"), J("Chest", "Hips", "Spine", order="ZXY"),
          J("Chest2", "Chest", "Spine1", order="ZXY")]
    ends = []
    for side in ("Left", "Right"):
        js += [J(f"{side}Collar", "Chest2", f"{side}Shoulder", order="ZXY"),
               J(f"{side}Shoulder", f"{side}Collar", f"{side}Arm", order="ZXY"),
               J(f"{side}Elbow", f"{side}Shoulder", f"{side}ForeArm", order="ZXY"),
               J(f"{side}Wrist", f"{side}Elbow", f"{side}Hand", order="ZXY")]
        ends.append(E(f"{side}Wrist", (0.0, 0.0, -0.08)))
    js += [J("Neck", "Chest2", "Neck", order="ZXY"), J("Head", "Neck", "Head", order="ZXY")]
    ends.append(E("Head", (0.0, 0.0, 0.2)))
    for side in ("Left", "Right"):
        js += [J(f"{side}Hip", "Hips", f"{side}UpLeg", order="ZXY"),
               J(f"{side}Knee", f"{side}Hip", f"{side}Leg", order="ZXY"),
               J(f"{side}Ankle", f"{side}Knee", f"{side}Foot", order="ZXY")]
        ends.append(E(f"{side}Ankle", (0.17, 0.0, -0.05)))
    return js, ends


def _spec18() -> tuple[list[J], list[E]]:
    """The classic 18-joint sample (Hips, Chest, LeftCollar, LeftUpArm, LeftLowArm, LeftUpLeg ...), ZXY."""
    js = [J("Hips", None, "Hips", order="ZXY"), J("Chest", "Hips", "Spine", order="ZXY"),
          J("Neck", "Chest", "Neck", order="ZXY"), J("Head", "Neck", "Head", order="ZXY")]
    ends = [E("Head", (0.0, 0.0, 0.2))]
    for side in ("Left", "Right"):
        js += [J(f"{side}Collar", "Chest", f"{side}Shoulder", order="ZXY"),
               J(f"{side}UpArm", f"{side}Collar", f"{side}Arm", order="ZXY"),
               J(f"{side}LowArm", f"{side}UpArm", f"{side}ForeArm", order="ZXY"),
               J(f"{side}Hand", f"{side}LowArm", f"{side}Hand", order="ZXY")]
        ends.append(E(f"{side}Hand", (0.0, 0.0, -0.08)))
    for side in ("Left", "Right"):
        js += [J(f"{side}UpLeg", "Hips", f"{side}UpLeg", order="ZXY"),
               J(f"{side}LowLeg", f"{side}UpLeg", f"{side}Leg", order="ZXY"),
               J(f"{side}Foot", f"{side}LowLeg", f"{side}Foot", order="ZXY")]
    ends.append(E("RightFoot", (0.17, 0.0, -0.05)))
    return js, ends


def _blender19() -> tuple[list[J], list[E]]:
    """bvhtools' Blender-rig names (pelvis, spine.001, thigh.L ...): XYZ, the shoulders and hip bones YXZ."""
    js = [J("pelvis", None, "Hips", order="XYZ"), J("spine", "pelvis", "Spine", order="XYZ"),
          J("spine.001", "spine", "Spine1", order="XYZ"), J("neck", "spine.001", "Neck", order="XYZ"),
          J("face", "neck", "Head", order="XYZ")]
    ends = [E("face", (0.0, 0.0, 0.2))]
    for s in ("L", "R"):
        side = "Left" if s == "L" else "Right"
        js += [J(f"shoulder.{s}", "spine.001", f"{side}Shoulder", order="YXZ"),
               J(f"upper_arm.{s}", f"shoulder.{s}", f"{side}Arm", order="XYZ"),
               J(f"forearm.{s}", f"upper_arm.{s}", f"{side}ForeArm", order="XYZ")]
        ends.append(E(f"forearm.{s}", (0.0, 0.0, -0.25)))
    for s, w in (("L", 1.0), ("R", -1.0)):
        js.append(J(f"pelvis.{s}", "pelvis", "Hips", (0.0, w * 0.06, -0.02), order="YXZ"))
        ends.append(E(f"pelvis.{s}", (0.05, w * 0.06, 0.04)))
    for s in ("L", "R"):
        side = "Left" if s == "L" else "Right"
        js += [J(f"thigh.{s}", "pelvis", f"{side}UpLeg", order="XYZ"),
               J(f"shin.{s}", f"thigh.{s}", f"{side}Leg", order="XYZ"),
               J(f"foot.{s}", f"shin.{s}", f"{side}Foot", order="XYZ")]
        ends.append(E(f"foot.{s}", (0.17, 0.0, -0.05)))
    return js, ends


def _mh_walk75() -> tuple[list[J], list[E]]:
    """MakeHuman's 75-joint game rig (Root, Spine1-3, __ helper bones, five-finger hands, a Hips bone
    joining both legs under Root), XYZ."""
    js = [J("Root", None, "Hips", order="XYZ"), J("Spine1", "Root", "Spine", order="XYZ"),
          J("Spine2", "Spine1", "Spine1", order="XYZ"), J("Spine3", "Spine2", "Spine1", (0.0, 0.0, 0.12), order="XYZ"),
          J("Neck", "Spine3", "Neck", order="XYZ"), J("Head", "Neck", "Head", order="XYZ"),
          J("__Jaw", "Head", "Head", (0.03, 0.0, 0.0), order="XYZ"),
          J("Jaw", "__Jaw", "Head", (0.04, 0.0, 0.0), order="XYZ"),
          J("__Tongue1", "Jaw", "Head", (0.05, 0.0, 0.01), order="XYZ"),
          J("Tongue1", "Jaw", "Head", (0.06, 0.0, 0.01), order="XYZ"),
          J("Tongue2", "Tongue1", "Head", (0.07, 0.0, 0.01), order="XYZ"),
          J("Tongue3", "Tongue2", "Head", (0.08, 0.0, 0.01), order="XYZ")]
    ends = [E("__Tongue1", (0.01, 0.0, 0.0)), E("Tongue3", (0.01, 0.0, 0.0))]
    for s, w in (("L", 1.0), ("R", -1.0)):
        js += [J(f"__Eye_{s}", "Head", "Head", (0.08, w * 0.03, 0.08), order="XYZ"),
               J(f"Eye_{s}", f"__Eye_{s}", "Head", (0.09, w * 0.03, 0.08), order="XYZ")]
        ends.append(E(f"Eye_{s}", (0.01, 0.0, 0.0)))
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"__Clavicle_{s}", "Spine3", f"{side}Shoulder", order="XYZ"),
               J(f"Clavicle_{s}", f"__Clavicle_{s}", f"{side}Shoulder", (0.0, 0.0, 0.01), order="XYZ"),
               J(f"UpArm_{s}", f"Clavicle_{s}", f"{side}Arm", order="XYZ"),
               J(f"LoArm_{s}", f"UpArm_{s}", f"{side}ForeArm", order="XYZ"),
               J(f"Hand_{s}", f"LoArm_{s}", f"{side}Hand", order="XYZ")]
        for f, finger in enumerate(("Thumb", "Index", "Middle", "Ring", "Pinky")):
            x = 0.03 - 0.015 * f
            parent = f"Hand_{s}"
            if finger != "Middle":
                js.append(J(f"__{finger}1_{s}", parent, f"{side}Hand", (x, 0.0, -0.03), order="XYZ"))
                parent = f"__{finger}1_{s}"
            for k in (1, 2, 3):
                js.append(J(f"{finger}{k}_{s}", parent, f"{side}Hand", (x, 0.0, -0.04 - 0.025 * k), order="XYZ"))
                parent = f"{finger}{k}_{s}"
            ends.append(E(parent, (0.0, 0.0, -0.02)))
    js.append(J("Hips", "Root", "Hips", order="XYZ"))
    for s, side in (("L", "Left"), ("R", "Right")):
        js += [J(f"__UpLeg_{s}", "Hips", "Hips", order="XYZ"),  # a helper bone at the pelvis centre
               J(f"UpLeg_{s}", f"__UpLeg_{s}", f"{side}UpLeg", order="XYZ"),
               J(f"LoLeg_{s}", f"UpLeg_{s}", f"{side}Leg", order="XYZ"),
               J(f"Foot_{s}", f"LoLeg_{s}", f"{side}Foot", order="XYZ"),
               J(f"Toe_{s}", f"Foot_{s}", f"{side}ToeBase", order="XYZ")]
        ends.append(E(f"Toe_{s}", (0.05, 0.0, 0.0)))
    return js, ends


#: the face bones of MakeHuman's default rig stood in for by chains on the head: (stem, joints per side)
_MH_FACE = (("levator", 6), ("oris", 7), ("orbicularis", 4), ("eyelid", 3), ("temporalis", 3), ("risorius", 3),
            ("cheek", 3), ("nose", 3), ("tongue", 4), ("jaw", 1))
#: MakeHuman's default body (1.66 m to the top of the head) over the generated walker's (1.80 m with the
#: face bones): its height decides the unit guessed, decimetres
MH_SCALE = 0.92
#: joints of MakeHuman's default rig without the face bones (``_mh_default``)
MH_BODY_JOINTS = 112


def _mh_default(face_joints: int) -> tuple[list[J], list[E]]:
    """MakeHuman's default rig (root, pelvis.L/R, upperleg01-02, metatarsals and toes, spine05-01,
    neck01-03, clavicle ... wrist, metacarpals and fingers), XYZ, and ``face_joints`` face bones on the head."""
    js = [J("root", None, "Hips", order="XYZ")]
    ends: list[E] = []
    for s, side, w in (("R", "Right", -1.0), ("L", "Left", 1.0)):
        js += [J(f"pelvis.{s}", "root", "Hips", order="XYZ"),
               J(f"upperleg01.{s}", f"pelvis.{s}", f"{side}UpLeg", order="XYZ"),
               J(f"upperleg02.{s}", f"upperleg01.{s}", f"{side}UpLeg", (0.0, 0.0, -0.2), order="XYZ"),
               J(f"lowerleg01.{s}", f"upperleg02.{s}", f"{side}Leg", order="XYZ"),
               J(f"lowerleg02.{s}", f"lowerleg01.{s}", f"{side}Leg", (0.0, 0.0, -0.2), order="XYZ"),
               J(f"foot.{s}", f"lowerleg02.{s}", f"{side}Foot", order="XYZ")]
        for t in range(1, 6):
            y = w * (0.04 - 0.02 * t)
            js.append(J(f"metatarsal{t}.{s}", f"foot.{s}", f"{side}Foot", (0.06, y, -0.04), order="XYZ"))
            parent = f"metatarsal{t}.{s}"
            for k in range(1, 3 if t == 1 else 4):
                js.append(J(f"toe{t}-{k}.{s}", parent, f"{side}Foot", (0.12 + 0.015 * k, y, -0.05), order="XYZ"))
                parent = f"toe{t}-{k}.{s}"
            ends.append(E(parent, (0.01, 0.0, 0.0)))
    js += [J("spine05", "root", "Spine", order="XYZ"), J("spine04", "spine05", "Spine", (0.0, 0.0, 0.1), order="XYZ"),
           J("spine03", "spine04", "Spine1", order="XYZ"),
           J("spine02", "spine03", "Spine1", (0.0, 0.0, 0.1), order="XYZ"),
           J("spine01", "spine02", "Spine1", (0.0, 0.0, 0.18), order="XYZ"),
           J("neck01", "spine01", "Neck", order="XYZ"), J("neck02", "neck01", "Neck", (0.0, 0.0, 0.03), order="XYZ"),
           J("neck03", "neck02", "Neck", (0.0, 0.0, 0.06), order="XYZ"), J("head", "neck03", "Head", order="XYZ")]
    for s, side in (("R", "Right"), ("L", "Left")):
        js += [J(f"clavicle.{s}", "spine01", f"{side}Shoulder", order="XYZ"),
               J(f"shoulder01.{s}", f"clavicle.{s}", f"{side}Arm", order="XYZ"),
               J(f"upperarm01.{s}", f"shoulder01.{s}", f"{side}Arm", (0.0, 0.0, -0.05), order="XYZ"),
               J(f"upperarm02.{s}", f"upperarm01.{s}", f"{side}Arm", (0.0, 0.0, -0.15), order="XYZ"),
               J(f"lowerarm01.{s}", f"upperarm02.{s}", f"{side}ForeArm", order="XYZ"),
               J(f"lowerarm02.{s}", f"lowerarm01.{s}", f"{side}ForeArm", (0.0, 0.0, -0.12), order="XYZ"),
               J(f"wrist.{s}", f"lowerarm02.{s}", f"{side}Hand", order="XYZ")]
        for f in range(1, 6):
            x = 0.03 - 0.015 * (f - 1)
            parent = f"wrist.{s}"
            if f > 1:
                js.append(J(f"metacarpal{f - 1}.{s}", parent, f"{side}Hand", (x, 0.0, -0.03), order="XYZ"))
                parent = f"metacarpal{f - 1}.{s}"
            for k in (1, 2, 3):
                js.append(J(f"finger{f}-{k}.{s}", parent, f"{side}Hand", (x, 0.0, -0.04 - 0.025 * k), order="XYZ"))
                parent = f"finger{f}-{k}.{s}"
            ends.append(E(parent, (0.0, 0.0, -0.02)))
    face = [(stem, k) for stem, n in _MH_FACE for k in range(1, n + 1)]
    added = 0
    for stem, k in face:
        for s, w in (("L", 1.0), ("R", -1.0)):
            if added < face_joints:
                parent = "head" if k == 1 else f"{stem}{k - 1:02d}.{s}"
                at = (0.06 + 0.01 * k, w * 0.04, 0.04 + 0.005 * len(stem))
                js.append(J(f"{stem}{k:02d}.{s}", parent, "Head", at, order="XYZ"))
                added += 1
    assert added == face_joints, "too few face bones"
    names = {j.name for j in js}
    parents = {j.parent for j in js}
    ends += [E(n, (0.01, 0.0, 0.0)) for n in sorted(names - parents) if not any(e.parent == n for e in ends)]
    return js, ends


def _splayed_rest(m: Motion, thigh: str, shin: str, foot: str, toe: str | None, side: float,
                  splay_deg: float = 20.0, foot_down_deg: float = 10.0) -> dict[str, Rotation]:
    """Rest-pose turns of one leg: splayed ``splay_deg`` outward from the hip, the foot pointing
    ``foot_down_deg`` down (as Holden's CMU rest pose stands)."""
    splay = Rotation.from_euler("x", side * splay_deg, degrees=True)
    out = {thigh: splay, shin: splay, foot: splay * Rotation.from_euler("y", foot_down_deg, degrees=True)}
    if toe is not None:
        out[toe] = out[foot]
    return out


# ---------------------------------------------------------------------- writing
def _to_file_frame(m: Motion, unit_m: float, up: str, fps: float | None) -> Motion:
    if fps is not None:
        m = m.resample(fps)
    return m.with_up(up).scaled(1.0 / unit_m)


def _text(m: Motion, *, eol: str = "\n", final_newline: bool = True, frames_tab: bool = False,
          frame_time: str | None = None, values_tab: bool = False) -> bytes:
    text = bvh_text(m, precision=PRECISION)
    if values_tab:  # the frame lines' values separated by tabs
        head, motion = text.split("Frame Time:", 1)
        first, rest = motion.split("\n", 1)
        text = head + "Frame Time:" + first + "\n" + rest.replace(" ", "\t")
    if frames_tab:
        text = text.replace("Frames: ", "Frames:\t", 1)
    if frame_time is not None:
        lines = text.split("\n")
        k = next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time:"))
        lines[k] = f"Frame Time: {frame_time}"
        text = "\n".join(lines)
    if not final_newline:
        text = text.rstrip("\n")
    if eol == "mixed":  # CRLF in the hierarchy, LF in the motion
        head, motion = text.split("MOTION", 1)
        return (head.replace("\n", "\r\n") + "MOTION" + motion).encode()
    return text.replace("\n", eol).encode()


def _human(layout: str) -> Motion:
    """The generated walk in ``layout`` (metres, Z up), with the layout's rest-pose quirks."""
    if layout == "holden31":
        js, ends = _holden31()
        m = relaid(_walk(2.81), js, ends)  # as long as CMU 02_01
        turns = {**_splayed_rest(m, "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", 1.0),
                 **_splayed_rest(m, "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", -1.0)}
        return rest_turned(m, turns)
    if layout == "holden31_wave":
        js, ends = _holden31()
        return relaid(_standing_wave(), js, ends)
    if layout == "mb31":
        js, ends = _holden31(toe_tips=True)
        return relaid(_walk(), js, ends)
    layouts = {"hip19": _hip19, "daz43": _daz43, "games105": _games105, "bandai": _bandai, "max31": _max31}
    js, ends = layouts[layout]()
    # Bandai's take is 9.6 s at 30 fps: a long clip, whose first and last steps weigh little
    m = relaid(_walk(7.0 if layout == "bandai" else 3.07), js, ends)
    if layout == "bandai":
        # bone-aligned joint frames: the identity pose lies on its back
        m = rest_turned(m, {n: Rotation.from_euler("y", -90, degrees=True) for n in m.skeleton.names})
    return m


def _in_place(m: Motion) -> Motion:
    """``m`` with its root's mean horizontal travel taken out (a cycle walked on the spot)."""
    root = m.root_translation.copy()
    t = np.arange(m.num_frames) / max(m.num_frames - 1, 1)
    root[:, :2] -= t[:, None] * (root[-1, :2] - root[0, :2])
    return m.copy(root_translation=root)


def _stand(frames: int, fps: float) -> Motion:
    """``frames`` identical frames of the generated skeleton standing in its rest pose."""
    m = _standing_wave()[:1]
    idx = np.zeros(frames, dtype=int)
    return m.copy(frame_time=1.0 / fps, root_translation=m.root_translation[idx], rotations=m.rotations[idx])


def _face_moves(m: Motion, seed: int = 0) -> Motion:
    """``m`` with every face bone (a joint past ``MH_BODY_JOINTS``) turned a different way each frame."""
    rng = np.random.default_rng(seed)
    rot = m.rotations.copy()
    turns = Rotation.from_rotvec(rng.normal(scale=0.2, size=(m.num_frames * (m.num_joints - MH_BODY_JOINTS), 3)))
    rot[:, MH_BODY_JOINTS:] = turns.as_quat().reshape(m.num_frames, -1, 4)
    return m.copy(rotations=canonical_quat(rot))


def _sinusoidal(frames: int = 120, fps: float = 60.0) -> Motion:
    """A synthetic 4-joint chain (no End Site on its leaf) turning sinusoidally about each axis, in
    unitless numbers about 5 long a bone (metres here, written as they are)."""
    names = ("base", "child1", "child2", "child3")
    offsets = np.array([[0.0, 0.0, 0.0], [0.0, 5.0, 0.0], [-5.0, 0.0, 0.0], [0.0, 0.0, 5.0]])
    xyz = tuple(f"{a}rotation" for a in "XYZ")
    sk = Skeleton(names=names, parents=np.array([-1, 0, 1, 2]), offsets=offsets,
                  channels=(ROOT6 + xyz, xyz, xyz, xyz),
                  end_site_parents=np.zeros(0, dtype=np.int64), end_site_offsets=np.zeros((0, 3)))
    t = np.arange(frames) / fps
    ang = np.stack([0.5 * np.sin(2 * np.pi * (0.5 + 0.25 * j) * t + j) for j in range(12)], axis=1)
    rot = Rotation.from_euler("XYZ", ang.reshape(frames * 4, 3)).as_quat().reshape(frames, 4, 4)
    root = np.stack([np.sin(2 * np.pi * t), np.zeros(frames), np.cos(2 * np.pi * t)], axis=1)
    return Motion(skeleton=sk, frame_time=1.0 / fps, root_translation=root, rotations=canonical_quat(rot),
                  unit=1.0, up="y")


def _odd(layout: str) -> Motion:
    """The generated walk or stand in one of the odd/ folder's layouts (metres, Z up)."""
    if layout == "max31_metres":
        return relaid(_walk(), *_max31_metres())
    if layout == "crouch19":
        return relaid(_walk(), *_crouch19())
    if layout == "spec18":  # two frames of the arm raised
        m = _standing_wave()
        return relaid(m[120:122].copy(frame_time=1.0 / 30.0), *_spec18())
    if layout == "blender19":
        m = relaid(_walk(7.0), *_blender19())
        return six_channels(m, only=frozenset(j.name for j in _blender19()[0]) - {"spine.001"})
    if layout == "mh_walk75":
        # one gait cycle in 13 frames (its last frame its first's), played at 24 fps: a game walk cycle
        cycle = generate_walk(WalkParams(frames_per_cycle=13, cycles=4))[13:27].copy(frame_time=1.0 / 24.0)
        return _in_place(relaid(cycle, *_mh_walk75())).scaled(MH_SCALE)
    if layout == "pfnn31":
        return relaid(_stand(60, 30.0), *_holden31())
    if layout == "mh_tpose173":
        js, ends = _mh_default(173 - MH_BODY_JOINTS)
        three = {"pelvis.L", "pelvis.R"} | {j.name for j in js[MH_BODY_JOINTS:MH_BODY_JOINTS + 27]}
        m = relaid(_stand(1, 24.0), js, ends)
        return six_channels(m.scaled(MH_SCALE), mode="add", only=frozenset(j.name for j in js[1:]) - three)
    if layout == "mh_face163":
        return _face_moves(relaid(_stand(60, 24.0), *_mh_default(163 - MH_BODY_JOINTS))).scaled(MH_SCALE)
    raise KeyError(layout)


def _dog() -> Motion:
    """The shipped horse on the MANN dog's skeleton (Spine1, shoulders, Tail/Tail1), ZXY."""
    from bipedsim.motion.samples import horse_walk

    js = [J("Hips", None, "Hips", order="ZXY"), J("Spine", "Hips", "Spine", order="ZXY"),
          J("Spine1", "Spine", "Chest", order="ZXY"), J("Neck", "Spine1", "Neck", order="ZXY"),
          J("Head", "Neck", "Head", order="ZXY")]
    ends = [E("Head", (0.40, 0.0, -0.15))]
    for side, w in (("Left", 1.0), ("Right", -1.0)):
        js += [J(f"{side}Shoulder", "Spine1", "Chest", (0.08, w * 0.08, -0.05), order="ZXY"),
               J(f"{side}Arm", f"{side}Shoulder", f"{side}Arm", order="ZXY"),
               J(f"{side}ForeArm", f"{side}Arm", f"{side}ForeArm", order="ZXY"),
               J(f"{side}Hand", f"{side}ForeArm", f"{side}Hand", order="ZXY")]
        ends.append(E(f"{side}Hand", (0.06, 0.0, -0.08)))
    for side in ("Left", "Right"):
        js += [J(f"{side}UpLeg", "Hips", f"{side}UpLeg", order="ZXY"),
               J(f"{side}Leg", f"{side}UpLeg", f"{side}Leg", order="ZXY"),
               J(f"{side}Foot", f"{side}Leg", f"{side}Foot", order="ZXY")]
        ends.append(E(f"{side}Foot", (0.06, 0.0, -0.08)))
    js += [J("Tail", "Hips", "Tail1", order="ZXY"), J("Tail1", "Tail", "Tail2", order="ZXY")]
    ends.append(E("Tail1", (-0.25, 0.0, -0.25)))
    return _swayed(relaid(horse_walk(), js, ends))


def _swayed(m: Motion, still: frozenset[str] = frozenset()) -> Motion:
    """``m`` with every joint it holds still (but those named in ``still``) turning a little: a real animal
    moves every joint; here the back and shoulders turn 0.2 rad side to side."""
    t = np.arange(m.num_frames) * m.frame_time
    sway = 0.2 * np.sin(2 * np.pi * t / m.duration)  # slow: the stance feet stay put
    rot = m.rotations.copy()
    for k in range(1, m.num_joints):
        if m.skeleton.names[k] not in still and Rotation.from_quat(rot[:, k]).magnitude().max() < 0.2:
            rot[:, k] = (Rotation.from_quat(rot[:, k]) * Rotation.from_euler("z", sway[:, None])).as_quat()
    return m.copy(rotations=canonical_quat(rot))


#: the flamingo over the generated walker (its hips at 0.48 m, the walker's at 0.95 m)
FLAMINGO_SCALE = 0.5


def _flamingo() -> Motion:
    """The generated walk, half size and in place, on the Truebones flamingo's skeleton (Bip01 names with
    3-character suffixes, thighs under the spine, a horse-link in each leg, toes, folded wings, a tail and
    a six-joint neck reaching forward), ZXY. The body above the legs turns with the walker's hips: its
    trunk lies forward of them, as a bird's does."""
    js = [J("Hips__w4v", None, "Hips", order="ZXY"), J("Bip01_Pelvis__bBo", "Hips__w4v", "Hips", order="ZXY"),
          J("BN_Tail_01__8Ri", "Bip01_Pelvis__bBo", "Hips", (-0.05, 0.0, 0.03), order="ZXY"),
          J("BN_Tail_R_01__vdN", "BN_Tail_01__8Ri", "Hips", (-0.13, -0.018, 0.04), order="ZXY"),
          J("BN_Tail_L_01__Qcw", "BN_Tail_01__8Ri", "Hips", (-0.13, 0.018, 0.04), order="ZXY"),
          J("Bip01_Spine__UlJ", "Bip01_Pelvis__bBo", "Hips", (0.04, 0.0, -0.05), order="ZXY")]
    ends = [E("BN_Tail_R_01__vdN", (0.0, 0.0, 0.0)), E("BN_Tail_L_01__Qcw", (0.0, 0.0, 0.0))]
    for s, sfx, w in (("L", ("tJN", "JiJ", "ror", "il9"), 1.0), ("R", ("8dz", "5Px", "nhh", "dxX"), -1.0)):
        for k in range(4):
            parent = "Bip01_Spine__UlJ" if k == 0 else f"BN_Forearm_{s}_{k:02d}__{sfx[k - 1]}"
            js.append(J(f"BN_Forearm_{s}_{k + 1:02d}__{sfx[k]}", parent, "Hips",
                        (0.05 - 0.03 * k, w * 0.063, -0.04), order="ZXY"))
        ends.append(E(js[-1].name, (0.0, 0.0, 0.0)))
    js += [J("Bone02__old", "Bip01_Spine__UlJ", "Hips", (0.07, 0.0, -0.08), order="ZXY"),
           J("Bone03__f96", "Bone02__old", "Hips", (0.15, 0.0, -0.08), order="ZXY")]
    ends.append(E("Bone03__f96", (0.0, 0.0, 0.0)))
    toes = {"R": (("Toe2__w2t", None), ("Toe1__eMA", None), ("Toe0__vYg", None)),
            "L": (("Toe2__w7U", "Toe21__Dqe"), ("Toe1__zUA", "Toe11__DhW"), ("Toe0__8VZ", "Toe01__haX"))}
    for s, side, sfx, w in (("R", "Right", ("qPK", "swj", "kyi", "bwL"), -1.0),
                            ("L", "Left", ("UfG", "IXD", "Idl", "ouF"), 1.0)):
        thigh, calf, link, foot = (f"Bip01_{s}_{n}__{x}" for n, x in zip(("Thigh", "Calf", "HorseLink", "Foot"), sfx))
        js += [J(thigh, "Bip01_Spine__UlJ", f"{side}UpLeg", order="ZXY"), J(calf, thigh, f"{side}Leg", order="ZXY"),
               J(link, calf, f"{side}Leg", (0.0, 0.0, -0.12), order="ZXY"), J(foot, link, f"{side}Foot", order="ZXY")]
        for t, (toe, tip) in enumerate(toes[s]):
            y = w * (0.01 * t - 0.01)
            # on the floor: the walker's ankle is 2.5 cm up at this size
            js.append(J(f"Bip01_{s}_{toe}", foot, f"{side}Foot", (0.015, y, -0.023), order="ZXY"))
            if tip is not None:
                js.append(J(f"Bip01_{s}_{tip}", f"Bip01_{s}_{toe}", f"{side}Foot", (0.03, y, -0.024), order="ZXY"))
            ends.append(E(js[-1].name, (0.0, 0.0, 0.0)))
    neck = (("Bip01_Spine1__OBc", (0.08, 0.0, -0.06)), ("Bip01_Neck__OQw", (0.14, 0.0, -0.07)),
            ("Bip01_Neck1__6Ap", (0.21, 0.0, -0.07)), ("Bip01_Neck2__9K1", (0.28, 0.0, -0.06)),
            ("Bip01_Neck3__A5z", (0.34, 0.0, -0.04)), ("Bip01_Neck4__PB6", (0.39, 0.0, -0.02)),
            ("Bip01_Head__N3g", (0.43, 0.0, 0.0)), ("BN_Mouth_01__VD1", (0.48, 0.0, -0.01)))
    parent = "Bip01_Spine__UlJ"
    for name, at in neck:
        js.append(J(name, parent, "Hips", at, order="ZXY"))
        parent = name
    ends.append(E("BN_Mouth_01__VD1", (0.0, 0.0, 0.0)))
    # the joints the legs hang from stay as the walker holds them: the feet keep their footing
    still = frozenset({"Hips__w4v", "Bip01_Pelvis__bBo", "Bip01_Spine__UlJ"})
    m = _swayed(_in_place(relaid(_walk(2.7).scaled(FLAMINGO_SCALE), js, ends)), still)
    # and turn from their rest pose, the pelvis 90 deg (the identity pose lies along X, as the
    # flamingo's does) and the spine back 60 deg of it
    return rest_turned(m, {"Bip01_Pelvis__bBo": Rotation.from_euler("y", -90, degrees=True),
                           "Bip01_Spine__UlJ": Rotation.from_euler("y", -30, degrees=True)})


#: what each stand-in is: the shared file's name -> (performance and layout, unit (m), up, fps, text quirks)
STANDINS: dict[str, tuple[str, float, str, float | None, dict[str, object]]] = {
    "human/cmu_02_01_walk__holden31_crlf.bvh": ("holden31", CMU_UNIT_M, "y", 120.0, {"eol": "\r\n"}),
    "human/cmu_02_02_walk__19joint_Hip_Abdomen.bvh": ("hip19", 0.01, "y", 120.0, {}),
    "human/cmu_02_02_walk__daz43.bvh": ("daz43", 0.01, "y", 120.0, {"frames_tab": True}),
    "human/cmu_12_03_walk__cgspeed_mb31.bvh": ("mb31", CMU_UNIT_M, "y", 120.0, {"frame_time": ".0083333"}),
    "human/games105_walk60__metres_crlf.bvh": ("games105", 1.0, "y", 60.0, {"eol": "\r\n", "final_newline": False}),
    "human/bandai2_walk_exhausted_001.bvh": ("bandai", 0.01, "y", 30.0, {"frames_tab": True}),
    "human/cmu_131_01_start_walk_stop__max31_mixedEOL.bvh": ("max31", CMU_UNIT_M, "y", 120.0,
                                                             {"eol": "mixed", "frame_time": ".0083333"}),
    "human/cmu_141_16_wave_hello__holden31_crlf.bvh": ("holden31_wave", CMU_UNIT_M, "y", None, {"eol": "\r\n"}),
    "animal/mann_dog_D1_007_KAN01_001_locomotion.bvh": ("dog", 0.01, "y", 60.0, {"eol": "\r\n", "frames_tab": True}),
    "animal/truebones_flamingo_walk_inplace.bvh": ("flamingo", 0.01, "y", 30.0, {"frames_tab": True}),
    "odd/cmu_131_01_start_walk_stop__metres.bvh": ("max31_metres", 1.0, "y", 120.0, {}),
    "odd/mocapbank_crouch__crlf.bvh": ("crouch19", 0.01, "y", 30.0, {"eol": "\r\n", "frames_tab": True}),
    "odd/mocapbank_crouch__lf.bvh": ("crouch19", 0.01, "y", 30.0, {"frames_tab": True}),
    "odd/bvh_spec_sample__2frames.bvh": ("spec18", 0.0254, "y", None,
                                         {"final_newline": False, "values_tab": True}),
    "odd/bvhtools_test3__YXZ_XYZ_metres_first600f__DERIVED.bvh": ("blender19", 1.0, "y", 24.0, {}),
    "odd/makehuman_walk1__zup_decimetre.bvh": ("mh_walk75", 0.1, "z", None, {}),
    "odd/fairmotion_pfnn_hierarchy__crlf_metres_static.bvh": ("pfnn31", 1.0, "y", None,
                                                               {"eol": "\r\n", "final_newline": False}),
    "odd/makehuman_tpose__173j_144six-channel.bvh": ("mh_tpose173", 0.1, "z", None, {}),
    "odd/makehuman_face_poseunits__163j.bvh": ("mh_face163", 0.1, "z", None, {}),
    "odd/fairmotion_sinusoidal__synthetic_no_endsite.bvh": ("sinusoidal", 1.0, "y", None,
                                                            {"final_newline": False, "values_tab": True}),
}
#: the odd/ folder's layouts (``_odd``)
ODD_LAYOUTS = frozenset({"max31_metres", "crouch19", "spec18", "blender19", "mh_walk75", "pfnn31", "mh_tpose173",
                         "mh_face163"})


def _standin_motion(kind: str, unit_m: float, up: str, fps: float | None) -> Motion:
    if kind == "sinusoidal":  # synthetic, written in its own frame
        return _sinusoidal()
    makers = {"dog": _dog, "flamingo": _flamingo}
    m = makers[kind]() if kind in makers else _odd(kind) if kind in ODD_LAYOUTS else _human(kind)
    m = _to_file_frame(m, unit_m, up, fps)
    return six_channels(m) if kind == "bandai" else m


@functools.cache
def standin_dir() -> Path:
    """The folder of every stand-in, written once per process (per xdist worker)."""
    root = Path(tempfile.mkdtemp(prefix="bipedsim-standins-"))
    atexit.register(shutil.rmtree, root, ignore_errors=True)
    for rel, (kind, unit_m, up, fps, quirks) in STANDINS.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(_text(_standin_motion(kind, unit_m, up, fps), **quirks))  # type: ignore[arg-type]
    return root


def standin(rel: str) -> Path | None:
    """The stand-in for the shared file ``rel`` (``human/NAME.bvh``), or None when there is none."""
    return standin_dir() / rel if rel in STANDINS else None


def standin_files(sub: str = "*") -> list[Path]:
    return sorted(standin_dir().glob(f"{sub}/*.bvh"))


if __name__ == "__main__":  # write them to a folder to look at: python tests/bvh_fixtures.py OUT
    import sys

    out = Path(sys.argv[1])
    shutil.copytree(standin_dir(), out, dirs_exist_ok=True)
    for p in sorted(out.rglob("*.bvh")):
        _, info = read_bvh(p)
        print(p.relative_to(out), info.num_frames, info.unit_name, info.up, info.line_endings,
              f"{os.path.getsize(p) // 1024} KiB")
