"""The ground (model/ground.py): parsing and its errors, the geoms at the heights the terrain reports,
the ground stored in the model, rough ground's determinism."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from bipedsim.errors import ConfigError
from bipedsim.model.build import load_model
from bipedsim.model.builtin import builtin_humanoid_path
from bipedsim.model.ground import (
    Ground,
    GroundFrame,
    Rough,
    Step,
    Terrain,
    ground_geoms,
    ground_of,
    terrain_of,
    with_ground,
)


def test_parse_terms_combine_and_round_trip() -> None:
    g = Ground.parse(["slope:-8", "step:0.1:3", "step:-0.05:1.5", "rough:0.03:1.0:7", "friction:0.5"])
    assert g.slope_deg == -8.0
    assert g.steps == (Step(-0.05, 1.5), Step(0.1, 3.0))  # in order of distance
    assert g.rough == Rough(0.03, 1.0, 7)
    assert g.friction == 0.5
    assert Ground.parse(g.terms()) == g
    assert Ground.parse(None).flat and Ground.parse("flat").flat and Ground.parse([]).flat
    assert Ground.parse("rough:0.03:1").rough == Rough(0.03, 1.0, 0)  # the seed defaults to 0
    assert g.label() == "slope:-8+step:-0.05:1.5+step:0.1:3+rough:0.03:1:7+friction:0.5"
    assert [lv for _, _, lv in g.levels()] == pytest.approx([0.0, -0.05, 0.05])


@pytest.mark.parametrize("terms, message", [
    (["hill:3"], "--ground: unknown ground 'hill:3'; give slope:DEG"),
    (["slope:40"], "--ground: 'slope:40': a slope is at most 30 degrees up or down, got 40"),
    (["slope:x"], "--ground: 'slope:x': the values after slope: must be numbers"),
    (["step:0.1"], "--ground: 'step:0.1': expected step:HEIGHT_M:DISTANCE_M"),
    (["step:0:3"], "a step's height is not 0"),
    (["step:0.1:0.2"], "a step lies 0.5 m to 50 m ahead of the start, got 0.2"),
    (["rough:0.5:1"], "the amplitude is > 0 and at most 0.2 m, got 0.5"),
    (["rough:0.03:1:1.5"], "the seed is a whole number >= 0, got 1.5"),
    (["friction:0"], "the friction coefficient is 0.05 to 5, got 0"),
    (["slope:5", "slope:6"], "--ground[1]: 'slope:6': a ground has one slope; give it once"),
    (["step:0.1:3", "step:0.1:3.2"], "steps at 3 m and 3.2 m: steps lie at least 0.5 m apart"),
    (["slope:nan"], "must be finite numbers"),
])
def test_parse_errors_name_the_flag_and_the_term(terms: list[str], message: str) -> None:
    with pytest.raises(ConfigError) as exc:
        Ground.parse(terms)
    assert message in str(exc.value)


def test_parse_error_names_the_file_and_key() -> None:
    with pytest.raises(ConfigError, match=r"^suite.yaml: scenarios\[0\].ground: 'slope:99'"):
        Ground.parse("slope:99", key="scenarios[0].ground", path="suite.yaml")


def _ray_heights(model: mujoco.MjModel, points: list[tuple[float, float]]) -> list[float]:
    data = mujoco.MjData(model)
    data.qpos[2] = 100.0  # the body out of the rays' way
    mujoco.mj_forward(model, data)
    out = []
    for x, y in points:
        gid = np.zeros(1, np.int32)
        d = mujoco.mj_ray(model, data, np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
        assert gid[0] in ground_geoms(model)
        out.append(10.0 - d)
    return out


@pytest.fixture(scope="module")
def body() -> object:
    return load_model(builtin_humanoid_path())


@pytest.mark.parametrize("terms", [["slope:8"], ["slope:-8"], ["step:0.1:3"], ["step:-0.1:3"],
                                   ["slope:5", "step:0.2:2", "step:-0.1:4"], ["rough:0.03:1.0:2"],
                                   ["slope:-5", "step:0.15:2.5", "rough:0.02:1.0"]])
def test_built_ground_lies_where_the_terrain_says(body: object, terms: list[str]) -> None:
    frame = GroundFrame(x=0.3, y=-0.1, yaw=0.4)
    built = with_ground(body, Ground.parse(terms), frame)  # type: ignore[arg-type]
    t = terrain_of(built.model)
    assert t is not None and t.frame == frame
    pts = [(frame.x + s * math.cos(frame.yaw) - lat * math.sin(frame.yaw),
            frame.y + s * math.sin(frame.yaw) + lat * math.cos(frame.yaw))
           for s in np.linspace(-2.9, 11.9, 38) for lat in (-1.0, 0.0, 0.7)]
    got = _ray_heights(built.model, pts)
    want = [t.height(x, y) for x, y in pts]
    # planes and boxes exactly (off their edges); a height field within its triangles' sag
    tol = 2e-3 if Ground.parse(terms).rough else 1e-9
    assert np.max(np.abs(np.subtract(got, want))) < tol
    assert abs(t.height(frame.x, frame.y)) < 1e-4  # the start is at height 0


def test_step_heights_and_slope_normal() -> None:
    t = Terrain(Ground.parse(["step:0.1:3", "step:-0.3:5"]))
    assert [t.height(x, 0.0) for x in (2.9, 3.1, 4.9, 5.1)] == pytest.approx([0.0, 0.1, 0.1, -0.2])
    s = Terrain(Ground.parse("slope:8"), GroundFrame(yaw=math.pi / 2))  # walking along +y
    assert s.height(0.0, 2.0) == pytest.approx(2.0 * math.tan(math.radians(8)))
    assert s.height(2.0, 0.0) == pytest.approx(0.0)
    assert s.pitch(0.0, 1.0, math.pi / 2) == pytest.approx(math.radians(8))
    assert np.linalg.norm(s.normal(0.0, 1.0)) == pytest.approx(1.0)


def test_the_model_records_its_ground_and_friction(body: object) -> None:
    g = Ground.parse(["slope:3", "friction:0.5"])
    built = with_ground(body, g, GroundFrame(x=0.2))  # type: ignore[arg-type]
    assert ground_of(built.model) == (g, GroundFrame(x=0.2))
    assert np.all(built.model.geom_friction[:, 0] == 0.5)  # every geom: a sole's priority wins its contacts
    again = mujoco.MjModel.from_xml_string(built.xml)  # the saved model.xml draws and records the ground
    assert ground_of(again) == (g, GroundFrame(x=0.2))
    assert with_ground(body, Ground(), GroundFrame()) is body  # type: ignore[arg-type]
    assert terrain_of(body.model) is None  # type: ignore[attr-defined]


def test_rough_ground_is_the_same_for_a_seed_and_another_for_another(body: object) -> None:
    a = with_ground(body, Ground.parse("rough:0.03:1.0:4"), GroundFrame())  # type: ignore[arg-type]
    b = with_ground(body, Ground.parse("rough:0.03:1.0:4"), GroundFrame())  # type: ignore[arg-type]
    c = with_ground(body, Ground.parse("rough:0.03:1.0:5"), GroundFrame())  # type: ignore[arg-type]
    assert a.xml == b.xml
    assert np.array_equal(a.model.hfield_data, b.model.hfield_data)
    assert not np.array_equal(a.model.hfield_data, c.model.hfield_data)
    t = terrain_of(a.model)
    assert t is not None
    hs = [t.height(x, y) for x in np.linspace(2.0, 20.0, 40) for y in np.linspace(-2.0, 2.0, 9)]
    assert max(abs(h) for h in hs) <= 0.03 + 1e-9 and np.std(hs) > 0.005
