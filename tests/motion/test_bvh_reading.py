"""Reading real files right: position-channel mode, up axis and unit chosen together by a
plausible body; root-on-a-child layouts; skeletons whose identity pose is no body."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import HAVE_SHARED, shared_files, shared_or_standin
from motion_standins import fast_cycle, root_on_a_child

from bipedsim.cli import main
from bipedsim.errors import BVHError
from bipedsim.model import build_model
from bipedsim.motion import read_bvh
from bipedsim.motion.conventions import score_reading
from bipedsim.motion.rest import standing_rest
from bipedsim.reference import describe_bvh

BANDAI = "human/bandai2_walk_exhausted_001.bvh"
MAKEHUMAN_CYCLE = "odd/makehuman_walk1__zup_decimetre.bvh"


@pytest.fixture(scope="module")
def bandai(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Bandai-Namco's exhausted walk: the real take, or without ``../shared`` its stand-in laid out as
    the take is (a static root at the floor, the hips' absolute position channels beside an OFFSET at
    the start pose)."""
    src = shared_or_standin(BANDAI)
    return src if HAVE_SHARED else root_on_a_child(src, tmp_path_factory.mktemp("bandai") / src.name)


@pytest.fixture(scope="module")
def makehuman_cycle(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, float, float]:
    """MakeHuman's walk cycle, whose header's frame rate makes it stride faster than people walk, that
    rate (fps, to 0.1) and its Frame Time (s): the real file at 24 fps, or without ``../shared`` its
    stand-in at twice its rate."""
    src = shared_or_standin(MAKEHUMAN_CYCLE)
    if not HAVE_SHARED:
        src = fast_cycle(src, tmp_path_factory.mktemp("makehuman") / src.name)
    info = read_bvh(src)[1]
    return src, round(info.fps, 1), info.file_frame_time


def test_root_on_a_child_walk_reads_upright_in_cm_and_travels_horizontally(bandai: Path) -> None:
    """The Bandai walk: a static root at the floor, the hips' absolute position channels beside an
    OFFSET at the start pose. Read Y up, cm, about 1.6 m standing, walking along the floor in a line
    (the real take ~9.5 m)."""
    assert read_bvh(bandai)[0].skeleton.names[:2] == ("joint_Root", "Hips")
    d = describe_bvh(bandai)
    assert d["up"] == "y" and d["unit_name"] == "cm"
    assert d["position_channels"]["Hips"] == "replace" and "absolute" in d["position_mode_reasons"]["Hips"]
    assert 1.5 <= d["standing_height_m"] <= 1.9
    assert d["root_displacement_m"] >= 0.95 * d["root_path_m"]  # along a line
    assert 0.9 <= d["root_speed_mps"] <= 1.1
    if HAVE_SHARED:  # the real take's own travel
        assert 9.0 <= d["root_displacement_m"] <= 10.0


def test_the_chosen_reading_beats_the_misreadings(bandai: Path) -> None:
    motion, info = read_bvh(bandai)
    sk = motion.skeleton
    pos = motion.fk()[0][::10]
    right, wrong = score_reading(sk.names, sk.parents, pos, "y"), score_reading(sk.names, sk.parents, pos, "z")
    assert right is not None and wrong is not None
    assert right.score + 1.0 < wrong.score
    assert 0.7 < right.hip_ratio < 1.1 and right.vertical_travel < 0.05
    assert "most plausible reading" in info.up_reason


def test_forced_readings_are_obeyed_and_checked(bandai: Path) -> None:
    m, info = read_bvh(bandai, positions="offset", up="y")
    assert info.position_channels["Hips"] == "add" and info.up_source == "given"
    with pytest.raises(BVHError, match="position mode must be one of absolute, offset"):
        read_bvh(bandai, positions="relative")
    assert main(["info", str(bandai), "--positions", "absolute", "--json"]) == 0


def test_rebased_rest_pose_keeps_every_frame_and_builds_a_standing_humanoid(bandai: Path) -> None:
    motion = read_bvh(bandai)[0].to_project_frame()
    standing = standing_rest(motion)
    assert standing is not motion  # bone-aligned joint frames: the identity pose lies along +X
    assert np.abs(motion.fk()[0] - standing.fk()[0]).max() < 1e-9
    assert np.abs(motion.end_site_positions() - standing.end_site_positions()).max() < 1e-9
    assert 1.2 < build_model(standing).summary()["height_m"] < 2.0
    cmu = read_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))[0].to_project_frame()
    assert standing_rest(cmu) is cmu  # a standing rest pose is kept


def _head_on_the_neck(text: str) -> str:
    """The BVH ``text`` with the OFFSETs of the joint ``Head`` and of its End Site zero (CRLF kept)."""
    lines = text.split("\n")
    head = next(i for i, ln in enumerate(lines) if ln.split() == ["JOINT", "Head"])
    site = next(i for i in range(head, len(lines)) if lines[i].split()[:2] == ["End", "Site"])
    for i in (head + 2, site + 2):
        assert lines[i].split()[0] == "OFFSET", lines[i]
        lines[i] = re.sub(r"OFFSET[^\r]*", "OFFSET 0.0 0.0 0.0", lines[i])
    return "\n".join(lines)


