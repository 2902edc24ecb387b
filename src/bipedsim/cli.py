"""The ``bipedsim`` command.

Each subcommand is a function ``cmd_<name>(args) -> int`` registered in :data:`COMMANDS`: it parses,
calls one package function and prints. Errors a user can cause are
:class:`~bipedsim.errors.BipedsimError`: the message is printed to stderr and the exit status is 2,
without a traceback. Package modules are imported inside the commands, so ``--help`` stays quick.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from bipedsim import __version__
from bipedsim.errors import BipedsimError
from bipedsim.files import describe_os_error

#: Trajectory samples per second when --record-hz is not given (sim.recorder.DEFAULT_RECORD_HZ, restated
#: here so that --help does not import the simulator; a test keeps the two equal).
DEFAULT_RECORD_HZ = 120.0
#: The video flags: flag, type, default, help (the defaults are render.video.VideoOptions'; a test keeps
#: them equal).
VIDEO_FLAGS: tuple[tuple[str, type, Any, str | None], ...] = (
    ("--width", int, 640, None),
    ("--height", int, 480, None),
    ("--fps", float, 30.0, None),
    ("--speed", float, 1.0, "playback speed (0.5 = slow motion)"),
    ("--cam-distance", float, 3.5, "camera distance (m)"),
    ("--cam-elevation", float, -15.0, "camera elevation (degrees)"),
    ("--cam-azimuth", float, 120.0, "camera azimuth (degrees)"),
)


# ---------------------------------------------------------------------- shared flags
def _scale_arg(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text


def _scale_up(p: argparse.ArgumentParser, scale_help: str, up_help: str) -> None:
    """--scale (metres per unit or a unit name) and --up (y or z), both None when omitted."""
    p.add_argument("--scale", type=_scale_arg, default=None, help=scale_help)
    p.add_argument("--up", choices=("y", "z"), default=None, help=up_help)
    p.add_argument("--positions", choices=("absolute", "offset"), default=None,
                   help="position channels are absolute or added to the joint's OFFSET (decided per joint and "
                        "scored with the up axis when omitted; bipedsim info says which reading was chosen)")
    p.add_argument("--clip-fps", type=float, default=None, dest="clip_fps", metavar="FPS",
                   help="the capture's frame rate, replacing the file's Frame Time (for a file whose header "
                        "does not give the rate it was captured at)")


def _output(p: argparse.ArgumentParser, what: str) -> None:
    """-o/--output, required: the file the command writes."""
    p.add_argument("-o", "--output", required=True, help=what)


def _video_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("video")
    for flag, kind, default, help_text in VIDEO_FLAGS:
        g.add_argument(flag, type=kind, default=default, help=help_text)
    g.add_argument("--ghost", action="store_true", help="draw the reference pose as a translucent ghost")


def video_options(args: argparse.Namespace):  # noqa: ANN201
    from bipedsim.render.video import VideoOptions

    return VideoOptions(width=args.width, height=args.height, fps=args.fps, speed=args.speed,
                        distance=args.cam_distance, elevation=args.cam_elevation, azimuth=args.cam_azimuth,
                        ghost=args.ghost)


def _subparser(sub: argparse._SubParsersAction, name: str, func: Callable[[argparse.Namespace], int],
               help_text: str) -> argparse.ArgumentParser:
    p = sub.add_parser(name, help=help_text)
    p.set_defaults(func=func)
    return p


# ---------------------------------------------------------------------- info and convert
def cmd_info(args: argparse.Namespace) -> int:
    from bipedsim.data import builtin_walk_path
    from bipedsim.model import describe_bvh, format_description

    d = describe_bvh(args.file or str(builtin_walk_path()), scale=args.scale, up=args.up, positions=args.positions,
                     fps=args.clip_fps)
    print(json.dumps(d, indent=2) if args.json else format_description(d))
    return 0


def _add_info(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "info", cmd_info, "describe a BVH file (joints, frames, units, up axis, speed)")
    p.add_argument("file", nargs="?", help="BVH file (default: the built-in reference walk)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    _scale_up(p, "metres per file unit, or a unit name (m, dm, cm, mm, inch, cmu, ft); guessed when omitted",
              "the file's up axis (guessed when omitted)")


def cmd_convert(args: argparse.Namespace) -> int:
    from bipedsim.model import convert_bvh, format_convert_summary

    summary = convert_bvh(args.input, args.output, profile=args.profile, profile_file=args.profile_file,
                          mass=args.mass, map=args.map, clip=args.clip, scale=args.scale, up=args.up,
                          positions=args.positions, fps=args.clip_fps)
    print(json.dumps(summary, indent=2) if args.json else format_convert_summary(summary))
    return 0


def _add_convert(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "convert", cmd_convert, "build an MJCF body from a BVH skeleton (and its reference clip)")
    p.add_argument("input", help="BVH file")
    _output(p, "MJCF file to write")
    p.add_argument("--profile", choices=("auto", "humanoid", "creature"), default="auto",
                   help="body kind (default auto: measured from the skeleton)")
    p.add_argument("--profile-file", default=None, help="a profile YAML (overrides --profile)")
    p.add_argument("--mass", type=float, default=None, help="total body mass in kg (scales every segment)")
    p.add_argument("--map", default=None, help="mapping YAML naming the humanoid roles' joints")
    p.add_argument("--clip", default=None, help="also retarget the motion and write this .npz reference clip")
    _scale_up(p, "metres per file unit or a unit name", "the file's up axis")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")


# ---------------------------------------------------------------------- config, run and render
def cmd_config(args: argparse.Namespace) -> int:
    from bipedsim.control.config import controller_yaml

    sys.stdout.write(controller_yaml(args.controller))
    return 0


def _add_config(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "config", cmd_config,
                   "print the controller settings as YAML: the built-in defaults, or a file merged over them")
    p.add_argument("controller", nargs="?", default=None,
                   help="controller YAML (default: none, the built-in defaults; controllers/default.yaml is "
                        "this output)")


def cmd_run(args: argparse.Namespace) -> int:
    from bipedsim.sim.outputs import run_to_folder

    run_to_folder(args.out, config=args.config, bvh=args.bvh, seconds=args.seconds, seed=args.seed,
                  init_noise=args.init_noise, mass=args.mass, scale=args.scale, up=args.up, positions=args.positions,
                  fps=args.clip_fps, events=args.events, profile=args.profile,
                  support=args.support, record_hz=DEFAULT_RECORD_HZ if args.record_hz is None else args.record_hz,
                  pushes=args.push or [], plots=args.plots, csv=args.csv, export_bvh=args.export_bvh,
                  video=args.video, gif=args.gif, video_options=video_options(args), progress=sys.stderr.isatty(),
                  say=print)
    return 0


def _add_run(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "run", cmd_run, "track a reference walk with the balance controller and report the outcome")
    p.add_argument("config", nargs="?", default=None,
                   help="controller YAML, layered over the built-in defaults (default: the defaults alone, which "
                        "`bipedsim config` prints)")
    p.add_argument("--bvh", default=None, help="reference BVH (default: the built-in walk on the built-in humanoid)")
    p.add_argument("--seconds", type=float, default=10.0, help="simulated seconds (default 10)")
    p.add_argument("--seed", type=int, default=0, help="random seed, recorded with the outcome")
    p.add_argument("--init-noise", type=float, default=0.0, help="initial velocity noise (std) drawn from the seed")
    p.add_argument("--out", default="bipedsim_run", help="output folder for outcome.json (default bipedsim_run)")
    p.add_argument("--mass", type=float, default=None, help="total body mass in kg")
    p.add_argument("--events", default=None, metavar="YAML",
                   help="the --bvh clip's foot strikes given by hand, replacing the detected ones: 'right: [12, 140]' "
                        "and 'left: [76]' (frames, or times like '1.2s')")
    _scale_up(p, "BVH metres per unit or unit name", "BVH up axis")
    p.add_argument("--profile", choices=("auto", "humanoid", "creature"), default=None,
                   help="body kind: humanoid (SIMBICON balance) or creature (legged balance for any skeleton); "
                        "default auto: measured from the skeleton")
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


def cmd_render(args: argparse.Namespace) -> int:
    from bipedsim.sim.outputs import render_folder, written_line

    render_folder(args.run_dir, args.output, video_options(args), plots=args.plots, progress=sys.stderr.isatty(),
                  on_write=lambda path, frames: print(written_line(path, frames)))
    return 0


def _add_render(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "render", cmd_render, "render a recorded run folder to mp4/gif (no re-simulation)")
    p.add_argument("run_dir", help="folder written by `bipedsim run` (model.xml, trajectory.npz)")
    p.add_argument("-o", "--output", default=None, help="video file, .mp4 or .gif (default RUN_DIR/rollout.mp4)")
    p.add_argument("--plots", action="store_true", help="also write the PNG plots into RUN_DIR")
    _video_args(p)


# ---------------------------------------------------------------------- breed and graph
def _weight(text: str) -> tuple[str, float]:
    name, sep, val = text.rpartition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected JOINT=WEIGHT, got {text!r}")
    try:
        return name, float(val)
    except ValueError:
        raise argparse.ArgumentTypeError(f"weight must be a number in {text!r}") from None


def cmd_breed(args: argparse.Namespace) -> int:
    if args.world:  # creature files bred for a world: bipedsim.world's block below
        return cmd_breed_world(args)
    from bipedsim.breed import breed_files, format_breed_summary
    from bipedsim.files import check_distinct_paths

    check_distinct_paths([("-o", args.output), ("--report", args.report), ("--save-map", args.save_map)],
                         [("PARENT_A", args.parent_a), ("PARENT_B", args.parent_b), ("--map", args.map)])
    kw = {} if args.mutations is None else {"mutations": args.mutations}  # None: breed_files' default
    rep = breed_files(args.parent_a, args.parent_b, args.output, x=args.x, weights=dict(args.weight or []),
                      map=args.map, report=args.report, save_map=args.save_map, **kw)
    print(format_breed_summary(rep, args.output, args.report, args.save_map))
    return 0


def _add_breed(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "breed", cmd_breed, "breed two creatures' motions into a child BVH (hierarchical evolution)")
    p.add_argument("parent_a", help="first parent BVH (the child follows its timing)")
    p.add_argument("parent_b", help="second parent BVH")
    _output(p, "child BVH to write (.bvh)")
    p.add_argument("--x", type=float, default=0.5, help="spacetime parameter in [0, 1] (0: A's motion, 1: B's)")
    p.add_argument("--mutations", type=int, default=None,
                   help="joints removed (with their subtrees), default 5 (0 with --world: every limb may carry a mode)")
    p.add_argument("--weight", action="append", type=_weight, metavar="JOINT=W",
                   help="shift a joint's activity score (negative: more likely to go); repeatable")
    p.add_argument("--map", default=None, help="YAML mapping joints of A to corresponding joints of B (default: "
                   "paired by role from names, else structure and geometry)")
    p.add_argument("--report", default=None, help="write a JSON report of the breeding (the correspondence included)")
    p.add_argument("--save-map", default=None, help="write the correspondence used as a --map YAML to edit")
    p.add_argument("--world", default=None,
                   help="world YAML: the parents are creature files (bipedsim world) and the child a creature "
                        "file with the modes of both, parent weights from the world (Bray-Curtis)")


def cmd_graph_build(args: argparse.Namespace) -> int:
    from bipedsim.graph import build_graph_file, format_graph_summary

    print(format_graph_summary(build_graph_file(args.config, args.output, args.report), args.output, args.report))
    return 0


def cmd_graph_play(args: argparse.Namespace) -> int:
    from bipedsim.graph import format_play_summary, play_script

    rep = play_script(args.graph, args.script, args.output, start=args.start, report=args.report)
    print(format_play_summary(rep, args.output))
    return 0


def _add_graph(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("graph", help="multi-layered motion graphs: build one, play a Motion Script on it")
    gs = p.add_subparsers(dest="graph_command", metavar="ACTION", required=True)
    b = _subparser(gs, "build", cmd_graph_build, "build a motion graph from a YAML description")
    b.add_argument("config", help="graph YAML (clips, tags, parts, k, threshold, sigma, segment)")
    _output(b, "graph file (.npz)")
    b.add_argument("--report", default=None, help="JSON build report: per layer, clip and tag the frames kept and "
                   "dropped and why")
    pl = _subparser(gs, "play", cmd_graph_play, "play a Motion Script on a graph and write the result as BVH")
    pl.add_argument("graph", help="graph file from `bipedsim graph build`")
    pl.add_argument("script", help="Motion Script text file")
    _output(pl, "BVH to write (.bvh)")
    pl.add_argument("--start", default=None, help="motion (name or tag) to start from")
    pl.add_argument("--report", default=None, help="JSON report of the path taken")


# ---------------------------------------------------------------------- sweep and regress
#: The files ``bipedsim sweep`` writes into its --out folder (checked against its inputs).
SWEEP_FILES = ("results.csv", "summary.json", "experiment.json", "push_polar.png")


def cmd_sweep(args: argparse.Namespace) -> int:
    from bipedsim.files import check_distinct_paths, folder_files, prepare_output_dir
    from bipedsim.sim.experiment import load_experiment
    from bipedsim.sim.sweep import check_backend, format_summary, interrupted_message, run_sweep

    check_backend(args.backend)  # before the output folder is made
    exp = load_experiment(args.experiment)  # every check before any rollout
    controllers = sorted({r.controller for r in exp.rows() if r.controller})
    check_distinct_paths(folder_files("the --out file", args.out, SWEEP_FILES),
                         [("the experiment file", args.experiment), ("its reference", exp.resolve(exp.spec.reference)),
                          *(("its controller", c) for c in controllers)])
    prepare_output_dir(args.out, "--out")
    return _resumable("sweep", lambda: format_summary(run_sweep(exp, args.out, workers=args.workers,
                                                                backend=args.backend, progress=sys.stderr.isatty()),
                                                      args.out),
                      lambda: interrupted_message(exp, args.out))


def _resumable(command: str, run: Callable[[], str], interrupted: Callable[[], str]) -> int:
    """Run a long, resumable job and print the lines it returns; on Ctrl-C (or a terminate signal) say
    what it kept and how to finish it, exit status 130."""
    try:
        lines = run()
    except KeyboardInterrupt:
        print(f"bipedsim {command}: {interrupted()}", file=sys.stderr)
        return 130
    print(lines)
    return 0


def _parallel_flags(p: argparse.ArgumentParser, what: str) -> None:
    """--workers and --backend of a job run in parallel."""
    p.add_argument("--workers", type=int, default=1, help=f"{what} (default 1)")
    p.add_argument("--backend", choices=("local", "ray"), default="local", help="local processes or Ray")


def _add_sweep(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "sweep", cmd_sweep, "run every rollout of an experiment in parallel; resumable")
    p.add_argument("experiment", help="experiment YAML (experiments/*.yaml)")
    p.add_argument("--out", required=True, help="output folder (results.csv, summary.json, push_polar.png)")
    _parallel_flags(p, "parallel rollouts")


def cmd_regress(args: argparse.Namespace) -> int:
    from bipedsim.sim.regress import run_suite

    return run_suite(args.suite, update=args.update)


def _add_regress(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "regress", cmd_regress, "run a fall / no-fall regression suite; non-zero exit on a mismatch")
    p.add_argument("suite", help="suite YAML")
    p.add_argument("--update", action="store_true", help="rewrite the expectations with the outcomes (after review)")


# ---------------------------------------------------------------------- world (motion-tile worlds)
def _creature_file(path: str) -> tuple[str | None, list[Path]]:
    """A creature file's name and the clip files it names (relative to its folder), read only for the
    check of the outputs against the inputs: a file that does not read gives (None, []) and is
    reported by the command's own reading."""
    from bipedsim.config import load_yaml

    try:
        data = load_yaml(path)
    except BipedsimError:
        return None, []
    if not isinstance(data, dict):
        return None, []
    clips = data.get("clips")
    files = [Path(path).parent / str(f) for f in clips.values()] if isinstance(clips, dict) else []
    name = data.get("name")
    return (str(name) if name is not None else None), files


