"""Retargeting fixes for references outside the body's joint ranges (issue 19): Euler triples chosen
within range near gimbal lock, two-bone twists continuous through straight limbs, a head named by its
last word."""

from __future__ import annotations

import numpy as np
from conftest import SHARED_BVH, need_shared
from scipy.spatial.transform import Rotation

from bipedsim.model.retarget import _continuous_twist, _hinge_angles, _in_range_euler

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
    need_shared()
    from bipedsim.model.naming import recognise_humanoid
    from bipedsim.motion.bvh import read_bvh

    motion = read_bvh(SHARED_BVH / "human" / "games105_walk60__metres_crlf.bvh")[0]
    hm = recognise_humanoid(motion.skeleton)
    assert hm.head == "torso_head"
    assert hm.chest == "lowerback_torso"
