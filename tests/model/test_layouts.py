"""The same walk written in other layouts (benchmarks/layout_variants.py) is read as the same body: a probe
for the files users bring that we do not have. Units, up axis and a static root under the body must not
change what is built or tracked; a walk in place gets its travel back."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_files, shared_or_standin

from bipedsim.model.creature_kind import detect_body_kind, read_source
from bipedsim.motion.bvh import read_bvh, write_bvh
from bipedsim.motion.reroot import add_static_root


def _probe():  # benchmarks/layout_variants.py, the probe's own variants
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import layout_variants

    return layout_variants


WALKS = ("cmu_02_01_walk__holden31_crlf", "cmu_02_02_walk__19joint_Hip_Abdomen", "cmu_02_02_walk__daz43",
         "games105_walk60__metres_crlf")


#: controller settings that track a capture's own legs (``reference: {feasible: false}``): the tests that
#: compare a walk rewritten in another layout with the original compare what is read, built and
#: retargeted; the legs' re-solve (a function of the body and the clip, 4-6 times the cost of the rest)
#: is left out
AS_CAPTURED = Path(__file__).resolve().parents[1] / "data" / "reference_as_captured.yaml"


def _load(path: Path):
    """``bipedsim run``'s scenario of the BVH file ``path``, on the clip's own legs (:data:`AS_CAPTURED`)."""
    from bipedsim.sim.runner import load_scenario

    return load_scenario(AS_CAPTURED, path)


@lru_cache(maxsize=len(WALKS))
def _scenario(name: str):
    """:func:`_load` of the shared human walk ``name`` (its stand-in without ``../shared``), built once for
    the tests that compare a rewritten file's body and reference with it (they only read it)."""
    return _load(shared_or_standin(f"human/{name}.bvh"))


@pytest.mark.parametrize("name", WALKS)
def test_a_static_root_at_the_floor_changes_nothing(name: str, tmp_path: Path) -> None:
    """A human walk put under a static root joint at the origin (a game export's layout): the origin is far
    from the walking body, which had tilted the measured trunk to 85 deg (CMU 02_01 was built as a 0.25 m
    creature). Now the root is no part of the measure and is folded away: the same kind, unit and body."""
    src = shared_or_standin(f"human/{name}.bvh")
    m, info = read_bvh(src)
    path = tmp_path / "static_root.bvh"
    write_bvh(add_static_root(m), path)
    raw0, info0, motion0, kind0 = read_source(src)
    raw1, info1, motion1, kind1 = read_source(path)
    assert kind0 == kind1 == "humanoid", detect_body_kind(motion1).describe()
    assert info1.unit_scale == pytest.approx(info0.unit_scale) and info1.up == info0.up
    assert motion1.skeleton.names == motion0.skeleton.names  # folded: no floor joint left
    np.testing.assert_allclose(motion1.fk()[0], motion0.fk()[0], atol=1e-4)


def test_a_walk_that_comes_back_is_not_in_place() -> None:
    """A walk round a circle ends where it began: its net displacement is near zero but its root travels.
    The public Emilya figure-eight walk (15 m of path, 0.35 m net) had been taken for a walk in place and
    its real root travel replaced by one rebuilt from its feet; in place is now the root's path (smoothed
    over a stride), not its net displacement."""
    from bipedsim.reference.prepare import humanoid_motion, in_place

    m = read_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))[0]
    circle = humanoid_motion(_probe()._turning(m, 128.0))  # one full turn in the clip's 2.8 s
    root = circle.travel()[:, :2]
    assert np.linalg.norm(root[-1] - root[0]) < 0.2 < 0.1 * np.linalg.norm(np.diff(root, axis=0), axis=1).sum()
    assert not in_place(circle)
    assert in_place(_probe()._in_place(circle))


