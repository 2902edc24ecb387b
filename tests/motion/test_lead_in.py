"""A T-pose or rest pose before the take (and the frames blending out of it) is dropped at reading,
found by measuring the clip: frame 0 lies several times the clip's own fast frame-to-frame change away
from every later frame. A clip whose first frame belongs to the take keeps it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from bipedsim.motion import read_bvh, write_bvh
from bipedsim.motion.gaitgen import WalkParams, generate_walk
from bipedsim.motion.lead_in import LEAD_IN_JUMP, lead_in_frames
from bipedsim.motion.motion import Motion, canonical_quat

#: frames per gait cycle of the generated walk at 120 fps (its cycle lasts 0.93 s)
CYCLE_120 = 112


def walk(fps_cycle: int = CYCLE_120) -> Motion:
    """2.3 cycles of the generated walk (m, Z up), from a tenth of a cycle in: it starts and ends
    mid-step at different phases, as a capture does (no loop)."""
    m = generate_walk(WalkParams(cycles=3, frames_per_cycle=fps_cycle))
    return m[fps_cycle // 10:fps_cycle // 10 + int(2.3 * fps_cycle)]


def t_pose(m: Motion) -> tuple[np.ndarray, np.ndarray]:
    """The rotations (J, 4) and root position (3,) of ``m``'s skeleton in a T-pose at the origin: every
    joint straight, the arms raised sideways."""
    sk = m.skeleton
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (sk.num_joints, 1))
    for side, sign in (("LeftArm", 1.0), ("RightArm", -1.0)):
        rot[sk.names.index(side)] = Rotation.from_euler("x", sign * 90, degrees=True).as_quat()
    return rot, np.array([0.0, 0.0, m.root_translation[0, 2]])


def with_lead_in(m: Motion, blend: int = 0) -> Motion:
    """``m`` after a T-pose frame at the world origin, and ``blend`` frames easing from it into ``m``'s
    first pose (a release that blends out of its T-pose)."""
    rot0, root0 = t_pose(m)
    s = np.arange(1, blend + 1) / (blend + 1)
    rots = [rot0[None]]
    if blend:
        per_joint = [Slerp([0.0, 1.0], Rotation.from_quat([rot0[j], m.rotations[0, j]]))(s).as_quat()
                     for j in range(m.num_joints)]
        rots.append(np.stack(per_joint, axis=1))
    rots.append(m.rotations)
    roots = [root0[None], root0 + s[:, None] * (m.root_translation[0] - root0), m.root_translation]
    return m.copy(rotations=canonical_quat(np.concatenate(rots)), root_translation=np.concatenate(roots))


def written(m: Motion, path: Path) -> Path:
    write_bvh(m.with_up("y").scaled(100.0), path)  # as most files are: Y up, centimetres
    return path


def test_a_t_pose_first_frame_is_dropped_at_reading(tmp_path: Path) -> None:
    w = walk()
    path = written(with_lead_in(w), tmp_path / "tpose.bvh")
    m, info = read_bvh(path)
    assert info.lead_in_frames == 1 and info.num_frames == m.num_frames == w.num_frames
    note = next(n for n in info.notes if n.startswith("lead-in:"))
    assert note.startswith(f"lead-in: frame 0 of {w.num_frames + 1} dropped") and "T-pose" in note
    np.testing.assert_allclose(m.to_project_frame().fk()[0], w.fk()[0], atol=1e-6)  # the walk as it was
    whole, info_all = read_bvh(path, lead_in=False)
    assert whole.num_frames == w.num_frames + 1 and info_all.lead_in_frames == 0
    assert not any(n.startswith("lead-in:") for n in info_all.notes)


def test_frames_blending_out_of_a_t_pose_are_dropped_with_it(tmp_path: Path) -> None:
    """CMU's Daz release eases out of its T-pose over 4 frames at 120 fps: all of them go."""
    w = walk()
    m, info = read_bvh(written(with_lead_in(w, blend=3), tmp_path / "blend.bvh"))
    assert info.lead_in_frames == 4 and m.num_frames == w.num_frames
    assert "frames 0-3 of" in next(n for n in info.notes if n.startswith("lead-in:"))


def test_a_take_keeps_its_first_frame() -> None:
    """A walk from any phase, at 30 to 120 fps, and a walk whose first frame is a little off (a
    capture's jitter: a few times a frame's change) keep every frame."""
    for cycle in (28, 56, CYCLE_120):
        for start in (0, cycle // 3, cycle // 2):
            m = generate_walk(WalkParams(cycles=2, frames_per_cycle=cycle))[start:]
            assert lead_in_frames(m)[0] == 0, (cycle, start)
    m = walk()
    rots = m.rotations.copy()
    knee = m.skeleton.names.index("LeftLeg")
    rots[0, knee] = (Rotation.from_euler("y", 0.05) * Rotation.from_quat(rots[0, knee])).as_quat()
    assert lead_in_frames(m.copy(rotations=canonical_quat(rots)))[0] == 0


def test_the_jump_is_measured_against_the_clips_own_changes() -> None:
    """The same T-pose is a lead-in before a slow clip and before a fast one alike (the threshold is the
    clip's fast change, not a fixed angle): a walk played at a quarter of its frame rate (four times the
    change per frame) still loses it, and the first frame's distance is said."""
    for cycle in (28, CYCLE_120):
        n, first, fast = lead_in_frames(with_lead_in(walk(cycle)))
        assert n == 1 and first > LEAD_IN_JUMP * fast


def test_resampling_ends_on_the_clip_s_last_frame() -> None:
    """A new frame rate whose last frame time lands a rounding step past the clip's end samples the end
    (it used to raise in the rotations' interpolation)."""
    from bipedsim.motion.gaitgen import generate_walk

    m = generate_walk().resample(60.0)[:185]
    out = m.resample(120.0)
    assert out.duration <= m.duration + 1e-9
    assert np.allclose(out.root_translation[-1], m.root_translation[-1], atol=1e-6)
