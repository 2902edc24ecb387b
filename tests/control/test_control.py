"""Controller equations (eq. 1-8), the FSM, configuration errors, and walking outcomes."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import (
    HAVE_SHARED,
    SHARED_BVH,
    looped,
    need_shared,
    swing_as_measured,
    toes_as_measured,
    torso_as_measured,
    velocity_as_measured,
    without_modulation,
)
from scipy.spatial.transform import Rotation

from bipedsim.cli import main
from bipedsim.control.humanoid.balance import (
    euler_from_matrix,
    feedback_angle,
    hinges_to_world,
    hip_torques,
    stance_share,
    world_to_hinges,
)
from bipedsim.control.humanoid.fsm import GaitFSM
from bipedsim.control.humanoid.simbicon import SimbiconController as Controller
from bipedsim.control.humanoid.simbicon import gait_source
from bipedsim.control.humanoid.torso import torso_torque
from bipedsim.control.settings import ControllerConfig, controller_yaml, load_controller
from bipedsim.errors import ConfigError
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario, run_seeds

REPO = Path(__file__).resolve().parents[2]


def test_pd_step_is_eq1(scenario) -> None:
    """Eq. 1 on the control step that runs: with balance, feedforward, servos and implicit damping off,
    every hinge's torque is kp (theta_d - theta) - kd theta_dot (clipped to its limit), and with
    ``pd_ref_velocity`` the damping acts on the velocity error."""
    from dataclasses import replace

    import mujoco

    model = scenario.built.model
    for mode in ("pd", "pd_ref_velocity"):
        cfg = replace(scenario.cfg, control_dt=None, balance=replace(scenario.cfg.balance, enabled=False),
                      pd=replace(scenario.cfg.pd, mode=mode, servo=False, implicit_damping=False,
                                 gravity_compensation=False))
        c = Controller(model, scenario.built.plan, gait_source(model, scenario.built.plan, scenario.clip, cfg), cfg)
        data = mujoco.MjData(model)
        f = c.start_frame()
        data.qpos[:] = scenario.clip.qpos[f + 3]  # a pose off the reference's, moving
        data.qvel[:] = scenario.clip.qvel[f + 3] * 1.5
        mujoco.mj_forward(model, data)
        c.reset(data, float(f))
        try:
            c(model, data, 0.0, model.opt.timestep)
            q, qd = data.qpos[c.hinges.qadr], data.qvel[c.hinges.dadr]
            q_d = q - c.tracking_error  # the reference's targets this step
            qd_d = c.source.hinge_targets(c.frame, c.fsm.state)[1] if mode == "pd_ref_velocity" else 0.0
            tau = c.tables.kp * (q_d - q) - c.tables.kd * (qd - qd_d)
            assert np.allclose(c.torque, np.clip(tau, -c.tables.limit, c.tables.limit), atol=1e-9)
            assert np.abs(c.tracking_error).max() > 0.01  # a real error, not a trivial zero
        finally:
            c.restore_model()


def test_stance_hip_single_support_eq2() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        t_torso, t_b = rng.normal(size=3) * 100, rng.normal(size=3) * 100
        t_a, t_b_total = map(np.array, hip_torques(tuple(t_torso), tuple(t_b), gamma=1.0))
        assert np.allclose(t_a, -t_torso - t_b) and np.allclose(t_b_total, t_b)


@pytest.mark.parametrize("gamma", np.linspace(0.0, 1.0, 11))
def test_hip_torques_sum_to_minus_torso_for_every_share(gamma: float) -> None:
    rng = np.random.default_rng(int(gamma * 10))
    t_torso, t_b = rng.normal(size=3) * 100, rng.normal(size=3) * 100
    t_a, t_b_total = map(np.array, hip_torques(tuple(t_torso), tuple(t_b), gamma))
    assert np.allclose(t_a + t_b_total, -t_torso)
    # eq. 3-5: the remainder tau_r = -(tau_torso + tau_B) is split gamma : 1 - gamma
    t_r = -(t_torso + t_b)
    assert np.allclose(t_a, gamma * t_r) and np.allclose(t_b_total - t_b, (1 - gamma) * t_r)


def test_stance_share_from_vertical_forces() -> None:
    assert stance_share(300.0, 100.0) == pytest.approx(0.75)
    assert stance_share(0.0, 0.0) == 1.0 and stance_share(0.0, 50.0) == 0.0


def test_feedback_term_eq6() -> None:
    assert feedback_angle(0.4, 0.5, 0.2, d=0.1, v=0.3) == pytest.approx(0.4 + 0.05 + 0.06)
    assert feedback_angle(0.0, 0.5, 0.2, d=10.0, v=0.0, limit=0.6) == pytest.approx(0.6)


def test_hinge_world_torque_mapping_round_trip() -> None:
    axes = Rotation.random(1, random_state=3).as_matrix()[0]
    t = np.array([10.0, -20.0, 5.0])
    assert np.allclose(hinges_to_world(axes, np.array(world_to_hinges(axes.tolist(), tuple(t)))), t)


@pytest.mark.parametrize("order", [(1, 0, 2), (0, 1, 2), (2, 0, 1), (0, 2, 1)])
def test_euler_from_matrix_matches_scipy(order) -> None:
    ang = np.array([0.3, -0.4, 0.7])
    seq = "".join("XYZ"[k] for k in order)
    r = Rotation.from_euler(seq, ang).as_matrix()
    assert np.allclose(euler_from_matrix(r, order), ang)


def test_fsm_timer_then_contact() -> None:
    fsm = GaitFSM(state1_time=0.3, min_swing_time=0.4, contact_force=30.0)
    t, dt = 0.0, 0.01
    while fsm.state == 1:
        assert fsm.update(dt, t, swing_force=1000.0) is None  # contact in state 1 is ignored
        t += dt
    assert fsm.state == 2 and t == pytest.approx(0.3, abs=dt)
    assert fsm.update(dt, t, 1000.0) is None  # before the minimum swing time
    while fsm.step_time < 0.4:
        fsm.update(dt, t, 0.0)
    assert fsm.update(dt, t, 10.0) is None  # below the contact threshold
    assert fsm.update(dt, t, 50.0) == "left" and fsm.state == 3 and fsm.stance == "left"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(looped(load_controller(None)))


@pytest.fixture(scope="module")
def hard_soles(scenario):
    """The built-in walk on its body with hard soles (profile ``sim.sole_solref/solimp`` null), where the
    push contrasts below were measured. On the default soft soles the raw lateral d survives these side
    pushes too (135 degrees up to 300 N, 270 degrees 1 of 3), and the forward-left push late in the
    right-stance swing (45 degrees, state 4, 248.2 N) is fallen by the default itself as well as by the
    raw velocity and by tempo off (pinned below, ``test_soft_soles_fall_a_forward_push_late_in_the_step``;
    docs/controller.md, *Soft soles*)."""
    from dataclasses import replace

    from bipedsim.data import BUILTIN_WALK
    from bipedsim.model import build_model, load_profile
    from bipedsim.motion import load_bvh

    prof = load_profile("humanoid")
    hard = replace(prof, sim=replace(prof.sim, sole_solref=None, sole_solimp=None))
    return replace(scenario, built=build_model(load_bvh(BUILTIN_WALK), hard, name="humanoid"))


def _as_on_64kg(sc, force: float = 200.0) -> float:
    """The push (N) that gives this scenario's body the acceleration ``force`` gives a 64 kg body: the
    push tests below were measured on the built-in body at 64 kg; it now weighs 79.4 kg from its legs."""
    from bipedsim.control.humanoid.simbicon import body_mass

    return force * body_mass(sc.built.model) / 64.0


def test_resync_moves_reference_the_right_way(scenario) -> None:
    from dataclasses import replace

    import mujoco

    cfg = replace(scenario.cfg, resync=replace(scenario.cfg.resync, enabled=True, gain=1.0, spread=0.0))
    model = scenario.built.model
    src = gait_source(scenario.built.model, scenario.built.plan, scenario.clip, scenario.cfg)
    c = Controller(model, scenario.built.plan, src, cfg)
    try:
        data = mujoco.MjData(model)
        c.reset(data, src.a)
        strike = src.next_strike(src.a + 1e-3, "left")
        step = strike - src.a
        # the simulation lands late: the reference has run past its strike frame -> M > 1, move back
        # (P_c is measured on the gait clock, which is real time while the tempo rate is 1)
        c.frame = strike + 5
        c.playback.clock = (step + 5) * src.frame_time
        c._resync("left", t=c.playback.clock)
        ev = c.resyncs[-1]
        assert ev.ratio > 1 and c.frame < ev.frame_before and c.frame == pytest.approx(strike)
        # early landing of the next foot: M < 1, move forward
        nxt = src.next_strike(strike + 1e-3, "right")
        c.frame = nxt - 4
        c.playback.clock = (step + 5) * src.frame_time + (nxt - strike - 4) * src.frame_time * 0.8
        c._resync("right", t=c.playback.clock)
        ev = c.resyncs[-1]
        assert ev.ratio < 1 and c.frame > ev.frame_before and c.frame == pytest.approx(nxt)
    finally:
        c.restore_model()


def test_default_walk_keeps_balance_10s(scenario) -> None:
    out, _ = run_scenario(scenario, RolloutSpec(seconds=10.0))
    assert out.outcome == "no_fall", out.fall_reason
    assert out.foot_strikes >= 15
    assert abs(out.mean_speed_mps - out.reference_speed_mps) <= 0.25 * out.reference_speed_mps
    assert out.tracking_rmse_rad <= 0.15


def test_balance_feedback_matters(scenario) -> None:
    from dataclasses import replace

    cfg = replace(scenario.cfg, balance=replace(scenario.cfg.balance, feedback=False))
    sc = replace(scenario, cfg=cfg)
    out, _ = run_scenario(sc, RolloutSpec(seconds=20.0))
    assert out.outcome == "fall" and out.fall_time_s < 20.0


def test_shared_cmu_walk_tracked_20s_without_falling() -> None:
    """CMU 02_01 (Holden's skeleton, legs splayed in the rest pose) converted into its own body,
    retargeted and tracked with balance (its shipped config), the clip looped at its gait events."""
    from conftest import SHARED_BVH

    path = SHARED_BVH / "human" / "cmu_02_01_walk__holden31_crlf.bvh"
    if not path.exists():
        pytest.skip(f"shared BVH data not found at {path}")
    out, ctrl = run_scenario(load_scenario(REPO / "controllers" / "cmu_walk.yaml", path), RolloutSpec(seconds=20.0))
    assert out.outcome == "no_fall", (out.fall_time_s, out.fall_reason)
    assert out.foot_strikes >= 30 and out.distance_m > 5.0
    # looped: the reference went round its gait cycle several times
    assert ctrl.frame - ctrl.source.loop_start > 3 * ctrl.source.period


def test_shared_cmu_walk_walks_20s_with_the_default_controller() -> None:
    """The same clip with no controller file: its legs measure infeasible for the body (out of range,
    straight knees), the default re-solves them (``reference: {feasible: auto}``) and it walks 20 s
    (seeds 0-9 all do with the soft soles; the slow ``test_gait`` check takes seeds 0-2 and the speed)."""
    from conftest import SHARED_BVH

    path = SHARED_BVH / "human" / "cmu_02_01_walk__holden31_crlf.bvh"
    if not path.exists():
        pytest.skip(f"shared BVH data not found at {path}")
    sc = load_scenario(None, path)
    assert "feasible" in sc.extra
    out, _ = run_scenario(sc, RolloutSpec(seconds=20.0))
    assert out.outcome == "no_fall", (out.fall_time_s, out.fall_reason)
    assert out.mean_speed_mps > 0.4 * out.reference_speed_mps


@pytest.mark.slow
def test_default_walk_60s(scenario) -> None:
    out, _ = run_scenario(scenario, RolloutSpec(seconds=60.0))
    assert out.outcome == "no_fall" and out.foot_strikes >= 80
    assert abs(out.mean_speed_mps - out.reference_speed_mps) <= 0.25 * out.reference_speed_mps
    assert out.tracking_rmse_rad <= 0.15


def test_servo_actuation_is_the_torque_law_at_full_rate(scenario) -> None:
    """With control on every physics step, PD stiffness inside MuJoCo's actuators (servo targets
    u = q + tau / kp) applies exactly the controller's torques; the model is restored afterwards."""
    from dataclasses import replace

    model = scenario.built.model
    before = {k: getattr(model, k).copy() for k in ("actuator_gainprm", "actuator_biasprm", "actuator_ctrlrange",
                                                    "actuator_forcerange", "dof_damping")}
    runs = []
    for servo in (True, False):
        cfg = replace(scenario.cfg, control_dt=None, pd=replace(scenario.cfg.pd, servo=servo))
        out, ctrl = run_scenario(replace(scenario, cfg=cfg), RolloutSpec(seconds=2.0))
        runs.append(out)
    assert runs[0].distance_m == pytest.approx(runs[1].distance_m, abs=1e-6)
    assert runs[0].tracking_rmse_rad == pytest.approx(runs[1].tracking_rmse_rad, abs=1e-6)
    for k, v in before.items():
        assert np.array_equal(getattr(model, k), v), k


