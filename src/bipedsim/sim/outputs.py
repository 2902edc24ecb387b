"""The files of a run folder, as ``bipedsim run`` and ``bipedsim render`` write them, callable from a
notebook: checking the output locations before a run, clearing what an earlier run left, saving the run
files (``trajectory.npz``, ``model.xml``) and the finishing outputs (plots, joint-angle CSV, BVH of the
simulated motion, videos); and the whole of ``bipedsim run``, :func:`run_to_folder`.

Output problems name the command line's flags (``--out``, ``--csv``, ``--video`` ...), as every check
of a run does.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.sources import clip_speed, describe_clip, step_time
from bipedsim.data import BUILTIN_WALK
from bipedsim.errors import ConfigError
from bipedsim.files import (
    NamedPath,
    OutputFolder,
    atomic_write_text,
    check_distinct_paths,
    check_output_file,
    folder_files,
    prepare_output_dir,
    progress_bar,
)
from bipedsim.model.build import check_total_mass, load_model
from bipedsim.model.ground import Ground
from bipedsim.model.humanoid import sides_note, toes_note
from bipedsim.reference.describe import pace_note
from bipedsim.render.gl import RenderError
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
from bipedsim.sim import runner
from bipedsim.sim.export import simulated_motion, write_joint_csv, write_motion_bvh
from bipedsim.sim.fidelity import Fidelity, measure_fidelity
from bipedsim.sim.push import Push, check_pushes
from bipedsim.sim.recorder import DEFAULT_RECORD_HZ, Recorder, Trajectory
from bipedsim.sim.rollout import Outcome, RolloutSpec

if TYPE_CHECKING:
    from bipedsim.sim.runner import Scenario

PathLike = str | os.PathLike[str]
FloatArray = npt.NDArray[np.float64]
#: Called as each output file is written: the path as it was given, and a video's frame count (else None).
OnWrite = Callable[[PathLike, int | None], None]
#: The humanoid's feet as recorded (trajectory.npz contact_force columns), left then right (bodies ``<side>_foot``).
PLOT_FEET = ("left", "right")
#: Runs at least this long (simulated s) show a progress bar when asked to.
PROGRESS_MIN_S = 5.0


#: The files every run writes into its folder.
RUN_FILES = (OUTCOME_FILE, TRAJECTORY_FILE, MODEL_FILE)
#: Every file a run folder may hold from bipedsim by a fixed name, in the order they are reported.
KNOWN_RUN_FILES = (*RUN_FILES, *PLOT_FILES, DEFAULT_VIDEO)
#: How error messages call the files a command writes into a run folder without a flag of their own.
FOLDER_FILE = "the --out file"
RUN_DIR_FILE = "the RUN_DIR file"


def run_outputs(out: PathLike, *, plots: bool = False, csv: PathLike | None = None,
                export_bvh: PathLike | None = None, video: PathLike | None = None,
                gif: PathLike | None = None) -> list[NamedPath]:
    """Every file ``bipedsim run`` writes, each with the flag that names it: the run files (and the plots
    with ``plots``) in the folder ``out``, then the optional files (None when not asked for)."""
    return [*folder_files(FOLDER_FILE, out, (*RUN_FILES, *(PLOT_FILES if plots else ()))),
            ("--csv", csv), ("--export-bvh", export_bvh), ("--video", video), ("--gif", gif)]


def run_inputs(config: PathLike | None = None, bvh: PathLike | None = None,
               events: PathLike | None = None) -> list[NamedPath]:
    """The files ``bipedsim run`` reads, each with the argument that names it."""
    return [("the controller file", config), ("--bvh", bvh), ("--events", events)]


def named_in(folder: PathLike, paths: Iterable[PathLike | None]) -> set[str]:
    """The names of those of ``paths`` that lie directly in ``folder`` (links resolved)."""
    here = os.path.realpath(folder)
    return {Path(p).name for p in paths if p and os.path.realpath(Path(p).parent) == here}


def check_run_outputs(out: PathLike, *, csv: PathLike | None = None, export_bvh: PathLike | None = None,
                      video: PathLike | None = None, gif: PathLike | None = None,
                      plots: bool = False) -> OutputFolder:
    """Check (and create) every output location of a run before the simulation starts: the run folder
    ``out`` and the optional files (each error names its flag), and that every file the run writes
    into the folder without being asked by name (the run files; the plots with ``plots``) is absent or
    one bipedsim wrote, unchanged (:class:`~bipedsim.files.OutputFolder`). Returns the folder, with its
    manifest."""
    prepare_output_dir(out, "--out")
    for flag, path, suffixes in (("--csv", csv, ()), ("--export-bvh", export_bvh, ()),
                                 ("--video", video, VIDEO_SUFFIXES), ("--gif", gif, (".gif",))):
        if path:
            check_output_file(path, flag, suffixes)
    folder = OutputFolder(out, "--out")
    asked = named_in(out, (csv, export_bvh, video, gif))  # named on the command line: the user's request
    folder.check_replaceable(n for n in (*RUN_FILES, *(PLOT_FILES if plots else ())) if n not in asked)
    return folder


def run_files_kept(folder: PathLike, *, trajectory: bool = True, plots: bool = False,
                   extra_files: Iterable[PathLike | None] = ()) -> tuple[list[str], set[str]]:
    """The files a run folder may hold from a run (by name) and those this run writes: the outcome and
    the model always, the trajectory when ``trajectory``, the plots when ``plots``, and any of
    ``extra_files`` (videos, CSV, BVH) that land in ``folder``. The rest of the first list, when
    present, are stale."""
    keep = {OUTCOME_FILE, MODEL_FILE}
    if trajectory:
        keep.add(TRAJECTORY_FILE)
    if plots:
        keep.update(PLOT_FILES)
    keep |= named_in(folder, extra_files)
    return list(KNOWN_RUN_FILES), keep


def clear_stale(folder: OutputFolder, *, trajectory: bool = True, plots: bool = False,
                extra_files: Iterable[PathLike | None] = ()) -> tuple[list[str], list[str]]:
    """Remove what an earlier run left in ``folder`` that this run will not rewrite (only the known run
    files, see :func:`run_files_kept`, and only those its manifest proves bipedsim wrote, unchanged),
    so the folder does not mix two runs' outputs. Returns (names removed, names left alone: files of a
    run file's name that bipedsim did not write, or that changed since)."""
    return folder.remove_stale(*run_files_kept(folder.path, trajectory=trajectory, plots=plots,
                                               extra_files=extra_files))


