"""Headless rollout videos (mp4 via imageio-ffmpeg's H.264, or gif) from a recorded trajectory.

Rendering reads only the run folder: ``model.xml`` and ``trajectory.npz``. A follow camera tracks the
pelvis smoothly (configurable distance, elevation, azimuth); pushes are drawn as arrows scaled by
force while they act; the time, FSM state and outcome are written on each frame; the reference pose
can be shown as a translucent ghost beside the body.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from bipedsim.errors import BipedsimError
from bipedsim.render.gl import RenderError, backend_env, choose_backend

MODEL_FILE = "model.xml"
TRAJECTORY_FILE = "trajectory.npz"
OUTCOME_FILE = "outcome.json"
#: Newtons per metre of arrow.
ARROW_N_PER_M = 400.0
#: Camera smoothing: the look-at point closes this fraction of the gap per second.
CAMERA_TIME_CONSTANT_S = 0.4


@dataclass
class VideoOptions:
    width: int = 640
    height: int = 480
    fps: float = 30.0
    speed: float = 1.0  #: playback speed: 0.5 = half speed (slow motion)
    distance: float = 3.5
    elevation: float = -15.0
    azimuth: float = 120.0
    ghost: bool = False
    ghost_offset: float = 1.0  #: metres to the character's left; 0 overlays
    label: bool = True
    start: float = 0.0
    end: float | None = None

    def validate(self) -> None:
        if self.width < 16 or self.height < 16 or self.width > 4096 or self.height > 4096:
            raise BipedsimError(f"video size must be 16..4096 pixels, got {self.width}x{self.height}")
        if not self.fps > 0 or not self.speed > 0:
            raise BipedsimError("fps and speed must be positive")


def frame_times(t0: float, t1: float, opts: VideoOptions) -> np.ndarray:
    """Simulation times of the video frames: ``fps`` per second of video, ``speed`` sim s per video s."""
    step = opts.speed / opts.fps
    return np.arange(t0, t1 + 1e-9, step)


def render_frames(run_dir: str | os.PathLike[str], opts: VideoOptions, progress: bool = False):  # noqa: ANN201
    """Yield RGB frames (H, W, 3 uint8). Must run in a process whose MUJOCO_GL works."""
    import mujoco

    from bipedsim.sim.recorder import Trajectory

    run = Path(run_dir)
    model = mujoco.MjModel.from_xml_path(str(run / MODEL_FILE))
    tr = Trajectory.load(run / TRAJECTORY_FILE)
    outcome = {}
    if (run / OUTCOME_FILE).is_file():
        outcome = json.loads((run / OUTCOME_FILE).read_text())
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, opts.width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, opts.height)
    renderer = mujoco.Renderer(model, opts.height, opts.width)
    data = mujoco.MjData(model)
    ghost = mujoco.MjData(model)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.distance, cam.elevation, cam.azimuth = opts.distance, opts.elevation, opts.azimuth
    vopt = mujoco.MjvOption()
    pert = mujoco.MjvPerturb()
    t_end = tr.time[-1] if opts.end is None else min(opts.end, tr.time[-1])
    times = frame_times(max(opts.start, tr.time[0]), t_end, opts)
    look = tr.qpos[0, :3].copy()
    look[2] = 0.9
    alpha = 1.0 - np.exp(-(opts.speed / opts.fps) / CAMERA_TIME_CONSTANT_S)
    fall_t = outcome.get("fall_time_s")
    it = times
    if progress and len(times) > 90:
        from tqdm import tqdm

        it = tqdm(times, unit="frame", desc="render", file=sys.stderr)
    for t in it:
        i = int(np.clip(np.searchsorted(tr.time, t, side="right") - 1, 0, tr.num_samples - 1))
        data.qpos[:] = tr.qpos[i]
        data.qvel[:] = tr.qvel[i]
        mujoco.mj_forward(model, data)
        target = data.xpos[1].copy()
        target[2] = 0.9
        look += alpha * (target - look)
        cam.lookat[:] = look
        renderer.update_scene(data, camera=cam, scene_option=vopt)
        scn = renderer.scene
        if opts.ghost:
            ghost.qpos[:] = tr.ref_qpos[i]
            # beside the body: the reference's pose and heading, the simulated root's place
            ghost.qpos[:2] = tr.qpos[i, :2]
            r = data.xmat[1].reshape(3, 3)
            left = np.array([-r[1, 0], r[0, 0], 0.0])
            left /= max(np.linalg.norm(left), 1e-9)
            ghost.qpos[:2] += opts.ghost_offset * left[:2]
            mujoco.mj_forward(model, ghost)
            n0 = scn.ngeom
            mujoco.mjv_addGeoms(model, ghost, vopt, pert, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
            for g in range(n0, scn.ngeom):
                scn.geoms[g].rgba[:] = [0.3, 0.6, 1.0, 0.35]
        for b in range(tr.xfrc.shape[1]):
            f = tr.xfrc[i, b]
            mag = float(np.linalg.norm(f))
            if mag < 1e-9 or scn.ngeom >= scn.maxgeom:
                continue
            tip = data.xipos[b]
            tail = tip - f / ARROW_N_PER_M
            g = scn.geoms[scn.ngeom]
            mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.zeros(9),
                                np.array([1.0, 0.2, 0.1, 1.0], dtype=np.float32))
            mujoco.mjv_connector(g, mujoco.mjtGeom.mjGEOM_ARROW, 0.03, tail, tip)
            scn.ngeom += 1
        img = renderer.render()
        if opts.label:
            status = outcome.get("outcome", "")
            if fall_t is not None and t < fall_t:
                status = "walking"
            img = _label(img, f"t = {t:5.2f} s   state {int(tr.fsm_state[i])}   {status}")
        yield img
    renderer.close()


def _label(img: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    d.rectangle([0, 0, im.width, 22], fill=(0, 0, 0))
    d.text((8, 5), text, fill=(255, 255, 255))
    return np.asarray(im)


def write_video(frames, path: str | os.PathLike[str], fps: float) -> int:  # noqa: ANN001
    """Write frames to ``path`` (.mp4: H.264; .gif); returns the frame count."""
    import imageio.v2 as imageio

    p = Path(path)
    tmp = p.with_name(f".{p.stem}.tmp{p.suffix}")
    n = 0
    if p.suffix.lower() == ".gif":
        with imageio.get_writer(tmp, mode="I", duration=1.0 / fps, loop=0) as w:
            for f in frames:
                w.append_data(f)
                n += 1
    else:
        with imageio.get_writer(tmp, fps=fps, codec="libx264", quality=7, macro_block_size=8,
                                ffmpeg_log_level="error", pixelformat="yuv420p") as w:
            for f in frames:
                w.append_data(f)
                n += 1
    os.replace(tmp, p)
    return n


def render_video(run_dir: str | os.PathLike[str], out: str | os.PathLike[str], opts: VideoOptions | None = None,
                 progress: bool = False) -> int:
    """Render a recorded run to ``out`` in a child process with a working GL backend; returns the
    frame count. Raises :class:`RenderError` with what to install when no backend works."""
    opts = opts or VideoOptions()
    opts.validate()
    suffix = Path(out).suffix.lower()
    if suffix not in (".mp4", ".gif"):
        raise RenderError(f"{out}: video must end in .mp4 or .gif")
    run = Path(run_dir)
    for f in (MODEL_FILE, TRAJECTORY_FILE):
        if not (run / f).is_file():
            raise RenderError(f"{run}: no {f} -- render a folder written by `bipedsim run`")
    backend = choose_backend()
    args = json.dumps({"run_dir": str(run), "out": str(out), "opts": asdict(opts), "progress": progress})
    # with a progress bar the child's stderr goes straight to the terminal (live), else it is kept
    # for the error message
    p = subprocess.run([sys.executable, "-m", "bipedsim.render.worker", args], env=backend_env(backend),
                       stdout=subprocess.PIPE, stderr=None if progress else subprocess.PIPE, text=True,
                       check=False)
    if p.returncode != 0:
        lines = [ln for ln in (p.stderr or "").strip().splitlines() if ln.strip()]
        why = lines[-1] if lines else f"exit status {p.returncode} (see the messages above)"
        raise RenderError(f"rendering with {backend} failed: {why}")
    return int(p.stdout.strip().splitlines()[-1])
