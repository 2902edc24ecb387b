"""Outputs never cost the user a file: a command deletes or replaces, unasked, only what the folder's
manifest proves bipedsim wrote there (unchanged); outputs that would overwrite each other or an input
are refused before any work with one line (exit 2, nothing written); and no temporary file outlives
SIGINT, SIGTERM or SIGHUP."""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO

from bipedsim import cli
from bipedsim.cli import main
from bipedsim.data import builtin_walk_path
from bipedsim.errors import ModelError, OutputError
from bipedsim.files import MANIFEST_FILE, OutputFolder, atomic_writer, check_distinct_paths
from bipedsim.model.build import load_model
from bipedsim.render import video
from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.render.plots import PLOT_FILES
from bipedsim.render.video import write_video

WALK = str(builtin_walk_path())
HORSE = str(Path(WALK).parent / "horse_walk.bvh")
#: The names a run folder's plots and default video have: a user may have files of the same names.
RUN_NAMES = (*PLOT_FILES, "rollout.mp4")
RUN = ["run", "--seconds", "1"]


def one_error_line(capsys, command: str) -> str:
    """The single stderr line of a failed command, in the project's error format."""
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"bipedsim {command}: error: "), err
    return err[0]


def snapshot(folder: Path) -> dict[str, bytes | str]:
    """Every entry under ``folder``: a file's bytes, a link's target, a folder's mark."""
    out: dict[str, bytes | str] = {}
    for p in sorted(folder.rglob("*")):
        key = str(p.relative_to(folder))
        out[key] = f"-> {os.readlink(p)}" if p.is_symlink() else ("<dir>" if p.is_dir() else p.read_bytes())
    return out


def users_files(folder: Path, names: tuple[str, ...] = RUN_NAMES) -> dict[str, bytes]:
    folder.mkdir(parents=True, exist_ok=True)
    for n in names:
        (folder / n).write_bytes(f"the user's own {n}\n".encode())
    return {n: (folder / n).read_bytes() for n in names}


# ---------------------------------------------------------------------- 1. deletions proven by the manifest
def test_a_users_files_in_a_folder_bipedsim_never_wrote_survive_a_run(tmp_path: Path, capsys) -> None:
    d = tmp_path / "mine"
    before = users_files(d)
    assert main([*RUN, "--out", str(d)]) == 0
    out = capsys.readouterr().out
    assert "removed" not in out
    assert f"left alone in {d}: {', '.join(RUN_NAMES)} (not written there by bipedsim, or changed since)" in out
    assert {n: (d / n).read_bytes() for n in RUN_NAMES} == before
    assert (d / "outcome.json").is_file()


def test_with_plots_a_users_plot_names_refuse_the_run_before_it_starts(tmp_path: Path, capsys) -> None:
    """--plots would replace the user's contacts.png (and the rest): refused, nothing written."""
    d = tmp_path / "mine"
    users_files(d)
    before = snapshot(tmp_path)
    assert main([*RUN, "--out", str(d), "--plots"]) == 2
    line = one_error_line(capsys, "run")
    assert f"--out {d}: would replace {', '.join(PLOT_FILES)}, which bipedsim cannot prove it wrote" in line
    assert snapshot(tmp_path) == before  # no outcome.json, no manifest, the user's files as they were


def test_a_file_the_manifest_lists_but_the_user_changed_survives(tmp_path: Path, capsys) -> None:
    d = tmp_path / "run"
    assert main([*RUN, "--out", str(d), "--plots"]) == 0
    # edited (appended to), and replaced by other bytes of the same size: both are the user's now
    with open(d / "contacts.png", "ab") as f:
        f.write(b"annotated")
    size = (d / "tracking_error.png").stat().st_size
    (d / "tracking_error.png").write_bytes(b"u" * size)
    edited = {n: (d / n).read_bytes() for n in ("contacts.png", "tracking_error.png")}
    capsys.readouterr()
    assert main([*RUN, "--out", str(d)]) == 0
    out = capsys.readouterr().out
    # the unchanged plots are an earlier run's and go; the changed ones stay
    assert f"removed from an earlier run in {d}: joint_angles.png, com_top_view.png\n" in out
    assert f"left alone in {d}: tracking_error.png, contacts.png (" in out
    assert not (d / "joint_angles.png").exists() and not (d / "com_top_view.png").exists()
    assert {n: (d / n).read_bytes() for n in edited} == edited
    # and a run that would replace them is refused
    assert main([*RUN, "--out", str(d), "--plots"]) == 2
    assert "would replace tracking_error.png, contacts.png" in one_error_line(capsys, "run")
    assert {n: (d / n).read_bytes() for n in edited} == edited


