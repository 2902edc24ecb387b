"""The clip's ghost of ``bipedsim render --ghost``: where it stands and what pose it has, and that it is drawn."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from bipedsim.cli import main
from bipedsim.render.ghost import CLIP_RGBA, Ghost
from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.sim.recorder import Trajectory

XML = """<mujoco><worldbody><body name="root"><freejoint/><geom size=".1"/>
<body name="arm" pos=".5 0 0"><joint name="j" type="hinge" axis="0 0 1"/><geom size=".05"/></body>
</body></worldbody></mujoco>"""
FT = 0.01  # s per clip frame


def yaw_quat(yaw: float) -> np.ndarray:
    return np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])


def trajectory(n: int = 300) -> Trajectory:
    """2.5 s at 120 Hz of a body standing at (5, 5) facing +y, its reference frame stuck at 0 (as a
    resynchronisation might hold it), tracking a 2 s clip walking +x at 1 m/s with its arm turning."""
    t = np.arange(n) / 120
    q = np.zeros((n, 8))
    q[:, :3] = [5.0, 5.0, 1.0]
    q[:, 3:7] = yaw_quat(math.pi / 2)
    ref = np.zeros((n, 8))
    ref[:, 3] = 1.0
    ref[:, 7] = -0.3
    clip = np.zeros((201, 8))
    clip[:, 0] = np.arange(201) * FT + 2.0
    clip[:, 2] = 1.0
    clip[:, 3] = 1.0
    clip[:, 7] = np.arange(201) * 0.01
    tr = Trajectory(time=t, qpos=q, qvel=np.zeros((n, 7)), ctrl=np.zeros((n, 1)), contact_force=np.zeros((n, 2)),
                    fsm_state=np.zeros(n, np.int8), ref_frame=np.zeros(n), ref_qpos=ref, xfrc=np.zeros((n, 3, 3)),
                    com=np.zeros((n, 3)))
    return tr.with_clip(clip, FT, start_frame=50)


def test_the_ghost_is_the_clip_at_the_runs_time_beside_its_aligned_course() -> None:
    model = mujoco.MjModel.from_xml_string(XML)
    tr = trajectory()
    g = Ghost(model, tr, offset=1.0)
    body = np.eye(3)
    # at 1 s: clip frame 50 + 100, not the reference's frame; the clip has walked 1 m since its start,
    # which the alignment turns onto the body's heading (+y) from the body's place, then 1 m to its left (-x)
    q = g.pose(1.0, 120, body)
    assert q[7] == pytest.approx(1.5)
    assert q[:3] == pytest.approx([5.0 - 1.0, 5.0 + 1.0, 1.0])
    assert q[3:7] == pytest.approx(yaw_quat(math.pi / 2))
    assert g.shows_clip(1.5) and g.rgba(1.0) == CLIP_RGBA and g.label(1.0) == "ghost: clip"
    # past the clip's end (1.5 s from frame 50): the controller's reference, 1 m to the body's left
    after = g.pose(2.0, 240, np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]))  # the body facing +y
    assert not g.shows_clip(2.0) and after[7] == pytest.approx(-0.3)
    assert after[:2] == pytest.approx([4.0, 5.0])


def test_without_a_clip_the_ghost_is_the_reference() -> None:
    model = mujoco.MjModel.from_xml_string(XML)
    tr = trajectory()
    tr.clip_qpos = None
    g = Ghost(model, tr, offset=0.0)
    q = g.pose(0.5, 60, np.eye(3))
    assert not g.shows_clip(0.0) and q[7] == pytest.approx(-0.3) and q[:2] == pytest.approx([5.0, 5.0])


@pytest.mark.slow  # a render; the ghost poses are checked without GL in the default run
def test_render_ghost_draws_the_clip(tmp_path: Path) -> None:
    import imageio.v2 as iio

    try:
        choose_backend()
    except RenderError as exc:
        pytest.skip(f"no headless GL here: {exc}")
    assert main(["run", "--seconds", "0.4", "--out", str(tmp_path)]) == 0
    size = ["--fps", "5", "--width", "160", "--height", "120"]
    assert main(["render", str(tmp_path), "-o", str(tmp_path / "plain.gif"), *size]) == 0
    assert main(["render", str(tmp_path), "-o", str(tmp_path / "ghost.gif"), "--ghost", *size]) == 0

    def blue(f: np.ndarray) -> float:
        r, g, b = (f[..., k].astype(int) for k in range(3))
        return float(((b - r > 60) & (b > 120)).mean())

    plain, ghost = iio.mimread(tmp_path / "plain.gif"), iio.mimread(tmp_path / "ghost.gif")
    assert blue(ghost[1]) > 5 * blue(plain[1]) + 0.002
