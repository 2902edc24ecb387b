"""The creature's controller (behind :class:`~bipedsim.control.base.Controller`): PD tracking of a
retargeted clip on every ball joint, for any skeleton.

Each ball joint is driven toward the clip's local orientation by tau = kp e (N*m), e the rotation
vector (rad) from the current to the target orientation in the joint frame, clipped to the joint's
torque limit; the -kd omega term is MuJoCo joint damping (integrated implicitly: explicit damping of
light end bodies -- a head, a wing tip -- is unstable at millisecond steps). The clip plays at real
time and loops.

**Root support** (``support``, e.g. for flying clips or anything that cannot hold itself up): a PD
wrench on the root's free joint toward the clip's root pose, scaled by the body's mass plus its
weight -- an external assistance, not the creature's own doing -- whose mean and peak force and
torque are reported in :meth:`CreatureController.metrics`. It acts through ``qfrc_applied``, so
``xfrc_applied`` stays the pushes' alone.
"""

from __future__ import annotations

import mujoco
import numpy as np

from bipedsim.control.base import Controller, FloatArray
from bipedsim.control.creature_config import CreatureControlConfig
from bipedsim.errors import ModelError
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.plan import BodyPlanSet


def quat_error_rotvecs(q: FloatArray, qd: FloatArray) -> FloatArray:
    """Rotation vectors (rad) of conj(q) * qd for rows of MuJoCo quaternions (w, x, y, z): the
    rotation from each current orientation to its target, in the current (joint) frame."""
    w1, v1 = q[:, 0], -q[:, 1:]
    w2, v2 = qd[:, 0], qd[:, 1:]
    w = w1 * w2 - np.einsum("ij,ij->i", v1, v2)
    v = w1[:, None] * v2 + w2[:, None] * v1 + np.cross(v1, v2)
    sign = np.where(w < 0.0, -1.0, 1.0)  # the short way round
    w, v = w * sign, v * sign[:, None]
    n = np.linalg.norm(v, axis=1)
    angle = 2.0 * np.arctan2(n, w)
    scale = np.where(n > 1e-12, angle / np.maximum(n, 1e-12), 2.0)
    return v * scale[:, None]


