"""Model builder and retargeting: compile + passive stability, kinematic replay accuracy, feet on the
floor, clear errors for bad input."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import HAVE_SHARED, shared_or_standin, shared_params
from scipy.spatial.transform import Rotation

from bipedsim.cli import main
from bipedsim.data import BUILTIN_HUMANOID, BUILTIN_WALK
from bipedsim.errors import BipedsimError, ConfigError, ModelError
from bipedsim.model import build_model, load_model, load_profile
from bipedsim.model.builtin import builtin_humanoid_xml
from bipedsim.model.hinge_angles import _hinge_angles
from bipedsim.model.naming import MapFile, load_map, split_name
from bipedsim.model.profile import PROFILE_DIR
from bipedsim.motion import Motion, Skeleton, load_bvh
from bipedsim.motion.rest import standing_rest
from bipedsim.reference import ReferenceClip, retarget
from bipedsim.reference.gait_events import ground_level
from bipedsim.reference.retarget import (
    foot_heights,
    kabsch,
    marker_positions,
    source_marker_positions,
)

#: Replay tolerance (m): pelvis, knees, ankles, shoulders, elbows, wrists on every frame.
REPLAY_TOL = 0.02


def passive_ok(model: mujoco.MjModel, qpos0: np.ndarray, seconds: float = 2.0) -> mujoco.MjData:
    data = mujoco.MjData(model)
    data.qpos[:] = qpos0
    for _ in range(round(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    assert sum(int(w.number) for w in data.warning) == 0, [int(w.number) for w in data.warning]
    return data


@pytest.fixture(scope="module")
def walk_model():
    m = load_bvh(BUILTIN_WALK)
    return m, build_model(m)


def test_builtin_humanoid_file_is_what_the_builder_makes() -> None:
    from generated import assert_xml_close

    assert_xml_close(BUILTIN_HUMANOID.read_text(), builtin_humanoid_xml())
    built = load_model(BUILTIN_HUMANOID)
    # legs 0.458 + 0.475 m (the walk's OFFSETs) -> 1.900 m tall at BMI 22
    assert built.summary()["total_mass_kg"] == pytest.approx(22.0 * (0.933 / 0.491) ** 2, abs=0.01)


def _bvh_leg_length(path: Path, scale: float) -> float:
    """Hip to knee plus knee to ankle (m), both sides' mean, read from the file's OFFSET lines alone: the
    OFFSET of each leg's knee and ankle joints (the two joints below each hip joint of the file)."""
    lines = [ln.split() for ln in path.read_text().splitlines()]
    total, legs = 0.0, 0
    for i, ln in enumerate(lines):
        if ln[:1] == ["JOINT"] and ln[1].endswith("UpLeg"):
            offsets = [np.array(lines[j][1:4], float) for j in range(i + 1, len(lines)) if lines[j][:1] == ["OFFSET"]]
            total += (np.linalg.norm(offsets[1]) + np.linalg.norm(offsets[2])) * scale
            legs += 1
    assert legs == 2
    return total / legs


def test_body_mass_comes_from_the_legs(walk_model, tmp_path: Path) -> None:
    """``total_mass: auto`` (the default): a person whose hip-to-ankle legs are 0.491 of the height (Winter)
    at body-mass index 22, the legs read from the BVH's OFFSETs (not the builder); the segments keep their
    shares; ``null`` keeps the segments' own 64 kg; ``--mass`` wins; a word other than auto is refused."""
    from dataclasses import replace

    from bipedsim.model.humanoid import mass_from_legs

    m, built = walk_model
    prof = load_profile("humanoid")
    assert prof.total_mass == "auto"
    leg = _bvh_leg_length(BUILTIN_WALK, 0.01)  # centimetres
    assert leg == pytest.approx(0.933)
    expected = 22.0 * (leg / 0.491) ** 2
    assert built.summary()["total_mass_kg"] == pytest.approx(expected, rel=1e-5)
    assert mass_from_legs(leg, prof) == pytest.approx(expected)
    mj = built.model
    pelvis = mj.body_mass[mj.body("pelvis").id]
    assert pelvis / built.summary()["total_mass_kg"] == pytest.approx(22.5 / 64.0)
    # a body s times the size weighs s^2 as much (the height's square at one BMI)
    small = build_model(m.similar(0.8))
    assert small.summary()["total_mass_kg"] == pytest.approx(0.64 * expected, rel=1e-5)
    assert build_model(m, replace(prof, total_mass=None)).summary()["total_mass_kg"] == pytest.approx(64.0)
    in_metres = tmp_path / "walk_m.bvh"  # the same walk written in metres weighs the same
    from bipedsim.motion.bvh import write_bvh

    write_bvh(m.in_metres(), in_metres)
    assert build_model(load_bvh(in_metres)).summary()["total_mass_kg"] == pytest.approx(expected, rel=1e-5)
    assert build_model(m, total_mass=70.0).summary()["total_mass_kg"] == pytest.approx(70.0)
    bad = tmp_path / "p.yaml"
    bad.write_text((PROFILE_DIR / "humanoid.yaml").read_text().replace("total_mass: auto", "total_mass: heavy"))
    with pytest.raises(ConfigError, match=r"total_mass.*heavy"):
        load_profile(bad)
    with pytest.raises(ModelError, match="legs > 0"):
        mass_from_legs(0.0, prof)


