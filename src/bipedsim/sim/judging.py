"""What a humanoid's run of a captured clip tracks: its searched feed-forward correction
(:mod:`bipedsim.sim.reconstruct`), kept where a run with it does better than one without, and the whole
clip or its best cycle looped, whichever walks the clip better. Each is decided by judging runs: the
scenario run over the clip and :data:`JUDGE_BEYOND_S` beyond (at least :data:`JUDGE_MIN_S`), measured by
how long it stands and how near its root path keeps to the clip's."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from bipedsim.control.humanoid.correction import Correction
from bipedsim.control.settings import ControllerConfig
from bipedsim.errors import ModelError
from bipedsim.sim.fidelity import PATH_TOLERANCE_M, interp_rows, measure_fidelity
from bipedsim.sim.reconstruct import (
    cached_choice,
    correction_for,
    correction_key,
    has_correction,
    remember_choice,
    remember_more,
    search_span,
    wants_more,
)
from bipedsim.sim.recorder import Recorder
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.scenario import Scenario, run_scenario


def with_correction(sc: Scenario) -> Scenario:
    """``sc`` (a humanoid tracking its whole captured clip) with its correction (searched, or read from
    the cache, and kept only where it helps: :func:`searched_correction`) and tracking the whole clip or
    its looped cycle (:func:`whole_or_looped`; the choice cached with the search); ``extra["reconstruct"]``
    says what was done."""
    judged = judge_once()
    searched = search_settings(sc, judged)
    sc.correction, sc.extra["reconstruct"], searched = searched_correction(sc, searched, judged)
    key = correction_key(sc.clip, sc.built.hash, searched)
    rule = choice_rule()
    chosen = cached_choice(key, rule)
    if chosen is None:
        sc, fallback = whole_or_looped(sc, judged)
        remember_choice(key, sc.cfg.source, fallback, rule)
    else:
        fallback = chosen[1]
        sc = looped(sc) if chosen[0] == "cycle" else sc
    if fallback:
        sc.extra["reconstruct"] += "\n" + fallback
    return sc


#: seconds a correction is judged over beyond the clip's end (the fade into the loop, a few steps of it)
JUDGE_BEYOND_S = 5.0
#: the shortest judging run (s): what a run of a short clip is judged by (a walk holds 20 s)
JUDGE_MIN_S = 20.0
#: samples per second a judging run records (its root path, against the clip's)
JUDGE_HZ = 30.0


def judging_seconds(sc: Scenario) -> float:
    """How long a judging run of ``sc`` lasts (s): its clip and :data:`JUDGE_BEYOND_S` beyond, at least
    :data:`JUDGE_MIN_S`."""
    return max(JUDGE_MIN_S, sc.clip.duration + JUDGE_BEYOND_S)


def stands_through(sc: Scenario, stood_s: float) -> bool:
    """Whether a judging run of ``sc`` that stood ``stood_s`` s stood it through: a run lasts whole
    physics steps, up to one short of :func:`judging_seconds`."""
    return stood_s >= judging_seconds(sc) - float(sc.built.model.opt.timestep) - 1e-9


def _judged(sc: Scenario) -> tuple[float, float]:
    """One run of ``sc`` over its clip and :data:`JUDGE_BEYOND_S` beyond (at least :data:`JUDGE_MIN_S`): how
    long it stands (s) and the
    largest distance of its root path from the clip's (m, :func:`~bipedsim.sim.fidelity.measure_fidelity`)."""
    seconds = judging_seconds(sc)
    rec = Recorder(sc.built.model, record_hz=JUDGE_HZ, seconds=seconds)
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=seconds), hooks=[rec])
    tr = rec.trajectory()
    fid = measure_fidelity(sc.built.model, tr.time, tr.qpos, sc.clip.qpos, sc.clip.frame_time,
                           ctrl.start_frame(), run_seconds=out.sim_seconds)
    return out.sim_seconds, fid.path_max_m if fid is not None else math.inf


Judge = Callable[[Scenario], tuple[float, float]]


def judge_once() -> Judge:
    """:func:`_judged`, remembering each (source, correction)'s result: the checks of one scenario share
    their runs (the whole clip with its kept correction is run once, not once per check)."""
    seen: dict[tuple[str, object], tuple[float, float]] = {}

    def judged(sc: Scenario) -> tuple[float, float]:
        c = sc.correction  # by content: a variant made for one check is another correction
        key = (sc.cfg.source, None if c is None else (c.starts, c.rows.tobytes(), c.end, c.fade, c.period))
        if key not in seen:
            seen[key] = _judged(sc)
        return seen[key]

    return judged


