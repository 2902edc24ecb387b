"""Creature breeding: each step on small synthetic skeletons, the sample creatures, breeding real
files, and the child in physics."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import SHARED_BVH, shared_params
from scipy.spatial.transform import Rotation

from bipedsim.cli import main
from bipedsim.data import BUILTIN_WALK, HORSE_WALK, PTEROSAUR_FLIGHT
from bipedsim.errors import ConfigError
from bipedsim.model import build_model
from bipedsim.motion import Motion, Skeleton, load_bvh
from bipedsim.motion.samples import sample_texts
from bipedsim.reference import retarget
from bipedsim.synthesis.breed.evolve import (
    BreedError,
    breed,
    crossover,
    floor_constraint,
    joint_activity,
    mutate,
    survivor,
)

WINGS = [f"{s}{w}" for s in ("Left", "Right") for w in ("Wing1", "Wing2", "Wing3", "WingFinger")]


def chain(names, parents, offsets, frames=40, amp=None, seed=0) -> Motion:
    rng = np.random.default_rng(seed)
    n = len(names)
    leaves = [j for j in range(n) if j not in parents]
    sk = Skeleton(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets, dtype=float),
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation"),)
                  + (("Zrotation", "Yrotation", "Xrotation"),) * (n - 1),
                  end_site_parents=np.array(leaves), end_site_offsets=np.tile([0.0, 0.0, -0.2], (len(leaves), 1)))
    t = np.arange(frames)[:, None]
    amp = np.full(n, 0.3) if amp is None else np.asarray(amp, dtype=float)
    rv = np.zeros((frames, n, 3))
    rv[..., 1] = amp[None, :] * np.sin(0.3 * t + rng.uniform(0, 6, n)[None, :])
    q = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(frames, n, 4)
    root = np.tile([0.0, 0.0, 2.0], (frames, 1))
    return Motion(skeleton=sk, frame_time=1 / 30, root_translation=root, rotations=q, up="z")


A_NAMES = ["Hips", "Spine", "Neck", "LegA"]
A_PARENTS = [-1, 0, 1, 0]
B_NAMES = ["Hips", "Spine", "Wing", "WingTip", "Tail"]
B_PARENTS = [-1, 0, 1, 2, 0]
OFF4 = [[0, 0, 0], [0, 0, 0.3], [0, 0, 0.3], [0, 0, -0.5]]
OFF5 = [[0, 0, 0], [0, 0, 0.3], [0, 0.3, 0], [0, 0.4, 0], [-0.3, 0, 0]]


def test_crossover_is_the_union() -> None:
    a, b = chain(A_NAMES, A_PARENTS, OFF4).skeleton, chain(B_NAMES, B_PARENTS, OFF5).skeleton
    meta = crossover(a, b)
    assert set(meta.skeleton.names) == set(A_NAMES) | set(B_NAMES)
    assert meta.skeleton.num_joints == 4 + 3  # Hips and Spine kept once
    sk = meta.skeleton
    assert sk.names[sk.parents[sk.index("Wing")]] == "Spine" and sk.names[sk.parents[sk.index("Tail")]] == "Hips"
    assert [sk.names[i] for i in meta.common] == ["Hips", "Spine"]
    # a mapping pairs differently named joints
    m2 = crossover(a, b, {"LegA": "Tail"})
    assert m2.skeleton.num_joints == 6 and "Tail" not in m2.skeleton.names


def test_crossover_errors() -> None:
    a = chain(A_NAMES, A_PARENTS, OFF4).skeleton
    c = chain(["Root", "X"], [-1, 0], [[0, 0, 0], [0, 0, 1]]).skeleton
    with pytest.raises(BreedError, match="no common root"):
        crossover(a, c)
    with pytest.raises(BreedError, match="mapping names unknown joints"):
        crossover(a, c, {"Hips": "Nope"})


def test_activity_and_mutation_remove_exactly_n_lowest_and_honour_weights() -> None:
    # joint activity follows the amplitude of its bone's motion
    m = chain(["Hips", "J1", "J2", "J3", "J4", "J5"], [-1, 0, 0, 0, 0, 0],
              [[0, 0, 0], [0.1, 0, -0.5], [-0.1, 0, -0.5], [0, 0.1, -0.5], [0, -0.1, -0.5], [0.2, 0, -0.5]],
              amp=[0.0, 0.05, 0.4, 0.2, 0.6, 0.1])
    act = joint_activity(m)
    assert act[1] < act[5] < act[3] < act[2] < act[4]
    meta = crossover(m.skeleton, m.skeleton)
    res = mutate(meta, act, act, count=2)
    assert res.removed == ["J1", "J5"]
    res = mutate(meta, act, act, count=2, weights={"J5": 10.0, "J4": -10.0})
    assert res.removed == ["J4", "J1"]
    with pytest.raises(BreedError, match="only 5 joints can be removed"):
        mutate(meta, act, act, count=6)
    with pytest.raises(BreedError, match="unknown joint 'Nope'"):
        mutate(meta, act, act, count=1, weights={"Nope": 1.0})


def test_mutation_never_removes_a_kept_joint_nor_a_joint_above_one() -> None:
    # Hips -> J1 -> J2 (the kept "foot"), Hips -> J3, Hips -> J4: J1 and J2 are the least active
    m = chain(["Hips", "J1", "J2", "J3", "J4"], [-1, 0, 1, 0, 0],
              [[0, 0, 0], [0.1, 0, -0.5], [0, 0, -0.5], [0, 0.1, -0.5], [0, -0.1, -0.5]],
              amp=[0.0, 0.01, 0.02, 0.4, 0.6])
    act = joint_activity(m)
    meta = crossover(m.skeleton, m.skeleton)
    assert mutate(meta, act, act, count=1).removed == ["J1"]  # without keep: the foot's leg goes
    res = mutate(meta, act, act, count=4, keep={2})
    assert "J1" not in res.removed_all and "J2" not in res.removed_all
    assert sorted(res.removed) == ["J3", "J4"]  # fewer than asked: only these may go


def test_bred_child_keeps_every_foot_of_its_parents() -> None:
    """Default mutations (5) on the shipped horse and pterosaur: the horse's four hooves (measured as
    feet from its clip) and their legs stay in the child, so its body kind is found without --profile."""
    from bipedsim.model.creature_kind import detect_body_kind
    from bipedsim.synthesis.breed.mutation import support_joints

    horse = load_bvh(HORSE_WALK)
    feet = support_joints(horse.to_project_frame())
    assert len(feet) == 4
    child, rep = breed(horse, load_bvh(PTEROSAUR_FLIGHT), mutations=5)
    assert feet <= set(child.skeleton.names)
    assert not feet & set(rep.removed_with_subtrees)
    assert len(detect_body_kind(child).legs) == 4


def _horse_with_wings() -> tuple[Motion, Motion]:
    """The shipped horse, and the horse with its fore legs held up 1.6 rad (like a bird's wings: in no
    leg of its clip, their tips never low)."""
    h = load_bvh(HORSE_WALK)
    rot = h.rotations.copy()
    for name in ("LeftArm", "RightArm"):
        j = h.skeleton.index(name)
        rot[:, j] = (Rotation.from_rotvec([0.0, -1.6, 0.0]) * Rotation.from_quat(rot[:, j])).as_quat()
    return h, h.copy(rotations=rot)


def test_a_limb_that_is_a_leg_in_one_parent_only_moves_as_one_parent() -> None:
    """Blended half way, a fore leg paired with a limb held up hangs above the floor (the dog x flamingo
    child fell on such legs): it takes the motion of the parent nearer x whole, A's up to x = 0.5 (the
    child's bones are A's), B's above; so does the trunk that carries it in one parent only (the
    horse's spine and chest)."""
    from bipedsim.model.creature_kind import detect_body_kind
    from bipedsim.model.source import motion_points

    horse, winged = _horse_with_wings()
    assert len(detect_body_kind(winged).legs) == 2
    hoof = horse.skeleton.index("LeftHand")
    ref = motion_points(horse).positions[:, hoof, 2]
    for x, want in ((0.5, "A"), (0.8, "B")):
        child, rep = breed(horse, winged, x=x, mutations=0)
        assert set(rep.limbs_from_one_parent) == {"Spine", "Chest"} | {f"{s}{j}" for s in ("Left", "Right")
                                                                   for j in ("Arm", "ForeArm", "Hand")}
        assert set(rep.limbs_from_one_parent.values()) == {want}
        z = motion_points(child).positions[:, child.skeleton.index("LeftHand"), 2]
        if want == "A":  # the hooves stay where the horse puts them: four legs
            np.testing.assert_allclose(z, ref, atol=0.02)
            assert len(detect_body_kind(child).legs) == 4
        else:  # held up as in B
            assert np.median(z) > np.median(ref) + 0.3


