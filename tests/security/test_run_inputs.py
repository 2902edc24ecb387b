"""Run, controller and model inputs that gave a silently wrong result or a traceback: each is now
applied as recorded, or refused with one line naming the file and the key (exit 2, no traceback)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from bipedsim.cli import main
from bipedsim.errors import BVHError, ConfigError, ModelError

REPO = Path(__file__).resolve().parents[2]


def _one_line_error(capsys: pytest.CaptureFixture[str], *words: str) -> str:
    """The command's stderr: one line, no traceback, holding every one of ``words``."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, (w, err)
    return err


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def _chain_bvh(root_x: str = "0", offset: str = "10") -> str:
    """A 4-joint chain, 3 frames, centimetre-sized bones; frame 2's root X position is ``root_x`` and
    the second joint's OFFSET ``offset`` (file units)."""
    out = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0",
           "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for i in range(1, 4):
        out += [f"JOINT j{i}", "{", f"OFFSET 0 {offset if i == 1 else '10'} 0",
                "CHANNELS 3 Zrotation Xrotation Yrotation"]
    out += ["End Site", "{", "OFFSET 0 10 0", "}"] + ["}"] * 4
    out += ["MOTION", "Frames: 3", "Frame Time: 0.0333333"]
    rows = [["0"] * 15 for _ in range(3)]
    rows[1][0] = root_x
    out += [" ".join(r) for r in rows]
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def walk():  # noqa: ANN201 - a Scenario
    from bipedsim.sim.runner import load_scenario

    return load_scenario()


# ---------------------------------------------------------------------- --init-noise at seed 0
def _first_qvel(sc, spec) -> tuple[np.ndarray, object]:  # noqa: ANN001
    from bipedsim.sim.runner import run_scenario

    seen: list[np.ndarray] = []

    def first(t, data, ctrl) -> None:  # noqa: ANN001 - a rollout hook
        if not seen:
            seen.append(data.qvel.copy())

    out, _ = run_scenario(sc, spec, hooks=[first])
    return seen[0], out


def test_init_noise_is_applied_at_seed_0_as_recorded(walk) -> None:  # noqa: ANN001
    """Seed 0 with --init-noise had started from the noiseless state yet recorded the noise: row 0 of
    every noisy sweep was noise-free. Now every seed's noise is drawn from that seed."""
    from bipedsim.sim.rollout import RolloutSpec
    from bipedsim.sim.runner import seed_noise

    plain, out0 = _first_qvel(walk, RolloutSpec(seconds=0.05))
    noisy_spec = RolloutSpec(seconds=0.05, seed=0, init_noise=0.05)
    noisy, out = _first_qvel(walk, noisy_spec)
    again, _ = _first_qvel(walk, noisy_spec)
    assert out.config["init_noise"] == 0.05 and out0.config["init_noise"] == 0.0 and out.seed == 0
    noise = seed_noise(noisy_spec, plain.shape)
    assert noise is not None and np.abs(noise).max() > 0.01
    np.testing.assert_allclose(noisy - plain, noise, atol=1e-9)
    np.testing.assert_array_equal(noisy, again)  # drawn from the seed
    one, _ = _first_qvel(walk, RolloutSpec(seconds=0.05, seed=1, init_noise=0.05))
    assert np.abs(one - noisy).max() > 0.01
    assert seed_noise(RolloutSpec(seed=3), plain.shape) is None  # no noise asked: none drawn