@pytest.mark.parametrize("name", WALKS + ("cmu_12_03_walk__cgspeed_mb31", "bandai2_walk_exhausted_001"))
def test_in_place_travel_rebuilt_from_rolling_feet(name: str) -> None:
    """Every shared steady walk with its translation removed: the rebuilt travel is within 10 % of the
    original's and its speed within a step follows the original's (the lowest foot joint alone had rebuilt
    CMU 02_02's 19-joint walk at 71 % of its travel, 0.9 m/s off on average)."""
    from bipedsim.reference.gait_events import smooth
    from bipedsim.reference.prepare import humanoid_motion, in_place, reconstruct_root

    m = humanoid_motion(read_bvh(shared_or_standin(f"human/{name}.bvh"))[0])
    flat = _probe()._in_place(m)
    assert in_place(flat)
    rebuilt = reconstruct_root(flat)
    a = m.travel()[:, :2] - m.travel()[0, :2]
    b = rebuilt.travel()[:, :2] - rebuilt.travel()[0, :2]
    assert 0.9 < np.linalg.norm(b[-1]) / np.linalg.norm(a[-1]) < 1.1
    dt = m.frame_time
    va = np.gradient(smooth(a, dt, 0.1), dt, axis=0)
    vb = np.gradient(smooth(b, dt, 0.1), dt, axis=0)
    speed = float(np.linalg.norm(va, axis=1).mean())
    assert np.sqrt(np.mean(np.sum((va - vb) ** 2, axis=1))) < 0.25 * speed


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cmu_02_02_walk__19joint_Hip_Abdomen", "cmu_02_02_walk__daz43"])
def test_a_walk_in_place_is_tracked(name: str, tmp_path: Path) -> None:
    """The CMU 02_02 walks written in place (a game export's layout) walk 20 s on seeds 0-2 at >= 60 % of
    the rebuilt clip's speed (0.69 and 0.71 by the median; they fell at 1.0 and 1.3 s with the travel
    rebuilt from the lowest foot joint alone; docs/controller.md, *The same walks in other layouts*)."""
    from bipedsim.control.humanoid.sources import clip_speed
    from bipedsim.sim.runner import load_scenario, run_seeds

    path = _variant(name, "in_place", tmp_path)
    sc = load_scenario(None, path)
    assert any("walks in place" in n for n in sc.bvh_info.notes)
    outs = run_seeds(sc, 20.0, 3)
    assert all(o.outcome == "no_fall" for o in outs), [(o.outcome, o.fall_time_s) for o in outs]
    assert np.median([o.mean_speed_mps for o in outs]) >= 0.6 * clip_speed(sc.clip)


def test_an_experiment_reads_a_file_as_run_does(tmp_path: Path) -> None:
    """An experiment naming the Bandai walk is accepted: its body-name check had built the body from the
    file's identity pose (no standing body: 'stands 0.38 m tall') instead of the standing rest pose
    `bipedsim run` uses (reference.prepare.load_source); and a build error names its file."""
    from bipedsim.errors import ModelError
    from bipedsim.experiments.experiment import load_experiment
    from bipedsim.model.build import build_model
    from bipedsim.motion.bvh import load_bvh

    bandai = shared_or_standin("human/bandai2_walk_exhausted_001.bvh")
    exp = tmp_path / "e.yaml"
    exp.write_text(f"name: e\nreference: {bandai}\nseconds: 2\nafter: 1.0\nbody: torso\n"
                   "runs:\n  - {magnitude: 100, direction: 90, duration: 0.2, start: 1.0}\n")
    assert load_experiment(exp).spec.reference is not None
    with pytest.raises(ModelError, match="bandai2_walk_exhausted_001.bvh: the humanoid built from this motion stands"):
        build_model(load_bvh(bandai), "humanoid", source=bandai)


def _variant(name: str, kind: str, tmp_path: Path) -> Path:
    """The probe's ``kind`` variant of a shared human walk, written to ``tmp_path``."""
    src = shared_or_standin(f"human/{name}.bvh")
    m, _ = read_bvh(src)
    path = tmp_path / f"{kind}.bvh"
    write_bvh(_probe().variants(m, str(src))[kind](), path)
    return path


