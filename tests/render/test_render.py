"""Headless videos, plots and motion export of recorded rollouts."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bipedsim.cli import main
from bipedsim.model.plan import plan_from_model
from bipedsim.motion import load_bvh
from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.render.video import VideoOptions, frame_times
from bipedsim.sim.recorder import Trajectory


def gl_or_skip() -> str:
    try:
        return choose_backend()
    except RenderError as exc:
        pytest.skip(f"no headless GL here: {exc}")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("run")
    assert main(["run", "--seconds", "2", "--out", str(d), "--plots", "--export-bvh", str(d / "sim.bvh"),
                 "--csv", str(d / "joints.csv")]) == 0
    return d


def body_fraction(img: np.ndarray) -> float:
    """Share of pixels in the body's skin colour (warm: red well above blue); the floor is grey-blue."""
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return float(((r - b > 25) & (r > 60) & (g > 40)).mean())


@pytest.mark.slow  # 2 s at 640x480 as mp4 and gif; test_render_again_gives_the_run_frames and
# test_push_arrow_is_drawn write both formats small in the default run
def test_video_mp4_and_gif(run_dir: Path) -> None:
    import imageio.v2 as iio

    gl_or_skip()
    for name in ("walk.mp4", "walk.gif"):
        out = run_dir / name
        assert main(["render", str(run_dir), "-o", str(out)]) == 0
        frames = iio.mimread(out, memtest=False)
        tr = Trajectory.load(run_dir / "trajectory.npz")
        expected = len(frame_times(tr.time[0], tr.time[-1], VideoOptions()))
        assert len(frames) == expected
        assert frames[0].shape[:2] == (480, 640)
        assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).mean() > 1.0  # it moves
        assert min(body_fraction(f[..., :3]) for f in frames[::10]) > 0.01  # the body is in view


@pytest.mark.slow  # two renders of a run; test_push_arrow_is_drawn renders in the default run
def test_render_again_gives_the_run_frames(tmp_path: Path) -> None:
    import imageio.v2 as iio

    gl_or_skip()
    a, b = tmp_path / "a.mp4", tmp_path / "b.mp4"
    size = ["--width", "320", "--height", "240"]
    assert main(["run", "--seconds", "1", "--out", str(tmp_path), "--video", str(a), *size]) == 0
    assert main(["render", str(tmp_path), "-o", str(b), *size]) == 0
    fa, fb = iio.mimread(a, memtest=False), iio.mimread(b, memtest=False)
    assert len(fa) == len(fb) == 30 and all(np.array_equal(x, y) for x, y in zip(fa, fb))


@pytest.mark.slow
def test_push_arrow_is_drawn(run_dir: Path, tmp_path: Path) -> None:
    """A recorded external force shows as a red arrow on the frames where it acts."""
    import shutil

    import imageio.v2 as iio

    gl_or_skip()
    d = tmp_path / "pushed"
    shutil.copytree(run_dir, d)
    tr = Trajectory.load(d / "trajectory.npz")
    torso = mujoco.MjModel.from_xml_path(str(d / "model.xml")).body("torso").id
    window = (tr.time > 0.5) & (tr.time < 0.7)
    tr.xfrc[window, torso] = [0.0, 300.0, 0.0]
    tr.save(d / "trajectory.npz")
    assert main(["render", str(d), "-o", str(d / "v.gif"), "--fps", "10", "--width", "320", "--height", "240"]) == 0
    frames = iio.mimread(d / "v.gif", memtest=False)

    def red(f: np.ndarray) -> float:
        r, g, b = (f[..., k].astype(int) for k in range(3))
        return float(((r > 180) & (g < 110) & (b < 90)).mean())

    assert red(frames[6]) > 5 * red(frames[2]) + 1e-4  # t = 0.6 s (pushed) vs 0.2 s


def test_no_gl_fails_clearly_and_keeps_results(tmp_path: Path) -> None:
    env = dict(os.environ, MUJOCO_GL="bogus")
    p = subprocess.run([sys.executable, "-m", "bipedsim.cli", "run", "--seconds", "0.5", "--out", str(tmp_path),
                        "--video", str(tmp_path / "v.mp4")], env=env, capture_output=True, text=True, check=False)
    assert p.returncode == 2, p.stderr
    assert "no working OpenGL backend" in p.stderr and "Traceback" not in p.stderr
    assert "libosmesa6" in p.stderr or "not a headless backend" in p.stderr
    assert json.loads((tmp_path / "outcome.json").read_text())["sim_seconds"] == pytest.approx(0.5)
    assert (tmp_path / "trajectory.npz").is_file() and not (tmp_path / "v.mp4").exists()


def test_exported_bvh_matches_simulated_joints(run_dir: Path) -> None:
    tr = Trajectory.load(run_dir / "trajectory.npz")
    model = mujoco.MjModel.from_xml_path(str(run_dir / "model.xml"))
    plan = plan_from_model(model)
    m = load_bvh(run_dir / "sim.bvh")
    assert m.num_frames == tr.num_samples
    pos = m.fk()[0]
    d = mujoco.MjData(model)
    turn = Rotation.from_rotvec([0.0, 0.0, plan.heading_yaw]).as_matrix()
    worst = 0.0
    for i in range(tr.num_samples):
        d.qpos[:] = tr.qpos[i]
        mujoco.mj_kinematics(model, d)
        for src, (kind, name) in plan.extra["markers"].items():
            p = d.xpos[model.body(name).id] if kind == "body" else d.site_xpos[model.site(name).id]
            worst = max(worst, float(np.linalg.norm(turn.T @ p - pos[i, m.skeleton.index(src)])))
    assert worst < 0.01


def test_plots_and_csv(run_dir: Path) -> None:
    for name in ("joint_angles.png", "tracking_error.png", "com_top_view.png", "contacts.png"):
        data = (run_dir / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    rows = (run_dir / "joints.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert header[0] == "time_s" and "left_knee" in header and "left_knee_ref" in header
    assert len(rows) == Trajectory.load(run_dir / "trajectory.npz").num_samples + 1


def test_trajectory_records_what_rendering_needs(run_dir: Path) -> None:
    tr = Trajectory.load(run_dir / "trajectory.npz")
    assert tr.qpos.shape[0] == tr.num_samples and tr.xfrc.shape[2] == 3
    assert set(np.unique(tr.fsm_state)) <= {1, 2, 3, 4}
    assert np.all(np.diff(tr.ref_frame) > 0)  # the reference advances
    assert tr.contact_force.max() > 100  # feet carry the body
