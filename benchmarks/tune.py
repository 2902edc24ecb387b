"""Tune scaling: one CMA-ES generation of a tune scored with 1 worker and with 2 (local processes,
pool start-up included), alternated ``--repeats`` times in one run; the ratio of the totals is printed
(target: 2 workers at least 1.6x faster). The same generation each time: the first CMA-ES asks from
the tune's seed. On a machine shared with other jobs the ratio measured is lower than on an idle one.

    python benchmarks/tune.py [TUNE.yaml] [--repeats N]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from bipedsim import config
from bipedsim.sim.sweep import BACKENDS
from bipedsim.tune import load_tune
from bipedsim.tune.cmaes import _new_state, _setup, _values
from bipedsim.tune.evaluate import evaluate

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
    totals = {1: 0.0, 2: 0.0}
    scores: dict[int, list[float]] = {}
    for rep in range(args.repeats):
        for workers in (1, 2):
            t0 = time.perf_counter()
            res = sorted(BACKENDS["local"](tasks, workers, fn=evaluate), key=lambda r: r["candidate"])
            dt = time.perf_counter() - t0
            totals[workers] += dt
            scores.setdefault(workers, [r["score"] for r in res])
            print(f"repeat {rep + 1}, {workers} worker(s): {dt:6.1f} s for a generation of {len(tasks)} candidates")
    assert scores[1] == scores[2], "1 and 2 workers scored the generation differently"
    print(f"2 workers vs 1: {totals[1] / totals[2]:.2f}x faster (target >= 1.6; the same scores either way)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