def test_humanoid_structure(walk_model) -> None:
    _, b = walk_model
    s = b.summary()
    # pelvis, torso, head, 2 x (upper arm, lower arm, thigh, shin, foot, toe)
    assert s["bodies"] == 15
    # 3 spine + 3 neck + 2 x (3 shoulder + 1 elbow + 3 hip + 1 knee + 1 ankle + 1 toe) = 26 hinges
    assert s["actuated_dofs"] == 26 and s["dofs"] == 32
    m = b.model
    rng = {m.joint(i).name: tuple(m.jnt_range[i]) for i in range(m.njnt)}
    assert rng["left_knee"] == (0.0, 2.5) and rng["left_elbow"] == (-2.7, 0.0)
    assert rng["left_hip_y"] == (-1.3, 1.9) and rng["right_hip_z"] == (-1.0, 0.25)
    assert rng["spine_x"] == (-0.6, 0.6) and rng["left_ankle"] == (-0.75, 0.75)
    masses = {m.body(i).name: m.body_mass[i] * 64.0 / s["total_mass_kg"] for i in range(m.nbody)}  # the shares
    shares = {"pelvis": 22.5, "left_thigh": 6.6, "left_toe": 1.0, "right_lower_arm": 1.7}
    assert all(masses[k] == pytest.approx(v, rel=1e-5) for k, v in shares.items()), masses
    assert m.opt.timestep == pytest.approx(0.002) and m.opt.gravity[2] == pytest.approx(-9.8)
    assert {m.sensor(i).name for i in range(m.nsensor)} == {
        "touch_left_foot_touch", "touch_right_foot_touch", "touch_left_toe_touch", "touch_right_toe_touch"}
    # positive knee flexion swings the shin backward (-x) in the rest frame
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    ankle0 = d.xpos[m.body("left_foot").id].copy()
    d.qpos[m.jnt_qposadr[m.joint("left_knee").id]] = 0.5
    mujoco.mj_forward(m, d)
    assert d.xpos[m.body("left_foot").id][0] < ankle0[0] - 0.1


def test_mass_scaling_and_ankle_option(walk_model) -> None:
    m, _ = walk_model
    assert build_model(m, total_mass=80.0).summary()["total_mass_kg"] == pytest.approx(80.0)
    prof = load_profile("humanoid")
    from dataclasses import replace

    two = build_model(m, replace(prof, ankle_2dof=True))
    names = {two.model.joint(i).name for i in range(two.model.njnt)}
    assert {"left_ankle_y", "left_ankle_x"} <= names


def test_builtin_walk_replays_exactly(walk_model) -> None:
    m, b = walk_model
    clip = retarget(m, b.model, xml=b.xml)
    mk = marker_positions(b.model, clip, b.plan)
    src = source_marker_positions(m, clip, b.plan)
    assert max(np.abs(mk[k] - src[k]).max() for k in mk) < 1e-6
    # the generated walk has exact contacts: 4 strikes per foot in 4 cycles
    assert [len(clip.events[f]["strike"]) for f in ("left", "right")] == [4, 4]
    assert clip.model_hash == b.hash


