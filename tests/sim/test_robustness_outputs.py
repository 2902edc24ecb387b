"""Outputs: every output path that cannot be written is a one-line error before the work starts
(nothing written), flags that mean nothing are refused, files respect the umask, a reused run folder
holds no stale outputs of bipedsim's, long jobs show progress on a terminal, and the recorder stays
compact."""

from __future__ import annotations

import errno
import json
import os
import pty
import re
import stat
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO

from bipedsim.cli import main
from bipedsim.data import builtin_walk_path
from bipedsim.errors import OutputError
from bipedsim.files import (
    FALLBACK_SIZE,
    MANIFEST_FILE,
    OutputFolder,
    atomic_write_bytes,
    check_output_file,
    prepare_output_dir,
    process_umask,
    stderr_size,
)
from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.render.plots import PLOT_FILES
from bipedsim.render.video import describe_exception, write_video
from bipedsim.sim.recorder import CHUNK_SAMPLES, SAMPLE_DTYPES, Recorder, Trajectory, write_npz_compressed

WALK = str(builtin_walk_path())
GRAPH_YAML = REPO / "examples" / "graphs" / "walk_wave.yaml"
SMALL_VIDEO = ["--width", "64", "--height", "48", "--fps", "10"]


def gl_or_skip() -> str:
    try:
        return choose_backend()
    except RenderError as exc:
        pytest.skip(f"no headless GL here: {exc}")


