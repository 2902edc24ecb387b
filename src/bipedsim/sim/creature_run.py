"""Tracking any creature's motion in physics: PD on every ball joint toward the retargeted clip.

Ground creatures stand on their own contacts; a fall is the root dropping below a fraction of its
starting height or tilting past a limit. Flying clips (or anything that cannot hold itself up) can
use the **root-support mode**: a PD wrench on the root body toward the clip's root pose, applied
through ``xfrc_applied`` -- an external assistance, not the creature's own doing -- whose mean and
peak force and torque are reported with the outcome.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.model.build import BuiltModel
from bipedsim.model.clip import ReferenceClip
from bipedsim.sim.rollout import MujocoWarnings, Outcome, diverged

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class CreatureRunSpec:
    seconds: float = 5.0
    seed: int = 0
    support: bool = False
    support_kp: float = 2000.0  #: N/m per kg of body mass... scaled below
    support_kd: float = 200.0
    root_height_fraction: float = 0.4
    root_tilt: float = 1.4
    loop: bool = True


def _ball_joints(model: mujoco.MjModel) -> list[tuple[int, int, int, list[int]]]:
    """(joint id, qpos adr, dof adr, [3 actuator ids]) of every ball joint."""
    acts: dict[int, list[int]] = {}
    for a in range(model.nu):
        acts.setdefault(int(model.actuator_trnid[a, 0]), []).append(a)
    out = []
    for j in range(model.njnt):
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            out.append((j, int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), sorted(acts.get(j, []))))
    return out


def run_creature(built: BuiltModel, clip: ReferenceClip, spec: CreatureRunSpec) -> Outcome:
    """Track ``clip`` on a creature model; returns the outcome (support forces in ``extra``)."""
    from bipedsim.io import versions

    t_wall = time.perf_counter()
    model, plan = built.model, built.plan
    data = mujoco.MjData(model)
    data.qpos[:] = clip.qpos[0]
    data.qvel[:] = clip.qvel[0]
    mujoco.mj_forward(model, data)
    balls = _ball_joints(model)
    gains = {j.name: (j.kp, j.kd) for b in plan.bodies for j in b.joints}
    kp = np.array([gains[model.joint(j).name][0] for j, *_ in balls])
    kd = np.array([gains[model.joint(j).name][1] for j, *_ in balls])
    lim = np.array([model.actuator_ctrlrange[a[0], 1] if a else 0.0 for *_, a in balls])
    mass = float(np.sum(model.body_mass))
    # kd as MuJoCo joint damping, integrated implicitly: explicit damping of light end bodies (a head,
    # a wing tip) is unstable at millisecond steps
    base_damping = model.dof_damping.copy()
    for k, (_, _, da, _) in enumerate(balls):
        model.dof_damping[da:da + 3] = base_damping[da:da + 3] + kd[k]
    dt = model.opt.timestep
    n = int(round(spec.seconds / dt))
    root = 1
    h0 = float(data.xpos[root][2])
    support_f, support_t = [], []
    err2, n_err = 0.0, 0
    outcome, fall_t, reason = "no_fall", None, None
    frames = clip.num_frames
    step = 0
    with MujocoWarnings() as mj_warnings:
        for step in range(n):
            t = step * dt
            f = t / clip.frame_time
            i = int(f) % frames if spec.loop else min(int(f), frames - 1)
            target = clip.qpos[i]
            for k, (_, qa, _da, acts) in enumerate(balls):
                q = data.qpos[qa:qa + 4]
                qd = target[qa:qa + 4]
                # error rotation from the current to the target local orientation, in the joint frame
                r = (Rotation.from_quat([q[1], q[2], q[3], q[0]]).inv()
                     * Rotation.from_quat([qd[1], qd[2], qd[3], qd[0]]))
                e = r.as_rotvec()
                err2 += float(e @ e)
                n_err += 1
                tau = np.clip(kp[k] * e, -lim[k], lim[k])
                data.ctrl[acts] = tau
            if spec.support:
                # PD wrench on the root toward the clip's root pose, scaled by the body's mass
                p_err = target[:3] - data.qpos[:3]
                v = data.qvel[:3]
                force = mass * (spec.support_kp / 100.0 * p_err - spec.support_kd / 100.0 * v)
                force[2] += mass * -model.opt.gravity[2]
                rq = Rotation.from_quat([data.qpos[4], data.qpos[5], data.qpos[6], data.qpos[3]])
                rd = Rotation.from_quat([target[4], target[5], target[6], target[3]])
                rot_err = (rd * rq.inv()).as_rotvec()
                omega = rq.apply(data.qvel[3:6])
                torque = mass * (spec.support_kp / 1000.0 * rot_err - spec.support_kd / 1000.0 * omega)
                data.xfrc_applied[root, :3] = force
                data.xfrc_applied[root, 3:] = torque
                support_f.append(float(np.linalg.norm(force)))
                support_t.append(float(np.linalg.norm(torque)))
            mujoco.mj_step(model, data)
            bad = diverged(data)
            if bad:
                outcome, fall_t, reason = "diverged", (step + 1) * dt, mj_warnings.reason(bad)
                break
            if not spec.support:
                z = float(data.xpos[root][2])
                up = data.xmat[root].reshape(3, 3)[:, 2]
                if z < spec.root_height_fraction * h0:
                    outcome, fall_t, reason = "fall", (step + 1) * dt, "root below its starting height fraction"
                    break
                if np.arccos(np.clip(up[2], -1, 1)) > spec.root_tilt:
                    outcome, fall_t, reason = "fall", (step + 1) * dt, "root tilted past the limit"
                    break
    model.dof_damping[:] = base_damping
    sim_s = (step + 1) * dt
    dist = float(np.linalg.norm(data.qpos[:2] - clip.qpos[0, :2])) if outcome != "diverged" else 0.0
    extra = {"profile": "creature", "support_mode": spec.support, "weight_n": mass * -model.opt.gravity[2]}
    if spec.support and support_f:
        extra.update({"support_force_mean_n": float(np.mean(support_f)),
                      "support_force_max_n": float(np.max(support_f)),
                      "support_torque_mean_nm": float(np.mean(support_t)),
                      "support_torque_max_nm": float(np.max(support_t))})
    return Outcome(outcome=outcome, sim_seconds=sim_s, fall_time_s=fall_t, fall_reason=reason, foot_strikes=0,
                   distance_m=dist, mean_speed_mps=dist / sim_s, reference_speed_mps=float(
                       np.linalg.norm(clip.qpos[-1, :2] - clip.qpos[0, :2]) / max(clip.duration, 1e-9)),
                   tracking_rmse_rad=float(np.sqrt(err2 / max(n_err, 1))), wall_seconds=time.perf_counter() - t_wall,
                   steps=step + 1, resyncs=0, mean_resync_ratio=None, seed=spec.seed, versions=versions(), extra=extra)
