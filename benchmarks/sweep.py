"""Sweep scaling: the same experiment with --workers 1 and --workers 2 (target: 2 workers in at most
0.6x the time of 1), and the Ray backend on a local instance, in one run.

    python benchmarks/sweep.py [EXPERIMENT.yaml]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import run_sweep

DEFAULT = Path(__file__).resolve().parents[1] / "experiments" / "push_200n.yaml"


def main() -> int:
    exp = load_experiment(sys.argv[1] if len(sys.argv) > 1 else DEFAULT)
    times = {}
    for label, workers, backend in (("local, 1 worker", 1, "local"), ("local, 2 workers", 2, "local"),
                                    ("ray, 2 workers", 2, "ray")):
        with tempfile.TemporaryDirectory() as d:
            t0 = time.perf_counter()
            try:
                run_sweep(exp, d, workers=workers, backend=backend, progress=False)
            except Exception as exc:  # noqa: BLE001 - report and go on (e.g. ray missing)
                print(f"{label:18s}: skipped ({exc})")
                continue
            times[label] = time.perf_counter() - t0
            print(f"{label:18s}: {times[label]:7.1f} s for {len(exp.rows())} rollouts")
    if "local, 1 worker" in times and "local, 2 workers" in times:
        r = times["local, 2 workers"] / times["local, 1 worker"]
        print(f"2 workers / 1 worker: {r:.2f}  (target <= 0.6)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