def _creature_inputs(creatures: Sequence[str]) -> tuple[list[tuple[str, Any]], list[str | None]]:
    """The files creature files name (themselves and their clips), for the check of a world command's
    outputs against its inputs, and the creatures' names (None where a file does not read)."""
    inputs: list[tuple[str, Any]] = []
    names = []
    for c in creatures:
        name, clips = _creature_file(c)
        names.append(name)
        inputs += [("the creature file", c), *((f"{c}'s clip", f) for f in clips)]
    return inputs, names


def cmd_world(args: argparse.Namespace) -> int:
    from bipedsim.files import check_distinct_paths
    from bipedsim.render.video import VideoOptions
    from bipedsim.world import run_world
    from bipedsim.world.run import output_paths

    inputs, names = _creature_inputs(args.creatures)
    if None in names:  # a creature file that does not read: the command says so before writing anything
        names = [""]
    elif len(set(names)) != len(names):  # as run_world tells the creatures' files apart
        names = [f"{n}{i}" for i, n in enumerate(names)]
    videos = output_paths(args.video, names) if args.video else []
    check_distinct_paths([*(("-o", o) for o in output_paths(args.output, names)), ("--report", args.report),
                          ("--plot", args.plot), *(("--video", v) for v in videos)],
                         [("the world file", args.world), *inputs])
    opts = VideoOptions(width=args.width, height=args.height, fps=args.fps, speed=args.speed,
                        distance=args.cam_distance, elevation=args.cam_elevation, azimuth=args.cam_azimuth,
                        label=False)
    run_world(args.world, args.creatures, args.output, report=args.report, video=args.video, plot=args.plot,
              weights=args.blend, video_options=opts, progress=sys.stderr.isatty(), say=print)
    return 0


