"""The planned gait's neutral stance, measured from the clip and made feasible on the built body.

Instead of tracking the clip's joint angles -- a pose that need not be feasible on the built body (a
horse's stance feet far behind its centre of mass, a dog's feet on the midline) -- the planned gait
stands the body in a neutral stance of its own:

- each foot's mean position relative to the root over the looped part, in the heading frame; the
  root's median height (x ``height_fraction``) and mean attitude (heading removed); the non-leg joints
  (spine, neck, tail) at their mean over the loop;
- pairs of feet (left and right) widened to at least ``stance_width`` x their hips' lateral offset, and
  the whole stance shifted so the feet's centroid lies under the body's centre of mass;
- the legs posed by IK on that stance inside their joint ranges, the stance taken from where the feet
  got; a leg too short to reach the floor lowers the body (at most MAX_CROUCH of its height).

Lengths in m; the heading frame is the world frame turned by the body's heading (its forward axis).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.frames import axis_heading, rot_z
from bipedsim.control.creature.ik import Attitude, LegIK
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.reference import LoopedReference
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.control.creature.tracking import CreatureBody

#: the neutral stance lowers the body by at most this share of the clip's root height so every leg
#: reaches the floor
MAX_CROUCH = 0.25
#: IK rounds (each re-centring the stance under the posed body) and iterations per round
STANCE_ROUNDS, STANCE_IK_ITERS = 3, 20
#: a widened stance whose feet the IK brings no nearer than this share of the root height to their places
#: across the floor is narrowed (the legs' joint ranges do not reach it): the reach's own tolerance
STANCE_REACH_TOL = 0.04
#: widenings tried, from ``stance_width`` down to none in equal steps
WIDEN_TRIES = 5
#: IK iterations of the check that a posed stance's feet are reached (as many as a reach target's)
STANCE_CHECK_ITERS = 30
#: a body's axis turned by less than this (rad) is left as measured from the clip
MIN_AXIS_TURN = 1e-3


@dataclass
class Stance:
    """The neutral stance (see the module text)."""

    #: the body's forward axis (unit, root frame)
    fwd: FloatArray
    #: the neutral pose, a qpos with the root at x = y = 0, heading 0
    q: FloatArray
    #: the root's attitude in the heading frame (3x3)
    att: FloatArray
    #: the root's height (m) and the clip's median root height over the loop (m)
    height: float
    clip_height: float
    #: (legs, 3) each foot site relative to the root, heading frame (z: the clip's mean)
    feet: FloatArray
    #: the centre of mass relative to the root (m, heading frame)
    com: FloatArray
    #: (legs,) each foot site's height (m) when its foot stands
    site_ground: FloatArray
    #: (legs, 3) each leg's root relative to the body's root, neutral pose (m, heading frame)
    hips: FloatArray
    #: (legs,) each leg's side of the stance's mid-line (+1 left, -1 right) and the widest half-width (m)
    side: FloatArray
    half_width: float


def measure_stance(model: mujoco.MjModel, body: CreatureBody, legs: LegSet, ref: LoopedReference, ik: LegIK,
                   bal: CreatureBalanceConfig, fwd: FloatArray, site_heights: Callable[[FloatArray], FloatArray],
                   attitude: Attitude | None = None) -> Stance:
    """The neutral stance for forward axis ``fwd`` (see the module text). ``site_heights``: each foot
    site's standing height given the default (the median of the site over its leg's lowest point);
    ``attitude``: the feet's orientations the IK aims at (:meth:`LegIK.solve`)."""
    clip, (a, b) = ref.clip, ref.loop
    d, n, root_id = ik.data, len(legs), body.root_body
    rel = np.zeros((b - a, n, 3))
    atts = []
    for k, f in enumerate(range(a, b)):
        d.qpos[:] = clip.qpos[f]
        mujoco.mj_kinematics(model, d)
        r = d.xmat[root_id].reshape(3, 3)
        h = rot_z(axis_heading(r, fwd)).T
        root = d.xpos[root_id]
        for i in range(n):
            rel[k, i] = h @ (d.site_xpos[ik.sites[i]] - root)
        atts.append(Rotation.from_matrix(h @ r))
    # the neutral pose: the looped frame with its feet lowest, its non-leg joints (spine, neck, tail) at
    # their mean over the loop (a turning clip's bent spine straightened), the root at the mean attitude
    # (heading removed) and the median height
    ref_low = ref.ref_low[a:b]
    lowest = np.nansum(np.where(np.isfinite(ref_low), ref_low, 0.0), axis=1)
    f0 = a + int(np.argmin(lowest))
    q = clip.qpos[f0].copy()
    leg_dofs = set(np.concatenate(legs.dofs).tolist()) if n else set()
    for k, qa in enumerate(body.qadr):
        if int(body.dadr[k]) not in leg_dofs:
            mean = Rotation.from_quat(clip.qpos[a:b, qa:qa + 4], scalar_first=True).mean()
            q[qa:qa + 4] = mean.as_quat(scalar_first=True)
    att = Rotation.concatenate(atts).mean().as_matrix()  # root attitude in the heading frame
    att = rot_z(-axis_heading(att, fwd)) @ att  # the mean's residual heading removed
    clip_height = float(np.median(clip.qpos[a:b, 2]))
    height = clip_height * bal.height_fraction
    q[0:2] = 0.0
    q[2] = height
    q[3:7] = Rotation.from_matrix(att).as_quat(scalar_first=True)
    d.qpos[:] = q
    mujoco.mj_kinematics(model, d)
    mujoco.mj_comPos(model, d)
    root = d.xpos[root_id].copy()
    com = d.subtree_com[root_id] - root  # heading frame = world here
    hips = np.array([d.xpos[model.body(leg.root).id] - root for leg in legs.legs]).reshape(n, 3)
    foot = rel.mean(axis=0)
    default = np.array([float(np.median(clip.qpos[a:b, 2] + rel[:, i, 2] - ref_low[:, i]))
                        if np.all(np.isfinite(ref_low[:, i])) else 0.0 for i in range(n)])
    site_ground = site_heights(default)
    ik.q = q.copy()
    posed = None
    for width in _widths(bal.stance_width):
        trial = _pose(model, ik, root_id, q, foot, hips, com, site_ground, bal, width, height, clip_height,
                      attitude)
        if posed is None or trial[4] < posed[4]:
            posed = trial
        if trial[4] <= STANCE_REACH_TOL * height:
            posed = trial
            break
    q, foot, com, height, _ = posed
    across = foot[:, 1] - foot[:, 1].mean() if n else np.zeros(0)
    return Stance(fwd=fwd, q=q, att=att, height=height, clip_height=clip_height, feet=foot, com=com,
                  site_ground=site_ground, hips=hips, side=np.sign(across),
                  half_width=float(np.abs(across).max()) if n else 0.0)