def looped(sc: Scenario) -> Scenario:
    """``sc`` looping its clip's best cycle (``source: cycle``), without a correction (one is searched
    for the whole clip)."""
    return replace(sc, cfg=replace(sc.cfg, source="cycle"), correction=None)


def whole_or_looped(sc: Scenario, judged: Judge = _judged) -> tuple[Scenario, str | None]:
    """``sc`` tracking its whole clip (with its correction, if any), or the clip's best cycle looped
    (``source: cycle``) where that does better over a judging run (:func:`_judged`, :func:`_better`): it
    stands longer, or as long with its root path nearer the clip's. The scenario to run and a line saying
    which was chosen (None: the whole clip)."""
    whole = judged(sc)
    cycle = looped(sc)
    try:
        loop = judged(cycle)
    except ModelError:  # no cycle to loop
        return sc, None
    if not _better(loop, whole) or _better(whole, loop):
        return sc, None
    over = f"over max({JUDGE_MIN_S:g} s, the clip and {JUDGE_BEYOND_S:g} s beyond)"
    why = (f"the whole clip falls at {whole[0]:.1f} s where its best cycle looped stands {loop[0]:.1f} s ({over})"
           if loop[0] > whole[0] + 1e-9 else
           f"both stand {whole[0]:.1f} s ({over}), the whole clip's root path keeps within {whole[1]:.2f} m of the "
           f"clip's, its best cycle looped within {loop[1]:.2f} m")
    return cycle, (f"reference: {why}: the run loops the cycle (source: cycle); --no-reconstruct tracks the whole "
                   "clip anyway")


def choice_rule() -> str:
    """A digest of the code that chooses between the whole clip and its looped cycle (this module): a
    choice cached by other code is made again."""
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]


