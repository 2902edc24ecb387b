"""Robustness of inputs: controller files layered over the defaults, implausible values refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from bipedsim.cli import main
from bipedsim.control.settings import MAX_CONTROL_DT, ControllerConfig, load_controller
from bipedsim.errors import ConfigError


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "ctl.yaml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("text", [
    "",                                                    # an empty file
    "# nothing but a comment\n",
    "pd:\n  gains:\n    hip: {kp: 1000.0, kd: 100.0}\n",    # only the default's own hip gains
    "pd:\n  gains:\n    hip: {kp: 1000.0}\n",               # one value of one group
    "balance:\n  sagittal: {{cd: {cd}}}\n",                # the default's own sagittal c_d
])
def test_partial_controller_file_is_the_default_controller(tmp_path: Path, text: str) -> None:
    text = text.format(cd=ControllerConfig().balance.sagittal.cd) if "{cd}" in text else text
    assert load_controller(_write(tmp_path, text)) == ControllerConfig()


def test_partial_controller_file_changes_only_what_it_names(tmp_path: Path) -> None:
    cfg = load_controller(_write(tmp_path, "pd:\n  gains:\n    hip: {kp: 800.0}\n"))
    base = ControllerConfig()
    assert cfg.pd.gains["hip"].kp == 800.0 and cfg.pd.gains["hip"].kd == base.pd.gains["hip"].kd
    assert {g: v for g, v in cfg.pd.gains.items() if g != "hip"} == {
        g: v for g, v in base.pd.gains.items() if g != "hip"}
    assert cfg.balance == base.balance and cfg.fsm == base.fsm and cfg.control_dt == base.control_dt


def test_partial_file_walks_exactly_as_the_default(tmp_path: Path) -> None:
    """A file with only the default's hip gains walks exactly as the default does (the rest of the
    settings are the defaults, not zeros)."""
    import json

    p = _write(tmp_path, "pd:\n  gains:\n    hip: {kp: 1000.0, kd: 100.0}\n")
    assert main(["run", str(p), "--seconds", "4", "--out", str(tmp_path / "a")]) == 0
    assert main(["run", "--seconds", "4", "--out", str(tmp_path / "b")]) == 0
    a, b = (json.loads((tmp_path / x / "outcome.json").read_text()) for x in "ab")
    assert a["outcome"] == b["outcome"] == "no_fall"
    assert a["distance_m"] == b["distance_m"] and a["tracking_rmse_rad"] == b["tracking_rmse_rad"]


@pytest.mark.parametrize("text,key,words", [
    ("control_dt: 4\n", "control_dt", f"must be <= {MAX_CONTROL_DT}"),
    ("control_dt: 0\n", "control_dt", "must be > 0"),
    ("- 1\n- 2\n", None, "expected a mapping of keys"),
    ("pd: 3\n", "pd", "expected a mapping of keys"),
])
def test_implausible_controller_values_are_refused(tmp_path: Path, text: str, key: str | None, words: str,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    p = _write(tmp_path, text)
    with pytest.raises(ConfigError) as exc:
        load_controller(p)
    assert str(p) in str(exc.value) and words in str(exc.value) and (key is None or key in str(exc.value))
    assert main(["run", str(p), "--seconds", "0.1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err


def _chain(n: int, bone: float = 0.1, frame_time: str = "0.0333333", frames: int = 3) -> str:
    """A BVH of ``n`` joints nested in one chain (each bone ``bone`` units long)."""
    out = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0",
           "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for i in range(1, n):
        out += [f"JOINT j{i}", "{", f"OFFSET 0 {bone} 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    out += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * n
    out += ["MOTION", f"Frames: {frames}", f"Frame Time: {frame_time}"]
    out += [" ".join(["0"] * (3 + 3 * n))] * frames
    return "\n".join(out) + "\n"


def test_thousand_nested_joints_read(tmp_path: Path) -> None:
    """A BVH with >= 1000 nested joints reads (no RecursionError)."""
    from bipedsim.motion import read_bvh

    p = tmp_path / "deep.bvh"
    p.write_text(_chain(1500))
    m, _ = read_bvh(p)
    assert m.num_joints == 1500 and list(m.skeleton.parents[:3]) == [-1, 0, 1] and m.skeleton.parents[-1] == 1498
    assert main(["info", str(p)]) == 0


def test_chain_that_collapses_into_one_body_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A 500-joint chain of tiny bones, which would run as a creature of one body, is refused."""
    p = tmp_path / "chain.bvh"
    p.write_text(_chain(500))
    assert main(["run", "--bvh", str(p), "--profile", "creature", "--seconds", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "500 joints merges into the root" in err and "merge_fraction" in err and err.count("\n") == 1
    assert not (tmp_path / "o" / "outcome.json").exists()


def test_body_nested_deeper_than_mujoco_reads_is_refused(tmp_path: Path) -> None:
    from bipedsim.errors import ModelError
    from bipedsim.model import build_model, load_profile
    from bipedsim.model.build import MAX_BODY_DEPTH
    from bipedsim.motion import load_bvh

    p = tmp_path / "deep.bvh"
    p.write_text(_chain(MAX_BODY_DEPTH + 10, bone=1.0))
    prof = load_profile("creature")
    from dataclasses import replace

    with pytest.raises(ModelError, match=f"nests {MAX_BODY_DEPTH + 10} bodies deep; MuJoCo reads at most"):
        build_model(load_bvh(p), replace(prof, merge_fraction=0.0))


@pytest.mark.parametrize("frame_time", ["1e30", "0", "-0.1", "5", "1e-6"])
def test_implausible_frame_time_is_refused(tmp_path: Path, frame_time: str) -> None:
    from bipedsim.errors import BVHError
    from bipedsim.motion import read_bvh

    p = tmp_path / "ft.bvh"
    p.write_text(_chain(4, frame_time=frame_time))
    with pytest.raises(BVHError, match=f"ft.bvh:28: Frame Time {frame_time} s is not plausible"):
        read_bvh(p)
    assert main(["info", str(p)]) == 2


def test_given_scale_that_makes_an_absurd_body_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    """--scale 1 on a centimetre file, which would make a 183 m body walking at 93 m/s, is refused."""
    from bipedsim.data import BUILTIN_WALK

    assert main(["info", str(BUILTIN_WALK), "--scale", "1"]) == 2
    err = capsys.readouterr().err
    assert "the body's height is" in err and "suggests cm (0.01 m per unit)" in err
    assert main(["info", str(BUILTIN_WALK), "--scale", "cm"]) == 0


@pytest.mark.parametrize("mass", ["inf", "nan", "-3", "0"])
def test_impossible_mass_is_refused(tmp_path: Path, mass: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--mass", mass, "--seconds", "1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--mass: total mass must be a finite number > 0 kg" in err and len(err.splitlines()) == 1
    from bipedsim.data import BUILTIN_WALK

    assert main(["convert", str(BUILTIN_WALK), "-o", str(tmp_path / "m.xml"), "--mass", mass]) == 2
    assert "bipedsim convert: error: --mass: total mass must be a finite number > 0 kg" in capsys.readouterr().err


def test_humanoid_of_implausible_height_is_refused_not_built(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    """A misread file must not become a body of the wrong size: the built-in walk (centimetres) read at
    2 mm a unit would stand 0.48 m tall (the Bandai-Namco walk, misread, built a 0.30 m humanoid)."""
    from bipedsim.data import BUILTIN_WALK

    out = tmp_path / "h.xml"
    assert main(["convert", str(BUILTIN_WALK), "-o", str(out), "--scale", "0.002"]) == 2
    err = capsys.readouterr().err
    assert "stands 0.48 m tall" in err and "probably misread" in err and not out.exists()
    assert f"{BUILTIN_WALK}: the humanoid built" in err  # which file: a sweep or a tune reads several
    assert main(["convert", str(BUILTIN_WALK), "-o", str(out), "--scale", "0.002", "--profile", "creature"]) == 0