def _widths(stance_width: float) -> list[float]:
    """The widenings tried (x the hips' half spacing), widest first: ``stance_width``, then narrower in
    equal steps down to none (the clip's own width), :data:`WIDEN_TRIES` in all."""
    return [stance_width * (1.0 - k / (WIDEN_TRIES - 1)) for k in range(WIDEN_TRIES)]


def _pose(model: mujoco.MjModel, ik: LegIK, root_id: int, q0: FloatArray, foot0: FloatArray, hips: FloatArray,
          com: FloatArray, site_ground: FloatArray, bal: CreatureBalanceConfig, width: float, height: float,
          clip_height: float, attitude: Attitude | None) -> tuple[FloatArray, FloatArray, FloatArray, float, float]:
    """The stance posed from the clip's feet ``foot0`` (legs, 3) widened to ``width`` (see
    :func:`_widen_pairs`) and centred under ``com``: (the posed qpos, the feet where they got, the posed
    centre of mass, the root height (m), the IK's largest miss (m) in its last round)."""
    d, n = ik.data, len(hips)
    q, foot = q0.copy(), foot0.copy()
    _widen_pairs(foot, hips, width)
    if n:  # centre: the feet's centroid under the neutral pose's centre of mass
        foot[:, 0:2] += com[0:2] - foot[:, 0:2].mean(axis=0)
    # reachable: the legs posed by IK on this stance (inside their joint ranges), the stance then taken
    # from where the feet got, re-centred under the posed body's centre of mass
    ik.q = q.copy()
    for _ in range(STANCE_ROUNDS):
        posture = q
        q = posture.copy()
        ik.solve(q, np.column_stack([foot[:, 0:2], site_ground]), posture, bal.posture_pull, iters=STANCE_IK_ITERS,
                 attitude=attitude)
        mujoco.mj_kinematics(model, d)
        mujoco.mj_comPos(model, d)
        com = d.subtree_com[root_id] - d.xpos[root_id]
        got = ik.site_positions()
        foot[:, 0:2] = got[:, 0:2]
        short = float(np.max(got[:, 2] - site_ground)) if n else 0.0
        # a leg too short to reach the floor from here: the body stands lower, by at most MAX_CROUCH of
        # its height (a 'leg' that is no leg -- a low head -- does not sink it)
        short = min(short, height - (1.0 - MAX_CROUCH) * clip_height)
        if short > 0.0:
            height -= short
            q[2] = height
        if n:
            foot[:, 0:2] += com[0:2] - foot[:, 0:2].mean(axis=0)
    return q, foot, com, height, _stance_miss(model, ik, q, foot, site_ground, bal, attitude)


