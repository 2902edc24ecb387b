"""The tile world in physics (``bipedsim world ... --simulate``): the terrain's height field against the
world's heights (mj_ray), the height-grid ground's queries against MuJoCo's surface, the report's
``simulated`` block, errors for bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from bipedsim.cli import main
from bipedsim.errors import ConfigError
from bipedsim.model.build import load_model
from bipedsim.model.builtin import builtin_humanoid_path
from bipedsim.model.ground import ground_geoms, terrain_of
from bipedsim.model.ground_grid import GridTerrain, HeightGrid, with_height_grid
from bipedsim.synthesis.world import SimulateSettings, cross_world, load_creature, parse_world, world_grid
from bipedsim.synthesis.world.physics import Steering, can_simulate, fell_where, jump_records, simulate_crossing
from bipedsim.synthesis.world.synth import Curve
from bipedsim.synthesis.world.tiles import GAP_DEPTH_M, MOUNTAIN_HEIGHT_M, WALL_HEIGHT_M

REPO = Path(__file__).resolve().parents[2]
WORLDS = REPO / "examples" / "worlds"


@pytest.fixture(scope="module")
def body():  # noqa: ANN201
    """A small built model with a flat floor (the built-in humanoid: read from the package, no build)."""
    return load_model(builtin_humanoid_path())


def _ray_down(model: mujoco.MjModel, data: mujoco.MjData, x: float, y: float) -> tuple[float, int]:
    """The height (m) a ray straight down from 10 m meets at (x, y), and the geom it meets."""
    gid = np.zeros(1, np.int32)
    dist = mujoco.mj_ray(model, data, np.array([x, y, 10.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
    return 10.0 - dist, int(gid[0])


def test_terrain_height_field_matches_the_world_at_sample_points(body) -> None:  # noqa: ANN001
    w = parse_world({"tile": 2.0, "rows": ["S.M.", "..#.", "~..G"],
                     "events": [{"kind": "jump", "at": [2, 2], "width": 1.0}]}, "w.yaml")
    grid = world_grid(w, samples_per_tile=4)
    built = with_height_grid(body, grid)
    model = built.model
    data = mujoco.MjData(model)
    data.qpos[0:3] = [100.0, 100.0, 1.0]  # the body out of the rays' way
    mujoco.mj_forward(model, data)
    floor = model.geom("floor").id
    assert floor in ground_geoms(model)
    rows, cols = w.shape
    # every sample point (between samples the surface slopes from one tile's height to the next)
    xs = grid.x0 + grid.dx * np.arange(grid.heights.shape[1])
    ys = grid.y0 + grid.dy * np.arange(grid.heights.shape[0])
    pts = [(x, y) for y in ys for x in xs]
    assert len(pts) == (rows * 4 + 1) * (cols * 4 + 1)
    for x, y in pts:
        h, gid = _ray_down(model, data, x, y)
        assert gid == floor
        assert h == pytest.approx(float(w.terrain(np.array([x, y]))), abs=1e-4)
    heights = {(0, 2): MOUNTAIN_HEIGHT_M, (1, 2): WALL_HEIGHT_M, (2, 2): -GAP_DEPTH_M, (0, 0): 0.0}
    for (r, c), want in heights.items():
        assert _ray_down(model, data, *w.centre(r, c))[0] == pytest.approx(want, abs=1e-4)
    # the saved model.xml draws the same terrain
    again = mujoco.MjModel.from_xml_string(built.xml)
    d2 = mujoco.MjData(again)
    mujoco.mj_forward(again, d2)
    assert _ray_down(again, d2, *w.centre(0, 2))[0] == pytest.approx(MOUNTAIN_HEIGHT_M, abs=1e-4)


def test_grid_terrain_answers_what_mujoco_collides_with(body) -> None:  # noqa: ANN001
    rng = np.random.default_rng(3)
    grid = HeightGrid(heights=rng.uniform(-0.3, 0.5, (5, 7)), x0=-1.0, y0=2.0, dx=0.5, dy=0.7)
    model = with_height_grid(body, grid).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    terrain = terrain_of(model)
    assert isinstance(terrain, GridTerrain)
    assert np.allclose(terrain.grid.heights, grid.heights, atol=1e-6)
    for x, y in rng.uniform([-0.95, 2.05], [1.95, 4.75], size=(50, 2)):
        h, _ = _ray_down(model, data, x, y)
        assert terrain.height(x, y) == pytest.approx(h, abs=1e-5)  # the same triangles between samples
    # the normal is the surface's slope: a finite difference of the height inside one triangle
    x, y, e = 0.1, 2.1, 1e-4
    nx, ny, nz = terrain.normal(x, y)
    gx = (terrain.height(x + e, y) - terrain.height(x - e, y)) / (2 * e)
    gy = (terrain.height(x, y + e) - terrain.height(x, y - e)) / (2 * e)
    assert (nx / nz, ny / nz) == pytest.approx((-gx, -gy), abs=1e-6)
    assert math.isclose(nx * nx + ny * ny + nz * nz, 1.0)


@pytest.mark.parametrize("kw, text", [
    ({"heights": np.zeros((1, 4))}, "at least 2 x 2 samples"),
    ({"heights": np.array([[0.0, np.nan], [0.0, 0.0]])}, "finite"),
    ({"heights": np.zeros((2, 2)), "dx": 0.0}, "spacing must be positive"),
])
def test_bad_height_grids_are_refused(kw: dict, text: str) -> None:
    args = {"x0": 0.0, "y0": 0.0, "dx": 1.0, "dy": 1.0, **kw}
    with pytest.raises(ConfigError, match=text):
        HeightGrid(**args)


@pytest.mark.parametrize("key, value", [("lookahead_m", 0.0), ("time_factor", -1.0), ("samples_per_tile", 1),
                                        ("max_turn_rate", float("nan")), ("turn_share", 0.0),
                                        ("lookahead_s", -1.0)])
def test_bad_simulate_settings_name_their_key(key: str, value: float) -> None:
    with pytest.raises(ConfigError, match=f"simulate.{key}"):
        SimulateSettings(**{key: value}).validate()


def test_only_walked_paths_are_simulated() -> None:
    assert can_simulate(["walk", "walk"]) is None
    assert "fly" in can_simulate(["walk", "fly"])
    w = parse_world({"tile": 2.0, "rows": ["S.G"]}, "w.yaml")
    syn, rep = cross_world(w, load_creature(WORLDS / "pterosaur.yaml"))
    sim = simulate_crossing(w, load_creature(WORLDS / "pterosaur.yaml"), syn, rep["modes"])
    assert sim["outcome"] == "skipped" and "fly" in sim["why"]


def test_simulate_writes_the_simulated_block(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    world = tmp_path / "tiny.yaml"
    world.write_text('tile: 1.0\nrows:\n  - "SG"\n')
    rc = main(["world", str(world), str(WORLDS / "horse.yaml"), "-o", str(tmp_path / "h.bvh"),
               "--report", str(tmp_path / "R.json"), "--simulate"])
    assert rc == 0
    sim = json.loads((tmp_path / "R.json").read_text())["simulated"]
    assert sim["outcome"] in ("reached", "stopped", "fell")
    for key in ("end_to_goal_m", "max_off_path_m", "max_off_path_at", "left_path", "progress_m", "sim_s"):
        assert key in sim
    assert sim["outcome"] == "reached"  # one tile straight ahead: the horse walks it
    assert sim["end_to_goal_m"] < 0.75 and sim["max_off_path_m"] < 0.5
    steer = sim["steering"]
    assert 0 < steer["slowest_walk_m_s"] <= steer["walk_speed_m_s"] and steer["fastest_turn_rad_s"] >= 0
    assert "horse in physics: reached" in capsys.readouterr().out


def test_simulate_with_a_bad_world_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    world = tmp_path / "bad.yaml"
    world.write_text('tile: 1.0\nrows:\n  - "S?G"\n')
    rc = main(["world", str(world), str(WORLDS / "horse.yaml"), "-o", str(tmp_path / "h.bvh"), "--simulate"])
    assert rc == 2
    assert "unknown tile '?'" in capsys.readouterr().err


class _Ctrl:
    """A controller stand-in that records the steering commands."""

    def __init__(self) -> None:
        self.commands: list[tuple[float, float]] = []

    def heading(self, data: object) -> float:
        return 0.0

    def steer(self, t: float, yaw: float) -> None:
        self.commands.append((t, yaw))


class _Data:
    def __init__(self, x: float, y: float, vx: float = 0.0, vy: float = 0.0) -> None:
        self.qpos = np.array([x, y, 0.5])
        self.qvel = np.array([vx, vy, 0.0])


def test_steering_turns_toward_the_path_ahead_at_most_its_rate() -> None:
    # an L-shaped path: 4 m east, then 4 m north
    xy = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]])
    pts = np.concatenate([np.linspace(xy[0], xy[1], 41), np.linspace(xy[1], xy[2], 41)[1:]])
    ss = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    yaw = np.where(ss < 4.0, 0.0, math.pi / 2)
    curve = Curve(xy=pts, s=ss, yaw=yaw, tile_s=np.array([0.0]))
    w = parse_world({"tile": 2.0, "rows": ["..G", "S.."]}, "w.yaml")
    st = Steering(curve, SimulateSettings(lookahead_m=1.0, max_turn_rate=1.0, off_path_m=0.5), w)
    ctrl = _Ctrl()
    st(0.0, _Data(3.5, 0.0), ctrl)  # 0.5 m before the corner: the target is 0.5 m up the second leg
    assert ctrl.commands[-1] == (0.0, 0.0)  # no time has passed: no turn yet
    st(0.1, _Data(3.5, 0.0), ctrl)
    assert ctrl.commands[-1][1] == pytest.approx(0.1)  # turning left at 1 rad/s
    for k in range(2, 30):
        st(0.1 * k, _Data(3.5, 0.0), ctrl)
    assert ctrl.commands[-1][1] == pytest.approx(math.atan2(0.5, 0.5), abs=1e-9)  # at the target's bearing
    assert st.progress == pytest.approx(3.5) and st.left_at is None
    st(3.0, _Data(5.0, 2.0), ctrl)  # 1 m east of the second leg
    assert st.max_off == pytest.approx(1.0) and st.left_at["tile"] == [0, 2]
    assert st.progress == pytest.approx(6.0)


def _l_path() -> Curve:
    """An L-shaped path: 4 m east, then 4 m north (0.1 m samples)."""
    xy = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]])
    pts = np.concatenate([np.linspace(xy[0], xy[1], 41), np.linspace(xy[1], xy[2], 41)[1:]])
    ss = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    return Curve(xy=pts, s=ss, yaw=np.where(ss < 4.0, 0.0, math.pi / 2), tile_s=np.array([0.0]))


class _Walker(_Ctrl):
    """A controller stand-in with a planned walk: 0.8 m/s, a support of 0.2 (half-width over height)."""

    def __init__(self) -> None:
        super().__init__()
        self.speeds: list[tuple[float, float]] = []

    def turn_support(self) -> float:
        return 0.2

    def walk_speed(self) -> float:
        return 0.8

    def set_walk_speed(self, t: float, speed: float) -> None:
        self.speeds.append((t, speed))


def test_steering_holds_the_turn_rate_to_what_the_feet_carry_at_the_speed() -> None:
    w = parse_world({"tile": 2.0, "rows": ["..G", "S.."]}, "w.yaml")
    st = Steering(_l_path(), SimulateSettings(max_turn_rate=1.5, turn_share=0.15, speed_filter_s=0.0,
                                              slow_for_turns=False), w)
    ctrl = _Walker()
    st(0.0, _Data(3.5, 0.0, 1.0), ctrl)
    st(0.1, _Data(3.5, 0.0, 1.0), ctrl)
    # at 1 m/s: 0.15 x 9.81 x 0.2 / 1 = 0.29 rad/s, below max_turn_rate
    assert st.rate_limit == pytest.approx(0.15 * 9.81 * 0.2)
    assert ctrl.commands[-1][1] == pytest.approx(0.1 * 0.15 * 9.81 * 0.2)
    # the lookahead grows with the speed: 1.5 s x 1 m/s = 1.5 m, so the target is 1 m up the second leg
    slow = Steering(_l_path(), SimulateSettings(lookahead_s=1.5, speed_filter_s=0.0), w)
    slow(0.0, _Data(3.5, 0.0, 0.2), _Ctrl())
    fast = Steering(_l_path(), SimulateSettings(lookahead_s=1.5, speed_filter_s=0.0), w)
    fast(0.0, _Data(3.5, 0.0, 1.0), _Ctrl())
    assert slow.rate_limit == fast.rate_limit == SimulateSettings().max_turn_rate  # no turn_support: the rate only


def test_steering_slows_the_walk_for_a_sharp_turn_ahead_and_not_on_a_straight() -> None:
    w = parse_world({"tile": 2.0, "rows": ["..G", "S.."]}, "w.yaml")
    settings = SimulateSettings(turn_share=0.15, speed_filter_s=0.0)
    a = 0.15 * 9.81 * 0.2  # the lateral acceleration allowed (m/s^2)
    st, ctrl = Steering(_l_path(), settings, w), _Walker()
    for k in range(10):  # far from the corner on the first leg: the walk keeps its speed
        st(0.1 * k, _Data(0.5, 0.0, 0.8), ctrl)
    assert ctrl.speeds == [] and st.speed_cmd == pytest.approx(0.8)
    st.progress = 0.0
    for k in range(10, 60):  # 0.5 m before the corner: a quarter turn over a 1.2 m lookahead
        st(0.1 * k, _Data(3.5, 0.0, 0.8), ctrl)
    v_corner = math.sqrt(a / ((math.pi / 2) / 1.2))
    assert ctrl.speeds[0][1] == pytest.approx(0.8 - a * 0.1)  # braking at most a
    assert ctrl.speeds[-1][1] == pytest.approx(v_corner, rel=0.05)
    assert st.min_speed_cmd == pytest.approx(v_corner, rel=0.05)


def test_a_fall_says_how_far_the_root_was_from_a_gap() -> None:
    w = parse_world({"tile": 2.0, "rows": ["S..G"], "events": [{"kind": "jump", "at": [0, 2], "width": 1.0}]},
                    "w.yaml")
    x_gap = float(w.centre(0, 2)[0])  # the gap runs north-south across tile (0, 2), 1 m wide
    near = fell_where(w, 3.0, np.array([x_gap - 0.8, -1.0, 0.3]))
    assert near["tile"] == [0, 2] and near["to_gap_m"] == pytest.approx(0.3)
    assert fell_where(w, 3.0, np.array([x_gap, -1.0, 0.3]))["to_gap_m"] == 0.0
    assert fell_where(parse_world({"tile": 2.0, "rows": ["SG"]}, "w.yaml"), None, np.zeros(3))["to_gap_m"] is None


class _Leaper(_Ctrl):
    """A controller stand-in that leaps: a lead time of 0.5 s, records the leaps asked for."""

    def __init__(self) -> None:
        super().__init__()
        self.asked: list[tuple[float, np.ndarray]] = []

    def can_leap(self) -> bool:
        return True

    @property
    def leaping(self) -> bool:
        return bool(self.asked)

    def leap_lead_s(self, velocity: np.ndarray) -> float:
        return 0.5

    def leap(self, t: float, velocity: np.ndarray) -> None:
        self.asked.append((t, velocity))


def test_the_leap_is_asked_for_its_lead_time_before_the_take_off() -> None:
    from types import SimpleNamespace

    from bipedsim.synthesis.world.physics import Leaps

    pts = np.stack([np.linspace(0.0, 10.0, 101), np.zeros(101)], axis=1)
    curve = Curve(xy=pts, s=pts[:, 0].copy(), yaw=np.zeros(101), tile_s=np.array([0.0]))
    w = parse_world({"tile": 2.0, "rows": ["S...G"]}, "w.yaml")
    steering = Steering(curve, SimulateSettings(), w)
    jump = SimpleNamespace(s_takeoff=5.0, s_land=7.0, vx=3.0, vz=2.0)
    leaps, ctrl = Leaps([jump], curve, steering), _Leaper()
    data = SimpleNamespace(qpos=np.array([4.0, 0.0, 0.5]), qvel=np.array([1.0, 0.0, 0.0]))
    steering.progress = 4.4  # 0.6 m short of the take-off at 1 m/s: 0.6 s > the 0.5 s lead
    leaps(1.0, data, ctrl)
    assert ctrl.asked == []
    steering.progress = 4.55
    leaps(1.2, data, ctrl)
    assert len(ctrl.asked) == 1 and ctrl.asked[0][0] == 1.2
    assert ctrl.asked[0][1] == pytest.approx([3.0, 0.0, 2.0])  # along the path's heading, rising as planned
    leaps(1.3, data, ctrl)
    assert len(ctrl.asked) == 1 and leaps.asked == [1.2]


def test_the_leap_asks_the_slowest_take_off_that_flies_the_plans_distance() -> None:
    from types import SimpleNamespace

    from bipedsim.synthesis.world.physics import Leaps

    pts = np.stack([np.zeros(101), np.linspace(0.0, 10.0, 101)], axis=1)  # a path heading north
    curve = Curve(xy=pts, s=pts[:, 1].copy(), yaw=np.full(101, math.pi / 2), tile_s=np.array([0.0]))
    steering = Steering(curve, SimulateSettings(), parse_world({"tile": 2.0, "rows": ["S...G"]}, "w.yaml"))
    jump = SimpleNamespace(s_takeoff=5.0, s_land=7.0, vx=3.5, vz=2.0, g=9.81)
    v = Leaps([jump], curve, steering, 45.0).velocity(0)
    # 45 degrees over the 2 m from take-off to landing: v^2 = g d, half of it in each component
    assert v == pytest.approx([0.0, math.sqrt(9.81), math.sqrt(9.81)], abs=1e-9)
    assert Leaps([jump], curve, steering, None).velocity(0) == pytest.approx([0.0, 3.5, 2.0], abs=1e-9)
    with pytest.raises(ConfigError, match="simulate.leap_angle_deg"):
        SimulateSettings(leap_angle_deg=90.0).validate()


class _FootprintLeaper(_Leaper):
    """A leaper with a body: feet 0.4 m ahead of the root to 0.1 m behind it, a walked crouch of 0.3 s
    before the set and 0.5 s to the take-off."""

    def leap_footprint(self) -> tuple[float, float]:
        return 0.4, -0.1

    def leap_set_s(self) -> float:
        return 0.3


def test_the_leap_plants_the_front_feet_short_of_the_gap_and_lands_the_hind_feet_past_it() -> None:
    from types import SimpleNamespace

    from bipedsim.synthesis.world.physics import Leaps

    pts = np.stack([np.linspace(0.0, 10.0, 101), np.zeros(101)], axis=1)
    curve = Curve(xy=pts, s=pts[:, 0].copy(), yaw=np.zeros(101), tile_s=np.array([0.0]))
    steering = Steering(curve, SimulateSettings(), parse_world({"tile": 2.0, "rows": ["S...G"]}, "w.yaml"))
    jump = SimpleNamespace(s_takeoff=5.0, s_land=7.0, width=1.0, vx=3.0, vz=2.0, g=9.81)  # the gap: 5.5 to 6.5 m
    leaps, ctrl = Leaps([jump], curve, steering, 45.0, margin=0.2, speed_margin=1.1), _FootprintLeaper()
    # the set: front feet 0.2 x the 0.5 m footprint short of the near edge, 5.5 - 0.4 - 0.1 = 5.0 m
    assert leaps.set_point(0, ctrl) == pytest.approx(5.0)
    data = SimpleNamespace(qpos=np.array([4.0, 0.0, 0.5]), qvel=np.array([1.0, 0.0, 0.0]))
    steering.progress = 4.6  # 0.4 m short of the set at 1 m/s: 0.4 s > the 0.3 s crouch
    leaps(1.0, data, ctrl)
    assert ctrl.asked == []
    steering.progress = 4.75
    leaps(1.2, data, ctrl)
    assert len(ctrl.asked) == 1
    # take-off 0.2 m on (set and push at 1 m/s), the hind feet down 0.1 m past the far edge:
    # d = (6.5 + 0.1 + 0.1) - 5.2 = 1.5 m, at 45 degrees v^2 = g d, asked x 1.1
    v = 1.1 * math.sqrt(9.81 * 1.5) / math.sqrt(2.0)
    assert ctrl.asked[0][1] == pytest.approx([v, 0.0, v], rel=1e-6)
    assert leaps.planned[0]["flight_m"] == pytest.approx(1.5)


def test_a_jump_is_crossed_once_the_root_is_past_the_gaps_far_edge() -> None:
    """``crossed`` reads the gap, not the plan's landing point: a root over the far side of the gap (past
    6.5 m) short of the plan's landing (7.0 m) has crossed; one over the gap has not."""
    from types import SimpleNamespace

    from bipedsim.synthesis.world.physics import Leaps

    pts = np.stack([np.linspace(0.0, 10.0, 101), np.zeros(101)], axis=1)
    curve = Curve(xy=pts, s=pts[:, 0].copy(), yaw=np.zeros(101), tile_s=np.array([0.0]))
    steering = Steering(curve, SimulateSettings(), parse_world({"tile": 2.0, "rows": ["S...G"]}, "w.yaml"))
    jump = SimpleNamespace(tile=(0, 2), s_takeoff=5.0, s_land=7.0, width=1.0, vx=3.0, vz=2.0, speed=3.6)
    leaps = Leaps([jump], curve, steering)
    for progress, crossed in ((6.2, False), (6.6, True)):
        steering.progress = progress
        rec = jump_records([jump], steering, leaps, [])[0]
        assert rec["crossed"] is crossed
        assert (rec["s_near_edge_m"], rec["s_far_edge_m"]) == pytest.approx((5.5, 6.5))
