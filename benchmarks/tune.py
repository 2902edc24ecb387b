"""Tune scaling: one CMA-ES generation of a tune scored with 1 worker and with 2 (local processes), in
one run. As ``bipedsim tune`` does, each holds one pool for the whole tune: the first round pays for
starting the workers (spawn, imports, building the body), every later generation runs on warm workers.
Both are timed; the ratio printed is that of the warm generations, summed over ``--repeats`` rounds
(target: 2 workers at least 1.6x faster). The same generation each time: the first CMA-ES asks from
the tune's seed. On a machine shared with other jobs the ratio measured is lower than on an idle one
(the load average is printed before and after).

    python benchmarks/tune.py [TUNE.yaml] [--repeats N]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from pathlib import Path

from bipedsim import config
from bipedsim.experiments.sweep import backend_session
from bipedsim.experiments.tune import load_tune
from bipedsim.experiments.tune.cmaes import _setup, _values
from bipedsim.experiments.tune.evaluate import evaluate
from bipedsim.experiments.tune.state import _new_state

DEFAULT = Path(__file__).resolve().parents[1] / "experiments" / "tune_broken_start.yaml"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tune", nargs="?", default=str(DEFAULT))
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    tune = load_tune(args.tune)
    setup = _setup(tune)
    asked = _new_state(tune)["es"].ask()
    tasks = [(i + 1, config.to_dict(tune.settings(_values(tune, list(x)))), setup) for i, x in enumerate(asked)]
    print(f"load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    warm: dict[int, float] = {1: 0.0, 2: 0.0}
    scores: dict[int, list[float]] = {}
    with contextlib.ExitStack() as stack:
        runs = {w: stack.enter_context(backend_session("local", w)) for w in (1, 2)}
        for rnd in range(args.repeats + 1):  # alternated, so a change in the machine's load hits both alike
            for workers, run in runs.items():
                t0 = time.perf_counter()
                res = sorted(run(tasks, evaluate), key=lambda r: r["candidate"])
                dt = time.perf_counter() - t0
                scores.setdefault(workers, [r["score"] for r in res])
                what = "start-up + first generation" if rnd == 0 else "a generation, warm workers"
                print(f"{workers} worker(s): {dt:6.1f} s for {what} ({len(tasks)} candidates)")
                if rnd:
                    warm[workers] += dt
    assert scores[1] == scores[2], "1 and 2 workers scored the generation differently"
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    print(f"2 workers vs 1, warm generations: {warm[1] / warm[2]:.2f}x faster (target >= 1.6; the same scores "
          "either way)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
