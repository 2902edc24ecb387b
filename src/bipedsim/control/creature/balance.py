"""The clip-timed creature balance (``gait: clip``), after Coros et al. 2011 ("Locomotion Skills for
Simulated Quadrupeds") and SIMBICON, for any skeleton: PD tracking of the clip on every ball joint plus

- **virtual wrench on the body**, applied through the legs whose feet really touch the ground by
  Jacobian transpose: gravity compensation and height control (vertical force), attitude control of
  the root against the clip's own root orientation with its heading taken out (torque), speed
  control toward the clip's root velocity turned into the body's heading (horizontal force). The
  wrench is shared among the stance feet by the least-norm contact forces f_i that produce it
  (sum f_i = F, sum r_i x f_i = T), each kept pushing (f_z >= 0) inside the friction cone; each
  stance leg's joints then get tau = -J_i^T f_i (J_i: the foot point's Jacobian over the leg's
  degrees of freedom, ``mj_jac``), so the ground pushes back f_i;
- **swing-foot placement** on each leg the clip has in swing: its leg-root joint target turned so
  the foot moves by ``placement`` x sqrt(L/g) x (v - v_d) (the inverted-pendulum step, per leg);
- **resynchronisation**: a leg counts as stance only while its foot really touches the ground, and
  the clip's clock waits (up to ``max_wait_s`` per step) for a foot the clip puts down that has not
  landed yet.

Every gain is scaled by the body: forces by its mass m and the natural frequency sqrt(g/L) of its
standing root height L, torques by m L^2. One default, no per-clip settings.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.frames import rot_z, yaw_between
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.reference import LoopedReference
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.control.creature.tracking import CreatureBody, Tracking
from bipedsim.control.humanoid.balance import heading_of


def balance_metrics(track: Tracking, name: str, legs: LegSet, resyncs: int,
                    virtual: list[tuple[float, float]]) -> dict[str, object]:
    """The outcome's figures of a legged balance: the tracking's, the controller's name, its legs,
    resynchronisations and the virtual wrench's mean force (N) and torque (N*m)."""
    out = track.metrics()
    out["controller"] = name
    out["legs"] = [leg.root for leg in legs.legs]
    out["resyncs"] = resyncs
    if virtual:
        f, tq = np.array(virtual).T
        out.update({"virtual_force_mean_n": float(f.mean()), "virtual_torque_mean_nm": float(tq.mean())})
    return out


