"""The ``bipedsim`` command.

Each subcommand is registered by a function ``_add_<name>(sub)`` listed in :data:`COMMANDS`: it declares
the command's flags and the function it runs, ``cmd_<name>(args) -> int`` in :mod:`bipedsim.cli.commands`,
which calls one package function and prints. The flags several commands share are in
:mod:`bipedsim.cli.flags`.
Errors a user can cause are :class:`~bipedsim.errors.BipedsimError`: the message is printed to stderr and
the exit status is 2, without a traceback. Package modules are imported inside the commands, so ``--help``
stays quick.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections.abc import Callable, Sequence

from bipedsim import __version__
from bipedsim.cli.commands import (
    cmd_breed,
    cmd_config,
    cmd_convert,
    cmd_graph_build,
    cmd_graph_play,
    cmd_info,
    cmd_regress,
    cmd_render,
    cmd_run,
    cmd_sweep,
    cmd_tune,
    cmd_view,
    cmd_world,
)
from bipedsim.cli.flags import (
    DEFAULT_RECORD_HZ,
    VIDEO_FLAGS,
    WORLD_VIDEO_DEFAULTS,
    _output,
    _parallel_flags,
    _scale_up,
    _subparser,
    _video_args,
    _weight,
)
from bipedsim.errors import BipedsimError
from bipedsim.files import describe_os_error

__all__ = ["COMMANDS", "DEFAULT_RECORD_HZ", "STOP_SIGNALS", "VIDEO_FLAGS", "build_parser", "main"]


# ---------------------------------------------------------------------- info and convert
def _add_info(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "info", cmd_info, "describe a BVH file (joints, frames, units, up axis, speed)")
    p.add_argument("file", nargs="?", help="BVH file (default: the built-in reference walk)")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    _scale_up(p, "metres per file unit, or a unit name (m, dm, cm, mm, inch, cmu, ft); guessed when omitted",
              "the file's up axis (guessed when omitted)")


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
def _add_config(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "config", cmd_config,
                   "print the controller settings as YAML: the built-in defaults, or a file merged over them")
    p.add_argument("controller", nargs="?", default=None,
                   help="controller YAML (default: none, the built-in defaults; controllers/default.yaml is "
                        "this output)")


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
    p.add_argument("--no-reconstruct", dest="reconstruct", action="store_false", default=None,
                   help="humanoid: track the clip with the feedback controller alone, without searching (or "
                        "reading the cached) feed-forward correction first (docs/controller.md, Reconstruction)")
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
    _ground_flag(p)
    p.add_argument("--video", default=None, help="render the rollout to this .mp4 (or .gif)")
    p.add_argument("--gif", default=None, help="render the rollout to this .gif")
    p.add_argument("--plots", action="store_true", help="write PNG plots into --out")
    p.add_argument("--export-bvh", default=None, help="write the simulated motion as BVH on the source skeleton")
    p.add_argument("--csv", default=None, help="write joint angles (simulated and reference) as CSV")
    _video_args(p)


def _add_render(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "render", cmd_render, "render a recorded run folder to mp4/gif (no re-simulation)")
    p.add_argument("run_dir", help="folder written by `bipedsim run` (model.xml, trajectory.npz)")
    p.add_argument("-o", "--output", default=None, help="video file, .mp4 or .gif (default RUN_DIR/rollout.mp4)")
    p.add_argument("--plots", action="store_true", help="also write the PNG plots into RUN_DIR")
    _video_args(p)


# ---------------------------------------------------------------------- breed and graph
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
def _add_sweep(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "sweep", cmd_sweep, "run every rollout of an experiment in parallel; resumable")
    p.add_argument("experiment", help="experiment YAML (experiments/*.yaml)")
    p.add_argument("--out", required=True, help="output folder (results.csv, summary.json, push_polar.png)")
    _parallel_flags(p, "parallel rollouts")


def _add_regress(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "regress", cmd_regress, "run a fall / no-fall regression suite; non-zero exit on a mismatch")
    p.add_argument("suite", help="suite YAML")
    p.add_argument("--update", action="store_true", help="rewrite the expectations with the outcomes (after review)")


# ---------------------------------------------------------------------- world (motion-tile worlds)
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
    p.add_argument("--simulate", action="store_true",
                   help="also run each walking creature's crossing in physics on the world's terrain (report: "
                        "simulated; --video shows the physical body)")
    g = p.add_argument_group("video")
    for flag, kind, default, help_text in VIDEO_FLAGS:
        g.add_argument(flag, type=kind, default=WORLD_VIDEO_DEFAULTS.get(flag, default), help=help_text)


# ---------------------------------------------------------------------- tune
def _add_tune(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "tune", cmd_tune, "tune controller values with CMA-ES over rollouts; parallel, resumable")
    p.add_argument("tune", help="tune YAML (experiments/tune_*.yaml; see docs/tuning.md)")
    p.add_argument("--out", required=True,
                   help="output folder (best.yaml, history.csv, convergence.png, summary.json, state.json)")
    _parallel_flags(p, "candidates scored in parallel")


# ---------------------------------------------------------------------- view (the live viewer)
def _ground_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ground", action="append", metavar="TERM",
                   help="the ground: slope:DEG (uphill along the walk; negative downhill), step:HEIGHT_M:DISTANCE_M "
                        "(up, or down when negative, that far ahead), rough:AMPLITUDE_M:WAVELENGTH_M[:SEED] (a "
                        "height field), friction:MU; repeatable to combine (default flat; docs/ground.md)")


def _add_view(sub: argparse._SubParsersAction) -> None:
    p = _subparser(sub, "view", cmd_view, "run the controller live in MuJoCo's viewer: push with keys 1-8 or the "
                   "mouse, pause, slow down, restart (needs a display)")
    p.add_argument("config", nargs="?", default=None, help="controller YAML (default: the built-in defaults)")
    p.add_argument("--bvh", default=None, help="reference BVH (default: the built-in walk on the built-in humanoid)")
    p.add_argument("--push", action="append", metavar="MAG:DIR:DUR:START",
                   help="a scheduled push, as for `bipedsim run`; repeatable")
    p.add_argument("--push-force", type=float, default=None, help="N of a key push (keys 1-8; default 200)")
    p.add_argument("--seconds", type=float, default=None, help="simulated seconds before the run stops (default 600)")
    p.add_argument("--profile", choices=("auto", "humanoid", "creature"), default=None, help="body kind (default auto)")
    p.add_argument("--no-reconstruct", dest="reconstruct", action="store_false", default=None,
                   help="humanoid: skip the clip's feed-forward correction search")
    _ground_flag(p)


#: Subcommand registrars, in the order ``--help`` lists them.
COMMANDS: list[Callable[[argparse._SubParsersAction], None]] = [
    _add_info, _add_convert, _add_config, _add_run, _add_render, _add_sweep, _add_regress, _add_tune, _add_breed,
    _add_graph, _add_world, _add_view]


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
