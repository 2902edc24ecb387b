"""Capture-point step timing (``balance.capture``): the linear inverted pendulum's capture point against the
reference's and the hurried gait clock."""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from bipedsim.control.humanoid.feedback import capture_deviation, capture_excess, capture_rate
from bipedsim.control.humanoid.settings import CaptureConfig
from bipedsim.control.humanoid.simbicon import SimbiconController as Controller
from bipedsim.control.humanoid.simbicon import gait_source
from bipedsim.sim.push import Push
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


@pytest.fixture(scope="module")
def scenario():
    return load_scenario()


def test_capture_deviation_and_excess_beyond_the_walks_own_offset() -> None:
    cc = CaptureConfig(enabled=True, deadband=0.05)
    w = 3.0  # 1/s
    com = (0.10, -0.02, 1.60, 0.30)  # d forward, d left (m), v forward, v left (m/s)
    ref = (np.array([0.05, 0.04]), np.array([1.30, 0.0]))
    dev = capture_deviation(com, ref, w)
    # sagittal: (0.10 - 0.05) + (1.60 - 1.30) / 3; coronal: (-0.02 - 0.04) + 0.30 / 3
    assert dev == pytest.approx((0.15, 0.04))
    assert capture_excess(cc, dev, (0.0, 0.0)) == pytest.approx((0.10, 0.0))  # coronal inside the deadband
    # the walk's own steady offset (the running mean) is not a push's
    assert capture_excess(cc, dev, (0.10, -0.06)) == pytest.approx((0.0, 0.05))
    assert capture_excess(cc, (-0.3, 0.2), (0.0, 0.0)) == pytest.approx((-0.25, 0.15))


def test_capture_rate_hurries_the_clock_up_to_its_limit() -> None:
    on = CaptureConfig(enabled=True, tempo_gain=4.0, max_rate=1.5)
    assert capture_rate(on, (0.03, 0.04)) == pytest.approx(1.0 + 4.0 * 0.05)
    assert capture_rate(on, (0.3, 0.0)) == 1.5
    assert capture_rate(on, (0.0, 0.0)) == 1.0
    assert capture_rate(replace(on, enabled=False), (0.3, 0.0)) == 1.0
    assert capture_rate(replace(on, tempo_gain=0.0), (0.3, 0.0)) == 1.0


def with_capture(scenario, cc: CaptureConfig):
    """``scenario`` with ``balance.capture`` set to ``cc`` (and its cached unpushed rollouts dropped)."""
    cfg = replace(scenario.cfg, balance=replace(scenario.cfg.balance, capture=cc))
    return replace(scenario, cfg=cfg, extra={})


def test_capture_timing_off_leaves_the_clock_to_fsm_tempo(scenario) -> None:
    """``capture.enabled: false`` (the default) is the walk without capture timing, bit for bit the same as
    a zero ``tempo_gain``; on, it changes the walk."""
    assert not scenario.cfg.balance.capture.enabled
    spec = RolloutSpec(seconds=1.5)
    off = run_scenario(with_capture(scenario, CaptureConfig(enabled=False, tempo_gain=9.0)), spec)[0]
    zero = run_scenario(with_capture(scenario, CaptureConfig(enabled=True, tempo_gain=0.0)), spec)[0]
    on = run_scenario(with_capture(scenario, CaptureConfig(enabled=True)), spec)[0]
    assert off.distance_m == zero.distance_m and off.tracking_rmse_rad == zero.tracking_rmse_rad
    assert on.distance_m != off.distance_m


def test_capture_timing_catches_a_backward_push(scenario) -> None:
    """300 N x 0.2 s backward half way through the left swing (60 N s): with a swing of the reference's
    length the body walks backward over its own feet and falls; with the step hurried while the capture
    point lies behind the reference's, it steps in time and recovers."""
    push = [Push(300.0, 180.0, 0.2, state=2, fraction=0.5)]
    spec = RolloutSpec(seconds=5.0)
    off, _ = run_scenario(with_capture(scenario, CaptureConfig(enabled=False)), spec, pushes=push)
    on, _ = run_scenario(with_capture(scenario, CaptureConfig(enabled=True)), spec, pushes=push)
    assert off.outcome == "fall" and on.outcome == "no_fall"


@pytest.mark.parametrize(("tempo_gain", "hurried"), [(0.0, False), (4.0, True)])
def test_a_far_capture_point_hurries_the_gait_clock(scenario, tempo_gain: float, hurried: bool) -> None:
    """A body moving sideways at 0.8 m/s (no forward excess, so fsm.tempo stays at 1): with
    ``capture.tempo_gain`` the reference frame and the FSM's timer run faster than real time."""
    cc = CaptureConfig(enabled=True, tempo_gain=tempo_gain, max_rate=1.4, bias_s=100.0)
    cfg = replace(scenario.cfg, balance=replace(scenario.cfg.balance, capture=cc))
    model = scenario.built.model
    src = gait_source(model, scenario.built.plan, scenario.clip, cfg)
    c = Controller(model, scenario.built.plan, src, cfg)
    try:
        data = mujoco.MjData(model)
        data.qpos[:] = model.qpos0
        data.qpos[2] += 0.3  # in the air: no contacts, no strike
        mujoco.mj_forward(model, data)
        c.reset(data, src.a)
        r = data.xmat[c.pelvis].reshape(3, 3)
        h = math.atan2(r[1, 0], r[0, 0])
        v_fwd, v_left = src.speed(), 0.8
        data.qvel[:] = 0.0
        data.qvel[0] = v_fwd * math.cos(h) - v_left * math.sin(h)
        data.qvel[1] = v_fwd * math.sin(h) + v_left * math.cos(h)
        mujoco.mj_forward(model, data)
        dt = 0.004
        c(model, data, 0.0, dt)  # measures the COM
        c.playback.capture_bias = (0.0, 0.0)  # a walk that had no offset of its own until now
        f0 = c.frame
        c(model, data, dt, dt)
        if hurried:
            assert 1.05 < c.state.tempo <= 1.4
            assert c.frame - f0 == pytest.approx(c.state.tempo * dt / src.frame_time)
        else:
            assert c.state.tempo == 1.0
    finally:
        c.restore_model()

