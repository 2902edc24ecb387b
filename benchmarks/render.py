"""Rendering throughput: frames rendered per second at 640x480 against simulation steps per second,
measured in one run.

    python benchmarks/render.py [--seconds 4]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from bipedsim.cli import main as cli


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=4.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        cli(["run", "--seconds", str(args.seconds), "--out", d])
        t_sim = time.perf_counter() - t0
        import json

        steps = json.loads((Path(d) / "outcome.json").read_text())["steps"]
        from bipedsim.render.video import VideoOptions, frame_times, render_video
        from bipedsim.sim.recorder import Trajectory

        tr = Trajectory.load(Path(d) / "trajectory.npz")
        t0 = time.perf_counter()
        n = render_video(d, Path(d) / "v.mp4", VideoOptions(width=640, height=480))
        t_render = time.perf_counter() - t0
        assert n == len(frame_times(tr.time[0], tr.time[-1], VideoOptions()))
        from bipedsim.render.gl import choose_backend

        backend = choose_backend()
    print(f"backend              : {backend}")
    print(f"simulation           : {steps / t_sim:10.0f} steps/s (incl. setup, {steps} steps)")
    print(f"rendering 640x480    : {n / t_render:10.1f} frames/s (incl. process start, {n} frames, mp4)")
    print(f"sim steps per frame rendered in the same time: {(steps / t_sim) / (n / t_render):.0f}")
    print(f"video seconds rendered per wall second: {(n / 30.0) / t_render:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
