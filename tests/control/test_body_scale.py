"""The controller's settings scaled to bodies of other sizes and masses (dynamic similarity,
``control.settings.for_body``, docs/controller.md "Bodies of any size")."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest

from bipedsim.control.settings import BODY_SCALED, ControllerConfig, for_body, load_controller
from bipedsim.errors import ConfigError

SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "bvh" / "human"


def _get(cfg: object, key: str) -> object:
    for k in key.split("."):
        cfg = getattr(cfg, k)
    return cfg


def test_inside_the_measured_legs_nothing_changes() -> None:
    cfg = ControllerConfig()
    for leg in (cfg.body.leg_min, 0.85, cfg.body.leg_max):
        assert for_body(cfg, leg, cfg.body.mass) is cfg


def test_each_unit_scales_by_its_power_of_the_leg_and_mass_ratios() -> None:
    cfg = ControllerConfig()
    lam, mu = 2.0, 3.0  # legs twice the longest measured, three times the mass (lam != mu: powers told apart)
    out = for_body(cfg, lam * cfg.body.leg_max, mu * cfg.body.mass)
    r = math.sqrt(lam)
    expect = {  # written out by hand from each setting's unit
        "balance.torso_kp": lam * mu,  # N*m/rad: m g L
        "balance.heading_kp": lam * mu,
        "balance.torso_kd": lam * r * mu,  # N*m*s/rad: m g L sqrt(L / g)
        "balance.sagittal.cd": 1 / lam,  # rad per m
        "balance.coronal.cd": 1 / lam,
        "balance.sagittal.cv": 1 / r,  # rad per m/s
        "balance.coronal.cv": 1 / r,
        "balance.velocity.kv_sagittal": mu / r,  # N per m/s: m g / sqrt(g L)
        "balance.velocity.max_force": mu,  # N
        "balance.velocity.filter_s": r,  # s
        "balance.course.deadband": lam,  # m
        "balance.course.steer_gain": 1 / lam,  # rad per m
        "balance.course.steer_damping": 1 / r,  # rad per m/s
        "fsm.contact_force": mu,  # N
        "fsm.max_wait": r,  # s
        "fsm.tempo.gain": 1 / r,  # clock rate per m/s
        "fsm.tempo.deadband": r,  # m/s
        "modulation.swing_foot.lift": lam,  # m
        "modulation.swing_foot.deadband": lam,
        "modulation.stance_ankle.kv": 1 / r,  # rad per m/s
        "modulation.stance_ankle.kd": 1 / lam,  # rad per m
        "reference.smooth_s": r,  # s
    }
    for key, f in expect.items():
        assert _get(out, key) == pytest.approx(_get(cfg, key) * f), key
    assert out.pd.gains["hip"].kp == pytest.approx(cfg.pd.gains["hip"].kp * lam * mu)
    assert out.pd.gains["hip"].kd == pytest.approx(cfg.pd.gains["hip"].kd * lam * r * mu)
    # angles, ratios and shares of the leg do not scale
    for key in ("balance.max_feedback", "modulation.swing_foot.height_gain", "reference.clearance", "control_dt"):
        assert _get(out, key) == _get(cfg, key), key
    # the scaled config names the body it was scaled to, and the model's torque limits follow
    assert out.body.leg_min == out.body.leg_max == pytest.approx(lam * cfg.body.leg_max)
    assert out.body.mass == pytest.approx(mu * cfg.body.mass)
    assert out.body.torque_scale == pytest.approx(lam * mu)
    # scaled again to another body, from the one it names: the torque scale accumulates
    again = for_body(out, 0.5 * lam * cfg.body.leg_max, mu * cfg.body.mass)
    assert again.body.torque_scale == pytest.approx(0.5 * lam * mu)
    assert again.balance.sagittal.cd == pytest.approx(cfg.balance.sagittal.cd / (0.5 * lam))
    # short legs are measured from the shortest measured leg
    short = for_body(cfg, 0.5 * cfg.body.leg_min, cfg.body.mass)
    assert short.balance.sagittal.cd == pytest.approx(2.0 * cfg.balance.sagittal.cd)


def _numbers(obj: object, prefix: str = "") -> list[str]:
    """Dotted keys of every number (or unset number) in a settings tree."""
    keys = []
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        v = getattr(obj, f.name)
        key = prefix + f.name
        if dataclasses.is_dataclass(v):
            keys += _numbers(v, key + ".")
        elif isinstance(v, float) or (v is None and "float" in str(f.type)):
            keys.append(key)
    return keys


def test_every_number_of_the_humanoid_settings_is_scaled_or_said_not_to_be() -> None:
    from bipedsim.control.settings import BODY_UNSCALED

    cfg = ControllerConfig()
    keys = [k for k in _numbers(cfg) if not k.startswith(("creature.", "pose_gait.state_", "pose_gait.elbow"))]
    keys.append("pose_gait.state_a_time")
    unclassified = [k for k in keys if k not in BODY_SCALED and k not in BODY_UNSCALED]
    assert not unclassified, f"say how these scale with the body (BODY_SCALED or BODY_UNSCALED): {unclassified}"
    assert not set(BODY_SCALED) & BODY_UNSCALED


def test_scaling_twice_to_one_body_is_scaling_once() -> None:
    cfg = ControllerConfig()
    once = for_body(cfg, 1.1, 90.0)
    assert for_body(once, 1.1, 90.0) == once  # a recorded config run again on its body is unchanged
    assert for_body(dataclasses.replace(cfg, body=dataclasses.replace(cfg.body, scale=False)), 1.1, 90.0).balance \
        == cfg.balance


def test_every_scaled_key_is_a_number_of_the_default_controller() -> None:
    cfg = ControllerConfig()
    for key in BODY_SCALED:
        v = _get(cfg, key)
        assert v is None or isinstance(v, float), key


def test_a_reversed_leg_range_is_refused_with_its_key(tmp_path: Path) -> None:
    y = tmp_path / "c.yaml"
    y.write_text("body: {leg_min: 1.0, leg_max: 0.9}\n")
    with pytest.raises(ConfigError, match=r"body.*leg_min 1.0 > leg_max 0.9"):
        load_controller(y)


def test_run_says_it_scaled_and_records_the_body(tmp_path: Path) -> None:
    from bipedsim.cli import main

    out = tmp_path / "run"
    lines: list[str] = []
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["run", "--seconds", "0.2", "--mass", "80", "--out", str(out)]) == 0
    lines = buf.getvalue().splitlines()
    assert any(ln.startswith("controller: settings scaled to the body") and "x1.250" in ln for ln in lines), lines
    body = json.loads((out / "outcome.json").read_text())["config"]["controller"]["body"]
    assert body["mass"] == pytest.approx(80.0) and body["torque_scale"] == pytest.approx(1.25)


def test_a_similar_motion_scales_lengths_and_time_so_the_froude_number_stays() -> None:
    from bipedsim.motion.bvh import load_bvh

    f = SHARED / "cmu_02_02_walk__19joint_Hip_Abdomen.bvh"
    if not f.exists():
        pytest.skip(f"shared walk not present: {f}")
    m = load_bvh(f)
    s = m.similar(0.64)
    assert s.unit == 1.0 and s.frame_time == pytest.approx(0.8 * m.frame_time)
    a, b = m.in_metres().travel(), s.travel()
    speed = [float(abs(x[-1, 0] - x[0, 0])) / (len(x) - 1) / ft for x, ft in ((a, m.frame_time), (b, s.frame_time))]
    assert speed[1] == pytest.approx(0.8 * speed[0])  # v / sqrt(g L) unchanged
    assert m.fk()[0][5].max() * m.unit * 0.64 == pytest.approx(s.fk()[0][5].max())


def _similar_walk(tmp_path: Path, size: float, name: str = "cmu_02_02_walk__19joint_Hip_Abdomen") -> Path:
    """A shared walk (CMU 02_02, 19-joint layout) as the walk of a body ``size`` times as large
    (``Motion.similar``)."""
    from bipedsim.motion.bvh import load_bvh, write_bvh

    f = SHARED / f"{name}.bvh"
    if not f.exists():
        pytest.skip(f"shared walk not present: {f}")
    out = tmp_path / f"similar_{size:g}.bvh"
    write_bvh(load_bvh(f).similar(size), out)
    return out


@pytest.mark.slow
def test_a_smaller_body_walks_its_similar_walk_only_when_the_controller_is_scaled(tmp_path: Path) -> None:
    """CMU 02_02 (daz layout, legs 0.82 m, 61.7 kg from its legs) as a body 0.8 times the size (legs
    0.66 m, below the measured 0.78-0.94 m; 39.5 kg) walking the same walk at the same Froude number:
    scaled, it walks 20 s at >= 70 % of its clip's speed (seed 0; seeds 0-3 all do); with the settings as
    written it falls (at 16.1 s, with the search off as the test suite runs)."""
    from bipedsim.control.humanoid.cycles import clip_speed
    from bipedsim.sim import runner
    from bipedsim.sim.rollout import RolloutSpec

    small = _similar_walk(tmp_path, 0.8, "cmu_02_02_walk__daz43")
    sc = runner.load_scenario(None, small)
    assert sc.cfg.body.leg_min == pytest.approx(0.8 * 0.822, abs=0.01)  # scaled to the small body
    assert sc.cfg.body.mass == pytest.approx(0.64 * 61.7, abs=0.1)  # its mass from its legs
    out, _ = runner.run_scenario(sc, RolloutSpec(seconds=20.0, seed=0))
    assert out.outcome == "no_fall" and out.mean_speed_mps >= 0.7 * clip_speed(sc.clip), out
    as_written = dataclasses.replace(ControllerConfig(), body=dataclasses.replace(ControllerConfig().body, scale=False))
    out, _ = runner.run_scenario(runner.load_scenario(as_written, small), RolloutSpec(seconds=20.0, seed=0))
    assert out.outcome == "fall", out


def test_tuning_candidates_get_the_settings_a_run_gets(tmp_path: Path) -> None:
    """``bipedsim tune`` swaps each candidate's settings into a loaded scenario: they are scaled to the
    body and their "auto" switches resolved exactly as ``load_scenario`` does for ``bipedsim run``."""
    from bipedsim.experiments.tune.evaluate import with_settings
    from bipedsim.sim import runner

    sc = runner.load_scenario(None, _similar_walk(tmp_path, 1.25))
    assert sc.cfg.body.leg_min > ControllerConfig().body.leg_max  # scaled to a body outside the range
    assert sc.cfg.modulation.swing_foot.enabled is True  # a capture: its legs re-solved, the IK on
    assert with_settings(sc, ControllerConfig()).cfg == sc.cfg


def test_the_controller_scales_settings_once_however_it_is_built(tmp_path: Path) -> None:
    """The controller scales the settings it is given to its body (``SimbiconController.__init__``), and
    settings ``load_scenario`` already scaled pass unchanged: a body outside the measured legs (0.8x,
    39.5 kg) and the built-in body (mass alone, 79.4 kg) get the same settings from the scenario, from
    the controller built on them, and from one built directly on unscaled settings (after the same
    reference switches)."""
    from bipedsim.control.humanoid.simbicon import body_mass, leg_length, make_humanoid
    from bipedsim.control.settings import for_reference
    from bipedsim.sim import runner

    for sc in (runner.load_scenario(None, _similar_walk(tmp_path, 0.8, "cmu_02_02_walk__daz43")),
               runner.load_scenario()):
        m = sc.built.model
        assert sc.controller().cfg == sc.cfg
        assert for_body(sc.cfg, leg_length(m), body_mass(m)) == sc.cfg
        direct = make_humanoid(m, sc.built.plan, sc.clip, for_reference(ControllerConfig(), "feasible" in sc.extra))
        assert direct.cfg == sc.cfg
        pose = make_humanoid(m, sc.built.plan, sc.clip, dataclasses.replace(ControllerConfig(), source="pose"))
        assert pose.source.gait.state_a_time == pose.cfg.pose_gait.state_a_time  # the key poses' time scaled too
    assert pose.cfg.pose_gait.state_a_time == ControllerConfig().pose_gait.state_a_time  # the built-in: lambda 1