def hinge_table(model: mujoco.MjModel) -> tuple[list[str], list[int]]:
    """The model's hinge joints: names and qpos addresses, in joint order (what plots and CSV show)."""
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    return [model.joint(j).name for j in hinges], [int(model.jnt_qposadr[j]) for j in hinges]


def save_run_files(folder: PathLike, scenario: Scenario, recorder: Recorder, outcome: Outcome,
                   feet: Sequence[str] | None = None, start_frame: float | None = None) -> Trajectory:
    """Write ``trajectory.npz`` (everything rendering and export read: the samples, the hinge table, the
    outcome, the source file's unit and up axis; with ``start_frame``, the clip frame the run started at,
    the clip itself for the ghost and the fidelity figures) and ``model.xml`` into ``folder``, beside
    ``outcome.json``; returns the trajectory. ``feet``: the controller's foot names, when known."""
    names, qadr = hinge_table(scenario.built.model)
    info = scenario.bvh_info
    meta = {"hinge_names": names, "hinge_qadr": qadr, "outcome": outcome.outcome, "fall_time_s": outcome.fall_time_s,
            "model_hash": scenario.built.hash, "reference": scenario.source_path,
            "trimmed_frames": scenario.clip.trimmed_frames,
            "source_unit": getattr(info, "unit_scale", 1.0), "source_up": getattr(info, "up", "y"),
            "profile": scenario.profile,
            "foot_names": list(feet if feet is not None else scenario.foot_names())}
    tr = recorder.trajectory(meta)
    if start_frame is not None:
        tr.with_clip(scenario.clip.qpos, scenario.clip.frame_time, start_frame)
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
    model = load_model(folder / MODEL_FILE).model
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
        model = load_model(folder / MODEL_FILE).model
        write_joint_csv(tr, *joint_series(model, tr), csv)
        wrote(csv)
    if export_bvh:
        write_simulated_bvh(tr, scenario, export_bvh)
        wrote(export_bvh)
    for video in videos:
        path, flag = video if isinstance(video, tuple) else (video, "video")
        wrote(path, render_video(folder, path, video_options, progress=progress, out_flag=flag))
    return written


