"""Robustness of inputs: controller files layered over the defaults, implausible values refused."""

from __future__ import annotations

from pathlib import Path

import pytest

from bipedsim.cli import main
from bipedsim.control.config import MAX_CONTROL_DT, ControllerConfig, load_controller
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
    "balance:\n  sagittal: {cd: 0.65}\n",
])
def test_partial_controller_file_is_the_default_controller(tmp_path: Path, text: str) -> None:
    assert load_controller(_write(tmp_path, text)) == ControllerConfig()


def test_partial_controller_file_changes_only_what_it_names(tmp_path: Path) -> None:
    cfg = load_controller(_write(tmp_path, "pd:\n  gains:\n    hip: {kp: 800.0}\n"))
    base = ControllerConfig()
    assert cfg.pd.gains["hip"].kp == 800.0 and cfg.pd.gains["hip"].kd == base.pd.gains["hip"].kd
    assert {g: v for g, v in cfg.pd.gains.items() if g != "hip"} == {
        g: v for g, v in base.pd.gains.items() if g != "hip"}
    assert cfg.balance == base.balance and cfg.fsm == base.fsm and cfg.control_dt == base.control_dt


def test_partial_file_walks_exactly_as_the_default(tmp_path: Path) -> None:
    """Issue 24 case 6: a file with only the default's hip gains fell at 3.65 s; now the same rollout."""
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
