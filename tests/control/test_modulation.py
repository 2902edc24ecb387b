"""Reference modulation (Lee, Kim & Lee 2010; ``modulation:`` in the controller YAML): swing-foot height by
two-link leg IK, stance-ankle feedback."""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from bipedsim.control.humanoid.modulation import stance_tilt, swing_foot_ik, two_link
from bipedsim.control.humanoid.simbicon import SimbiconController, gait_source
from bipedsim.control.settings import ModulationConfig, StanceAnkleConfig, SwingFootConfig
from bipedsim.sim.runner import load_scenario


@pytest.fixture(scope="module")
def scenario():
    return load_scenario()


def _ik(c, data, q_d, tau) -> float:
    """The swing-foot IK as the control step calls it, for the left foot swinging (state 2)."""
    src = c.source
    return swing_foot_ik(c.cfg.modulation.swing_foot, c.tables, data, src.swing_leg(c.frame, "left"),
                         src.swing_phase(c.frame, "left"), "left", "right", c.drive.akp, q_d, tau)


def controller(scenario, **mod):
    cfg = replace(scenario.cfg, modulation=replace(ModulationConfig(), **mod))
    src = gait_source(scenario.built.model, scenario.built.plan, scenario.clip, cfg)
    return SimbiconController(scenario.built.model, scenario.built.plan, src, cfg)


@pytest.mark.parametrize("reach", [0.5, 0.7, 0.85, 0.9])
def test_two_link_reaches_the_ankle(reach: float) -> None:
    l1, l2 = 0.45, 0.47
    knee, thigh = two_link(l1, l2, reach)
    # thigh turned `thigh` ahead of the hip-ankle line (along 0), the shin turned back by the knee
    x = l1 * math.cos(thigh) + l2 * math.cos(thigh - knee)
    y = l1 * math.sin(thigh) + l2 * math.sin(thigh - knee)
    assert math.hypot(x, y) == pytest.approx(reach, abs=1e-9)
    assert math.atan2(y, x) == pytest.approx(0.0, abs=1e-9)
    # a reach beyond the links' span is clamped: the leg straight
    assert two_link(l1, l2, 2.0)[0] == pytest.approx(0.0, abs=0.03)


def test_swing_phase_runs_from_the_stance_strike_to_the_swing_strike(scenario) -> None:
    src = gait_source(scenario.built.model, scenario.built.plan, scenario.clip, scenario.cfg)
    a = src.a  # a right strike: the left foot's step begins
    nxt = src.next_strike(a + 1e-3, "left")
    assert src.swing_phase(a, "left") == pytest.approx(0.0)
    assert src.swing_phase(nxt - 1e-6, "left") == pytest.approx(1.0, abs=1e-3)
    mids = [src.swing_phase(a + u * (nxt - a), "left") for u in (0.25, 0.5, 0.75)]
    assert mids == pytest.approx([0.25, 0.5, 0.75], abs=1e-6)


def test_swing_foot_ik_raises_the_ankle_by_bending_the_knee(scenario) -> None:
    c = controller(scenario, swing_foot=SwingFootConfig(enabled=True, height_gain=0.0, lift=0.05, deadband=0.0))
    try:
        src, model = c.source, c.model
        data = mujoco.MjData(model)
        c.reset(data, src.a)
        left = src.next_strike(src.a + 1e-3, "left")
        c.frame = src.a + 0.5 * (left - src.a)  # mid-swing of the left foot: lift 0.05 m
        data.qpos[:] = src.reference_qpos(c.frame, 2, data.qpos)
        mujoco.mj_forward(model, data)
        q_d, _ = src.hinge_targets(c.frame, 2)
        tau = np.zeros(len(q_d))
        k = c.tables.knee["left"]
        before = float(q_d[k])
        turn = _ik(c, data, q_d, tau)
        x, z, _ = src.swing_leg(c.frame, "left")
        l1, l2 = c.tables.leg_len["left"]
        dk = two_link(l1, l2, math.hypot(x, z + 0.05))[0] - two_link(l1, l2, math.hypot(x, z))[0]
        assert dk > 0.02
        assert q_d[k] - before == pytest.approx(min(dk, c.tables.thi[k] - before), abs=1e-9)
        assert tau[k] == pytest.approx(c.drive.akp[k] * (q_d[k] - before))
        assert turn > 0  # the thigh turns forward to keep the ankle above the same point
    finally:
        c.restore_model()


