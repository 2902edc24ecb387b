"""The Python API (``bipedsim.run``, ``bipedsim.sweep``, ``bipedsim.tune``): importable from the top-level
package without loading it at import, and giving the commands' own results (the commands call them)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import bipedsim
from bipedsim.cli import main
from bipedsim.errors import ConfigError
from bipedsim.sim.rollout import Outcome, RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


def test_import_bipedsim_does_not_load_the_api() -> None:
    code = "import sys, bipedsim; print('bipedsim.api' in sys.modules, 'mujoco' in sys.modules, callable(bipedsim.run))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False", "True"]


def test_run_returns_the_outcome_of_the_run_command(tmp_path: Path) -> None:
    out = bipedsim.run(seconds=1.0, pushes=["120:90:0.1:0.5"])
    assert isinstance(out, Outcome) and out.outcome == "no_fall"
    assert out.extra["push_start_s"] == pytest.approx(0.5, abs=0.01) and out.fidelity is not None
    assert main(["run", "--seconds", "1.0", "--push", "120:90:0.1:0.5", "--out", str(tmp_path / "cli")]) == 0
    written = json.loads((tmp_path / "cli" / "outcome.json").read_text())
    assert written["distance_m"] == out.distance_m and written["tracking_rmse_rad"] == out.tracking_rmse_rad
    bare, _ = run_scenario(load_scenario(None), RolloutSpec(seconds=1.0))
    assert bare.outcome == "no_fall" and bare.distance_m != out.distance_m  # the push moved it


def test_run_with_out_writes_the_folder(tmp_path: Path) -> None:
    out = bipedsim.run(seconds=0.5, out=tmp_path / "r")
    assert json.loads((tmp_path / "r" / "outcome.json").read_text())["steps"] == out.steps == 250


def test_run_errors_name_the_option() -> None:
    with pytest.raises(ConfigError, match="--push"):
        bipedsim.run(seconds=1.0, pushes=["100:0:0.2"])


def test_sweep_returns_one_record_per_rollout(tmp_path: Path) -> None:
    spec = tmp_path / "tiny.yaml"
    spec.write_text("name: tiny\nseconds: 1.0\ngrid:\n  magnitude: [60, 120]\n  direction: [90]\n"
                    "  start: [0.4]\n  duration: [0.1]\n")
    res = bipedsim.sweep(spec, tmp_path / "out")
    assert [r["index"] for r in res.rows] == [0, 1] and [r["magnitude"] for r in res.rows] == [60, 120]
    assert {r["outcome"] for r in res.rows} <= {"no_fall", "fall"} and isinstance(res.rows[0]["distance_m"], float)
    assert res.summary["rollouts"] == 2
    assert json.loads((tmp_path / "out" / "summary.json").read_text()) == res.summary
