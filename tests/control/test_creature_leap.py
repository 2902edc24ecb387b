"""The creature's leap (control/creature/leap.py): its push's timing, its settings' checks, the feet's
share of a wrench held in their friction cones, a leap from walking on the generated dog reaching its
take-off velocity on all its feet and holding its legs still as it rises, one going through its phases with
every foot off the floor, and the gait resuming at the speed the body has."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from conftest import HAVE_SHARED
from creature_clips import dog_clip

from bipedsim.control.creature.controller import CreatureController
from bipedsim.control.creature.leap import (
    PHASES,
    LeapSettings,
    cone_forces,
    lead_time,
    leg_extension,
    push_time,
    resume_gait,
    stroke,
)
from bipedsim.errors import ConfigError
from bipedsim.sim.rollout import Rollout, RolloutSpec
from bipedsim.sim.runner import load_scenario


def test_push_time_is_the_stroke_at_constant_acceleration() -> None:
    # rising 0.2 m from rest to 2 m/s at constant acceleration takes 0.2 s
    assert push_time(0.2, np.array([1.0, 0.0, 2.0])) == pytest.approx(0.2)
    with pytest.raises(ConfigError, match="leap.velocity"):
        push_time(0.2, np.array([3.0, 0.0, 0.0]))


@pytest.mark.parametrize("key, value", [("crouch", -0.1), ("straight", 0.0), ("land_stiffness", 2.0),
                                        ("crouch_time", float("nan")), ("set_time", -1.0), ("cone_edges", 2),
                                        ("moment_weight", 0.0), ("land_max", 0.0), ("settle_speed", -1.0),
                                        ("settle_spin", 0.0)])
def test_bad_leap_settings_name_their_key(key: str, value: float) -> None:
    with pytest.raises(ConfigError, match=f"leap.{key}"):
        LeapSettings(**{key: value}).validate()


class _Landed:
    """A stand-in for a landed leap: its settings, sqrt(g/L) (1/s), L (m) and a mean spin (rad/s)."""

    def __init__(self, spin: np.ndarray) -> None:
        self.settings, self.w0, self.height, self.spin = LeapSettings(), 4.5, 0.48, spin

    def _mean_spin(self, data: object) -> tuple[np.ndarray, np.ndarray]:
        return np.eye(3), self.spin


def test_a_landing_is_settled_on_its_feet_at_rest() -> None:
    """All feet but one down, the fall and the spin stopped: settled; a foot more in the air, a body still
    rising at 0.3 m/s or rolling at 2 rad/s: not (the gait would restart from feet in the air)."""
    from bipedsim.control.creature.leap_dynamics import LeapDynamics

    still = _Landed(np.zeros(3))
    assert LeapDynamics._settled(still, None, [True, True, True, False], np.array([0.5, 0.0, 0.05]))
    assert not LeapDynamics._settled(still, None, [True, True, False, False], np.zeros(3))
    assert not LeapDynamics._settled(still, None, [True] * 4, np.array([0.0, 0.0, 0.3]))
    assert not LeapDynamics._settled(_Landed(np.array([2.0, 0.0, 0.0])), None, [True] * 4, np.zeros(3))


def test_the_feet_share_a_wrench_inside_their_friction_cones() -> None:
    """Four feet under a body 0.45 m up: a push forward and up (through the centre of mass) is carried
    exactly, the hind feet taking most of it (the moment of the forward force about the centre of mass);
    a sideways pull beyond friction is carried only as far as the cones allow."""
    feet = np.array([[0.3, 0.1, 0.0], [0.3, -0.1, 0.0], [-0.3, 0.1, 0.0], [-0.3, -0.1, 0.0]])
    com = np.array([0.0, 0.0, 0.45])
    f = cone_forces(np.array([245.0, 0.0, 448.0]), np.zeros(3), feet, com, 0.8, 0.45)
    assert f.sum(axis=0) == pytest.approx([245.0, 0.0, 448.0], abs=1.0)
    moment = sum(np.cross(p - com, fi) for p, fi in zip(feet, f))
    assert np.abs(moment).max() < 1.0
    assert f[2:, 2].sum() > 3.0 * f[:2, 2].sum()  # the hind feet push
    weak = cone_forces(np.array([0.0, 0.0, 400.0]), np.zeros(3), feet, com, 0.8, 0.45,
                       capacity=np.array([1.0, 1.0, 0.05, 1.0]))
    assert weak[2, 2] < 0.2 * weak[3, 2]  # a foot of little capacity gets a small share
    assert weak.sum(axis=0) == pytest.approx([0.0, 0.0, 400.0], abs=1.0)
    for want in (np.array([245.0, 0.0, 448.0]), np.array([0.0, 500.0, 100.0])):
        f = cone_forces(want, np.zeros(3), feet, com, 0.8, 0.45)
        assert (f[:, 2] >= -1e-9).all()
        assert (np.linalg.norm(f[:, 0:2], axis=1) <= 0.8 * f[:, 2] + 1e-6).all()


def _walk(sc, ctrl, seconds: float, watch) -> None:
    """``ctrl`` run ``seconds`` s from the clip's first frame, ``watch`` seeing every step."""
    spec = RolloutSpec(seconds=seconds, start_frame=0.0, fall=sc.fall_criteria())
    with Rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=sc.clip.qpos[0].copy(),
                 hooks=[watch]) as run:
        while run.step():
            pass
        run.finish()


