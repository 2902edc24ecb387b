"""How far a ground reaches: a plane-based ground's boxes cover any allowed run, rough ground's height
fields as far as their sample budget allows (at least 50 m), its heights over the first 50 m scaled to
the amplitude."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from bipedsim.model.build import load_model
from bipedsim.model.builtin import builtin_humanoid_path
from bipedsim.model.ground import Ground, GroundFrame, Terrain, terrain_of, with_ground
from bipedsim.model.ground_terms import AHEAD_M, BEHIND_M, ROUGH_MAX_SAMPLES
from bipedsim.sim.limits import MAX_ROLLOUT_S


@pytest.fixture(scope="module")
def body() -> object:
    return load_model(builtin_humanoid_path())


def _height_at(model: mujoco.MjModel, x: float, y: float) -> float:
    data = mujoco.MjData(model)
    data.qpos[2] = 1000.0  # the body out of the ray's way
    mujoco.mj_forward(model, data)
    gid = np.zeros(1, np.int32)
    d = mujoco.mj_ray(model, data, np.array([x, y, 100.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, gid)
    return 100.0 - d if d >= 0 else -math.inf


def test_a_step_top_reaches_past_any_allowed_run(body: object) -> None:
    g = Ground.parse(["step:0.1:3"])
    behind, ahead = g.extent()
    assert ahead >= MAX_ROLLOUT_S * 2.5 and behind >= BEHIND_M
    built = with_ground(body, g, GroundFrame())  # type: ignore[arg-type]
    for s, lat in ((100.0, 0.0), (2000.0, 20.0)):
        assert _height_at(built.model, s, lat) == pytest.approx(0.1, abs=1e-6)


def test_rough_ground_reaches_as_far_as_its_samples_allow(body: object) -> None:
    g = Ground.parse(["rough:0.03:1.0"])
    _, ahead = g.extent()
    assert ahead > 150.0  # a minute's walk at 2.5 m/s
    built = with_ground(body, g, GroundFrame())  # type: ignore[arg-type]
    assert built.model.nhfielddata <= ROUGH_MAX_SAMPLES
    t = terrain_of(built.model)
    assert t is not None
    x = ahead - 5.0
    assert _height_at(built.model, x, 0.3) == pytest.approx(t.height(x, 0.3), abs=2e-3)
    assert _height_at(built.model, ahead + 5.0, 0.0) == -math.inf  # nothing past the end
    # fine waves need more samples per metre: they keep at least the 50 m they always had
    assert Ground.parse(["rough:0.03:0.2"]).extent()[1] == AHEAD_M


def test_rough_heights_over_the_first_50_m_peak_at_the_amplitude() -> None:
    t = Terrain(Ground.parse(["rough:0.05:2.0:3"]))
    s = np.linspace(-BEHIND_M, AHEAD_M, 600)
    lat = np.linspace(-5.0, 5.0, 21)
    h = np.array([[t.height(a, b) for a in s] for b in lat])
    assert np.max(np.abs(h)) == pytest.approx(0.05, rel=0.05)