def render_folder(folder: PathLike, output: PathLike | None = None, video_options: VideoOptions | None = None, *,
                  plots: bool = False, progress: bool = False, on_write: OnWrite | None = None) -> list[Path]:
    """Render the run recorded in ``folder`` (no re-simulation) to ``output`` (.mp4 or .gif; default
    ``folder/rollout.mp4``; errors name ``-o``) and, with ``plots``, write the PNG plots into the
    folder. ``progress``: a bar on stderr; ``on_write`` is called as each file is written (a video
    with its frame count). Returns the paths written, in order.

    Before rendering, the outputs are checked against each other and the run's files, and the files
    written into the folder without being named (the default video, the plots) must be absent or ones
    bipedsim wrote there, unchanged; what is written into the folder is added to its manifest."""
    folder = Path(folder)
    out = output or str(folder / DEFAULT_VIDEO)
    plot_files = PLOT_FILES if plots else ()
    implicit = [*([] if output else [DEFAULT_VIDEO]), *plot_files]  # written into the folder unasked by name
    written = [("-o" if output else RUN_DIR_FILE, out), *folder_files(RUN_DIR_FILE, folder, plot_files)]
    check_distinct_paths(written, folder_files("the run's file", folder, (MODEL_FILE, TRAJECTORY_FILE, OUTCOME_FILE)))
    record: OutputFolder | None = None
    if implicit or named_in(folder, [out]):
        record = OutputFolder(folder, "RUN_DIR")
        record.check_replaceable(implicit, hint=" (or give -o)" if not output else "")

    def wrote(path: PathLike, frames: int | None) -> None:
        if record is not None:
            record.record(path)
        if on_write is not None:
            on_write(path, frames)

    frames = render_video(folder, out, video_options or VideoOptions(), progress=progress, out_flag="-o")
    wrote(out, frames)
    return [Path(out), *(finish_outputs(folder, plots=True, on_write=wrote) if plots else [])]


# ---------------------------------------------------------------------- the whole run
def check_run_options(*, profile: str | None = None, support: bool = False, bvh: PathLike | None = None,
                      scale: float | str | None = None, up: str | None = None, init_noise: float = 0.0,
                      seed: int = 0, positions: str | None = None, mass: float | None = None,
                      fps: float | None = None) -> None:
    """Refuse run options that would be ignored or meaningless, before anything runs: each error names
    the flag and what is allowed. Ranges of the run length and pushes are checked by
    :func:`~bipedsim.sim.push.check_pushes`, the video options by :meth:`VideoOptions.validate`."""
    if support and (profile == "humanoid" or bvh is None):  # a creature's, given or detected
        raise ConfigError("holds a creature's root; it needs --profile creature", key="--support")
    if bvh is None:
        for flag, value, what in (("--scale", scale, "unit"), ("--up", up, "up axis"),
                                  ("--positions", positions, "position-channel mode"),
                                  ("--clip-fps", fps, "frame rate")):
            if value is not None:
                raise ConfigError(f"sets the {what} of a --bvh file; the built-in walk's {what} is known "
                                  f"(give --bvh FILE or drop {flag})", key=flag)
    if not (math.isfinite(init_noise) and init_noise >= 0):
        raise ConfigError(f"must be a standard deviation >= 0 (rad/s, m/s), got {init_noise}", key="--init-noise")
    if seed < 0:
        raise ConfigError(f"must be a whole number >= 0, got {seed}", key="--seed")
    check_total_mass(mass)