@pytest.mark.parametrize("path", shared_params("human"))
def test_shared_humans_convert_simulate_and_replay(path: Path) -> None:
    """Every shared human builds at a plausible height and replays its clip -- or, only where reading the
    file found no plausible unit, is refused with the misread message (never a wrongly sized body)."""
    from bipedsim.model.build import HUMANOID_BUILT_HEIGHT_M
    from bipedsim.motion import read_bvh

    m = standing_rest(load_bvh(path))
    try:
        b = build_model(m)
    except ModelError as exc:
        assert "probably misread" in str(exc) and "--scale" in str(exc)
        _, info = read_bvh(path)
        assert "fits no unit's plausible range" in info.unit_reason, info.unit_reason
        return
    lo, hi = HUMANOID_BUILT_HEIGHT_M
    assert lo <= b.summary()["height_m"] <= hi
    clip = retarget(m, b.model, xml=b.xml)
    passive_ok(b.model, clip.qpos[0])
    mk = marker_positions(b.model, clip, b.plan)
    src = source_marker_positions(m, clip, b.plan)
    kept = {"pelvis", "knee", "ankle", "shoulder", "elbow", "wrist"}
    roles = b.plan.extra["roles"]
    checked = {roles["pelvis"]}
    for side in ("left", "right"):
        checked |= {roles["legs"][side][r] for r in ("knee", "ankle")}
        checked |= {roles["arms"][side][r] for r in ("upper_arm", "elbow", "wrist")}
    assert len(checked) == 1 + 2 * 5 and kept
    tol = REPLAY_TOL
    worst = max(float(np.linalg.norm(mk[k] - src[k], axis=1).max()) for k in checked)
    assert worst < tol, worst
    # feet never sink more than 1 cm into the floor; contact labels follow foot height
    low, _ = foot_heights(b.model, clip.qpos, b.plan.foot_bodies)
    assert low.min() > -0.01
    # (labels: within 5 cm of the foot's resting level and slower than 0.5 m/s, then debounced: gaps
    # under 60 ms filled, touches under 120 ms dropped)
    # (heights above the ground under the feet, reference.gait_events.ground_level: a capture floor may drift)
    fh = clip.foot_heights
    above = np.stack([fh[:, k] - ground_level(fh[:, [k]], clip.frame_time) for k in range(fh.shape[1])], axis=1)
    level = np.percentile(above, 5, axis=0)
    near = above < level + 0.08  # heel and toe each rest at their own level (reference.gait_events); the side's lowest
    # point therefore sits up to their difference above the side's level during contact
    assert (near[clip.contacts]).mean() > 0.95
    assert not np.any(clip.contacts & (above > level + 0.10))


def stance_sole_pitch(b, clip, axis: int = 0) -> np.ndarray:
    """Pitch (rad) of the foot boxes' long axis on the frames the clip labels as contact (``axis=1``:
    the roll, the tilt of the boxes' lateral axis)."""
    d = mujoco.MjData(b.model)
    pitch = []
    for f in range(0, clip.num_frames, 3):
        d.qpos[:] = clip.qpos[f]
        mujoco.mj_kinematics(b.model, d)
        for k, side in enumerate(clip.foot_names):
            if clip.contacts[f, k]:
                x = d.geom_xmat[b.model.geom(f"{side}_foot_geom").id].reshape(3, 3)[:, axis]
                pitch.append(np.arcsin(x[2]))
    return np.array(pitch)


@pytest.mark.parametrize("path", shared_params("animal"))
def test_shared_animals_as_creatures(path: Path) -> None:
    """Every shared animal (walking or in place, any naming) builds as a creature whose feet -- at
    least two end effectors -- reach the floor, steps passively without NaN and replays its clip."""
    m = load_bvh(path)
    b = build_model(m, "creature")
    clip = retarget(m, b.model, xml=b.xml)
    passive_ok(b.model, clip.qpos[0])
    assert b.plan.extra["merged"] == [] or all(isinstance(x, str) for x in b.plan.extra["merged"])
    feet = [x.name for x in b.plan.bodies if x.is_foot]
    assert len(feet) >= 2, feet
    # each foot touches the ground at some point of the clip (the retargeted clip's contact labels:
    # the foot's sole within reach of the floor level, slow)
    assert sorted(clip.foot_names) == sorted(feet) and clip.contacts.any(axis=0).all(), clip.contacts.mean(axis=0)
    assert np.all(clip.foot_heights.min(axis=0) < 0.05 * b.plan.extra["size_m"])
    # ball joints with a range from the motion
    m_ = b.model
    balls = [i for i in range(m_.njnt) if m_.jnt_type[i] == mujoco.mjtJoint.mjJNT_BALL]
    assert len(balls) == m_.nbody - 2 and np.all(m_.jnt_range[balls, 1] > 0.5)
    mk = marker_positions(b.model, clip, b.plan)
    src = source_marker_positions(m, clip, b.plan)
    # unmerged creature bodies follow the source joints; merged bones are short by rule
    assert max(float(np.linalg.norm(mk[k] - src[k], axis=1).max()) for k in mk) < 0.05 * b.plan.extra["size_m"]


