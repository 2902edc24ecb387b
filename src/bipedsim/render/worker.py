"""Child process that renders a run (started by :func:`bipedsim.render.video.render_video` with
``MUJOCO_GL`` set). Prints the number of frames written."""

from __future__ import annotations

import json
import sys

from bipedsim.render.video import VideoOptions, render_frames, write_video


def main() -> int:
    args = json.loads(sys.argv[1])
    opts = VideoOptions(**args["opts"])
    n = write_video(render_frames(args["run_dir"], opts, progress=args["progress"]), args["out"], opts.fps)
    print(n)
    return 0


if __name__ == "__main__":
    sys.exit(main())
