"""The torso's yaw target kept within reach of the stance foot (``balance.stance_yaw_limit``).

The ankles have no yaw hinge, so the torso law's yaw torque, reacted by the stance hip, goes down the
stance leg to the sole; a sole on its edge (a one-hinge ankle cannot roll it flat) touches the floor at one
point and holds no torque about the vertical. Asked to turn the pelvis back toward a heading its feet no
longer point at, the stance foot spins instead and the hip's twist limit drags the pelvis round (the
Bandai and CMU 12_03 sideways falls). The limit keeps the target within ``stance_yaw_limit`` of the
stance foot's yaw less the reference foot's own yaw from its pelvis.
"""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest
from conftest import (
    SHARED_BVH,
    need_shared,
    swing_as_measured,
    toes_as_measured,
    torso_as_measured,
    velocity_as_measured,
    without_modulation,
)

from bipedsim.control.humanoid.balance import yaw_within
from bipedsim.control.humanoid.simbicon import SimbiconController, gait_source
from bipedsim.control.humanoid.torso import torso_heading, torso_torque
from bipedsim.control.settings import ControllerConfig
from bipedsim.sim.runner import load_scenario


def test_yaw_within_moves_a_heading_to_the_limit_and_no_further() -> None:
    assert yaw_within(0.1, 0.0, 0.35) == pytest.approx(0.1)
    assert yaw_within(1.0, 0.0, 0.35) == pytest.approx(0.35)
    assert yaw_within(-1.0, 0.2, 0.35) == pytest.approx(-0.15)
    # across +-pi: 3.0 and -3.0 are 0.28 rad apart, inside the limit
    assert math.remainder(yaw_within(3.0, -3.0, 0.35) - 3.0, 2 * math.pi) == pytest.approx(0.0)
    assert math.remainder(yaw_within(2.0, -3.0, 0.35) - (-3.0 - 0.35), 2 * math.pi) == pytest.approx(0.0)


def _yaw(r) -> float:
    return math.atan2(float(r[1, 0]), float(r[0, 0]))


@pytest.fixture(scope="module")
def scenario():
    return load_scenario()


def test_torso_heading_follows_a_turned_stance_foot_to_within_the_limit(scenario) -> None:
    """The built-in body at its start, turned 1 rad about the vertical under an unchanged heading target:
    the torso law's heading is the stance foot's anchor (its yaw less the reference foot's from its pelvis)
    plus the limit toward the target; an unloaded stance foot, or no limit, leaves the target's."""
    model, cfg = scenario.built.model, scenario.cfg
    lim = cfg.balance.stance_yaw_limit
    assert lim is not None
    c = SimbiconController(model, scenario.built.plan, gait_source(model, scenario.built.plan, scenario.clip, cfg), cfg)
    data = mujoco.MjData(model)
    try:
        data.qpos[:] = scenario.clip.qpos[c.start_frame()]
        mujoco.mj_forward(model, data)
        c.reset(data, float(c.start_frame()))
        h_target = _yaw(c.steering.r_heading)
        # turn the whole body by 1 rad (root quaternion about z)
        q = data.qpos[3:7].copy()
        turn = [math.cos(0.5), 0.0, 0.0, math.sin(0.5)]
        mujoco.mju_mulQuat(data.qpos[3:7], turn, q)
        mujoco.mj_forward(model, data)
        stance, swing = c.fsm.stance, c.fsm.swing
        f_ref = c.source.foot_target(c.frame, c.fsm.state, stance)
        anchor = _yaw(data.xmat[c.tables.foot_body[stance]].reshape(3, 3)) - _yaw(f_ref)
        assert math.remainder(anchor - h_target, 2 * math.pi) == pytest.approx(1.0, abs=0.15)
        r = c._torso_heading(data, {stance: 500.0, swing: 0.0})
        assert math.remainder(_yaw(r) - anchor, 2 * math.pi) == pytest.approx(-lim, abs=1e-9)
        # the torso law then turns the pelvis toward that heading, not the target's: its yaw torque is
        # smaller than without the limit by heading_kp (1 rad less the limit), about
        pelvis_ref = c.source.pelvis_target(c.frame, c.fsm.state)
        r_p = data.xmat[c.pelvis].reshape(3, 3)
        pm = r_p.ravel().tolist()
        tz = torso_torque(cfg.balance, c.tables.roll_kp, r, pelvis_ref, r_p, pm, [0.0] * 3, 1.0, 0.0)[2]
        tz0 = torso_torque(cfg.balance, c.tables.roll_kp, c.steering.r_heading, pelvis_ref, r_p, pm, [0.0] * 3, 1.0,
                           0.0)[2]
        assert abs(tz) < abs(tz0) - 0.5 * cfg.balance.heading_kp * (1.0 - lim)
        # an unloaded stance foot holds nothing to turn against: the target's heading
        assert c._torso_heading(data, {stance: 0.0, swing: 0.0}) is c.steering.r_heading
        # no limit: the target's heading
        fm = data.xmat[c.tables.foot_body[stance]]
        assert torso_heading(c.steering.r_heading, np.eye(3), None, 500.0, f_ref, fm) is c.steering.r_heading
    finally:
        c.restore_model()


@pytest.mark.slow
@pytest.mark.parametrize("name", [
    # seeds 0-2, soft soles, torso damping 100: the limit delays the sideways falls
    "bandai2_walk_exhausted_001.bvh",
    # (CMU 12_03, whose swing toes peel off the floor, walks its 20 s on most seeds either way: no contrast)
])
def test_stance_yaw_limit_delays_the_sideways_falls(name: str) -> None:
    """Seeds 0-2, the reference modulation off as first measured (single runs of these walks are chaotic):
    without the limit a run falls, with it the median run walks at least 1 s longer. (On the hard soles
    every run without it fell within 2.3-4.4 s; the soft soles hold part of the spin themselves,
    docs/controller.md, *Soft soles*.)"""
    import statistics

    from bipedsim.sim.runner import run_seeds

    need_shared()
    with toes_as_measured():  # as measured (Bandai's toes: 3 cm; with its real-length ones 12-14 s either way)
        sc = load_scenario(None, SHARED_BVH / "human" / name)
    # as measured: without the modulation (with it Bandai falls at 2 s either way), at the torso damping of
    # 100 (at 175 CMU 12_03 walks its 20 s without the limit too); the limit itself today's (0.6)
    sc = replace(sc, cfg=velocity_as_measured(swing_as_measured(torso_as_measured(without_modulation(sc.cfg)))))
    lim = ControllerConfig().balance.stance_yaw_limit
    sc = replace(sc, cfg=replace(sc.cfg, balance=replace(sc.cfg.balance, stance_yaw_limit=lim)))
    off = replace(sc.cfg, balance=replace(sc.cfg.balance, stance_yaw_limit=None))
    with_ = [o.fall_time_s or 20.0 for o in run_seeds(sc, 20.0, 3)]
    without = [o.fall_time_s or 20.0 for o in run_seeds(replace(sc, cfg=off), 20.0, 3)]
    assert min(without) < 20.0, without
    assert float(statistics.median(with_)) > float(statistics.median(without)) + 1.0, (with_, without)