def test_the_manifest_holds_what_the_run_wrote_into_its_folder(tmp_path: Path) -> None:
    d = tmp_path / "run"
    assert main([*RUN, "--out", str(d), "--plots", "--csv", str(d / "j.csv"), "--export-bvh",
                 str(tmp_path / "sim.bvh")]) == 0
    data = json.loads((d / MANIFEST_FILE).read_text())
    assert data["format"] == "bipedsim output manifest" and data["version"] == 1
    files = data["files"]
    assert set(files) == {"outcome.json", "trajectory.npz", "model.xml", "j.csv", *PLOT_FILES}  # not sim.bvh
    for name, entry in files.items():
        raw = (d / name).read_bytes()
        assert entry == {"sha256": hashlib.sha256(raw).hexdigest(), "size": len(raw)}, name


def test_a_crafted_manifest_proves_nothing_it_should_not(tmp_path: Path, capsys) -> None:
    """Entries naming paths outside the folder are dropped; a link is never a file bipedsim wrote, even
    when the manifest lists the bytes it points to."""
    d = tmp_path / "run"
    d.mkdir()
    victim = tmp_path / "victim.png"
    victim.write_bytes(b"precious")
    (d / "contacts.png").symlink_to(victim)
    entry = {"sha256": hashlib.sha256(b"precious").hexdigest(), "size": 8}
    (d / MANIFEST_FILE).write_text(json.dumps({"format": "bipedsim output manifest", "version": 1, "files": {
        "contacts.png": entry, "../victim.png": entry, "/etc/passwd": entry}}))
    assert set(OutputFolder(d).files) == {"contacts.png"}
    assert not OutputFolder(d).proves("contacts.png")
    assert main([*RUN, "--out", str(d)]) == 0
    assert "left alone in" in capsys.readouterr().out
    assert (d / "contacts.png").is_symlink() and victim.read_bytes() == b"precious"


@pytest.mark.parametrize("text, why", [
    ("my notes about this run\n", "is not a bipedsim manifest (not JSON)"),
    ('{"files": {}}', "is not a bipedsim manifest"),
    ('{"format": "bipedsim output manifest", "version": 99, "files": {}}', "is of a newer bipedsim"),
])
def test_a_file_by_the_manifests_name_that_is_not_ours_is_refused(text: str, why: str, tmp_path: Path,
                                                                   capsys) -> None:
    d = tmp_path / "run"
    d.mkdir()
    (d / MANIFEST_FILE).write_text(text)
    assert main([*RUN, "--out", str(d)]) == 2
    line = one_error_line(capsys, "run")
    assert f"--out {d}: {MANIFEST_FILE} {why}" in line and "move it away or choose another --out" in line
    assert (d / MANIFEST_FILE).read_text() == text and not (d / "outcome.json").exists()


def test_render_does_not_replace_a_users_video_or_plots(tmp_path: Path, capsys) -> None:
    """The checks come before rendering: no GL is needed to see them."""
    d = tmp_path / "run"
    assert main([*RUN, "--out", str(d)]) == 0
    mine = users_files(d, ("rollout.mp4", "contacts.png"))
    capsys.readouterr()
    assert main(["render", str(d)]) == 2
    line = one_error_line(capsys, "render")
    assert f"RUN_DIR {d}: would replace rollout.mp4, which bipedsim cannot prove it wrote" in line
    assert line.endswith("(or give -o)")
    assert main(["render", str(d), "-o", str(tmp_path / "v.gif"), "--plots"]) == 2
    assert "would replace contacts.png," in one_error_line(capsys, "render")
    assert {n: (d / n).read_bytes() for n in mine} == mine and not (tmp_path / "v.gif").exists()


def test_a_path_named_on_the_command_line_is_the_users_request(tmp_path: Path) -> None:
    """An explicit output path replaces what is there, as any Unix tool's -o does (and, inside the run
    folder, joins the manifest)."""
    d = tmp_path / "run"
    users_files(d, ("notes.csv",))
    assert main([*RUN, "--out", str(d), "--csv", str(d / "notes.csv")]) == 0
    assert (d / "notes.csv").read_text().startswith("time_s,")
    assert OutputFolder(d).proves("notes.csv")


