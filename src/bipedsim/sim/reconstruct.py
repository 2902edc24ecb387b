"""Sampling-based control reconstruction: the feed-forward correction that keeps a body on its clip.

After Liu et al. 2010 ("Sampling-based contact-rich motion control"), window by window along the clip:
from each of the ``keep`` best states found so far, ``samples`` rollouts of one window (``window_s``),
each with its own random offsets of the controller's targets
(:mod:`~bipedsim.control.humanoid.correction`: every hinge, the swing hip's feedback angles, the
torso's pitch and roll) drawn around its parent's (``coherence``: the offsets of one window carry into
the next, so the correction is smooth); the ``keep`` whose end states lie nearest the clip at the same
time (:func:`tracking_cost`) go on. A sample that falls is dropped; when every sample of a window falls
the search backs up and searches again with more samples (``retries`` in all), then stops there and the
correction ends at that window. The best final state's offsets, window
by window, are the :class:`~bipedsim.control.humanoid.correction.Correction`.

The search runs the controller exactly as a rollout does (the same control step, physics steps and
fall checks), and a rollout with the correction from the same start repeats the best sample's path.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import math
import multiprocessing
import os
import signal
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.config import to_dict
from bipedsim.control.humanoid.correction import EXTRA, Correction, LiveCorrection
from bipedsim.control.humanoid.settings import ReconstructConfig
from bipedsim.control.humanoid.simbicon import SimbiconController
from bipedsim.control.humanoid.sources import ClipSource
from bipedsim.control.settings import ControllerConfig
from bipedsim.errors import BipedsimError, ModelError
from bipedsim.files import atomic_write_text, read_input_text
from bipedsim.files.progress import progress_bar
from bipedsim.files.provenance import versions
from bipedsim.model.ground import Terrain
from bipedsim.reference.clip import ReferenceClip
from bipedsim.sim.rollout import FallCriteria, FallDetector, control_every, walk_window

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


@dataclass(frozen=True)
class _Search:
    """What every sample of a search shares (set before the workers fork; they read it, never write)."""

    model: mujoco.MjModel
    frames: tuple[FloatArray, FloatArray]  #: the played frames' qpos and qvel (the cost's reference)
    frame0: float
    frame_time: float
    cfg: ReconstructConfig
    falls: FallDetector
    shared: dict[int, object]
    every: int
    check_every: int
    per_window: int
    hinge_qadr: npt.NDArray[np.integer]
    terrain: Terrain | None = None  #: the ground's heights (None: the flat floor at z = 0)


def tracking_cost(data: mujoco.MjData, ref_qpos: FloatArray, ref_qvel: FloatArray, frame: float,
                  hinge_qadr: npt.NDArray[np.integer], cfg: ReconstructConfig, ground_z: float = 0.0) -> float:
    """How far the body is from the reference frames ``ref_qpos``/``ref_qvel`` at (fractional)
    ``frame``: the hinges' RMS angle error (rad), the root's orientation error (rad), its horizontal
    and vertical position errors (m, the body started on the reference's root; the height above the
    ground under the root, ``ground_z`` m, against the clip's above its flat floor) and its horizontal
    velocity error (m/s), weighted by ``cfg``."""
    i = min(int(frame), len(ref_qpos) - 2)
    u = min(max(frame - i, 0.0), 1.0)
    ref = (1.0 - u) * ref_qpos[i] + u * ref_qpos[i + 1]
    vref = (1.0 - u) * ref_qvel[i] + u * ref_qvel[i + 1]
    q = data.qpos
    e_pose = float(np.sqrt(np.mean((q[hinge_qadr] - ref[hinge_qadr]) ** 2)))
    quat = ref[3:7] / np.linalg.norm(ref[3:7])
    dot = abs(float(np.dot(quat, q[3:7])))
    e_rot = 2.0 * math.acos(min(dot, 1.0))
    e_xy = float(np.hypot(q[0] - ref[0], q[1] - ref[1]))
    e_z = abs(float(q[2] - ground_z - ref[2]))
    e_v = float(np.hypot(data.qvel[0] - vref[0], data.qvel[1] - vref[1]))
    return (cfg.pose_weight * e_pose + cfg.root_weight * e_rot + cfg.position_weight * e_xy
            + cfg.height_weight * e_z + cfg.velocity_weight * e_v)


def _shared(ctrl: SimbiconController) -> dict[int, object]:
    """What every copy of ``ctrl`` shares: the model and the per-run constants (a deep copy's memo)."""
    keep: list[object] = [ctrl.model, ctrl.plan, ctrl.source, ctrl.tables, ctrl.cfg, ctrl.hinges, ctrl.terrain]
    tr = ctrl.steering.tracker
    keep += [getattr(tr, k) for k in ("xs", "ys", "hs", "dx", "dy", "ll", "nx", "ny", "arc")]
    return {id(x): x for x in keep}


def search_end(src: ClipSource, loop_cycles: int, loop_max_s: float | None = None, start: float = 0.0,
               cover_s: float = 0.0) -> tuple[float, bool]:
    """The reference frame a search of ``src`` ends at, and whether that covers whole periods of its
    loop: the clip's end, or, where the clip has a cycle to loop, ``loop_cycles`` periods of the loop
    played after it (a cycle's correction then repeats). ``loop_max_s`` (s) bounds the search past the
    clip's end: as many whole periods as fit in it, or, where not one does (a loop of many strides), the
    search ends that long after the clip and its correction fades out (None: no bound). ``cover_s`` (s;
    0: none) takes the search on over whole periods until it is at least that long after ``start`` (the
    run's first frame), whatever ``loop_cycles`` and ``loop_max_s`` say."""
    end = float(src.clip.num_frames - 1)
    looping = any(len(v) for v in src.playlist.loop.values())
    if not looping or loop_cycles <= 0:
        return end, False
    cycles = loop_cycles
    cover = int(math.ceil((start + cover_s / src.frame_time - src.a) / src.period - 1e-9)) if cover_s > 0 else 0
    if loop_max_s is not None:
        limit = end + loop_max_s / src.frame_time
        cycles = min(cycles, int(math.floor((limit - src.a) / src.period + 1e-9)))
        if cycles <= 0 and cover <= 0:
            return max(end, limit), False
    return max(end, src.a + max(cycles, cover) * src.period), True


def search_span(ctrl: SimbiconController, loop_cycles: int | None = None) -> float:
    """The seconds a search covers from the controller's start (:func:`search_end`; ``loop_cycles``
    None: the settings'; 0: the clip alone)."""
    src = ctrl.source
    assert isinstance(src, ClipSource)
    rc = ctrl.cfg.reconstruct
    cycles = rc.loop_cycles if loop_cycles is None else loop_cycles
    start = float(ctrl.start_frame())
    return (search_end(src, cycles, rc.loop_max_s, start, rc.cover_s)[0] - start) * src.frame_time


def reconstruct(model: mujoco.MjModel, ctrl: SimbiconController, cfg: ReconstructConfig, fall: FallCriteria, *,
                workers: int = 1, progress: Callable[[float, float], None] | None = None) -> Correction | None:
    """The correction that keeps ``ctrl``'s body (``model``; the controller fresh, not yet reset) on its
    whole clip and its loop's first cycles (:func:`search_span`), or None when not even the first window
    could be walked.
    ``workers`` processes sample each window (the result does not depend on how many);
    ``progress(done_s, total_s)`` is called after each window."""
    return search_corrections(model, ctrl, cfg, fall, workers=workers, progress=progress)[0]


def search_corrections(model: mujoco.MjModel, ctrl: SimbiconController, cfg: ReconstructConfig,
                       fall: FallCriteria, *, workers: int = 1, progress: Callable[[float, float], None] | None = None,
                       state: dict[str, object] | None = None) -> tuple[Correction | None, Correction | None]:
    """:func:`reconstruct`'s correction, and the best one at the clip's end: the search's best path when
    its windows first covered the clip (what a search of the clip alone finds, window for window), which
    fades out after the clip; None where there is none, or where it is the first. ``state`` (a dict)
    receives the search's state where it reached its end; given one so filled by a search of the same
    body and clip with the same settings but ``cover_s``, a search over a longer span goes on from it:
    the same result as a search from the start, without walking the shorter one's windows again."""
    src = ctrl.source
    if not isinstance(ctrl, SimbiconController) or not isinstance(src, ClipSource) or not src.whole:
        raise ModelError("reconstruction drives the humanoid's controller tracking a whole clip (source: clip)")
    frame0 = float(ctrl.start_frame())
    end_frame, looped = search_end(src, cfg.loop_cycles, cfg.loop_max_s, frame0, cfg.cover_s)
    total_s = (end_frame - frame0) * src.frame_time
    if total_s <= 0:
        return None, None
    played = (src.qpos_played, src.playlist.qvel)
    data = mujoco.MjData(model)
    data.qpos[:] = played[0][int(frame0)]
    data.qvel[:] = played[1][int(frame0)]
    mujoco.mj_forward(model, data)
    nh = ctrl.tables.kp.shape[0]
    ctrl.correction = LiveCorrection(nh)
    ctrl.reset(data, frame0)
    dt = model.opt.timestep
    every = control_every(ctrl.control_dt, dt)
    per_window = max(every, int(round(cfg.window_s / dt / every)) * every)
    n_windows = int(math.ceil(total_s / (per_window * dt)))
    sigma = np.concatenate([np.full(nh, cfg.hinge_sigma), np.full(2, cfg.feedback_sigma),
                            np.full(EXTRA - 2, cfg.torso_sigma)])
    rng = np.random.default_rng(cfg.seed)
    search = _Search(model, played, frame0, src.frame_time, cfg,
                     FallDetector(model, ctrl.plan, fall, data, root=ctrl.root_body), _shared(ctrl), every,
                     max(1, int(round(fall.check_every / dt))), per_window, ctrl.hinges.qadr, ctrl.terrain)
    history = [[_Node(data, ctrl, [], [], 0.0)]]  # the states kept at the start of each window
    # the windows covering the clip alone: the search's best there, the first time it gets there
    clip_s = search_span(ctrl, 0)
    clip_windows = int(math.ceil(clip_s / (per_window * dt) - 1e-9)) if total_s > clip_s else n_windows
    at_clip: _Node | None = None
    # SAMCON's backtracking: where every sample of a window falls, the search backs up one window more
    # for each failure in a row at that frontier, and searches from there with more samples until it
    # is past it (a fall is often sealed a window or more before it happens)
    retries, boost, frontier, streak = 0, 1, 0, 0
    # what a search to go on from shares: the body, the clip's start, the windows, every setting but the span
    same = (id(model), id(src.clip), frame0, per_window, fall, replace(cfg, cover_s=0.0, workers=0),
            replace(ctrl.cfg, reconstruct=replace(ctrl.cfg.reconstruct, cover_s=0.0, workers=0)))
    if state and state.get("same") == same and len(state["history"]) <= n_windows + 1:  # type: ignore[arg-type]
        # its nodes' controllers share the first search's constants (the deep copies' memo)
        search, history, rng, at_clip = state["search"], state["history"], state["rng"], state["at_clip"]  # type: ignore[assignment]
        retries, boost, frontier, streak = state["counts"]  # type: ignore[misc]
    while len(history) <= n_windows:
        step = (len(history) - 1) * per_window
        parents = history[-1]
        n = cfg.samples * boost
        rows = [cfg.coherence * (parents[j % len(parents)].rows[-1] if parents[j % len(parents)].rows
                                 else 0.0) + rng.normal(0.0, sigma) for j in range(n)]
        found = _window(search, parents, rows, step, workers)
        if found:
            history.append(found)
            if at_clip is None and len(history) == clip_windows + 1:
                at_clip = found[0]
            if len(history) - 1 > frontier:  # past the window that failed
                boost, streak = 1, 0
            if progress is not None:
                progress(min((step + per_window) * dt, total_s), total_s)
            continue
        if retries >= cfg.retries:
            break
        retries += 1
        window = len(history) - 1
        if window > frontier:  # a new frontier
            frontier, streak = window, 0
        streak += 1
        boost = min(2 ** streak, MAX_BOOST)
        del history[max(1, frontier - streak + 1):]
    if state is not None and len(history) > n_windows:
        state.update(same=same, search=search, history=list(history), rng=rng, at_clip=at_clip,
                     counts=(retries, boost, frontier, streak))
    best = history[-1][0]
    if not best.rows:
        return None, None
    end = float(best.ctrl.frame)
    fade = cfg.fade_s / src.frame_time
    # the whole span walked, its last loop period included: that period's rows repeat after it
    period = src.period if looped and len(history) > n_windows and end - src.period >= max(src.a, best.starts[0]) \
        else 0.0
    full = Correction(starts=tuple(best.starts), rows=np.array(best.rows), end=end, fade=fade, period=period)
    clip = None
    if at_clip is not None and at_clip is not best:
        clip = Correction(starts=tuple(at_clip.starts), rows=np.array(at_clip.rows), end=float(at_clip.ctrl.frame),
                          fade=fade)
    return full, clip


#: the search a forked worker reads (set by the parent before it forks, read-only in the workers)
_FORK: tuple[_Search, list[_Node], list[FloatArray], int] | None = None


def _window(search: _Search, parents: list[_Node], rows: list[FloatArray], step: int, workers: int) -> list[_Node]:
    """The ``cfg.keep`` best samples of the window from physics step ``step`` that stay up (sample j
    from ``parents[j % len(parents)]`` with offsets ``rows[j]``), best first. The costs are computed in
    ``workers`` forked processes where there are several; the kept samples are then walked again here
    (the same path: the physics and the controller are deterministic) for their states."""
    global _FORK
    n = len(rows)
    # a pool's own worker (a sweep's) may not start processes: it samples here
    daemon = multiprocessing.current_process().daemon
    if workers > 1 and n > 1 and not daemon and "fork" in multiprocessing.get_all_start_methods():
        _FORK = (search, parents, rows, step)
        try:
            chunks = [list(range(k, n, workers)) for k in range(workers)]
            pool = multiprocessing.get_context("fork").Pool(workers, initializer=_worker_signals)
            try:
                costs = [c for part in pool.map(_costs_of, chunks) for c in part]
                pool.close()  # the workers end when their work is done
            except BaseException:
                pool.terminate()  # interrupted: the workers are stopped (they take the default action)
                raise
            finally:
                pool.join()
        finally:
            _FORK = None
    else:  # here: the walked samples are kept as they are
        nodes = [(node, j) for j in range(n) for node in [_sample(search, parents, rows, step, j)[0]] if node]
        nodes.sort(key=lambda nj: (nj[0].cost, nj[1]))
        return [node for node, _ in nodes[:search.cfg.keep]]
    order = sorted((c, j) for c, j in costs if c is not None)[:search.cfg.keep]
    kept = []
    for _c, j in order:
        node, _ = _sample(search, parents, rows, step, j)
        assert node is not None
        kept.append(node)
    return kept


def _worker_signals() -> None:
    """A worker takes the default action on the stop signals (the parent, not the worker, turns them
    into a clean stop) and leaves Ctrl-C to the parent, which stops the workers."""
    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _costs_of(indices: list[int]) -> list[tuple[float | None, int]]:
    """A worker's share of a window: (cost or None for a fall, sample index) per sample."""
    assert _FORK is not None
    search, parents, rows, step = _FORK
    return [(_sample(search, parents, rows, step, j)[1], j) for j in indices]


def _sample(search: _Search, parents: list[_Node], rows: list[FloatArray], step: int,
            j: int) -> tuple[_Node | None, float | None]:
    """Sample ``j`` of a window walked: its node and cost, or (None, None) if it fell."""
    model = search.model
    parent = parents[j % len(parents)]
    d = mujoco.MjData(model)
    mujoco.mj_copyData(d, model, parent.data)
    c = copy.deepcopy(parent.ctrl, dict(search.shared))
    live = c.correction
    assert isinstance(live, LiveCorrection)
    live.set(rows[j])
    if not walk_window(model, d, c, step, search.per_window, search.every, search.check_every, search.falls):
        return None, None
    t_end = (step + search.per_window) * model.opt.timestep
    ground_z = 0.0 if search.terrain is None else search.terrain.height(float(d.qpos[0]), float(d.qpos[1]))
    cost = tracking_cost(d, *search.frames, search.frame0 + t_end / search.frame_time, search.hinge_qadr,
                         search.cfg, ground_z)
    return _Node(d, c, parent.starts + [float(live.started)], parent.rows + [rows[j]], cost), cost


#: where searched corrections are kept, under the user's cache folder (``XDG_CACHE_HOME`` or ~/.cache)
CACHE_SUBDIR = ("bipedsim", "corrections")
#: the modules whose code shapes a search's result: a change to any of them makes a new cache key
_CODE = ("control/humanoid", "sim/reconstruct.py", "sim/rollout.py", "model/ground.py")


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
    settings = to_dict(cfg)
    settings["reconstruct"].pop("workers", None)  # the result is the same on any number of processes
    h.update(json.dumps(settings, sort_keys=True, default=str).encode())
    h.update(json.dumps(versions(), sort_keys=True).encode())
    root = Path(__file__).resolve().parent.parent
    for part in _CODE:
        p = root / part
        for src in sorted(p.glob("*.py")) if p.is_dir() else [p]:
            h.update(src.read_bytes())
    return h.hexdigest()[:24]


#: what a judge of a search's corrections says: whether to keep one, why (a clause for the run's
#: printout), and the one to keep (of those searched, or a variant of one the judge found better)
Verdict = tuple[bool, str, Correction]


def correction_for(model: mujoco.MjModel, model_hash: str, make_ctrl: Callable[[], SimbiconController],
                   clip: ReferenceClip, cfg: ControllerConfig, fall: FallCriteria,
                   judge: Callable[[list[Correction], bool], Verdict] | None = None,
                   state: dict[str, object] | None = None,
                   cover_why: str = "the controller alone does not walk the loop") -> tuple[Correction | None, str]:
    """The correction for ``clip`` on this body with these settings, and a line saying where it came
    from: read from the cache when this search was run before, else searched (a progress bar on a
    terminal), judged and cached. ``judge`` says whether a searched correction is kept (a run with it
    against one without, :func:`bipedsim.sim.judging.judge_correction`; told too whether the search
    reached the end of its span) and which: the search's, or its best
    at the clip's end (:func:`search_corrections`), or a variant; one it rejects is cached as
    rejected, so the run goes on without one and the next run does not search again. ``state``: as for
    :func:`search_corrections` (a search over a longer span goes on from a shorter one's). ``cover_why``:
    why the search covers the loop to ``cover_s`` where it does (for its printout)."""
    key = correction_key(clip, model_hash, cfg)
    path = cache_folder() / f"{key}.json"
    ctrl = make_ctrl()
    nh = ctrl.tables.kp.shape[0]
    stale = ""
    if path.is_file():
        try:
            d = json.loads(read_input_text(path, "json"))
            corr = Correction.from_dict(d["correction"], nh) if d["correction"] is not None else None
            if not d["kept"]:
                return None, f"reconstruct: the correction searched before was not kept ({d['why']}; {path})"
            return corr, f"reconstruct: the correction searched before, read from {path}"
        except (BipedsimError, ValueError, KeyError, TypeError) as exc:
            stale = f" (the cached one was unreadable: {exc})"
    total = search_span(ctrl, cfg.reconstruct.loop_cycles)
    bar = progress_bar(round(total, 1), "reconstruct", "s of clip")
    rc = cfg.reconstruct
    cycles = f"{rc.loop_cycles} cycle" + ("s" if rc.loop_cycles != 1 else "")
    src = ctrl.source
    assert isinstance(src, ClipSource)
    start = float(ctrl.start_frame())
    grown = total > (search_end(src, rc.loop_cycles, rc.loop_max_s)[0] - start) * src.frame_time + 1e-9
    over = ("the clip" if rc.loop_cycles <= 0
            else f"the clip and its loop to {rc.cover_s:g} s from the start: {cover_why}" if grown
            else f"the clip and up to {cycles} of its loop")
    if bar is None:  # no terminal for a bar: one line says why the run has not started yet
        print(f"reconstruct: searching a correction for {max(total, 0.0):.1f} s ({over}; the first run of a clip; "
              "cached after it; --no-reconstruct skips it)", file=sys.stderr, flush=True)
    done = [0.0]

    def tick(t: float, _total: float) -> None:
        if bar is not None:
            bar.update(round(t - done[0], 4))
        done[0] = t

    t0 = time.perf_counter()
    try:
        corr, at_clip = search_corrections(model, ctrl, cfg.reconstruct, fall, workers=search_workers(cfg.reconstruct),
                                           progress=tick, state=state)
    finally:
        ctrl.restore_model()
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    what = (f"reconstruct: searched a correction for {done[0]:.1f} s of {max(total, 0.0):.1f} s ({over}) in "
            f"{wall:.0f} s (windows of {rc.window_s:g} s, {rc.samples} samples each){stale}")
    if done[0] < total - 1e-6:
        what += f"; every sample fell after {done[0]:.1f} s, so the correction ends there"
    kept, why = (False, "no window could be walked") if corr is None else (True, "")
    if corr is not None and judge is not None:
        kept, why, corr = judge([corr] if at_clip is None else [corr, at_clip], done[0] >= total - 1e-6)
    what += f"; {why}" if why else ""
    (cache_folder() / f"{key}.source.json").unlink(missing_ok=True)  # chosen with the correction it replaces
    try:
        atomic_write_text(path, json.dumps({"key": key, "clip": clip.source, "seconds": done[0], "kept": kept,
                                            "why": why, "correction": corr.to_dict() if corr is not None else None}))
        what += f"; cached in {path}"
    except OSError as exc:
        what += f"; not cached ({exc.strerror or exc})"
    return (corr if kept else None), what


def has_correction(key: str) -> bool:
    """Whether the search of cache key ``key`` (:func:`correction_key`) was run and cached before."""
    return (cache_folder() / f"{key}.json").is_file()


def cached_choice(key: str, rule: str = "") -> tuple[str, str | None] | None:
    """The reference source chosen before for the scenario of cache ``key`` (:func:`correction_key`) by
    the choosing code ``rule`` (a digest of it): ``("clip" | "cycle", the line that said why)``, or None
    when none was recorded by that code (or the record is unreadable: the choice is then made again)."""
    path = cache_folder() / f"{key}.source.json"
    if not path.is_file():
        return None
    try:
        d = json.loads(read_input_text(path, "json"))
        source, line, made_by = d["source"], d["line"], d.get("rule", "")
    except (BipedsimError, ValueError, KeyError, TypeError, AttributeError):
        return None
    if source not in ("clip", "cycle") or not (line is None or isinstance(line, str)) or made_by != rule:
        return None
    return source, line


def remember_choice(key: str, source: str, line: str | None, rule: str = "") -> None:
    """Record which reference source the scenario of cache ``key`` runs, and the choosing code's digest
    ``rule`` (the judging runs that chose it are not repeated by the next run of the same clip, settings
    and code); a cache that cannot be written is left alone (the choice is made again next time)."""
    with contextlib.suppress(OSError):
        atomic_write_text(cache_folder() / f"{key}.source.json", json.dumps({"key": key, "source": source,
                                                                            "line": line, "rule": rule}))


def remember_more(key: str, more: bool) -> None:
    """Record (or clear) that the search of cache ``key`` is to be taken further
    (:func:`bipedsim.sim.judging.searched_correction`), so that a run stopped during the longer search
    makes it again rather than settling for the shorter one; a cache that cannot be written is left alone."""
    path = cache_folder() / f"{key}.more.json"
    with contextlib.suppress(OSError):
        if more:
            atomic_write_text(path, json.dumps({"key": key, "more": True}))
        else:
            path.unlink(missing_ok=True)


def wants_more(key: str) -> bool:
    """Whether the search of cache ``key`` was found to need taking further (:func:`remember_more`)."""
    return (cache_folder() / f"{key}.more.json").is_file()


def search_workers(rc: ReconstructConfig) -> int:
    """The processes a search samples with: ``rc.workers``, or with 0 the cores this process may use."""
    if rc.workers > 0:
        return rc.workers
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on every platform
        return max(1, os.cpu_count() or 1)