def test_nominal_rollout_cache_keeps_noisy_seed_0_apart(walk) -> None:  # noqa: ANN001
    """The unpushed rollout a push is measured against is cached per scenario: seed 0 with noise is its
    own entry, not the noiseless one."""
    from bipedsim.sim.push import Push
    from bipedsim.sim.rollout import RolloutSpec
    from bipedsim.sim.runner import run_scenario

    sc = dataclasses.replace(walk, extra={})
    push = [Push(magnitude=50.0, direction=90.0, duration=0.05, start=0.1)]
    for seed, noise in ((0, 0.0), (7, 0.0), (0, 0.05), (1, 0.05)):
        run_scenario(sc, RolloutSpec(seconds=0.2, seed=seed, init_noise=noise), pushes=push)
    keys = list(sc.extra["nominal_com"])
    assert len(keys) == 3  # seeds 0 and 7 without noise share one
    assert {(k[1], k[2]) for k in keys} == {(0, 0.0), (0, 0.05), (1, 0.05)}


# ---------------------------------------------------------------------- control_dt
@pytest.mark.parametrize("value,words", [
    ("1.0e-9", "shorter than the physics timestep 0.002 s"),
    ("0.003", "not a whole multiple of the physics timestep 0.002 s"),
])
def test_control_period_that_is_no_whole_number_of_physics_steps_is_refused(
        tmp_path: Path, value: str, words: str, capsys: pytest.CaptureFixture[str]) -> None:
    """``control_dt: 1e-9`` ran at the physics rate and recorded 1e-9."""
    ctl = _write(tmp_path / "fast.yaml", f"control_dt: {value}\n")
    assert main(["run", str(ctl), "--seconds", "0.5", "--out", str(tmp_path / "o")]) == 2
    _one_line_error(capsys, "fast.yaml: control_dt:", words)
    assert not (tmp_path / "o" / "outcome.json").exists()


def test_control_period_used_is_the_one_recorded(walk) -> None:  # noqa: ANN001
    from bipedsim.sim.rollout import RolloutSpec, control_every
    from bipedsim.sim.runner import run_scenario

    assert control_every(None, 0.002) == 1 and control_every(0.006, 0.002) == 3 and control_every(0.002, 0.002) == 1
    with pytest.raises(ConfigError, match="control_dt: a control period of nan s"):
        control_every(float("nan"), 0.002)
    calls: list[float] = []
    sc = dataclasses.replace(walk, cfg=dataclasses.replace(walk.cfg, control_dt=0.006))
    out, _ = run_scenario(sc, RolloutSpec(seconds=0.3), hooks=[lambda t, d, c: calls.append(t)])
    assert out.config["controller"]["control_dt"] == 0.006
    assert len(calls) == 50 and np.allclose(np.diff(calls), 0.006)
    with pytest.raises(ConfigError, match="physics timestep 0.002 s"):
        run_scenario(walk, RolloutSpec(seconds=0.1, control_dt=0.001))