# ---------------------------------------------------------------------- 2. outputs that collide
def collision_cases(tmp: Path) -> list[tuple[list[str], list[str], str]]:
    """(argv, words of the error line, the file that must stay as it was)."""
    w, out = tmp / "w.bvh", tmp / "out"
    return [
        (["convert", WALK, "-o", f"{tmp}/m.xml", "--clip", f"{tmp}/m.xml"],
         [f"-o {tmp}/m.xml and --clip {tmp}/m.xml are the same file"], ""),
        ([*RUN, "--out", str(out), "--csv", f"{out}/outcome.json"],
         [f"the --out file {out}/outcome.json and --csv {out}/outcome.json are the same file"], ""),
        ([*RUN, "--out", str(out), "--csv", f"{tmp}/a.csv", "--export-bvh", f"{tmp}/a.csv"],
         [f"--csv {tmp}/a.csv and --export-bvh {tmp}/a.csv are the same file"], ""),
        ([*RUN, "--out", str(out), "--plots", "--csv", f"{out}/contacts.png"], ["contacts.png", "--csv"], ""),
        (["convert", str(w), "-o", str(w)], [f"-o {w} would overwrite the input BVH {w}"], "w.bvh"),
        ([*RUN, "--out", str(out), "--bvh", str(w), "--export-bvh", f"{tmp}/link.bvh"],
         [f"--export-bvh {tmp}/link.bvh would overwrite --bvh {w}"], "w.bvh"),
        (["breed", str(w), HORSE, "-o", f"{tmp}/c.bvh", "--report", str(w)], ["--report", "PARENT_A"], "w.bvh"),
        (["graph", "build", f"{tmp}/g.yaml", "-o", f"{tmp}/g.npz", "--report", f"{tmp}/g.yaml"],
         ["--report", "the graph YAML"], "g.yaml"),
        (["world", str(REPO / "examples" / "worlds" / "ridge.yaml"), f"{tmp}/horse.yaml", "-o", f"{tmp}/h.bvh"],
         [f"-o {tmp}/h.bvh would overwrite {tmp}/horse.yaml's clip"], "h.bvh"),
        (["sweep", f"{tmp}/out/summary.json", "--out", str(out)],
         [f"the --out file {out}/summary.json would overwrite the experiment file"], "out/summary.json"),
    ]


@pytest.mark.parametrize("case", range(10))
def test_outputs_that_collide_are_one_line_before_any_work(case: int, tmp_path: Path, capsys) -> None:
    (tmp_path / "w.bvh").write_bytes(Path(WALK).read_bytes())
    (tmp_path / "link.bvh").symlink_to(tmp_path / "w.bvh")  # the same file by another name
    (tmp_path / "g.yaml").write_text("clips: []\n")
    (tmp_path / "h.bvh").write_bytes(Path(HORSE).read_bytes())
    (tmp_path / "horse.yaml").write_text("name: horse\nclips:\n  walk: h.bvh\n")
    argv, words, kept = collision_cases(tmp_path)[case]
    if argv[0] == "sweep":
        (tmp_path / "out").mkdir()
        (tmp_path / "out" / "summary.json").write_text((REPO / "experiments" / "push_200n.yaml").read_text())
    before = snapshot(tmp_path)
    assert main(argv) == 2
    line = one_error_line(capsys, argv[0])
    assert all(w in line for w in words), line
    assert snapshot(tmp_path) == before  # nothing written, no folder made, the inputs as they were
    assert not kept or (tmp_path / kept).is_file()


def test_distinct_paths_helper(tmp_path: Path) -> None:
    (tmp_path / "a").write_text("x")
    os.link(tmp_path / "a", tmp_path / "hard")
    check_distinct_paths([("-o", tmp_path / "a"), ("--report", None), ("--x", tmp_path / "b")],
                         [("IN", tmp_path / "c"), ("--map", None)])
    with pytest.raises(OutputError, match=r"^--x .*/hard would overwrite IN .*/a, an input of this command"):
        check_distinct_paths([("--x", tmp_path / "hard")], [("IN", tmp_path / "a")])
    with pytest.raises(OutputError, match=r"^-o .*/sub/\.\./a and --y .*/a are the same file"):
        check_distinct_paths([("-o", tmp_path / "sub" / ".." / "a"), ("--y", tmp_path / "a")])
    assert not (tmp_path / "sub").exists()


# ---------------------------------------------------------------------- 3. temporary files and signals
def test_an_interrupted_atomic_write_leaves_no_temporary_file(tmp_path: Path) -> None:
    (tmp_path / "f.json").write_text("old")
    with pytest.raises(KeyboardInterrupt), atomic_writer(tmp_path / "f.json") as f:
        f.write(b"half")
        raise KeyboardInterrupt
    assert [p.name for p in tmp_path.iterdir()] == ["f.json"] and (tmp_path / "f.json").read_text() == "old"


