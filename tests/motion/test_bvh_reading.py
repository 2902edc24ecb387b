"""Reading real files right: position-channel mode, up axis and unit chosen together by a
plausible body; root-on-a-child layouts; skeletons whose identity pose is no body."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_BVH, need_shared

from bipedsim.cli import main
from bipedsim.errors import BVHError
from bipedsim.model import build_model
from bipedsim.motion import read_bvh
from bipedsim.motion.conventions import score_reading
from bipedsim.motion.rest import standing_rest
from bipedsim.reference import describe_bvh

BANDAI = "human/bandai2_walk_exhausted_001.bvh"


def shared_dir() -> Path:
    need_shared()
    return SHARED_BVH


def test_root_on_a_child_walk_reads_upright_in_cm_and_travels_horizontally() -> None:
    """The Bandai walk: a static root at the floor, the hips' absolute position channels beside an
    OFFSET at the start pose. Read Y up, cm, about 1.6 m standing, walking ~9.5 m along the floor."""
    d = describe_bvh(shared_dir() / BANDAI)
    assert d["up"] == "y" and d["unit_name"] == "cm"
    assert d["position_channels"]["Hips"] == "replace"
    assert 1.5 <= d["standing_height_m"] <= 1.9
    assert 9.0 <= d["root_displacement_m"] <= 10.0
    assert 0.9 <= d["root_speed_mps"] <= 1.1


def test_the_chosen_reading_beats_the_misreadings() -> None:
    motion, info = read_bvh(shared_dir() / BANDAI)
    sk = motion.skeleton
    pos = motion.fk()[0][::10]
    right, wrong = score_reading(sk.names, sk.parents, pos, "y"), score_reading(sk.names, sk.parents, pos, "z")
    assert right is not None and wrong is not None
    assert right.score + 1.0 < wrong.score
    assert 0.7 < right.hip_ratio < 1.1 and right.vertical_travel < 0.05
    assert "most plausible reading" in info.up_reason


def test_forced_readings_are_obeyed_and_checked(tmp_path: Path) -> None:
    m, info = read_bvh(shared_dir() / BANDAI, positions="offset", up="y")
    assert info.position_channels["Hips"] == "add" and info.up_source == "given"
    with pytest.raises(BVHError, match="position mode must be one of absolute, offset"):
        read_bvh(shared_dir() / BANDAI, positions="relative")
    assert main(["info", str(shared_dir() / BANDAI), "--positions", "absolute", "--json"]) == 0


def test_rebased_rest_pose_keeps_every_frame_and_builds_a_standing_humanoid() -> None:
    motion = read_bvh(shared_dir() / BANDAI)[0].to_project_frame()
    standing = standing_rest(motion)
    assert standing is not motion  # bone-aligned joint frames: the identity pose lies along +X
    assert np.abs(motion.fk()[0] - standing.fk()[0]).max() < 1e-9
    assert np.abs(motion.end_site_positions() - standing.end_site_positions()).max() < 1e-9
    assert 1.2 < build_model(standing).summary()["height_m"] < 2.0
    cmu = read_bvh(shared_dir() / "human/cmu_02_01_walk__holden31_crlf.bvh")[0].to_project_frame()
    assert standing_rest(cmu) is cmu  # a standing rest pose is kept


def test_a_head_joint_on_the_neck_does_not_stop_the_build(tmp_path: Path) -> None:
    """A zero-length head (the head joint on the neck, a zero End Site) takes the farthest head point."""
    text = (shared_dir() / BANDAI).read_text().replace("OFFSET 6.45672 0.0 0.0", "OFFSET 0.0 0.0 0.0")
    f = tmp_path / "headless.bvh"
    f.write_text(text)
    motion = standing_rest(read_bvh(f)[0].to_project_frame())
    assert build_model(motion).summary()["bodies"] >= 10


def test_rebased_limbs_rest_straight_so_the_walk_stays_within_the_knee_range() -> None:
    """Each leg and arm of a rebased skeleton rests as it is straightest: the retargeted knees and
    elbows stay within their ranges (from a bent rest knee they were 1.15 rad beyond)."""
    from bipedsim.control.humanoid.sources import Hinges
    from bipedsim.reference import retarget

    m = standing_rest(read_bvh(shared_dir() / BANDAI)[0].to_project_frame())
    b = build_model(m)
    clip = retarget(m, b.model, plan=b.plan, xml=b.xml)
    h = Hinges.of(b.model, b.plan)
    for k, name in enumerate(h.names):
        if name.endswith(("_knee", "_elbow")):
            lo, hi = b.model.jnt_range[h.jid[k]]
            q = clip.qpos[:, h.qadr[k]]
            assert q.min() > lo - 0.05 and q.max() < hi + 0.05, (name, q.min(), q.max(), lo, hi)


def test_info_reads_a_creature_as_run_builds_it() -> None:
    """``bipedsim info`` and ``bipedsim run`` agree on a creature's unit: the flamingo (an upright bird
    whose unit is guessed) is read from its largest extent in both, not as an inch-sized human in info
    and a centimetre bird in run; info names the body kind it measured."""
    from bipedsim.sim.runner import load_scenario

    need_shared()
    path = SHARED_BVH / "animal" / "truebones_flamingo_walk_inplace.bvh"
    d = describe_bvh(path)
    sc = load_scenario(bvh=path)
    assert d["body"] == sc.profile == "creature"
    assert d["unit_name"] == sc.bvh_info.unit_name and d["unit_scale"] == sc.bvh_info.unit_scale
    human = describe_bvh(SHARED_BVH / "human" / "cmu_02_01_walk__holden31_crlf.bvh")
    assert human["body"] == "humanoid"


# ---------------------------------------------------------------------- the frame rate
def test_a_given_frame_rate_replaces_the_file_s_frame_time_and_is_checked(tmp_path: Path) -> None:
    """``fps`` (``--clip-fps``) sets the capture's rate for a file whose Frame Time is not it: every frame
    kept, the time between them changed, the file's own Frame Time recorded beside it."""
    from bipedsim.data import builtin_walk_path

    path = builtin_walk_path()
    m0, i0 = read_bvh(path)
    m1, i1 = read_bvh(path, fps=i0.fps / 2)
    assert i0.frame_time_source == "file" and i1.frame_time_source == "given"
    assert i1.file_frame_time == pytest.approx(i0.frame_time)
    assert m1.frame_time == pytest.approx(2 * m0.frame_time) and i1.frame_time == pytest.approx(2 * i0.frame_time)
    assert m1.num_frames == m0.num_frames
    assert np.allclose(m1.rotations, m0.rotations) and np.allclose(m1.root_translation, m0.root_translation)
    for bad in (0.0, -30.0, float("nan"), 1e6):
        with pytest.raises(BVHError, match="frame rate .* is not plausible: give 1 to 10000 frames per second"):
            read_bvh(path, fps=bad)


