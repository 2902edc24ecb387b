"""The controller's speed range (docs/controller.md, "Speed range"): generated walks faster than the
built-in one, the Froude-scheduled sagittal c_v (``balance.cv_froude``) and its equation."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from bipedsim.control.balance import froude, sagittal_cd, sagittal_cv
from bipedsim.control.config import BalanceConfig, ControllerConfig, PlaneGains
from bipedsim.motion.bvh import bvh_text
from bipedsim.motion.gaitgen import WalkParams, walk_bvh_motion
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


def test_froude_number_and_the_scheduled_cv() -> None:
    assert froude(1.0, 1.0, 9.81) == pytest.approx(1 / 9.81)
    assert froude(2.0, 0.5, 10.0) == pytest.approx(0.8)
    b = BalanceConfig(sagittal=PlaneGains(0.55, 0.2), cv_froude=0.1)
    # at or below the threshold: c_v as configured
    assert sagittal_cv(b, 0.9, 0.93, 9.8) == 0.2
    assert sagittal_cv(b, math.sqrt(0.1 * 9.8 * 0.93), 0.93, 9.8) == pytest.approx(0.2)
    # above it: c_v x cv_froude / Fr, so c_v falls with the square of the speed
    fr = 1.5 ** 2 / (9.8 * 0.93)
    assert sagittal_cv(b, 1.5, 0.93, 9.8) == pytest.approx(0.2 * 0.1 / fr)
    assert sagittal_cv(b, 1.5, 0.93, 9.8) / sagittal_cv(b, 1.2, 0.93, 9.8) == pytest.approx((1.2 / 1.5) ** 2)
    # a shorter leg walks the same speed at a higher Froude number: a smaller c_v
    assert sagittal_cv(b, 1.2, 0.7, 9.8) < sagittal_cv(b, 1.2, 0.93, 9.8)
    # null: no scheduling at any speed
    assert sagittal_cv(replace(b, cv_froude=None), 1.5, 0.93, 9.8) == 0.2


def test_the_scheduled_cd() -> None:
    b = BalanceConfig(sagittal=PlaneGains(0.55, 0.2), cd_froude=0.13, cd_froude_power=0.3)
    # at or below the threshold (the built-in walk: 0.95 m/s on 0.93 m legs, Fr 0.098): c_d as configured
    assert sagittal_cd(b, 0.95, 0.93, 9.81) == 0.55
    assert sagittal_cd(b, math.sqrt(0.13 * 9.81 * 0.93), 0.93, 9.81) == pytest.approx(0.55)
    # above it: c_d x (cd_froude / Fr) ** power, i.e. falling with speed ** (2 power)
    fr = 1.5 ** 2 / (9.81 * 0.84)
    assert sagittal_cd(b, 1.5, 0.84, 9.81) == pytest.approx(0.55 * (0.13 / fr) ** 0.3)
    assert sagittal_cd(b, 1.5, 0.84, 9.81) / sagittal_cd(b, 1.2, 0.84, 9.81) == pytest.approx((1.2 / 1.5) ** 0.6)
    # the default config: on, and null switches it off
    assert BalanceConfig().cd_froude == 0.13
    assert sagittal_cd(replace(b, cd_froude=None), 1.5, 0.84, 9.81) == 0.55


def generated_walk(tmp_path: Path, speed: float, cadence: float, width: float = 0.2) -> Path:
    path = tmp_path / f"walk_{speed:g}_{cadence:g}_{width:g}.bvh"
    path.write_text(bvh_text(walk_bvh_motion(WalkParams(speed=speed, step_length=None, cadence=cadence,
                                                        step_width=width))))
    return path


def scheduled_off(tmp_path: Path, kv: str = "", extra: str = "") -> Path:
    """The default with the clip's own legs: c_v as given at every speed (``kv``: a balance overlay,
    ``extra``: more top-level lines)."""
    path = tmp_path / "no_cv_froude.yaml"
    path.write_text("balance: {cv_froude: null" + kv + "}\nreference: {feasible: false}\n" + extra)
    return path


def scheduled(tmp_path: Path, kv: str = "", extra: str = "") -> Path:
    """The Froude schedule on (it is off by default: docs/controller.md, *Speed range*), the clip's own
    legs (the generated walks above 1.1 m/s measure out of range and ``feasible: auto`` would re-solve
    them)."""
    path = tmp_path / "cv_froude.yaml"
    path.write_text("balance: {cv_froude: 0.1" + kv + "}\nreference: {feasible: false}\n" + extra)
    return path


def test_builtin_walk_keeps_its_cv_and_a_fast_walk_gets_a_smaller_one(tmp_path: Path) -> None:
    ctrl = load_scenario().controller()
    assert ctrl._cv_sagittal == ControllerConfig().balance.sagittal.cv  # 0.95 m/s: Froude 0.098 < 0.1
    fast = load_scenario(scheduled(tmp_path), generated_walk(tmp_path, 1.5, 129)).controller()
    leg = (sum(fast.leg_len["left"]) + sum(fast.leg_len["right"])) / 2
    assert leg == pytest.approx(0.933, abs=0.01)
    cv = ControllerConfig().balance.sagittal.cv
    assert fast._cv_sagittal == pytest.approx(cv * 0.1 * 9.8 * leg / 1.5 ** 2, rel=1e-6)


def test_a_1_2_mps_walk_at_110_steps_needs_the_scheduled_cv(tmp_path: Path) -> None:
    """1.2 m/s at 110 steps/min (0.65 m steps, the built-in walk's 0.44 m): with c_v 0.2 it falls within
    2 s (measured 1.33 s); with the Froude-scheduled c_v (0.13 here) it walks (20 s: 0.82 of its speed).
    Measured without velocity tuning (``kv_sagittal: 0``): with the default's 75 N per m/s the scheduled walk
    falls at 2.4 s (docs/controller.md, *Speed deficit*); and with the sagittal c_d as given (``cd_froude:
    null``, the c_d schedule came later: with it, c_d 0.52 here, the scheduled-c_v walk falls at 2.4 s)."""
    bvh = generated_walk(tmp_path, 1.2, 110)
    # and at the torso damping of then (100): at the default 175, without velocity tuning and the c_d
    # schedule, the scheduled walk falls at 1.6 s too
    # and the swing of then: the hips' limits on the actuator alone, c_v 0.2 (with the swing hip's net limit and
    # c_v 0.15 the unscheduled walk no longer falls)
    kv0 = ", velocity: {kv_sagittal: 0.0}, cd_froude: null, torso_kd: 100.0, sagittal: {cd: 0.55, cv: 0.2}"
    swing = "pd: {net_limit: \"off\"}\n"
    off, _ = run_scenario(load_scenario(scheduled_off(tmp_path, kv0, swing), bvh), RolloutSpec(seconds=10.0))
    assert off.outcome == "fall" and off.fall_time_s < 3.0
    on, _ = run_scenario(load_scenario(scheduled(tmp_path, kv0, swing), bvh), RolloutSpec(seconds=10.0))
    assert on.outcome == "no_fall", (on.fall_time_s, on.fall_reason)
    assert on.mean_speed_mps >= 0.7 * 1.2


@pytest.mark.parametrize(("speed", "cadence", "width"), [
    (0.6, 100, 0.2), (0.8, 135, 0.2), (1.0, 110, 0.2), (1.2, 129, 0.25), (1.35, 129, 0.2)])
def test_generated_walks_walk_20s_at_70_percent_of_their_speed(tmp_path: Path, speed: float, cadence: float,
                                                               width: float) -> None:
    """A sample of benchmarks/speed_range.py's walks that the default controller walks (about 1 s each)."""
    out, _ = run_scenario(load_scenario(scheduled(tmp_path), generated_walk(tmp_path, speed, cadence, width)),
                          RolloutSpec(seconds=20.0))
    assert out.outcome == "no_fall", (out.fall_time_s, out.fall_reason)
    assert out.mean_speed_mps >= 0.7 * speed


@pytest.mark.parametrize("cadence", [
    pytest.param(110, marks=pytest.mark.xfail(strict=True, reason="not met: the generated walk at 1.5 m/s and 110 "
                                              "steps/min falls within 2 s (docs/controller.md, 'Speed range': the "
                                              "reference needs a centre of pressure behind the heel)")),
    129])  # walks since the swing hip's net limit (session 14); it fell within 2 s before
def test_goal_a_1_5_mps_walk_walks_20s(tmp_path: Path, cadence: float) -> None:
    out, _ = run_scenario(load_scenario(scheduled(tmp_path), generated_walk(tmp_path, 1.5, cadence)),
                          RolloutSpec(seconds=20.0))
    assert out.outcome == "no_fall" and out.mean_speed_mps >= 0.7 * 1.5
