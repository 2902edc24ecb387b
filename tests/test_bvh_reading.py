"""Reading real files right (issue 19): position-channel mode, up axis and unit chosen together by a
plausible body; root-on-a-child layouts; skeletons whose identity pose is no body."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_BVH, need_shared

from bipedsim.cli import main
from bipedsim.errors import BVHError
from bipedsim.model import build_model
from bipedsim.motion import describe_bvh, read_bvh
from bipedsim.motion.conventions import score_reading

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
    standing = motion.with_standing_rest()
    assert standing is not motion  # bone-aligned joint frames: the identity pose lies along +X
    assert np.abs(motion.fk()[0] - standing.fk()[0]).max() < 1e-9
    assert np.abs(motion.end_site_positions() - standing.end_site_positions()).max() < 1e-9
    assert 1.2 < build_model(standing).summary()["height_m"] < 2.0
    cmu = read_bvh(shared_dir() / "human/cmu_02_01_walk__holden31_crlf.bvh")[0].to_project_frame()
    assert cmu.with_standing_rest() is cmu  # a standing rest pose is kept


def test_a_head_joint_on_the_neck_does_not_stop_the_build(tmp_path: Path) -> None:
    """A zero-length head (the head joint on the neck, a zero End Site) takes the farthest head point."""
    text = (shared_dir() / BANDAI).read_text().replace("OFFSET 6.45672 0.0 0.0", "OFFSET 0.0 0.0 0.0")
    f = tmp_path / "headless.bvh"
    f.write_text(text)
    motion = read_bvh(f)[0].to_project_frame().with_standing_rest()
    assert build_model(motion).summary()["bodies"] >= 10


def test_rebased_limbs_rest_straight_so_the_walk_stays_within_the_knee_range() -> None:
    """Each leg and arm of a rebased skeleton rests as it is straightest: the retargeted knees and
    elbows stay within their ranges (from a bent rest knee they were 1.15 rad beyond)."""
    from bipedsim.control.reference import Hinges
    from bipedsim.model import retarget

    m = read_bvh(shared_dir() / BANDAI)[0].to_project_frame().with_standing_rest()
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