def test_a_walk_cycle_is_repeated_seamlessly(tmp_path: Path) -> None:
    """One gait cycle cut from a shared walk and put in place (a game animation's walk cycle: one strike
    per foot) is recognised as a loop and repeated with its seam closed; it had been refused ("1 right and
    1 left foot strikes"). A clip that is no loop is left as it is."""
    from bipedsim.reference.prepare import LOOP_REPEAT_S, repeat_loop

    path = _variant("cmu_02_02_walk__daz43", "cycle", tmp_path)
    m = read_bvh(path)[0].to_project_frame()
    notes: list[str] = []
    out = repeat_loop(m, notes)
    assert notes and "a loop" in notes[0] and out.duration >= LOOP_REPEAT_S
    period = m.num_frames - 1
    pos = out.fk()[0]
    rel = pos - pos[:, :1]
    step = np.linalg.norm(np.diff(rel, axis=0), axis=-1).max(axis=1)
    joins = [k * period - 1 for k in range(1, out.num_frames // period)]
    assert step[joins].max() < 2.0 * np.median(step), (step[joins], np.median(step))  # no jump at a join
    for name in ("cmu_02_02_walk__daz43", "cmu_131_01_start_walk_stop__max31_mixedEOL"):
        full = read_bvh(shared_or_standin(f"human/{name}.bvh"))[0].to_project_frame()
        assert repeat_loop(full) is full


def test_a_one_cycle_game_walk_is_not_refused() -> None:
    """MakeHuman's walk1 (shared: 14 frames, one cycle in place, decimetres, Z up) now loops: its strikes
    repeat and a gait cycle is found (its cycle is 0.54 s at 24 fps: a walk played about twice as fast as
    a human walks, which the body does not keep up with)."""
    from bipedsim.sim.runner import load_scenario

    sc = load_scenario(None, shared_or_standin("odd/makehuman_walk1__zup_decimetre.bvh"))
    assert any("a loop" in n for n in sc.bvh_info.notes) and any("walks in place" in n for n in sc.bvh_info.notes)
    assert len(sc.clip.events["right"]["strike"]) >= 3 and len(sc.clip.events["left"]["strike"]) >= 3


def test_info_reports_the_speed_a_walk_in_place_walks(tmp_path: Path) -> None:
    """`bipedsim info` on a walk in place reports its root as still (as the file has it) and the speed it
    walks at, its travel rebuilt from its feet: within 10 % of the original walk's root speed."""
    from bipedsim.reference.describe import describe_bvh, format_description

    original = describe_bvh(shared_or_standin("human/cmu_02_02_walk__daz43.bvh"))
    assert "walked_speed_mps" not in original
    d = describe_bvh(_variant("cmu_02_02_walk__daz43", "in_place", tmp_path))
    assert d["root_speed_mps"] < 0.01
    assert abs(d["walked_speed_mps"] / original["root_speed_mps"] - 1.0) < 0.1, (d["walked_speed_mps"], original)
    assert "walks       " in format_description(d) and "walks in place" in d["walked_note"]


@pytest.mark.parametrize("name", ["cmu_02_01_walk__holden31_crlf", "games105_walk60__metres_crlf"])
def test_joint_names_that_say_nothing(name: str, tmp_path: Path) -> None:
    """A shared walk with every joint renamed ``Bone000``... (names in no convention we know) is built
    from its skeleton's geometry (limbs as sibling chains, the legs the lowest, left of the direction of
    travel: model.naming.map_from_roles) into the same body with the same reference: it had been refused
    ("no left leg: could not find the left thigh, knee, ankle joint(s) by name")."""
    import dataclasses

    src = shared_or_standin(f"human/{name}.bvh")
    m, _ = read_bvh(src)
    anon = tmp_path / "anon.bvh"
    write_bvh(m.copy(skeleton=dataclasses.replace(
        m.skeleton, names=tuple(f"Bone{i:03d}" for i in range(m.skeleton.num_joints)))), anon)
    a, b = _scenario(name), _load(anon)
    assert a.built.model.nbody == b.built.model.nbody and a.built.model.nq == b.built.model.nq
    assert abs(a.built.summary()["total_mass_kg"] - b.built.summary()["total_mass_kg"]) < 1e-6
    np.testing.assert_allclose(b.clip.qpos, a.clip.qpos, atol=1e-6)


@pytest.mark.parametrize("name", ["cmu_02_01_walk__holden31_crlf", "cmu_02_02_walk__daz43",
                                  "bandai2_walk_exhausted_001", "games105_walk60__metres_crlf"])
def test_side_names_that_contradict_the_legs(name: str, tmp_path: Path) -> None:
    """A shared walk with its joints' side words exchanged (``LeftUpLeg`` on the body's right: a skeleton
    named from the viewer's side, or a mirrored capture) had been built facing backward, its knees bent
    the wrong way, and fell within 0.1-0.8 s. The legs say where they face (knees bend and feet point
    forward: model.humanoid.side_evidence), so the sides are taken from them: the same body, the same
    reference, and a note naming what was exchanged."""
    from bipedsim.model.humanoid import sides_note

    lv = _probe()
    src = shared_or_standin(f"human/{name}.bvh")
    m, _ = read_bvh(src)
    swapped = tmp_path / "side_names.bvh"
    write_bvh(lv._side_names(m), swapped)
    a, b = _scenario(name), _load(swapped)
    assert "sides_from_geometry" not in a.built.plan.extra
    note = sides_note(b.built.plan.extra)
    assert note is not None and "side names are mirrored" in note and "--map" in note
    ev = b.built.plan.extra["sides_from_geometry"]
    assert ev["knee"] < -0.9 and ev.get("foot", -1.0) < -0.5
    np.testing.assert_allclose(b.built.model.body_pos, a.built.model.body_pos, atol=1e-9)
    np.testing.assert_allclose(b.built.model.jnt_axis, a.built.model.jnt_axis, atol=1e-9)
    np.testing.assert_allclose(b.clip.qpos, a.clip.qpos, atol=1e-6)
    from bipedsim.reference import describe_bvh

    assert describe_bvh(swapped)["sides_note"] == note and "sides_note" not in describe_bvh(src)  # info says so


def test_side_evidence_on_every_shared_human_and_its_rule() -> None:
    """Every shared human file's legs face the way its names say (knees where they bend +0.39 to +1.00,
    feet +0.61 to +1.00, except the BVH spec sample's backward end sites, which the knees outvote);
    the rule swaps only when the knees bend backward of the named forward (below -0.5) and the feet, where
    measured, agree; straight knees (a T-pose, a stand) leave the names as they are."""
    from bipedsim.model.humanoid import MIN_KNEE_BEND_M, mirrored_sides, side_evidence
    from bipedsim.model.naming import recognise_humanoid
    from bipedsim.model.source import motion_points

    for f in shared_files("human") + shared_files("odd"):
        try:
            _, _, m, kind = read_source(f)
            hm = recognise_humanoid(m.skeleton)
        except Exception:  # not a humanoid by name: nothing to check
            continue
        if kind != "humanoid":
            continue
        ev = side_evidence(motion_points(m), hm)
        assert not mirrored_sides(ev), (f.name, ev)
        if "walk" in f.name and "knee" in ev:
            assert ev["knee"] > 0.9, (f.name, ev)
    assert mirrored_sides({"knee": -0.9, "foot": -0.8, "knee_bend_m": 0.1})
    assert not mirrored_sides({"knee": 0.95, "foot": -0.86, "knee_bend_m": 0.19})  # the spec sample
    assert not mirrored_sides({"foot": -0.9, "knee_bend_m": MIN_KNEE_BEND_M / 2})  # straight knees: kept
    assert not mirrored_sides({"knee_bend_m": 0.0})
    assert not mirrored_sides({"knee": -0.9, "foot": 0.8, "knee_bend_m": 0.1})  # the feet disagree


def _xpos(sc, frames: list[int]) -> np.ndarray:
    """World positions of every body of ``sc``'s model posed by its reference clip at ``frames``."""
    import mujoco

    m = sc.built.model
    d = mujoco.MjData(m)
    out = []
    for f in frames:
        d.qpos[:] = sc.clip.qpos[f]
        mujoco.mj_kinematics(m, d)
        out.append(d.xpos.copy())
    return np.array(out)


#: the game and animation rigs' layouts (benchmarks/layout_variants.py) a shared walk is written in
RIGS = ("rig_prefix", "helpers", "fingers", "spine_down", "no_tips", "held_tail")
#: the walks whose feet have no toe joint: ``no_tips`` (a foot without a toe joint, its End Site of no
#: length) is made of these only (the test checks the probe agrees)
WITHOUT_TOES = frozenset({"cmu_02_02_walk__19joint_Hip_Abdomen", "cmu_02_02_walk__daz43"})


@pytest.mark.parametrize(("kind", "name"), [pytest.param(kind, name, id=f"{kind}-{name}") for kind in RIGS
                                            for name in WALKS if kind != "no_tips" or name in WITHOUT_TOES])
def test_game_rig_layouts_build_the_same_humanoid(name: str, kind: str, tmp_path: Path) -> None:
    """A shared walk written as game and animation rigs write theirs (benchmarks/layout_variants.py) is the
    same humanoid, posed where the original is. Among 17 public walks from other sources, seven had been
    built as creatures (finger joints tilting the measured trunk to 51-80 deg, twist and share bones
    taken for two more legs or cutting the legs at the knee, arms hanging close to a slender body) and
    five had stopped at a bone of no length (a rig prefix hiding the names, a foot or head End Site on
    its joint); four Mixamo exports padded with a held pose had hidden their loop (``held_tail``):
    docs/controller.md, *Walks from thirteen more repositories*."""
    from bipedsim.control.humanoid.simbicon import leg_length

    src = shared_or_standin(f"human/{name}.bvh")
    m, _ = read_bvh(src)
    made = _probe().variants(m, str(src))
    assert ("no_tips" in made) == (name in WITHOUT_TOES)
    path = tmp_path / f"{kind}.bvh"
    write_bvh(made[kind](), path)
    assert read_source(path)[3] == "humanoid", detect_body_kind(read_bvh(path)[0]).describe()
    sc0, sc = _scenario(name), _load(path)
    assert [sc.built.model.body(i).name for i in range(sc.built.model.nbody)] == \
        [sc0.built.model.body(i).name for i in range(sc0.built.model.nbody)]
    assert leg_length(sc.built.model) == pytest.approx(leg_length(sc0.built.model), rel=0.02)
    n = min(sc.clip.num_frames, sc0.clip.num_frames)
    frames = list(range(0, n, max(1, n // 12)))
    a, b = _xpos(sc, frames), _xpos(sc0, frames)
    if kind in ("rig_prefix", "helpers", "fingers", "held_tail"):  # the same skeleton and motion, written otherwise
        err = np.linalg.norm(a - b, axis=2)
        assert np.median(err) < 0.02 and err.max() < 0.1, (np.median(err), err.max())
        if kind == "held_tail":  # the padding dropped: the clip is the original's, frame for frame
            assert any(n.startswith("held pose: the last") for n in sc.bvh_info.notes)
            assert sc.clip.num_frames == sc0.clip.num_frames
        return
    # the body's pose about its pelvis: a rest pose rebased on a standing frame (spine_down) turns the
    # reference about the origin, and feet given a person's length (no_tips) stand the body higher
    names = [sc.built.model.body(i).name for i in range(sc.built.model.nbody)]
    body = [i for i, nm in enumerate(names) if nm != "world" and not nm.endswith(("_foot", "_toe", "_shin"))]
    pel = names.index("pelvis")
    err = np.linalg.norm((a - a[:, pel:pel + 1]) - (b - b[:, pel:pel + 1]), axis=2)[:, body]
    assert np.median(err) < 0.03 and err.max() < 0.1, (np.median(err), err.max())
    if kind == "spine_down":
        assert any("rest pose" in n for n in sc.bvh_info.notes)
    else:
        assert any("where it begins" in n or "where they begin" in n for n in sc.bvh_info.notes)


def test_rig_prefixes_are_told_from_role_words() -> None:
    from bipedsim.model.naming import rig_prefix, split_name

    assert rig_prefix(["CC_Base_BoneRoot", "CC_Base_Hip", "CC_Base_L_Thigh", "CC_Base_R_Thigh"]) == "CC_Base_"
    assert rig_prefix(["simHips", "simLeftUpLeg", "simRightUpLeg", "simHead"]) == "sim"
    assert rig_prefix(["Character1_Hips", "Character1_LeftUpLeg", "L_Femur_RIGMESH", "Character1_Head"]) == \
        "Character1_"
    assert rig_prefix(["Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg"]) == ""  # no rig: 'Left' is a side
    assert rig_prefix(["mixamorig:Hips", "mixamorig:LeftUpLeg", "mixamorig:Spine"]) == ""  # a namespace, no prefix
    assert split_name("CC_Base_L_Thigh", "CC_Base_") == ("left", "thigh")
    assert split_name("Bip01 R Calf", "Bip01 ") == ("right", "calf")


def test_a_held_tail_is_dropped_only_when_it_is_padding() -> None:
    """Frames that repeat the last moving frame exactly for at least HELD_TAIL_S are padding; one repeated
    frame (CMU 131's last in its metres copy) or a wholly still clip is left as it is."""
    from bipedsim.reference.prepare import HELD_TAIL_S, trim_held_tail

    m = read_bvh(shared_or_standin("human/cmu_02_01_walk__holden31_crlf.bvh"))[0].to_project_frame()
    notes: list[str] = []
    padded = _probe()._held_tail(m, 1.0)
    assert trim_held_tail(padded, notes).num_frames == m.num_frames and notes[0].startswith("held pose")
    short = _probe()._held_tail(m, 0.5 * HELD_TAIL_S)
    assert trim_held_tail(short).num_frames == short.num_frames
    still = _probe()._held_tail(m[:1], 2.0)
    assert trim_held_tail(still).num_frames == still.num_frames
