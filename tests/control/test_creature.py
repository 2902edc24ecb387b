"""The legged creature: body kind measured from the skeleton, legs, the virtual-wrench
distribution and its Jacobian-transpose torques, the tilt rule against the clip's own root, the
trunk-contact rule."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import SHARED_BVH, need_shared, shared_params
from creature_clips import dog_clip

from bipedsim.control.creature.balance import ClipBalance
from bipedsim.control.creature.controller import CreatureController, make_creature_controller
from bipedsim.control.creature.forces import distribute_wrench
from bipedsim.control.creature.reference import loop_segment
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.data import BUILTIN_WALK, HORSE_WALK, PTEROSAUR_FLIGHT
from bipedsim.errors import ModelError
from bipedsim.model.creature_builder import creature_legs, trunk_bodies
from bipedsim.model.creature_kind import detect_body_kind
from bipedsim.motion.bvh import load_bvh, read_bvh
from bipedsim.sim.rollout import FallCriteria, FallDetector, RolloutSpec
from bipedsim.sim.runner import load_scenario, resolve_profile, run_scenario

DOG = SHARED_BVH / "animal" / "mann_dog_D1_007_KAN01_001_locomotion.bvh"
FLAMINGO = SHARED_BVH / "animal" / "truebones_flamingo_walk_inplace.bvh"


@pytest.mark.parametrize("path", shared_params("human"))
def test_shared_humans_are_humanoids(path: Path) -> None:
    """Every shared human walk is measured humanoid -- or, only where reading found no plausible unit
    (a misread file), refused with a message asking for --profile, never built as a creature."""
    motion = load_bvh(path).to_project_frame()
    try:
        kind = resolve_profile(motion, source=str(path))
    except ModelError as exc:
        assert "--profile" in str(exc) and "leg(s) found" in str(exc)
        _, info = read_bvh(path)
        assert "fits no unit's plausible range" in info.unit_reason, info.unit_reason
        return
    assert kind == "humanoid", detect_body_kind(motion).describe()


#: human bodies among the odd shared files (other skeleton layouts: MakeHuman's pelvis bone joining both
#: thighs under the root, 163-173 joints, Blender names, a crouch)
ODD_HUMANS = ("makehuman_walk1__zup_decimetre.bvh", "makehuman_tpose__173j_144six-channel.bvh",
              "makehuman_face_poseunits__163j.bvh", "bvhtools_test3__YXZ_XYZ_metres_first600f__DERIVED.bvh",
              "fairmotion_pfnn_hierarchy__crlf_metres_static.bvh", "mocapbank_crouch__lf.bvh")


@pytest.mark.parametrize("name", ODD_HUMANS)
def test_odd_human_layouts_are_humanoids_with_two_legs(name: str) -> None:
    path = SHARED_BVH / "odd" / name
    if not path.exists():
        pytest.skip(f"shared BVH file not found: {path}")
    kind = detect_body_kind(load_bvh(path))
    assert kind.kind == "humanoid" and len(kind.legs) == 2, kind.describe()
    # one leg per thigh: a bone joining both legs (MakeHuman's 'Hips' under 'Root') is no leg's root
    sk = load_bvh(path).skeleton
    roots = [sk.names.index(r) for r, _ in kind.legs]
    assert len(set(roots)) == 2 and not set(roots) & {int(sk.parents[r]) for r in roots}


@pytest.mark.parametrize("path, legs", [(HORSE_WALK, 4), (PTEROSAUR_FLIGHT, 2), (BUILTIN_WALK, 2)])
def test_shipped_clips_body_kind(path: Path, legs: int) -> None:
    kind = detect_body_kind(load_bvh(path))
    assert len(kind.legs) == legs
    assert kind.kind == ("humanoid" if path == BUILTIN_WALK else "creature"), kind.describe()


def test_shared_animals_are_creatures_with_their_legs() -> None:
    dog = detect_body_kind(load_bvh(DOG))
    assert dog.kind == "creature" and len(dog.legs) == 4
    bird = detect_body_kind(load_bvh(FLAMINGO))
    # two legs (the left foot's three toes are one leg) but a horizontal trunk: not human-like
    assert bird.kind == "creature" and len(bird.legs) == 2 and bird.trunk_tilt_rad > np.radians(60)
    assert max(len(feet) for _, feet in bird.legs) == 3


def test_profile_flag_overrides_and_birds_need_no_flag() -> None:
    assert load_scenario(bvh=FLAMINGO).profile == "creature"  # was "no left leg" without --profile
    assert resolve_profile(load_bvh(FLAMINGO).to_project_frame(), "humanoid") == "humanoid"
    assert load_scenario(bvh=PTEROSAUR_FLIGHT, support=True).profile == "creature"


def test_the_balance_height_of_a_root_at_the_floor_is_the_legs() -> None:
    """The creature balance works at the root's median height; a root at the floor carrying the travel
    (ActorCore's BoneRoot, run with --profile creature) had given 0 m and a traceback ("math domain
    error"): such a root's height gives way to the legs' roots' height above the feet."""
    from dataclasses import replace

    from bipedsim.control.creature.legs import leg_height

    sc = load_scenario(bvh=HORSE_WALK)
    m, clip = sc.built.model, sc.clip
    legs = creature_legs(sc.built.plan)
    h = leg_height(m, clip, legs)
    assert h == pytest.approx(float(np.median(clip.qpos[:, 2])))  # a root where the body is: as it was
    low = clip.qpos.copy()
    low[:, 2] -= float(np.median(clip.qpos[:, 2]))  # the whole body lowered: its root at the floor
    h_low = leg_height(m, replace(clip, qpos=low), legs)
    assert 0.5 * h < h_low < 1.5 * h


def test_legs_of_the_dog_and_the_horse() -> None:
    for path in (DOG, HORSE_WALK):
        plan = load_scenario(bvh=path).built.plan
        legs = creature_legs(plan)
        assert len(legs) == 4 and all(len(leg.feet) == 1 for leg in legs)
        assert {f for leg in legs for f in leg.feet} == set(plan.foot_bodies)
        # the trunk holds the root and none of a leg's bodies
        trunk = trunk_bodies(plan)
        assert plan.bodies[0].name in trunk and not trunk & {b for leg in legs for b in leg.bodies}


def test_wrench_distribution_reproduces_the_wrench() -> None:
    rng = np.random.default_rng(1)
    pts = np.array([[0.3, 0.1, 0.0], [0.3, -0.1, 0.0], [-0.3, 0.1, 0.0], [-0.3, -0.1, 0.0]])
    com = np.array([0.02, 0.0, 0.45])
    for _ in range(5):
        force, torque = rng.normal(size=3) * 50, rng.normal(size=3) * 10
        f = distribute_wrench(force, torque, pts, com)
        assert np.allclose(f.sum(axis=0), force, rtol=1e-3, atol=1e-2)
        assert np.allclose(np.cross(pts - com, f).sum(axis=0), torque, rtol=1e-3, atol=1e-2)


def test_stance_leg_torques_are_the_jacobian_transpose() -> None:
    """tau = -J^T f: by virtual work, tau . dq = -f . dp for a small leg motion dq moving the foot
    point by dp (measured by forward kinematics, not from the Jacobian)."""
    sc = load_scenario(bvh=HORSE_WALK)
    m = sc.built.model
    ctrl = sc.controller()
    assert isinstance(ctrl, CreatureController) and ctrl.legs is not None
    legs = ctrl.legs
    data = mujoco.MjData(m)
    data.qpos[:] = sc.clip.qpos[ctrl.start_frame()]
    mujoco.mj_forward(m, data)
    rng = np.random.default_rng(0)
    for leg in range(len(legs)):
        site = legs.sites[leg][0]
        p0 = data.site_xpos[site].copy()
        f = rng.normal(size=3) * 100
        tau = legs.torques(data, leg, p0, f)
        dq = rng.normal(size=len(legs.dofs[leg])) * 1e-6
        dv = np.zeros(m.nv)
        dv[legs.dofs[leg]] = dq
        d2 = mujoco.MjData(m)
        d2.qpos[:] = data.qpos
        mujoco.mj_integratePos(m, d2.qpos, dv, 1.0)
        mujoco.mj_kinematics(m, d2)
        dp = d2.site_xpos[site] - p0
        assert tau @ dq == pytest.approx(-f @ dp, rel=1e-3, abs=1e-9)
        # and the actuators the torques go to drive exactly those degrees of freedom
        assert list(m.actuator_trnid[legs.acts[leg], 0]) == [m.dof_jntid[d] for d in legs.dofs[leg]]


def test_reference_is_levelled_on_the_legs() -> None:
    """The controller's reference puts its lowest leg on the floor in every frame (measured on this
    body's geoms, checked here against the capsules' end points posed by the levelled clip), and the
    rollout starts from the levelled pose."""
    sc = load_scenario(bvh=HORSE_WALK)
    m = sc.built.model
    # the clip-timed controller starts from the levelled clip (the planned gait from its own stance)
    ctrl = make_creature_controller(m, sc.built.plan, sc.clip, sc.creature_cfg, CreatureBalanceConfig(gait="clip"))
    assert isinstance(ctrl.gait, ClipBalance)
    ref = ctrl.reference
    assert np.all(np.abs(ref.level_shift) < 0.1 * ctrl.legs.height)
    assert np.any(np.abs(ref.level_shift) > 1e-3)  # the horse's hooves float in the capture
    data = mujoco.MjData(m)
    leg_geoms = sorted(ctrl.legs.geom_leg)
    for f in range(0, sc.clip.num_frames, 7):
        data.qpos[:] = ref.clip.qpos[f]
        mujoco.mj_kinematics(m, data)
        lows = []
        for g in leg_geoms:
            if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_CAPSULE:
                continue
            axis = data.geom_xmat[g].reshape(3, 3)[:, 2] * m.geom_size[g][1]
            lows.append(min(data.geom_xpos[g][2] + axis[2], data.geom_xpos[g][2] - axis[2]) - m.geom_size[g][0])
        assert min(lows) == pytest.approx(0.0, abs=1e-9)
    data = mujoco.MjData(m)
    f0 = ctrl.start_frame()
    data.qpos[:] = sc.clip.qpos[f0]
    mujoco.mj_forward(m, data)
    ctrl.reset(data, f0)
    assert data.qpos[2] == pytest.approx(ref.clip.qpos[f0, 2])
    assert ref.clip.qpos[f0, 2] != pytest.approx(sc.clip.qpos[f0, 2])


def test_a_single_low_bone_is_no_leg() -> None:
    """The pterosaur's short tail hangs as low as its feet but cannot step: two legs, in the skeleton
    and in the body built from it."""
    sc = load_scenario(bvh=PTEROSAUR_FLIGHT, support=True)
    assert len(creature_legs(sc.built.plan)) == 2
    assert all("Tail" not in leg.root for leg in creature_legs(sc.built.plan))


class _Ref:
    """A stand-in controller whose reference root orientation is a given quaternion."""

    def __init__(self, nq: int, quat: np.ndarray) -> None:
        self.q = np.zeros(nq)
        self.q[3:7] = quat

    def reference_qpos(self) -> np.ndarray:
        return self.q


def test_tilt_is_measured_against_the_clips_own_root() -> None:
    """A root frame lying on its side in the clip (90 deg about x) is upright for the creature; the same
    body turned upright in world terms, or tipped 90 deg further, has fallen; yaw never counts."""
    sc = load_scenario(bvh=HORSE_WALK)
    m = sc.built.model
    data = mujoco.MjData(m)
    data.qpos[:] = sc.clip.qpos[0]
    lying = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])  # 90 deg about x
    crit = FallCriteria(non_foot_contact=False, pelvis_height_fraction=0.0, torso_tilt=1.0, tilt_from="reference")

    def verdict(root_quat: np.ndarray, ref_quat: np.ndarray) -> str | None:
        data.qpos[3:7] = root_quat
        data.qpos[2] = 5.0  # in the air: no contact, only the tilt is judged
        mujoco.mj_forward(m, data)
        det = FallDetector(m, sc.built.plan, crit, data, root=1)
        return det.check(data, _Ref(m.nq, ref_quat))

    yaw = np.array([np.cos(0.6), 0.0, 0.0, np.sin(0.6)])
    yawed_lying = np.zeros(4)
    mujoco.mju_mulQuat(yawed_lying, yaw, lying)
    assert verdict(lying, lying) is None
    assert verdict(yawed_lying, lying) is None  # a turned heading is no tilt
    assert "from the reference's root" in verdict(np.array([1.0, 0, 0, 0]), lying)
    tipped = np.zeros(4)
    mujoco.mju_mulQuat(tipped, lying, lying)
    assert verdict(tipped, lying) is not None