def test_clip_round_trip_and_hash_check(walk_model, tmp_path: Path) -> None:
    m, b = walk_model
    clip = retarget(m, b.model, xml=b.xml)
    clip.save(tmp_path / "c.npz")
    back = ReferenceClip.load(tmp_path / "c.npz", expect_hash=b.hash)
    assert np.array_equal(back.qpos, clip.qpos) and back.events == clip.events
    with pytest.raises(ModelError, match="made for model"):
        ReferenceClip.load(tmp_path / "c.npz", expect_hash="0" * 16)
    # qvel is the manifold derivative: integrating it one frame reproduces the next pose
    q = clip.qpos[10].copy()
    mujoco.mj_integratePos(b.model, q, clip.qvel[10], clip.frame_time)
    assert np.abs(q[7:] - clip.qpos[11][7:]).max() < 0.02


def test_kabsch_and_hinge_decomposition() -> None:
    rng = np.random.default_rng(0)
    r = Rotation.random(5, random_state=1).as_matrix()
    pts = rng.normal(size=(4, 3))
    cur = np.einsum("tij,nj->tni", r, pts)
    assert np.allclose(kabsch(pts, cur, r), r, atol=1e-9)
    # the pull toward the reference is weak: a wrong reference barely moves the fit
    assert np.allclose(kabsch(pts, cur, np.tile(np.eye(3), (5, 1, 1))), r, atol=2e-2)
    ang = rng.uniform(-0.5, 0.5, size=(5, 3))
    axes = [np.array([0, -1.0, 0]), np.array([1.0, 0, 0]), np.array([0, 0, 1.0])]
    def rot(k: int, a: np.ndarray) -> np.ndarray:
        return Rotation.from_rotvec(axes[k] * a[k]).as_matrix()

    local = np.stack([rot(0, a) @ rot(1, a) @ rot(2, a) for a in ang])
    assert np.allclose(_hinge_angles(local, axes), ang, atol=1e-9)


def test_name_conventions() -> None:
    assert split_name("mixamorig:LeftUpLeg") == ("left", "upleg")
    assert split_name("lThigh") == ("left", "thigh")
    assert split_name("upperleg01.R") == ("right", "upperleg")
    assert split_name("joint_UpperLeg_L") == ("left", "upperleg")
    assert split_name("LHipJoint") == ("left", "hipjoint")
    assert split_name("ThighLT") == ("left", "thigh")


# ---------------------------------------------------------------------- bad input
def chain_skeleton(names, parents, offsets) -> Motion:
    sk = Skeleton(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets, dtype=float),
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),)
                  + (("Zrotation", "Xrotation", "Yrotation"),) * (len(names) - 1))
    q = np.tile([0.0, 0, 0, 1], (3, len(names), 1))
    return Motion(skeleton=sk, frame_time=0.01, root_translation=np.tile([0, 0, 1.0], (3, 1)), rotations=q)


def test_no_legs_is_a_clear_error() -> None:
    m = chain_skeleton(["base", "a", "b"], [-1, 0, 1], [[0, 0, 0], [0, 0, 0.3], [0, 0, 0.3]])
    with pytest.raises(ModelError, match="no left leg.*creature profile"):
        build_model(m)
    b = build_model(m, "creature")  # any skeleton works as a creature
    assert b.summary()["bodies"] >= 2


def test_zero_length_bone_is_a_clear_error(walk_model) -> None:
    m, _ = walk_model
    sk = m.skeleton
    off = sk.offsets.copy()
    off[sk.index("LeftLeg")] = 0.0  # knee on top of the hip
    bad = m.copy(skeleton=sk.replace(offsets=off))
    with pytest.raises(ModelError, match="zero-length bone: left thigh from 'LeftUpLeg' to 'LeftLeg'"):
        build_model(bad)


