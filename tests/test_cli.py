"""The command line: output, JSON, exit codes, and the README's commands."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

from conftest import REPO

from bipedsim.cli import main


def test_info_text_and_json(capsys) -> None:
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "joints      21" in out and "unit        cm" in out and "up axis     Y" in out
    assert main(["info", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["num_frames"] == 201 and d["unit_name"] == "cm"
    assert abs(d["root_speed_mps"] - 0.946) < 0.01  # 0.44 m steps at 129 steps/min


def test_no_command_prints_help_and_exits_2(capsys) -> None:
    assert main([]) == 2


def readme_block(marker: str) -> str:
    text = (REPO / "README.md").read_text()
    m = re.search(rf"<!-- {marker} -->\s*```bash\n(.*?)```", text, re.DOTALL)
    assert m, marker
    return m.group(1).strip()


def test_readme_main_command_runs(tmp_path: Path) -> None:
    cmd = readme_block("main-command")
    # the install part is what CI does already; run what follows it with this interpreter's bipedsim,
    # in a fresh folder (it writes its default output folder where it runs)
    run = cmd.split("&&", 1)[1].strip()
    assert run.startswith("bipedsim ")
    proc = subprocess.run([sys.executable, "-m", "bipedsim.cli", *run.split()[1:]], capture_output=True,
                          text=True, cwd=tmp_path, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "bipedsim_run" / "outcome.json").is_file()


def test_readme_test_command_is_what_ci_runs() -> None:
    assert readme_block("test-command") == 'pip install -e ".[test]" && python -m pytest'
    assert "test-command" in (REPO / ".ci" / "run").read_text()