def found_lines(sc: Scenario) -> list[str]:
    """What reading a ``--bvh`` humanoid's clip found (feet, strikes, cycle, speeds, what preparing the
    motion did) and how the controller was scaled to the body; for the built-in walk only the latter,
    nothing for a creature."""
    if sc.profile != "humanoid":
        return []
    scaled = [f"controller: {sc.extra['body_scale']}"] if "body_scale" in sc.extra else []
    searched = sc.extra["reconstruct"].split("\n") if "reconstruct" in sc.extra else []
    if sc.bvh_info is None or sc.source_path == str(BUILTIN_WALK):
        return scaled + searched
    notes = [f"note: {n}" for n in [sc.bvh_info.reading_note, *sc.bvh_info.notes] if n]
    notes += [f"body: {n}" for n in (sides_note(sc.built.plan.extra), toes_note(sc.built.plan.extra)) if n]
    if "feasible" in sc.extra:
        notes.append("reference: legs made feasible for the body (" + "; ".join(sc.extra["feasible"]) + ")")
    notes += searched
    pace = pace_note(clip_speed(sc.clip), sc.bvh_info, step_time(sc.clip))
    return notes + scaled + describe_clip(sc.clip, sc.built.model, sc.built.plan) + ([f"pace: {pace}"] if pace else [])


def check_run_length(seconds: float, timestep: float) -> None:
    """Refuse a run shorter than one physics step (``timestep``, s): it would take no step and record
    nothing (the upper bound is :func:`~bipedsim.sim.push.check_pushes`'s)."""
    if seconds < timestep:
        raise ConfigError(f"must be at least one physics step ({timestep:g} s), got {seconds:g}", key="--seconds")


def outcome_line(out: Outcome, sc: Scenario) -> str:
    """One line: the verdict and the run's figures (s, m, m/s, rad); a supported creature says how much
    it was helped (N)."""
    fall = f" at {out.fall_time_s:.2f} s ({out.fall_reason})" if out.fall_time_s is not None else ""
    body = "" if sc.profile == "humanoid" else f"{sc.profile}, {sc.built.summary()['bodies']} bodies, "
    e = out.extra
    sup = "" if not e.get("support_mode") else (
        f"; ROOT SUPPORT assisted: mean {e.get('support_force_mean_n', 0):.0f} N (body weight {e['weight_n']:.0f} N), "
        f"peak {e.get('support_force_max_n', 0):.0f} N")
    cv = out.extra.get("clip_speed_mps")
    clip_v = f", whole clip {cv:.2f} m/s" if cv is not None else ""
    course = "" if out.course_speed_mps is None else (
        f", {out.course_speed_mps:.2f} m/s along the reference's course, {out.course_offset_m:+.2f} m off it")
    return (f"{out.outcome}{fall}: {body}{out.sim_seconds:.2f} s simulated in {out.wall_seconds:.1f} s, "
            f"{out.foot_strikes} foot strikes, {out.distance_m:.2f} m at {out.mean_speed_mps:.2f} m/s{course} "
            f"(reference loop {out.reference_speed_mps:.2f} m/s{clip_v}), "
            f"tracking RMSE {out.tracking_rmse_rad:.3f} rad{sup}")


