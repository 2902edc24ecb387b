"""Rig helpers (IK targets and poles, placeholders, twist bones) found by measuring the clip, and left
out of a creature's body; names alone never remove a bone."""

from __future__ import annotations

import numpy as np

from bipedsim.model.creature_kind import detect_body_kind
from bipedsim.motion.helper_bones import drop_helper_bones, find_helper_bones, without_joints
from bipedsim.motion.motion import Motion
from bipedsim.motion.samples import horse_walk
from bipedsim.motion.skeleton import Skeleton

POS = ("Xposition", "Yposition", "Zposition")
ROT = ("Zrotation", "Yrotation", "Xrotation")


def rigged(m: Motion, helpers: dict[str, tuple[str, np.ndarray | None, np.ndarray]]) -> Motion:
    """``m`` (project frame) with helper joints appended: name -> (parent, world positions (T, 3) it
    follows by its own translation, or None: a fixed bone, its offset)."""
    sk = m.skeleton
    pos, rot = m.fk()
    names, parents, offsets = list(sk.names), list(sk.parents), list(sk.offsets)
    channels, trans = list(sk.channels), m.local_translations()
    extra_t = []
    for name, (parent, follow, off) in helpers.items():
        p = sk.index(parent)
        names.append(name)
        parents.append(p)
        offsets.append(off)
        if follow is None:
            channels.append(ROT)
            extra_t.append(np.broadcast_to(off, (m.num_frames, 3)))
        else:
            channels.append(POS + ROT)
            extra_t.append(np.einsum("tji,tj->ti", rot[:, p], follow - pos[:, p]))  # in the parent's frame
    new_sk = Skeleton(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets),
                      channels=tuple(channels), end_site_parents=sk.end_site_parents,
                      end_site_offsets=sk.end_site_offsets)
    q = np.concatenate([m.rotations, np.tile([0.0, 0.0, 0.0, 1.0], (m.num_frames, len(helpers), 1))], axis=1)
    t = np.concatenate([trans, np.stack(extra_t, axis=1)], axis=1)
    return Motion(skeleton=new_sk, frame_time=m.frame_time, root_translation=m.root_translation, rotations=q,
                  translations=t, unit=m.unit, up=m.up)


def _horse_rig() -> tuple[Motion, Motion]:
    horse = horse_walk(cycles=1).to_project_frame()
    pos, _ = horse.fk()
    sk = horse.skeleton
    foot, knee = pos[:, sk.index("LeftFoot")], pos[:, sk.index("LeftLeg")]
    return horse, rigged(horse, {
        "IK_Foot_L": ("Hips", foot, np.zeros(3)),  # an IK target on the hoof, animated by translation
        "Pole_Knee_L": ("Hips", knee + [0.4, 0.0, 0.0], np.zeros(3)),  # a pole in front of the knee
        "ZeroOut": ("Hips", None, np.zeros(3)),  # a zero-length placeholder that never moves
        "Armature_Ctrl": ("Hips", None, np.array([0.0, 0.0, 0.05])),  # a still bone named as a control
    })


def test_ik_targets_poles_and_placeholders_are_found_and_dropped() -> None:
    horse, rig = _horse_rig()
    found = find_helper_bones(rig)
    assert found.names == {"IK_Foot_L", "Pole_Knee_L", "ZeroOut", "Armature_Ctrl"}, found.describe()
    body, _ = drop_helper_bones(rig)
    assert body.skeleton.names == horse.skeleton.names
    assert np.abs(body.fk()[0] - horse.fk()[0]).max() < 1e-9  # the body's joints where they were
    assert len(detect_body_kind(body).legs) == 4


def test_names_alone_never_remove_a_bone() -> None:
    """A still bone without a helper's name (a stiff head) stays, and so does a moving bone with one."""
    horse = horse_walk(cycles=1).to_project_frame()
    still = rigged(horse, {"Horn": ("Hips", None, np.array([0.0, 0.0, 0.05]))})
    assert find_helper_bones(still).names == set()
    renamed = horse.copy(skeleton=horse.skeleton.replace(
        names=tuple("LeftLegTwist" if n == "LeftLeg" else n for n in horse.skeleton.names)))
    assert find_helper_bones(renamed).names == set()
    assert find_helper_bones(horse).names == set()


def test_without_joints_keeps_the_rest() -> None:
    horse = horse_walk(cycles=1).to_project_frame()
    less = without_joints(horse, {"Neck"})
    assert "Neck" not in less.skeleton.names and "Head" not in less.skeleton.names
    keep = [horse.skeleton.index(n) for n in less.skeleton.names]
    assert np.abs(less.fk()[0] - horse.fk()[0][:, keep]).max() < 1e-9


def test_a_rig_file_is_read_without_its_helpers(tmp_path) -> None:
    """``read_source`` (what ``bipedsim run`` reads) leaves the helpers out and says so in the notes."""
    from bipedsim.model.creature_kind import read_source
    from bipedsim.motion.bvh import write_bvh

    horse, rig = _horse_rig()
    path = tmp_path / "rig.bvh"
    write_bvh(rig.with_up("y").scaled(100.0), path, precision=6)
    raw, info, motion, kind = read_source(path, scale="cm")
    assert kind == "creature" and sorted(motion.skeleton.names) == sorted(horse.skeleton.names)
    assert any("rig helpers left out" in n for n in info.notes)
