"""A gait the built body can carry, for any legged skeleton (Coros et al. 2011's planned gait, made
quasi-static): instead of tracking the clip's joint angles -- a pose that is not feasible on the built
body (the horse's stance feet 0.42 m behind its centre of mass, the dog's feet on the midline) -- the
controller plans where each foot stands and where the trunk is, and solves the legs by inverse
kinematics on the built body every few milliseconds:

- **neutral stance, measured from the clip**: each foot's mean position relative to the root over the
  looped part (in the root's heading frame), the root's mean height and attitude (heading removed);
  the feet are widened laterally to at least ``stance_width`` x their hips' lateral offset and the whole
  stance is shifted so the centroid of the feet lies under the built body's centre of mass;
- **gait clock**: the legs swing one after another in the order the clip lifts them
  (``swing_share``/n of the cycle each: with four legs at least three feet are down), the cycle period
  chosen so a stride is at most ``stride_fraction`` x the leg length at ``speed_fraction`` x the clip's
  speed (a clip in place steps in place), and a stance foot's sweep under the body within the legs'
  reach measured by IK on the built body (the speed lowered where the shortest swing needs it);
- **trunk**: the root moves along a straight path at the desired speed, its centre of mass shifted
  toward the centroid of the feet that will carry it during the next swing (the support triangle of a
  walking quadruped), at the neutral height and attitude;
- **feet**: a stance foot stays where it landed; a swing foot moves from lift-off to a landing point
  ahead of its hip by half a stride plus the inverted-pendulum correction ``placement`` sqrt(L/g) (v - v_d);
- **legs by IK** (damped least squares on each leg's ball-joint DOFs, warm-started, pulled toward the
  neutral leg pose in the null space), the joints PD-tracked; gravity, height and attitude by the
  virtual wrench of :class:`~bipedsim.control.creature_balance.CreatureBalanceController` through the
  legs that really touch the floor.

The clip's non-leg joints (spine, neck, tail) are held at the neutral frame's pose.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray, register
from bipedsim.control.creature import CreatureControlConfig
from bipedsim.control.creature_balance import (
    CreatureBalanceConfig,
    CreatureBalanceController,
    _rz,
    distribute_wrench,
    geom_bottom,
)
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.creature import creature_legs
from bipedsim.model.plan import BodyPlanSet

#: a clip whose root travels slower than this (m/s, mean over the loop) walks in place
IN_PLACE_MPS = 0.1
#: the neutral stance lowers the body by at most this share of the clip's root height so every leg
#: reaches the floor
MAX_CROUCH = 0.25
#: a foot the IK brings within this share of the root height of its target is reached
REACH_TOL = 0.04
#: the reach of the legs is measured in steps of this share of the root height
REACH_STEP = 0.025
#: IK iterations per measured target
REACH_IK_ITERS = 30


def _heading(r: FloatArray, fwd: FloatArray) -> float:
    """The heading (rad about world Z) of body axis ``fwd`` (root frame) under root rotation ``r``."""
    d = r @ fwd
    return math.atan2(d[1], d[0])


def zmp_limited(force_h: FloatArray, com: FloatArray, feet: FloatArray, weight: float) -> FloatArray:
    """The horizontal force ``force_h`` (N, world) on a body of ``weight`` (N) with its centre of mass
    at ``com`` (m, world), scaled down (never turned) so the zero-moment point it implies,
    com_xy - h force_h / weight (h: the centre of mass's height over the feet), stays inside the convex
    hull of ``feet`` (k, 3; m, world). Fewer than three feet, or feet in a line, leave it as it is."""
    if len(feet) < 3:
        return force_h
    try:
        hull = ConvexHull(feet[:, 0:2])
    except QhullError:
        return force_h
    h = float(com[2] - feet[:, 2].mean())
    u = -h * np.asarray(force_h) / weight
    alpha = 1.0
    for nx, ny, off in hull.equations:  # n . x + off <= 0 inside
        inside = -(nx * com[0] + ny * com[1] + off)
        out = nx * u[0] + ny * u[1]
        if out > 1e-12:
            alpha = min(alpha, max(inside, 0.0) / out)
    return alpha * np.asarray(force_h)


def smoothstep(s: float) -> float:
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


class CreatureGaitController(CreatureBalanceController):
    """The planned, quasi-static gait for any legged creature (see the module text)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                 cfg: CreatureControlConfig | None = None, balance: CreatureBalanceConfig | None = None) -> None:
        super().__init__(model, plan, clip, cfg, balance)
        self.ik_data = mujoco.MjData(model)
        self._site_ids = self._foot_sites()
        ball_ids = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL]
        leg_dofs = set(np.concatenate(self.leg_dofs).tolist()) if self.legs else set()
        #: (qpos address, range less a 5 % margin) of each limited leg ball joint
        self._ik_limits = [(int(model.jnt_qposadr[j]), 0.95 * float(model.jnt_range[j, 1])) for j in ball_ids
                           if model.jnt_limited[j] and int(model.jnt_dofadr[j]) in leg_dofs]
        # IK turns the joints above the feet: a paw's or toe's own joint is held at its neutral pose (a
        # foot bent to reach is a foot folded under the load, and past its joint range)
        self.ik_dofs = []
        for i in range(len(self.legs)):
            held = self._held_feet(i)
            foot_dofs = {int(model.body_dofadr[model.body(f).id]) + k for f in held for k in range(3)
                         if model.body_dofnum[model.body(f).id]}
            self.ik_dofs.append(np.array([v for v in self.leg_dofs[i] if v not in foot_dofs], dtype=np.int64))
        self._measure_gait()
        self._neutral_stance()
        if len(self.legs) >= 2:
            # the body's own long axis: the hips' principal horizontal direction (a clip that turns or
            # walks a little crabwise travels at an angle to it); two hips side by side: across it
            h = self._hips[:, 0:2] - self._hips[:, 0:2].mean(axis=0)
            axis = np.linalg.svd(h, full_matrices=False)[2][0]
            if len(self.legs) == 2:
                axis = np.array([-axis[1], axis[0]])
            theta = math.atan2(axis[1], axis[0]) if axis[0] >= 0 else math.atan2(-axis[1], -axis[0])
            if abs(theta) > 1e-3:
                att = self.neutral_att
                fwd = att.T @ _rz(theta) @ att @ self.fwd
                self.fwd = fwd / np.linalg.norm(fwd)
                self._neutral_stance()
        self._wave_order()
        self._measure_reach()
        #: each leg's side (+1 left, -1 right of the stance's mid-line, heading frame)
        across = self.neutral_feet[:, 1] - self.neutral_feet[:, 1].mean() if len(self.legs) else np.zeros(0)
        self.leg_side = np.sign(across)
        self.half_width = float(np.abs(across).max()) if len(self.legs) else 0.0
        self.reach_out = np.zeros(len(self.legs))
        if self.bal.capture_step > 0 and len(self.legs) > 2 and not self.cfg.support:
            self._measure_reach_out()

    # ------------------------------------------------------------------ hooks (control/creature_biped.py)
    def _foot_sites(self) -> list[int]:
        """The site each leg's foot is placed by: its first foot's touch site."""
        return [s[0] for s in self.leg_sites]

    def _held_feet(self, i: int) -> tuple[str, ...]:
        """The bodies of leg ``i`` whose own joints the IK leaves at the neutral pose: its feet."""
        return self.legs[i].feet

    def _site_heights(self, rel: FloatArray) -> FloatArray:
        """Each foot site's height (m) when its foot stands: the median over the loop of the site above
        its leg's lowest point (``rel``: (frames, legs, 3) sites relative to the root, heading frame)."""
        clip, (a, b) = self.clip, self.loop
        return np.array([float(np.median(clip.qpos[a:b, 2] + rel[:, i, 2] - self.ref_low[a:b, i]))
                         if np.all(np.isfinite(self.ref_low[a:b, i])) else 0.0 for i in range(len(self.legs))])

    def _foot_attitude(self, i: int) -> FloatArray | None:
        """The world orientation leg ``i``'s foot site is aimed at by the IK; None: its position only."""
        return None

    # ------------------------------------------------------------------ measured on the built body
    def _reach_error(self, shift: float, lift: float, out: float = 0.0) -> FloatArray:
        """Each leg's IK miss (m) with every foot ``shift`` (m) ahead of its neutral place (behind when
        negative), ``out`` (m) further out to its side and ``lift`` (m) above the floor, the body in its
        neutral pose."""
        n = len(self.legs)
        q = self.neutral_q.copy()
        root = q[0:3]
        across = self.leg_side * out if out else 0.0
        feet = np.column_stack([root[0] + self.neutral_feet[:, 0] + shift, root[1] + self.neutral_feet[:, 1] + across,
                                self.site_ground + lift])
        self._solve_ik(q, feet, iters=REACH_IK_ITERS)
        mujoco.mj_kinematics(self.model, self.ik_data)
        got = np.array([self.ik_data.site_xpos[s] for s in self._site_ids]).reshape(n, 3)
        return np.linalg.norm(got - feet, axis=1)

    def _measure_reach(self) -> None:
        """The stride the legs reach by IK inside their joint ranges, measured on the built body from
        the neutral stance; the gait plan is held to it (a clip's joint ranges can leave a leg too
        little room for the planned step: the horse's hind hooves missed by 22 cm).

        - ``self.reach_ahead`` / ``self.reach_behind`` (n,): how far (m) each foot reaches ahead of and
          behind its neutral place on the floor (within REACH_TOL x the root height at every step of
          REACH_STEP up to there), each leg measured to its own first miss;
        - ``self.centred``: whether the sweeps are centred: with ``centre_sweep``, or where centring
          widens the sweep at least ``centre_sweep_gain`` times (legs whose reach ahead and behind are
          lopsided: a hind leg that reaches far back but little ahead);
        - ``self.reach``: half the stance's sweep: the shortest of them all (the symmetric sweep), or
          centred half the narrowest leg's interval, each foot's neutral place then moved the least that
          puts the sweep inside its own interval;
        - the stance's sweep, speed x stance time, is at most 2 x reach: the cycle is shortened, and
          where the shortest swing does not allow that, the speed lowered (and held to the longest
          stride, ``stride_fraction`` x the root height per cycle)."""
        n, b_ = len(self.legs), self.bal
        L = self.leg_height
        self.reach = math.inf
        self.reach_ahead = self.reach_behind = np.zeros(n)
        self.centred = False
        if n == 0 or self.cfg.support:
            return
        tol = REACH_TOL * L
        saved = self._ik_q.copy()
        reach = np.zeros((2, n))  # ahead, behind
        going = np.ones((2, n), dtype=bool)
        for k in range(1, int(b_.stride_fraction / REACH_STEP) + 1):
            s = k * REACH_STEP * L
            for side, sign in enumerate((1.0, -1.0)):
                if going[side].any():
                    going[side] &= self._reach_error(sign * s, 0.0) <= tol
                    reach[side, going[side]] = s
            if not going.any():
                break
        self._ik_q[:] = saved
        self.reach_ahead, self.reach_behind = reach
        symmetric, centred = float(reach.min()), float((reach[0] + reach[1]).min()) / 2.0
        self.centred = b_.centre_sweep or (b_.centre_sweep_gain > 0 and centred >= b_.centre_sweep_gain * symmetric)
        if self.centred:
            self.reach = centred
            self.neutral_feet[:, 0] += np.clip(0.0, self.reach - reach[1], reach[0] - self.reach)
        else:
            self.reach = symmetric
        if self.v_des > 0:
            stance = 1.0 - self.swing_frac
            self.period = min(self.period, max(2.0 * self.reach, 1e-6) / (stance * self.v_des))
            shortest = self._min_swing() / self.swing_frac
            if self.period < shortest:
                # the shortest cycle: the speed held to the reach and to the longest stride
                self.period = shortest
                self.v_des = min(self.v_des, 2.0 * self.reach / (stance * shortest),
                                 b_.stride_fraction * self.leg_height / shortest)

    def _measure_reach_out(self) -> None:
        """``self.reach_out`` (n,): how far (m) each foot reaches out to its side of its neutral place
        (within REACH_TOL x the root height at every step of REACH_STEP up to there), by IK inside the
        joint ranges: the furthest a capture step (``capture_step``) puts it."""
        L = self.leg_height
        saved = self._ik_q.copy()
        going = np.ones(len(self.legs), dtype=bool)
        for k in range(1, int(self.bal.max_placement / REACH_STEP) + 1):
            going &= self._reach_error(0.0, 0.0, out=k * REACH_STEP * L) <= REACH_TOL * L
            if not going.any():
                break
            self.reach_out[going] = k * REACH_STEP * L
        self._ik_q[:] = saved

    def _wave_order(self) -> None:
        """Where the clip lifts none of the legs (its contact labels empty: a bred child's blended feet
        never stand still), the sequence gait's footfall order is the wave the walking quadrupeds'
        clips show (the dog's and the horse's alike): one side's legs from the hindmost forward, then
        the other side's (``footfall_fallback: wave``; ``legs``: the legs' own order)."""
        n = len(self.legs)
        if (self.bal.footfall_fallback != "wave" or n <= 2 or self._clip_lifts.any()
                or self.bal.phases == "clip"):
            return
        side = self._hips[:, 1] - self._hips[:, 1].mean()
        self.leg_order = sorted(range(n), key=lambda i: (bool(side[i] > 0), float(self._hips[i, 0])))
        for rank, i in enumerate(self.leg_order):
            self.offsets[i] = rank / n

    # ------------------------------------------------------------------ measured from the clip
    def _measure_gait(self) -> None:
        """Forward axis (root frame), desired speed, leg order, swing time and cycle period."""
        clip, (a, b) = self.clip, self.loop
        rots = Rotation.from_quat(clip.qpos[a:b, 3:7], scalar_first=True).as_matrix()
        v = clip.qvel[a:b, 0:3].copy()
        v[:, 2] = 0.0
        path = np.linalg.norm(np.diff(clip.qpos[a:b, :2], axis=0), axis=1).sum()
        self.clip_speed = float(path / max((b - a - 1) * clip.frame_time, 1e-9))
        local = np.einsum("fji,fj->fi", rots, v)  # R^T v per frame
        fwd = local.mean(axis=0)
        fwd[2] = 0.0 if abs(fwd[2]) < np.linalg.norm(fwd[:2]) else fwd[2]
        if np.linalg.norm(fwd) < 1e-6 or self.clip_speed < IN_PLACE_MPS:
            # walking in place: the axis from the hind legs' roots to the front ones' is as good as any;
            # take the root frame's axis that is most horizontal on average
            horiz = np.abs(rots[:, 2, :]).mean(axis=0)
            fwd = np.eye(3)[int(np.argmin(horiz))]
        self.fwd = fwd / np.linalg.norm(fwd)
        b_ = self.bal
        self.v_des = 0.0 if self.clip_speed < IN_PLACE_MPS else b_.speed_fraction * self.clip_speed
        n = len(self.legs)
        # lift-off phase of each leg in the clip (first swing frame after a stance frame)
        starts = []
        swing_times, strides = [], []
        self._clip_lifts = np.zeros(n, dtype=bool)
        for i in range(n):
            down = np.array([self._ref_down(f, i) for f in range(a, b)])
            lifts = np.flatnonzero(down[:-1] & ~down[1:])
            lands = np.flatnonzero(~down[:-1] & down[1:])
            self._clip_lifts[i] = len(lifts) > 0
            starts.append(float(lifts[0]) if len(lifts) else float(i * (b - a) / max(n, 1)))
            strides.extend(np.diff(lifts) * clip.frame_time)
            for lf in lifts:
                after = lands[lands > lf]
                if len(after):
                    swing_times.append((after[0] - lf) * clip.frame_time)
        self.leg_order = [int(i) for i in np.argsort(starts, kind="stable")]
        swing = float(np.median(swing_times)) if swing_times else 0.5 * math.sqrt(self.leg_height / 9.81)
        stride = float(np.median(strides)) if strides else 4.0 * swing
        self.offsets = np.zeros(n)
        if b_.phases == "clip" and strides:
            # the clip's own footfall pattern (a trot's diagonal pairs), its swing share capped
            self.swing_frac = float(np.clip(swing / stride, 0.2, b_.max_swing_fraction))
            period = stride
            for i in range(n):
                self.offsets[i] = ((starts[i] - starts[self.leg_order[0]]) * clip.frame_time / stride) % 1.0
        else:
            self.swing_frac = min(b_.swing_share / max(n, 1), b_.max_swing_fraction)
            period = swing / self.swing_frac
            for rank, i in enumerate(self.leg_order):
                self.offsets[i] = rank / max(n, 1)
        if self.v_des > 0:  # a stride of at most stride_fraction x the leg length
            period = min(period, b_.stride_fraction * self.leg_height / self.v_des)
        self.period = max(period, self._min_swing() / self.swing_frac)

    def _min_swing(self) -> float:
        """The shortest swing (s): ``min_swing_froude`` sqrt(L/g) (L: the standing root height), at least
        ``min_swing_s`` (``min_swing_froude`` 0: ``min_swing_s`` alone)."""
        g = -float(self.model.opt.gravity[2]) or 9.81
        return max(self.bal.min_swing_s, self.bal.min_swing_froude * math.sqrt(self.leg_height / g))

    def _neutral_stance(self) -> None:
        """The neutral pose: root height and attitude, non-leg joints, and each foot's position relative
        to the root in the heading frame, widened and centred under the body's centre of mass."""
        clip, (a, b), model = self.clip, self.loop, self.model
        d = self.ik_data
        n = len(self.legs)
        rel = np.zeros((b - a, n, 3))
        hips = np.zeros((b - a, n, 3))
        atts = []
        for k, f in enumerate(range(a, b)):
            d.qpos[:] = clip.qpos[f]
            mujoco.mj_kinematics(model, d)
            r = d.xmat[self.root_body].reshape(3, 3)
            h = _rz(_heading(r, self.fwd)).T
            root = d.xpos[self.root_body]
            for i in range(n):
                rel[k, i] = h @ (d.site_xpos[self._site_ids[i]] - root)
                hips[k, i] = h @ (d.xpos[model.body(self.legs[i].root).id] - root)
            atts.append(Rotation.from_matrix(h @ r))
        # the neutral pose: the looped frame with its feet lowest, its non-leg joints (spine, neck,
        # tail) at their mean over the loop (a turning clip's bent spine straightened), the root at the
        # mean attitude (heading removed) and the median height
        lowest = np.nansum(np.where(np.isfinite(self.ref_low[a:b]), self.ref_low[a:b], 0.0), axis=1)
        f0 = a + int(np.argmin(lowest))
        self.neutral_q = clip.qpos[f0].copy()
        leg_dofs = set(np.concatenate(self.leg_dofs).tolist()) if n else set()
        for k, qa in enumerate(self.qadr):
            if int(self.dadr[k]) not in leg_dofs:
                mean = Rotation.from_quat(clip.qpos[a:b, qa:qa + 4], scalar_first=True).mean()
                self.neutral_q[qa:qa + 4] = mean.as_quat(scalar_first=True)
        att = Rotation.concatenate(atts).mean().as_matrix()  # root attitude in the heading frame
        self.neutral_att = _rz(-_heading(att, self.fwd)) @ att  # the mean's residual heading removed
        self._clip_height = float(np.median(clip.qpos[a:b, 2]))
        self.neutral_height = self._clip_height * self.bal.height_fraction
        self.neutral_q[0:2] = 0.0
        self.neutral_q[2] = self.neutral_height
        self.neutral_q[3:7] = Rotation.from_matrix(self.neutral_att).as_quat(scalar_first=True)
        d.qpos[:] = self.neutral_q
        mujoco.mj_kinematics(model, d)
        mujoco.mj_comPos(model, d)
        root = d.xpos[self.root_body].copy()
        com = d.subtree_com[self.root_body] - root  # heading frame = world here
        hip = np.array([d.xpos[model.body(leg.root).id] - root for leg in self.legs]).reshape(n, 3)
        self._hips = hip
        foot = rel.mean(axis=0)
        self.site_ground = self._site_heights(rel)
        # pairs of legs (left and right: each hip the nearest to the other's mirror image across the
        # hips' mid-line) stand symmetric about their hips' centre, at least stance_width x their hips'
        # half spacing apart, level with each other
        mid = float(hip[:, 1].mean()) if n else 0.0
        mirror = hip.copy()
        mirror[:, 1] = 2 * mid - mirror[:, 1]
        for i in range(n):
            dist = np.linalg.norm(hip - mirror[i], axis=1)
            dist[i] = np.inf
            j = int(np.argmin(dist)) if n > 1 else i
            back = np.linalg.norm(hip - mirror[j], axis=1)
            back[j] = np.inf
            if j == i or int(np.argmin(back)) != i or j < i:
                continue
            cy = 0.5 * (hip[i, 1] + hip[j, 1])
            half = max(abs(foot[i, 1] - foot[j, 1]) / 2, self.bal.stance_width * abs(hip[i, 1] - hip[j, 1]) / 2)
            side = 1.0 if hip[i, 1] >= cy else -1.0
            foot[i, 1], foot[j, 1] = cy + side * half, cy - side * half
            foot[i, 0] = foot[j, 0] = 0.5 * (foot[i, 0] + foot[j, 0])
        # centre: the feet's centroid under the neutral pose's centre of mass
        if n:
            foot[:, 0:2] += com[0:2] - foot[:, 0:2].mean(axis=0)
        # reachable: the legs posed by IK on this stance (inside their joint ranges), the stance then
        # taken from where the feet got, re-centred under the posed body's centre of mass
        self._ik_q = self.neutral_q.copy()
        for _ in range(3):
            q = self.neutral_q.copy()
            self._solve_ik(q, np.column_stack([foot[:, 0:2], self.site_ground]), iters=20)
            mujoco.mj_kinematics(model, d)
            mujoco.mj_comPos(model, d)
            com = d.subtree_com[self.root_body] - d.xpos[self.root_body]
            got = np.array([d.site_xpos[s] for s in self._site_ids]).reshape(n, 3)
            foot[:, 0:2] = got[:, 0:2]
            short = float(np.max(got[:, 2] - self.site_ground)) if n else 0.0
            # a leg too short to reach the floor from here: the body stands lower, by at most
            # MAX_CROUCH of its height (a 'leg' that is no leg -- a low head -- does not sink it)
            short = min(short, self.neutral_height - (1.0 - MAX_CROUCH) * self._clip_height)
            if short > 0.0:
                self.neutral_height -= short
                q[2] = self.neutral_height
            if n:
                foot[:, 0:2] += com[0:2] - foot[:, 0:2].mean(axis=0)
            self.neutral_q = q
        self.neutral_feet = foot  # (n, 3) relative to the root, heading frame (z: the clip's mean, for shift_share)
        self.neutral_com = com

    # ------------------------------------------------------------------ planning
    def _phase(self, t: float, i: int) -> float:
        """Leg ``i``'s swing progress in [0, 1), or -1 while in stance."""
        if t < self._t_walk:
            return -1.0
        p = ((t - self._t_walk) / self.period - self.offsets[i]) % 1.0
        return p / self.swing_frac if p < self.swing_frac else -1.0

    def _root_path(self, t: float) -> FloatArray:
        """The root's planned horizontal position (m, world) at time ``t``."""
        tw = max(t - self._t_walk, 0.0)
        ramp = self.bal.speed_ramp_s
        dist = self.v_des * (tw * tw / (2 * ramp) if tw < ramp else tw - ramp / 2)
        return self._origin + dist * self._dir

    def _heading_rot(self) -> FloatArray:
        return _rz(self._yaw)

    def _foot_home(self, t: float, i: int) -> FloatArray:
        """Leg ``i``'s neutral foot position (world) for a root on its planned path at time ``t``."""
        p = self._root_path(t)
        h = self._heading_rot() @ self.neutral_feet[i]
        return np.array([p[0] + h[0], p[1] + h[1], self.site_ground[i]])

    def _landing(self, t: float, i: int, data: mujoco.MjData) -> FloatArray:
        """Where leg ``i``'s swing ends: its neutral point half a stance ahead at landing time, plus the
        inverted-pendulum correction on the velocity error."""
        s = self._phase(t, i)
        t_land = t + (1.0 - s) * self.swing_frac * self.period
        stance_t = (1.0 - self.swing_frac) * self.period
        ahead = self._speed_at(t_land) * stance_t / 2.0 * self._dir
        p = self._foot_home(t_land, i)
        p[0:2] += ahead
        dv = self._v_filt - self._speed_at(t) * self._dir
        shift = self.bal.step_placement / self.omega0 * dv
        cap = self.bal.max_placement * self.leg_height
        size = float(np.linalg.norm(shift))
        if size > cap:
            shift *= cap / size
        p[0:2] += shift
        if self.bal.capture_step > 0 and self.reach_out[i] > 0:
            # a swinging foot on the side the capture point went out to lands further out
            side = np.array([-self._dir[1], self._dir[0]])
            beyond = self.leg_side[i] * float((self._xi - p[0:2]) @ side)
            if beyond > 0:
                p[0:2] += self.leg_side[i] * min(self.bal.capture_step * beyond, float(self.reach_out[i])) * side
        return p

    def _catch(self, model: mujoco.MjModel, data: mujoco.MjData, t: float) -> None:
        """The centre of mass's capture point ``self._xi`` (m, world xy), c + v / w (w = sqrt(g / h), h its
        height over the feet), and the catch: while it lies out to one side beyond that side's outermost
        stance foot (by ``capture_margin`` x the stance's half-width) and no leg of that side swings, the
        gait's clock moves on to that side's leg that lifts soonest (the legs between keep their feet
        where they are; the planned path is held where it was)."""
        mujoco.mj_subtreeVel(model, data)
        com, v = data.subtree_com[self.root_body], data.subtree_linvel[self.root_body]
        g = -float(model.opt.gravity[2])
        w = math.sqrt(g / max(float(com[2] - self.site_ground.mean()), 1e-3))
        self._xi = com[0:2] + v[0:2] / w
        if t < self._t_walk:
            return
        n = len(self.legs)
        side = np.array([-self._dir[1], self._dir[0]])
        xi = float(self._xi @ side)
        for s in (1.0, -1.0):
            legs = [i for i in range(n) if self.leg_side[i] == s]
            if not legs or any(self._phase(t, i) >= 0 for i in legs):
                continue
            edge = max(s * float(self._planted[i][0:2] @ side) for i in legs)
            if s * xi <= edge + self.bal.capture_margin * self.half_width:
                continue
            wait = {i: (self.offsets[i] - (t - self._t_walk) / self.period) % 1.0 * self.period for i in legs}
            i = min(wait, key=wait.get)
            before = self._root_path(t)
            self._t_walk -= wait[i] + 1e-9
            self._origin -= self._root_path(t) - before
            self.catches += 1
            return

    def _speed_at(self, t: float) -> float:
        tw = max(t - self._t_walk, 0.0)
        return self.v_des * min(1.0, tw / self.bal.speed_ramp_s)

    def _plan(self, t: float, data: mujoco.MjData) -> FloatArray:
        """The target pose (qpos) at time ``t``: root from the path and the support shift, feet from the
        gait, legs by IK."""
        # the body's velocity, low-passed over a quarter swing, for the foot placement: a landing point
        # that jumps with every bounce makes the swing leg's IK target jump
        a_v = min(1.0, self._dt_plan / max(0.25 * self.swing_frac * self.period, 1e-6))
        self._v_filt += a_v * (self._body_velocity(data) - self._v_filt)
        if self.bal.path_follow_s > 0 and t > self._t_start:
            # the planned path drifts after the body (time constant path_follow_s): a body that lags or
            # strays is walked on from where it is, not pulled back by its stance legs like a spring
            lag = data.qpos[0:2] - (self._root_path(t) + self._shift)
            self._origin += min(1.0, self._dt_plan / self.bal.path_follow_s) * lag
        feet, swinging = self._plan_feet(t, data)
        q = self.neutral_q.copy()
        q[0:2] = self._plan_root(t, data, feet, swinging)
        q[2] = self.neutral_height + self._z_offset
        q[3:7] = Rotation.from_matrix(self._heading_rot() @ self.neutral_att).as_quat(scalar_first=True)
        q[self._leg_q] = self._ik_q[self._leg_q]
        q_ik = q.copy()
        q_ik[3:7] = self._ik_attitude(data, q[3:7]) if t > self._t_start else q[3:7]
        self._solve_ik(q_ik, feet)
        q[self._leg_q] = q_ik[self._leg_q]
        self._feet_target = feet
        return q

    def _ik_attitude(self, data: mujoco.MjData, planned: FloatArray) -> FloatArray:
        """The root attitude (quaternion) the legs are solved for: the ``planned`` one turned toward the
        real root's until its tilt (roll and pitch; heading kept) is within ``ik_tilt_limit`` rad of it.
        Posed for an upright plan, a body rolled onto one side has its low side's feet driven into the
        floor (the body thrown up) and its high side's held off it. Off on two legs (capture steps)."""
        lim = self.bal.ik_tilt_limit
        if lim <= 0 or len(self.legs) <= 2:
            return planned
        plan = Rotation.from_quat(planned, scalar_first=True)
        err = (Rotation.from_quat(data.qpos[3:7], scalar_first=True) * plan.inv()).as_rotvec()
        err[2] = 0.0
        size = float(np.linalg.norm(err))
        if size <= lim:
            return planned
        return (Rotation.from_rotvec(err * (1.0 - lim / size)) * plan).as_quat(scalar_first=True)

    def _body_velocity(self, data: mujoco.MjData) -> FloatArray:
        """The body's horizontal velocity (m/s, world) the foot placement reads: the root's."""
        return data.qvel[0:2]

    def _plan_feet(self, t: float, data: mujoco.MjData) -> tuple[FloatArray, list[int]]:
        """Each foot's target (m, world) at time ``t`` and the legs in swing: a stance foot where it
        landed, a swinging one on its way from lift-off to :meth:`_landing`, lifted on a sine."""
        n = len(self.legs)
        feet = np.zeros((n, 3))
        swinging = []
        for i in range(n):
            s = self._phase(t, i)
            if s < 0:
                if self._lift[i] is not None:  # just landed: plant where the foot is
                    self._strikes.append((t, self.legs[i].root))
                    p = data.site_xpos[self._site_ids[i]].copy()
                    self._planted[i] = np.array([p[0], p[1], self.site_ground[i]])
                    self._lift[i] = None
                feet[i] = self._planted[i]
                feet[i, 2] -= self.bal.stance_press * self.leg_height
            else:
                if self._lift[i] is None:
                    self._lift[i] = self._planted[i].copy()
                p0, p1 = self._lift[i], self._landing(t, i, data)
                e = smoothstep(s)
                feet[i] = p0 + e * (p1 - p0)
                feet[i, 2] = self.site_ground[i] + self.bal.step_height * self.leg_height * math.sin(math.pi * s)
                swinging.append(i)
        return feet, swinging

    def _plan_root(self, t: float, data: mujoco.MjData, feet: FloatArray, swinging: list[int]) -> FloatArray:
        """The root's target (m, world xy): on the path, its centre of mass shifted toward the feet that
        carry the next swing (sideways only, by ``lateral_only``; not on two legs: a line of two feet is
        no support polygon)."""
        n = len(self.legs)
        # the centre of mass over the feet that carry the next swing
        nxt = self._next_swing(t)
        support = [i for i in range(n) if i != nxt] or list(range(n))
        centroid = np.mean([self._planted[i][0:2] if i not in swinging else feet[i, 0:2] for i in support], axis=0)
        path = self._root_path(t)
        com_path = path + (self._heading_rot() @ self.neutral_com)[0:2]
        want = self._shift_share * (centroid - com_path) if n > 2 else np.zeros(2)
        side = np.array([-self._dir[1], self._dir[0]])
        want = (1.0 - self.bal.lateral_only) * want + self.bal.lateral_only * float(want @ side) * side
        a = min(1.0, self._dt_plan / max(self.bal.shift_time_s, 1e-6))
        self._shift += a * (want - self._shift)
        return path + self._shift

    def shift_share(self) -> float:
        """The share of the way the centre of mass moves toward the next support's centroid: ``com_shift``,
        with ``com_shift_dynamic`` scaled by the inverted pendulum's response at the gait's frequency.
        The supports' centroid sways once per cycle; a centre of mass at height h over the feet swaying by
        a at w = 2 pi / period needs its centre of pressure to sway by a (1 + w^2 h / g) (x'' = g / h (x -
        p)), so with the pressure held to the support's own sway the centre of mass follows 1 / (1 + w^2
        h / g) of it. The horse's 0.6 s cycle at 0.71 m: 0.11 (shifted all the way, its centre of mass
        left the triangle of its three stance feet while a right leg swung); a slow walk follows nearly
        all of it."""
        b = self.bal
        if not b.com_shift_dynamic or not math.isfinite(self.period) or self.period <= 0:
            return b.com_shift
        g = -float(self.model.opt.gravity[2])
        h = self.leg_height  # the centre of mass's height over the feet
        if len(self.legs):
            h = max(float(self.neutral_com[2] - self.neutral_feet[:, 2].mean()), 1e-3)
        w = 2.0 * math.pi / self.period
        return b.com_shift / (1.0 + w * w * h / g)

    def _next_swing(self, t: float) -> int:
        """The leg swinging now, or the next to lift off."""
        if t < self._t_walk:
            return -1
        best, who = 2.0, -1
        for i in range(len(self.legs)):
            p = ((t - self._t_walk) / self.period - self.offsets[i]) % 1.0
            if p < self.swing_frac:
                return i
            wait = 1.0 - p
            if wait < best:
                best, who = wait, i
        return who

    def _solve_ik(self, q: FloatArray, feet: FloatArray, iters: int = 4, damping: float = 0.02) -> None:
        """Each leg's joints (in ``q``, in place) so its foot site reaches ``feet[i]`` (m, world): damped
        least squares over the leg's DOFs, pulled toward the neutral leg pose in the null space."""
        m, d = self.model, self.ik_data
        lam2 = (damping * self.leg_height) ** 2
        jac, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for _ in range(iters):
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            dq = np.zeros(m.nv)
            diff = np.zeros(m.nv)
            mujoco.mj_differentiatePos(m, diff, 1.0, q, self.neutral_q)
            for i, dofs in enumerate(self.ik_dofs):
                err = feet[i] - d.site_xpos[self._site_ids[i]]
                mujoco.mj_jacSite(m, d, jac, jacr, self._site_ids[i])
                j = jac[:, dofs]
                att = self._foot_attitude(i)
                if att is not None:  # the foot's attitude too, its radians weighed as leg_height m
                    cur = d.site_xmat[self._site_ids[i]].reshape(3, 3)
                    rot = Rotation.from_matrix(att @ cur.T).as_rotvec()
                    err = np.concatenate([err, self.leg_height * rot])
                    j = np.vstack([j, self.leg_height * jacr[:, dofs]])
                inv = np.linalg.solve(j @ j.T + lam2 * np.eye(len(err)), np.eye(len(err)))
                step = j.T @ inv @ err
                null = diff[dofs] - j.T @ inv @ (j @ diff[dofs])
                dq[dofs] = step + self.bal.posture_pull * null
            mujoco.mj_integratePos(m, q, dq, 1.0)
            self._clamp_balls(q)
        self._ik_q[:] = q

    def _clamp_balls(self, q: FloatArray) -> None:
        """Each leg ball joint's rotation (in ``q``, in place) kept inside its range (the cone MuJoCo
        enforces): a target past it is one the leg cannot take."""
        for qa, lim in self._ik_limits:
            w = q[qa]
            v = q[qa + 1:qa + 4]
            angle = 2.0 * math.atan2(float(np.linalg.norm(v)), abs(float(w)))
            if angle > lim:
                axis = v / max(float(np.linalg.norm(v)), 1e-12) * (1.0 if w >= 0 else -1.0)
                q[qa] = math.cos(lim / 2)
                q[qa + 1:qa + 4] = axis * math.sin(lim / 2)

    # ------------------------------------------------------------------ the control step
    def start_frame(self) -> int:
        return self.loop[0]

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        super().reset(data, frame, t)
        if self.cfg.support:
            return
        n = len(self.legs)
        r = data.xmat[self.root_body].reshape(3, 3)
        self._yaw = _heading(r, self.fwd)
        self._dir = np.array([math.cos(self._yaw), math.sin(self._yaw)])
        self._origin = data.qpos[0:2].copy()
        self._t_walk = t + self.bal.settle_s
        self._t_start = t
        self._shift = np.zeros(2)
        self._shift_share = self.shift_share()  # constant over a walk: the period and stance are fixed
        self._v_filt = np.zeros(2)
        self._xi = np.zeros(2)
        self.catches = 0  # steps started by the catch (capture_step)
        self._dt_plan = self.bal.plan_dt_s
        self._lift: list[FloatArray | None] = [None] * n
        self._planted = [self._foot_home(t, i) for i in range(n)]
        leg_dofs = set(np.concatenate(self.leg_dofs).tolist()) if n else set()
        self._leg_q = np.array([a for k, qa in enumerate(self.qadr) if int(self.dadr[k]) in leg_dofs
                                for a in range(qa, qa + 4)], dtype=np.int64)
        self._ik_q = self.neutral_q.copy()
        self._z_offset = 0.0
        q = self._plan(t, data)
        for _ in range(5):
            q = self._plan(t, data)
        # start standing in the planned pose, at rest, its lowest foot on the floor
        data.qpos[:] = q
        data.qvel[:] = 0.0
        mujoco.mj_kinematics(self.model, data)
        # the whole body above the floor (a shin posed below it is a contact impulse at t = 0)
        low = min(geom_bottom(self.model, data, g) for g in range(self.model.ngeom)
                  if self.model.geom_bodyid[g] > 0)
        data.qpos[2] -= low
        self._z_offset = -low
        self._target = q
        self._target[2] -= low
        self._next_plan = t
        self._qdot_ref = np.zeros(self.model.nv)
        self._swing_state = [False] * n
        self._kp_now, self._kd_now = self.kp.copy(), self.kd.copy()
        leg_dof_sets = [set(d.tolist()) for d in self.leg_dofs]
        self._leg_balls = [[k for k in range(len(self.qadr)) if int(self.dadr[k]) in ds] for ds in leg_dof_sets]
        mujoco.mj_forward(self.model, data)

    def _body_wrench(self, data: mujoco.MjData, target: FloatArray, t: float, stance: list[int]) -> FloatArray:
        """Joint torques (by actuator) through the stance legs for the body's virtual wrench: gravity
        compensation, a PD of the root toward its planned position and velocity (horizontal and vertical,
        natural frequency ``body_freq`` sqrt(g/L), damping ratio ``damping_ratio``: the body on stiff legs
        is a mass on springs that the legs' own joint damping, sized for the legs, leaves underdamped) and
        a PD of its attitude toward the planned one."""
        b, m, w0 = self.bal, self.mass, self.omega0
        g = -float(self.model.opt.gravity[2])
        w = b.body_freq * w0
        v_d = np.array([*(self._speed_at(t) * self._dir), 0.0])
        force = m * (w * w * (target[0:3] - data.qpos[0:3]) + 2 * b.damping_ratio * w * (v_d - data.qvel[0:3]))
        force[2] += m * b.gravity_comp * g
        if b.zmp_limit or (self.centred and b.centre_sweep_zmp):
            support = np.array([self._planted[i] for i in range(len(self.legs)) if self._phase(t, i) < 0])
            force[0:2] = zmp_limited(force[0:2], data.subtree_com[self.root_body], support, m * g)
        r = data.xmat[self.root_body].reshape(3, 3)
        r_d = Rotation.from_quat(target[3:7], scalar_first=True).as_matrix()
        err = Rotation.from_matrix(r_d @ r.T).as_rotvec()
        wa = b.attitude_freq * w0
        torque = m * self.leg_height ** 2 * (wa * wa * err - 2 * b.damping_ratio * wa * (r @ data.qvel[3:6]))
        self.virtual.append((float(np.linalg.norm(force)), float(np.linalg.norm(torque))))
        pts = np.array([self.contact_points[i] for i in stance])
        fs = distribute_wrench(force, torque, pts, data.subtree_com[self.root_body])
        out = np.zeros(self.model.nu)
        for k, i in enumerate(stance):
            out[self.leg_acts[i]] += self.leg_torques(data, i, pts[k], self._in_cone(fs[k]))
        return out

    def _lowest(self, data: mujoco.MjData, i: int) -> float:
        """The lowest point (m, world z) of leg ``i``'s lower end as posed in ``data``."""
        gs = [g for g, leg in self.geom_leg.items() if leg == i]
        return min(geom_bottom(self.model, data, g) for g in gs) if gs else 0.0

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        if self.cfg.support:
            return super().__call__(model, data, t, dt)
        down = self._feet_down(data)
        if self.bal.capture_step > 0 and len(self.legs) > 2:
            self._catch(model, data, t)
        if t >= self._next_plan - 1e-9:
            prev = self._target
            self._target = self._plan(t, data)
            mujoco.mj_differentiatePos(model, self._qdot_ref, self._dt_plan, prev, self._target)
            self._next_plan = t + self._dt_plan
        target = self._target
        self.frame = self.loop[0] + (t - self._t_start) / self.clip.frame_time
        e = self._quat_error(data, target)
        self.tracking_error = np.linalg.norm(e, axis=1)
        swinging = [self._phase(t, i) >= 0 for i in range(len(self.legs))]
        if swinging != self._swing_state:  # a swinging leg is softer: stiffness x s, damping x sqrt(s)
            self._swing_state = swinging
            kp_scale = np.ones(len(self.qadr))
            for i, sw in enumerate(swinging):
                if sw:
                    kp_scale[self._leg_balls[i]] = self.bal.swing_stiffness
            self._kp_now = self.kp * kp_scale
            kd_now = self.kd * np.sqrt(kp_scale)
            for k, dadr in enumerate(self.dadr):
                model.dof_damping[dadr:dadr + 3] = self.base_damping[dadr:dadr + 3] + kd_now[k]
            self._kd_now = kd_now
        tau_all = np.zeros(model.nu)
        # kd (qdot_ref - qdot): the -kd qdot half is MuJoCo's implicit joint damping; the planned joint
        # velocity half is fed forward, or the damping would hold back the stance legs' sweep
        tau = self._kp_now[:, None] * e
        if self.bal.velocity_feedforward:  # on the swinging legs only: the stance legs move slowly
            ff = np.zeros(model.nv)
            for i, sw in enumerate(swinging):
                if sw:
                    ff[self.leg_dofs[i]] = self._qdot_ref[self.leg_dofs[i]]
            tau = tau + self._kd_now[:, None] * ff[self._vel_idx]
        tau_all[self.acts.ravel()] = tau.ravel()
        for i, sw in enumerate(swinging):  # a swinging leg carries its own weight (gravity, Coriolis)
            if sw:
                tau_all[self.leg_acts[i]] += data.qfrc_bias[self.leg_dofs[i]]
        stance = [i for i, dn in enumerate(down) if dn and self._phase(t, i) < 0]
        if stance:
            tau_all += self._body_wrench(data, target, t, stance)
        lim = np.repeat(self.limit, 3)
        order = self.acts.ravel()
        self.torque[order] = np.clip(tau_all[order], -lim, lim)
        return self.torque

    def contact_state(self, data: mujoco.MjData, t: float) -> tuple[list[bool], list[bool], list[float]]:
        """Per leg at time ``t``: planned in stance, touching the floor, and the stance progress in
        [0, 1) (-1 while swinging or before the first step): what the contact measures read
        (:class:`~bipedsim.sim.contacts.StanceContacts`)."""
        n = len(self.legs)
        planned = [self._phase(t, i) < 0 for i in range(n)]
        down = self._feet_down(data)
        prog = []
        for i in range(n):
            if t < self._t_walk or not planned[i]:
                prog.append(-1.0)
                continue
            p = ((t - self._t_walk) / self.period - self.offsets[i]) % 1.0
            prog.append((p - self.swing_frac) / max(1.0 - self.swing_frac, 1e-9))
        return planned, down, prog

    def heading(self, data: mujoco.MjData) -> float:
        """The body's heading (rad about world Z): its forward axis, measured from the clip (the root
        frame's x axis points backward in the dog's skeleton), so a push at 90 deg is to its left."""
        return _heading(data.xmat[self.root_body].reshape(3, 3), self.fwd)

    def reference_qpos(self) -> FloatArray:
        return self._target if hasattr(self, "_target") else super().reference_qpos()

    def reference_speed(self) -> float:
        return self.v_des

    def metrics(self) -> dict[str, object]:
        out = super().metrics()
        out.update({"controller": "creature_gait", "gait_period_s": self.period, "swing_fraction": self.swing_frac,
                    "target_speed_mps": self.v_des, "clip_speed_mps": self.clip_speed})
        return out


#: the planned gait's controller by number of legs, where one differs (``control/creature_biped.py``: two)
GAITS_BY_LEGS: dict[int, type[CreatureGaitController]] = {}


@register("creature")
def make_creature_controller(model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                             cfg: CreatureControlConfig | None = None,
                             balance: CreatureBalanceConfig | None = None) -> CreatureBalanceController:
    """The creature's controller: the planned gait (``gait: planned``, the default) or the clip-timed
    balance of :class:`~bipedsim.control.creature_balance.CreatureBalanceController` (``gait: clip``)."""
    balance = balance or (cfg or CreatureControlConfig()).balance
    if balance.gait == "clip":
        return CreatureBalanceController(model, plan, clip, cfg, balance)
    gait = GAITS_BY_LEGS.get(len(creature_legs(plan)), CreatureGaitController)
    return gait(model, plan, clip, cfg, balance)


__all__ = ["GAITS_BY_LEGS", "CreatureGaitController", "make_creature_controller"]
