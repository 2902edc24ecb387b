"""Sampling-based control reconstruction: the feed-forward correction that keeps a body on its clip.

After Liu et al. 2010 ("Sampling-based contact-rich motion control"), window by window along the clip:
from each of the ``keep`` best states found so far, ``samples`` rollouts of one window (``window_s``),
each with its own random offsets of the controller's targets
(:mod:`~bipedsim.control.humanoid.correction`: every hinge, the swing hip's feedback angles, the
torso's pitch and roll) drawn around its parent's (``coherence``: the offsets of one window carry into
the next, so the correction is smooth); the ``keep`` whose end states lie nearest the clip at the same
time (:func:`tracking_cost`) go on. A sample that falls is dropped; when every sample of a window falls
the search stops there and the correction ends at that window. The best final state's offsets, window
by window, are the :class:`~bipedsim.control.humanoid.correction.Correction`.

The search runs the controller exactly as a rollout does (the same control step, physics steps and
fall checks), and a rollout with the correction from the same start repeats the best sample's path.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.correction import EXTRA, Correction, LiveCorrection
from bipedsim.control.humanoid.settings import ReconstructConfig
from bipedsim.control.humanoid.simbicon import SimbiconController
from bipedsim.errors import ModelError
from bipedsim.reference.clip import ReferenceClip
from bipedsim.sim.rollout import FallCriteria, FallDetector, control_every, diverged

FloatArray = npt.NDArray[np.float64]


@dataclass
class _Node:
    """One state the search keeps: the physics, the controller, the offsets that led there."""

    data: mujoco.MjData
    ctrl: SimbiconController
    starts: list[float]
    rows: list[FloatArray]
    cost: float


def tracking_cost(model: mujoco.MjModel, data: mujoco.MjData, clip: ReferenceClip, frame: float,
                  hinge_qadr: npt.NDArray[np.integer], cfg: ReconstructConfig) -> float:
    """How far the body is from the clip at (fractional) clip ``frame``: the hinges' RMS angle error
    (rad), the root's orientation error (rad), its horizontal and vertical position errors (m, the
    body started on the clip's root) and its horizontal velocity error (m/s), weighted by ``cfg``."""
    i = min(int(frame), clip.num_frames - 2)
    u = min(max(frame - i, 0.0), 1.0)
    ref = (1.0 - u) * clip.qpos[i] + u * clip.qpos[i + 1]
    vref = (1.0 - u) * clip.qvel[i] + u * clip.qvel[i + 1]
    q = data.qpos
    e_pose = float(np.sqrt(np.mean((q[hinge_qadr] - ref[hinge_qadr]) ** 2)))
    quat = ref[3:7] / np.linalg.norm(ref[3:7])
    dot = abs(float(np.dot(quat, q[3:7])))
    e_rot = 2.0 * math.acos(min(dot, 1.0))
    e_xy = float(np.hypot(q[0] - ref[0], q[1] - ref[1]))
    e_z = abs(float(q[2] - ref[2]))
    e_v = float(np.hypot(data.qvel[0] - vref[0], data.qvel[1] - vref[1]))
    return (cfg.pose_weight * e_pose + cfg.root_weight * e_rot + cfg.position_weight * e_xy
            + cfg.height_weight * e_z + cfg.velocity_weight * e_v)


def _clone(ctrl: SimbiconController, shared: dict[int, object]) -> SimbiconController:
    return copy.deepcopy(ctrl, dict(shared))


def _shared(ctrl: SimbiconController) -> dict[int, object]:
    """What every copy of ``ctrl`` shares: the model and the per-run constants (a deep copy's memo)."""
    keep: list[object] = [ctrl.model, ctrl.plan, ctrl.source, ctrl.tables, ctrl.cfg, ctrl.hinges]
    tr = ctrl.steering.tracker
    keep += [getattr(tr, k) for k in ("xs", "ys", "hs", "dx", "dy", "ll", "nx", "ny", "arc")]
    return {id(x): x for x in keep}


