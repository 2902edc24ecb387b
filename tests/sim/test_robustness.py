"""Misuse cases, each run through the command line as a user would: a clear
one-line error with exit status 2, or the fixed behaviour. The detailed checks of each area live in
``test_robustness_inputs.py`` (BVH, bodies, controller files), ``test_robustness_outputs.py`` (paths,
files, flags, recorder), ``test_robustness_sweep.py`` (sweeps, suites, pushes) and
``test_robustness_course.py`` (heading and course)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from bipedsim.cli import main
from bipedsim.data import BUILTIN_WALK

REPO = Path(__file__).resolve().parents[2]


def one_line_error(capsys: pytest.CaptureFixture[str], *words: str) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("bipedsim ") and ": error: " in lines[0], err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.fixture
def places(tmp_path: Path) -> dict[str, Path]:
    f = tmp_path / "a_file"
    f.write_text("x")
    d = tmp_path / "a_folder"
    d.mkdir()
    return {"file": f, "folder": d, "tmp": tmp_path}


# ---------------------------------------------------------------- 2. unwritable outputs
@pytest.mark.parametrize("argv,words", [
    (["run", "--seconds", "0.1", "--out", "{file}"], ["--out", "is an existing file"]),
    (["run", "--seconds", "0.1", "--out", "{file}/sub"], ["--out", "is a file, not a folder"]),
    (["convert", str(BUILTIN_WALK), "-o", "{folder}"], ["-o", "is a folder"]),
    (["sweep", str(REPO / "experiments" / "smoke.yaml"), "--out", "{file}"], ["--out", "is an existing file"]),
    (["breed", str(BUILTIN_WALK), str(BUILTIN_WALK), "-o", "{file}/c.bvh"], ["-o", "is not a folder"]),
    (["run", "--seconds", "0.1", "--out", "{tmp}/r", "--video", "{file}/v.mp4"], ["--video"]),
])
def test_case2_unwritable_outputs(argv: list[str], words: list[str], places: dict[str, Path],
                                  capsys: pytest.CaptureFixture[str]) -> None:
    argv = [a.format(**places) for a in argv]
    assert main(argv) == 2
    one_line_error(capsys, *words)


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0, reason="root writes into a 0555 folder")
def test_case2_read_only_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["run", "--seconds", "0.1", "--out", str(ro)]) == 2
        one_line_error(capsys, "--out")
    finally:
        ro.chmod(0o755)


# ---------------------------------------------------------------- 3. torn results row
def test_case3_torn_results_row_is_rerun(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    exp = tmp_path / "e.yaml"
    exp.write_text("name: e\nseconds: 1.5\nafter: 0.5\nruns:\n  - {magnitude: 50, direction: 0, duration: 0.1, "
                   "start: 1.0}\n  - {magnitude: 60, direction: 90, duration: 0.1, start: 1.0}\n")
    out = tmp_path / "o"
    assert main(["sweep", str(exp), "--out", str(out)]) == 0
    csv = out / "results.csv"
    text = csv.read_text()
    csv.write_text(text[:-9])  # the last row cut in the middle
    capsys.readouterr()
    assert main(["sweep", str(exp), "--out", str(out)]) == 0
    assert "malformed row" in capsys.readouterr().err
    assert csv.read_text().count("\n") == text.count("\n")
    assert json.loads((out / "summary.json").read_text())["rollouts"] == 2


# ---------------------------------------------------------------- 4. regress --update on a flow mapping
def test_case4_regress_update_writes_flow_mappings(tmp_path: Path) -> None:
    suite = tmp_path / "s.yaml"
    suite.write_text("# kept\nscenarios:\n  - {name: a, seconds: 1, expect: fall}  # flow\n")
    assert main(["regress", str(suite)]) == 1
    assert main(["regress", str(suite), "--update"]) == 0
    text = suite.read_text()
    assert "expect: no_fall" in text and "# kept" in text and "# flow" in text
    assert main(["regress", str(suite)]) == 0


# ---------------------------------------------------------------- 5. meaningless settings
def _chain(n: int) -> str:
    out = ["HIERARCHY", "ROOT j0", "{", "OFFSET 0 0 0",
           "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for i in range(1, n):
        out += [f"JOINT j{i}", "{", "OFFSET 0 0.1 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]
    out += ["End Site", "{", "OFFSET 0 1 0", "}"] + ["}"] * n
    out += ["MOTION", "Frames: 2", "Frame Time: 0.0333333"] + [" ".join(["0"] * (3 + 3 * n))] * 2
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("argv,words", [
    (["run", "--push", "200:0:0.2:50", "--seconds", "3", "--out", "{tmp}/o"], ["--push", "after the run ends"]),
    (["run", "{ctl_dt}", "--seconds", "1", "--out", "{tmp}/o"], ["control_dt", "must be <="]),
    (["info", "{ft}"], ["Frame Time 1e30 s is not plausible"]),
    (["info", str(BUILTIN_WALK), "--scale", "1"], ["the body's height is", "suggests cm"]),
    (["sweep", "{long_exp}", "--out", "{tmp}/s"], ["seconds", "must be <= 3600"]),
    (["sweep", "{big_exp}", "--out", "{tmp}/s"], ["random.count", "at most 100000"]),
    (["run", "--seconds", "inf", "--out", "{tmp}/o"], ["--seconds"]),
    (["run", "--init-noise", "-1", "--seconds", "1", "--out", "{tmp}/o"], ["--init-noise"]),
    (["run", "--support", "--seconds", "1", "--out", "{tmp}/o"], ["--support", "--profile creature"]),
    (["run", "--scale", "cm", "--seconds", "1", "--out", "{tmp}/o"], ["--scale", "--bvh"]),
    (["run", "--bvh", "{chain}", "--profile", "creature", "--seconds", "1", "--out", "{tmp}/o"],
     ["merges into the root"]),
])
def test_case5_meaningless_settings(argv: list[str], words: list[str], tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    files = {"tmp": tmp_path}
    for name, text in {
        "ctl_dt": "control_dt: 4\n",
        "ft": _chain(4).replace("Frame Time: 0.0333333", "Frame Time: 1e30"),
        "long_exp": "name: x\nseconds: 1e12\nruns:\n  - {magnitude: 1, direction: 0, duration: 0.1, start: 1}\n",
        "big_exp": "name: x\nseconds: 5\nrandom: {count: 1000000000000}\n",
        "chain": _chain(500),
    }.items():
        p = tmp_path / (name + (".bvh" if name in ("ft", "chain") else ".yaml"))
        p.write_text(text)
        files[name] = p
    argv = [a.format(**files) for a in argv]
    assert main(argv) == 2
    one_line_error(capsys, *words)
    assert not (tmp_path / "o" / "outcome.json").exists()


def test_case5_thousand_nested_joints(tmp_path: Path) -> None:
    p = tmp_path / "deep.bvh"
    p.write_text(_chain(1000))
    assert main(["info", str(p)]) == 0


# ---------------------------------------------------------------- 6. partial controller files
@pytest.mark.parametrize("text", ["", "pd:\n  gains:\n    hip: {kp: 1000.0, kd: 100.0}\n"])
def test_case6_partial_controller_file_is_the_default(text: str, tmp_path: Path) -> None:
    p = tmp_path / "c.yaml"
    p.write_text(text)
    assert main(["run", str(p), "--seconds", "5", "--out", str(tmp_path / "a")]) == 0
    d = json.loads((tmp_path / "a" / "outcome.json").read_text())
    assert d["outcome"] == "no_fall" and d["config"]["controller"]["fsm"]["tempo"]["gain"] > 0


# ---------------------------------------------------------------- 8. workers capped
def test_case8_workers_capped(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    exp = tmp_path / "e.yaml"
    exp.write_text("name: e\nseconds: 1\nafter: 0.5\nruns:\n  - {magnitude: 50, direction: 0, duration: 0.1, "
                   "start: 0.6}\n")
    assert main(["sweep", str(exp), "--out", str(tmp_path / "o"), "--workers", "64"]) == 0
    assert "not 64" in capsys.readouterr().err


# ---------------------------------------------------------------- 9. files
def test_case9_outputs_respect_the_umask_and_stale_files_go(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    old = os.umask(0o022)
    try:
        out = tmp_path / "r"
        assert main(["run", "--seconds", "0.5", "--out", str(out), "--plots"]) == 0
        assert (out / "outcome.json").stat().st_mode & 0o777 == 0o644
        pngs = sorted(p.name for p in out.glob("*.png"))
        assert pngs
        assert main(["run", "--seconds", "0.5", "--out", str(out)]) == 0
        assert not list(out.glob("*.png")) and "removed from an earlier run" in capsys.readouterr().out
    finally:
        os.umask(old)