def test_a_clip_faster_than_a_walk_says_so_and_names_the_flag() -> None:
    """A walk read at three times its rate moves at Froude 0.8, where people run: ``describe_bvh`` says so
    (the Froude number from its own speed and hip height) and names ``--clip-fps``; at its own rate, or
    given its rate back, it says nothing."""
    from bipedsim.data import builtin_walk_path
    from bipedsim.motion.conventions import HIP_PER_STATURE
    from bipedsim.reference.describe import GRAVITY, WALK_FROUDE_MAX

    path = builtin_walk_path()
    d0 = describe_bvh(path)
    assert "pace_note" not in d0
    fast = describe_bvh(path, fps=3 * d0["fps"])
    v = fast["root_speed_mps"]
    assert v == pytest.approx(3 * d0["root_speed_mps"], rel=1e-6)
    fr = v ** 2 / (GRAVITY * fast["standing_height_m"] * HIP_PER_STATURE)
    assert fr > WALK_FROUDE_MAX
    note = fast["pace_note"]
    assert f"Froude {fr:.2f}" in note and "--clip-fps" in note and f"at {1.5 * d0['fps']:.4g} fps" in note
    assert "given" in note  # the rate it was read at is named as the caller's


def test_no_shared_walk_is_faster_than_a_walk_but_the_makehuman_cycle_is() -> None:
    """Every shared human walk reads below Froude 0.5; the MakeHuman walk cycle, whose 14 frames at its
    header's 24 fps make a 2.9 m/s stride, is flagged, and read at 12 fps it is not."""
    need_shared()
    for f in sorted((SHARED_BVH / "human").glob("*.bvh")):
        assert "pace_note" not in describe_bvh(f), f.name
    mh = SHARED_BVH / "odd" / "makehuman_walk1__zup_decimetre.bvh"
    d = describe_bvh(mh)
    assert "Froude 0.89" in d["pace_note"] and "the file's Frame Time 0.041667 s" in d["pace_note"]
    assert "pace_note" not in describe_bvh(mh, fps=12)


def test_clip_fps_on_the_command_line(capsys, tmp_path: Path) -> None:
    """``bipedsim info --clip-fps`` prints the rate as given; a rate out of range, or one without a
    ``--bvh`` file to apply to, exits 2 naming what is allowed."""
    need_shared()
    mh = str(SHARED_BVH / "odd" / "makehuman_walk1__zup_decimetre.bvh")
    assert main(["info", mh, "--clip-fps", "12"]) == 0
    out = capsys.readouterr().out
    assert "14 at 12 fps (frame time 0.0833333 s, given; the file's 0.041667 s)" in out and "pace" not in out
    assert main(["info", mh]) == 0
    assert "pace        the clip moves at 2.86 m/s" in capsys.readouterr().out
    assert main(["info", mh, "--clip-fps", "0"]) == 2
    err = capsys.readouterr().err
    assert "frame rate 0.0 is not plausible: give 1 to 10000 frames per second" in err and "Traceback" not in err
    assert main(["run", "--clip-fps", "12", "--seconds", "0.1", "--out", str(tmp_path / "r")]) == 2
    assert "--clip-fps: sets the frame rate of a --bvh file" in capsys.readouterr().err


def test_run_prints_the_pace_and_records_the_rate_it_read(capsys, tmp_path: Path) -> None:
    """``bipedsim run --bvh`` prints the pace line for a clip faster than a walk, and ``outcome.json``
    records how the file was read (unit, up axis, frame rate and where each came from)."""
    import json

    need_shared()
    mh = str(SHARED_BVH / "odd" / "makehuman_walk1__zup_decimetre.bvh")
    assert main(["run", "--bvh", mh, "--seconds", "0.1", "--out", str(tmp_path / "a")]) == 0
    assert "pace: the clip moves at 2.73 m/s" in capsys.readouterr().out
    assert main(["run", "--bvh", mh, "--clip-fps", "12", "--seconds", "0.1", "--out", str(tmp_path / "b")]) == 0
    assert "pace:" not in capsys.readouterr().out
    a = json.loads((tmp_path / "a" / "outcome.json").read_text())["config"]["reading"]
    b = json.loads((tmp_path / "b" / "outcome.json").read_text())["config"]["reading"]
    assert a["fps"] == pytest.approx(24.0, rel=1e-4) and a["fps_source"] == "file"
    assert b["fps"] == pytest.approx(12.0) and b["fps_source"] == "given"
    assert a["unit_m_per_unit"] == b["unit_m_per_unit"] == pytest.approx(0.1) and a["up"] == "z"
