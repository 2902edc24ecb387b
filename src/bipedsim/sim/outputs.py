"""The files of a run folder, as ``bipedsim run`` and ``bipedsim render`` write them, callable from a
notebook: checking the output locations before a run, clearing what an earlier run left, saving the run
files (``trajectory.npz``, ``model.xml``) and the finishing outputs (plots, joint-angle CSV, BVH of the
simulated motion, videos).

Output problems name the command line's flags (``--out``, ``--csv``, ``--video`` ...), as every check
of a run does.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.io import atomic_write_text, check_output_file, prepare_output_dir, remove_stale
from bipedsim.render.plots import PLOT_FILES, plot_run
from bipedsim.render.video import (
    DEFAULT_VIDEO,
    MODEL_FILE,
    OUTCOME_FILE,
    TRAJECTORY_FILE,
    VIDEO_SUFFIXES,
    VideoOptions,
    render_video,
)
from bipedsim.sim.export import simulated_motion, write_joint_csv, write_motion_bvh
from bipedsim.sim.recorder import Trajectory

if TYPE_CHECKING:
    from bipedsim.sim.recorder import Recorder
    from bipedsim.sim.rollout import Outcome
    from bipedsim.sim.runner import Scenario

PathLike = str | os.PathLike[str]
FloatArray = npt.NDArray[np.float64]
#: Called as each output file is written: the path as it was given, and a video's frame count (else None).
OnWrite = Callable[[PathLike, int | None], None]
#: The feet whose positions the top-view plot marks, left then right (bodies ``<side>_foot``).
PLOT_FEET = ("left", "right")


def check_run_outputs(out: PathLike, *, csv: PathLike | None = None, export_bvh: PathLike | None = None,
                      video: PathLike | None = None, gif: PathLike | None = None) -> Path:
    """Check (and create) every output location of a run before the simulation starts: the run folder
    ``out`` and the optional files (each error names its flag); returns the run folder."""
    folder = prepare_output_dir(out, "--out")
    for flag, path, suffixes in (("--csv", csv, ()), ("--export-bvh", export_bvh, ()),
                                 ("--video", video, VIDEO_SUFFIXES), ("--gif", gif, (".gif",))):
        if path:
            check_output_file(path, flag, suffixes)
    return folder


def run_files_kept(folder: PathLike, *, trajectory: bool = True, plots: bool = False,
                   extra_files: Iterable[PathLike | None] = ()) -> tuple[list[str], set[str]]:
    """The files a run folder may hold from a run (by name) and those this run writes: the outcome and
    the model always, the trajectory when ``trajectory``, the plots when ``plots``, and any of
    ``extra_files`` (videos, CSV, BVH) that land in ``folder``. The rest of the first list, when
    present, are stale."""
    known = [OUTCOME_FILE, TRAJECTORY_FILE, MODEL_FILE, *PLOT_FILES, DEFAULT_VIDEO]
    keep = {OUTCOME_FILE, MODEL_FILE}
    if trajectory:
        keep.add(TRAJECTORY_FILE)
    if plots:
        keep.update(PLOT_FILES)
    for extra in extra_files:
        if extra and Path(extra).resolve().parent == Path(folder).resolve():
            keep.add(Path(extra).name)
    return known, keep


def clear_stale(folder: PathLike, *, trajectory: bool = True, plots: bool = False,
                extra_files: Iterable[PathLike | None] = ()) -> list[str]:
    """Remove what an earlier run left in ``folder`` that this run will not rewrite (only the known run
    files, see :func:`run_files_kept`), so the folder never mixes two runs' outputs; returns the names
    removed."""
    return remove_stale(folder, *run_files_kept(folder, trajectory=trajectory, plots=plots, extra_files=extra_files))


def hinge_table(model: mujoco.MjModel) -> tuple[list[str], list[int]]:
    """The model's hinge joints: names and qpos addresses, in joint order (what plots and CSV show)."""
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    return [model.joint(j).name for j in hinges], [int(model.jnt_qposadr[j]) for j in hinges]


def save_run_files(folder: PathLike, scenario: Scenario, recorder: Recorder, outcome: Outcome) -> Trajectory:
    """Write ``trajectory.npz`` (everything rendering and export read: the samples, the hinge table, the
    outcome, the source file's unit and up axis) and ``model.xml`` into ``folder``, beside
    ``outcome.json``; returns the trajectory."""
    names, qadr = hinge_table(scenario.built.model)
    info = scenario.bvh_info
    meta = {"hinge_names": names, "hinge_qadr": qadr, "outcome": outcome.outcome, "fall_time_s": outcome.fall_time_s,
            "model_hash": scenario.built.hash, "reference": scenario.source_path,
            "trimmed_frames": scenario.clip.trimmed_frames,
            "source_unit": getattr(info, "unit_scale", 1.0), "source_up": getattr(info, "up", "y"),
            "profile": scenario.profile,
            "foot_names": list(scenario.foot_names())}
    tr = recorder.trajectory(meta)
    tr.save(Path(folder) / TRAJECTORY_FILE)
    atomic_write_text(Path(folder) / MODEL_FILE, scenario.built.xml)
    return tr