class CreatureController(Controller):
    """PD tracking of a clip on every ball joint of a creature body (see the module's text)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                 cfg: CreatureControlConfig | None = None) -> None:
        if plan.profile != "creature":
            raise ModelError("the creature controller drives creature bodies (ball joints); this one is "
                             f"{plan.profile!r}")
        self.model, self.plan, self.clip = model, plan, clip
        self.cfg = cfg or CreatureControlConfig()
        self.control_dt = None
        self.root_body = 1
        self._set_ball_tables(model, plan)
        self.base_damping = model.dof_damping.copy()
        self.mass = float(np.sum(model.body_mass))
        self.weight = self.mass * -float(model.opt.gravity[2])
        self._feet = [model.body(f).id for f in plan.foot_bodies]
        self._foot_names = tuple(plan.foot_bodies)
        self.tracking_error = np.zeros(len(self.qadr))
        self.torque = np.zeros(model.nu)
        self.frame = 0.0
        self._support: list[tuple[float, float]] = []
        self._speed = float(np.linalg.norm(clip.qpos[-1, :2] - clip.qpos[0, :2]) / max(clip.duration, 1e-9))

    def _set_ball_tables(self, model: mujoco.MjModel, plan: BodyPlanSet) -> None:
        """qpos/dof addresses, three actuators, gains and torque limits of every ball joint."""
        acts: dict[int, list[int]] = {}
        for a in range(model.nu):
            acts.setdefault(int(model.actuator_trnid[a, 0]), []).append(a)
        gains = {j.name: (j.kp, j.kd) for b in plan.bodies for j in b.joints}
        balls = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
        self.joint_names = [model.joint(j).name for j in balls]
        self.qadr = np.array([model.jnt_qposadr[j] for j in balls], dtype=np.int64)
        self.dadr = np.array([model.jnt_dofadr[j] for j in balls], dtype=np.int64)
        self.acts = np.array([sorted(acts.get(j, []))[:3] for j in balls], dtype=np.int64).reshape(len(balls), 3)
        self.kp = np.array([gains[n][0] for n in self.joint_names])
        self.kd = np.array([gains[n][1] for n in self.joint_names])
        self.limit = np.array([model.actuator_ctrlrange[a[0], 1] for a in self.acts])
        self._quat_idx = self.qadr[:, None] + np.arange(4)

    # ------------------------------------------------------------------ the control step
    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        self.frame = 0.0 if frame is None else float(frame)
        self._t0 = t - self.frame * self.clip.frame_time
        self._support.clear()
        self.model.dof_damping[:] = self.base_damping
        for k, d in enumerate(self.dadr):
            self.model.dof_damping[d:d + 3] += self.kd[k]

    def restore_model(self) -> None:
        self.model.dof_damping[:] = self.base_damping

    def _frame_index(self) -> int:
        n = self.clip.num_frames
        i = int(self.frame)
        return i % n if self.cfg.loop else min(i, n - 1)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        self.frame = (t - self._t0) / self.clip.frame_time
        target = self.clip.qpos[self._frame_index()]
        e = quat_error_rotvecs(data.qpos[self._quat_idx], target[self._quat_idx])
        self.tracking_error = np.linalg.norm(e, axis=1)
        tau = np.clip(self.kp[:, None] * e, -self.limit[:, None], self.limit[:, None])
        self.torque[self.acts.ravel()] = tau.ravel()
        if self.cfg.support:
            self._apply_support(data, target)
        return self.torque

    def _apply_support(self, data: mujoco.MjData, target: FloatArray) -> None:
        """The root-support wrench toward the clip's root pose (world-frame force, body-frame torque)."""
        c, m = self.cfg, self.mass
        force = m * (c.support_kp * (target[:3] - data.qpos[:3]) - c.support_kd * data.qvel[:3])
        force[2] += self.weight
        r = data.xmat[self.root_body].reshape(3, 3)
        err = quat_error_rotvecs(data.qpos[None, 3:7], target[None, 3:7])[0]  # body frame
        torque_body = m * (0.1 * c.support_kp * err - 0.1 * c.support_kd * data.qvel[3:6])
        data.qfrc_applied[0:3] = force
        data.qfrc_applied[3:6] = torque_body
        self._support.append((float(np.linalg.norm(force)), float(np.linalg.norm(r @ torque_body))))

    # ------------------------------------------------------------------ read-outs
    def reference_qpos(self) -> FloatArray:
        return self.clip.qpos[self._frame_index()]

    def reference_speed(self) -> float:
        return self._speed

    def actuator_torques(self) -> FloatArray:
        return self.torque

    def foot_names(self) -> tuple[str, ...]:
        return self._foot_names

    def foot_forces(self, data: mujoco.MjData) -> list[float]:
        """Each foot body's vertical contact force with anything (N), from MuJoCo's contacts."""
        out = [0.0] * len(self._feet)
        if not data.ncon:
            return out
        f6 = np.zeros(6)
        for i in range(data.ncon):
            con = data.contact[i]
            for k, b in enumerate(self._feet):
                if b in (self.model.geom_bodyid[con.geom1], self.model.geom_bodyid[con.geom2]):
                    mujoco.mj_contactForce(self.model, data, i, f6)
                    # the normal force along the contact frame's first axis, its world z share
                    out[k] += abs(f6[0] * con.frame[2])
        return out

    def metrics(self) -> dict[str, object]:
        out: dict[str, object] = {"profile": "creature", "support_mode": self.cfg.support, "weight_n": self.weight}
        if self._support:
            f, tq = np.array(self._support).T
            out.update({"support_force_mean_n": float(f.mean()), "support_force_max_n": float(f.max()),
                        "support_torque_mean_nm": float(tq.mean()), "support_torque_max_nm": float(tq.max())})
        return out


__all__ = ["CreatureControlConfig", "CreatureController", "quat_error_rotvecs"]