def test_mass_must_be_positive(walk_model) -> None:
    m, _ = walk_model
    with pytest.raises(ModelError, match="total mass must be a finite number > 0"):
        build_model(m, total_mass=0.0)
    assert main(["convert", str(BUILTIN_WALK), "-o", "/dev/null", "--mass", "-3"]) == 2


def test_mapping_errors_and_use(walk_model, tmp_path: Path) -> None:
    m, _ = walk_model
    p = tmp_path / "map.yaml"
    p.write_text("left:\n  thigh: LeftUpLeg\n  knee: LeftKnee\n")
    with pytest.raises(ConfigError, match=r"left\.knee: names joint 'LeftKnee', which the skeleton does not have"):
        load_map(p, m.skeleton)
    p.write_text("left:\n  shin: LeftLeg\n")
    with pytest.raises(ConfigError, match=r"left\.shin: unknown role"):
        load_map(p, m.skeleton)
    p.write_text("pelvis: Hips\nleft: {thigh: LeftUpLeg, knee: LeftLeg, ankle: LeftFoot}\n")
    mp = load_map(p, m.skeleton)
    assert isinstance(mp, MapFile) and build_model(m, mapping=mp).summary()["bodies"] == 15


@pytest.mark.parametrize("yaml_text,message", [
    ("joints:\n  knee: {axes: [y], range: [[2.5, 0.0]], torque: 400}\n", "limits reversed"),
    ("gains:\n  hip: [-5, 1]\n", "unknown key"),  # PD gains are the controller's (pd.gains)
    ("masses:\n  pelvis: 0\n", "must be > 0 kg"),
    ("colour: red\n", "unknown key"),
    ("sim:\n  timestep: -1\n", "must be > 0.0"),
])
def test_profile_yaml_errors(tmp_path: Path, yaml_text: str, message: str) -> None:
    import yaml

    from bipedsim.model.profile import PROFILE_DIR

    base = yaml.safe_load((PROFILE_DIR / "humanoid.yaml").read_text())
    patch = yaml.safe_load(yaml_text)
    for k, v in patch.items():
        if isinstance(v, dict) and isinstance(base.get(k), dict):
            base[k].update(v)
        else:
            base[k] = v
    p = tmp_path / "prof.yaml"
    p.write_text(yaml.safe_dump(base))
    with pytest.raises(BipedsimError, match=message) as exc:
        load_profile(p)
    assert str(p) in str(exc.value)


def test_cli_convert_writes_model_and_clip(tmp_path: Path, capsys) -> None:
    out, clip = tmp_path / "h.xml", tmp_path / "h.npz"
    assert main(["convert", str(BUILTIN_WALK), "-o", str(out), "--clip", str(clip)]) == 0
    assert "15 bodies" in capsys.readouterr().out
    model = mujoco.MjModel.from_xml_path(str(out))  # what MuJoCo's viewer opens
    assert model.nbody == 16
    assert ReferenceClip.load(clip).num_frames == 201


