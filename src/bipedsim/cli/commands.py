"""What each ``bipedsim`` command runs: a function ``cmd_<name>(args) -> int`` that calls one package
function and prints. Package modules are imported inside the commands, so ``--help`` stays quick.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from bipedsim.cli.flags import DEFAULT_RECORD_HZ
from bipedsim.errors import BipedsimError


def video_options(args: argparse.Namespace):  # noqa: ANN201
    from bipedsim.render.video import VideoOptions

    return VideoOptions(width=args.width, height=args.height, fps=args.fps, speed=args.speed,
                        distance=args.cam_distance, elevation=args.cam_elevation, azimuth=args.cam_azimuth,
                        ghost=args.ghost, ghost_offset=args.ghost_offset)


# ---------------------------------------------------------------------- info and convert
def cmd_info(args: argparse.Namespace) -> int:
    from bipedsim.data import builtin_walk_path
    from bipedsim.reference import describe_bvh, format_description

    d = describe_bvh(args.file or str(builtin_walk_path()), scale=args.scale, up=args.up, positions=args.positions,
                     fps=args.clip_fps)
    print(json.dumps(d, indent=2) if args.json else format_description(d))
    return 0


def cmd_convert(args: argparse.Namespace) -> int:
    from bipedsim.reference import convert_bvh, format_convert_summary

    summary = convert_bvh(args.input, args.output, profile=args.profile, profile_file=args.profile_file,
                          mass=args.mass, map=args.map, clip=args.clip, scale=args.scale, up=args.up,
                          positions=args.positions, fps=args.clip_fps)
    print(json.dumps(summary, indent=2) if args.json else format_convert_summary(summary))
    return 0


# ---------------------------------------------------------------------- config, run and render
def cmd_config(args: argparse.Namespace) -> int:
    from bipedsim.control.settings import controller_yaml

    sys.stdout.write(controller_yaml(args.controller))
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from bipedsim.api import run_folder

    run_folder(args.config, args.bvh, out=args.out, seconds=args.seconds, seed=args.seed,
               init_noise=args.init_noise, mass=args.mass, scale=args.scale, up=args.up, positions=args.positions,
               fps=args.clip_fps, events=args.events, profile=args.profile, reconstruct=args.reconstruct,
               support=args.support, record_hz=DEFAULT_RECORD_HZ if args.record_hz is None else args.record_hz,
               pushes=args.push or [], plots=args.plots, csv=args.csv, export_bvh=args.export_bvh,
               video=args.video, gif=args.gif, video_options=video_options(args), progress=sys.stderr.isatty(),
               say=print, ground=args.ground)
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from bipedsim.sim.outputs import render_folder, written_line

    render_folder(args.run_dir, args.output, video_options(args), plots=args.plots, progress=sys.stderr.isatty(),
                  on_write=lambda path, frames: print(written_line(path, frames)))
    return 0


# ---------------------------------------------------------------------- breed and graph
def cmd_breed(args: argparse.Namespace) -> int:
    if args.world:  # creature files bred for a world: bipedsim.synthesis.world's block below
        return cmd_breed_world(args)
    from bipedsim.files import check_distinct_paths
    from bipedsim.synthesis.breed import breed_files, format_breed_summary

    check_distinct_paths([("-o", args.output), ("--report", args.report), ("--save-map", args.save_map)],
                         [("PARENT_A", args.parent_a), ("PARENT_B", args.parent_b), ("--map", args.map)])
    kw = {} if args.mutations is None else {"mutations": args.mutations}  # None: breed_files' default
    rep = breed_files(args.parent_a, args.parent_b, args.output, x=args.x, weights=dict(args.weight or []),
                      map=args.map, report=args.report, save_map=args.save_map, **kw)
    print(format_breed_summary(rep, args.output, args.report, args.save_map))
    return 0


def cmd_graph_build(args: argparse.Namespace) -> int:
    from bipedsim.synthesis.graph import build_graph_file, format_graph_summary

    print(format_graph_summary(build_graph_file(args.config, args.output, args.report), args.output, args.report))
    return 0


def cmd_graph_play(args: argparse.Namespace) -> int:
    from bipedsim.synthesis.graph import format_play_summary, play_script

    rep = play_script(args.graph, args.script, args.output, start=args.start, report=args.report)
    print(format_play_summary(rep, args.output))
    return 0


# ---------------------------------------------------------------------- sweep and regress
def cmd_sweep(args: argparse.Namespace) -> int:
    from bipedsim.api import sweep
    from bipedsim.experiments.experiment import load_experiment
    from bipedsim.experiments.sweep import format_summary, interrupted_message

    return _resumable("sweep", lambda: format_summary(sweep(args.experiment, args.out, workers=args.workers,
                                                            backend=args.backend,
                                                            progress=sys.stderr.isatty()).summary, args.out),
                      lambda: interrupted_message(load_experiment(args.experiment), args.out))


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


def cmd_regress(args: argparse.Namespace) -> int:
    from bipedsim.experiments.regress import run_suite

    return run_suite(args.suite, update=args.update)


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
    from bipedsim.synthesis.world import run_world
    from bipedsim.synthesis.world.run import output_paths

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
              weights=args.blend, video_options=opts, progress=sys.stderr.isatty(), say=print,
              simulate=args.simulate)
    return 0


def cmd_breed_world(args: argparse.Namespace) -> int:
    from bipedsim.files import check_distinct_paths
    from bipedsim.synthesis.world import breed_world_files, format_world_breed_summary
    from bipedsim.synthesis.world.tiles import TRAVEL_MODES

    inputs, _ = _creature_inputs([args.parent_a, args.parent_b])
    out = Path(args.output)
    check_distinct_paths([("-o", out), ("--report", args.report),
                          *((f"the {m} clip beside -o", out.with_name(f"{out.stem}_{m}.bvh")) for m in TRAVEL_MODES)],
                         [("--world", args.world), *inputs])
    kw = {} if args.mutations is None else {"mutations": args.mutations}
    rep = breed_world_files(args.parent_a, args.parent_b, args.world, args.output, report=args.report, **kw)
    print(format_world_breed_summary(rep, args.report))
    return 0


# ---------------------------------------------------------------------- tune
def cmd_tune(args: argparse.Namespace) -> int:
    from bipedsim.api import tune
    from bipedsim.experiments.tune import format_tune_summary, interrupted_message, load_tune

    return _resumable("tune", lambda: format_tune_summary(tune(args.tune, args.out, workers=args.workers,
                                                               backend=args.backend, progress=sys.stderr.isatty()),
                                                          args.out),
                      lambda: interrupted_message(load_tune(args.tune), args.out))


# ---------------------------------------------------------------------- view (the live viewer)
def cmd_view(args: argparse.Namespace) -> int:
    from bipedsim.config import from_dict
    from bipedsim.model.ground import Ground
    from bipedsim.render.viewer import ViewSettings, display_problem, view
    from bipedsim.sim.push import Push, check_pushes
    from bipedsim.sim.runner import load_scenario

    problem = display_problem()  # before minutes of loading
    if problem:
        print(f"bipedsim view: error: {problem}", file=sys.stderr)
        return 2
    given = {"seconds": args.seconds, "push_magnitude": args.push_force}
    settings = from_dict(ViewSettings, {k: v for k, v in given.items() if v is not None})
    pushes = [Push.parse(p) for p in args.push or []]
    check_pushes(pushes, settings.seconds)
    sc = load_scenario(args.config, args.bvh, profile=args.profile, reconstruct=args.reconstruct,
                       ground=Ground.parse(args.ground, key="--ground"))
    view(sc, pushes, settings, say=print)
    return 0