def cmd_breed_world(args: argparse.Namespace) -> int:
    from bipedsim.files import check_distinct_paths
    from bipedsim.world import breed_world_files, format_world_breed_summary
    from bipedsim.world.tiles import TRAVEL_MODES

    inputs, _ = _creature_inputs([args.parent_a, args.parent_b])
    out = Path(args.output)
    check_distinct_paths([("-o", out), ("--report", args.report),
                          *((f"the {m} clip beside -o", out.with_name(f"{out.stem}_{m}.bvh")) for m in TRAVEL_MODES)],
                         [("--world", args.world), *inputs])
    kw = {} if args.mutations is None else {"mutations": args.mutations}
    rep = breed_world_files(args.parent_a, args.parent_b, args.world, args.output, report=args.report, **kw)
    print(format_world_breed_summary(rep, args.report))
    return 0


def _add_world(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "world", cmd_world, "creatures cross a tile map by walking, flying or swimming (BVH out)")
    p.add_argument("world", help="world YAML (tile, rows, legend, events)")
    p.add_argument("creatures", nargs="+", help="creature YAML files (name, clips: mode -> BVH)")
    _output(p, "BVH to write (several creatures: OUT_<name>.bvh each)")
    p.add_argument("--report", default=None, help="JSON report: path, modes, length, frames, events, weights, timings")
    p.add_argument("--video", default=None, help="render the world and the creature to this .mp4 (or .gif)")
    p.add_argument("--plot", default=None, help="PNG (.png) of the map with every creature's path")
    p.add_argument("--blend", choices=("quadratic", "linear", "smoothstep"), default="quadratic",
                   help="transition weights (default quadratic: P(n) = n^2/m^2)")
    g = p.add_argument_group("video")
    for flag, kind, default, help_text in VIDEO_FLAGS:
        g.add_argument(flag, type=kind, default=WORLD_VIDEO_DEFAULTS.get(flag, default), help=help_text)