def test_same_seed_same_result(scenario) -> None:
    a, _ = run_scenario(scenario, RolloutSpec(seconds=2.0, seed=3, init_noise=0.05))
    b, _ = run_scenario(scenario, RolloutSpec(seconds=2.0, seed=3, init_noise=0.05))
    assert a.distance_m == b.distance_m and a.tracking_rmse_rad == b.tracking_rmse_rad


def test_run_seeds_is_seed_0_clean_then_noisy_seeds(scenario) -> None:
    """run_seeds: seed 0 is the plain run (no noise), seeds 1.. add the body kind's initial noise, each
    the run that seed gives alone; fewer than one seed is refused."""
    from bipedsim.sim.runner import SEED_NOISE

    outs = run_seeds(scenario, 2.0, 3)
    plain, _ = run_scenario(scenario, RolloutSpec(seconds=2.0))
    two, _ = run_scenario(scenario, RolloutSpec(seconds=2.0, seed=2, init_noise=SEED_NOISE["humanoid"]))
    assert [o.config["init_noise"] for o in outs] == [0.0, SEED_NOISE["humanoid"], SEED_NOISE["humanoid"]]
    assert outs[0].distance_m == plain.distance_m and outs[2].distance_m == two.distance_m
    assert outs[1].distance_m != outs[2].distance_m != outs[0].distance_m
    assert [o.distance_m for o in run_seeds(scenario, 2.0, 3, start=2)] == [two.distance_m]
    with pytest.raises(ValueError, match="at least 1"):
        run_seeds(scenario, 2.0, 0)


