"""A clip that is one walk cycle (a game animation's: in place or travelling, 24 or 30 fps, its last
frame repeating its first or leading into it) loops without ``--events``: the motion is repeated before
the body is built (``reference.prepare.repeat_loop``), and a reference clip of one cycle loops whole
(``control.humanoid.cycles.loop_cycle``, strikes read on the wrapped clip)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bipedsim.control.humanoid.cycles import best_cycle, clip_cycle, clip_period, describe_clip
from bipedsim.control.humanoid.hinges import Hinges
from bipedsim.model import build_model
from bipedsim.motion import write_bvh
from bipedsim.motion.gaitgen import WalkParams, generate_walk
from bipedsim.motion.motion import Motion
from bipedsim.reference.gait_events import cyclic_strikes
from bipedsim.reference.prepare import repeat_loop
from bipedsim.reference.retarget import retarget

#: where the cut starts in the generated walk (frames): mid-swing, not at a strike
START = 5


def walk(fps: int, cycles: int = 5) -> Motion:
    """The generated walk at ``fps`` frames per second, a cycle lasting 1 s (120 steps a minute)."""
    return generate_walk(WalkParams(cadence=120.0, frames_per_cycle=fps, cycles=cycles))


def one_cycle(fps: int, closed: bool, in_place: bool = False) -> Motion:
    """One cycle cut from the walk: ``fps`` + 1 frames whose last repeats the first (``closed``) or
    ``fps`` frames whose last leads into the first; ``in_place``: its root's travel taken out."""
    m = walk(fps)[START:START + fps + int(closed)]
    if in_place:
        root = m.root_translation.copy()
        t = np.arange(m.num_frames) / (m.num_frames - 1)
        root[:, :2] -= t[:, None] * (root[-1, :2] - root[0, :2])
        m = m.copy(root_translation=root)
    return m


def _joints(m: Motion) -> np.ndarray:
    pos = m.fk()[0]
    return pos - pos[:1, :1]  # from the first frame's root


@pytest.mark.parametrize("fps", [24, 30])
@pytest.mark.parametrize("closed", [True, False], ids=["last-repeats-first", "last-leads-into-first"])
def test_a_walk_cycle_is_repeated_as_the_walk_it_was_cut_from(fps: int, closed: bool) -> None:
    """Repeated, the cycle is the walk it was cut from, to a millimetre: its period is all its frames
    (the last one too where it leads into the first; a cycle one frame short would drift by a frame a
    loop)."""
    notes: list[str] = []
    out = repeat_loop(one_cycle(fps, closed), notes)
    assert notes and notes[0].startswith("a loop:")
    said = "the clip ends in the pose it starts with" if closed else "its last frame leads into its first"
    assert said in notes[0] and f"a cycle of {fps})" in notes[0]
    ref = walk(fps)[START:START + out.num_frames]
    assert np.abs(_joints(out) - _joints(ref)).max() < 1e-3


def test_a_clip_that_is_no_loop_is_left_as_it_is() -> None:
    for frames in (13, 20, 40):  # a half, two thirds and four thirds of a cycle
        m = walk(30)[START:START + frames]
        assert repeat_loop(m) is m, frames


def test_a_one_cycle_game_walk_with_a_t_pose_builds_a_looping_reference(tmp_path: Path) -> None:
    """A 31-frame walk cycle in place at 30 fps whose first frame is a T-pose (as a Mixamo export gives
    it): the T-pose is dropped at reading, the cycle repeated, its travel rebuilt from its feet, and the
    reference has a gait cycle to loop; it had been refused without ``--events``."""
    import sys

    from bipedsim.reference.prepare import load_source

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "motion"))
    from test_lead_in import with_lead_in, written

    path = written(with_lead_in(one_cycle(30, closed=False, in_place=True)), tmp_path / "cycle.bvh")
    _, info, motion, kind = load_source(path)  # as `bipedsim run` reads it
    assert [n.split(":")[0] for n in info.notes] == ["lead-in", "a loop", "walks in place"], info.notes
    built = build_model(motion, kind)
    clip = retarget(motion, built.model, plan=built.plan)
    assert all(len(clip.events[f]["strike"]) >= 2 for f in ("left", "right"))
    c = clip_cycle(clip, built.model, built.plan)
    assert c is not None and not c.whole and round((c.b - c.a) * clip.frame_time, 2) in (1.0, 2.0)


def test_cyclic_strikes_count_a_strike_at_the_wrap() -> None:
    down = np.array([[1, 0], [1, 0], [0, 0], [0, 1], [0, 1], [0, 0]], dtype=bool)
    assert cyclic_strikes(down) == [[0], [3]]
    assert cyclic_strikes(np.roll(down, -1, axis=0)) == [[5], [2]]  # frame 0 continues the stance: none there
    assert cyclic_strikes(np.ones((4, 1), dtype=bool)) == [[]]


def test_clip_period_tells_a_loop_and_its_seam() -> None:
    def hinge_angles(m: Motion) -> np.ndarray:
        from scipy.spatial.transform import Rotation

        return Rotation.from_quat(m.rotations.reshape(-1, 4)).as_rotvec().reshape(m.num_frames, -1)

    for fps in (24, 30):
        assert clip_period(hinge_angles(one_cycle(fps, closed=True)), 1.0 / fps) == fps
        assert clip_period(hinge_angles(one_cycle(fps, closed=False)), 1.0 / fps) == fps
        assert clip_period(hinge_angles(walk(fps)[START:START + fps * 4 // 3]), 1.0 / fps) is None
    assert clip_period(np.zeros((30, 4)), 1.0 / 30) is None  # a clip that holds still is no loop


@pytest.mark.parametrize("closed", [True, False], ids=["last-repeats-first", "last-leads-into-first"])
def test_a_reference_clip_of_one_cycle_loops_whole(closed: bool) -> None:
    """Retargeted as it is (one strike per foot), a travelling walk cycle has no loop from strike to
    strike; its cycle is the whole clip, starting in the stance of the foot that struck last before the
    loop wraps (the right foot: the cut starts mid-step after the right strike)."""
    m = one_cycle(24, closed)
    built = build_model(m, "humanoid")
    clip = retarget(m, built.model, plan=built.plan)
    rs, ls = clip.events["right"]["strike"], clip.events["left"]["strike"]
    assert len(rs) == len(ls) == 1
    h = Hinges.of(built.model, built.plan)
    args = (clip.qpos[:, h.qadr], clip.qvel[:, h.dadr], clip.qpos[:, :2])
    assert best_cycle(*args, rs, ls, clip.frame_time) is None and best_cycle(*args, ls, rs, clip.frame_time) is None
    c = clip_cycle(clip, built.model, built.plan)
    assert c is not None and c.whole and (c.a, c.b) == (0, clip.num_frames - 1)
    assert c.foot == "right" and c.alternates and c.step_balance > 0.9
    assert any("the whole clip, one loop of a walk" in line for line in describe_clip(clip, built.model, built.plan))


def test_one_cycle_clip_written_and_read_loops(tmp_path: Path) -> None:
    """The cycle written as most files are (Y up, cm) reads back and loops the same way."""
    from bipedsim.reference.prepare import load_source

    path = tmp_path / "cycle24.bvh"
    write_bvh(one_cycle(24, closed=False).with_up("y").scaled(100.0), path)
    _, info, motion, _ = load_source(path)
    assert any("its last frame leads into its first (24 frames, a cycle of 24)" in n for n in info.notes)
    assert motion.duration >= 2.9
