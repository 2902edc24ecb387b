"""Motion-tile worlds end to end on the example world: the dog (the shared clip, or without ``../shared``
the dog's stand-in after a stand, ``fixture_clips.py``) walks through the passage and jumps its gap, the
pterosaur flies straight over the ridge, the child bred for the world flies over it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from fixture_clips import dog_creature

from bipedsim.cli import main
from bipedsim.motion import load_bvh
from bipedsim.synthesis.world import cross_world, load_creature, load_world, parent_weights
from bipedsim.synthesis.world.synth import body_points

REPO = Path(__file__).resolve().parents[2]
WORLDS = REPO / "examples" / "worlds"
RIDGE = WORLDS / "ridge.yaml"


@pytest.fixture(scope="module")
def ridge():  # noqa: ANN201
    return load_world(RIDGE)


@pytest.fixture(scope="module")
def dog_yaml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example world's dog, its clip read from the shared take or the generated one."""
    return dog_creature(tmp_path_factory.mktemp("dog"))


@pytest.fixture(scope="module")
def dog(ridge, dog_yaml: Path):  # noqa: ANN001, ANN201
    return cross_world(ridge, load_creature(dog_yaml))


def _tiles_under(world, xy: np.ndarray) -> list[str]:  # noqa: ANN001
    r, c = world.tile_of(xy)
    return [world.rows[a][b] for a, b in zip(r, c)]


def test_dog_walks_through_the_single_passage(ridge, dog) -> None:  # noqa: ANN001
    syn, rep = dog
    root = syn.motion.root_translation
    assert "M" not in _tiles_under(ridge, root[:, :2])  # no root sample over a mountain tile
    assert (6, 4) in [tuple(t) for t in rep["path"]] and (6, 5) in [tuple(t) for t in rep["path"]]
    assert set(rep["modes"]) == {"walk"}
    goal = ridge.centre(*ridge.goal)
    assert np.linalg.norm(root[-1, :2] - goal) < ridge.tile  # ends within one tile of the goal
    assert syn.mode[-1] == "idle"  # and rests there (walk + idle)


def test_dog_jumps_the_gap(ridge, dog, dog_yaml: Path) -> None:  # noqa: ANN001
    syn, rep = dog
    assert len(rep["events"]) == 1
    jump = rep["events"][0]
    assert jump["tile"] == [6, 4] and jump["angle_deg"] in (15, 30, 45, 60, 75)
    assert jump["pushing_feet"]
    root = syn.motion.root_translation
    ev = ridge.events[0]
    gx = ridge.centre(*ev.at)[0]
    over = np.abs(root[:, 0] - gx) < ev.width / 2
    over &= np.abs(root[:, 1] - ridge.centre(*ev.at)[1]) < ridge.tile / 2
    walking = np.array([lab == "walk" for lab in syn.mode])
    stand = np.median(root[walking, 2])
    assert over.any()
    assert root[over, 2].min() > stand + 0.5 * jump["apex_m"]  # the root rises over the gap
    beyond = np.flatnonzero(root[:, 0] > gx + ev.width / 2 + 0.6 * load_creature(dog_yaml).size)
    first = beyond[0]
    assert root[first:first + 30, 2].max() < stand + 0.05  # it comes down beyond the gap
    assert jump["s_land"] > jump["s_takeoff"] + ev.width


def test_no_ground_penetration_and_feet_on_the_ground(ridge, dog) -> None:  # noqa: ANN001
    syn, rep = dog
    pts = body_points(syn.motion)
    assert (pts[..., 2] - ridge.terrain(pts[..., :2])).min() >= -1e-9
    met = rep["metrics"]
    assert met["min_clearance_m"] >= -1e-9
    # feet stay planted about as well as in the source clip (turns and blends add a little)
    assert met["foot_skate_m_s"] < 1.5 * met["source_foot_skate_m_s"]