#: The world's camera stands farther back and higher than a run's: the terrain is part of the picture.
WORLD_VIDEO_DEFAULTS = {"--cam-distance": 8.0, "--cam-elevation": -25.0}


# ---------------------------------------------------------------------- tune
#: The files ``bipedsim tune`` writes into its --out folder besides its history and state (checked
#: against its inputs).
TUNE_FILES = ("best.yaml", "convergence.png", "summary.json")


def cmd_tune(args: argparse.Namespace) -> int:
    from bipedsim.files import check_distinct_paths, folder_files
    from bipedsim.tune import format_tune_summary, interrupted_message, load_tune, run_tune
    from bipedsim.tune.cmaes import HISTORY_FILE, STATE_FILE

    tune = load_tune(args.tune)  # every check before any rollout
    check_distinct_paths(folder_files("the --out file", args.out, (*TUNE_FILES, HISTORY_FILE, STATE_FILE)),
                         [("the tune file", args.tune), ("its controller", tune.controller_path),
                          *(("its reference", r) for r in tune.references)])
    return _resumable("tune", lambda: format_tune_summary(run_tune(tune, args.out, workers=args.workers,
                                                                   backend=args.backend,
                                                                   progress=sys.stderr.isatty()), args.out),
                      lambda: interrupted_message(tune, args.out))


