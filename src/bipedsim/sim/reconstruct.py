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
import hashlib
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.config import to_dict
from bipedsim.control.humanoid.correction import EXTRA, Correction, LiveCorrection
from bipedsim.control.humanoid.settings import ReconstructConfig
from bipedsim.control.humanoid.simbicon import SimbiconController
from bipedsim.control.settings import ControllerConfig
from bipedsim.errors import BipedsimError, ModelError
from bipedsim.files import atomic_write_text, read_input_text
from bipedsim.files.progress import progress_bar
from bipedsim.files.provenance import versions
from bipedsim.reference.clip import ReferenceClip
from bipedsim.sim.rollout import FallCriteria, FallDetector, control_every, diverged

FloatArray = npt.NDArray[np.float64]
#: a window searched again after every sample fell gets up to this many times the samples
MAX_BOOST = 8


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
    history = [[_Node(data, ctrl, [], [], 0.0)]]  # the states kept at the start of each window
    retries, boost = 0, 1
    while len(history) <= n_windows:
        step = (len(history) - 1) * per_window
        found = _window(model, clip, cfg, history[-1], step, per_window, every, check_every, falls, shared,
                        sigma, rng, cfg.samples * boost, frame0)
        if found:
            history.append(found[:cfg.keep])
            boost = 1
            if progress is not None:
                progress(min((step + per_window) * dt, total_s), total_s)
            continue
        # every sample fell: search the window before again, with more samples (SAMCON's backtracking)
        if retries >= cfg.retries:
            break
        retries += 1
        boost = min(2 * boost, MAX_BOOST)
        if len(history) > 1:
            history.pop()
    nodes = history[-1]
    best = nodes[0]
    if not best.rows:
        return None
    return Correction(starts=tuple(best.starts), rows=np.array(best.rows), end=float(best.ctrl.frame))


def _window(model: mujoco.MjModel, clip: ReferenceClip, cfg: ReconstructConfig, parents: list[_Node], step: int,
            n: int, every: int, check_every: int, falls: FallDetector, shared: dict[int, object], sigma: FloatArray,
            rng: np.random.Generator, samples: int, frame0: float) -> list[_Node]:
    """The samples of one window of ``n`` physics steps from ``step`` that stay up, drawn around
    ``parents`` in turn, best first."""
    dt = model.opt.timestep
    qadr = parents[0].ctrl.hinges.qadr
    found: list[_Node] = []
    for j in range(samples):
        parent = parents[j % len(parents)]
        last = parent.rows[-1] if parent.rows else np.zeros(len(sigma))
        row = cfg.coherence * last + rng.normal(0.0, sigma)
        d = mujoco.MjData(model)
        mujoco.mj_copyData(d, model, parent.data)
        c = _clone(parent.ctrl, shared)
        live = c.correction
        assert isinstance(live, LiveCorrection)
        live.set(row)
        if not _walk(model, d, c, step, n, every, check_every, falls):
            continue
        cost = tracking_cost(model, d, clip, frame0 + (step + n) * dt / clip.frame_time, qadr, cfg)
        found.append(_Node(d, c, parent.starts + [float(live.started)], parent.rows + [row], cost))
    found.sort(key=lambda node: node.cost)
    return found


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


#: where searched corrections are kept, under the user's cache folder (``XDG_CACHE_HOME`` or ~/.cache)
CACHE_SUBDIR = ("bipedsim", "corrections")
#: the modules whose code shapes a search's result: a change to any of them makes a new cache key
_CODE = ("control/humanoid", "sim/reconstruct.py", "sim/rollout.py")


def cache_folder() -> Path:
    """The folder of cached corrections."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache").joinpath(*CACHE_SUBDIR)


def correction_key(clip: ReferenceClip, model_hash: str, cfg: ControllerConfig) -> str:
    """The cache key of a search: the clip's frames, the body, every controller setting and the code
    and library versions that shape the result."""
    h = hashlib.sha256()
    for a in (clip.qpos, clip.qvel, clip.contacts):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(repr(clip.frame_time).encode() + model_hash.encode())
    h.update(json.dumps(to_dict(cfg), sort_keys=True, default=str).encode())
    h.update(json.dumps(versions(), sort_keys=True).encode())
    root = Path(__file__).resolve().parent.parent
    for part in _CODE:
        p = root / part
        for src in sorted(p.glob("*.py")) if p.is_dir() else [p]:
            h.update(src.read_bytes())
    return h.hexdigest()[:24]


def correction_for(model: mujoco.MjModel, model_hash: str, make_ctrl: Callable[[], SimbiconController],
                   clip: ReferenceClip, cfg: ControllerConfig, fall: FallCriteria) -> tuple[Correction | None, str]:
    """The correction for ``clip`` on this body with these settings, and a line saying where it came
    from: read from the cache when this search was run before, else searched (a progress bar on a
    terminal) and cached."""
    key = correction_key(clip, model_hash, cfg)
    path = cache_folder() / f"{key}.json"
    ctrl = make_ctrl()
    nh = ctrl.tables.kp.shape[0]
    stale = ""
    if path.is_file():
        try:
            d = json.loads(read_input_text(path, "json"))
            corr = Correction.from_dict(d["correction"], nh) if d["correction"] is not None else None
            return corr, f"reconstruct: the correction searched before, read from {path}"
        except (BipedsimError, ValueError, KeyError, TypeError) as exc:
            stale = f" (the cached one was unreadable: {exc})"
    total = (clip.num_frames - 1 - ctrl.start_frame()) * clip.frame_time
    bar = progress_bar(round(total, 1), "reconstruct", "s of clip")
    done = [0.0]

    def tick(t: float, _total: float) -> None:
        if bar is not None:
            bar.update(round(t - done[0], 4))
        done[0] = t

    t0 = time.perf_counter()
    try:
        corr = reconstruct(model, ctrl, clip, cfg.reconstruct, fall, progress=tick)
    finally:
        ctrl.restore_model()
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    rc = cfg.reconstruct
    what = (f"reconstruct: searched a correction for {done[0]:.1f} s of the clip's {max(total, 0.0):.1f} s in "
            f"{wall:.0f} s (windows of {rc.window_s:g} s, {rc.samples} samples each){stale}")
    if done[0] < total - 1e-6:
        what += f"; every sample fell after {done[0]:.1f} s, so the correction ends there"
    try:
        atomic_write_text(path, json.dumps({"key": key, "clip": clip.source, "seconds": done[0],
                                            "correction": corr.to_dict() if corr is not None else None}))
        what += f"; cached in {path}"
    except OSError as exc:
        what += f"; not cached ({exc.strerror or exc})"
    return corr, what
