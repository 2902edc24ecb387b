"""One controller interface, one rollout loop: every body goes through ``sim.rollout.rollout`` with a
:class:`~bipedsim.control.base.Controller`; pushes, recording and fall detection use only the interface."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bipedsim.control import CONTROLLERS, Controller, CreatureController, SimbiconController
from bipedsim.control.creature.controller import quat_error_rotvecs
from bipedsim.data import HORSE_WALK, PTEROSAUR_FLIGHT
from bipedsim.errors import ConfigError
from bipedsim.sim.push import Push
from bipedsim.sim.recorder import Recorder
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

SIM = Path(__file__).resolve().parents[2] / "src" / "bipedsim" / "sim"


def test_one_step_loop_in_sim() -> None:
    """Only the rollout loop steps the physics (creature_run.py's second loop is gone)."""
    stepping = sorted(p.name for p in SIM.glob("*.py") if re.search(r"mujoco\.mj_step\(", p.read_text()))
    assert stepping == ["rollout.py"]


def test_registry_has_a_controller_per_body_kind() -> None:
    assert set(CONTROLLERS) == {"humanoid", "creature"}


@pytest.fixture(scope="module")
def horse():
    return load_scenario(bvh=HORSE_WALK, profile="creature")


@pytest.fixture(scope="module")
def walk():
    return load_scenario()


def _model_arrays(model) -> dict[str, np.ndarray]:  # noqa: ANN001
    return {k: getattr(model, k).copy() for k in ("dof_damping", "actuator_gainprm", "actuator_biasprm",
                                                 "actuator_biastype", "actuator_forcerange", "actuator_ctrlrange")}


@pytest.mark.parametrize("which", ["walk", "horse"])
def test_making_a_controller_leaves_the_model_alone(which: str, request: pytest.FixtureRequest) -> None:
    """Constructing a controller must not change the model: a second one made before the first runs
    (the push sweep's unpushed twin) used to double the joint damping and fall at 1.8 s."""
    sc = request.getfixturevalue(which)
    before = _model_arrays(sc.built.model)
    a = sc.controller()
    b = sc.controller()
    assert isinstance(a, Controller) and isinstance(b, Controller)
    after = _model_arrays(sc.built.model)
    assert all(np.array_equal(before[k], after[k]) for k in before)
    o1, _ = run_scenario(sc, RolloutSpec(seconds=2.0))
    o2, _ = run_scenario(sc, RolloutSpec(seconds=2.0))
    assert (o1.outcome, o1.distance_m, o1.tracking_rmse_rad) == (o2.outcome, o2.distance_m, o2.tracking_rmse_rad)
    assert all(np.array_equal(before[k], getattr(sc.built.model, k)) for k in before)  # restored after


def test_quaternion_error_matches_scipy() -> None:
    rng = np.random.default_rng(3)
    a, b = Rotation.random(50, random_state=rng), Rotation.random(50, random_state=rng)
    wxyz = lambda r: np.roll(r.as_quat(), 1, axis=1)  # noqa: E731 -- scipy is (x, y, z, w)
    got = quat_error_rotvecs(wxyz(a), wxyz(b))
    assert np.allclose(got, (a.inv() * b).as_rotvec(), atol=1e-9)
    assert np.allclose(quat_error_rotvecs(wxyz(a), -wxyz(a)), 0.0, atol=1e-9)  # q and -q: no error


def test_creature_runs_through_the_same_loop_with_pushes_and_recorder(horse) -> None:
    rec = Recorder(horse.built.model, feet=len(horse.foot_names()))
    out, ctrl = run_scenario(horse, RolloutSpec(seconds=1.5), hooks=[rec],
                             pushes=[Push(magnitude=300, direction=90, duration=0.2, start=0.5)])
    assert isinstance(ctrl, CreatureController) and out.config["profile"] == "creature"
    tr = rec.trajectory({})
    assert tr.contact_force.shape == (tr.num_samples, len(horse.built.plan.foot_bodies))
    assert tr.contact_force.max() > 0  # the feet carry the body
    pushed = tr.xfrc[:, ctrl.root_body]  # no torso: the push acts on the creature's root
    assert np.linalg.norm(pushed, axis=1).max() == pytest.approx(300, rel=1e-5)
    assert out.extra["push_start_s"] == pytest.approx(0.5, abs=0.01)


def test_phase_timed_push_needs_a_gait_machine(horse) -> None:
    with pytest.raises(ConfigError, match="timed by gait state 2, but this body's controller has no gait states"):
        run_scenario(horse, RolloutSpec(seconds=3.0), pushes=[Push(magnitude=50, state=2, fraction=0.5)])


def test_creature_fall_is_judged_against_the_reference_root() -> None:
    """The MANN dog's root frame is not upright: judged against world up it 'fell' at 0.00 s."""
    from conftest import SHARED_BVH

    sc = load_scenario(bvh=SHARED_BVH / "animal" / "mann_dog_D1_007_KAN01_001_locomotion.bvh", profile="creature")
    out, _ = run_scenario(sc, RolloutSpec(seconds=1.0))
    assert out.fall_time_s is None or out.fall_time_s > 0.5


def test_root_support_holds_a_flying_creature() -> None:
    sc = load_scenario(bvh=PTEROSAUR_FLIGHT, profile="creature", support=True)
    out, _ = run_scenario(sc, RolloutSpec(seconds=2.0))
    e = out.extra
    assert out.outcome == "no_fall" and e["support_mode"] is True
    assert e["support_force_mean_n"] > 0.5 * e["weight_n"]  # it really is held up from outside


def test_humanoid_controller_is_the_simbicon_one(walk) -> None:
    assert isinstance(walk.controller(), SimbiconController)


@pytest.mark.parametrize("kwargs,words", [
    ({"profile": "creature"}, "needs a motion"),
    ({"support": True}, "needs the creature profile"),
    ({"profile": "bird"}, "unknown body profile"),
])
def test_scenario_errors(kwargs: dict, words: str) -> None:
    with pytest.raises(ConfigError, match=words):
        load_scenario(**kwargs)


def test_creature_sweep_and_suite(tmp_path: Path) -> None:
    """Sweeps and regression suites run any body kind (``profile``, ``support``) through the same loop."""
    from bipedsim.experiments.experiment import load_experiment
    from bipedsim.experiments.regress import run_suite
    from bipedsim.experiments.sweep import run_sweep

    exp = tmp_path / "horse.yaml"
    exp.write_text(f"name: horse\nreference: {HORSE_WALK}\nprofile: creature\nseconds: 1.5\n"
                   "runs:\n  - {magnitude: 50, direction: 90, duration: 0.2, start: 0.5}\n"
                   "  - {magnitude: 3000, direction: 0, duration: 0.3, start: 0.5}\n")
    summary = run_sweep(load_experiment(exp), tmp_path / "out", progress=False)
    assert summary["rollouts"] == 2 and sum(summary["outcomes"].values()) == 2
    suite = tmp_path / "suite.yaml"
    suite.write_text(f"scenarios:\n  - {{name: flyer, reference: {PTEROSAUR_FLIGHT}, profile: creature, support: true,"
                     " seconds: 1.0, expect: no_fall}\n")
    assert run_suite(suite) == 0