def _better(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether judging result ``a`` (stood s, path distance m) beats ``b``: it stands longer, or as long
    with its root path nearer the clip's."""
    return a[0] > b[0] + 1e-9 or (a[0] >= b[0] - 1e-9 and a[1] <= b[1])


def judge_correction(sc: Scenario, corrs: Correction | list[Correction], judged: Judge = _judged
                     ) -> tuple[bool, str, Correction]:
    """Whether ``sc`` tracks its clip better with the best of ``corrs`` than without, and the correction
    to keep: each way, one run over the clip and :data:`JUDGE_BEYOND_S` beyond; the one that stands
    longer wins, then the one whose root path stays nearer the clip's
    (:func:`~bipedsim.sim.fidelity.measure_fidelity`). A correction that repeats its last loop period is
    also run fading out after it instead (feedback alone walks the loop on). Also a clause saying how
    they compared."""
    cands = [corrs] if isinstance(corrs, Correction) else list(corrs)
    cands += [replace(c, period=0.0) for c in cands if c.period > 0.0]
    corr, with_ = cands[0], judged(replace(sc, correction=cands[0]))
    for c in cands[1:]:
        r = judged(replace(sc, correction=c))
        if _better(r, with_) and not _better(with_, r):
            corr, with_ = c, r
    (t_with, d_with), (t_without, d_without) = with_, judged(sc)
    keep = _better(with_, (t_without, d_without))
    told = (f"with it the root path keeps within {d_with:.2f} m of the clip's, without {d_without:.2f} m"
            if abs(t_with - t_without) < 1e-9 else f"with it the body stands {t_with:.1f} s, without {t_without:.1f} s")
    clip_end = sc.clip.num_frames - 1
    after = ("; after the searched loop it repeats its last period" if corr.period > 0.0
             else "; the search's best at the clip's end, fading out after it" if corr.end <= clip_end + 1e-9
             else "; it fades out after the searched loop")
    return keep, ("kept: " if keep else "not kept: ") + told + (after if keep else ""), corr


def search_settings(sc: Scenario, judged: Judge) -> ControllerConfig:
    """The settings ``sc``'s search runs with first: its own, or ``reconstruct.cover_s`` 0 where the clip's
    best cycle looped by the feedback alone (:func:`looped`) stands a whole judging run (:func:`_judged`): a
    loop the controller walks needs no open-loop correction past ``loop_max_s``, which would only make the
    run more sensitive to a disturbance (:func:`searched_correction` covers it after all where the run
    falls). A search cached with either is used without a judging run."""
    cfg = sc.cfg
    if cfg.reconstruct.cover_s <= 0.0:
        return cfg
    short = replace(cfg, reconstruct=replace(cfg.reconstruct, cover_s=0.0))
    for settings in (cfg, short):  # the search run before, whichever it was
        if has_correction(correction_key(sc.clip, sc.built.hash, settings)):
            return settings
    try:
        t_loop, _ = judged(looped(sc))
    except ModelError:  # no cycle to loop: nothing past the clip to search
        return cfg
    return short if stands_through(sc, t_loop) else cfg


def searched_correction(sc: Scenario, searched: ControllerConfig, judged: Judge
                        ) -> tuple[Correction | None, str, ControllerConfig]:
    """``sc``'s correction searched with ``searched`` (:func:`search_settings`), or read from the cache,
    and judged (:func:`judge_correction`); the line saying where it came from; the settings it was found
    with. A search just made without its loop covered to ``reconstruct.cover_s`` that reached its end,
    but whose run (with what was kept, or without) falls within a judging run, is made again covering
    it, judged with the first search's corrections: the run needs the correction past where the loop's
    feedback alone took over. Not where the cover adds nothing to the span, nor where the clip's looped
    cycle already stands the judging run within the path's tolerance (:func:`path_tolerance`): that is
    run instead, and a longer search would only cost time. The decision is cached with the first search,
    so a run stopped during the second makes it again."""
    model, hash_, fall = sc.built.model, sc.built.hash, sc.fall_criteria()
    tried: list[Correction] = []
    stood: list[tuple[float, bool]] = []  # how long the run stood, and whether the search reached its end

    def judge(cands: list[Correction], reached: bool) -> tuple[bool, str, Correction]:
        keep, why, corr = judge_correction(sc, cands + tried, judged)
        tried.extend(cands)
        stood.append((judged(replace(sc, correction=corr if keep else None))[0], reached))  # no new run: judged
        return keep, why, corr

    state: dict[str, object] = {}  # the first search's, for the second to go on from
    corr, line = correction_for(model, hash_, replace(sc, cfg=searched).controller, sc.clip, searched, fall, judge,
                                state)
    if searched == sc.cfg:
        return corr, line, searched
    key = correction_key(sc.clip, sc.built.hash, searched)
    if not stood:  # read from the cache: taken further where that was found needed (a run stopped in it)
        if not wants_more(key):
            return corr, line, searched
        tried.extend([corr] if corr is not None else [])
        why = "the run with the shorter search's correction fell within its judging run"
    else:
        fell, reached = stood[-1]
        more = (not stands_through(sc, fell) and reached  # a search that stopped short would stop there again
                and search_span(sc.controller()) > search_span(replace(sc, cfg=searched).controller()) + 1e-9
                and not _loop_walks_the_path(sc, judged))
        remember_more(key, more)
        if not more:
            return corr, line, searched
        why = f"the run falls at {fell:.1f} s of its {judging_seconds(sc):.1f} s judging run"
    again = (f"reconstruct: {why}: the search goes on over the loop to {sc.cfg.reconstruct.cover_s:g} s from the "
             "start")
    corr, more_line = correction_for(model, hash_, sc.controller, sc.clip, sc.cfg, fall, judge, state,
                                     cover_why=why)
    return corr, "\n".join((line, again, more_line)), sc.cfg


def _loop_walks_the_path(sc: Scenario, judged: Judge) -> bool:
    """Whether the clip's looped cycle stands a judging run within the path's tolerance
    (:func:`path_tolerance`): it is then run (:func:`whole_or_looped`), and a longer search only costs time."""
    try:
        loop = judged(looped(sc))  # judged already by search_settings where it searched: no new run
    except ModelError:  # no cycle to loop
        return False
    return stands_through(sc, loop[0]) and loop[1] <= path_tolerance(sc)


def path_tolerance(sc: Scenario) -> float:
    """How far (m) a run's root path may stray from ``sc``'s clip by the fidelity goal
    (:attr:`~bipedsim.sim.fidelity.Fidelity.path_tolerance_m`: max(0.5 m, 10 % of the clip's path from
    the run's start frame), measured on the clip's own root path at the judging runs' 30 Hz."""
    clip, start = sc.clip, float(sc.controller().start_frame())
    span = (clip.num_frames - 1 - start) * clip.frame_time
    t = np.arange(0.0, max(span, 0.0) + 1e-9, 1.0 / JUDGE_HZ)
    fid = measure_fidelity(sc.built.model, t, interp_rows(clip.qpos, start + t / clip.frame_time), clip.qpos,
                           clip.frame_time, start)
    return fid.path_tolerance_m if fid is not None else PATH_TOLERANCE_M
