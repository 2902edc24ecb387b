"""benchmarks/whole_clips.py runs a controller file's settings (``--config``) and refuses a bad one."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import bipedsim

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "whole_clips.py"
WALK = Path(bipedsim.__file__).parent / "data" / "walk.bvh"


def _rows(tmp_path: Path, *extra: str) -> tuple[int, str, list[dict[str, object]]]:
    out = tmp_path / f"rows{len(list(tmp_path.glob('rows*')))}.jsonl"
    p = subprocess.run([sys.executable, str(SCRIPT), str(WALK), "--ways", "cycle", "--jobs", "1", "--jsonl", str(out),
                        *extra], capture_output=True, text=True, timeout=300)
    rows = [json.loads(line) for line in out.read_text().splitlines()] if out.is_file() else []
    return p.returncode, p.stderr, rows


def test_a_controller_file_changes_what_the_benchmark_runs(tmp_path: Path) -> None:
    rc, err, default = _rows(tmp_path)
    assert rc == 0, err
    cfg = tmp_path / "weak.yaml"
    cfg.write_text("balance:\n  enabled: false\n")  # no balance: the built-in walk falls
    rc, err, weak = _rows(tmp_path, "--config", str(cfg))
    assert rc == 0, err
    assert default[0]["outcome"] == "no_fall"
    assert weak[0]["outcome"] == "fall" and weak[0]["fall_s"] < 20.0


def test_a_bad_controller_file_is_refused_naming_the_key(tmp_path: Path) -> None:
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("balance:\n  nonsense: 1\n")
    rc, err, rows = _rows(tmp_path, "--config", str(cfg))
    assert rc == 2 and rows == []
    assert "balance.nonsense" in err and "Traceback" not in err