def test_trunk_contact_is_a_fall_for_creatures() -> None:
    sc = load_scenario(bvh=HORSE_WALK)
    crit = sc.fall_criteria()
    assert crit.trunk_contact and crit.tilt_from == "reference"
    m = sc.built.model
    data = mujoco.MjData(m)
    data.qpos[:] = sc.clip.qpos[0]
    data.qpos[2] = 0.0  # the body dropped to the floor: its trunk touches it
    mujoco.mj_forward(m, data)
    det = FallDetector(m, sc.built.plan, FallCriteria(non_foot_contact=False, pelvis_height_fraction=0.0,
                                                      torso_tilt=np.pi, trunk_contact=True), data)
    mujoco.mj_forward(m, data)
    assert "touched the ground" in (det.check(data) or "")


def test_loop_segment_skips_lying_frames() -> None:
    """The dog lies for its first second: the looped walk starts where it stands."""
    sc = load_scenario(bvh=DOG)
    ctrl = sc.controller()
    a, b = loop_segment(sc.clip, ctrl.body.quat_idx)
    z = sc.clip.qpos[:, 2]
    assert z[a] > 0.75 * np.median(z) and b - a >= 0.4 * sc.clip.num_frames


@pytest.mark.slow
def test_run_a_dog_without_flags_and_sweep_it(tmp_path: Path) -> None:
    """README's creature command: no --profile; a sweep with a creature reference (no profile key)
    pushes the creature's root and draws its results."""
    import json

    from bipedsim.cli import main
    from bipedsim.experiments.experiment import load_experiment
    from bipedsim.experiments.sweep import run_sweep

    assert main(["run", "--bvh", str(DOG), "--seconds", "0.5", "--out", str(tmp_path / "r")]) == 0
    out = json.loads((tmp_path / "r" / "outcome.json").read_text())
    assert out["config"]["profile"] == "creature" and out["extra"]["controller"] == "creature_gait"
    assert len(out["extra"]["legs"]) == 4
    exp = tmp_path / "dog.yaml"
    exp.write_text(f"name: dog\nreference: {DOG}\nseconds: 0.6\n"
                   "runs:\n  - {magnitude: 34, direction: 90, duration: 0.2, start: 0.2}\n"
                   "  - {magnitude: 5000, direction: 90, duration: 0.2, start: 0.2}\n")
    summary = run_sweep(load_experiment(exp), tmp_path / "sweep", progress=False)
    assert summary["rollouts"] == 2 and summary["outcomes"].get("fall", 0) >= 1  # 5 kN knocks it over
    assert (tmp_path / "sweep" / "push_polar.png").stat().st_size > 0