def test_stance_ankle_tilts_the_foot_toe_down_when_the_com_runs_ahead(scenario) -> None:
    c = controller(scenario, stance_ankle=StanceAnkleConfig(enabled=True, kv=0.1, kd=0.0, max_angle=0.2))
    try:
        sa = c.cfg.modulation.stance_ankle
        d_ref, v_ref = c.source.com_reference(c.frame, c.fsm.stance)
        com = (float(d_ref[0]), float(d_ref[1]), float(v_ref[0]) + 1.0, float(v_ref[1]))
        r = stance_tilt(sa, com, d_ref, v_ref)
        assert math.asin(-r[2, 0]) == pytest.approx(0.1, abs=1e-9)  # toe down by kv x 1 m/s
        com = (float(d_ref[0]), float(d_ref[1]), float(v_ref[0]) + 5.0, float(v_ref[1]))
        assert math.asin(-stance_tilt(sa, com, d_ref, v_ref)[2, 0]) == pytest.approx(0.2, abs=1e-9)  # clipped
    finally:
        c.restore_model()


def test_swing_foot_ik_with_a_deadband_leaves_a_foot_at_its_reference_height_alone(scenario) -> None:
    c = controller(scenario, swing_foot=SwingFootConfig(enabled=True, deadband=0.02))
    try:
        src, model = c.source, c.model
        data = mujoco.MjData(model)
        c.reset(data, src.a)
        left = src.next_strike(src.a + 1e-3, "left")
        c.frame = src.a + 0.5 * (left - src.a)
        data.qpos[:] = src.reference_qpos(c.frame, 2, data.qpos)  # the foot exactly as high as the reference's
        mujoco.mj_forward(model, data)
        q_d, _ = src.hinge_targets(c.frame, 2)
        before, tau = q_d.copy(), np.zeros(len(q_d))
        assert _ik(c, data, q_d, tau) == 0.0
        assert np.array_equal(q_d, before) and not tau.any()
    finally:
        c.restore_model()


def test_auto_modulation_is_on_for_a_capture_and_off_for_the_built_in_walk() -> None:
    """``enabled: auto`` (the default of the swing-foot IK and the stance-ankle feedback) follows the
    feasibility measure: on for a capture whose legs measure infeasible for the body, off for the built-in
    walk generated for it; the resolved switches are what the controller and outcome.json see."""
    from conftest import SHARED_BVH

    from bipedsim.control.settings import ControllerConfig, for_reference
    from bipedsim.sim.runner import load_scenario

    d = ControllerConfig()
    assert d.modulation.swing_foot.enabled == "auto" and d.modulation.stance_ankle.enabled == "auto"
    on, off = for_reference(d, True), for_reference(d, False)
    assert on.modulation.swing_foot.enabled is True and on.modulation.stance_ankle.enabled is True
    assert off.modulation.swing_foot.enabled is False and off.modulation.stance_ankle.enabled is False
    forced = replace(d, modulation=replace(d.modulation, swing_foot=SwingFootConfig(enabled=False)))
    assert for_reference(forced, True).modulation.swing_foot.enabled is False  # an explicit switch stays
    builtin = load_scenario(None)
    assert builtin.cfg.modulation.swing_foot.enabled is False and not builtin.controller().tables.ik_on
    cap = load_scenario(None, SHARED_BVH / "human" / "cmu_02_01_walk__holden31_crlf.bvh")
    c = cap.controller()
    assert cap.cfg.modulation.swing_foot.enabled is True and c.tables.ik_on and c.tables.ankle_feedback_on
    c.restore_model()