def one_error_line(capsys, command: str) -> str:
    """The single stderr line of a failed command (and that it is the project's error format)."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"bipedsim {command}: error: "), err
    return err[0]


@pytest.fixture
def afile(tmp_path: Path) -> Path:
    p = tmp_path / "afile"
    p.write_text("not a folder\n")
    return p


# ---------------------------------------------------------------------- 1. unwritable outputs
def output_cases(tmp: Path, afile: Path) -> list[tuple[list[str], list[str]]]:
    run = ["run", "--seconds", "0.5", "--out", str(tmp / "r")]
    return [
        (["run", "--seconds", "0.5", "--out", str(afile)], ["--out", str(afile), "is an existing file; give a folder"]),
        (["run", "--seconds", "0.5", "--out", str(afile / "sub")],
         ["--out", "cannot create folder", f"{afile} is a file, not a folder"]),
        ([*run, "--csv", str(afile / "j.csv")], ["--csv", f"{afile} exists and is not a folder"]),
        ([*run, "--export-bvh", str(tmp)], ["--export-bvh", "is a folder; give a file name"]),
        ([*run, "--video", str(afile / "v.mp4")], ["--video", f"{afile} exists and is not a folder"]),
        ([*run, "--video", str(tmp / "v.avi")], ["--video", "must end in .mp4 or .gif"]),
        ([*run, "--gif", str(tmp / "v.mp4")], ["--gif", "must end in .gif"]),
        (["convert", WALK, "-o", str(tmp)], ["-o", "is a folder; give a file name"]),
        (["convert", WALK, "-o", str(tmp / "m.xml"), "--clip", str(afile / "c.npz")], ["--clip", "not a folder"]),
        (["convert", WALK, "-o", "/dev/null"], ["-o /dev/null", "not a regular file"]),
        (["sweep", str(REPO / "experiments" / "push_200n.yaml"), "--out", str(afile)],
         ["--out", "is an existing file; give a folder"]),
        (["breed", WALK, WALK, "-o", str(afile / "c.bvh")], ["-o", "not a folder"]),
        (["breed", WALK, WALK, "-o", str(tmp / "c.bvh"), "--report", str(tmp)], ["--report", "is a folder"]),
        (["graph", "build", str(GRAPH_YAML), "-o", str(afile / "g.npz")], ["-o", "not a folder"]),
    ]


@pytest.mark.parametrize("case", range(14))
def test_unwritable_outputs_fail_before_the_work(case: int, tmp_path: Path, afile: Path, capsys) -> None:
    argv, words = output_cases(tmp_path, afile)[case]
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(argv) == 2
    line = one_error_line(capsys, argv[0])
    assert all(w in line for w in words), line
    # nothing written: not the run folder's files, not the converted model, not a temporary file
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "r") == before
    assert not (tmp_path / "r" / "outcome.json").exists()
    assert afile.read_text() == "not a folder\n"


@pytest.mark.parametrize("argv, flag, allowed", [
    (["breed", WALK, WALK, "-o", "{tmp}/c.txt"], "-o", ".bvh"),
    (["graph", "build", str(GRAPH_YAML), "-o", "{tmp}/g.txt"], "-o", ".npz"),
    (["world", str(REPO / "examples" / "worlds" / "ridge.yaml"), str(REPO / "examples" / "worlds" / "horse.yaml"),
      "-o", "{tmp}/w.bvh", "--plot", "{tmp}/p.jpg"], "--plot", ".png"),
])
def test_an_output_of_the_wrong_kind_is_refused_naming_the_flag_and_suffix(
        argv: list[str], flag: str, allowed: str, tmp_path: Path, capsys) -> None:
    """breed -o c.txt wrote a BVH into .txt, graph build -o g.txt an npz zip, world --plot p.jpg PNG data."""
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    line = one_error_line(capsys, argv[0])
    assert line.endswith(f"{flag} {argv[argv.index(flag) + 1]}: must end in {allowed}"), line
    assert list(tmp_path.iterdir()) == []


def test_graph_play_checks_its_outputs(tmp_path: Path, afile: Path, capsys) -> None:
    """``graph play`` refuses a folder, a wrong suffix and an unwritable report before it plays. The
    graph: the built-in walk alone, with the example's upper-body layer (the script names that layer)."""
    config = tmp_path / "tiny.yaml"
    config.write_text(f"name: tiny\nfps: 30\nk: 10\nclips:\n  - {{name: walk, file: {WALK}, tags: [WALK]}}\n"
                      "parts:\n  Upper-Body: {root: Spine1}\n")
    g = tmp_path / "g.npz"
    assert main(["graph", "build", str(config), "-o", str(g)]) == 0
    capsys.readouterr()
    script = REPO / "examples" / "graphs" / "walk_and_wave.txt"
    assert main(["graph", "play", str(g), str(script), "-o", str(tmp_path)]) == 2
    assert "is a folder; give a file name" in one_error_line(capsys, "graph")
    assert main(["graph", "play", str(g), str(script), "-o", str(tmp_path / "o.txt")]) == 2
    assert one_error_line(capsys, "graph").endswith(f"-o {tmp_path / 'o.txt'}: must end in .bvh")
    out = tmp_path / "ok.bvh"
    assert main(["graph", "play", str(g), str(script), "-o", str(out), "--report", str(afile / "r.json")]) == 2
    assert "--report" in one_error_line(capsys, "graph")
    assert not out.exists()


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only (chmod 555) folders")
def test_folder_without_permission(tmp_path: Path, capsys) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["run", "--seconds", "0.5", "--out", str(ro / "x")]) == 2
        assert "Permission denied" in one_error_line(capsys, "run")
        assert main(["run", "--seconds", "0.5", "--out", str(ro)]) == 2
        line = one_error_line(capsys, "run")
        assert f"cannot write in {ro}" in line and "Permission denied" in line
    finally:
        ro.chmod(0o755)


def test_output_helpers(tmp_path: Path, afile: Path) -> None:
    d = prepare_output_dir(tmp_path / "a" / "b", "--out")
    assert d.is_dir()
    f = check_output_file(tmp_path / "new" / "deep" / "v.gif", "-o", (".mp4", ".gif"))
    assert f.parent.is_dir() and not f.exists()
    assert not [p for p in f.parent.iterdir()]  # the write probe leaves nothing behind
    with pytest.raises(OutputError, match=r"^--out .*afile: is an existing file; give a folder$"):
        prepare_output_dir(afile, "--out")
    with pytest.raises(OutputError, match=r"^-o .*v\.MOV: must end in \.mp4 or \.gif$"):
        check_output_file(tmp_path / "v.MOV", "-o", (".mp4", ".gif"))


