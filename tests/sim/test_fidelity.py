"""The fidelity figures of a run against its clip (sim/fidelity.py), on a two-body model made in code."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from bipedsim.sim.fidelity import (
    Fidelity,
    align_start,
    clip_seconds,
    heading_axis,
    measure_fidelity,
    moving_average,
    path_length,
)

#: a free root with one arm (a hinge about z, 0.5 m long): enough for a path, a heading and a pose
XML = """<mujoco><worldbody><body name="root"><freejoint/><geom size=".1"/>
<body name="arm" pos=".5 0 0"><joint name="j" type="hinge" axis="0 0 1"/><geom size=".05"/>
<body name="tip" pos=".5 0 0"/></body></body></worldbody></mujoco>"""
FT = 0.01  # s per clip frame


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(XML)


def yaw_quat(yaw: float) -> np.ndarray:
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def poses(t: np.ndarray, speed: float = 1.0, yaw: float = 0.0, origin=(0.0, 0.0), bend: float = 0.0) -> np.ndarray:
    """qpos per time: the root walking along its heading ``yaw`` at ``speed`` m/s from ``origin``, arm ``bend`` rad."""
    q = np.zeros((len(t), 8))
    q[:, 0] = origin[0] + speed * t * math.cos(yaw)
    q[:, 1] = origin[1] + speed * t * math.sin(yaw)
    q[:, 2] = 1.0
    q[:, 3:7] = yaw_quat(yaw)
    q[:, 7] = bend
    return q


CLIP = poses(np.arange(301) * FT)  # 3 s at 1 m/s along x
T = np.arange(0, 3.0 + 1e-9, 1 / 120)  # the run's samples, 120 Hz


def test_the_clip_itself_scores_perfectly(model: mujoco.MjModel) -> None:
    f = measure_fidelity(model, T, poses(T), CLIP, FT, 0)
    assert f is not None and f.covered == 1.0 and f.clip_seconds == pytest.approx(3.0)
    assert f.path_max_m < 1e-9 and f.joint_error_cm < 1e-9
    assert f.path_ratio == pytest.approx(1.0) and f.speed_ratio == pytest.approx(1.0)
    assert f.clip_path_m == pytest.approx(f.clip_speed_mps * 3.0, rel=0.2)  # smoothing shortens the ends
    assert f.path_ok


def test_the_start_is_aligned_and_drift_is_measured(model: mujoco.MjModel) -> None:
    # the body starts elsewhere, facing another way: the same walk after alignment
    f = measure_fidelity(model, T, poses(T, yaw=1.2, origin=(5.0, -2.0)), CLIP, FT, 0)
    assert f.path_max_m < 1e-9 and f.joint_error_cm < 1e-9
    # the body walks at half the clip's speed: it ends half the clip's path behind
    slow = measure_fidelity(model, T, poses(T, speed=0.5), CLIP, FT, 0)
    assert slow.speed_ratio == pytest.approx(0.5) and slow.path_ratio == pytest.approx(0.5)
    assert slow.path_final_m == pytest.approx(1.5, abs=0.15) and slow.path_max_m == pytest.approx(slow.path_final_m)
    assert not slow.path_ok and slow.joint_error_cm < 1e-9  # drift is the path's, not the joints'


def test_joint_error_is_in_the_heading_frame(model: mujoco.MjModel) -> None:
    # arm bent by 90 degrees: the tip 0.5 * sqrt(2) m off, the arm's own body (at its joint) not
    f = measure_fidelity(model, T, poses(T, bend=math.pi / 2), CLIP, FT, 0)
    assert f.joint_error_cm == pytest.approx(100 * 0.5 * math.sqrt(2) / 2)
    # a body facing another way (same pose in its own frame) has no joint error
    assert measure_fidelity(model, T, poses(T, yaw=2.0), CLIP, FT, 0).joint_error_cm < 1e-9


def test_time_aligned_from_the_start_frame_and_a_fall_covers_part(model: mujoco.MjModel) -> None:
    # a run that started at frame 100 sees the clip from there: 2 s of it
    t = T[T <= 2.0]
    f = measure_fidelity(model, t, poses(t, origin=(1.0, 0.0)), CLIP, FT, 100)
    assert f.clip_seconds == pytest.approx(2.0) and f.covered == 1.0 and f.path_max_m < 1e-9
    assert f.start_frame == 100
    # a run that ended at 1.2 s: compared over that part, with the share covered
    part = T[T <= 1.2]
    g = measure_fidelity(model, part, poses(part), CLIP, FT, 0, run_seconds=1.2)
    assert g.covered == pytest.approx(0.4, abs=0.01) and g.compared_seconds == pytest.approx(1.2, abs=0.01)
    assert not g.path_ok and "the run ended sooner" in g.describe()
    # a run that went on past the clip's end is compared over the clip only
    long_t = np.arange(0, 6.0, 1 / 120)
    h = measure_fidelity(model, long_t, poses(long_t), CLIP, FT, 0)
    assert h.covered == 1.0 and h.samples == 361


def test_nothing_to_compare_and_a_clip_in_place(model: mujoco.MjModel) -> None:
    assert measure_fidelity(model, T, poses(T), CLIP, FT, 300) is None  # started at the last frame
    assert clip_seconds(301, FT, 400) == 0.0
    still = poses(np.arange(301) * FT, speed=0.0)
    f = measure_fidelity(model, T, poses(T, speed=0.0), still, FT, 0)
    assert f.path_ratio is None and f.speed_ratio is None and f.path_ok
    assert "clip in place" in f.describe() and "speed -" in f.describe()


def test_pieces() -> None:
    t = np.arange(0, 2.0 + 1e-9, 0.1)
    x = np.sin(2 * np.pi * t)[:, None]  # one period a second averages out over a one-second window
    assert np.abs(moving_average(t, x, 1.0)[5:-5]).max() < 0.1
    assert moving_average(t, t[:, None], 1.0)[0, 0] == pytest.approx(0.25)  # half a window at the start
    assert path_length(np.array([[0, 0], [3, 4], [3, 0]])) == 9.0
    moved = align_start(np.array([[1.0, 1.0], [2.0, 1.0]]), 0.0, np.array([5.0, 5.0]), math.pi / 2)
    assert np.allclose(moved, [[5, 5], [5, 6]])
    assert heading_axis(np.array([1.0, 0, 0, 0])) == 0
    # a root pitched 90 degrees (its x axis up): the heading is its first floor axis, y
    assert heading_axis(np.array([math.cos(math.pi / 4), 0, -math.sin(math.pi / 4), 0])) == 1


def test_figures_and_line() -> None:
    f = Fidelity(clip_seconds=10.2, compared_seconds=10.2, covered=1.0, path_max_m=0.31, path_final_m=0.12,
                 clip_path_m=8.0, body_path_m=7.68, path_ratio=0.96, clip_speed_mps=1.0, body_speed_mps=0.97,
                 speed_ratio=0.97, joint_error_cm=4.1, start_frame=0.0, samples=1225)
    assert f.describe() == ("fidelity over the clip's 10.20 s: path within 0.31 m (final 0.12 m), 96 % of the "
                            "clip's path (8.00 m), speed x0.97, joints 4.1 cm")
    d = f.to_dict()
    assert d["path_tolerance_m"] == 0.8 and d["path_ok"] is True and d["joint_error_cm"] == 4.1