def test_the_blend_never_lifts_a_foot_the_parent_stood_on() -> None:
    """A horse bred with the horse reared up 1.2 rad: its root blended half way lifts the child's fore
    hooves (0.27 of the height over the horse's 0.09). The root's blend is held toward A's until every
    foot of A stands within FOOT_LIFT_TOL of its height in A (the dog x human child stood on its hind
    legs this way, measured a humanoid)."""
    from bipedsim.synthesis.breed.feasible import FOOT_LIFT_TOL, foot_heights

    horse = load_bvh(HORSE_WALK)
    rot = horse.rotations.copy()
    rot[:, 0] = (Rotation.from_rotvec([0.0, -1.2, 0.0]) * Rotation.from_quat(rot[:, 0])).as_quat()
    child, rep = breed(horse, horse.copy(rotations=rot), mutations=0)
    assert 0.0 <= rep.feet_held_down["Hips"] < 0.5
    feet = ["LeftHand", "RightHand", "LeftFoot", "RightFoot"]
    stood, now = foot_heights(horse, feet), foot_heights(child, feet)
    assert all(now[f] <= stood[f] + FOOT_LIFT_TOL for f in feet), (now, stood)


def test_survivor_reproduces_c1_plus_x_d() -> None:
    a = chain(A_NAMES, A_PARENTS, OFF4, frames=30)
    b = chain(B_NAMES, B_PARENTS, OFF5, frames=30, seed=3)
    meta = crossover(a.skeleton, b.skeleton)
    d = np.zeros((30, len(meta.common), 3))
    d[:, :, 1] = np.linspace(0.0, 0.4, 30)[:, None]  # a known correction
    for x in (0.0, 0.5, 1.0):
        res = survivor(meta, a, b, x=x, correction=d)
        for k, i in enumerate(meta.common):
            want = Rotation.from_quat(a.rotations[:, i]) * Rotation.from_rotvec(x * d[:, k])
            got = Rotation.from_quat(res.rotations[:, i])
            assert np.allclose((want.inv() * got).magnitude(), 0.0, atol=1e-9)
        # joints only one parent has take that parent's motion
        assert np.allclose(np.abs(np.sum(res.rotations[:, meta.skeleton.index("LegA")] *
                                         a.rotations[:, a.skeleton.index("LegA")], axis=1)), 1.0)
    with pytest.raises(BreedError, match=r"x must be in \[0.0, 1.0\]"):
        survivor(meta, a, b, x=1.5)