def test_an_interrupted_video_write_leaves_no_temporary_file(tmp_path: Path) -> None:
    def frames():  # noqa: ANN202
        yield np.zeros((48, 64, 3), np.uint8)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_video(frames(), tmp_path / "v.mp4", 10.0)
    assert list(tmp_path.iterdir()) == []


def test_the_command_line_stops_on_sigterm_and_sighup_but_keeps_an_ignored_one(monkeypatch) -> None:
    """SIGTERM and SIGHUP unwind as Ctrl-C does while a command runs (and are given back after); a
    hang-up ignored from the start (``nohup``) stays ignored."""
    seen = {}

    def probe(args) -> int:  # noqa: ANN001
        seen.update({s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP)})
        return 0

    monkeypatch.setattr(cli, "cmd_info", probe)
    old = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP)}
    try:
        # whatever the test run inherited (under nohup the hang-up is ignored already)
        for s in old:
            signal.signal(s, signal.SIG_DFL)
        assert main(["info"]) == 0
        assert seen == {signal.SIGTERM: cli._terminate, signal.SIGHUP: cli._terminate}
        assert {s: signal.getsignal(s) for s in old} == {s: signal.SIG_DFL for s in old}
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        assert main(["info"]) == 0
        assert seen[signal.SIGHUP] is signal.SIG_IGN and seen[signal.SIGTERM] is cli._terminate
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def test_a_renderer_that_does_not_stop_is_killed_with_what_it_started(tmp_path: Path, monkeypatch) -> None:
    """The render child gets SIGTERM, and SIGKILL after the grace time; the signals reach its process
    group (the ffmpeg it started), not only the child."""
    monkeypatch.setattr(video, "STOP_GRACE_S", 0.5)
    stubborn = ("import os, signal, subprocess, sys, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                "c = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(60)']); "
                "print(c.pid, flush=True); time.sleep(60)")
    proc = subprocess.Popen([sys.executable, "-c", stubborn], stdout=subprocess.PIPE, text=True,
                            start_new_session=True)
    grandchild = int(proc.stdout.readline())
    t0 = time.monotonic()
    video._stop_worker(proc)
    assert proc.returncode == -signal.SIGKILL and time.monotonic() - t0 < 10
    deadline = time.monotonic() + 10
    while True:  # the grandchild (SIGTERM ends it) is gone too; its parent was killed, so nobody reaps it here
        try:
            os.kill(grandchild, 0)
        except ProcessLookupError:
            break
        with open(f"/proc/{grandchild}/stat") as f:
            if f.read().split(") ")[-1].startswith("Z"):  # ended, waiting for init to collect it
                break
        assert time.monotonic() < deadline, "the renderer's child outlived it"
        time.sleep(0.05)
    proc.stdout.close()


# one signal in the default run (they share one handler); the other two with -m slow
@pytest.mark.parametrize("sig", [pytest.param(signal.SIGTERM, marks=pytest.mark.slow),
                                 pytest.param(signal.SIGHUP, marks=pytest.mark.slow), signal.SIGINT],
                         ids=lambda s: s.name)
def test_a_signal_during_a_video_leaves_no_temporary_file(sig: signal.Signals, tmp_path: Path) -> None:
    try:
        backend = choose_backend()
    except RenderError as exc:
        pytest.skip(f"no headless GL here (MUJOCO_GL egl or osmesa): {exc}")
    d = tmp_path / "run"
    env = dict(os.environ, MUJOCO_GL=backend)
    p = subprocess.Popen([sys.executable, "-m", "bipedsim.cli", "run", "--seconds", "3", "--out", str(d),
                          "--video", str(d / "v.mp4")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env)
    try:
        deadline = time.monotonic() + 120
        while not list(d.glob(".v.*tmp*")):
            assert p.poll() is None, p.communicate()
            assert time.monotonic() < deadline, "no temporary video file appeared"
            time.sleep(0.02)
        time.sleep(0.3)  # the renderer and its ffmpeg at work
        p.send_signal(sig)
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode != 0 and "Traceback" not in err, err
    assert err.strip().splitlines()[-1] == "bipedsim run: interrupted", err
    assert [q.name for q in tmp_path.rglob("*") if "tmp" in q.name] == []
    assert not (d / "v.mp4").exists() and (d / "outcome.json").is_file()


@pytest.mark.parametrize("extra", ['<include file="/etc/hostname"/>',
                                   '<asset><mesh name="m" file="/etc/x.stl"/></asset>'])
def test_a_run_folders_model_that_names_other_files_is_refused(tmp_path: Path, extra: str) -> None:
    xml = tmp_path / "model.xml"
    xml.write_text(f"<mujoco>{extra}<worldbody/></mujoco>")
    with pytest.raises(ModelError, match="names other files"):
        load_model(xml)