# ---------------------------------------------------------------------- configuration
def write_cfg(tmp_path: Path, text: str, name: str = "c.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("text,key,message", [
    ("pd:\n  gains:\n    hip: {kp: -5, kd: 1}\n", "pd.gains.hip.kp", "must be >= 0.0"),
    ("pd:\n  gian: {}\n", "pd.gian", "unknown key"),
    ("balance:\n  sagittal: {cd: fast}\n", "balance.sagittal.cd", "expected a number"),
    ("pd:\n  target_limits: {left_knee: [1.0, 0.5]}\n", "pd.target_limits.left_knee", "limits reversed"),
    ("fsm:\n  state1_time: 0\n", "fsm.state1_time", "must be > 0.0"),
    ("fade:\n  min_scale: 2\n", "fade.min_scale", "must be <= 1.0"),
    ("pd:\n  gains:\n    tail: {kp: 5}\n", "pd.gains.tail", "unknown joint group"),
    ("fsm:\n  tempo: {min: 1.2}\n", "fsm.tempo.min", "must be <= 1.0"),
    ("fsm:\n  tempo: {max: 0.5}\n", "fsm.tempo.max", "must be >= 1.0"),
    ("fsm:\n  tempo: {gain: -1}\n", "fsm.tempo.gain", "must be >= 0.0"),
])
def test_bad_controller_files(tmp_path: Path, text: str, key: str, message: str) -> None:
    p = write_cfg(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        load_controller(p)
    assert str(p) in str(exc.value) and key in str(exc.value) and message in str(exc.value)
    assert main(["run", str(p), "--seconds", "0.1", "--out", str(tmp_path / "o")]) == 2


def test_shipped_controllers_load_and_default_yaml_restates_the_code_defaults() -> None:
    for p in sorted((REPO / "controllers").glob("*.yaml")):
        assert isinstance(load_controller(p), ControllerConfig)
    # one source of defaults: the dataclasses; the YAML restates every one of them
    assert load_controller(REPO / "controllers" / "default.yaml") == ControllerConfig() == load_controller(None)


def test_default_yaml_is_generated_by_bipedsim_config(capsys) -> None:
    """``controllers/default.yaml`` is exactly what ``bipedsim config`` prints (regenerate it with
    ``bipedsim config > controllers/default.yaml``)."""
    assert main(["config"]) == 0
    out = capsys.readouterr().out
    assert out == controller_yaml() == (REPO / "controllers" / "default.yaml").read_text()


def test_config_prints_a_file_merged_over_the_defaults(tmp_path: Path, capsys) -> None:
    """``bipedsim config FILE``: every key, the file's values over the defaults; read back, the same settings."""
    p = write_cfg(tmp_path, "name: mine\npd:\n  gains:\n    hip: {kp: 700.0}\n")
    assert main(["config", str(p)]) == 0
    text = capsys.readouterr().out
    back = write_cfg(tmp_path, text, "back.yaml")
    cfg = load_controller(back)
    assert cfg == load_controller(p)
    assert cfg.pd.gains["hip"].kp == 700.0 and cfg.pd.gains["hip"].kd == ControllerConfig().pd.gains["hip"].kd
    assert cfg.name == "mine" and cfg.balance == ControllerConfig().balance
    assert main(["config", str(tmp_path / "missing.yaml")]) == 2  # a user's error: one line, exit 2


def test_run_cli_writes_outcome(tmp_path: Path, capsys) -> None:
    import json

    assert main(["run", "--seconds", "1.5", "--seed", "7", "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "outcome.json").read_text())
    for k in ("outcome", "sim_seconds", "fall_time_s", "foot_strikes", "distance_m", "mean_speed_mps",
              "tracking_rmse_rad", "config", "seed", "versions"):
        assert k in d
    assert d["seed"] == 7 and d["outcome"] in ("no_fall", "fall", "diverged")
    assert d["versions"]["mujoco"] == mujoco.__version__ and d["config"]["controller"]["name"] == "default"


def test_pose_gait_source_walks(tmp_path: Path) -> None:
    sc = load_scenario(REPO / "controllers" / "pose_gait.yaml")
    out, _ = run_scenario(sc, RolloutSpec(seconds=8.0))
    assert out.outcome == "no_fall" and out.foot_strikes >= 10 and out.distance_m > 2.0


def test_hot_path_rotation_helpers_match_scipy() -> None:
    """The controller's float-only helpers: rotation vector, one- and two-hinge angles."""
    from bipedsim.control.humanoid.feet import hinge_angles_small
    from bipedsim.control.humanoid.torso import rotvec3

    rng = np.random.default_rng(5)
    for r in Rotation.random(20, random_state=7):
        assert np.allclose(rotvec3(r.as_matrix()), r.as_rotvec(), atol=1e-9)
    for _ in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        theta = rng.uniform(-2.5, 2.5)
        m = Rotation.from_rotvec(axis * theta).as_matrix()
        assert hinge_angles_small(m, [tuple(axis)])[0] == pytest.approx(theta, abs=1e-9)
    # two hinges (y then x, as an ankle with pitch and roll): the angles come back
    a, b = 0.4, -0.3
    m = Rotation.from_euler("YX", [a, b]).as_matrix()
    assert np.allclose(hinge_angles_small(m, [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0)]), [a, b])
    # the same rotation about the opposite axes is the opposite angles
    assert np.allclose(hinge_angles_small(m, [(0.0, -1.0, 0.0), (-1.0, 0.0, 0.0)]), [-a, -b])
    # two hinges off x, y, z (a flexion axis along the shin's, then roll about x), in their own basis
    from bipedsim.reference.retarget import hinge_basis

    flex = np.array([0.0, np.cos(0.2), np.sin(0.2)])
    axes = [flex, np.array([-1.0, 0.0, 0.0])]
    basis = hinge_basis(axes)[2]
    m = Rotation.from_rotvec(axes[0] * a).as_matrix() @ Rotation.from_rotvec(axes[1] * b).as_matrix()
    assert np.allclose(hinge_angles_small(m, [tuple(x) for x in axes], basis), [a, b], atol=1e-12)


def test_velocity_tuning_virtual_force_holds_the_walking_speed() -> None:
    """balance.velocity (Coros et al. 2010): the loaded legs' knee and ankle torques push the centre of
    mass toward the reference's mean speed, so after a backward push the walk gets back to its speed."""
    from dataclasses import replace

    from bipedsim.control.settings import VelocityConfig, load_controller
    from bipedsim.sim.push import Push
    from bipedsim.sim.runner import settings_for

    sc = load_scenario()
    base = load_controller(None)  # as written: the override is scaled to the body with the rest
    dev = {}
    for kv in (0.0, 300.0):
        sc.cfg = settings_for(sc, replace(base, balance=replace(base.balance, velocity=VelocityConfig(
            kv_sagittal=kv, filter_s=0.0))))
        vs: list[float] = []
        out, ctrl = run_scenario(sc, RolloutSpec(seconds=3.0), pushes=[Push(150.0, 180.0, 0.2, start=1.0)],
                                 hooks=[lambda t, d, c, vs=vs: vs.append(d.subtree_linvel[1][0])])
        assert out.outcome == "no_fall"
        dev[kv] = float(np.mean(np.abs(np.array(vs) - ctrl.source.speed())))
        if kv:
            f0, f1 = ctrl.state.virtual_force
            cap = ctrl.cfg.balance.velocity.max_force  # 150 N x the body's mass / 64 kg
            assert cap > 150.0 and abs(f0) <= cap + 1e-9 and f1 == 0.0  # clipped to max_force; no coronal gain
    # measured: mean |v - v_ref| 0.46 m/s without (the push halves the speed), 0.20 with
    assert dev[300.0] < 0.6 * dev[0.0], dev


@pytest.mark.parametrize(("direction", "state"), [(135.0, 4), (270.0, 3)])
def test_lateral_d_against_the_reference_sway_recovers_side_pushes(hard_soles, direction: float, state: int) -> None:
    """190, 200 and 210 N (as on a 64 kg body) x 0.2 s back-left late in the left-stance swing, or to
    the right in the right-stance swing: with the raw lateral d (COM from the stance ankle) the walk falls
    from at least two of the three; measured against the reference's own lateral sway about the stance
    foot (the default, ``relative: lateral_reference``) it recovers from all three. (One push's outcome
    flips on a 1 % change of the body: 248.2 N on the 79.4 kg body at 270 degrees, state 3, is survived
    with the raw d, where 236 and 260 N are not.)"""
    from dataclasses import replace

    from bipedsim.sim.push import Push

    scenario = hard_soles
    assert scenario.cfg.balance.relative == "lateral_reference"
    falls: dict[str, int] = {}
    for mode in ("mean_velocity", "lateral_reference"):
        cfg = replace(scenario.cfg, balance=replace(scenario.cfg.balance, relative=mode))
        falls[mode] = sum(run_scenario(replace(scenario, cfg=cfg), RolloutSpec(seconds=6.0), pushes=[
            Push(_as_on_64kg(scenario, f), direction, 0.2, state=state, fraction=0.5)])[0].outcome == "fall"
            for f in (190.0, 200.0, 210.0))
    assert falls["mean_velocity"] >= 2 and falls["lateral_reference"] == 0, falls


@pytest.mark.parametrize(("v_excess", "minimum", "rate"), [
    (0.05, 1.0, 1.0),    # inside the deadband
    (0.3, 1.0, 1.4),     # 1 + 2 (0.3 - 0.1)
    (1.0, 1.0, 1.5),     # clamped to max
    (-0.5, 1.0, 1.0),    # slower than the walk: min 1 keeps real time
    (-0.5, 0.8, 0.8),    # 1 + 2 (-0.5 + 0.1) = 0.2, clamped to min
])
def test_tempo_rate_drives_the_gait_clock(scenario, v_excess: float, minimum: float, rate: float) -> None:
    """fsm.tempo: the gait clock runs at clamp(1 + gain (v - v_ref -+ deadband), min, max) times real
    time, v the sagittal COM velocity of the previous control step; the reference frame and the FSM's
    timer advance by rate x dt."""
    from dataclasses import replace

    import mujoco

    from bipedsim.control.settings import TempoConfig

    tempo = TempoConfig(gain=2.0, deadband=0.1, min=minimum, max=1.5)
    cfg = replace(scenario.cfg, fsm=replace(scenario.cfg.fsm, tempo=tempo))
    model = scenario.built.model
    src = gait_source(scenario.built.model, scenario.built.plan, scenario.clip, scenario.cfg)
    c = Controller(model, scenario.built.plan, src, cfg)
    try:
        data = mujoco.MjData(model)
        data.qpos[:] = scenario.built.model.qpos0
        data.qpos[2] += 0.3  # in the air: no contacts, no strike
        mujoco.mj_forward(model, data)
        c.reset(data, src.a)
        r = data.xmat[c.pelvis].reshape(3, 3)
        h = math.atan2(r[1, 0], r[0, 0])
        v = src.speed() + v_excess
        data.qvel[:] = 0.0
        data.qvel[0], data.qvel[1] = v * math.cos(h), v * math.sin(h)
        mujoco.mj_forward(model, data)
        dt = 0.004
        c(model, data, 0.0, dt)  # measures v; this step still runs at the reset rate 1
        assert c.state.tempo == 1.0
        f0, clock0, tis0 = c.frame, c.playback.clock, c.fsm.time_in_state
        c(model, data, dt, dt)
        assert c.state.tempo == pytest.approx(rate)
        assert c.frame - f0 == pytest.approx(rate * dt / src.frame_time)
        assert c.playback.clock - clock0 == pytest.approx(rate * dt)
        assert c.fsm.time_in_state - tis0 == pytest.approx(rate * dt)
    finally:
        c.restore_model()


@pytest.mark.parametrize(("direction", "state", "body"), [(0.0, 2, "scenario"), (45.0, 4, "hard_soles")])
def test_tempo_recovers_forward_pushes_late_in_the_swing(request, direction: float, state: int, body: str) -> None:
    """200 N (as on a 64 kg body) x 0.2 s forward (or forward-left) in the second half of a step: at a
    fixed swing time the next step is taken at 2 m/s with the legs 65 degrees apart, the impact halves the
    speed and the body stalls between two loaded feet and falls; with the gait clock sped up (the default
    ``fsm.tempo``) it steps sooner and recovers. Forward on the default body; forward-left on the
    hard-soled one (``hard_soles``). Both contrasts with the torso law they were measured with (damping 100,
    yaw limit 0.35: ``torso_as_measured``); the default (175, 0.6) survives both pushes as well."""
    from dataclasses import replace

    from bipedsim.control.settings import TempoConfig
    from bipedsim.sim.push import Push

    scenario = request.getfixturevalue(body)
    assert scenario.cfg.fsm.tempo.gain > 0
    push = [Push(_as_on_64kg(scenario), direction, 0.2, state=state, fraction=0.5)]
    out = {}
    before = swing_as_measured(torso_as_measured(scenario.cfg))
    for name, tempo in (("off", TempoConfig(gain=0.0)), ("tempo", scenario.cfg.fsm.tempo)):
        cfg = replace(before, fsm=replace(before.fsm, tempo=tempo))
        out[name], _ = run_scenario(replace(scenario, cfg=cfg), RolloutSpec(seconds=6.0), pushes=push)
    out["default"], _ = run_scenario(scenario, RolloutSpec(seconds=6.0), pushes=push)
    assert out["off"].outcome == "fall"
    assert out["tempo"].outcome == "no_fall"
    assert out["default"].outcome == "no_fall"


def test_torso_law_on_the_running_method(scenario) -> None:
    """The torso law as the control step computes it (:func:`bipedsim.control.humanoid.torso.torso_torque`): a pelvis
    pitched by delta from its target and turning at omega about world y gets the world torque
    (0, kp delta - kd omega, 0) whatever its heading (roll and pitch gains equal by default)."""
    import mujoco

    cfg = scenario.cfg
    model = scenario.built.model
    c = Controller(model, scenario.built.plan, gait_source(model, scenario.built.plan, scenario.clip, cfg), cfg)
    data = mujoco.MjData(model)
    data.qpos[:] = scenario.clip.qpos[c.start_frame()]
    mujoco.mj_forward(model, data)
    c.reset(data, float(c.start_frame()))
    try:
        pelvis_ref = c.source.pelvis_target(c.frame, c.fsm.state)
        r_des = c.steering.r_heading.dot(pelvis_ref)
        b = cfg.balance
        assert b.roll_kp is None  # the law below assumes roll_kp = torso_kp
        for delta, omega in ((0.1, 0.0), (-0.05, 0.3), (0.0, -0.5)):
            r_p = Rotation.from_rotvec([0.0, -delta, 0.0]).as_matrix() @ r_des  # r_des r_p^T = R_y(delta)
            h = math.atan2(r_p[1, 0], r_p[0, 0])
            w_body = r_p.T @ np.array([0.0, omega, 0.0])
            tau = torso_torque(b, c.tables.roll_kp, c.steering.r_heading, pelvis_ref, r_p, r_p.ravel().tolist(),
                               w_body.tolist(), math.cos(h), math.sin(h))
            assert np.allclose(tau, [0.0, b.torso_kp * delta - b.torso_kd * omega, 0.0], atol=1e-6)
    finally:
        c.restore_model()


def test_the_default_survives_a_forward_push_late_in_the_step(scenario) -> None:
    """The forward-left push late in the right-stance swing at 200 N per 64 kg (248.2 N on 79.4 kg): with
    the torso law's damping 175 and yaw limit 0.6 the body survives it (at a damping of 100 the soft soles
    cost it)."""
    from bipedsim.sim.push import Push

    push = [Push(_as_on_64kg(scenario), 45.0, 0.2, state=4, fraction=0.5)]
    out, _ = run_scenario(scenario, RolloutSpec(seconds=6.0), pushes=push)
    assert out.outcome == "no_fall", out.fall_time_s


def test_velocity_tuning_on_the_low_passed_speed_keeps_a_forward_push(hard_soles) -> None:
    """balance.velocity.filter_s: the virtual force compares the COM velocity low-passed over 1.0 s (the
    default), so a push's transient is left to the balance law. Measured: 200 N x 0.2 s forward-left
    in the right-stance swing (the 200 N grid's 45 degrees, state 4) with 50 N per m/s on the raw
    velocity the walk falls at 4.2 s; the default (90 N per m/s, low-passed) recovers. Both at the torso
    law it was measured with (damping 100, yaw limit 0.35: ``torso_as_measured``): with today's the raw
    velocity survives too."""
    from dataclasses import replace

    from bipedsim.control.settings import VelocityConfig
    from bipedsim.sim.push import Push

    sc = hard_soles
    base = sc.cfg
    assert base.balance.velocity.kv_sagittal > 0.0 and base.balance.velocity.filter_s > 0.0
    push = [Push(_as_on_64kg(sc), 45.0, 0.2, state=4, fraction=0.5)]
    from bipedsim.control.settings import load_controller
    from bipedsim.sim.runner import settings_for

    written = load_controller(None)  # the override scaled to the body with the rest of the settings
    raw = settings_for(sc, looped(replace(written, balance=replace(written.balance, velocity=VelocityConfig(
        kv_sagittal=50.0, filter_s=0.0)))))
    out_raw, _ = run_scenario(replace(sc, cfg=swing_as_measured(torso_as_measured(raw))), RolloutSpec(seconds=6.0),
                              pushes=push)
    out_def, _ = run_scenario(replace(sc, cfg=swing_as_measured(torso_as_measured(sc.cfg))), RolloutSpec(seconds=6.0),
                              pushes=push)
    assert out_raw.outcome == "fall"
    assert out_def.outcome == "no_fall"


@pytest.mark.slow  # two 20 s runs of a real take
def test_velocity_tuning_brings_a_slow_capture_up_to_its_speed() -> None:
    """The shared CMU 02_01 walk (1.20 m/s) on its feasible reference walks 20 s at about half its speed
    without velocity tuning (the swing-hip feedback c_v (v - v_mean) shortens every step of a slow body
    and the gait clock keeps the step time, so it stays slow); with the default virtual force it walks
    20 s at >= 70 % of its speed. Three seeds (0; 1 and 2 with 0.02 rad/s of initial noise), the median
    speed: single runs of this walk vary (at 90 N per m/s seed 0 crabs off its line at 0.66 of the clip's
    speed while seeds 1-5 walk at 0.77-0.82; docs/controller.md "Speed deficit")."""
    from dataclasses import replace

    from bipedsim.control.humanoid.cycles import clip_speed

    need_shared()  # the real take's own contrast: the stand-in walks at its speed with or without the tuning
    with toes_as_measured():  # as measured (with today's toes, on these old settings, it falls at 5.4-19.6 s with it)
        sc = load_scenario(None, SHARED_BVH / "human" / "cmu_02_01_walk__holden31_crlf.bvh")
    sc = replace(sc, cfg=velocity_as_measured(swing_as_measured(torso_as_measured(without_modulation(sc.cfg)))))
    v_clip = clip_speed(sc.clip)  # ^ as measured
    off = replace(sc.cfg, balance=replace(sc.cfg.balance, velocity=replace(sc.cfg.balance.velocity, kv_sagittal=0.0)))

    def runs(cfg: object) -> tuple[list[str], list[float]]:
        outs = run_seeds(replace(sc, cfg=cfg), 20.0, 3)
        return [o.outcome for o in outs], [o.mean_speed_mps / v_clip for o in outs]

    outcomes, ratios = runs(sc.cfg)
    assert outcomes == ["no_fall"] * 3 and float(np.median(ratios)) >= 0.7, (outcomes, ratios)
    outcomes, ratios = runs(off)  # slower (measured: 0.63, 0.60, 0.64; the noisy starts fall at 17.0 and 19.8 s)
    assert float(np.median(ratios)) < 0.67, (outcomes, ratios)


def test_froude_scheduled_cd_lets_a_fast_capture_stride_out(tmp_path: Path) -> None:
    """The sagittal c_d is scheduled by the capture's Froude number: a fast capture gets a lower c_d than
    the built-in walk (Fr 0.098), which keeps 0.55. The shared CMU 02_02 walk (1.51 m/s, Fr 0.32 on its
    0.84 m legs; without ``../shared`` the generated walk at 0.7 m steps and 130 steps/min, 1.48 m/s:
    c_d 0.45) and what the schedule is for, with ``../shared``: with the raw d's gain at the built-in
    walk's 0.55 the CMU walk limps (a long step, then one landing behind the stance foot) at about half
    its speed; the default schedule (c_d 0.42 here) walks it 20 s at >= 70 % (measured at seed 0 on the
    19-joint file: 0.53 -> 0.76 at 75 N per m/s of velocity tuning; at 90 N per m/s that file walks 0.74
    unscheduled, the daz file used here 0.56 -> 0.74, seeds 0-2 alike). The generated fast walk shows no
    such contrast (it falls within 1.2 s either way), so that part stays with the real take."""
    from dataclasses import replace

    from bipedsim.control.humanoid.cycles import clip_speed
    from bipedsim.motion.bvh import write_bvh
    from bipedsim.motion.gaitgen import WalkParams, generate_walk

    if HAVE_SHARED:
        fast = SHARED_BVH / "human" / "cmu_02_02_walk__daz43.bvh"
    else:
        fast = tmp_path / "fast_walk.bvh"
        write_bvh(generate_walk(WalkParams(step_length=0.7, cadence=130.0, cycles=3)), fast, precision=6)
    sc = load_scenario(None, fast)
    sc = replace(sc, cfg=looped(swing_as_measured(torso_as_measured(without_modulation(sc.cfg)))))  # as measured
    assert 0.35 < sc.controller().tables.cd_sagittal < 0.5
    assert load_scenario(None).controller().tables.cd_sagittal == 0.55
    if HAVE_SHARED:
        v_clip = clip_speed(sc.clip)
        out, _ = run_scenario(sc, RolloutSpec(seconds=20.0))
        assert out.outcome == "no_fall" and out.mean_speed_mps >= 0.7 * v_clip, (out.fall_time_s, out.mean_speed_mps)
        off = replace(sc.cfg, balance=replace(sc.cfg.balance, cd_froude=None))
        out0, _ = run_scenario(replace(sc, cfg=off), RolloutSpec(seconds=20.0))
        assert out0.outcome == "no_fall" and out0.mean_speed_mps < 0.6 * v_clip, out0.mean_speed_mps


@pytest.mark.parametrize("mode", ["off", "swing_hip", "all"])
def test_net_torque_limit_bounds_actuator_and_damping_together(mode: str, monkeypatch) -> None:
    """``pd.net_limit`` (the default: ``swing_hip``; docs/controller.md, *The swing's speed limit*): the
    implicit damping -kd qdot acts beside the actuator, so a joint driven at its torque limit tops out at
    limit / kd. With the net limit, while a joint is driven the way it moves, the actuator may give up to
    limit + kd |qdot|, and actuator less damping stays within the limit; braking is bounded as before.
    Off, no torque passes the limit."""
    import dataclasses

    rec: list = []
    call = Controller.__call__

    def spy(self, model, data, t, dt):  # type: ignore[no-untyped-def]
        out = call(self, model, data, t, dt)
        rec.append((self.torque.copy(), self.drive.akd * data.qvel[self.tables.dsel], self.tables.limit.copy(),
                    self.fsm.swing, self.tables.hip[self.fsm.swing].idx_l))
        return out

    monkeypatch.setattr(Controller, "__call__", spy)
    cfg = load_controller(None)
    cfg = looped(dataclasses.replace(cfg, pd=dataclasses.replace(cfg.pd, net_limit=mode)))
    sc = load_scenario(cfg, SHARED_BVH / "human" / "bandai2_walk_exhausted_001.bvh")
    run_scenario(sc, RolloutSpec(seconds=1.5, seed=0))
    over = 0
    for tq, damp, lim, _swing, hips in rec:
        driving = tq * damp > 0
        assert np.all(np.abs(tq - damp)[driving] <= lim[driving] + 1e-6)
        assert np.all(np.abs(tq)[~driving] <= lim[~driving] + 1e-6)  # braking: the limit as before
        past = np.abs(tq) > lim + 1e-6
        over += int(past.sum())
        if mode == "swing_hip":
            assert set(np.flatnonzero(past)) <= set(hips)  # only the swing hip's hinges
    assert (over == 0) if mode == "off" else (over > 20)


@pytest.mark.slow
@pytest.mark.xfail(reason="one short in right stance (5 + 6) since the whole clip is tracked with its searched "
                          "correction: docs/results.md, Pushes on a real capture", strict=False)
def test_pushes_on_the_shared_cmu_walk_meet_the_issue_s_target(tmp_path: Path) -> None:
    """The push check on a real capture: `experiments/push_cmu_02_01.yaml` (200 N x 0.2 s torso pushes
    at 8 directions in the middle of each stance of the shared CMU 02_01 walk, 4 s in, 12 s walked) with the
    default controller survives at least 6 of 8 in each stance (docs/results.md)."""
    import csv

    from bipedsim.experiments.experiment import load_experiment
    from bipedsim.experiments.sweep import run_sweep

    need_shared()
    exp = Path(__file__).resolve().parents[2] / "experiments" / "push_cmu_02_01.yaml"
    run_sweep(load_experiment(exp), tmp_path / "out", progress=False)
    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert len(rows) == 16
    for state in ("1", "3"):
        survived = [r["direction"] for r in rows if r["state"] == state and r["outcome"] == "no_fall"]
        assert len(survived) >= 6, (state, survived)
