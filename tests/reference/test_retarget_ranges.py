"""Retargeting fixes for references outside the body's joint ranges: Euler triples chosen
within range near gimbal lock, two-bone twists continuous through straight limbs, a head named by its
last word."""

from __future__ import annotations

import numpy as np
from conftest import SHARED_BVH
from scipy.spatial.transform import Rotation

from bipedsim.model.hinge_angles import _hinge_angles, _in_range_euler
from bipedsim.model.orientations import _continuous_twist

AXES = [np.array([0, -1.0, 0]), np.array([1.0, 0, 0]), np.array([0, 0, 1.0])]


def _compose(ang: np.ndarray) -> np.ndarray:
    out = np.eye(3)
    for k, a in enumerate(AXES):
        out = out @ Rotation.from_rotvec(a * ang[k]).as_matrix()
    return out


def test_in_range_euler_keeps_the_rotation_and_finds_the_triple_within_range() -> None:
    ranges = np.array([[-1.5, 1.5], [-1.7, 1.7], [-1.5, 1.5]])
    signs = np.array([-1.0, 1.0, 1.0])
    # a sideways-raised arm: the middle hinge near -pi/2, the outer ones small; the decomposition may
    # return the other triple (outer angles near +-pi)
    true = np.array([[0.3, -1.5, -0.2], [0.1, -1.52, 0.4], [-0.2, -1.45, 0.1]])
    local = np.stack([_compose(a) for a in true])
    ang = _hinge_angles(local, AXES)
    raw = ang * signs
    other = np.stack([raw[:, 0] + np.pi, np.pi - raw[:, 1], raw[:, 2] + np.pi], axis=1) * signs
    other = (other + np.pi) % (2 * np.pi) - np.pi
    for start in (ang, other):  # whichever triple the decomposition gave, the in-range one comes back
        got = _in_range_euler(start, ranges, signs)
        assert np.allclose(got, true, atol=1e-6)
        assert np.allclose(np.stack([_compose(a) for a in got]), local, atol=1e-9)


def test_twist_interpolated_through_a_nearly_straight_limb() -> None:
    t = np.arange(40)
    phi = 0.2 + 0.01 * t  # the reliable twist, drifting slowly
    bend = np.full(40, np.sin(np.radians(30.0)))
    bend[15:25] = np.sin(np.radians(1.0))  # the knee nearly straight: the twist flips by pi there
    noisy = phi.copy()
    noisy[15:25] = phi[15:25] + np.pi
    straight = (t >= 15) & (t < 25)
    cands = np.stack([noisy, np.where(straight, phi, phi + 1.0)], axis=1)  # the other twist solution
    out = _continuous_twist(noisy, cands, bend)
    assert np.allclose(out[:15], phi[:15]) and np.allclose(out[25:], phi[25:])
    assert np.max(np.abs(np.diff(out))) < 0.05  # no flip


def test_head_found_by_the_last_word_of_its_name() -> None:
    from bipedsim.model.naming import recognise_humanoid
    from bipedsim.motion.bvh import read_bvh

    motion = read_bvh(SHARED_BVH / "human" / "games105_walk60__metres_crlf.bvh")[0]
    hm = recognise_humanoid(motion.skeleton)
    assert hm.head == "torso_head"
    assert hm.chest == "lowerback_torso"


#: the toe joint per shared human file (hand-read from the files; None: the skeleton has no toe joint)
SHARED_TOES = {
    "bandai2_walk_exhausted_001": ("Toes_L", "Toes_R"),
    "cmu_02_01_walk__holden31_crlf": ("LeftToeBase", "RightToeBase"),
    "cmu_02_02_walk__19joint_Hip_Abdomen": (None, None),
    "cmu_02_02_walk__daz43": (None, None),
    "cmu_12_03_walk__cgspeed_mb31": ("LeftToeBase", "RightToeBase"),
    "cmu_131_01_start_walk_stop__max31_mixedEOL": ("LeftToe", "RightToe"),
    "cmu_141_16_wave_hello__holden31_crlf": ("LeftToeBase", "RightToeBase"),
    "games105_walk60__metres_crlf": ("lToeJoint", "rToeJoint"),
    "makehuman_walk1__zup_decimetre": ("Toe_L", "Toe_R"),
    "fairmotion_pfnn_hierarchy__crlf_metres_static": ("LeftToeBase", "RightToeBase"),
}


def test_toes_recognised_on_every_shared_human_layout() -> None:
    """Every shared humanoid's toe joints, games105's ``lToeJoint`` included (a toe word with a suffix):
    a body without toe segments loses the trailing foot's push-off (docs/controller.md)."""
    from bipedsim.model.naming import recognise_humanoid
    from bipedsim.motion.bvh import read_bvh

    found = 0
    for stem, want in SHARED_TOES.items():
        path = next(SHARED_BVH.glob(f"*/{stem}.bvh"), None)
        if path is None:
            continue
        hm = recognise_humanoid(read_bvh(path)[0].skeleton)
        assert (hm.legs["left"]["toe"], hm.legs["right"]["toe"]) == want, stem
        found += 1
    assert found >= 8


def test_toe_stem_rule_finds_suffixed_toes_below_the_ankle_only() -> None:
    from bipedsim.model.naming import recognise_humanoid
    from bipedsim.motion.skeleton import Skeleton

    def skel(toe_l: str, toe_r: str, extra: str | None = None) -> Skeleton:
        names = ["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", toe_l, "RightUpLeg", "RightLeg", "RightFoot", toe_r,
                 "Spine", "Head"]
        parents = [-1, 0, 1, 2, 3, 0, 5, 6, 7, 0, 9]
        if extra:  # a toe-like name that is not below an ankle
            names.append(extra)
            parents.append(9)
        off = np.zeros((len(names), 3))
        off[[1, 5], 0] = [0.1, -0.1]
        off[[2, 3, 6, 7], 1] = -0.4
        off[[4, 8], 2] = 0.1
        off[[9, 10], 1] = 0.3
        return Skeleton(names=tuple(names), parents=np.array(parents), offsets=off,
                        channels=tuple(("Zrotation", "Xrotation", "Yrotation") for _ in names))

    for left, right in (("LeftToeJoint", "RightToeJoint"), ("LeftToe_jnt", "RightToe_jnt"),
                        ("LeftToe_End", "RightToe_End"), ("LeftToeBase", "RightToeBase")):
        hm = recognise_humanoid(skel(left, right))
        assert (hm.legs["left"]["toe"], hm.legs["right"]["toe"]) == (left, right)
    hm = recognise_humanoid(skel("LeftHeel", "RightHeel", extra="ToeTarget"))
    assert hm.legs["left"]["toe"] is None and hm.legs["right"]["toe"] is None
