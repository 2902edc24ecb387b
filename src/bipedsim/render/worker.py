"""Child process that renders a run (started by :func:`bipedsim.render.video.render_video` with
``MUJOCO_GL`` set). Prints one JSON line on stdout: ``{"frames": N}``, or ``{"error": "..."}`` (one
line naming the cause) with exit status 1."""

from __future__ import annotations

import json
import sys

from bipedsim.render.video import VideoOptions, describe_exception, render_frames, write_video


def main() -> int:
    args = json.loads(sys.argv[1])
    opts = VideoOptions(**args["opts"])
    try:
        n = write_video(render_frames(args["run_dir"], opts, progress=args["progress"]), args["out"], opts.fps)
    except Exception as exc:  # reported to the parent, which raises it as a RenderError
        print(json.dumps({"error": describe_exception(exc)}), flush=True)
        return 1
    print(json.dumps({"frames": n}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