def test_survivor_finds_the_matching_window() -> None:
    a = chain(A_NAMES, A_PARENTS, OFF4, frames=40)
    b = a[3:]  # B is A started 3 frames later: A's frame t is B's frame t - 3
    meta = crossover(a.skeleton, b.skeleton)
    res = survivor(meta, a, b, x=1.0)
    inner = np.arange(10, 30)
    assert np.array_equal(res.matched[inner], inner - 3)
    assert np.abs(res.correction[inner]).max() < 1e-6  # the matched motion is A's own


def test_floor_constraint_lifts_only_what_is_below() -> None:
    m = chain(["Hips", "Thigh", "Shin"], [-1, 0, 1], [[0, 0, 0], [0, 0, -0.5], [0, 0, -0.5]], frames=20)
    m.root_translation[:, 2] = np.linspace(1.2, 0.8, 20)  # the shin end dips below the floor late on
    before = m.fk()[0]
    fixed, n = floor_constraint(m)
    after = fixed.fk()[0]
    assert n > 0 and after[..., 2].min() >= -1e-9
    ok = np.all(before[..., 2] >= 0, axis=1)
    assert np.allclose(after[ok], before[ok])  # frames that were above are unchanged
    assert np.allclose(after[:, :2], before[:, :2])  # the joints above the offending one stay


