"""Headless rollout videos (mp4 via imageio-ffmpeg's H.264, or gif) from a recorded trajectory.

Rendering reads only the run folder: ``model.xml`` and ``trajectory.npz``. A follow camera tracks the
pelvis smoothly (with the clip's ghost, the point between the two; configurable distance, elevation,
azimuth); pushes are drawn as arrows scaled by
force while they act; the time, FSM state and outcome are written on each frame; the clip can be shown
as a translucent ghost beside the body (:mod:`bipedsim.render.ghost`).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.files import check_output_file, progress_bar
from bipedsim.model.build import load_model
from bipedsim.render.ghost import Ghost
from bipedsim.render.gl import RenderError, backend_env, backends_tried, choose_backend
from bipedsim.sim.recorder import Trajectory

MODEL_FILE = "model.xml"
TRAJECTORY_FILE = "trajectory.npz"
OUTCOME_FILE = "outcome.json"
#: The file ``bipedsim render`` writes into a run folder when no ``-o`` is given.
DEFAULT_VIDEO = "rollout.mp4"
#: Video formats written (by file name ending).
VIDEO_SUFFIXES = (".mp4", ".gif")
#: Newtons per metre of arrow.
ARROW_N_PER_M = 400.0
#: Camera smoothing: the look-at point closes this fraction of the gap per second.
CAMERA_TIME_CONSTANT_S = 0.4
#: Accepted ranges of the video options (inclusive), with the flag that sets each: frame size in pixels
#: (MuJoCo's offscreen buffer and H.264 both handle 16..4096); frames per second of video (1..240: below
#: one frame a second is a slide show, above 240 no player shows them); playback speed (0.01..100:
#: 100x slow motion to 100x fast forward; beyond that a 10 s run is days of frames or a single one);
#: camera distance (m) and elevation (degrees; beyond +-90 the camera flips over); the ghost's sideways
#: offset (m; negative: to the right; beyond 10 m it leaves the picture).
VIDEO_LIMITS: dict[str, tuple[str, float, float, str]] = {
    "width": ("--width", 16, 4096, "pixels"), "height": ("--height", 16, 4096, "pixels"),
    "fps": ("--fps", 1.0, 240.0, "frames/s"), "speed": ("--speed", 0.01, 100.0, "x real time"),
    "distance": ("--cam-distance", 0.1, 100.0, "m"), "elevation": ("--cam-elevation", -90.0, 90.0, "degrees"),
    "azimuth": ("--cam-azimuth", -360.0, 360.0, "degrees"), "ghost_offset": ("--ghost-offset", -10.0, 10.0, "m")}


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
    #: metres the ghost stands to the clip's left (after the clip's end, the body's); 0 overlays
    ghost_offset: float = 1.0
    label: bool = True
    start: float = 0.0
    end: float | None = None

    def validate(self) -> None:
        """Raise :class:`ConfigError` naming the flag of the first option outside :data:`VIDEO_LIMITS`."""
        for name, (flag, lo, hi, unit) in VIDEO_LIMITS.items():
            v = getattr(self, name)
            if not lo <= v <= hi:  # also NaN
                raise ConfigError(f"must be {lo:g}..{hi:g} {unit}, got {v}", key=flag)


def frame_times(t0: float, t1: float, opts: VideoOptions) -> np.ndarray:
    """Simulation times of the video frames: ``fps`` per second of video, ``speed`` sim s per video s."""
    step = opts.speed / opts.fps
    return np.arange(t0, t1 + 1e-9, step)


def render_frames(run_dir: str | os.PathLike[str], opts: VideoOptions, progress: bool = False):  # noqa: ANN201
    """Yield RGB frames (H, W, 3 uint8). Must run in a process whose MUJOCO_GL works."""
    run = Path(run_dir)
    model = load_model(run / MODEL_FILE).model
    tr = Trajectory.load(run / TRAJECTORY_FILE)
    outcome = {}
    if (run / OUTCOME_FILE).is_file():
        outcome = json.loads((run / OUTCOME_FILE).read_text())
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, opts.width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, opts.height)
    renderer = mujoco.Renderer(model, opts.height, opts.width)
    data = mujoco.MjData(model)
    ghost = mujoco.MjData(model)
    shadow = Ghost(model, tr, opts.ghost_offset) if opts.ghost else None
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
    # the parent asked for a bar only when its stderr (which this process shares) is a terminal
    bar = progress_bar(len(times), "render", "frame", force=True) if progress else None
    for t in times:
        i = int(np.clip(np.searchsorted(tr.time, t, side="right") - 1, 0, tr.num_samples - 1))
        data.qpos[:] = tr.qpos[i]
        data.qvel[:] = tr.qvel[i]
        mujoco.mj_forward(model, data)
        target = data.xpos[1].copy()
        if shadow is not None:
            ghost.qpos[:] = shadow.pose(float(t), i, data.xmat[shadow.root].reshape(3, 3))
            mujoco.mj_forward(model, ghost)
            if shadow.shows_clip(float(t)):  # between the body and the clip, both in view as they part
                target = 0.5 * (target + ghost.xpos[shadow.root])
        target[2] = 0.9
        look += alpha * (target - look)
        cam.lookat[:] = look
        renderer.update_scene(data, camera=cam, scene_option=vopt)
        scn = renderer.scene
        if shadow is not None:
            n0 = scn.ngeom
            mujoco.mjv_addGeoms(model, ghost, vopt, pert, mujoco.mjtCatBit.mjCAT_DYNAMIC, scn)
            for g in range(n0, scn.ngeom):
                scn.geoms[g].rgba[:] = shadow.rgba(float(t))
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
            seen = f"   {shadow.label(float(t))}" if shadow is not None else ""
            img = _label(img, f"t = {t:5.2f} s   state {int(tr.fsm_state[i])}   {status}{seen}")
        yield img
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    renderer.close()


def _label(img: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    d.rectangle([0, 0, im.width, 22], fill=(0, 0, 0))
    d.text((8, 5), text, fill=(255, 255, 255))
    return np.asarray(im)


def temp_video_path(path: str | os.PathLike[str], pid: int | None = None) -> Path:
    """Where a video is written before it is renamed to ``path``: beside it (same file system for the
    rename), hidden, named for the process ``pid`` (default this one) that renders it."""
    p = Path(path)
    return p.with_name(f".{p.stem}.{os.getpid() if pid is None else pid}.tmp{p.suffix}")


def write_video(frames, path: str | os.PathLike[str], fps: float,  # noqa: ANN001
                tmp: str | os.PathLike[str] | None = None) -> int:
    """Write frames to ``path`` (.mp4: H.264; .gif) through the temporary file ``tmp`` (default
    :func:`temp_video_path`); returns the frame count. On any error or interruption (Ctrl-C, and
    SIGTERM/SIGHUP where they raise KeyboardInterrupt) the temporary file is removed and ``path`` is
    left as it was."""
    import imageio.v2 as imageio

    p = Path(path)
    tmp = Path(tmp) if tmp is not None else temp_video_path(p)
    n = 0
    writer = None
    try:
        # made here first so that a folder that cannot take it fails with the file and the reason,
        # not with imageio's "Broken pipe" from an ffmpeg that could not open it
        open(tmp, "xb").close()
        if p.suffix.lower() == ".gif":
            writer = imageio.get_writer(tmp, mode="I", duration=1.0 / fps, loop=0)
        else:
            writer = imageio.get_writer(tmp, fps=fps, codec="libx264", quality=7, macro_block_size=8,
                                        ffmpeg_log_level="error", pixelformat="yuv420p")
        for f in frames:
            writer.append_data(f)
            n += 1
        writer.close()
        os.replace(tmp, p)
    except BaseException:
        try:
            # imageio's writer is not closed by its own `with` on an error: its ffmpeg would go on and
            # write the file again after it is removed here (when the writer is collected)
            if writer is not None:
                writer.close()
        except Exception:  # the first error is the one to report
            pass
        finally:
            with contextlib.suppress(OSError):
                tmp.unlink()
        raise
    return n


#: Seconds an interrupted render child is given to remove its temporary file before it is killed.
STOP_GRACE_S = 10.0


def _stop_worker(proc: subprocess.Popen[str]) -> None:
    """Stop the render child and what it started (ffmpeg): SIGTERM to its process group, which the child
    turns into a clean exit, then SIGKILL after :data:`STOP_GRACE_S`. Signals go only while the child
    is not yet reaped, so its group id is still its own."""
    if proc.poll() is not None:
        return
    try:
        _signal_group(proc, signal.SIGTERM)
        proc.wait(timeout=STOP_GRACE_S)
    except BaseException:  # a timeout, or a second Ctrl-C while waiting
        if proc.poll() is None:
            _signal_group(proc, getattr(signal, "SIGKILL", signal.SIGTERM))
            proc.wait()


def _signal_group(proc: subprocess.Popen[str], sig: int) -> None:
    """Send ``sig`` to the process group ``proc`` leads (to ``proc`` alone where there are no groups)."""
    with contextlib.suppress(ProcessLookupError):
        if hasattr(os, "killpg"):
            os.killpg(proc.pid, sig)
        else:  # pragma: no cover -- Windows
            proc.send_signal(sig)


def render_video(run_dir: str | os.PathLike[str], out: str | os.PathLike[str], opts: VideoOptions | None = None,
                 progress: bool = False, out_flag: str = "video") -> int:
    """Render a recorded run to ``out`` (.mp4 or .gif; missing folders are created) in a child process
    with a working GL backend; returns the frame count. ``progress``: show a bar on stderr (pass
    ``sys.stderr.isatty()``). Raises :class:`RenderError` naming the file and the cause when the run
    folder is incomplete or rendering fails (with the GL backends tried), with what to install when no
    backend works, and :class:`~bipedsim.errors.OutputError` (naming ``out_flag``) when ``out`` cannot
    be written.

    The video is written to a temporary file beside ``out`` and renamed at the end; however the render
    ends (an error, a crash of the child, Ctrl-C, SIGTERM or SIGHUP in this process: KeyboardInterrupt
    from the command line) no temporary file is left."""
    opts = opts or VideoOptions()
    opts.validate()
    run = Path(run_dir)
    for f in (MODEL_FILE, TRAJECTORY_FILE):
        if not (run / f).is_file():
            raise RenderError(f"{run}: no {f} -- render a folder written by `bipedsim run`")
    check_output_file(out, out_flag, VIDEO_SUFFIXES)
    backend = choose_backend()
    tmp = temp_video_path(out)  # named here: this process removes it whatever happens to the child
    args = json.dumps({"run_dir": str(run), "out": str(out), "tmp": str(tmp), "opts": asdict(opts),
                       "progress": progress})
    # the child reports on its stdout (one JSON line: the frame count or the error); its stderr goes
    # straight to the terminal with a progress bar (live), else it is kept for a crash's last words.
    # It runs in its own process group, so that stopping it stops the ffmpeg it starts as well; a
    # terminal's Ctrl-C reaches this process, which stops it.
    proc = subprocess.Popen([sys.executable, "-m", "bipedsim.render.worker", args], env=backend_env(backend),
                            stdout=subprocess.PIPE, stderr=None if progress else subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        stdout, stderr = proc.communicate()
    except BaseException:
        _stop_worker(proc)
        raise
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()  # renamed away when the render succeeded; left by a child that crashed or was killed
    report = _worker_report(stdout)
    if proc.returncode == 0 and "frames" in report:
        return int(report["frames"])
    done = subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)
    why = report.get("error") or _crash_reason(done)
    last = _last_line(stderr)
    if report.get("error") and last and last not in why:  # e.g. ffmpeg's reason after imageio's "Broken pipe"
        why = f"{why} ({last})"
    raise RenderError(f"cannot render {out}: {why} (GL backend {backends_tried(backend)})")


def _worker_report(stdout: str | None) -> dict[str, Any]:
    for line in reversed((stdout or "").strip().splitlines()):
        try:
            d = json.loads(line)
        except ValueError:
            continue
        if isinstance(d, dict):
            return d
    return {}


def _crash_reason(p: subprocess.CompletedProcess[str]) -> str:
    """Why a render child ended without its report: a signal (a GL driver crash) or its last line."""
    if p.returncode < 0:
        try:
            name = signal.Signals(-p.returncode).name
        except ValueError:
            name = f"signal {-p.returncode}"
        return f"the renderer was killed by {name}"
    last = _last_line(p.stderr)
    return f"the renderer stopped (exit status {p.returncode})" + (f": {last}" if last else "")


def _last_line(text: str | None) -> str:
    lines = [ln.strip() for ln in (text or "").splitlines() if ln.strip()]
    return lines[-1][:300] if lines else ""


def describe_exception(exc: BaseException, limit: int = 300) -> str:
    """One line for an error inside rendering: an OSError's reason and file; a project error's message;
    otherwise the type and the message, line breaks folded. imageio's ffmpeg errors ("Broken pipe"
    followed by the whole ffmpeg command line) are cut to their first line: ffmpeg's own reason is the
    last line it printed, which :func:`render_video` adds."""
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.strerror} ({exc.filename})" if exc.filename else exc.strerror
    elif isinstance(exc, BipedsimError):
        text = str(exc)
    else:
        text = f"{type(exc).__name__}: {str(exc).split('FFMPEG COMMAND')[0]}"
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit - 3] + "..."