def run_fidelity(sc: Scenario, recorder: Recorder, start_frame: float | None, outcome: Outcome) -> Fidelity | None:
    """The run against its clip (:func:`~bipedsim.sim.fidelity.measure_fidelity`) from the samples
    recorded so far, the run having started at clip frame ``start_frame`` and lasted
    ``outcome.sim_seconds``; None for a run that tracks no clip (``start_frame`` None: key poses) or
    has nothing to compare."""
    if start_frame is None or not recorder.num_samples:
        return None
    tr = recorder.trajectory()
    return measure_fidelity(sc.built.model, tr.time, tr.qpos, sc.clip.qpos, sc.clip.frame_time, start_frame,
                            run_seconds=outcome.sim_seconds)


@dataclass
class RunResult:
    """What :func:`run_to_folder` ran and wrote: the folder, the outcome, the scenario, the trajectory
    and every file written, in order."""

    folder: Path
    outcome: Outcome
    scenario: Scenario
    trajectory: Trajectory
    written: list[Path] = field(default_factory=list)


def _timed_bar(seconds: float, show: bool) -> tuple[Callable[[float], None], Callable[[], None]]:
    """A progress callback (simulated time, s) and a close for a run of ``seconds``: a bar on stderr
    when ``show`` and the run lasts at least :data:`PROGRESS_MIN_S`, else nothing."""
    bar = progress_bar(seconds, "bipedsim run", "sim s") if show and seconds >= PROGRESS_MIN_S else None

    def progress(t: float) -> None:
        if bar is not None:
            bar.n = round(t, 2)
            bar.refresh()

    return progress, (bar.close if bar is not None else lambda: None)