def test_sample_creatures_regenerate_identically() -> None:
    from generated import assert_text_close

    from bipedsim.data import SHIPPED_BVH_PRECISION

    for path, text in sample_texts().items():
        assert_text_close(path.read_text(), text, SHIPPED_BVH_PRECISION)


def test_horse_pterosaur_child_keeps_or_loses_wings() -> None:
    h, p = load_bvh(HORSE_WALK), load_bvh(PTEROSAUR_FLIGHT)
    # the horse's legs, spine and chest carry its hooves and are never removed: the head and the tail
    # are what remains to go besides the wings
    raised, rep_r = breed(h, p, weights={w: 5.0 for w in WINGS}, mutations=2)
    lowered, rep_l = breed(h, p, weights={"LeftWing1": -5.0, "RightWing1": -5.0}, mutations=2)
    assert set(WINGS) <= set(raised.skeleton.names)
    assert not set(WINGS) & set(lowered.skeleton.names)
    assert len(rep_r.removed) == len(rep_l.removed) == 2
    for child in (raised, lowered):
        assert child.fk()[0][..., 2].min() >= -1e-9


def _simulate(child: Motion, seconds: float = 5.0) -> mujoco.MjData:
    b = build_model(child, "creature")
    clip = retarget(child, b.model, xml=b.xml)
    d = mujoco.MjData(b.model)
    d.qpos[:] = clip.qpos[0]
    for _ in range(int(seconds / b.model.opt.timestep)):
        mujoco.mj_step(b.model, d)
    assert np.all(np.isfinite(d.qpos)) and sum(int(w.number) for w in d.warning) == 0
    return d


def test_horse_pterosaur_child_converts_and_simulates(tmp_path: Path) -> None:
    child, _ = breed(load_bvh(HORSE_WALK), load_bvh(PTEROSAUR_FLIGHT), weights={w: 5.0 for w in WINGS})
    _simulate(child)
    # and bred again with a third parent
    grand, rep = breed(child, load_bvh(BUILTIN_WALK), x=0.3)
    assert rep.child_joints == grand.num_joints and grand.num_frames == child.num_frames
    _simulate(grand, 2.0)


