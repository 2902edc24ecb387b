"""The legged creature's balance controller, after Coros et al. 2011 ("Locomotion Skills for Simulated
Quadrupeds") and SIMBICON, for any skeleton: PD tracking of the clip on every ball joint (the base
:class:`~bipedsim.control.creature.CreatureController`) plus

- **legs** found from the body (:func:`~bipedsim.model.creature.creature_legs`: foot end effectors
  walked up to where they leave the trunk), any number;
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

import math
from dataclasses import replace

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature import CreatureControlConfig, CreatureController, quat_error_rotvecs
from bipedsim.control.creature_config import CreatureBalanceConfig
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.creature import Leg, creature_legs
from bipedsim.model.plan import FLOOR_NAME, BodyPlanSet


def distribute_wrench(force: FloatArray, torque: FloatArray, points: FloatArray, com: FloatArray,
                      reg: float = 1e-6) -> FloatArray:
    """(N, 3) least-norm contact forces (N) at ``points`` (N, 3; m, world) whose sum is ``force`` and
    whose moment about ``com`` is ``torque`` (N*m), as nearly as the points allow."""
    n = len(points)
    a = np.zeros((6, 3 * n))
    for i, p in enumerate(points):
        r = p - com
        a[0:3, 3 * i:3 * i + 3] = np.eye(3)
        a[3:6, 3 * i:3 * i + 3] = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    w = np.concatenate([force, torque])
    scale = max(float(np.trace(a @ a.T)) / 6.0, 1e-9)
    f = a.T @ np.linalg.solve(a @ a.T + reg * scale * np.eye(6), w)
    return f.reshape(n, 3)


#: frames whose root stands lower than this fraction of the clip's median root height are not part of
#: the walk (a dog lying down before it gets up)
STANDING_FRACTION = 0.75
#: the looped part of a clip spans at least this share of its standing frames
MIN_LOOP_SHARE = 0.5


def loop_segment(clip: ReferenceClip, quat_idx: npt.NDArray[np.int64]) -> tuple[int, int]:
    """Frames [a, b) of the clip to play and loop: among the frames where the root stands (height at
    least STANDING_FRACTION of the median), the pair a < b, at least MIN_LOOP_SHARE of them apart, whose
    poses (joint rotations and root height) differ least, so the loop's seam is the smoothest the clip
    offers."""
    z = clip.qpos[:, 2]
    standing = np.flatnonzero(z >= STANDING_FRACTION * np.median(z))
    if len(standing) < 4:
        return 0, clip.num_frames
    lo, hi = int(standing[0]), int(standing[-1]) + 1
    q = clip.qpos[lo:hi][:, quat_idx]  # (n, balls, 4)
    feat_z = z[lo:hi] / max(float(np.median(z)), 1e-9)
    n = hi - lo
    gap = max(2, int(MIN_LOOP_SHARE * n))
    best, pair = np.inf, (lo, hi)
    for a in range(0, n - gap):
        dots = np.abs(np.einsum("jk,bjk->bj", q[a], q[a + gap:]))
        d = np.sum(1.0 - np.minimum(dots, 1.0), axis=1) + np.abs(feat_z[a + gap:] - feat_z[a])
        k = int(np.argmin(d))
        if d[k] < best:
            best, pair = float(d[k]), (lo + a, lo + a + gap + k)
    return pair


#: frames whose lowest leg stands higher than this fraction of the standing root height are in flight
#: (a gallop's or a jump's): they keep the clip's own height, shifted by the median of the others
FLIGHT_FRACTION = 0.1


def geom_bottom(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    """The lowest point (m, world z) of geom ``g`` as posed in ``data`` (spheres, capsules and boxes exactly,
    other shapes by their bounding sphere)."""
    z = float(data.geom_xpos[g][2])
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return z - float(model.geom_size[g][0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:  # axis along the geom's local z, half-length size[1]
        return z - float(model.geom_size[g][0]) - abs(float(data.geom_xmat[g][8])) * float(model.geom_size[g][1])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:  # its lowest corner: half sizes along the axes' vertical parts
        return z - float(np.abs(data.geom_xmat[g][6:9]) @ model.geom_size[g])
    return z - float(model.geom_rbound[g])


def yaw_between(r: FloatArray, r_ref: FloatArray) -> float:
    """The heading turn (rad, about world Z) that best carries orientation ``r_ref`` onto ``r``."""
    e = r @ r_ref.T
    return math.atan2(e[1, 0] - e[0, 1], e[0, 0] + e[1, 1])


def _rz(a: float) -> FloatArray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _leg_height(model: mujoco.MjModel, clip: ReferenceClip, legs: list[Leg]) -> float:
    """The height (m) the balance works at: the root body's median height, or -- where the root is not
    where the body is (a root joint at the floor carrying the travel, as ActorCore's ``BoneRoot``: 0 m,
    and a square root of it had stopped the run) -- the legs' roots' median height above the lowest foot."""
    h = float(np.median(clip.qpos[:, 2]))
    if not legs:
        return h
    d = mujoco.MjData(model)
    roots = [model.body(leg.root).id for leg in legs]
    feet = [model.body(f).id for leg in legs for f in leg.feet]
    hips = []
    for f in np.unique(np.linspace(0, clip.num_frames - 1, min(clip.num_frames, 40)).astype(int)):
        d.qpos[:] = clip.qpos[f]
        mujoco.mj_kinematics(model, d)
        hips.append(float(np.mean(d.xpos[roots, 2]) - np.min(d.xpos[feet, 2])))
    legs_h = float(np.median(hips))
    return legs_h if h < 0.5 * legs_h else h


class CreatureBalanceController(CreatureController):
    """PD tracking plus legged balance for any creature (see the module text)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                 cfg: CreatureControlConfig | None = None, balance: CreatureBalanceConfig | None = None) -> None:
        super().__init__(model, plan, clip, cfg)
        self.bal = balance or self.cfg.balance
        self.legs = creature_legs(plan)
        self.leg_height = _leg_height(model, clip, self.legs)
        self.omega0 = math.sqrt(-float(model.opt.gravity[2]) / max(self.leg_height, 1e-3))
        self._leg_tables(model, plan)
        self._level_reference(model)
        self._ref_velocity(self.clip)
        self.loop = loop_segment(clip, self._quat_idx)
        self._vel_idx = self.dadr[:, None] + np.arange(3)
        self.resyncs = 0
        self._strikes: list[tuple[float, str]] = []
        self.virtual: list[tuple[float, float]] = []

    def _leg_tables(self, model: mujoco.MjModel, plan: BodyPlanSet) -> None:
        """Per leg: its dof columns, its actuators (same order), the feet's body ids and tip sites, the
        leg-root ball index, and which clip contact columns are its feet."""
        ball_of = {model.jnt_bodyid[j]: k for k, j in enumerate(
            [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL])}
        self.leg_dofs, self.leg_acts, self.leg_feet, self.leg_sites, self.leg_root_ball = [], [], [], [], []
        self.leg_clip_cols, self.leg_length = [], []
        for leg in self.legs:
            ks = [ball_of[model.body(b).id] for b in leg.bodies if model.body(b).id in ball_of]
            self.leg_dofs.append(np.concatenate([self.dadr[k] + np.arange(3) for k in ks]))
            self.leg_acts.append(np.concatenate([self.acts[k] for k in ks]))
            self.leg_feet.append([model.body(f).id for f in leg.feet])
            self.leg_sites.append([model.site(f"{f}_touch").id for f in leg.feet])
            self.leg_root_ball.append(ball_of[model.body(leg.root).id])
            self.leg_clip_cols.append([self.clip.foot_names.index(f) for f in leg.feet if f in self.clip.foot_names])
        #: floor-contact geoms of each leg: its feet and the bodies they hang from (a foot's own
        #: geom may be a tiny sphere while the bone to it, on the parent body, meets the ground)
        self.geom_leg: dict[int, int] = {}
        for i, feet in enumerate(self.leg_feet):
            lower = set(feet) | {int(model.body_parentid[f]) for f in feet}
            for g in range(model.ngeom):
                if model.geom_bodyid[g] in lower:
                    self.geom_leg[g] = i
        self.floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, FLOOR_NAME)
        self.root_ball_parent = [model.body_parentid[model.body(leg.root).id] for leg in self.legs]
        self.jacp = np.zeros((3, model.nv))

    def _level_reference(self, model: mujoco.MjModel) -> None:
        """Re-level the reference on this body's legs: pose the clip frame by frame, measure each leg's
        lowest point (``ref_low``, m: its lower end's geoms, as the contacts see them) and shift the
        root height (``level_shift``, m per frame) so the lowest leg touches the floor in every frame
        where one is near it (below FLIGHT_FRACTION of the standing height; frames in flight take the
        median shift). A body built from bone lengths stands its feet centimetres above or into the
        floor where the capture's joints touched it (the dog's front paws and the horse's hooves
        float 2-3 cm, the flamingo's stance foot sinks 2.5 cm): the height target, the start pose
        and the stance legs' reach then disagree with the ground."""
        clip, n_leg = self.clip, len(self.legs)
        data = mujoco.MjData(model)
        geoms = [[g for g, leg in self.geom_leg.items() if leg == i] for i in range(n_leg)]
        low = np.full((clip.num_frames, n_leg), np.inf)
        for f in range(clip.num_frames):
            data.qpos[:] = clip.qpos[f]
            mujoco.mj_kinematics(model, data)
            for i, gs in enumerate(geoms):
                if gs:
                    low[f, i] = min(geom_bottom(model, data, g) for g in gs)
        ground = low.min(axis=1) if n_leg else np.zeros(clip.num_frames)
        near = ground < FLIGHT_FRACTION * self.leg_height
        fallback = -float(np.median(ground[near])) if near.any() else 0.0
        self.level_shift = np.where(near, -ground, fallback)
        self.ref_low = low + self.level_shift[:, None]
        qpos = clip.qpos.copy()
        qpos[:, 2] += self.level_shift
        self.clip = replace(clip, qpos=qpos)

    def _ref_velocity(self, clip: ReferenceClip) -> None:
        """The clip's horizontal root velocity (m/s, world), averaged over a window, per frame."""
        n = clip.num_frames
        w = max(1, int(round(self.bal.velocity_window_s / clip.frame_time)))
        v = clip.qvel[:, 0:2]
        kernel = np.ones(w) / w
        self.v_ref = np.stack([np.convolve(np.concatenate([v[-w:, k], v[:, k], v[:w, k]]) if n > w
                                           else np.pad(v[:, k], w, mode="edge"), kernel, mode="same")[w:w + n]
                               for k in range(2)], axis=1)

    def start_frame(self) -> int:
        return self.loop[0]

    def _frame_index(self) -> int:
        a, b = self.loop
        i = int(self.frame)
        return i if i < b else a + (i - a) % (b - a)

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        super().reset(data, self.loop[0] if frame is None else frame, t)
        if not self.cfg.support:  # the caller posed the clip's start; start from the re-levelled one
            data.qpos[2] += self.level_shift[min(int(self.frame), self.clip.num_frames - 1)]
            mujoco.mj_forward(self.model, data)
        self.resyncs = 0
        self._strikes = []
        self.virtual = []
        self._wait = 0.0
        self._was_down = [False] * len(self.legs)

    # ------------------------------------------------------------------ the control step
    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        if self.cfg.support:
            return super().__call__(model, data, t, dt)
        down = self._feet_down(data)
        self._resync(t, dt, down)
        self.frame = (t - self._t0) / self.clip.frame_time
        f = self._frame_index()
        target = self.clip.qpos[f].copy()
        r = data.xmat[self.root_body].reshape(3, 3)
        r_ref = Rotation.from_quat(target[3:7], scalar_first=True).as_matrix()
        yaw = yaw_between(r, r_ref)
        v_d = (_rz(yaw) @ np.array([*self.v_ref[f], 0.0]))
        self._place_swing_feet(data, target, f, v_d, down)
        e = self._quat_error(data, target)
        self.tracking_error = np.linalg.norm(e, axis=1)
        # kd (qdot_ref - qdot): the -kd qdot half is MuJoCo's implicit joint damping, the reference
        # velocity half is fed forward here so fast swings are not damped away
        tau = self.kp[:, None] * e
        if self.bal.velocity_feedforward:
            tau = tau + self.kd[:, None] * self.clip.qvel[f][self._vel_idx]
        tau_all = np.zeros(model.nu)
        tau_all[self.acts.ravel()] = tau.ravel()
        stance = [i for i, d in enumerate(down) if d]
        if stance:
            tau_all += self._virtual_torques(data, target, r, r_ref, yaw, v_d, stance)
        lim = np.repeat(self.limit, 3)
        order = self.acts.ravel()
        self.torque[order] = np.clip(tau_all[order], -lim, lim)
        return self.torque

    def _quat_error(self, data: mujoco.MjData, target: FloatArray) -> FloatArray:
        return quat_error_rotvecs(data.qpos[self._quat_idx], target[self._quat_idx])

    def _feet_down(self, data: mujoco.MjData) -> list[bool]:
        """Per leg: does its lower end (feet and the bones to them) touch the floor now? Also keeps
        each touching leg's mean contact point (m, world) in ``contact_points``."""
        n = len(self.legs)
        pts = [np.zeros(3) for _ in range(n)]
        counts = [0] * n
        floor, gl = self.floor, self.geom_leg
        for c in range(data.ncon):
            g1, g2 = data.contact.geom[c]
            other = g2 if g1 == floor else g1 if g2 == floor else -1
            leg = gl.get(int(other), -1)
            if leg >= 0:
                pts[leg] += data.contact.pos[c]
                counts[leg] += 1
        self.contact_points = [p / k if k else data.site_xpos[self.leg_sites[i][0]].copy()
                               for i, (p, k) in enumerate(zip(pts, counts))]
        return [k > 0 for k in counts]

    def _ref_down(self, f: int, leg: int) -> bool:
        cols = self.leg_clip_cols[leg]
        return bool(cols) and bool(self.clip.contacts[f, cols].any())

    def _resync(self, t: float, dt: float, down: list[bool]) -> None:
        """Hold the clip's clock while a foot the clip has on the ground is still in the air (at most
        ``max_wait_s`` per step); record real foot strikes."""
        f = self._frame_index()
        for i, d in enumerate(down):
            if d and not self._was_down[i]:
                self._strikes.append((t, self.legs[i].root))
                self._wait = 0.0
            self._was_down[i] = d
        late = [i for i in range(len(self.legs)) if self._ref_down(f, i) and not down[i]
                and not self._ref_down(max(f - 1, 0), i)]
        if late and self._wait + dt <= self.bal.max_wait_s:
            if self._wait == 0.0:
                self.resyncs += 1
            self._wait += dt
            self._t0 += dt

    def _place_swing_feet(self, data: mujoco.MjData, target: FloatArray, f: int, v_d: FloatArray,
                          down: list[bool]) -> None:
        """Turn the root-joint target of each leg in swing (in the clip, and off the ground) so its foot
        lands ``placement`` sqrt(L/g) (v - v_d) further along the velocity error (the inverted-pendulum
        step), at most ``max_placement`` L."""
        dv = data.qvel[0:3].copy() - v_d
        dv[2] = 0.0
        if self.bal.placement <= 0 or not np.any(dv):
            return
        shift = self.bal.placement / self.omega0 * dv  # m
        cap = self.bal.max_placement * self.leg_height
        size = float(np.linalg.norm(shift))
        if size > cap:
            shift *= cap / size
        for i in range(len(self.legs)):
            if self._ref_down(f, i) or down[i]:
                continue
            k = self.leg_root_ball[i]
            rp = data.xmat[self.root_ball_parent[i]].reshape(3, 3)
            hip = data.xpos[self.model.body(self.legs[i].root).id]
            foot = data.site_xpos[self.leg_sites[i][0]]
            arm = hip - foot
            length = float(np.linalg.norm(arm)) or 1e-9
            w = np.cross(arm / length, shift) / length  # world rotation vector moving the foot by ``shift``
            w = -w
            local = Rotation.from_rotvec(rp.T @ w)
            q = target[self.qadr[k]:self.qadr[k] + 4]
            target[self.qadr[k]:self.qadr[k] + 4] = (local * Rotation.from_quat(q, scalar_first=True)).as_quat(
                scalar_first=True)

    def _virtual_torques(self, data: mujoco.MjData, target: FloatArray, r: FloatArray, r_ref: FloatArray,
                         yaw: float, v_d: FloatArray, stance: list[int]) -> FloatArray:
        """Joint torques (by actuator) that make the stance feet push the desired wrench."""
        b, m, w0 = self.bal, self.mass, self.omega0
        g = -float(self.model.opt.gravity[2])
        com = data.subtree_com[self.root_body]
        vel = data.qvel[0:3]
        wh, wa = b.height_freq * w0, b.attitude_freq * w0
        force = np.zeros(3)
        force[2] = m * (b.gravity_comp * g + wh * wh * (target[2] - data.qpos[2]) - 2 * b.damping_ratio * wh * vel[2])
        force[0:2] = m * b.speed_gain * w0 * (v_d[0:2] - vel[0:2])
        r_d = _rz(yaw) @ r_ref
        err = Rotation.from_matrix(r_d @ r.T).as_rotvec()
        err[2] = 0.0  # the heading is the clip's to follow, not the stance legs' to force
        omega = r @ data.qvel[3:6]
        inertia = m * self.leg_height ** 2
        torque = inertia * (wa * wa * err - 2 * b.damping_ratio * wa * omega)
        torque[2] = 0.0
        self.virtual.append((float(np.linalg.norm(force)), float(np.linalg.norm(torque))))
        pts = np.array([self.contact_points[i] for i in stance])
        fs = distribute_wrench(force, torque, pts, com)
        out = np.zeros(self.model.nu)
        for k, i in enumerate(stance):
            out[self.leg_acts[i]] += self.leg_torques(data, i, pts[k], self._in_cone(fs[k]))
        return out

    def leg_torques(self, data: mujoco.MjData, leg: int, point: FloatArray, force: FloatArray) -> FloatArray:
        """Joint torques (N*m, the leg's actuators in ``leg_acts`` order) that make leg ``leg``'s foot,
        held at ``point`` (m, world), be pushed by the ground with ``force`` (N, world): -J^T f, J the
        point's Jacobian over the leg's degrees of freedom."""
        mujoco.mj_jac(self.model, data, self.jacp, None, point, self.leg_feet[leg][0])
        return -self.jacp[:, self.leg_dofs[leg]].T @ force

    def _in_cone(self, f: FloatArray) -> FloatArray:
        """``f`` with a pushing vertical part (>= 0) and its horizontal part inside the friction cone."""
        fz = max(float(f[2]), 0.0)
        h = f[0:2]
        n = float(np.linalg.norm(h))
        cap = self.bal.friction * fz
        if n > cap:
            h = h * (cap / n)
        return np.array([h[0], h[1], fz])

    # ------------------------------------------------------------------ read-outs
    def foot_strikes(self) -> list[tuple[float, str]]:
        return list(self._strikes)

    def metrics(self) -> dict[str, object]:
        out = super().metrics()
        out["controller"] = "creature_balance"
        out["legs"] = [leg.root for leg in self.legs]
        out["resyncs"] = self.resyncs
        if self.virtual:
            f, tq = np.array(self.virtual).T
            out.update({"virtual_force_mean_n": float(f.mean()), "virtual_torque_mean_nm": float(tq.mean())})
        return out


__all__ = ["CreatureBalanceConfig", "CreatureBalanceController", "distribute_wrench", "geom_bottom",
           "yaw_between"]