def test_two_segment_spine_where_the_source_bends() -> None:
    """CMU 131_01's spine shortens by 5 cm (lowerback..Chest2 bend): one rigid torso misplaces the
    shoulders by > 2 cm, so ``spine_segments: auto`` splits it at the chest joint; the built-in walk
    (a rigid spine) keeps the paper's single torso. The take's stand-in, a walk with a rigid spine, is
    made to bow 1 rad at its chest joint (its shoulders 6 cm nearer its lower back)."""
    from dataclasses import replace

    from model_standins import bent_spine, joint_on_its_parent

    m = load_bvh(shared_or_standin("human/cmu_131_01_start_walk_stop__max31_mixedEOL.bvh"))
    if not HAVE_SHARED:
        m = bent_spine(m, "Chest2", "LeftShoulder", "RightShoulder", amplitude=1.0, period_s=1.5)
    prof = load_profile("humanoid")

    def shoulder_error(b) -> float:
        clip = retarget(m, b.model, xml=b.xml)
        mk = marker_positions(b.model, clip, b.plan)
        src = source_marker_positions(m, clip, b.plan)
        return max(float(np.linalg.norm(mk[k] - src[k], axis=1).max()) for k in ("LeftShoulder", "RightShoulder"))

    auto = build_model(m)
    names = [b.name for b in auto.plan.bodies]
    assert names[:3] == ["pelvis", "abdomen", "torso"]
    mj = auto.model
    hinges = {mj.joint(i).name for i in range(mj.njnt)}
    assert {"spine_x", "spine_y", "spine_z", "chest_x", "chest_y", "chest_z"} <= hinges
    assert mj.jnt_range[mj.joint("chest_x").id].tolist() == [-0.6, 0.6]
    masses = {mj.body(i).name: mj.body_mass[i] for i in range(mj.nbody)}
    total = auto.summary()["total_mass_kg"]
    assert (masses["abdomen"] + masses["torso"]) / total == pytest.approx(5.2 / 64.0, rel=1e-5)
    one = build_model(m, replace(prof, spine_segments=1))
    assert "abdomen" not in [b.name for b in one.plan.bodies]
    e_auto, e_one = shoulder_error(auto), shoulder_error(one)
    assert e_auto < 0.01 < 0.02 < e_one, (e_auto, e_one)
    walk = load_bvh(BUILTIN_WALK)
    assert "abdomen" not in [b.name for b in build_model(walk).plan.bodies]
    two = build_model(walk, replace(prof, spine_segments=2))
    assert "abdomen" in [b.name for b in two.plan.bodies]
    clip = retarget(walk, two.model, xml=two.xml)
    mk = marker_positions(two.model, clip, two.plan)
    src = source_marker_positions(walk, clip, two.plan)
    assert max(np.abs(mk[k] - src[k]).max() for k in mk) < 1e-6
    # CMU releases by Holden put the neck on the chest joint (Spine1): the split moves down to Spine
    holden = load_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))
    if not HAVE_SHARED:  # the stand-in's neck sits above the chest joint
        holden = joint_on_its_parent(holden, "Neck")
    h2 = build_model(holden, replace(prof, spine_segments=2))
    assert {b.name: b.source for b in h2.plan.bodies}["torso"] == "Spine"
    passive_ok(h2.model, retarget(holden, h2.model, xml=h2.xml).qpos[0])


def test_spine_segments_validated(tmp_path: Path) -> None:
    bad = tmp_path / "humanoid.yaml"
    text = (Path(__file__).resolve().parents[2] / "src/bipedsim/profiles/humanoid.yaml").read_text()
    bad.write_text(text.replace("spine_segments: auto", "spine_segments: 3"))
    with pytest.raises(ConfigError, match="spine_segments"):
        load_profile(bad)


def test_soles_lie_flat_in_stance_when_the_rest_pose_is_not_flat_footed(monkeypatch) -> None:
    """Holden's CMU skeleton points its feet down in the rest pose; boxes built in the rest frame
    would stand on their toe edges. The builder pitches them to the motion's flat-foot frames. (The
    real take's feet point 0.4 rad down, its stand-in's 0.17.)"""
    import bipedsim.model.flat_foot as hum

    m = load_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))
    b = build_model(m)
    flat = float(np.median(stance_sole_pitch(b, retarget(m, b.model, xml=b.xml))))
    monkeypatch.setattr(hum, "FLAT_MIN_TILT", 10.0)  # no correction: rest-frame soles
    r = build_model(m)
    rest = float(np.median(stance_sole_pitch(r, retarget(m, r.model, xml=r.xml))))
    assert abs(flat) < 0.05 < 0.15 < abs(rest), (flat, rest)
    if HAVE_SHARED:  # the real rest pose's foot pitch
        assert abs(rest) > 0.3, rest


