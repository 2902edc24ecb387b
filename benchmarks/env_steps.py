"""The Gymnasium environment's throughput against the bare rollout of the same seconds, in one run.

    python benchmarks/env_steps.py [--seconds 10] [--repeats 3]

Prints simulated seconds per wall second for (a) the bare rollout ``bipedsim run`` takes
(``run_scenario`` on the built-in walk, no recorder), (b) ``bipedsim/Track-v0`` made with
``gymnasium.make`` (its checking wrappers included) stepped with a zero action and (c) the same with a
random residual, against (d) the bare loop stepped with the same residuals (a residual changes the
gait, and with it the contacts the physics solves); each the best of ``--repeats``; the ratios of (b)
to (a) and (c) to (d) (goal >= 0.8).
"""

from __future__ import annotations

import argparse
import sys
import time

import gymnasium as gym
import numpy as np

import bipedsim.envs  # noqa: F401 - registers the environments
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import Scenario, load_scenario, run_scenario


def bare(sc: Scenario, seconds: float) -> float:
    t0 = time.perf_counter()
    out, _ = run_scenario(sc, RolloutSpec(seconds=seconds))
    return out.sim_seconds / (time.perf_counter() - t0)


def episode(env: gym.Env, random: bool, seed: int = 0) -> float:
    env.reset(seed=seed)
    zero = np.zeros(env.action_space.shape, dtype=np.float32)
    env.action_space.seed(seed)
    t0 = time.perf_counter()
    done, info = False, {}
    while not done:
        a = env.action_space.sample() * 0.1 if random else zero
        _, _, term, trunc, info = env.step(a)
        done = term or trunc
    wall = time.perf_counter() - t0
    return info["time"] / wall


def bare_residual(env: gym.Env, seed: int = 0) -> float:
    """The same random residuals as :func:`episode` (same seed), set on the controller of the env's own
    rollout and stepped without the environment (no observation, reward or checks): the physics of a
    residual-driven episode at the bare loop's cost."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    run = env.unwrapped.run
    t0 = time.perf_counter()
    while not run.done:
        a = np.asarray(env.action_space.sample() * 0.1, dtype=np.float64)
        run.ctrl.target_offset = a
        run.step()
    return run.time / (time.perf_counter() - t0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    env = gym.make("bipedsim/Track-v0", seconds=args.seconds)
    sc = load_scenario(None, reconstruct=False)
    base = zero = rand = base_rand = 0.0
    for _ in range(args.repeats):  # interleaved: a load on the machine falls on all four alike
        base = max(base, bare(sc, args.seconds))
        zero = max(zero, episode(env, False))
        rand = max(rand, episode(env, True))
        base_rand = max(base_rand, bare_residual(env))
    print(f"built-in walk, {args.seconds:g} s episodes, best of {args.repeats}; control period "
          f"{env.unwrapped.run.every * env.unwrapped.model.opt.timestep * 1000:g} ms = one env step")
    print(f"bare rollout (bipedsim run)        : {base:7.1f} sim s / wall s")
    print(f"Track-v0, zero action              : {zero:7.1f} sim s / wall s  ratio {zero / base:5.2f} (goal >= 0.8)")
    print(f"bare loop, the same residuals      : {base_rand:7.1f} sim s / wall s  (a residual changes the gait's "
          "contacts: the physics costs more)")
    print(f"Track-v0, random residual (0.1 x)  : {rand:7.1f} sim s / wall s  ratio {rand / base_rand:5.2f} to the bare "
          f"loop with the same residuals (goal >= 0.8); {rand / base:5.2f} to the plain rollout")
    env.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