def _stance_miss(model: mujoco.MjModel, ik: LegIK, q: FloatArray, foot: FloatArray, site_ground: FloatArray,
                 bal: CreatureBalanceConfig, attitude: Attitude | None) -> float:
    """The IK's largest miss (m) of the stance's feet (``foot`` relative to the root of ``q``, each on
    the floor at its standing height), solved from the posed stance as the legs' reach is; the IK's
    warm start and pose are left as they were."""
    if not len(foot):
        return 0.0
    saved = ik.q.copy()
    target = np.column_stack([q[0] + foot[:, 0], q[1] + foot[:, 1], site_ground])
    trial = q.copy()
    ik.solve(trial, target, q, bal.posture_pull, iters=STANCE_CHECK_ITERS, attitude=attitude)
    mujoco.mj_kinematics(model, ik.data)
    miss = float(np.max(np.linalg.norm(ik.site_positions() - target, axis=1)))
    ik.q[:] = saved
    ik.data.qpos[:] = saved
    mujoco.mj_kinematics(model, ik.data)
    mujoco.mj_comPos(model, ik.data)
    return miss


def _widen_pairs(foot: FloatArray, hips: FloatArray, stance_width: float) -> None:
    """Pairs of legs (left and right: each hip the nearest to the other's mirror image across the hips'
    mid-line) stand symmetric about their hips' centre, at least ``stance_width`` x their hips' half
    spacing apart, level with each other (``foot``, (legs, 3), in place)."""
    n = len(hips)
    mid = float(hips[:, 1].mean()) if n else 0.0
    mirror = hips.copy()
    mirror[:, 1] = 2 * mid - mirror[:, 1]
    for i in range(n):
        dist = np.linalg.norm(hips - mirror[i], axis=1)
        dist[i] = np.inf
        j = int(np.argmin(dist)) if n > 1 else i
        back = np.linalg.norm(hips - mirror[j], axis=1)
        back[j] = np.inf
        if j == i or int(np.argmin(back)) != i or j < i:
            continue
        cy = 0.5 * (hips[i, 1] + hips[j, 1])
        half = max(abs(foot[i, 1] - foot[j, 1]) / 2, stance_width * abs(hips[i, 1] - hips[j, 1]) / 2)
        side = 1.0 if hips[i, 1] >= cy else -1.0
        foot[i, 1], foot[j, 1] = cy + side * half, cy - side * half
        foot[i, 0] = foot[j, 0] = 0.5 * (foot[i, 0] + foot[j, 0])


def body_axis(stance: Stance) -> FloatArray | None:
    """The body's own long axis (unit, root frame), where it differs from ``stance.fwd``: the hips'
    principal horizontal direction (a clip that turns or walks a little crabwise travels at an angle
    to it); two hips side by side: across it. None: fewer than two legs, or the same axis."""
    n = len(stance.hips)
    if n < 2:
        return None
    h = stance.hips[:, 0:2] - stance.hips[:, 0:2].mean(axis=0)
    axis = np.linalg.svd(h, full_matrices=False)[2][0]
    if n == 2:
        axis = np.array([-axis[1], axis[0]])
    theta = math.atan2(axis[1], axis[0]) if axis[0] >= 0 else math.atan2(-axis[1], -axis[0])
    if abs(theta) <= MIN_AXIS_TURN:
        return None
    att = stance.att
    fwd = att.T @ rot_z(theta) @ att @ stance.fwd
    return fwd / np.linalg.norm(fwd)


__all__ = ["MAX_CROUCH", "Stance", "body_axis", "measure_stance"]