@pytest.mark.skipif(not HAVE_SHARED, reason="the generated stand-in dog leaves the floor with 69 % of the "
                    "vertical take-off asked; the bound is the shared MANN dog's")
def test_a_leap_from_walking_reaches_its_take_off_on_all_its_feet() -> None:
    """The shared dog, walking, asked at 1 s for 1 m/s forward and 2 m/s up: it crouches as it walks,
    sets its feet and pushes on all four, none leaving the floor before half the push, and leaves the
    floor with at least 85 % of the velocity asked, forward and up."""
    sc = load_scenario(bvh=dog_clip())
    ctrl = sc.controller()
    watch = _Watch(1.0, np.array([1.0, 0.0, 2.0]))
    _walk(sc, ctrl, 1.9, watch)
    rec = ctrl.leaps[0].record()
    assert rec["push_feet"] == 4
    assert all(t is None or t >= 0.5 * rec["push_s"] for t in rec["push_feet_lost_s"])
    # rising, the legs hold the pose they left the floor in (a leg swung in flight turns the trunk)
    rising = [q for t, phase, q, vz in watch.targets if phase == "flight" and vz > 0.0]
    assert len(rising) > 5
    assert max(float(np.abs(q - rising[0]).max()) for q in rising) < 1e-12
    asked, got = np.array(rec["takeoff_planned_m_s"]), np.array(rec["takeoff_reached_m_s"])
    ahead = asked[0:2] / np.linalg.norm(asked[0:2])
    assert got[0:2] @ ahead >= 0.85 * np.linalg.norm(asked[0:2])
    assert got[2] >= 0.85 * asked[2]


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_SHARED, reason="measured on the shared MANN dog's walk")
def test_the_push_brings_the_walks_spin_to_rest() -> None:
    """The shared dog, walking, asked to leap at three walking phases (1.0, 1.1, 1.2 s): with the push
    bringing the angular momentum to rest by the take-off (``push_spin_stop``) it leaves the floor
    spinning less, over the three, than with the attitude PD's damping alone."""
    spins = {}
    for stop in (True, False):
        total = 0.0
        for t_leap in (1.0, 1.1, 1.2):
            sc = load_scenario(bvh=dog_clip())
            ctrl = sc.controller()
            ctrl.leap_settings = dataclasses.replace(ctrl.leap_settings, push_spin_stop=stop)
            _walk(sc, ctrl, t_leap + 0.9, _Watch(t_leap, np.array([1.0, 0.0, 2.0])))
            total += float(np.linalg.norm(ctrl.leaps[0].record()["takeoff_spin_rad_s"]))
        spins[stop] = total
    assert spins[True] <= 0.95 * spins[False]


class _Watch:
    """A rollout hook: asks for a leap at ``t_leap`` and records, per control step, the leap's phase and
    how many legs touch the floor."""

    def __init__(self, t_leap: float, velocity: np.ndarray) -> None:
        self.t_leap, self.velocity = t_leap, velocity
        self.rows: list[tuple[float, str, int, float]] = []
        #: per control step of a leap: time (s), phase, the legs' joint targets, the centre of mass's v_z (m/s)
        self.targets: list[tuple[float, str, np.ndarray, float]] = []

    def __call__(self, t: float, data: object, ctrl: CreatureController) -> None:
        if t >= self.t_leap and not ctrl.leaps and not ctrl.leaping:
            yaw = ctrl.heading(data)
            v = self.velocity
            ctrl.leap(t, np.array([v[0] * math.cos(yaw), v[0] * math.sin(yaw), v[2]]))
        phase = ctrl.leaps[-1].phase if ctrl.leaps else "-"
        self.rows.append((t, phase, sum(ctrl.legs.feet_down(data)), float(data.qpos[2])))
        if ctrl.leaps:
            leap = ctrl.leaps[-1]
            self.targets.append((t, phase, leap.target.copy(), float(leap._com_velocity(data)[2])))


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
    _walk(sc, ctrl, 4.0, watch)
    seen = [p for p in dict.fromkeys(r[1] for r in watch.rows) if p != "-"]
    assert seen[:4] == list(PHASES[:4])
    flight = [r for r in watch.rows if r[1] == "flight"]
    assert any(r[2] == 0 for r in flight)
    rec = ctrl.leaps[0].record()
    assert rec["takeoff_reached_m_s"][2] > 0.0 and rec["t_takeoff_s"] > rec["t_start_s"]


def test_the_gait_resumes_at_the_speed_the_body_has() -> None:
    """After a landing the plan restarts from where the root is: moving at half the walking speed along
    the heading, half-way up the speed ramp (no settle); at rest, the settle time first."""
    sc = load_scenario(bvh=dog_clip())
    ctrl = sc.controller()
    data = mujoco.MjData(sc.built.model)
    data.qpos[:] = sc.clip.qpos[0]
    ctrl.reset(data, 0.0)
    mujoco.mj_forward(sc.built.model, data)
    g = ctrl.gait
    v_des, t = g.clock.v_des, 3.0
    data.qvel[0:2] = 0.5 * v_des * g.planner.dir
    resume_gait(g, data, t, g.target)
    assert g.clock.speed_at(t) == pytest.approx(0.5 * v_des)
    assert g.planner.root_path(t) == pytest.approx(data.qpos[0:2])
    data.qvel[:] = 0.0
    resume_gait(g, data, t, g.target)
    assert g.clock.t_walk == pytest.approx(t + g.bal.settle_s)
    assert g.planner.root_path(t) == pytest.approx(data.qpos[0:2])