def run_to_folder(out: PathLike, *, config: PathLike | None = None, bvh: PathLike | None = None,
                  seconds: float = 10.0, seed: int = 0, init_noise: float = 0.0, mass: float | None = None,
                  scale: float | str | None = None, up: str | None = None, positions: str | None = None,
                  fps: float | None = None,
                  events: PathLike | None = None, profile: str | None = None, support: bool = False,
                  reconstruct: bool | None = None,
                  record_hz: float = DEFAULT_RECORD_HZ, pushes: Sequence[str | Push] = (),
                  plots: bool = False, csv: PathLike | None = None, export_bvh: PathLike | None = None,
                  video: PathLike | None = None, gif: PathLike | None = None,
                  video_options: VideoOptions | None = None, progress: bool = False,
                  say: Callable[[str], None] | None = None,
                  ground: Sequence[str] | Ground | None = None) -> RunResult:
    """Everything ``bipedsim run`` does: track the reference (``bvh``, else the built-in walk; its
    ``scale``, ``up``, ``positions``, ``fps``: see :func:`~bipedsim.motion.bvh.read_bvh`; ``events``: a YAML of
    foot strikes given by hand, :func:`~bipedsim.reference.gait_events.load_events`) with the controller
    YAML ``config`` on the ``profile`` body (``mass`` in kg;
    ``support``: hold a creature's root) for ``seconds`` (simulated s) from ``seed`` (``init_noise``:
    initial velocity std, rad/s and m/s) with ``pushes`` (``MAG:DIR:DUR:START`` strings or
    :class:`Push`), recording ``record_hz`` samples/s; write ``outcome.json``, ``trajectory.npz`` and
    ``model.xml`` into the folder ``out`` (removing what an earlier run left there that this one does
    not rewrite, when the folder's manifest proves bipedsim wrote it; see :func:`clear_stale`), then
    the optional plots, ``csv``, ``export_bvh``, ``video`` and ``gif``; each file written into ``out``
    is added to its manifest.

    Every option and output location is checked before the simulation (errors name the command
    line's flags): outputs that would overwrite each other or an input, and files of the folder the
    run would replace without being asked that bipedsim cannot prove it wrote, are refused.
    ``progress``: bars on stderr (pass ``sys.stderr.isatty()``). ``say`` gets each line
    the command prints, as it happens. A video that cannot be rendered raises :class:`RenderError`
    saying the results are in the folder. ``ground``: the ground's terms (``--ground``, see
    :class:`~bipedsim.model.ground.Ground`) or a parsed one; None: flat."""
    say = say or (lambda line: None)
    ground = ground if isinstance(ground, Ground) else Ground.parse(ground, key="--ground")
    options = video_options or VideoOptions()
    # outputs that would overwrite each other or an input: refused before anything is read or made
    check_distinct_paths(run_outputs(out, plots=plots, csv=csv, export_bvh=export_bvh, video=video, gif=gif),
                         run_inputs(config, bvh, events))
    check_run_options(profile=profile, support=support, bvh=bvh, scale=scale, up=up, init_noise=init_noise,
                      seed=seed, positions=positions, mass=mass, fps=fps)
    options.validate()
    pushes = [p if isinstance(p, Push) else Push.parse(p) for p in pushes]
    check_pushes(pushes, seconds)  # the run length too, before anything is built
    sc = runner.load_scenario(config, bvh, scale=scale, up=up, mass=mass, profile=profile, support=support,
                              positions=positions, events=events, fps=fps, reconstruct=reconstruct, ground=ground)
    check_run_length(seconds, sc.built.model.opt.timestep)
    for line in found_lines(sc):
        say(line)
    probe = sc.controller()  # asked once, before the run, for what the checks and the recorder need
    sc.check_pushes(pushes, probe)
    feet = sc.foot_names(probe)
    rec = Recorder(sc.built.model, record_hz=record_hz, seconds=seconds, key="--record-hz", feet=len(feet))
    outdir = check_run_outputs(out, csv=csv, export_bvh=export_bvh, video=video, gif=gif, plots=plots)
    folder = outdir.path
    tick, close = _timed_bar(seconds, progress)
    outcome, ctrl = runner.run_scenario(sc, RolloutSpec(seconds=seconds, seed=seed, init_noise=init_noise),
                                        progress=tick, hooks=[rec], pushes=pushes)
    close()
    if sc.profile == "humanoid":
        outcome.extra["clip_speed_mps"] = clip_speed(sc.clip)
    start = float(ctrl.start_frame()) if sc.tracks_clip else None
    fidelity = run_fidelity(sc, rec, start, outcome)
    outcome.fidelity = fidelity.to_dict() if fidelity is not None else None
    removed, left = clear_stale(outdir, plots=plots, extra_files=(video, gif, csv, export_bvh))
    if removed:
        say(f"removed from an earlier run in {folder}: {', '.join(removed)}")
    if left:
        say(f"left alone in {folder}: {', '.join(left)} (not written there by bipedsim, or changed since)")
    path = runner.write_outcome(outcome, folder)
    outdir.record(path)
    tr = save_run_files(folder, sc, rec, outcome, feet, start_frame=start)
    outdir.record(folder / TRAJECTORY_FILE, folder / MODEL_FILE)
    del rec  # the trajectory holds the samples
    say(outcome_line(outcome, sc))
    if fidelity is not None:
        say(fidelity.describe())
    for why in outcome.extra.get("pushes_not_applied", []):
        say(f"  push not applied: {why}")
    say(f"wrote {path}, {folder / TRAJECTORY_FILE}, {folder / MODEL_FILE}")
    result = RunResult(folder, outcome, sc, tr, [path, folder / TRAJECTORY_FILE, folder / MODEL_FILE])
    videos = [(v, flag) for v, flag in ((video, "--video"), (gif, "--gif")) if v]
    try:
        result.written += finish_outputs(folder, plots=plots, csv=csv, export_bvh=export_bvh, videos=videos,
                                         video_options=options, scenario=sc, trajectory=tr, progress=progress,
                                         on_write=lambda p, n: (outdir.record(p), say(written_line(p, n))))
    except RenderError as exc:
        raise RenderError(f"{exc} The simulation results were written to {folder}; render them later "
                          f"with `bipedsim render {folder}`.") from None
    return result


def written_line(path: PathLike, frames: int | None = None) -> str:
    """``wrote PATH``, with a video's frame count when given."""
    return f"wrote {path}" + ("" if frames is None else f" ({frames} frames)")
