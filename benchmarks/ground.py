"""Ground (docs/ground.md): the built-in walk on each ground of the issue's list, in one run: whether it
stands for ``--seconds``, the distance and speed, and the simulation's speed (steps/s of the whole
controlled rollout) against the flat floor's, as a ratio. The height field of rough ground and the
controller's ground queries are what a shaped ground costs.

    python benchmarks/ground.py                  # 7 grounds x 20 s: ~15 s on one core
    python benchmarks/ground.py --seconds 10 --ground rough:0.05:0.5:3 --ground slope:12
"""

from __future__ import annotations

import argparse
import time

from bipedsim.model.ground import Ground
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

GROUNDS = ["flat", "slope:8", "slope:-8", "step:0.1:3", "step:-0.1:3", "rough:0.03:1.0", "friction:0.5"]


def measure(terms: str, seconds: float) -> dict[str, object]:
    """One rollout of the built-in walk on ``terms`` (``+`` joins several)."""
    sc = load_scenario(ground=Ground.parse(terms.split("+")))
    t0 = time.perf_counter()
    out, _ = run_scenario(sc, RolloutSpec(seconds=seconds))
    wall = time.perf_counter() - t0
    return {"ground": terms, "outcome": out.outcome, "stood_s": out.sim_seconds, "distance_m": out.distance_m,
            "speed_mps": out.mean_speed_mps, "steps_per_s": out.steps / wall, "fall": out.fall_reason or ""}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--ground", action="append", help="a ground (terms joined by +); repeatable (default: the list)")
    args = ap.parse_args()
    grounds = ["flat"] + [g for g in (args.ground or GROUNDS) if g != "flat"]
    rows = [measure(g, args.seconds) for g in grounds]
    flat = rows[0]["steps_per_s"]
    print(f"{'ground':18s} {'outcome':8s} {'stood s':>7s} {'dist m':>7s} {'m/s':>5s} {'steps/s':>8s} {'x flat':>6s}")
    for r in rows:
        print(f"{r['ground']:18s} {r['outcome']:8s} {r['stood_s']:7.1f} {r['distance_m']:7.2f} {r['speed_mps']:5.2f} "
              f"{r['steps_per_s']:8.0f} {r['steps_per_s'] / flat:6.2f}  {r['fall']}")  # type: ignore[operator]


if __name__ == "__main__":
    main()
