"""A run's fidelity against its clip in ``outcome.json``, its printout and its trajectory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bipedsim.model.build import load_model
from bipedsim.sim.fidelity import trajectory_fidelity
from bipedsim.sim.outputs import run_to_folder
from bipedsim.sim.recorder import Trajectory

ROOT = Path(__file__).resolve().parents[2]


def test_a_run_reports_its_fidelity(tmp_path: Path) -> None:
    lines: list[str] = []
    res = run_to_folder(tmp_path, seconds=0.5, say=lines.append)
    fid = json.loads((tmp_path / "outcome.json").read_text())["fidelity"]
    assert fid == res.outcome.fidelity
    assert fid["covered"] == pytest.approx(0.5 / fid["clip_seconds"], abs=0.01)  # the clip is longer than the run
    assert 0 < fid["joint_error_cm"] < 20 and fid["path_max_m"] < 0.5 and fid["samples"] == 60
    line = next(ln for ln in lines if ln.startswith("fidelity "))
    assert f"joints {fid['joint_error_cm']:.1f} cm" in line and "the run ended sooner" in line
    # the trajectory keeps the clip at the run's time: the same figures from the file alone
    tr = Trajectory.load(tmp_path / "trajectory.npz")
    clip_qpos, frame_time, start = tr.clip_pose_frames()
    assert clip_qpos.shape == (res.scenario.clip.num_frames, tr.qpos.shape[1])
    assert frame_time == res.scenario.clip.frame_time and start == fid["start_frame"]
    again = trajectory_fidelity(load_model(tmp_path / "model.xml").model, tr, res.outcome.sim_seconds).to_dict()
    assert again["path_max_m"] == pytest.approx(fid["path_max_m"], abs=1e-4)
    assert again["joint_error_cm"] == pytest.approx(fid["joint_error_cm"], abs=1e-3)


def test_key_poses_have_no_clip_to_judge(tmp_path: Path) -> None:
    lines: list[str] = []
    res = run_to_folder(tmp_path, config=ROOT / "controllers" / "pose_gait.yaml", seconds=0.3, say=lines.append)
    assert res.outcome.fidelity is None
    assert json.loads((tmp_path / "outcome.json").read_text())["fidelity"] is None
    assert not any(ln.startswith("fidelity") for ln in lines)
    assert Trajectory.load(tmp_path / "trajectory.npz").clip_pose_frames() is None


def test_an_older_trajectory_reads_without_a_clip(tmp_path: Path) -> None:
    n = 3
    tr = Trajectory(time=np.arange(n) / 120, qpos=np.zeros((n, 8)), qvel=np.zeros((n, 7)), ctrl=np.zeros((n, 1)),
                    contact_force=np.zeros((n, 2)), fsm_state=np.zeros(n, np.int8), ref_frame=np.zeros(n),
                    ref_qpos=np.zeros((n, 8)), xfrc=np.zeros((n, 2, 3)), com=np.zeros((n, 3)))
    tr.save(tmp_path / "t.npz")
    back = Trajectory.load(tmp_path / "t.npz")
    assert back.clip_qpos is None and back.clip_pose_frames() is None
    tr.with_clip(np.ones((5, 8)), 0.02, 2).save(tmp_path / "c.npz")
    clip = Trajectory.load(tmp_path / "c.npz").clip_pose_frames()
    assert clip[0].shape == (5, 8) and clip[1:] == (0.02, 2.0)
