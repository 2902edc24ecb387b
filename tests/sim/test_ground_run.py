"""Runs on a shaped ground: a short walk on a slope stands and records its ground, the fall rule
counts every ground geom as floor and measures the pelvis from the ground under it, --ground errors."""

from __future__ import annotations

import json
from dataclasses import replace

import mujoco
import pytest

from bipedsim.cli import main
from bipedsim.model.ground import Ground, ground_geoms
from bipedsim.sim.rollout import FallCriteria, FallDetector, RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


@pytest.fixture(scope="module")
def slope() -> object:
    return load_scenario(ground=Ground.parse(["slope:-8", "step:0.1:6"]))


def test_a_short_walk_down_a_slope_stands_and_records_its_ground(slope: object) -> None:
    out, ctrl = run_scenario(slope, RolloutSpec(seconds=3.0))  # type: ignore[arg-type]
    assert out.outcome == "no_fall", out.fall_reason
    assert out.distance_m > 1.5
    assert out.config["ground"] == ["slope:-8", "step:0.1:6"]
    assert ctrl.terrain is not None  # type: ignore[attr-defined]


def test_the_fall_rule_counts_a_step_as_floor(slope: object) -> None:
    sc = slope
    m = sc.built.model  # type: ignore[attr-defined]
    assert len(ground_geoms(m)) == 2  # the plane and the step's box
    data = mujoco.MjData(m)
    data.qpos[:] = sc.clip.qpos[sc.controller().start_frame()]  # type: ignore[attr-defined]
    mujoco.mj_forward(m, data)
    det = FallDetector(m, sc.built.plan, FallCriteria(), data)  # type: ignore[attr-defined]
    assert det.check(data) is None
    # the body lying on the step's top, 6.2 m ahead (on the box, not the plane)
    t = sc.terrain  # type: ignore[attr-defined]
    x = t.frame.x + 6.2
    data.qpos[0], data.qpos[2] = x, t.height(x, 0.0) + 0.1
    data.qpos[3:7] = [0.7071, 0.0, 0.7071, 0.0]  # pitched 90 degrees: lying face down
    mujoco.mj_forward(m, data)
    step_box = max(ground_geoms(m))
    assert any(step_box in (int(g1), int(g2)) for g1, g2 in data.contact.geom[:data.ncon])
    assert "touched the ground" in (det.check(data) or "")


def test_the_pelvis_height_is_measured_from_the_ground_under_it(slope: object) -> None:
    sc = slope
    m = sc.built.model  # type: ignore[attr-defined]
    data = mujoco.MjData(m)
    data.qpos[:] = sc.clip.qpos[sc.controller().start_frame()]  # type: ignore[attr-defined]
    mujoco.mj_forward(m, data)
    det = FallDetector(m, sc.built.plan, FallCriteria(non_foot_contact=False), data)  # type: ignore[attr-defined]
    t = sc.terrain  # type: ignore[attr-defined]
    x0, z0 = float(data.qpos[0]), float(data.qpos[2])
    data.qpos[0] = x0 + 4.0  # 4 m downhill: 0.56 m lower, at the same height above the ground
    data.qpos[2] = z0 + t.height(x0 + 4.0, float(data.qpos[1])) - t.height(x0, float(data.qpos[1]))
    mujoco.mj_forward(m, data)
    assert data.qpos[2] < 0.55 * z0 + 0.1 and det.check(data) is None
    data.qpos[2] -= 0.5 * z0  # now half its height above the ground
    mujoco.mj_forward(m, data)
    assert "below 0.55" in (det.check(data) or "")


def test_controller_without_ground_adaptation_reads_the_setting(slope: object) -> None:
    sc = slope
    cfg = sc.cfg  # type: ignore[attr-defined]
    off = replace(sc, cfg=replace(cfg, modulation=replace(cfg.modulation, ground=replace(
        cfg.modulation.ground, enabled=False))))
    on, _ = run_scenario(sc, RolloutSpec(seconds=1.0))  # type: ignore[arg-type]
    without, _ = run_scenario(off, RolloutSpec(seconds=1.0))
    assert on.tracking_rmse_rad != without.tracking_rmse_rad  # the adaptation acts on a shaped ground


def test_cli_ground_error_exits_2_without_a_traceback(tmp_path, capsys) -> None:
    assert main(["run", "--seconds", "0.5", "--ground", "rough:0.03", "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "--ground: 'rough:0.03': expected rough:AMPLITUDE_M:WAVELENGTH_M[:SEED]" in err
    assert "Traceback" not in err


def test_cli_run_saves_the_ground_in_model_xml(tmp_path) -> None:
    out = tmp_path / "r"
    assert main(["run", "--seconds", "0.3", "--ground", "slope:4", "--ground", "friction:0.8",
                 "--out", str(out)]) == 0
    assert "bipedsim.ground" in (out / "model.xml").read_text()
    rec = json.loads((out / "outcome.json").read_text())
    assert rec["config"]["ground"] == ["slope:4", "friction:0.8"]


def test_suite_and_experiment_files_name_a_bad_ground_term(tmp_path) -> None:
    from bipedsim.errors import ConfigError
    from bipedsim.experiments.experiment import load_experiment, load_suite

    suite = tmp_path / "suite.yaml"
    suite.write_text("scenarios:\n  - {name: a, ground: ['slope:8', 'step:1:3']}\n")
    with pytest.raises(ConfigError, match=r"suite.yaml: scenarios\[0\]\.ground\[1\]: 'step:1:3': a step's height"):
        load_suite(suite)
    exp = tmp_path / "exp.yaml"
    exp.write_text("ground: ['hill']\nruns: [{magnitude: 10, start: 1.0}]\n")
    with pytest.raises(ConfigError, match=r"exp.yaml: ground: unknown ground 'hill'"):
        load_experiment(exp)