class ClipBalance:
    """The clip-timed balance of a legged creature (see the module text): the clip's own timing, its
    clock held for late feet, a virtual wrench through the stance legs and swing-foot placement."""

    name = "creature_balance"
    #: no planned pose: the reference is the clip's frame now
    target: FloatArray | None = None

    def __init__(self, body: CreatureBody, legs: LegSet, ref: LoopedReference, track: Tracking,
                 bal: CreatureBalanceConfig) -> None:
        self.body, self.legs, self.ref, self.track, self.bal = body, legs, ref, track, bal
        self.resyncs = 0
        #: (time s, leg root) of every real foot strike
        self.strikes: list[tuple[float, str]] = []
        #: (force N, torque N*m) of the virtual wrench at each step with a stance leg
        self.virtual: list[tuple[float, float]] = []
        self._wait = 0.0
        self._was_down = [False] * len(legs)

    def reset(self, data: mujoco.MjData, t: float) -> None:
        self.resyncs = 0
        self.strikes = []
        self.virtual = []
        self._wait = 0.0
        self._was_down = [False] * len(self.legs)

    # ------------------------------------------------------------------ the control step
    def step(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        body, track, clip = self.body, self.track, self.ref.clip
        down = self.legs.feet_down(data)
        self._resync(t, dt, down)
        track.frame = (t - track.t0) / clip.frame_time
        f = track.frame_index()
        target = clip.qpos[f].copy()
        r = data.xmat[body.root_body].reshape(3, 3)
        r_ref = Rotation.from_quat(target[3:7], scalar_first=True).as_matrix()
        yaw = yaw_between(r, r_ref)
        v_d = (rot_z(yaw) @ np.array([*self.ref.v_ref[f], 0.0]))
        self._place_swing_feet(data, target, f, v_d, down)
        e = body.joint_error(data, target)
        track.tracking_error = np.linalg.norm(e, axis=1)
        # kd (qdot_ref - qdot): the -kd qdot half is MuJoCo's implicit joint damping, the reference
        # velocity half is fed forward here so fast swings are not damped away
        tau = body.kp[:, None] * e
        if self.bal.velocity_feedforward:
            tau = tau + body.kd[:, None] * clip.qvel[f][body.vel_idx]
        tau_all = np.zeros(model.nu)
        tau_all[body.acts.ravel()] = tau.ravel()
        stance = [i for i, d in enumerate(down) if d]
        if stance:
            tau_all += self._virtual_torques(data, target, r, r_ref, yaw, v_d, stance)
        return body.clipped(tau_all)

    def _resync(self, t: float, dt: float, down: list[bool]) -> None:
        """Hold the clip's clock while a foot the clip has on the ground is still in the air (at most
        ``max_wait_s`` per step); record real foot strikes."""
        legs, clip = self.legs, self.ref.clip
        f = self.track.frame_index()
        for i, d in enumerate(down):
            if d and not self._was_down[i]:
                self.strikes.append((t, legs.legs[i].root))
                self._wait = 0.0
            self._was_down[i] = d
        late = [i for i in range(len(legs)) if legs.clip_down(clip, f, i) and not down[i]
                and not legs.clip_down(clip, max(f - 1, 0), i)]
        if late and self._wait + dt <= self.bal.max_wait_s:
            if self._wait == 0.0:
                self.resyncs += 1
            self._wait += dt
            self.track.t0 += dt

    def _place_swing_feet(self, data: mujoco.MjData, target: FloatArray, f: int, v_d: FloatArray,
                          down: list[bool]) -> None:
        """Turn the root-joint target of each leg in swing (in the clip, and off the ground) so its foot
        lands ``placement`` sqrt(L/g) (v - v_d) further along the velocity error (the inverted-pendulum
        step), at most ``max_placement`` L."""
        legs, qadr = self.legs, self.body.qadr
        dv = data.qvel[0:3].copy() - v_d
        dv[2] = 0.0
        if self.bal.placement <= 0 or not np.any(dv):
            return
        shift = self.bal.placement / legs.omega0 * dv  # m
        cap = self.bal.max_placement * legs.height
        size = float(np.linalg.norm(shift))
        if size > cap:
            shift *= cap / size
        for i in range(len(legs)):
            if legs.clip_down(self.ref.clip, f, i) or down[i]:
                continue
            k = legs.root_ball[i]
            rp = data.xmat[legs.root_parent[i]].reshape(3, 3)
            hip = data.xpos[self.body.model.body(legs.legs[i].root).id]
            foot = data.site_xpos[legs.sites[i][0]]
            arm = hip - foot
            length = float(np.linalg.norm(arm)) or 1e-9
            w = np.cross(arm / length, shift) / length  # world rotation vector moving the foot by ``shift``
            w = -w
            local = Rotation.from_rotvec(rp.T @ w)
            q = target[qadr[k]:qadr[k] + 4]
            target[qadr[k]:qadr[k] + 4] = (local * Rotation.from_quat(q, scalar_first=True)).as_quat(
                scalar_first=True)

    def _virtual_torques(self, data: mujoco.MjData, target: FloatArray, r: FloatArray, r_ref: FloatArray,
                         yaw: float, v_d: FloatArray, stance: list[int]) -> FloatArray:
        """Joint torques (by actuator) that make the stance feet push the desired wrench."""
        b, m, w0 = self.bal, self.body.mass, self.legs.omega0
        g = -float(self.body.model.opt.gravity[2])
        com = data.subtree_com[self.body.root_body]
        vel = data.qvel[0:3]
        wh, wa = b.height_freq * w0, b.attitude_freq * w0
        force = np.zeros(3)
        force[2] = m * (b.gravity_comp * g + wh * wh * (target[2] - data.qpos[2]) - 2 * b.damping_ratio * wh * vel[2])
        force[0:2] = m * b.speed_gain * w0 * (v_d[0:2] - vel[0:2])
        r_d = rot_z(yaw) @ r_ref
        err = Rotation.from_matrix(r_d @ r.T).as_rotvec()
        err[2] = 0.0  # the heading is the clip's to follow, not the stance legs' to force
        omega = r @ data.qvel[3:6]
        inertia = m * self.legs.height ** 2
        torque = inertia * (wa * wa * err - 2 * b.damping_ratio * wa * omega)
        torque[2] = 0.0
        self.virtual.append((float(np.linalg.norm(force)), float(np.linalg.norm(torque))))
        return self.legs.stance_torques(data, force, torque, stance, com, b.friction)

    # ------------------------------------------------------------------ read-outs
    def reference_speed(self) -> float:
        return self.track.speed

    def heading(self, data: mujoco.MjData) -> float:
        """The root body's heading (rad about world Z)."""
        return heading_of(data.xmat[self.body.root_body].reshape(3, 3))

    def foot_strikes(self) -> list[tuple[float, str]]:
        return list(self.strikes)

    def metrics(self) -> dict[str, object]:
        return balance_metrics(self.track, self.name, self.legs, self.resyncs, self.virtual)


__all__ = ["ClipBalance", "balance_metrics"]