def test_a_failed_write_names_the_file_and_keeps_the_old_one(tmp_path: Path, monkeypatch) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")

    def full(fd: int) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr("bipedsim.files.writing.os.fsync", full)
    with pytest.raises(OutputError, match=rf"^cannot write {target}: No space left on device$"):
        atomic_write_bytes(target, b"new")
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_an_os_error_while_writing_is_one_line(tmp_path: Path, monkeypatch, capsys) -> None:
    def full(out, folder):  # noqa: ANN001, ANN202
        raise OSError(errno.ENOSPC, "No space left on device", str(Path(folder) / "outcome.json"))

    monkeypatch.setattr("bipedsim.sim.runner.write_outcome", full)
    assert main(["run", "--seconds", "0.3", "--out", str(tmp_path)]) == 2
    line = one_error_line(capsys, "run")
    assert line.endswith(f"cannot write {tmp_path / 'outcome.json'}: No space left on device")


# ---------------------------------------------------------------------- 2./3. rendering errors and folders
def test_render_errors_name_the_file_and_the_cause(tmp_path: Path, capsys) -> None:
    msg = describe_exception(OSError("[Errno 32] Broken pipe\n\nFFMPEG COMMAND:\nffmpeg -y -i - out.mp4\n\n"
                                     "FFMPEG STDERR OUTPUT:\n"))
    assert msg == "OSError: [Errno 32] Broken pipe"
    assert describe_exception(PermissionError(errno.EACCES, "Permission denied", "ro/v.mp4")) == \
        "Permission denied (ro/v.mp4)"
    # a folder that cannot take the video: the error names it; no temporary file is left
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(NotADirectoryError):
        write_video(iter([np.zeros((48, 64, 3), np.uint8)]), afile / "v.mp4", 10.0)
    assert [p.name for p in tmp_path.iterdir()] == ["afile"]
    # the same from the command line, when the child renderer fails
    gl_or_skip()
    run = tmp_path / "run"
    assert main(["run", "--seconds", "0.3", "--out", str(run)]) == 0
    (run / "trajectory.npz").write_text("junk")
    capsys.readouterr()
    assert main(["render", str(run), "-o", str(run / "v.mp4"), *SMALL_VIDEO]) == 2
    line = one_error_line(capsys, "render")
    assert f"cannot render {run / 'v.mp4'}" in line and "trajectory.npz: not a bipedsim trajectory" in line
    assert "not an .npz archive" in line and "(GL backend " in line
    assert not (run / "v.mp4").exists() and not list(run.glob(".v.*"))


@pytest.mark.slow  # two CLI processes; the render side: test_render.test_no_gl_fails_clearly_and_keeps_results
def test_no_gl_after_a_run_says_where_the_results_are(tmp_path: Path) -> None:
    env = dict(os.environ, MUJOCO_GL="bogus")
    p = subprocess.run([sys.executable, "-m", "bipedsim.cli", "run", "--seconds", "0.3", "--out", str(tmp_path),
                        "--video", str(tmp_path / "v.mp4")], env=env, capture_output=True, text=True, check=False)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert f"results were written to {tmp_path}; render them later with `bipedsim render {tmp_path}`" in p.stderr
    p = subprocess.run([sys.executable, "-m", "bipedsim.cli", "render", str(tmp_path)], env=env, capture_output=True,
                       text=True, check=False)
    assert p.returncode == 2 and "no working OpenGL backend" in p.stderr and "results were written" not in p.stderr


@pytest.mark.slow  # a run and a render (output folders made for any command: test_outputs' own checks)
def test_render_creates_missing_folders(tmp_path: Path) -> None:
    gl_or_skip()
    assert main(["run", "--seconds", "0.3", "--out", str(tmp_path)]) == 0
    out = tmp_path / "new" / "nested" / "v.gif"
    assert main(["render", str(tmp_path), "-o", str(out), *SMALL_VIDEO]) == 0
    assert out.read_bytes()[:3] == b"GIF"


