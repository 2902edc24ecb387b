"""Motion operations: FK, resampling, slicing, concatenation, mirroring, units and axes."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.motion import Motion, Skeleton, concatenate, left_right_pairs, up_basis
from bipedsim.motion.gaitgen import WalkParams, generate_walk, walk_skeleton


def chain_motion(frames: int = 30, seed: int = 0) -> Motion:
    """A 4-joint sinusoid chain (the tiny synthetic fixture)."""
    rng = np.random.default_rng(seed)
    sk = Skeleton(names=("a", "b", "c", "d"), parents=np.array([-1, 0, 1, 2]),
                  offsets=np.array([[0, 0, 0], [0, 1.0, 0], [0.5, 0, 0], [0, 0, 0.3]]),
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),)
                  + (("Zrotation", "Xrotation", "Yrotation"),) * 3)
    t = np.arange(frames)[:, None] / frames
    ang = np.sin(2 * np.pi * t * rng.uniform(0.5, 2, size=(1, 12)) + rng.uniform(0, 6, size=(1, 12)))
    q = Rotation.from_rotvec(ang.reshape(-1, 3)).as_quat().reshape(frames, 4, 4)
    root = np.concatenate([t * 2.0, np.zeros((frames, 1)), np.ones((frames, 1))], axis=1)
    return Motion(skeleton=sk, frame_time=1 / 30, root_translation=root, rotations=q, up="z")


def naive_fk(m: Motion) -> np.ndarray:
    out = np.zeros((m.num_frames, m.num_joints, 3))
    for f in range(m.num_frames):
        g = [None] * m.num_joints
        for j in range(m.num_joints):
            r = Rotation.from_quat(m.rotations[f, j]).as_matrix()
            p = m.skeleton.parents[j]
            if p < 0:
                g[j], out[f, j] = r, m.root_translation[f]
            else:
                g[j] = g[p] @ r
                out[f, j] = out[f, p] + g[p] @ m.skeleton.offsets[j]
    return out


def test_fk_vectorised_matches_naive_loop() -> None:
    m = chain_motion()
    assert np.allclose(m.fk()[0], naive_fk(m), atol=1e-12)


def test_resample_same_rate_is_identity_and_slerp_midpoints() -> None:
    m = chain_motion()
    r = m.resample(m.fps)
    assert r.num_frames == m.num_frames
    assert np.allclose(np.abs(np.sum(r.rotations * m.rotations, axis=-1)), 1.0)
    up = m.resample(2 * m.fps)
    assert up.num_frames == 2 * m.num_frames - 1
    assert np.allclose(up.fk()[0][::2], m.fk()[0], atol=1e-9)
    # a midpoint is the half-way rotation between its neighbours
    q0, q1 = Rotation.from_quat(m.rotations[3, 1]), Rotation.from_quat(m.rotations[4, 1])
    mid = q0 * Rotation.from_rotvec((q0.inv() * q1).as_rotvec() / 2)
    assert np.allclose(np.abs(np.dot(mid.as_quat(), up.rotations[7, 1])), 1.0)
    assert np.isclose(up.duration, m.duration)


def test_slice_and_getitem() -> None:
    m = chain_motion()
    s = m[5:15:2]
    assert s.num_frames == 5 and np.isclose(s.frame_time, 2 / 30)
    assert np.array_equal(s.rotations, m.rotations[5:15:2])
    with pytest.raises(ModelError, match="empty"):
        m.slice(40, 50)


def test_concatenate_aligns_root() -> None:
    m = generate_walk(WalkParams(cycles=1))
    turned = m.rotated_about_up(1.0, pivot=np.array([5.0, 0.0, 0.0]))
    joined = concatenate([m, turned])
    n = m.num_frames
    assert joined.num_frames == 2 * n
    # the second part starts where the first ended (horizontally) and with the same heading
    assert np.allclose(joined.root_translation[n, :2], m.root_translation[-1, :2])
    assert np.isclose(joined.heading()[n], m.heading()[-1])
    # and its shape is unchanged: FK relative to the root is the same as the original's
    pj = joined.fk()[0][n:] - joined.root_translation[n:, None]
    pm = m.fk()[0] - m.root_translation[:, None]
    assert np.allclose(pj, pm, atol=1e-9)
    assert np.array_equal(concatenate([m, m], align=False).root_translation[n:], m.root_translation)


def test_mirror_reflects_fk_and_is_an_involution() -> None:
    m = generate_walk(WalkParams(cycles=1))
    pairs = left_right_pairs(m.skeleton.names)
    assert pairs["LeftUpLeg"] == "RightUpLeg" and len(pairs) == 8
    mm = m.mirrored()
    perm = np.arange(m.num_joints)
    for a, b in pairs.items():
        perm[m.skeleton.index(a)] = m.skeleton.index(b)
        perm[m.skeleton.index(b)] = m.skeleton.index(a)
    p, pm = m.fk()[0], mm.fk()[0]
    reflect = np.array([1.0, -1.0, 1.0])  # the walk's lateral axis is Y
    assert np.allclose(pm, p[:, perm] * reflect, atol=1e-9)
    back = mm.mirrored()
    assert np.allclose(back.fk()[0], p, atol=1e-9)


@pytest.mark.parametrize("names,expected", [
    (("LeftArm", "RightArm"), {"LeftArm": "RightArm"}),
    (("lThigh", "rThigh", "hip"), {"lThigh": "rThigh"}),
    (("thigh.L", "thigh.R"), {"thigh.L": "thigh.R"}),
    (("UpLeg_L", "UpLeg_R"), {"UpLeg_L": "UpLeg_R"}),
    (("LHipJoint", "RHipJoint"), {"LHipJoint": "RHipJoint"}),
])
def test_left_right_names(names, expected) -> None:
    assert left_right_pairs(names) == expected


def test_up_conversion_maps_positions() -> None:
    m = chain_motion()
    y = m.with_up("y")
    c = up_basis("z", "y")
    assert np.allclose(y.fk()[0], m.fk()[0] @ c.T, atol=1e-12)
    assert np.allclose(y.with_up("z").fk()[0], m.fk()[0], atol=1e-12)
    assert np.allclose(up_basis("y", "z") @ [0, 1, 0], [0, 0, 1])


def test_units_scale_lengths_only() -> None:
    m = chain_motion()
    cm = m.scaled(100.0)
    assert cm.unit == pytest.approx(0.01)
    assert np.allclose(cm.fk()[0], 100 * m.fk()[0])
    assert np.allclose(cm.in_metres().fk()[0], m.fk()[0])


def test_skeleton_validation() -> None:
    with pytest.raises(ModelError, match="unique"):
        Skeleton(names=("a", "a"), parents=np.array([-1, 0]), offsets=np.zeros((2, 3)), channels=((), ()))
    with pytest.raises(ModelError, match="after its parent"):
        Skeleton(names=("a", "b", "c"), parents=np.array([-1, 2, 0]), offsets=np.zeros((3, 3)),
                 channels=((), (), ()))
    sk = walk_skeleton()
    assert sk.subtree(sk.index("LeftUpLeg")) == [sk.index(n) for n in
                                                 ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase")]
    with pytest.raises(KeyError, match="no joint 'Tail'"):
        sk.index("Tail")


def test_generated_walk_keeps_stance_feet_planted() -> None:
    m = generate_walk()
    p = m.fk()[0]
    v, length, _cadence = WalkParams().resolved()
    for side in ("Left", "Right"):
        a = p[:, m.skeleton.index(f"{side}Foot")]
        speed = np.linalg.norm(np.diff(a, axis=0), axis=1) / m.frame_time
        down = (a[:-1, 2] < 0.07 + 1e-6) & (a[1:, 2] < 0.07 + 1e-6)  # the ankle at its standing height
        assert down.mean() > 0.5 and speed[down].max() < 0.02
    root = m.root_translation
    assert np.isclose((root[-1, 0] - root[0, 0]) / m.duration, v, rtol=1e-9)
    # periodic: one cycle later the pose is the same, moved by a stride
    assert np.allclose(p[50] - p[0], [2 * length, 0, 0], atol=1e-12)
    with pytest.raises(ModelError, match="give two of"):
        WalkParams(speed=None, step_length=None, cadence=100).resolved()
