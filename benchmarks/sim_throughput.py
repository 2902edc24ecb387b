"""Control + physics throughput against raw ``mj_step`` on the same model, in one run.

    python benchmarks/sim_throughput.py [--seconds 10]

Prints physics steps per second for (a) raw mj_step with zero controls from the same start, (b) the
full rollout (controller, fall checks, metrics) with the default controller (control every 4 ms, PD
stiffness in MuJoCo's actuators on every 2 ms step) and (c) the same with control on every physics
step; the ratio of each to (a) (target >= 0.5) and the real-time factor.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace

import mujoco

from bipedsim.control.humanoid.simbicon import gait_source
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args()
    sc = load_scenario()
    model = sc.built.model
    n = int(round(args.seconds / model.opt.timestep))
    src = gait_source(sc.built.model, sc.built.plan, sc.clip, sc.cfg)
    f = int(src.start_frame())

    data = mujoco.MjData(model)
    data.qpos[:] = sc.clip.qpos[f]
    data.qvel[:] = sc.clip.qvel[f]
    mujoco.mj_forward(model, data)
    t0 = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(model, data)
    raw = n / (time.perf_counter() - t0)

    print(f"model: {model.nq} qpos, {model.nv} dof, {model.nu} actuators, timestep {model.opt.timestep} s")
    print(f"raw mj_step                          : {raw:8.0f} steps/s")
    cfg = sc.cfg
    for label, control_dt in ((f"default controller ({1 / (cfg.control_dt or model.opt.timestep):.0f} Hz)",
                               cfg.control_dt), ("control on every physics step", None)):
        sc.cfg = replace(cfg, control_dt=control_dt)
        out, _ = run_scenario(sc, RolloutSpec(seconds=args.seconds))
        full = out.steps / out.wall_seconds
        print(f"{label:37s}: {full:8.0f} steps/s  ratio {full / raw:5.2f} (target >= 0.5)  "
              f"real-time {full * model.opt.timestep:5.1f}x  ({out.outcome}, {out.sim_seconds:.1f} s simulated)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