# ---------------------------------------------------------------------- 4. meaningless flags
FLAG_CASES = [
    (["run", "--seconds", "inf"], ["--seconds", "(0, 3600]", "inf"]),
    (["run", "--seconds", "nan"], ["--seconds", "nan"]),
    (["run", "--seconds", "3601"], ["--seconds", "3600"]),
    (["run", "--seconds", "1e-9"], ["--seconds", "at least one physics step (0.002 s)"]),
    (["run", "--init-noise", "-1"], ["--init-noise", ">= 0", "-1"]),
    (["run", "--init-noise", "nan"], ["--init-noise"]),
    (["run", "--seed", "-1"], ["--seed", ">= 0"]),
    (["run", "--support"], ["--support", "needs --profile creature"]),
    (["run", "--scale", "cm"], ["--scale", "--bvh", "built-in walk"]),
    (["run", "--up", "z"], ["--up", "--bvh", "built-in walk"]),
    (["run", "--record-hz", "0"], ["--record-hz", "[1, 500]", "got 0.0"]),
    (["run", "--record-hz", "-5"], ["--record-hz"]),
    (["run", "--record-hz", "1e9"], ["--record-hz", "physics step"]),
    (["run", "--width", "0"], ["--width", "16..4096 pixels"]),
    (["run", "--height", "-480"], ["--height", "16..4096"]),
    (["run", "--fps", "0"], ["--fps", "frames/s"]),
    (["run", "--speed", "-1"], ["--speed"]),
    (["run", "--speed", "nan"], ["--speed"]),
    (["render", "RUN", "--fps", "inf"], ["--fps"]),
    (["render", "RUN", "--cam-distance", "0"], ["--cam-distance"]),
    (["run", "--profile", "creature", "--bvh", WALK, "--push", "100:0:0.1:s2.5", "--seconds", "3"],
     ["push.state", "no gait states"]),
]


@pytest.mark.parametrize("argv, words", FLAG_CASES, ids=[" ".join(c[0][1:]) for c in FLAG_CASES])
def test_meaningless_flags_are_refused(argv: list[str], words: list[str], tmp_path: Path, capsys) -> None:
    argv = [str(tmp_path) if a == "RUN" else a for a in argv]
    out = [] if argv[0] == "render" else ["--out", str(tmp_path / "r")]
    assert main([*argv, *out]) == 2
    line = one_error_line(capsys, argv[0])
    assert all(w in line for w in words), line
    assert not (tmp_path / "r").exists()  # refused before the output folder was made


# ---------------------------------------------------------------------- 5. umask
@pytest.mark.parametrize("mask", [0o022, 0o027, 0o077])
def test_files_respect_the_umask(mask: int, tmp_path: Path) -> None:
    old = os.umask(mask)
    process_umask.cache_clear()
    try:
        atomic_write_bytes(tmp_path / "f.bin", b"x")
        atomic_write_bytes(tmp_path / "f.bin", b"y")  # rewritten: still the umask's mode
    finally:
        os.umask(old)
        process_umask.cache_clear()
    assert stat.S_IMODE((tmp_path / "f.bin").stat().st_mode) == 0o666 & ~mask
    assert (tmp_path / "f.bin").read_bytes() == b"y"