def foot_names(tr: Trajectory) -> list[str]:
    """The feet of ``contact_force``'s columns: the humanoid's left and right, a creature's foot bodies."""
    return list(tr.meta.get("foot_names") or PLOT_FEET)


def joint_series(model: mujoco.MjModel, tr: Trajectory) -> tuple[list[str], FloatArray, FloatArray]:
    """(names, simulated, reference) joint angles (rad) per sample, shape (T, J): each hinge's angle;
    for a body of ball joints (a creature), each ball joint's rotation angle from its rest pose."""
    names, qadr = tr.meta.get("hinge_names", []), tr.meta.get("hinge_qadr", [])
    if names:
        return list(names), tr.qpos[:, qadr], tr.ref_qpos[:, qadr].astype(np.float64)
    balls = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
    w = np.array([model.jnt_qposadr[j] for j in balls], dtype=np.int64)

    def angle(q: FloatArray) -> FloatArray:
        return 2.0 * np.arccos(np.clip(np.abs(q[:, w]), 0.0, 1.0))

    return [model.joint(j).name for j in balls], angle(tr.qpos), angle(tr.ref_qpos.astype(np.float64))


def foot_tracks(model: mujoco.MjModel, tr: Trajectory) -> npt.NDArray[np.float64]:
    """Positions (m, world x and y) of the feet (:func:`foot_names`) per sample, shape (T, feet, 2)."""
    data = mujoco.MjData(model)
    feet = [model.body(f if f not in PLOT_FEET else f"{f}_foot").id for f in foot_names(tr)]
    xy = np.zeros((tr.num_samples, len(feet), 2))
    for i in range(tr.num_samples):
        data.qpos[:] = tr.qpos[i]
        mujoco.mj_kinematics(model, data)
        xy[i] = data.xpos[feet, :2]
    return xy


def write_plots(folder: PathLike, tr: Trajectory | None = None) -> list[Path]:
    """The PNG plots (:data:`~bipedsim.render.plots.PLOT_FILES`) of the run in ``folder`` (its
    ``model.xml``, and its ``trajectory.npz`` unless ``tr`` is given) written into it; returns their paths."""
    folder = Path(folder)
    if tr is None:
        tr = Trajectory.load(folder / TRAJECTORY_FILE)
    model = mujoco.MjModel.from_xml_path(str(folder / MODEL_FILE))
    names, q, qr = joint_series(model, tr)
    return plot_run(tr, names, q, qr, foot_tracks(model, tr), foot_names(tr), folder)


def write_simulated_bvh(tr: Trajectory, scenario: Scenario, path: PathLike) -> None:
    """The simulated motion on the source skeleton, as BVH in the source file's unit and up axis; the
    joints the body lacks follow the reference frame each sample tracked."""
    src = scenario.motion
    frames = np.round(tr.ref_frame).astype(int) + scenario.clip.trimmed_frames
    motion = simulated_motion(tr, scenario.built.model, scenario.built.plan, src, frames % src.num_frames)
    write_motion_bvh(motion, path, unit=tr.meta["source_unit"], up=tr.meta["source_up"])


def finish_outputs(folder: PathLike, *, plots: bool = False, csv: PathLike | None = None,
                   export_bvh: PathLike | None = None, videos: Iterable[PathLike | tuple[PathLike, str]] = (),
                   video_options: VideoOptions | None = None, scenario: Scenario | None = None,
                   trajectory: Trajectory | None = None, progress: bool = False,
                   on_write: OnWrite | None = None) -> list[Path]:
    """Write the optional outputs of the run in ``folder``: the PNG plots into it (``plots``), joint
    angles as CSV, the simulated motion as BVH (``export_bvh``; needs the run's ``scenario``) and each
    of ``videos`` (a path, or a path and the flag that named it for error messages) -- videos last,
    since they may fail without GL. ``trajectory``: the run's trajectory when in memory (else read from
    the folder). ``progress``: a bar on stderr while rendering (pass ``sys.stderr.isatty()``).
    ``on_write`` is called as each file is written. Returns the paths written, in order."""
    if export_bvh and scenario is None:
        raise ValueError("export_bvh needs the run's scenario (the source motion and the built body)")
    folder = Path(folder)
    written: list[Path] = []

    def wrote(path: PathLike, frames: int | None = None) -> None:
        written.append(Path(path))
        if on_write is not None:
            on_write(path, frames)

    tr = trajectory
    if tr is None and (plots or csv or export_bvh):
        tr = Trajectory.load(folder / TRAJECTORY_FILE)
    if plots:
        for p in write_plots(folder, tr):
            wrote(p)
    if csv:
        model = mujoco.MjModel.from_xml_path(str(folder / MODEL_FILE))
        write_joint_csv(tr, *joint_series(model, tr), csv)
        wrote(csv)
    if export_bvh:
        write_simulated_bvh(tr, scenario, export_bvh)
        wrote(export_bvh)
    for video in videos:
        path, flag = video if isinstance(video, tuple) else (video, "video")
        wrote(path, render_video(folder, path, video_options, progress=progress, out_flag=flag))
    return written
