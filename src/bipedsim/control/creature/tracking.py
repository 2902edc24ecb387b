"""PD tracking of a clip on every ball joint of a creature body, and the optional root support.

Each ball joint is driven toward the clip's local orientation by tau = kp e (N*m), e the rotation
vector (rad) from the current to the target orientation in the joint frame, clipped to the joint's
torque limit; the -kd omega term is MuJoCo joint damping (integrated implicitly: explicit damping of
light end bodies -- a head, a wing tip -- is unstable at millisecond steps). The clip plays at real
time and loops.

**Root support** (``support``, e.g. for flying clips or anything that cannot hold itself up): a PD
wrench on the root's free joint toward the clip's root pose, scaled by the body's mass plus its
weight -- an external assistance, not the creature's own doing -- whose mean and peak force and
torque are reported in :meth:`Tracking.metrics`. It acts through ``qfrc_applied``, so
``xfrc_applied`` stays the pushes' alone.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.settings import CreatureControlConfig
from bipedsim.errors import ModelError
from bipedsim.model.plan import BodyPlanSet
from bipedsim.reference.clip import ReferenceClip

#: the root support's rotational gains as a share of its positional ones (N*m/rad per N/m)
SUPPORT_ROTATION_SHARE = 0.1


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


class CreatureBody:
    """What every part of the creature controller reads of the built body: its ball joints (qpos and
    dof addresses, three actuators each, gains, torque limits N*m), its mass (kg) and weight (N), the
    model's own joint damping, and the torque buffer (N*m per actuator) the control step fills."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet) -> None:
        if plan.profile != "creature":
            raise ModelError("the creature controller drives creature bodies (ball joints); this one is "
                             f"{plan.profile!r}")
        self.model, self.plan = model, plan
        #: the body pushes act on and fall detection watches: the creature's root
        self.root_body = 1
        acts: dict[int, list[int]] = {}
        for a in range(model.nu):
            acts.setdefault(int(model.actuator_trnid[a, 0]), []).append(a)
        gains = {j.name: (j.kp, j.kd) for b in plan.bodies for j in b.joints}
        balls = ball_joints(model)
        self.joint_names = [model.joint(j).name for j in balls]
        self.qadr = np.array([model.jnt_qposadr[j] for j in balls], dtype=np.int64)
        self.dadr = np.array([model.jnt_dofadr[j] for j in balls], dtype=np.int64)
        self.acts = np.array([sorted(acts.get(j, []))[:3] for j in balls], dtype=np.int64).reshape(len(balls), 3)
        self.kp = np.array([gains[n][0] for n in self.joint_names])
        self.kd = np.array([gains[n][1] for n in self.joint_names])
        self.limit = np.array([model.actuator_ctrlrange[a[0], 1] for a in self.acts])
        #: (balls, 4) qpos indices of each ball joint's quaternion; (balls, 3) its velocity's dof indices
        self.quat_idx = self.qadr[:, None] + np.arange(4)
        self.vel_idx = self.dadr[:, None] + np.arange(3)
        self.base_damping = model.dof_damping.copy()
        self.mass = float(np.sum(model.body_mass))
        self.weight = self.mass * -float(model.opt.gravity[2])
        self.torque = np.zeros(model.nu)
        #: see :attr:`bipedsim.control.base.Controller.target_offset`; here (balls, 3) rad, None: none
        self.target_offset: FloatArray | None = None
        self.target_absolute = False

    def joint_error(self, data: mujoco.MjData, target: FloatArray) -> FloatArray:
        """(balls, 3) rotation vectors (rad, joint frame) from each ball joint's pose to ``target``'s,
        with :attr:`target_offset` (rad, (balls, 3)) added (a policy's residual, to first order a rotation
        of the target by it); with :attr:`target_absolute`, to the offset's own orientations instead
        (rotation vectors from the parent frame)."""
        q = data.qpos[self.quat_idx]
        if self.target_offset is None:
            return quat_error_rotvecs(q, target[self.quat_idx])
        if self.target_absolute:
            return quat_error_rotvecs(q, Rotation.from_rotvec(self.target_offset).as_quat(scalar_first=True))
        return quat_error_rotvecs(q, target[self.quat_idx]) + self.target_offset

    def damp(self) -> None:
        """The model's joint damping plus each ball joint's kd (the PD's -kd omega, integrated implicitly)."""
        self.model.dof_damping[:] = self.base_damping
        for k, d in enumerate(self.dadr):
            self.model.dof_damping[d:d + 3] += self.kd[k]

    def restore(self) -> None:
        """The model's own joint damping back."""
        self.model.dof_damping[:] = self.base_damping

    def clipped(self, tau_all: FloatArray) -> FloatArray:
        """``tau_all`` (N*m by actuator) held to each ball joint's torque limit, into the torque buffer."""
        lim = np.repeat(self.limit, 3)
        order = self.acts.ravel()
        self.torque[order] = np.clip(tau_all[order], -lim, lim)
        return self.torque


