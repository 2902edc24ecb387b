"""The flags several ``bipedsim`` commands share, and the defaults restated for ``--help``.

Nothing here imports the simulator, numpy or MuJoCo: ``bipedsim --help`` stays quick.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

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
#: Metres the --ghost stands beside the body (render.video.VideoOptions.ghost_offset; a test keeps them equal).
GHOST_OFFSET_M = 1.0
#: The world's camera stands farther back and higher than a run's: the terrain is part of the picture.
WORLD_VIDEO_DEFAULTS = {"--cam-distance": 8.0, "--cam-elevation": -25.0}


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
    g.add_argument("--ghost", action="store_true",
                   help="draw the clip as a translucent ghost beside the body: its pose at the run's time, its root "
                        "where the clip's goes (aligned at the start), --ghost-offset m to its left; after the "
                        "clip's end, the controller's reference beside the body")
    g.add_argument("--ghost-offset", type=float, default=GHOST_OFFSET_M, metavar="M",
                   help=f"metres the ghost stands to the left (negative: right; 0 overlays; "
                        f"default {GHOST_OFFSET_M:g})")



def _subparser(sub: argparse._SubParsersAction, name: str, func: Callable[[argparse.Namespace], int],
               help_text: str) -> argparse.ArgumentParser:
    p = sub.add_parser(name, help=help_text)
    p.set_defaults(func=func)
    return p


def _weight(text: str) -> tuple[str, float]:
    name, sep, val = text.rpartition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected JOINT=WEIGHT, got {text!r}")
    try:
        return name, float(val)
    except ValueError:
        raise argparse.ArgumentTypeError(f"weight must be a number in {text!r}") from None


def _parallel_flags(p: argparse.ArgumentParser, what: str) -> None:
    """--workers and --backend of a job run in parallel."""
    p.add_argument("--workers", type=int, default=1, help=f"{what} (default 1)")
    p.add_argument("--backend", choices=("local", "ray"), default="local", help="local processes or Ray")