def _add_tune(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "tune", cmd_tune, "tune controller values with CMA-ES over rollouts; parallel, resumable")
    p.add_argument("tune", help="tune YAML (experiments/tune_*.yaml; see docs/tuning.md)")
    p.add_argument("--out", required=True,
                   help="output folder (best.yaml, history.csv, convergence.png, summary.json, state.json)")
    _parallel_flags(p, "candidates scored in parallel")


#: Subcommand registrars, in the order ``--help`` lists them.
COMMANDS: list[Callable[[argparse._SubParsersAction], None]] = [
    _add_info, _add_convert, _add_config, _add_run, _add_render, _add_sweep, _add_regress, _add_tune, _add_breed,
    _add_graph, _add_world]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bipedsim", description="Physics-based character simulation on MuJoCo.")
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
    # a terminate signal (kill, a cluster's scheduler) or a hang-up (the terminal closed) stops a job as
    # Ctrl-C does: cleanly, with what it has written kept and no temporary file left. A signal ignored
    # when the command started (`nohup` ignores SIGHUP) stays ignored.
    old_handlers = {}
    if threading.current_thread() is threading.main_thread():
        old_handlers = {sig: signal.signal(sig, _terminate) for sig in STOP_SIGNALS
                        if signal.getsignal(sig) is not signal.SIG_IGN}
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
    except MemoryError:  # the input limits keep the commands within about 1 GB; a lower ulimit can still end here
        print(f"bipedsim {args.command}: error: out of memory (the inputs are within their size limits; a shorter "
              "clip or a smaller grid needs less, or run with more memory)", file=sys.stderr)
        return 2
    except OSError as exc:  # a write (or read) the checks could not foresee: a full disk, a vanished folder
        print(f"bipedsim {args.command}: error: {describe_os_error(exc)}", file=sys.stderr)
        return 2
    finally:
        for sig, handler in old_handlers.items():
            signal.signal(sig, handler)


#: The signals that stop a command as Ctrl-C (SIGINT) does: terminate, and hang-up where there is one.
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