def test_dog_bvh_reads_back_with_root_at_tile_centres(ridge, dog, dog_yaml: Path,  # noqa: ANN001
                                                       tmp_path: Path) -> None:
    out = tmp_path / "dog.bvh"
    rep_file = tmp_path / "R.json"
    assert main(["world", str(RIDGE), str(dog_yaml), "-o", str(out), "--report", str(rep_file)]) == 0
    m = load_bvh(out)
    assert m.up == "z" and m.unit == 1.0
    root = m.root_translation
    rep = json.loads(rep_file.read_text())
    assert rep["frames"] == m.num_frames
    assert {"path", "modes", "length_m", "frames", "events", "environment_weights", "timings_s"} <= set(rep)
    for r, c in rep["path"]:  # the root passes over each path tile's centre (x = (c+.5) t, y = -(r+.5) t)
        centre = np.array([(c + 0.5) * ridge.tile, -(r + 0.5) * ridge.tile])
        assert np.min(np.linalg.norm(root[:, :2] - centre, axis=1)) < 0.15 * ridge.tile
    np.testing.assert_allclose(root, dog[0].motion.root_translation, atol=1e-5)


def test_pterosaur_flies_straight_over_the_ridge(ridge) -> None:  # noqa: ANN001
    syn, rep = cross_world(ridge, load_creature(WORLDS / "pterosaur.yaml"))
    assert set(rep["modes"]) == {"fly"}
    assert rep["length_m"] <= 1.2 * rep["straight_m"]
    root = syn.motion.root_translation
    assert "M" in _tiles_under(ridge, root[:, :2])
    assert rep["metrics"]["min_clearance_m"] > 0


def test_child_bred_for_the_world_flies_over_the_mountain(ridge, tmp_path: Path) -> None:  # noqa: ANN001
    child = tmp_path / "child.yaml"
    breed_rep = tmp_path / "breed.json"
    assert main(["breed", str(WORLDS / "horse.yaml"), str(WORLDS / "pterosaur.yaml"), "--world", str(RIDGE),
                 "-o", str(child), "--report", str(breed_rep)]) == 0
    rep = json.loads(breed_rep.read_text())
    expect = parent_weights(ridge, ["walk"], ["fly"])
    assert rep["bray_curtis"] == pytest.approx(expect["bray_curtis"])
    assert rep["transfer"] == pytest.approx(expect["transfer"])
    c = load_creature(child)
    assert c.travel_modes == ["walk", "fly"]
    syn, crep = cross_world(ridge, c)
    on_m = [m for (r, cc), m in zip(crep["path"], crep["modes"]) if ridge.rows[r][cc] == "M"]
    assert on_m and set(on_m) == {"fly"}
    _, walker = cross_world(ridge, load_creature(WORLDS / "horse.yaml"))
    assert crep["length_m"] < walker["length_m"]
    pts = body_points(syn.motion)
    assert (pts[..., 2] - ridge.terrain(pts[..., :2])).min() >= -1e-9
    # a flying creature's BVH reads back into the project frame too, given its up axis: a body flying
    # level, its feet trailing behind, gives the up-axis guess nothing to measure (docs/world.md)
    out = tmp_path / "child.bvh"
    assert main(["world", str(RIDGE), str(child), "-o", str(out)]) == 0
    np.testing.assert_allclose(load_bvh(out, up="y").root_translation, syn.motion.root_translation, atol=1e-5)


@pytest.mark.slow
def test_readme_world_commands_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every command of the README's world block (the video through the headless renderer: about a minute),
    the dog's clip read from the shared take or the generated one."""
    import re
    import shlex

    text = (REPO / "README.md").read_text()
    block = re.search(r"<!-- world-commands -->\s*```bash\n(.*?)```", text, re.DOTALL)
    assert block
    monkeypatch.chdir(tmp_path)
    (tmp_path / "dog").mkdir()
    dog = dog_creature(tmp_path / "dog")
    for line in block.group(1).strip().splitlines():
        args = [str(dog) if a == "examples/worlds/dog.yaml" else a.replace("examples/", f"{REPO}/examples/")
                for a in shlex.split(line)]
        assert args[0] == "bipedsim"
        assert main(args[1:]) == 0, line
    assert (tmp_path / "dog.mp4").stat().st_size > 10_000
    assert (tmp_path / "paths.png").is_file() and (tmp_path / "out_horse_pterosaur.bvh").is_file()
    assert json.loads((tmp_path / "R.json").read_text())["modes"]