@pytest.mark.parametrize("animal", shared_params("animal"))
def test_human_animal_child(animal: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Every shared animal breeds with the human walk without a map, whatever its naming convention:
    the joints are paired by role, the printout lists the pairs, the child simulates."""
    out = tmp_path / "child.bvh"
    argv = ["breed", str(BUILTIN_WALK), str(animal), "-o", str(out), "--report", str(tmp_path / "r.json")]
    assert main(argv) == 0
    assert "correspondence by role" in capsys.readouterr().out
    child = load_bvh(out)
    assert child.num_joints > 5
    _simulate(child)


def test_breed_cli_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "c.bvh")
    for x in ("2", "-0.5", "nan"):  # the flag and its range named (the error said 'x must be in ...')
        assert main(["breed", str(HORSE_WALK), str(PTEROSAUR_FLIGHT), "-o", out, "--x", x]) == 2
        assert capsys.readouterr().err.strip() == (f"bipedsim breed: error: --x: must be in [0, 1] (0: parent A's "
                                                   f"motion, 1: B's), got {float(x)}")
    assert main(["breed", str(HORSE_WALK), str(PTEROSAUR_FLIGHT), "-o", out, "--mutations", "99"]) == 2
    bad_map = tmp_path / "m.yaml"
    bad_map.write_text("Hips: Hips\nMane: Crest\n")
    assert main(["breed", str(HORSE_WALK), str(PTEROSAUR_FLIGHT), "-o", out, "--map", str(bad_map)]) == 2
    with pytest.raises(ConfigError, match="parent A has no joint 'Mane'"):
        from bipedsim.synthesis.breed.evolve import load_joint_map

        load_joint_map(bad_map, load_bvh(HORSE_WALK).skeleton, load_bvh(PTEROSAUR_FLIGHT).skeleton)


def test_run_creature_with_and_without_support(tmp_path: Path) -> None:
    import json

    assert main(["run", "--bvh", str(HORSE_WALK), "--profile", "creature", "--seconds", "1",
                 "--out", str(tmp_path / "a")]) == 0
    a = json.loads((tmp_path / "a" / "outcome.json").read_text())
    assert a["outcome"] in ("no_fall", "fall") and a["extra"]["support_mode"] is False
    assert main(["run", "--bvh", str(PTEROSAUR_FLIGHT), "--profile", "creature", "--support", "--seconds", "2",
                 "--out", str(tmp_path / "b")]) == 0
    b = json.loads((tmp_path / "b" / "outcome.json").read_text())
    assert b["outcome"] == "no_fall" and b["extra"]["support_force_mean_n"] > 0
    assert main(["run", "--profile", "creature", "--out", str(tmp_path / "c")]) == 2  # needs --bvh


def _heights_over_body(m: Motion) -> tuple[list[str], np.ndarray]:
    """Every joint and End Site (End Sites named PARENT.end): its height above the frame's lowest point,
    over the frame's body height (T, P)."""
    m = m if m.up == "z" else m.to_project_frame().in_metres()
    sk = m.skeleton
    z = np.concatenate([m.fk()[0][..., 2], m.end_site_positions()[..., 2]], axis=1)
    low = z.min(axis=1, keepdims=True)
    names = list(sk.names) + [sk.names[int(p)] + ".end" for p in sk.end_site_parents]
    return names, (z - low) / (z.max(axis=1, keepdims=True) - low)


@pytest.mark.parametrize("x", [0.25, 0.5, 0.75])
def test_child_of_two_standing_quadrupeds_stands_on_four_feet(x: float) -> None:
    """A child of the shared dog (rest pose along X, large local rotations) and the shipped
    horse (standing rest pose), no mutation, stands on its four paws as both parents do: each paw is
    near the floor in stance (10th percentile of its height <= 3 % of the body height) and low over
    the clip (median <= 12 %), the lowest point of nearly every frame is a paw, and the head is well
    up (median >= 50 %). Before the fix (rotations blended from different rest poses) the head lay on
    the floor at x = 0.5 and the paws were 12-45 % up."""
    dog = load_bvh(SHARED_BVH / "animal" / "mann_dog_D1_007_KAN01_001_locomotion.bvh")
    child, _ = breed(dog, load_bvh(HORSE_WALK), x=x, mutations=0)
    names, rel = _heights_over_body(child)
    paws = [names.index(f"{n}.end") for n in ("LeftHand", "RightHand", "LeftFoot", "RightFoot")]
    for p in paws:
        assert np.percentile(rel[:, p], 10) <= 0.03, names[p]
        assert np.median(rel[:, p]) <= 0.12, names[p]
    paw_points = set(paws) | {names.index(n) for n in ("LeftHand", "RightHand", "LeftFoot", "RightFoot")}
    assert np.mean([int(np.argmin(r)) in paw_points for r in rel]) >= 0.95
    assert np.median(rel[:, names.index("Head.end")]) >= 0.5


def test_rest_alignment_keeps_every_point_where_it_was() -> None:
    """B re-expressed in A's rest pose (joint frames turned) moves no joint and no End Site, and its
    rest pose takes A's bone directions at the paired joints."""
    from bipedsim.synthesis.breed.alignment import _rest_positions, in_rest_of, on_typical_rest

    h, p = load_bvh(HORSE_WALK).to_project_frame(), load_bvh(PTEROSAUR_FLIGHT).to_project_frame()
    h, p = on_typical_rest(h), on_typical_rest(p.resample(h.fps))
    pairs = {p.skeleton.index(n): h.skeleton.index(n) for n in ("Hips", "Spine", "Chest", "Head", "LeftUpLeg",
                                                                   "LeftLeg", "LeftFoot")}
    q = in_rest_of(h.skeleton, p, pairs)
    assert np.allclose(q.fk()[0], p.fk()[0], atol=1e-9)
    assert np.allclose(q.end_site_positions(), p.end_site_positions(), atol=1e-9)
    ra, rb = _rest_positions(h.skeleton), _rest_positions(q.skeleton)
    for top, low in (("LeftUpLeg", "LeftLeg"), ("LeftLeg", "LeftFoot")):
        da = ra[h.skeleton.index(low)] - ra[h.skeleton.index(top)]
        db = rb[q.skeleton.index(low)] - rb[q.skeleton.index(top)]
        assert np.dot(da, db) / np.linalg.norm(da) / np.linalg.norm(db) > 0.999


def test_bred_child_is_read_back_at_its_parents_size_and_speed(tmp_path: Path) -> None:
    """The child of the shared dog and the horse travels as its first parent does (its root
    translation is the dog's, in metres, on the dog's bones). Written in centimetres and read back
    without flags, its head up makes it 'upright' by its extents, and a unit guessed from a human's
    height would be inches (the whole child 2.54 x too large); a body measured as a creature has its
    unit guessed from its largest extent: centimetres, the dog's size and speed."""
    from bipedsim.sim.runner import load_scenario
    from bipedsim.synthesis.breed.files import breed_files

    dog_path = SHARED_BVH / "animal" / "mann_dog_D1_007_KAN01_001_locomotion.bvh"
    out = tmp_path / "child.bvh"
    breed_files(dog_path, HORSE_WALK, out, mutations=0)
    sc = load_scenario(bvh=out)
    assert (sc.profile, sc.bvh_info.unit_name) == ("creature", "cm")
    dog = load_bvh(dog_path).to_project_frame()
    child = sc.motion
    np.testing.assert_allclose(child.root_translation[:, :2], dog.root_translation[:, :2], atol=1e-4)
    # the child's root stands at about the dog's height (the blend lifts the horse's neck, not the hips)
    ratio = np.median(child.root_translation[:, 2]) / np.median(dog.root_translation[:, 2])
    assert 0.7 < ratio < 1.3


def test_the_readme_dog_x_human_child_is_a_creature_by_breed_and_run(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """The README's child of the dog and CMU 02_02 (breed defaults): its fore legs and the spine that
    carries them move as the dog's, its feet stand where the dog's stood, so it stands on four legs;
    breed's printout and ``run`` without --profile both take it for a creature (it stood on its hind
    legs, measured a humanoid, with breed advising --profile creature)."""
    from conftest import need_shared

    from bipedsim.model.creature_kind import detect_body_kind, read_source

    need_shared()
    out = tmp_path / "child.bvh"
    assert main(["breed", str(SHARED_BVH / "animal" / "mann_dog_D1_007_KAN01_001_locomotion.bvh"),
                 str(SHARED_BVH / "human" / "cmu_02_02_walk__19joint_Hip_Abdomen.bvh"), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"a creature: bipedsim run --bvh {out} --scale cm\n" in text + "\n"
    _, _, motion, profile = read_source(out, scale="cm")
    assert profile == "creature" and len(detect_body_kind(motion).legs) == 4



def test_a_bred_childs_rest_stands_with_left_and_right_alike() -> None:
    """The child's rest (the pose its body is built in, each ball joint's range centred on it) has its
    legs straight and left and right alike: a horse bred with itself stands in it with its left and
    right hooves mirrored, each hoof below its hip, and its left and right joints given the same range.
    On a mid-stride frame the hooves stood 0.13 m (hind) and 0.40 m (fore) apart along the body and the
    hind knees' ranges differed by 0.12 rad; FK is unchanged."""
    from bipedsim.synthesis.breed.alignment import _rest_positions, on_typical_rest

    child, _ = breed(load_bvh(HORSE_WALK), load_bvh(HORSE_WALK), mutations=0)
    sk = child.skeleton
    np.testing.assert_allclose(child.fk()[0], on_typical_rest(child).fk()[0], atol=1e-9)
    rest = _rest_positions(sk)
    for n in ("UpLeg", "Leg", "Foot", "Arm", "ForeArm", "Hand"):
        left, right = rest[sk.index(f"Left{n}")], rest[sk.index(f"Right{n}")]
        np.testing.assert_allclose(left, right * [1.0, -1.0, 1.0], atol=0.02, err_msg=n)
    for top, hoof in (("LeftUpLeg", "LeftFoot"), ("LeftArm", "LeftHand")):
        leg = rest[sk.index(top)] - rest[sk.index(hoof)]
        assert leg[2] > 0.9 * np.linalg.norm(leg), top  # a standing leg: its hoof below its hip
    m = build_model(child, "creature").model
    for n in ("UpLeg", "Leg", "Foot", "Arm", "ForeArm", "Hand"):
        left, right = (m.jnt_range[m.joint(f"{s}{n}_ball").id, 1] for s in ("Left", "Right"))
        assert abs(left - right) < 0.02, (n, left, right)