def test_a_human_run_as_a_creature_keeps_its_unit_and_folds_a_static_root() -> None:
    """``--profile creature`` on a human walk reads it as the human it is: CMU 12_03 (unit guessed)
    keeps the humanoid reading's size and speed, not a creature's guess from its largest extent (0.16 m/s
    instead of 0.82 before); and Bandai's static ``joint_Root`` at the floor is folded into the hips
    (built as a bone it touched the floor at once and the clip read as standing still)."""
    from bipedsim.model.creature_kind import read_source

    walk = SHARED_BVH / "human" / "cmu_12_03_walk__cgspeed_mb31.bvh"
    _, info_h, m_h, kind_h = read_source(walk)
    _, info_c, m_c, kind_c = read_source(walk, profile="creature")
    assert (kind_h, kind_c) == ("humanoid", "creature")
    assert info_c.unit_scale == pytest.approx(info_h.unit_scale)
    assert np.allclose(m_c.root_translation, m_h.root_translation)
    bandai = SHARED_BVH / "human" / "bandai2_walk_exhausted_001.bvh"
    raw, _, m_b, _ = read_source(bandai, profile="creature")
    assert raw.skeleton.names[0] != "joint_Root" and "joint_Root" not in raw.skeleton.names
    travel = np.linalg.norm(m_b.root_translation[-1, :2] - m_b.root_translation[0, :2])
    assert travel > 5.0  # the 9 m walk travels; a static floor root would read 0
    _, _, m_bh, _ = read_source(bandai)  # the humanoid reading folds it too (tests/model/test_layouts.py)
    assert m_bh.skeleton.names == m_b.skeleton.names