# ---------------------------------------------------------------------- one kind's settings for the other
def test_humanoid_settings_in_a_creatures_controller_file_are_refused(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    from bipedsim.data import BUILTIN_WALK

    ctl = _write(tmp_path / "h.yaml", "pd:\n  gains:\n    hip: {kp: 800.0}\nfsm: {state1_time: 0.25}\n")
    assert main(["run", str(ctl), "--bvh", str(BUILTIN_WALK), "--profile", "creature", "--seconds", "0.5",
                 "--out", str(tmp_path / "o")]) == 2
    _one_line_error(capsys, "h.yaml", "pd.gains.hip.kp, fsm.state1_time", "only a humanoid's controller reads")


def test_creature_settings_in_a_humanoids_controller_file_are_refused(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    ctl = _write(tmp_path / "c.yaml", "creature:\n  support_kp: 30.0\n  balance: {speed_gain: 0.7}\n")
    assert main(["run", str(ctl), "--seconds", "0.5", "--out", str(tmp_path / "o")]) == 2
    _one_line_error(capsys, "c.yaml", "creature.support_kp, creature.balance.speed_gain",
                    "only a creature's controller reads")


def test_a_file_restating_the_defaults_serves_both_kinds(tmp_path: Path) -> None:
    """controllers/default.yaml names every key of both kinds, each at its default: nothing is ignored."""
    from bipedsim.control.settings import load_controller, unread_settings

    cfg = load_controller(REPO / "controllers" / "default.yaml")
    assert unread_settings(cfg, "creature") == [] and unread_settings(cfg, "humanoid") == []
    named = load_controller(_write(tmp_path / "n.yaml", "name: mine\n"))
    assert unread_settings(named, "creature") == [] and unread_settings(named, "humanoid") == []


def test_experiments_and_suites_check_their_controllers_against_the_body(tmp_path: Path) -> None:
    from bipedsim.data import BUILTIN_WALK
    from bipedsim.experiments.experiment import load_experiment, load_suite

    _write(tmp_path / "h.yaml", "balance: {torso_kp: 900.0}\n")
    _write(tmp_path / "c.yaml", "creature: {support_kp: 30.0}\n")
    exp = _write(tmp_path / "exp.yaml", f"reference: {BUILTIN_WALK}\nprofile: creature\nseconds: 2\n"
                 "grid: {magnitude: [10], start: [0.5], controller: [h.yaml]}\n")
    with pytest.raises(ConfigError, match=r"exp.yaml: grid.controller: .*h.yaml: sets balance.torso_kp"):
        load_experiment(exp)
    suite = _write(tmp_path / "s.yaml", "scenarios:\n  - {name: walk, seconds: 1, controller: c.yaml}\n")
    with pytest.raises(ConfigError, match=r"s.yaml: scenarios\[0\].controller: .*c.yaml: sets creature.support_kp"):
        load_suite(suite)


# ---------------------------------------------------------------------- names
@pytest.mark.parametrize("name", ["\x1b[2J\x1b[31mred", "two\nlines", "tab\there", "\u202eevil", "bell\x07"])
def test_names_with_control_characters_are_refused(tmp_path: Path, name: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from bipedsim.experiments.experiment import load_experiment

    quoted = json.dumps(name)  # a YAML double-quoted string
    suite = _write(tmp_path / "s.yaml", f"scenarios:\n  - {{name: {quoted}, seconds: 1}}\n")
    assert main(["regress", str(suite)]) == 2
    err = _one_line_error(capsys, "s.yaml: scenarios[0].name: holds the unprintable character U+")
    assert not any(c in err for c in "\x1b\x07\t\u202e")
    assert main(["regress", str(_write(tmp_path / "t.yaml", f"name: {quoted}\nscenarios:\n  - {{name: a}}\n"))]) == 2
    _one_line_error(capsys, "t.yaml: name: holds the unprintable character")
    exp = _write(tmp_path / "e.yaml", f"name: {quoted}\nseconds: 2\ngrid: {{start: [0.5]}}\n")
    with pytest.raises(ConfigError, match="e.yaml: name: holds the unprintable character"):
        load_experiment(exp)


def test_printable_names_pass_and_the_table_escapes_what_it_prints(monkeypatch: pytest.MonkeyPatch,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    from bipedsim.experiments import regress
    from bipedsim.experiments.experiment import Suite, SuiteScenario, check_name

    check_name("Gehen über 200 N -- 10 % links")  # letters of any script, spaces, punctuation
    with pytest.raises(ValueError, match="at most 200"):
        check_name("x" * 201)
    assert regress.printable("a\x1b[31mb\n") == "a\\x1b[31mb\\n"
    monkeypatch.setattr(regress, "load_suite", lambda p: Suite(scenarios=(SuiteScenario(name="a"),)))
    monkeypatch.setattr(regress, "run_scenarios", lambda s, b: [
        regress.ScenarioResult("odd\x1b[2Jname", "no_fall", "fall", 1.0, "push\x1b[31m note")])
    assert regress.run_suite("suite.yaml") == 1
    out = capsys.readouterr().out
    assert "\x1b" not in out and "odd\\x1b[2Jname" in out and "push\\x1b[31m note" in out


# ---------------------------------------------------------------------- implausible lengths in a BVH
@pytest.mark.parametrize("root_x,offset,what,then", [
    # corrupt numbers, refused by the reader
    ("1e300", "10", "frame 2 holds a value of 1e+300: larger than 1e+09", "the file's numbers are corrupt"),
    ("0", "1e300", "an OFFSET of 1e+300 file units: larger than 1e+09", "the file's numbers are corrupt"),
    # numbers a file can hold, too far once in metres
    ("1e8", "10", "the root's position (j0, frame 2) has a coordinate of ",
     " m per file unit); a motion stays within 100000 m"),
])
def test_bvh_with_an_implausible_length_is_refused_by_every_command(
        tmp_path: Path, root_x: str, offset: str, what: str, then: str, capsys: pytest.CaptureFixture[str]) -> None:
    """A root position of 1e300 ended in an SVD that did not converge (LinAlgError) or speeds of inf m/s."""
    bvh = _write(tmp_path / "far.bvh", _chain_bvh(root_x, offset))
    for argv in (["info", str(bvh)], ["convert", str(bvh), "-o", str(tmp_path / "m.xml")],
                 ["run", "--bvh", str(bvh), "--seconds", "0.5", "--out", str(tmp_path / "o")]):
        assert main(argv) == 2, argv
        _one_line_error(capsys, f"{bvh}: ", what, then)
    assert not (tmp_path / "m.xml").exists() and not (tmp_path / "o" / "outcome.json").exists()


def test_motion_within_the_bound_passes_the_check(tmp_path: Path) -> None:
    from bipedsim.motion import read_bvh
    from bipedsim.motion.motion import MAX_POSITION_M, check_extent

    m, _ = read_bvh(_write(tmp_path / "near.bvh", _chain_bvh("5e5")), scale=0.01)  # 5 km
    check_extent(m, "near.bvh")
    with pytest.raises(BVHError, match="near.bvh: the root's position"):
        check_extent(m.copy(unit=1.0), "near.bvh")  # read as metres: 500 km
    assert MAX_POSITION_M == 1e5


# ---------------------------------------------------------------------- --mass
@pytest.mark.parametrize("mass", ["1e-6", "0.05", "1e6"])
def test_body_mass_outside_the_range_is_refused(tmp_path: Path, mass: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """``--mass 1e-6`` ended in MuJoCo's ValueError (mass and inertia below mjMINVAL)."""
    from bipedsim.data import BUILTIN_WALK

    assert main(["run", "--mass", mass, "--seconds", "0.5", "--out", str(tmp_path / "o")]) == 2
    _one_line_error(capsys, "--mass: total mass must be 0.1 to 100000 kg")
    assert main(["convert", str(BUILTIN_WALK), "-o", str(tmp_path / "m.xml"), "--mass", mass]) == 2
    _one_line_error(capsys, "--mass: total mass must be 0.1 to 100000 kg")


def test_body_mass_is_bounded_where_it_is_applied(tmp_path: Path) -> None:
    from bipedsim.data import BUILTIN_WALK
    from bipedsim.model import build_model, load_profile
    from bipedsim.motion import load_bvh

    with pytest.raises(ModelError, match="total mass must be 0.1 to 100000 kg, got 1e-06 kg"):
        build_model(load_bvh(BUILTIN_WALK), "humanoid", total_mass=1e-6)
    prof = _write(tmp_path / "tiny_creature.yaml", "density: 1000.0\ntotal_mass: 1.0e-6\n")
    with pytest.raises(ConfigError, match="total_mass: must be >= 0.1"):
        load_profile(prof)
    assert build_model(load_bvh(BUILTIN_WALK), "humanoid", total_mass=0.1).summary()["total_mass_kg"] == \
        pytest.approx(0.1, rel=1e-3)


# ---------------------------------------------------------------------- deeply nested YAML
def test_deeply_nested_yaml_is_one_line_for_every_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from bipedsim.data import BUILTIN_WALK

    deep = _write(tmp_path / "deep.yaml", "a: " + "[" * 5000 + "]" * 5000 + "\n")
    out = str(tmp_path / "o")
    for argv in (["run", str(deep), "--seconds", "0.5", "--out", out],
                 ["run", "--bvh", str(BUILTIN_WALK), "--events", str(deep), "--seconds", "0.5", "--out", out],
                 ["convert", str(BUILTIN_WALK), "-o", str(tmp_path / "m.xml"), "--map", str(deep)],
                 ["sweep", str(deep), "--out", out], ["regress", str(deep)]):
        assert main(argv) == 2, argv
        _one_line_error(capsys, "deep.yaml: line 1", "nested more than")


def test_suite_update_reads_the_file_as_every_input_before_the_round_trip(tmp_path: Path) -> None:
    """``regress --update`` hands the text to ruamel.yaml (for the rewrite that keeps comments) only after
    the project's reader has checked it: size, nesting, duplicate keys."""
    from bipedsim.experiments.regress import update_expectations

    deep = _write(tmp_path / "deep.yaml", "scenarios: " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(ConfigError, match="nested more than"):
        update_expectations(deep, {"a": "fall"})
    twice = _write(tmp_path / "twice.yaml", "scenarios:\n  - {name: a}\nscenarios: []\n")
    with pytest.raises(ConfigError, match="twice.yaml: line 3, column 1: invalid YAML: key 'scenarios' is given twice"):
        update_expectations(twice, {"a": "fall"})
    ok = _write(tmp_path / "ok.yaml", "# kept\nscenarios:\n  - {name: a, seconds: 1}  # and this\n")
    assert update_expectations(ok, {"a": "fall"}) == ["a"]
    assert "# kept" in ok.read_text() and "expect: fall" in ok.read_text() and "# and this" in ok.read_text()


# ---------------------------------------------------------------------- bounds on run lengths and settings
def test_run_length_is_bounded(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from bipedsim.experiments.experiment import load_experiment

    assert main(["run", "--seconds", "1e12", "--out", str(tmp_path / "o")]) == 2
    _one_line_error(capsys, "--seconds: must be a run length in (0, 3600] s")
    exp = _write(tmp_path / "e.yaml", "seconds: 1.0e12\ngrid: {start: [0.5]}\n")
    with pytest.raises(ConfigError, match="e.yaml: seconds: must be <= 3600"):
        load_experiment(exp)


@pytest.mark.parametrize("text,key", [
    ("pd:\n  gains:\n    hip: {kp: .nan}\n", "pd.gains.hip.kp: must be a finite number"),
    ("reference: {feasible: true, smooth_s: 1.0e300}\n", "reference.smooth_s: must be <= 10.0"),
    ("reference: {feasible: true, pendulum: 1.0e300}\n", "reference.pendulum: must be <= 1000000.0"),
    ("body: {leg_min: 1.0e-300, leg_max: 1.0e-300}\n", "body.leg_min: must be >= 0.2"),
    ("body: {mass: 1.0e-300}\n", "body.mass: must be >= 0.1"),
    ("creature:\n  balance: {velocity_window_s: 1.0e300}\n", "creature.balance.velocity_window_s: must be <= 10.0"),
    ("creature:\n  balance: {height_fraction: 1.0e300}\n", "creature.balance.height_fraction: must be <= 1.5"),
    ("creature:\n  balance: {plan_dt_s: 1.0e-9}\n", "creature.balance.plan_dt_s: must be >= 0.002"),
])
def test_absurd_controller_settings_are_refused(tmp_path: Path, text: str, key: str) -> None:
    """Each of these had ended in a traceback (an overflow, an array too large, NaN targets) or scaled the
    controller by an absurd factor."""
    from bipedsim.control.settings import load_controller

    ctl = _write(tmp_path / "ctl.yaml", text)
    with pytest.raises(ConfigError, match="ctl.yaml: " + key.replace(".", r"\.")):
        load_controller(ctl)