def ball_joints(model: mujoco.MjModel) -> list[int]:
    """The ids of the model's ball joints, in model order."""
    return [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]


class Tracking:
    """PD tracking of ``clip`` on every ball joint at real time (see the module text). ``loop``: the
    frames [a, b) played and looped after the first pass (None: the whole clip, looped when
    ``cfg.loop``)."""

    def __init__(self, body: CreatureBody, clip: ReferenceClip, cfg: CreatureControlConfig,
                 loop: tuple[int, int] | None = None) -> None:
        self.body, self.clip, self.cfg, self.loop = body, clip, cfg, loop
        #: the clip frame played now (a float: between frames) and the time (s) frame 0 played at
        self.frame = 0.0
        self.t0 = 0.0
        #: per ball joint, the last step's rotation error (rad)
        self.tracking_error = np.zeros(len(body.qadr))
        #: (force N, torque N*m) of the root support at each step
        self.support_log: list[tuple[float, float]] = []
        #: the clip's mean horizontal root speed (m/s), first frame to last
        self.speed = float(np.linalg.norm(clip.qpos[-1, :2] - clip.qpos[0, :2]) / max(clip.duration, 1e-9))

    def frame_index(self) -> int:
        """The clip frame the current ``frame`` plays."""
        i = int(self.frame)
        if self.loop is not None:
            a, b = self.loop
            return i if i < b else a + (i - a) % (b - a)
        n = self.clip.num_frames
        return i % n if self.cfg.loop else min(i, n - 1)

    def reset(self, frame: float, t: float) -> None:
        """Play ``frame`` at time ``t`` (s); the joints' damping set."""
        self.frame = float(frame)
        self.t0 = t - self.frame * self.clip.frame_time
        self.support_log.clear()
        self.body.damp()

    def step(self, data: mujoco.MjData, t: float) -> FloatArray:
        """The PD torques (N*m by actuator) at time ``t``; the root support applied when configured."""
        body = self.body
        self.frame = (t - self.t0) / self.clip.frame_time
        target = self.clip.qpos[self.frame_index()]
        e = body.joint_error(data, target)
        self.tracking_error = np.linalg.norm(e, axis=1)
        tau = np.clip(body.kp[:, None] * e, -body.limit[:, None], body.limit[:, None])
        body.torque[body.acts.ravel()] = tau.ravel()
        if self.cfg.support:
            self.apply_support(data, target)
        return body.torque

    def apply_support(self, data: mujoco.MjData, target: FloatArray) -> None:
        """The root-support wrench toward the clip's root pose (world-frame force, body-frame torque)."""
        c, m = self.cfg, self.body.mass
        force = m * (c.support_kp * (target[:3] - data.qpos[:3]) - c.support_kd * data.qvel[:3])
        force[2] += self.body.weight
        r = data.xmat[self.body.root_body].reshape(3, 3)
        err = quat_error_rotvecs(data.qpos[None, 3:7], target[None, 3:7])[0]  # body frame
        share = SUPPORT_ROTATION_SHARE
        torque_body = m * (share * c.support_kp * err - share * c.support_kd * data.qvel[3:6])
        data.qfrc_applied[0:3] = force
        data.qfrc_applied[3:6] = torque_body
        self.support_log.append((float(np.linalg.norm(force)), float(np.linalg.norm(r @ torque_body))))

    def reference_qpos(self) -> FloatArray:
        return self.clip.qpos[self.frame_index()]

    def metrics(self) -> dict[str, object]:
        """The body kind, whether the root was supported, the body weight (N) and the support's mean and
        peak force (N) and torque (N*m)."""
        out: dict[str, object] = {"profile": "creature", "support_mode": self.cfg.support,
                                  "weight_n": self.body.weight}
        if self.support_log:
            f, tq = np.array(self.support_log).T
            out.update({"support_force_mean_n": float(f.mean()), "support_force_max_n": float(f.max()),
                        "support_torque_mean_nm": float(tq.mean()), "support_torque_max_nm": float(tq.max())})
        return out


__all__ = ["CreatureBody", "Tracking", "ball_joints", "quat_error_rotvecs"]