def _small_dog(tmp_path: Path, dog: Path = DOG) -> Path:
    """The dog ``dog`` at 1/2.54 of its size (its file read as centimetres; the shared dog then a 0.7 kg,
    19 cm tall dog)."""
    from bipedsim.motion.bvh import write_bvh

    m, _ = read_bvh(dog)
    path = tmp_path / "small_dog.bvh"
    write_bvh(m.scaled(1.0 / 2.54), path, precision=6)
    return path


def test_joint_damping_and_armature_are_held_to_the_bodys_own_scale(tmp_path: Path) -> None:
    """The profile's absolute joint damping and armature are capped at a share of M s^2 sqrt(g/s) and
    M s^2 (model.creature_builder.DAMPING_SHARE, ARMATURE_SHARE): the small dog's are capped, a dog's own
    (the shared dog's a 0.017 and 0.0011 share; without ``../shared`` the generated dog of
    ``creature_clips.py``, of a dog's size too) are the profile's own."""
    from bipedsim.model.creature_builder import ARMATURE_SHARE, DAMPING_SHARE

    dog = dog_clip()
    for path, capped in ((dog, False), (_small_dog(tmp_path, dog), True)):
        sc = load_scenario(bvh=path)
        model = sc.built.model
        mass, size = float(model.body_subtreemass[1]), sc.built.plan.extra["size_m"]
        balls = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
        dofs = [int(model.jnt_dofadr[j]) for j in balls]
        arm = model.dof_armature[dofs]
        if capped:
            assert np.allclose(arm, ARMATURE_SHARE * mass * size * size)
            assert sc.built.plan.sim["joint_damping"] == pytest.approx(
                DAMPING_SHARE * mass * size * size * np.sqrt(9.8 / size))
        else:
            assert np.allclose(arm, 0.01) and sc.built.plan.sim["joint_damping"] == 0.5


@pytest.mark.slow
def test_a_small_dog_walks(tmp_path: Path) -> None:
    """The shared dog at 1/2.54 of its size walks 20 s at >= 50 % of its clip's speed (with the
    profile's absolute damping, 1.1 times its own scale on every joint, it fell at 2.7 s)."""
    need_shared()
    sc = load_scenario(bvh=_small_dog(tmp_path))
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=20.0))
    assert out.outcome == "no_fall" and out.mean_speed_mps >= 0.5 * ctrl.gait.clock.clip_speed