def test_a_head_joint_on_the_neck_does_not_stop_the_build(bandai: Path, tmp_path: Path) -> None:
    """A zero-length head (the head joint on the neck, a zero End Site) takes the farthest head point."""
    text = _head_on_the_neck(bandai.read_text())
    f = tmp_path / "headless.bvh"
    f.write_text(text)
    m = read_bvh(f)[0]
    assert not m.skeleton.offsets[m.skeleton.index("Head")].any()
    motion = standing_rest(m.to_project_frame())
    assert build_model(motion).summary()["bodies"] >= 10


def test_rebased_limbs_rest_straight_so_the_walk_stays_within_the_knee_range(bandai: Path) -> None:
    """Each leg and arm of a rebased skeleton rests as it is straightest: the retargeted knees and
    elbows stay within their ranges (from a bent rest knee they were 1.15 rad beyond)."""
    from bipedsim.control.humanoid.sources import Hinges
    from bipedsim.reference import retarget

    m = standing_rest(read_bvh(bandai)[0].to_project_frame())
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

    path = shared_or_standin("animal/truebones_flamingo_walk_inplace.bvh")
    d = describe_bvh(path)
    sc = load_scenario(bvh=path)
    assert d["body"] == sc.profile == "creature"
    assert d["unit_name"] == sc.bvh_info.unit_name and d["unit_scale"] == sc.bvh_info.unit_scale
    human = describe_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))
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


def test_no_shared_walk_is_faster_than_a_walk_but_the_makehuman_cycle_is(makehuman_cycle) -> None:
    """Every shared human walk reads below Froude 0.5; the MakeHuman walk cycle, whose 14 frames at its
    header's rate make a 2.9 m/s stride (the real file's 24 fps), is flagged, and read at half the rate
    it is not."""
    for f in shared_files("human"):
        assert "pace_note" not in describe_bvh(f), f.name
    mh, fps, frame_time = makehuman_cycle
    d = describe_bvh(mh)
    assert d["pace_note"].startswith(f"the clip moves at {d['walked_speed_mps']:.2f} m/s")
    assert f"the file's Frame Time {frame_time:.6g} s" in d["pace_note"]
    assert 2.5 < d["walked_speed_mps"] < 3.2  # a person's stride played this fast
    if HAVE_SHARED:
        assert "Froude 0.89" in d["pace_note"]
    assert "pace_note" not in describe_bvh(mh, fps=fps / 2)


def test_clip_fps_on_the_command_line(capsys, tmp_path: Path, makehuman_cycle) -> None:
    """``bipedsim info --clip-fps`` prints the rate as given; a rate out of range, or one without a
    ``--bvh`` file to apply to, exits 2 naming what is allowed."""
    path, fps, frame_time = makehuman_cycle
    mh = str(path)
    assert main(["info", mh, "--clip-fps", f"{fps / 2:g}"]) == 0
    out = capsys.readouterr().out
    assert (f"14 at {fps / 2:g} fps (frame time {2 / fps:.6g} s, given; the file's {frame_time:.6g} s)" in out
            and "pace" not in out)
    assert main(["info", mh]) == 0
    pace = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("pace "))
    assert pace.startswith(f"pace        the clip moves at {describe_bvh(mh)['walked_speed_mps']:.2f} m/s")
    if HAVE_SHARED:
        assert pace.startswith("pace        the clip moves at 2.86 m/s")
    assert main(["info", mh, "--clip-fps", "0"]) == 2
    err = capsys.readouterr().err
    assert "frame rate 0.0 is not plausible: give 1 to 10000 frames per second" in err and "Traceback" not in err
    assert main(["run", "--clip-fps", "12", "--seconds", "0.1", "--out", str(tmp_path / "r")]) == 2
    assert "--clip-fps: sets the frame rate of a --bvh file" in capsys.readouterr().err


def test_run_prints_the_pace_and_records_the_rate_it_read(capsys, tmp_path: Path, makehuman_cycle) -> None:
    """``bipedsim run --bvh`` prints the pace line for a clip faster than a walk, and ``outcome.json``
    records how the file was read (unit, up axis, frame rate and where each came from)."""
    import json

    path, fps, _ = makehuman_cycle
    mh = str(path)
    assert main(["run", "--bvh", mh, "--seconds", "0.1", "--out", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "pace: the clip moves at " in out
    if HAVE_SHARED:
        assert "pace: the clip moves at 2.73 m/s" in out
    half = f"{fps / 2:g}"
    assert main(["run", "--bvh", mh, "--clip-fps", half, "--seconds", "0.1", "--out", str(tmp_path / "b")]) == 0
    assert "pace:" not in capsys.readouterr().out
    a = json.loads((tmp_path / "a" / "outcome.json").read_text())["config"]["reading"]
    b = json.loads((tmp_path / "b" / "outcome.json").read_text())["config"]["reading"]
    assert a["fps"] == pytest.approx(fps, rel=1e-4) and a["fps_source"] == "file"
    assert b["fps"] == pytest.approx(fps / 2) and b["fps_source"] == "given"
    assert a["unit_m_per_unit"] == b["unit_m_per_unit"] == pytest.approx(0.1) and a["up"] == "z"