def test_splayed_rest_legs_get_flexion_axes_and_level_soles() -> None:
    """Holden's CMU skeleton stands with its legs splayed 20 degrees in the rest pose. The knee,
    ankle and toe hinges are the leg's flexion axis (normal to the rest-pose shin, not the world y
    axis), so the twobone fit puts the knee plane where the motion has it; and the 1-DOF ankle cannot
    roll the foot, so the sole is built level for the leg's pose on the flat-foot frames: on the
    clip's stance frames the foot boxes neither roll nor pitch (they stood on one edge, 20 degrees
    rolled, before). The built-in walk (legs straight down at rest) keeps y axes."""
    m = load_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))
    b = build_model(m)
    mj = b.model
    for side in ("left", "right"):
        shin = mj.body_pos[mj.body(f"{side}_foot").id]  # the ankle in the shin's frame: the rest shin
        assert abs(shin[1]) > 0.1 * np.linalg.norm(shin)  # splayed
        for j in (f"{side}_knee", f"{side}_ankle", f"{side}_toe"):
            axis = mj.jnt_axis[mj.joint(j).id]
            assert abs(np.dot(axis, shin)) < 1e-5 * np.linalg.norm(shin), j
            assert np.dot(axis, [1.0, 0.0, 0.0]) == pytest.approx(0.0, abs=1e-6)
    clip = retarget(m, mj, xml=b.xml)
    roll = stance_sole_pitch(b, clip, axis=1)
    pitch = stance_sole_pitch(b, clip)
    assert abs(float(np.median(roll))) < 0.05 and abs(float(np.median(pitch))) < 0.05, (np.median(roll),
                                                                                      np.median(pitch))
    walk = build_model(load_bvh(BUILTIN_WALK)).model
    for j in ("left_knee", "right_knee", "left_ankle", "left_toe"):
        assert np.allclose(walk.jnt_axis[walk.joint(j).id], [0.0, 1.0, 0.0])


def test_thigh_helper_bones_at_the_pelvis_centre_are_passed_for_the_hip_joints() -> None:
    """MakeHuman names a helper bone at the pelvis centre __UpLeg_L/__UpLeg_R above the hip joints
    UpLeg_L/UpLeg_R: the thighs found by name coincide, so the legs start at the joints that part."""
    from bipedsim.model.naming import recognise_humanoid

    hm = recognise_humanoid(load_bvh(shared_or_standin("odd/makehuman_walk1__zup_decimetre.bvh")).skeleton)
    assert (hm.legs["left"]["thigh"], hm.legs["right"]["thigh"]) == ("UpLeg_L", "UpLeg_R")
    assert hm.pelvis == "Hips"


def _sole_lengths(model: mujoco.MjModel) -> dict[str, tuple[float, float]]:
    """Per side, the foot box's and the toe box's lengths (m) along the sole."""
    out = {}
    for side in ("left", "right"):
        def box(body: str) -> float:
            g = [i for i in range(model.ngeom) if model.body(model.geom_bodyid[i]).name == body
                 and model.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX]
            return 2.0 * float(model.geom_size[g[0]][0])
        out[side] = (box(f"{side}_foot"), box(f"{side}_toe"))
    return out


def test_a_toe_without_a_tip_reaches_a_person_s_foot_length(tmp_path: Path) -> None:
    """The built-in walk's toes end in 5 cm tips: kept as measured. The same skeleton with zero-length
    toe end sites (Bandai-Namco's and the Holden CMU layouts have them): the sole reaches, heel to toe
    tip, ``foot_length_share`` x the height (the legs over ``leg_share``: 0.152 H in Winter's table),
    where the toe box used to stop at its 3 cm minimum (a 17 cm foot on a 1.63 m body)."""
    from bipedsim.control.humanoid.simbicon import leg_length
    from bipedsim.model.humanoid import toes_note
    from bipedsim.motion import load_bvh

    prof = load_profile("humanoid")
    built = build_model(load_bvh(BUILTIN_WALK))
    for _foot, toe in _sole_lengths(built.model).values():
        assert toe == pytest.approx(0.05, abs=1e-3)  # the tip's 5 cm, not the rule's length
    assert "toes_without_tip" not in built.plan.extra
    assert toes_note(built.plan.extra) is None
    text = BUILTIN_WALK.read_text()
    assert text.count("OFFSET 5.000000 0.000000 0.000000") == 2  # the two toes' end sites
    tipless = tmp_path / "tipless.bvh"
    tipless.write_text(text.replace("OFFSET 5.000000 0.000000 0.000000", "OFFSET 0.000000 0.000000 0.000000"))
    built = build_model(load_bvh(tipless))
    m = built.model
    height = leg_length(m) / prof.leg_share
    for side, (foot, toe) in _sole_lengths(m).items():
        assert foot + toe == pytest.approx(prof.geometry.foot_length_share * height, abs=0.003), side
        assert toe > 0.06  # far past the 3 cm minimum the tipless toe had
        # recorded with the body (``bipedsim run --bvh`` prints it)
        assert built.plan.extra["toes_without_tip"][side]["sole_m"] == pytest.approx(foot + toe, abs=0.003)
    # what `bipedsim run --bvh` and `convert` print
    assert "toes end without a tip (left, right); the soles reach" in (toes_note(built.summary()) or "")
