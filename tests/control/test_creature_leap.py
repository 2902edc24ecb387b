"""The creature's leap (control/creature/leap.py): its push's timing, its settings' checks, and a leap
from standing on the generated dog going through its phases with every foot off the floor."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from creature_clips import dog_clip

from bipedsim.control.creature.controller import CreatureController
from bipedsim.control.creature.leap import PHASES, LeapSettings, lead_time, leg_extension, push_time, stroke
from bipedsim.errors import ConfigError
from bipedsim.sim.rollout import Rollout, RolloutSpec
from bipedsim.sim.runner import load_scenario


def test_push_time_is_the_stroke_at_constant_acceleration() -> None:
    # rising 0.2 m from rest to 2 m/s at constant acceleration takes 0.2 s
    assert push_time(0.2, np.array([1.0, 0.0, 2.0])) == pytest.approx(0.2)
    with pytest.raises(ConfigError, match="leap.velocity"):
        push_time(0.2, np.array([3.0, 0.0, 0.0]))


@pytest.mark.parametrize("key, value", [("crouch", -0.1), ("straight", 0.0), ("land_stiffness", 2.0),
                                        ("crouch_time", float("nan"))])
def test_bad_leap_settings_name_their_key(key: str, value: float) -> None:
    with pytest.raises(ConfigError, match=f"leap.{key}"):
        LeapSettings(**{key: value}).validate()


class _Watch:
    """A rollout hook: asks for a leap at ``t_leap`` and records, per control step, the leap's phase and
    how many legs touch the floor."""

    def __init__(self, t_leap: float, velocity: np.ndarray) -> None:
        self.t_leap, self.velocity = t_leap, velocity
        self.rows: list[tuple[float, str, int, float]] = []

    def __call__(self, t: float, data: object, ctrl: CreatureController) -> None:
        if t >= self.t_leap and not ctrl.leaps and not ctrl.leaping:
            yaw = ctrl.heading(data)
            v = self.velocity
            ctrl.leap(t, np.array([v[0] * math.cos(yaw), v[0] * math.sin(yaw), v[2]]))
        phase = ctrl.leaps[-1].phase if ctrl.leaps else "-"
        self.rows.append((t, phase, sum(ctrl.legs.feet_down(data)), float(data.qpos[2])))


@pytest.mark.slow
def test_a_leap_from_standing_goes_through_its_phases_off_the_floor() -> None:
    """Standing, then a leap toward 0.5 m/s forward and 1.5 m/s up: the crouch, the push, a flight with
    every foot off the floor, the landing and the gait back; the take-off rises."""
    sc = load_scenario(bvh=dog_clip())
    ctrl = sc.controller()
    assert ctrl.can_leap()
    ctrl.leap_settings = dataclasses.replace(LeapSettings())
    g = ctrl.gait
    assert 0.0 <= leg_extension(g, 0.92) < g.legs.height
    assert stroke(g, LeapSettings()) > 0.0
    v = np.array([0.5, 0.0, 1.5])
    assert ctrl.leap_lead_s(v) == pytest.approx(lead_time(g, v, LeapSettings()))
    watch = _Watch(1.0, v)
    spec = RolloutSpec(seconds=4.0, start_frame=0.0, fall=sc.fall_criteria())
    with Rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=sc.clip.qpos[0].copy(),
                 hooks=[watch]) as run:
        while run.step():
            pass
        run.finish()
    seen = [p for p in dict.fromkeys(r[1] for r in watch.rows) if p != "-"]
    assert seen[:3] == list(PHASES[:3])
    flight = [r for r in watch.rows if r[1] == "flight"]
    assert any(r[2] == 0 for r in flight)
    rec = ctrl.leaps[0].record()
    assert rec["takeoff_reached_m_s"][2] > 0.0 and rec["t_takeoff_s"] > rec["t_start_s"]
