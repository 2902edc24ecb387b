"""The ``bipedsim`` command.

Each subcommand is a function ``cmd_<name>(args) -> int`` registered in :data:`COMMANDS`. Errors a
user can cause are :class:`~bipedsim.errors.BipedsimError`: the message is printed to stderr and the
exit status is 2, without a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from bipedsim import __version__
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.io import check_output_file, describe_os_error, prepare_output_dir, progress_bar, read_text_file

if TYPE_CHECKING:
    from bipedsim.sim.recorder import Trajectory
    from bipedsim.sim.rollout import Outcome
    from bipedsim.sim.runner import Scenario


def _scale_arg(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


# ---------------------------------------------------------------------- info
def cmd_info(args: argparse.Namespace) -> int:
    from bipedsim.data import builtin_walk_path
    from bipedsim.motion.describe import describe_bvh, format_description

    d = describe_bvh(args.file or str(builtin_walk_path()), scale=args.scale, up=args.up)
    print(json.dumps(d, indent=2) if args.json else format_description(d))
    return 0


def _add_info(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("info", help="describe a BVH file (joints, frames, units, up axis, speed)")
    p.add_argument("file", nargs="?", help="BVH file (default: the built-in reference walk)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.add_argument("--scale", type=_scale_arg, default=None,
                   help="metres per file unit, or a unit name (m, dm, cm, mm, inch, cmu, ft); "
                        "guessed when omitted")
    p.add_argument("--up", choices=("y", "z"), default=None, help="the file's up axis (guessed when omitted)")
    p.set_defaults(func=cmd_info)


# ---------------------------------------------------------------------- convert
def cmd_convert(args: argparse.Namespace) -> int:
    from bipedsim.model import build_model, retarget
    from bipedsim.model.naming import load_map
    from bipedsim.motion.bvh import read_bvh

    motion, info = read_bvh(args.input, scale=args.scale, up=args.up)
    motion = motion.to_project_frame()
    check_output_file(args.output, "-o")
    if args.clip:
        check_output_file(args.clip, "--clip")
    mapping = load_map(args.map, motion.skeleton) if args.map else None
    profile = args.profile_file or args.profile
    built = build_model(motion, profile, total_mass=args.mass, mapping=mapping, name=Path(args.output).stem)
    built.write(args.output)
    summary = built.summary()
    summary.update({"source": str(args.input), "output": str(args.output),
                    "unit": f"{info.unit_name} ({info.unit_source})", "up": f"{info.up} ({info.up_source})"})
    if args.clip:
        clip = retarget(motion, built.model, plan=built.plan, xml=built.xml, source=str(args.input))
        clip.save(args.clip)
        summary["clip"] = {"path": str(args.clip), "frames": clip.num_frames,
                           "trimmed_frames": clip.trimmed_frames,
                           "strikes": {f: len(e["strike"]) for f, e in clip.events.items()}}
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"wrote {args.output}: {summary['bodies']} bodies, {summary['dofs']} DOFs "
              f"({summary['actuated_dofs']} actuated), {summary['total_mass_kg']:.1f} kg, "
              f"{summary['height_m']:.2f} m tall, profile {summary['profile']}, timestep {summary['timestep_s']} s")
        if args.clip:
            c = summary["clip"]
            print(f"wrote {args.clip}: {c['frames']} frames, foot strikes {c['strikes']}"
                  + (f", dropped {c['trimmed_frames']} leading glitch frame(s)" if c["trimmed_frames"] else ""))
    return 0


def _add_convert(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("convert", help="build an MJCF body from a BVH skeleton (and its reference clip)")
    p.add_argument("input", help="BVH file")
    p.add_argument("-o", "--output", required=True, help="MJCF file to write")
    p.add_argument("--profile", choices=("humanoid", "creature"), default="humanoid")
    p.add_argument("--profile-file", default=None, help="a profile YAML (overrides --profile)")
    p.add_argument("--mass", type=float, default=None, help="total body mass in kg (scales every segment)")
    p.add_argument("--map", default=None, help="mapping YAML naming the humanoid roles' joints")
    p.add_argument("--clip", default=None, help="also retarget the motion and write this .npz reference clip")
    p.add_argument("--scale", type=_scale_arg, default=None, help="metres per file unit or a unit name")
    p.add_argument("--up", choices=("y", "z"), default=None, help="the file's up axis")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_convert)


# ---------------------------------------------------------------------- run
#: Trajectory samples per second when --record-hz is not given.
DEFAULT_RECORD_HZ = 120.0


def check_run_args(args: argparse.Namespace) -> None:
    """Refuse `bipedsim run` flags that would be ignored or meaningless, before anything runs: each
    error names the flag and what is allowed. Ranges of the run length and pushes are checked by
    :func:`~bipedsim.sim.push.check_pushes`, the video flags by :meth:`VideoOptions.validate`."""
    if args.support and args.profile != "creature":
        raise ConfigError("holds a creature's root; it needs --profile creature", key="--support")
    if args.bvh is None:
        for flag, value, what in (("--scale", args.scale, "unit"), ("--up", args.up, "up axis")):
            if value is not None:
                raise ConfigError(f"sets the {what} of a --bvh file; the built-in walk's {what} is known "
                                  f"(give --bvh FILE or drop {flag})", key=flag)
    if not (math.isfinite(args.init_noise) and args.init_noise >= 0):
        raise ConfigError(f"must be a standard deviation >= 0 (rad/s, m/s), got {args.init_noise}",
                          key="--init-noise")
    if args.seed < 0:
        raise ConfigError(f"must be a whole number >= 0, got {args.seed}", key="--seed")


def check_run_length(seconds: float, timestep: float) -> None:
    """Refuse a run shorter than one physics step (``timestep``, s): it would take no step and record
    nothing (the upper bound is :func:`~bipedsim.sim.push.check_pushes`'s)."""
    if seconds < timestep:
        raise ConfigError(f"must be at least one physics step ({timestep:g} s), got {seconds:g}", key="--seconds")


def _print_removed(folder: Path, removed: list[str]) -> None:
    if removed:
        print(f"removed from an earlier run in {folder}: {', '.join(removed)}")


def cmd_run(args: argparse.Namespace) -> int:
    from bipedsim.sim.outputs import check_run_outputs, clear_stale, save_run_files
    from bipedsim.sim.push import Push, check_pushes
    from bipedsim.sim.recorder import Recorder
    from bipedsim.sim.rollout import RolloutSpec
    from bipedsim.sim.runner import load_scenario, run_scenario, write_outcome

    check_run_args(args)
    video_options(args).validate()
    pushes = [Push.parse(x) for x in (args.push or [])]
    check_pushes(pushes, args.seconds)  # the run length too, before anything is built
    sc = load_scenario(args.config, args.bvh, scale=args.scale, up=args.up, mass=args.mass, profile=args.profile,
                       support=args.support)
    check_run_length(args.seconds, sc.built.model.opt.timestep)
    sc.check_pushes(pushes)
    hz = DEFAULT_RECORD_HZ if args.record_hz is None else args.record_hz
    rec = Recorder(sc.built.model, record_hz=hz, seconds=args.seconds, key="--record-hz",
                   feet=len(sc.foot_names()))
    folder = check_run_outputs(args.out, csv=args.csv, export_bvh=args.export_bvh, video=args.video, gif=args.gif)
    spec = RolloutSpec(seconds=args.seconds, seed=args.seed, init_noise=args.init_noise)
    bar = progress_bar(args.seconds, "bipedsim run", "sim s") if args.seconds >= 5 else None

    def progress(t: float) -> None:
        if bar is not None:
            bar.n = round(t, 2)
            bar.refresh()

    out, _ = run_scenario(sc, spec, progress=progress, hooks=[rec], pushes=pushes)
    if bar is not None:
        bar.close()
    _print_removed(folder, clear_stale(folder, plots=args.plots,
                                       extra_files=(args.video, args.gif, args.csv, args.export_bvh)))
    path = write_outcome(out, folder)
    tr = save_run_files(folder, sc, rec, out)
    del rec  # the trajectory holds the samples
    print(outcome_line(out, sc))
    for why in out.extra.get("pushes_not_applied", []):
        print(f"  push not applied: {why}")
    print(f"wrote {path}, {folder / 'trajectory.npz'}, {folder / 'model.xml'}")
    return _finish_run(args, folder, sc, tr)


def outcome_line(out: Outcome, sc: Scenario) -> str:
    """One line: the verdict and the run's figures; a supported creature says how much it was helped."""
    fall = f" at {out.fall_time_s:.2f} s ({out.fall_reason})" if out.fall_time_s is not None else ""
    body = "" if sc.profile == "humanoid" else f"{sc.profile}, {sc.built.summary()['bodies']} bodies, "
    e = out.extra
    sup = "" if not e.get("support_mode") else (
        f"; ROOT SUPPORT assisted: mean {e.get('support_force_mean_n', 0):.0f} N (body weight {e['weight_n']:.0f} N), "
        f"peak {e.get('support_force_max_n', 0):.0f} N")
    return (f"{out.outcome}{fall}: {body}{out.sim_seconds:.2f} s simulated in {out.wall_seconds:.1f} s, "
            f"{out.foot_strikes} foot strikes, {out.distance_m:.2f} m at {out.mean_speed_mps:.2f} m/s "
            f"(reference {out.reference_speed_mps:.2f} m/s), tracking RMSE {out.tracking_rmse_rad:.3f} rad{sup}")


def _print_written(path: object, frames: int | None) -> None:
    print(f"wrote {path}" + ("" if frames is None else f" ({frames} frames)"))


def _finish_run(args: argparse.Namespace, folder: Path, sc: Scenario, tr: Trajectory) -> int:
    """The optional outputs of `bipedsim run`, each printed as it is written."""
    from bipedsim.render.gl import RenderError
    from bipedsim.sim.outputs import finish_outputs

    videos = [(v, flag) for v, flag in ((args.video, "--video"), (args.gif, "--gif")) if v]
    try:
        finish_outputs(folder, plots=args.plots, csv=args.csv, export_bvh=args.export_bvh, videos=videos,
                       video_options=video_options(args), scenario=sc, trajectory=tr,
                       progress=sys.stderr.isatty(), on_write=_print_written)
    except RenderError as exc:
        raise RenderError(f"{exc} The simulation results were written to {folder}; render them later "
                          f"with `bipedsim render {folder}`.") from None
    return 0


def video_options(args: argparse.Namespace):  # noqa: ANN201
    from bipedsim.render.video import VideoOptions

    return VideoOptions(width=args.width, height=args.height, fps=args.fps, speed=args.speed,
                        distance=args.cam_distance, elevation=args.cam_elevation, azimuth=args.cam_azimuth,
                        ghost=args.ghost)


def _video_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("video")
    g.add_argument("--width", type=int, default=640)
    g.add_argument("--height", type=int, default=480)
    g.add_argument("--fps", type=float, default=30.0)
    g.add_argument("--speed", type=float, default=1.0, help="playback speed (0.5 = slow motion)")
    g.add_argument("--cam-distance", type=float, default=3.5, help="camera distance (m)")
    g.add_argument("--cam-elevation", type=float, default=-15.0, help="camera elevation (degrees)")
    g.add_argument("--cam-azimuth", type=float, default=120.0, help="camera azimuth (degrees)")
    g.add_argument("--ghost", action="store_true", help="draw the reference pose as a translucent ghost")


def cmd_render(args: argparse.Namespace) -> int:
    from bipedsim.render.video import DEFAULT_VIDEO, render_video

    folder = Path(args.run_dir)
    out = args.output or str(folder / DEFAULT_VIDEO)
    n = render_video(folder, out, video_options(args), progress=sys.stderr.isatty(), out_flag="-o")
    print(f"wrote {out} ({n} frames)")
    if args.plots:
        from bipedsim.sim.outputs import finish_outputs

        finish_outputs(folder, plots=True, on_write=_print_written)
    return 0


def _add_render(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("render", help="render a recorded run folder to mp4/gif (no re-simulation)")
    p.add_argument("run_dir", help="folder written by `bipedsim run` (model.xml, trajectory.npz)")
    p.add_argument("-o", "--output", default=None, help="video file, .mp4 or .gif (default RUN_DIR/rollout.mp4)")
    p.add_argument("--plots", action="store_true", help="also write the PNG plots into RUN_DIR")
    _video_args(p)
    p.set_defaults(func=cmd_render)


def _add_run(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("run", help="track a reference walk with the balance controller and report the outcome")
    p.add_argument("config", nargs="?", default=None, help="controller YAML (default: controllers/default.yaml)")
    p.add_argument("--bvh", default=None, help="reference BVH (default: the built-in walk on the built-in humanoid)")
    p.add_argument("--seconds", type=float, default=10.0, help="simulated seconds (default 10)")
    p.add_argument("--seed", type=int, default=0, help="random seed, recorded with the outcome")
    p.add_argument("--init-noise", type=float, default=0.0, help="initial velocity noise (std) drawn from the seed")
    p.add_argument("--out", default="bipedsim_run", help="output folder for outcome.json (default bipedsim_run)")
    p.add_argument("--mass", type=float, default=None, help="total body mass in kg")
    p.add_argument("--scale", type=_scale_arg, default=None, help="BVH metres per unit or unit name")
    p.add_argument("--up", choices=("y", "z"), default=None, help="BVH up axis")
    p.add_argument("--profile", choices=("humanoid", "creature"), default="humanoid",
                   help="humanoid (balance controller) or creature (PD tracking of every joint)")
    p.add_argument("--support", action="store_true",
                   help="creature only: hold the root toward the clip with an external, reported wrench "
                        "(root-support mode, e.g. for flying clips)")
    p.add_argument("--record-hz", type=float, default=None,
                   help=f"trajectory samples per second (default {DEFAULT_RECORD_HZ:g})")
    p.add_argument("--push", action="append", metavar="MAG:DIR:DUR:START",
                   help="push the torso: N, degrees from heading (0 forward, 90 left), s, start s "
                        "(or sSTATE.FRACTION, e.g. s2.5); repeatable; a push must end within --seconds")
    p.add_argument("--video", default=None, help="render the rollout to this .mp4 (or .gif)")
    p.add_argument("--gif", default=None, help="render the rollout to this .gif")
    p.add_argument("--plots", action="store_true", help="write PNG plots into --out")
    p.add_argument("--export-bvh", default=None, help="write the simulated motion as BVH on the source skeleton")
    p.add_argument("--csv", default=None, help="write joint angles (simulated and reference) as CSV")
    _video_args(p)
    p.set_defaults(func=cmd_run)


# ---------------------------------------------------------------------- breed
def _weight(text: str) -> tuple[str, float]:
    name, sep, val = text.rpartition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected JOINT=WEIGHT, got {text!r}")
    try:
        return name, float(val)
    except ValueError:
        raise argparse.ArgumentTypeError(f"weight must be a number in {text!r}") from None


def cmd_breed(args: argparse.Namespace) -> int:
    from bipedsim.breed.evolve import breed, load_joint_map
    from bipedsim.io import atomic_write_json
    from bipedsim.motion.bvh import load_bvh, write_bvh

    a, b = load_bvh(args.parent_a), load_bvh(args.parent_b)
    check_output_file(args.output, "-o")
    if args.report:
        check_output_file(args.report, "--report")
    mapping = load_joint_map(args.map, a.skeleton, b.skeleton) if args.map else None
    child, report = breed(a, b, x=args.x, mutations=args.mutations, weights=dict(args.weight or []),
                          mapping=mapping, names=(str(args.parent_a), str(args.parent_b)))
    # written as most BVH files are: Y up, centimetres
    write_bvh(child.with_up("y").scaled(100.0), args.output, precision=6)
    print(f"wrote {args.output}: {report.child_joints} joints, {report.child_frames} frames; common "
          f"{len(report.kept_common)}, from A only {len(report.only_a)}, from B only {len(report.only_b)}; "
          f"removed {', '.join(report.removed) or 'none'}; x={report.x}; "
          f"{sum(report.timings_s.values()) * 1000:.0f} ms")
    if args.report:
        atomic_write_json(Path(args.report), report.to_dict())
        print(f"wrote {args.report}")
    return 0


def _add_breed(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("breed", help="breed two creatures' motions into a child BVH (hierarchical evolution)")
    p.add_argument("parent_a", help="first parent BVH (the child follows its timing)")
    p.add_argument("parent_b", help="second parent BVH")
    p.add_argument("-o", "--output", required=True, help="child BVH to write")
    p.add_argument("--x", type=float, default=0.5, help="spacetime parameter in [0, 1] (0: A's motion, 1: B's)")
    p.add_argument("--mutations", type=int, default=5, help="joints removed (with their subtrees), default 5")
    p.add_argument("--weight", action="append", type=_weight, metavar="JOINT=W",
                   help="shift a joint's activity score (negative: more likely to go); repeatable")
    p.add_argument("--map", default=None, help="YAML mapping joints of A to corresponding joints of B")
    p.add_argument("--report", default=None, help="write a JSON report of the breeding")
    p.set_defaults(func=cmd_breed)


# ---------------------------------------------------------------------- graph
def cmd_graph_build(args: argparse.Namespace) -> int:
    from bipedsim.graph import build_graph, load_graph_config

    p = Path(args.config)
    cfg = load_graph_config(p)
    check_output_file(args.output, "-o")
    g = build_graph(cfg, p.resolve().parent)
    g.save(args.output)
    print(f"wrote {args.output}: {len(g.clips)} clips, {g.timings['frames']} frames, built in "
          f"{g.timings['total_s']:.2f} s")
    for name, ly in g.layers.items():
        print(f"  {name:12s} parent {ly.parent or '-':10s} {len(ly.transitions):4d} transitions, "
              f"{ly.scc_nodes} nodes in the strongly connected graph, motions {len(ly.kept_clips)}/{len(g.clips)}")
    return 0


def cmd_graph_play(args: argparse.Namespace) -> int:
    from bipedsim.graph import MotionGraph, Player, parse
    from bipedsim.io import atomic_write_json
    from bipedsim.motion.bvh import write_bvh

    g = MotionGraph.load(args.graph)
    cmds = parse(read_text_file(args.script), source=str(args.script), layers=tuple(g.layers))
    check_output_file(args.output, "-o")
    if args.report:
        check_output_file(args.report, "--report")
    player = Player(g, start=args.start)
    motion = player.run(cmds)
    write_bvh(motion.with_up("y").scaled(100.0), args.output, precision=6)
    rep = player.report()
    print(f"wrote {args.output}: {rep['frames']} frames ({rep['seconds']:.1f} s) at {g.config.fps:g} fps")
    for e in rep["events"]:
        cost = "" if e["cost"] is None else f" (cost {e['cost']:.3f})"
        print(f"  {e['time_s']:6.2f} s  {e['layer']:12s} {e['kind']:12s} {e['detail']}{cost}")
    if args.report:
        atomic_write_json(args.report, rep)
    return 0


def _add_graph(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("graph", help="multi-layered motion graphs: build one, play a Motion Script on it")
    gs = p.add_subparsers(dest="graph_command", metavar="ACTION", required=True)
    b = gs.add_parser("build", help="build a motion graph from a YAML description")
    b.add_argument("config", help="graph YAML (clips, tags, parts, k, threshold, sigma, segment)")
    b.add_argument("-o", "--output", required=True, help="graph file (.npz)")
    b.set_defaults(func=cmd_graph_build)
    pl = gs.add_parser("play", help="play a Motion Script on a graph and write the result as BVH")
    pl.add_argument("graph", help="graph file from `bipedsim graph build`")
    pl.add_argument("script", help="Motion Script text file")
    pl.add_argument("-o", "--output", required=True, help="BVH to write")
    pl.add_argument("--start", default=None, help="motion (name or tag) to start from")
    pl.add_argument("--report", default=None, help="JSON report of the path taken")
    pl.set_defaults(func=cmd_graph_play)


# ---------------------------------------------------------------------- sweep and regress
def cmd_sweep(args: argparse.Namespace) -> int:
    from bipedsim.sim.experiment import load_experiment
    from bipedsim.sim.sweep import run_sweep

    exp = load_experiment(args.experiment)  # every check before any rollout
    prepare_output_dir(args.out, "--out")
    try:
        summary = run_sweep(exp, args.out, workers=args.workers, backend=args.backend,
                            progress=sys.stderr.isatty())
    except KeyboardInterrupt:
        from bipedsim.sim.sweep import read_results

        n = len(read_results(Path(args.out) / "results.csv"))
        print(f"bipedsim sweep: interrupted; {args.out}/results.csv holds {n} of {len(exp.rows())} rollouts; "
              "run the same command again to finish the rest", file=sys.stderr)
        return 130
    print(f"{summary['rollouts']} rollouts: " + ", ".join(f"{k} {v}" for k, v in sorted(summary["outcomes"].items())))
    counts = summary.get("survived_per_direction", {})
    sector = summary.get("direction_sector_deg")
    width = f" +-{sector / 2:g}" if sector else ""
    for d, v in summary["largest_survived_per_direction_n"].items():
        c = counts.get(d, {"survived": 0, "rollouts": 0})
        what = "push" if sector else "phase"
        every = f"every {what} survived up to {v:g} N" if v is not None else f"no magnitude survived in every {what}"
        print(f"  direction {d:>5}{width} deg: {c['survived']}/{c['rollouts']} survived; {every}")
    print(f"wrote {args.out}/results.csv, summary.json, push_polar.png")
    return 0


def _add_sweep(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="run every rollout of an experiment in parallel; resumable")
    p.add_argument("experiment", help="experiment YAML (experiments/*.yaml)")
    p.add_argument("--out", required=True, help="output folder (results.csv, summary.json, push_polar.png)")
    p.add_argument("--workers", type=int, default=1, help="parallel rollouts (default 1)")
    p.add_argument("--backend", choices=("local", "ray"), default="local", help="local processes or Ray")
    p.set_defaults(func=cmd_sweep)


def cmd_regress(args: argparse.Namespace) -> int:
    from bipedsim.sim.regress import run_suite

    return run_suite(args.suite, update=args.update)


def _add_regress(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("regress", help="run a fall / no-fall regression suite; non-zero exit on a mismatch")
    p.add_argument("suite", help="suite YAML")
    p.add_argument("--update", action="store_true", help="rewrite the expectations with the outcomes (after review)")
    p.set_defaults(func=cmd_regress)


#: Subcommand registrars, in the order ``--help`` lists them.
COMMANDS: list[Callable[[argparse._SubParsersAction], None]] = [
    _add_info, _add_convert, _add_run, _add_render, _add_sweep, _add_regress, _add_breed, _add_graph]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bipedsim", description="Physics-based character simulation on MuJoCo.")
    parser.add_argument("--version", action="version", version=f"bipedsim {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in COMMANDS:
        register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    # a terminate signal (kill, a cluster's scheduler) stops a long job as Ctrl-C does: cleanly, with
    # what it has written kept
    old_term = None
    if threading.current_thread() is threading.main_thread():
        old_term = signal.signal(signal.SIGTERM, _terminate)
    try:
        return int(args.func(args))
    except BipedsimError as exc:
        print(f"bipedsim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"bipedsim {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `bipedsim info | head`
        sys.stderr.close()
        return 0
    except OSError as exc:  # a write (or read) the checks could not foresee: a full disk, a vanished folder
        print(f"bipedsim {args.command}: error: {describe_os_error(exc)}", file=sys.stderr)
        return 2
    finally:
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