def test_run_outputs_are_readable_by_others_under_umask_022(tmp_path: Path) -> None:
    p = subprocess.run(["sh", "-c", f'umask 022 && exec "{sys.executable}" -m bipedsim.cli run --seconds 0.3 '
                        f'--out "{tmp_path}" --csv "{tmp_path}/j.csv"'], capture_output=True, text=True, check=False)
    assert p.returncode == 0, p.stderr
    for name in ("outcome.json", "trajectory.npz", "model.xml", "j.csv"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o644, name


# ---------------------------------------------------------------------- 6. stale outputs
def test_a_reused_run_folder_keeps_no_stale_outputs(tmp_path: Path, capsys) -> None:
    """What an earlier run wrote and this one does not rewrite is removed (the manifest proves it is
    bipedsim's); the user's files, of any name, stay."""
    for name in ("notes.txt", "my_plot.png", "rollout.mp4"):
        (tmp_path / name).write_text("from before")
    assert main(["run", "--seconds", "0.3", "--out", str(tmp_path), "--plots"]) == 0
    out = capsys.readouterr().out
    assert "removed" not in out and f"left alone in {tmp_path}: rollout.mp4 (" in out
    assert main(["run", "--seconds", "0.3", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert f"removed from an earlier run in {tmp_path}: {', '.join(PLOT_FILES)}\n" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        MANIFEST_FILE, "model.xml", "my_plot.png", "notes.txt", "outcome.json", "rollout.mp4", "trajectory.npz"]
    assert (tmp_path / "rollout.mp4").read_text() == "from before"
    # what this run writes again is not reported
    assert main(["run", "--seconds", "0.3", "--out", str(tmp_path), "--plots"]) == 0
    assert main(["run", "--seconds", "0.3", "--out", str(tmp_path), "--plots"]) == 0
    assert "removed" not in capsys.readouterr().out
    assert (tmp_path / "joint_angles.png").read_bytes()[:4] == b"\x89PNG"


def test_a_creature_run_writes_the_run_files_and_takes_every_output_flag(tmp_path: Path, capsys) -> None:
    """One loop for every body: a creature run records a trajectory and takes pushes, plots and CSV
    (they were refused, or silently ignored, before)."""
    horse = Path(WALK).parent / "horse_walk.bvh"
    csv_path = tmp_path / "j.csv"
    assert main(["run", "--profile", "creature", "--bvh", str(horse), "--seconds", "1.5", "--out", str(tmp_path / "r"),
                 "--push", "100:90:0.2:0.5", "--plots", "--csv", str(csv_path)]) == 0
    names = sorted(p.name for p in (tmp_path / "r").iterdir())
    assert names == sorted([MANIFEST_FILE, "model.xml", "outcome.json", "trajectory.npz", *PLOT_FILES])
    header = csv_path.read_text().splitlines()[0].split(",")
    assert header[0] == "time_s" and len(header) > 10 and header[-1].endswith("_ref")
    out = json.loads((tmp_path / "r" / "outcome.json").read_text())
    assert out["config"]["profile"] == "creature" and out["extra"]["push_start_s"] == pytest.approx(0.5, abs=0.01)


def test_remove_stale_touches_only_known_names_the_manifest_proves(tmp_path: Path) -> None:
    for name in ("a.png", "c.txt", "d.png"):
        (tmp_path / name).write_text("x")
    (tmp_path / "b.png").mkdir()  # a folder by a known name is not a stale file
    folder = OutputFolder(tmp_path)
    folder.record(tmp_path / "a.png", tmp_path / "c.txt", tmp_path / "b.png")  # a folder is not recorded
    assert set(folder.files) == {"a.png", "c.txt"}
    assert folder.remove_stale(["a.png", "b.png", "d.png", "z.png"], keep=[]) == (["a.png"], ["b.png", "d.png"])
    assert sorted(p.name for p in tmp_path.iterdir()) == [MANIFEST_FILE, "b.png", "c.txt", "d.png"]
    assert set(OutputFolder(tmp_path).files) == {"c.txt"}  # the removed file left the manifest


# ---------------------------------------------------------------------- 7. progress on a terminal
def run_on_pty(argv: list[str], cwd: Path) -> tuple[int, str]:
    """Run bipedsim with stderr on a pseudo-terminal (0 columns, as some consoles report); returns
    the exit status and what the terminal showed."""
    master, slave = pty.openpty()
    p = subprocess.Popen([sys.executable, "-m", "bipedsim.cli", *argv], stdout=subprocess.PIPE, stderr=slave,
                         cwd=cwd)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    p.stdout.read()
    return p.wait(), b"".join(chunks).decode(errors="replace")


@pytest.mark.slow  # three processes (a 5 s run, two renders); the sweep's bar on a terminal is checked in
# the default run (test_robustness_sweep.py)
def test_progress_bars_on_a_terminal_only(tmp_path: Path) -> None:
    rc, shown = run_on_pty(["run", "--seconds", "5", "--out", str(tmp_path)], tmp_path)
    assert rc == 0 and "bipedsim run" in shown and "sim s" in shown
    gl_or_skip()
    rc, shown = run_on_pty(["render", str(tmp_path), "-o", str(tmp_path / "v.gif"), *SMALL_VIDEO], tmp_path)
    assert rc == 0 and "render" in shown and "frame" in shown and re.search(r" \d+/\d+ \[", shown), shown
    # not a terminal: nothing on stderr
    p = subprocess.run([sys.executable, "-m", "bipedsim.cli", "render", str(tmp_path), "-o",
                        str(tmp_path / "v2.gif"), *SMALL_VIDEO], capture_output=True, text=True, check=False)
    assert p.returncode == 0 and p.stderr == "" and "wrote" in p.stdout


def test_terminal_width_falls_back_when_unknown(monkeypatch) -> None:
    """A terminal that reports 0 x 0 gets a bar of the fallback size (tqdm would draw nothing)."""
    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.delenv("LINES", raising=False)
    monkeypatch.setattr(os, "get_terminal_size", lambda fd=None: os.terminal_size((0, 0)))
    assert stderr_size() == FALLBACK_SIZE


# ---------------------------------------------------------------------- 8. compact recording
class FakeCtrl:
    """What the recorder reads from a controller: the interface's read-outs only."""

    def __init__(self, nq: int, nu: int = 0) -> None:
        self.frame = 0.0
        self.nq, self.nu = nq, nu

    def reference_qpos(self) -> np.ndarray:
        return np.full(self.nq, self.frame)

    def actuator_torques(self) -> np.ndarray:
        return np.zeros(self.nu)

    def foot_forces(self, data) -> list[float]:  # noqa: ANN001
        return [float(data.sensordata[0])] * 2

    def gait_state(self) -> int:
        return 3


TINY_XML = ('<mujoco><option timestep="0.002"/><worldbody><body><freejoint/><geom size=".1"/><site name="s"/>'
            '</body></worldbody><sensor><touch site="s"/></sensor></mujoco>')


@pytest.mark.parametrize("seconds", [None, 3.0])
def test_recorder_buffers_are_compact_and_in_order(seconds: float | None) -> None:
    import mujoco

    model = mujoco.MjModel.from_xml_string(TINY_XML)
    data = mujoco.MjData(model)
    ctrl = FakeCtrl(model.nq)
    rec = Recorder(model, record_hz=500.0, seconds=seconds)
    n = CHUNK_SAMPLES + 7 if seconds is None else 1501  # past one block when the length is unknown
    for i in range(n):
        data.qpos[0] = i * 0.001
        ctrl.frame = float(i)
        rec(i * 0.002, data, ctrl)
    tr = rec.trajectory({"x": 1})
    assert tr.num_samples == n and tr.meta["record_hz"] == 500.0
    assert np.array_equal(tr.time, np.arange(n) * 0.002) and np.array_equal(tr.ref_frame, np.arange(n))
    assert np.array_equal(tr.qpos[:, 0], np.arange(n) * 0.001)
    assert {k: v.dtype for k, v in tr.arrays().items()} == {k: np.dtype(t) for k, t in SAMPLE_DTYPES.items()}


def test_trajectory_file_is_compressed_and_reads_back(tmp_path: Path) -> None:
    assert main(["run", "--seconds", "1", "--out", str(tmp_path)]) == 0
    tr = Trajectory.load(tmp_path / "trajectory.npz")
    per_sample = sum(v.nbytes for v in tr.arrays().values()) / tr.num_samples
    assert per_sample < 900  # built-in humanoid: 869 bytes a sample (was 1428 as float64 arrays)
    with zipfile.ZipFile(tmp_path / "trajectory.npz") as z:
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in z.infolist())
    tr.save(tmp_path / "again.npz")
    back = Trajectory.load(tmp_path / "again.npz")
    for k, v in tr.arrays().items():
        assert np.array_equal(getattr(back, k), v) and getattr(back, k).dtype == v.dtype, k
    assert json.loads((tmp_path / "outcome.json").read_text())["sim_seconds"] == pytest.approx(1.0)


def test_npz_writer_matches_numpy(tmp_path: Path) -> None:
    arrays = {"a": np.arange(12.0).reshape(3, 4)[:, ::2], "e": np.zeros((0, 3), np.float32),
              "s": np.array("text"), "i": np.int8([1, 2, 3])}
    with open(tmp_path / "x.npz", "wb") as f:
        write_npz_compressed(f, arrays)
    with np.load(tmp_path / "x.npz") as z:
        for k, v in arrays.items():
            assert z[k].shape == v.shape and z[k].dtype == v.dtype and np.array_equal(z[k], v), k