def reconstruct(model: mujoco.MjModel, ctrl: SimbiconController, clip: ReferenceClip, cfg: ReconstructConfig,
                fall: FallCriteria, *, end_frame: float | None = None,
                progress: Callable[[float, float], None] | None = None) -> Correction | None:
    """The correction that keeps ``ctrl``'s body (``model``, fresh, not yet reset) on ``clip`` from the
    controller's start frame to ``end_frame`` (default: the clip's last frame), or None when not even
    the first window could be walked. ``progress(done_s, total_s)`` is called after each window."""
    if not isinstance(ctrl, SimbiconController):
        raise ModelError("reconstruction drives the humanoid's controller")
    frame0 = float(ctrl.start_frame())
    end = float(clip.num_frames - 1 if end_frame is None else end_frame)
    total_s = (end - frame0) * clip.frame_time
    if total_s <= 0:
        return None
    data = mujoco.MjData(model)
    data.qpos[:] = clip.qpos[int(frame0)]
    data.qvel[:] = clip.qvel[int(frame0)]
    mujoco.mj_forward(model, data)
    nh = ctrl.tables.kp.shape[0]
    ctrl.correction = LiveCorrection(nh)
    ctrl.reset(data, frame0)
    falls = FallDetector(model, ctrl.plan, fall, data, root=ctrl.root_body)
    dt = model.opt.timestep
    every = control_every(ctrl.control_dt, dt)
    check_every = max(1, int(round(fall.check_every / dt)))
    per_window = max(every, int(round(cfg.window_s / dt / every)) * every)
    n_windows = int(math.ceil(total_s / (per_window * dt)))
    sigma = np.concatenate([np.full(nh, cfg.hinge_sigma), np.full(2, cfg.feedback_sigma),
                            np.full(EXTRA - 2, cfg.torso_sigma)])
    rng = np.random.default_rng(cfg.seed)
    shared = _shared(ctrl)
    qadr = ctrl.hinges.qadr
    nodes = [_Node(data, ctrl, [], [], 0.0)]
    step = 0
    for _w in range(n_windows):
        found: list[_Node] = []
        for j in range(cfg.samples):
            parent = nodes[j % len(nodes)]
            last = parent.rows[-1] if parent.rows else np.zeros(nh + EXTRA)
            row = cfg.coherence * last + rng.normal(0.0, sigma)
            d = mujoco.MjData(model)
            mujoco.mj_copyData(d, model, parent.data)
            c = _clone(parent.ctrl, shared)
            live = c.correction
            assert isinstance(live, LiveCorrection)
            live.set(row)
            if not _walk(model, d, c, step, per_window, every, check_every, falls):
                continue
            t_end = (step + per_window) * dt
            cost = tracking_cost(model, d, clip, frame0 + t_end / clip.frame_time, qadr, cfg)
            found.append(_Node(d, c, parent.starts + [float(live.started)], parent.rows + [row], cost))
        if not found:
            break
        found.sort(key=lambda n: n.cost)
        nodes = found[:cfg.keep]
        step += per_window
        if progress is not None:
            progress(min(step * dt, total_s), total_s)
    best = nodes[0]
    if not best.rows:
        return None
    return Correction(starts=tuple(best.starts), rows=np.array(best.rows), end=float(best.ctrl.frame))


def _walk(model: mujoco.MjModel, data: mujoco.MjData, ctrl: SimbiconController, step: int, n: int, every: int,
          check_every: int, falls: FallDetector) -> bool:
    """Run ``n`` physics steps from physics step ``step`` as :func:`~bipedsim.sim.rollout.rollout` does
    (control, then ``every`` physics steps; fall and divergence checks every ``check_every``); whether
    the body is still up."""
    dt = model.opt.timestep
    end = step + n
    while step < end:
        data.ctrl[:] = ctrl(model, data, step * dt, dt * every)
        k = min(every, end - step)
        before = step // check_every
        mujoco.mj_step(model, data, k)
        step += k
        if step // check_every > before and (diverged(data) or falls.check(data, ctrl)):
            return False
    return True
