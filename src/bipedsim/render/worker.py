"""Child process that renders a run (started by :func:`bipedsim.render.video.render_video` with
``MUJOCO_GL`` set). Prints one JSON line on stdout: ``{"frames": N}``, or ``{"error": "..."}`` (one
line naming the cause) with exit status 1. SIGINT, SIGTERM and SIGHUP end it without a traceback and
without its temporary file (exit status 130)."""

from __future__ import annotations

import json
import signal
import sys

from bipedsim.render.video import VideoOptions, describe_exception, render_frames, write_video

#: Exit status after an interruption, as a shell reports Ctrl-C.
INTERRUPTED = 130


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main() -> int:
    # a terminate or hang-up (the parent stopping this render, a closed terminal) unwinds as Ctrl-C
    # does, through write_video's clean-up of its temporary file
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _interrupt)
    args = json.loads(sys.argv[1])
    opts = VideoOptions(**args["opts"])
    try:
        n = write_video(render_frames(args["run_dir"], opts, progress=args["progress"]), args["out"], opts.fps,
                        tmp=args.get("tmp"))
    except KeyboardInterrupt:
        print(json.dumps({"error": "interrupted"}), flush=True)
        return INTERRUPTED
    except Exception as exc:  # reported to the parent, which raises it as a RenderError
        print(json.dumps({"error": describe_exception(exc)}), flush=True)
        return 1
    print(json.dumps({"frames": n}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
