"""Motion-tile worlds: the equations and rules on small synthetic inputs (bipedsim.synthesis.world)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bipedsim.cli import main
from bipedsim.motion import Motion, Skeleton, load_bvh, write_bvh
from bipedsim.synthesis.world import (
    ModeClip,
    WorldError,
    ability_weights,
    best_direction,
    bray_curtis,
    choose_mode,
    find_path,
    linear_weights,
    load_world,
    mode_x,
    parent_weights,
    parse_world,
    path_modes,
    priority_scores,
    quadratic_weights,
    smoothstep_weights,
    warp_times,
)
from bipedsim.synthesis.world import path as path_mod
from bipedsim.synthesis.world.creature_file import load_creature
from bipedsim.synthesis.world.events import ANGLES_DEG, GRAVITY, ccd_frame
from bipedsim.synthesis.world.scene import scene_xml

REPO = Path(__file__).resolve().parents[2]
RIDGE = REPO / "examples" / "worlds" / "ridge.yaml"


def world(rows: list[str], **extra: object):  # noqa: ANN201
    return parse_world({"tile": 2.0, "rows": rows, **extra}, "w.yaml")


# ---------------------------------------------------------------------- environment weights, Bray-Curtis
def test_bray_curtis_hand_computed() -> None:
    wc = {"fly": 0.5, "walk": 0.3, "swim": 0.2}
    wp = {"fly": 0.0, "walk": 0.3, "swim": 0.0}
    assert bray_curtis(wc, wp) == pytest.approx((0.5 + 0.0 + 0.2) / (1.0 + 0.3))
    assert bray_curtis(wc, wc) == 0.0
    assert bray_curtis({"fly": 1.0, "walk": 0.0, "swim": 0.0}, {"fly": 0.0, "walk": 1.0, "swim": 0.0}) == 1.0


def test_environment_and_parent_weights_hand_computed() -> None:
    w = world(["S.", "MG"])  # fly on 4 tiles, walk on 3 (S, ., G), swim on none: E = (4/7, 3/7, 0)
    env = w.environment_weights()
    assert env == pytest.approx({"fly": 4 / 7, "walk": 3 / 7, "swim": 0.0})
    assert ability_weights(["walk"], env) == pytest.approx({"fly": 0.0, "walk": 3 / 7, "swim": 0.0})
    pw = parent_weights(w, ["walk"], ["fly"])
    # child (4/7, 3/7, 0): D(C, walker) = (4/7) / (1 + 3/7) = 0.4; D(C, flyer) = (3/7) / (1 + 4/7) = 3/11
    assert pw["bray_curtis"]["A"] == pytest.approx(0.4)
    assert pw["bray_curtis"]["B"] == pytest.approx(3 / 11)
    ta = 0.6 / (0.6 + 8 / 11)
    assert pw["transfer"]["A"] == pytest.approx(ta)
    assert pw["transfer"]["B"] == pytest.approx(1 - ta)
    assert pw["child_modes"] == ["walk", "fly"]
    assert mode_x("walk", True, False, 1 - ta) == pytest.approx(max(0.0, 1 - ta - 0.5))
    assert mode_x("fly", False, True, 1 - ta) == 1.0
    assert mode_x("walk", True, True, 0.3) == 0.3


# ---------------------------------------------------------------------- blending
def test_quadratic_weights_are_n2_over_m2() -> None:
    # n counts the frames left: the first transition frame is all FI (P = 1), the last all TI (P = 0)
    assert quadratic_weights(4) == pytest.approx([1.0, 9 / 16, 4 / 16, 1 / 16, 0.0])
    assert linear_weights(4) == pytest.approx([1.0, 0.75, 0.5, 0.25, 0.0])
    u = np.array([1.0, 0.75, 0.5, 0.25, 0.0])
    assert smoothstep_weights(4) == pytest.approx(3 * u ** 2 - 2 * u ** 3)
    m = 10
    p = quadratic_weights(m)
    assert p[-2] - p[-1] == pytest.approx(1 / m ** 2)  # joins TI with a small (quadratic) last step


def _z_clip(n: int, step: float) -> ModeClip:
    """A clip whose root turns ``step`` rad about z per frame and rises 1 cm per frame."""
    rots = Rotation.from_euler("z", np.arange(n)[:, None] * step).as_quat()[:, None, :]
    off = np.stack([np.zeros(n), np.zeros(n), np.arange(n) * 0.01], axis=1)
    return ModeClip(mode="walk", source="", frame_time=0.01, rots=rots, off=off, speed=1.0,
                    keys=np.array([0, n // 2]), contacts=np.zeros((n, 0), bool), feet=[], below_root=0.0,
                    frames=(0, n))


def test_time_warp_of_an_interval_to_m_frames() -> None:
    # an m' = 6 frame interval from frame 10, warped to m = 4: samples every 6/4 = 1.5 frames
    t = warp_times(10.0, 6, 4)
    assert t == pytest.approx([10.0, 11.5, 13.0, 14.5, 16.0])
    clip = _z_clip(40, 0.02)
    for ti in t:
        q, off = clip.sample(ti)  # linear interpolation of frames (slerp for rotations)
        assert Rotation.from_quat(q[0]).as_euler("xyz")[2] == pytest.approx(0.02 * ti)
        assert off[2] == pytest.approx(0.01 * ti)


def test_next_key_and_interval() -> None:
    clip = _z_clip(40, 0.02)  # keys 0, 20
    assert clip.next_key(5.0) == (20, 20)
    assert clip.next_key(20.0) == (20, 20)
    assert clip.next_key(25.0) == (40, 20)  # the next loop's key 0


# ---------------------------------------------------------------------- motion priority
def test_priority_scores_60_hard_40_soft() -> None:
    s = priority_scores(["walk", "fly"], ["walk", "fly"], None)
    pref_fly = path_mod.MODE_COST["walk"] / path_mod.MODE_COST["fly"]
    assert s["walk"] == pytest.approx(0.6 + 0.4 * 0.5 * 1.0)
    assert s["fly"] == pytest.approx(0.6 + 0.4 * 0.5 * pref_fly)
    assert priority_scores(["fly"], ["walk", "fly"], "walk") == {"fly": pytest.approx(0.6 + 0.4 * 0.5 * pref_fly)}
    assert choose_mode(["walk"], ["fly"], "fly") is None


def test_priority_tie_keeps_previous_mode(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(path_mod.MODE_COST, "fly", path_mod.MODE_COST["walk"])  # equally good at both
    assert choose_mode(["walk", "fly"], ["walk", "fly"], "fly") == "fly"
    assert choose_mode(["walk", "fly"], ["walk", "fly"], "walk") == "walk"
    monkeypatch.setattr(path_mod, "priority_scores", lambda *a: {"walk": 0.8, "fly": 0.8})
    assert path_mod.choose_mode(["walk", "fly"], ["walk", "fly"], "fly") == "fly"  # an exact tie
    assert path_mod.choose_mode(["walk", "fly"], ["walk", "fly"], None) == "walk"


# ---------------------------------------------------------------------- path finding
def test_path_around_a_wall() -> None:
    w = world(["S#G", "..."])
    p = find_path(w, ["walk"], "dog")
    assert p.tiles[0] == (0, 0) and p.tiles[-1] == (0, 2)
    assert (0, 1) not in p.tiles
    # no corner cut past the wall: (0,0) -> (1,1) diagonal would brush it
    assert all(abs(a[1] - b[1]) + abs(a[0] - b[0]) == 1 for a, b in zip(p.tiles, p.tiles[1:]))


def test_path_water_only_crossing_needs_swim() -> None:
    w = world(["S~G"])
    p = find_path(w, ["walk", "swim"], "otter")
    assert p.tiles == [(0, 0), (0, 1), (0, 2)]
    assert path_modes(w, p, ["walk", "swim"]) == ["walk", "swim", "walk"]
    with pytest.raises(WorldError, match=r"dog cannot reach the goal \[0, 2\].*'~' water at \[0, 1\]"):
        find_path(w, ["walk"], "dog")


def test_unreachable_goal_names_creature_and_blocking_tiles() -> None:
    w = world(["S.#.", "..#G", "..#."])
    with pytest.raises(WorldError) as e:
        find_path(w, ["walk", "fly"], "horse")
    msg = str(e.value)
    assert msg.startswith("w.yaml: horse cannot reach")
    assert "'#' wall at [0, 2], [1, 2], [2, 2]" in msg


def test_flyer_goes_straight_over_mountains_walker_around() -> None:
    w = load_world(RIDGE)
    fly = find_path(w, ["fly"], "pterosaur")
    walk = find_path(w, ["walk"], "horse")
    assert fly.length_m(w.tile) == pytest.approx(20.0)
    assert all(w.rows[r][c] != "M" for r, c in walk.tiles)
    assert walk.length_m(w.tile) > fly.length_m(w.tile)


# ---------------------------------------------------------------------- malformed world files
@pytest.mark.parametrize("rows, pattern", [
    (["S..", ".G"], r"w\.yaml: rows: row 1 has 2 tiles, row 0 has 3: every row must have the same number"),
    (["S.X", "..G"], r"w\.yaml: rows: row 0, column 2: unknown tile 'X'; allowed: '\.' ground, 'S' start, "
                     r"'G' goal, 'M' mountain, '~' water, '#' wall"),
    (["...", "..G"], r"w\.yaml: rows: needs exactly one start tile 'S', found 0"),
    (["S..", "..."], r"w\.yaml: rows: needs exactly one goal tile 'G', found 0"),
    ([], r"w\.yaml: rows: must be a list of strings"),
])
def test_malformed_rows(rows: list[str], pattern: str) -> None:
    with pytest.raises(WorldError, match=pattern):
        world(rows)


@pytest.mark.parametrize("events, pattern", [
    ([{"kind": "jump", "at": [5, 1], "width": 0.5}],
     r"w\.yaml: events\[0\]: at \[5, 1\] is off the map: rows 0\.\.1, columns 0\.\.2"),
    ([{"kind": "jump", "at": [0, 1], "width": 0.5}], r"events\[0\]: row 0, column 1: a jump needs a walkable tile, "
                                                      r"found 'M' \(mountain\)"),
    ([{"kind": "fall", "at": [0, 0]}], r"events\[0\]: unknown kind 'fall'; allowed: jump"),
    ([{"kind": "jump", "at": [0, 0], "width": 3.0}], r"width must be > 0 and < the tile \(2 m\), got 3"),
    ([{"kind": "jump", "at": [1, 0], "size": 2}],
     r"events\[0\]\.size: unknown key; allowed keys here: kind, at, width"),
])
def test_malformed_events(events: list[dict], pattern: str) -> None:
    with pytest.raises(WorldError, match=pattern):
        world(["SM.", "..G"], events=events)


def test_malformed_world_file_cli_exits_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("tile: 2\nrows:\n  - 'S..'\n  - '.?G'\n")
    creature = REPO / "examples" / "worlds" / "horse.yaml"
    assert main(["world", str(bad), str(creature), "-o", str(tmp_path / "o.bvh")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0] == (f"bipedsim world: error: {bad}: rows: row 1, column 1: unknown tile '?'; allowed: '.' ground, "
                      "'S' start, 'G' goal, 'M' mountain, '~' water, '#' wall (more kinds go in legend:)")


def test_legend_adds_a_tile_kind() -> None:
    w = world(["S=G"], legend={"=": {"name": "bridge", "modes": ["walk"], "cost": 2.0}})
    assert w.kind(0, 1).name == "bridge"
    assert find_path(w, ["walk"], "x").cost == pytest.approx(2.0 + 1.0)
    with pytest.raises(WorldError, match=r"legend\.=: unknown mode 'run'; allowed: walk, fly, swim"):
        world(["S=G"], legend={"=": {"modes": ["run"]}})


def test_creature_file_errors(tmp_path: Path) -> None:
    from bipedsim.synthesis.world import load_creature

    f = tmp_path / "c.yaml"
    f.write_text("name: x\nclips: {run: a.bvh}\n")
    with pytest.raises(WorldError, match=r"c\.yaml: clips: unknown mode 'run'; allowed: walk, fly, swim, idle, jump"):
        load_creature(f)
    f.write_text("name: x\nclips: {walk: missing.bvh}\n")
    with pytest.raises(WorldError, match=r"clips\.walk: no BVH file .*missing\.bvh"):
        load_creature(f)
    f.write_text("name: x\nclips: {idle: missing.bvh}\n")
    with pytest.raises(WorldError, match=r"needs at least one travel mode"):
        load_creature(f)


# ---------------------------------------------------------------------- events
def test_best_direction_searches_15_degree_steps() -> None:
    d, v0, mass = 2.0, 1.0, 10.0
    angle, v, f, table = best_direction(d, v0, mass)
    assert ANGLES_DEG == (15.0, 30.0, 45.0, 60.0, 75.0)
    assert angle in ANGLES_DEG and table[f"{angle:g}"] == min(table.values())
    r = np.radians(angle)
    assert v == pytest.approx(np.sqrt(GRAVITY * d / np.sin(2 * r)))  # lands d away at take-off height
    push = 0.25
    assert f == pytest.approx(mass * (np.array([v * np.cos(r), v * np.sin(r)]) - [v0, 0]) / push + [0, mass * GRAVITY])
    # a wider gap needs a faster take-off: more force at the best angle
    assert best_direction(2 * d, v0, mass)[3][f"{angle:g}"] > table[f"{angle:g}"]


def _chain() -> Motion:
    sk = Skeleton(names=("root", "hip", "knee", "ankle"), parents=np.array([-1, 0, 1, 2]),
                  offsets=np.array([[0, 0, 0], [0, 0, -0.1], [0, 0, -0.4], [0, 0, -0.4]], float),
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                            ("Zrotation", "Xrotation", "Yrotation"), ("Zrotation", "Xrotation", "Yrotation"),
                            ("Zrotation", "Xrotation", "Yrotation")),
                  end_site_parents=np.array([3]), end_site_offsets=np.array([[0.1, 0, 0]]))
    q = np.tile([0.0, 0.0, 0.0, 1.0], (1, 4, 1))
    return Motion(skeleton=sk, frame_time=0.01, root_translation=np.array([[0.0, 0.0, 1.0]]), rotations=q, up="z")


def test_ccd_reaches_a_reachable_target() -> None:
    m = _chain()
    target = np.array([0.3, 0.1, 0.35])
    out = ccd_frame(m, 3, np.array([0.1, 0.0, 0.0]), target, iterations=30)
    pos, g = out.fk()
    tip = pos[0, 3] + g[0, 3] @ [0.1, 0.0, 0.0]
    assert np.linalg.norm(tip - target) < 5e-3
    assert np.allclose(pos[0, :2], m.fk()[0][0, :2])  # root and hip stay


# ---------------------------------------------------------------------- BVH of a skeleton not in depth-first order
def test_bvh_writes_non_depth_first_skeleton(tmp_path: Path) -> None:
    # a bred meta-skeleton appends B-only joints under earlier parents: root, a, b, a2 (child of a)
    sk = Skeleton(names=("root", "a", "b", "a2"), parents=np.array([-1, 0, 0, 1]),
                  offsets=np.array([[0, 0, 0], [0.5, 0, 0], [-0.5, 0, 0], [0, 0.5, 0]], float),
                  channels=(("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"),
                            ("Zrotation", "Xrotation", "Yrotation"), ("Zrotation", "Xrotation", "Yrotation"),
                            ("Zrotation", "Xrotation", "Yrotation")),
                  end_site_parents=np.array([2, 3]), end_site_offsets=np.array([[-0.2, 0, 0], [0, 0.2, 0]]))
    rot = Rotation.from_euler("xyz", np.random.default_rng(0).uniform(-1, 1, (5 * 4, 3))).as_quat().reshape(5, 4, 4)
    m = Motion(skeleton=sk, frame_time=0.1, root_translation=np.tile([0.0, 0.0, 1.0], (5, 1)), rotations=rot, up="z")
    write_bvh(m, tmp_path / "m.bvh")
    back = load_bvh(tmp_path / "m.bvh", scale=1.0, up="z")
    order = [back.skeleton.index(n) for n in sk.names]
    assert back.skeleton.names == ("root", "a", "a2", "b")
    assert np.allclose(back.fk()[0][:, order], m.fk()[0], atol=1e-9)


# ---------------------------------------------------------------------- scene
def test_scene_height_field_matches_the_terrain() -> None:
    import mujoco

    w = load_world(RIDGE)
    xml = scene_xml('<mujoco>\n  <asset>\n  </asset>\n  <worldbody>\n    <geom name="floor" type="plane"/>\n'
                    '  </worldbody>\n</mujoco>', w)
    xml = xml.replace('material="grid" ', "")
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for r, c in [(1, 0), (0, 4), (3, 5), (6, 8)]:
        x, y = w.centre(r, c)
        gid = np.zeros(1, np.int32)
        dist = mujoco.mj_ray(model, data, np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
        assert 10.0 - dist == pytest.approx(w.kind(r, c).height, abs=1e-3)
    ev = w.events[0]
    x, y = w.centre(*ev.at)
    dist = mujoco.mj_ray(model, data, np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
    assert 10.0 - dist < -0.5  # the gap is cut out


@pytest.mark.parametrize("text, key", [
    ("name: x\nclips: {walk: a.bvh}\nlegs: 4\n", "legs"),
])
def test_a_creature_file_key_that_does_not_exist_is_named(tmp_path: Path, text: str, key: str) -> None:
    f = tmp_path / "c.yaml"
    f.write_text(text)
    with pytest.raises(WorldError, match=rf"{key}: unknown key; allowed keys here: name, clips, scale, up"):
        load_creature(f)


def test_world_breeding_refuses_bvh_parents(tmp_path: Path) -> None:
    from bipedsim.synthesis.world.breeding import breed_world_files

    with pytest.raises(WorldError, match="with --world the parents are creature files"):
        breed_world_files(tmp_path / "a.bvh", tmp_path / "b.bvh", tmp_path / "w.yaml", tmp_path / "c.yaml")
