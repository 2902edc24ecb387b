"""Sampling-based control reconstruction: the search, its correction and its cache."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bipedsim.control.humanoid.correction import EXTRA, Correction
from bipedsim.errors import ConfigError
from bipedsim.sim.reconstruct import correction_for, reconstruct, search_corrections, search_span
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, reconstruct_wanted, run_scenario

#: a small search: enough to exercise every part, a second or two on one core
SMALL = {"samples": 3, "keep": 2, "window_s": 0.8, "loop_cycles": 0}


@pytest.fixture(scope="module")
def small():
    sc = load_scenario(None, reconstruct=False)
    return replace(sc, cfg=replace(sc.cfg, reconstruct=replace(sc.cfg.reconstruct, **SMALL)))


def _search(sc, workers: int = 1) -> Correction:
    ctrl = sc.controller()
    try:
        corr = reconstruct(sc.built.model, ctrl, sc.cfg.reconstruct, sc.fall_criteria(), workers=workers)
    finally:
        ctrl.restore_model()
    assert corr is not None
    return corr


@pytest.mark.slow
def test_the_search_is_deterministic_on_any_number_of_processes(small) -> None:
    short = _search(small)  # no loop searched: the search ends with the clip and its correction fades out
    # one period of the loop searched (no cover of the loop to cover_s)
    small = replace(small, cfg=replace(small.cfg, reconstruct=replace(small.cfg.reconstruct, loop_cycles=1,
                                                                      cover_s=0.0)))
    ctrl = small.controller()
    try:
        a, at_clip = search_corrections(small.built.model, ctrl, small.cfg.reconstruct, small.fall_criteria())
    finally:
        ctrl.restore_model()
    b = _search(small, 2)
    # with a loop searched, the search's best when its windows first covered the clip is given too: window
    # for window what a search of the clip alone finds
    assert at_clip is not None and at_clip.period == 0.0
    assert at_clip.starts == short.starts and np.array_equal(at_clip.rows, short.rows) and at_clip.end == short.end
    assert a.starts == b.starts and np.array_equal(a.rows, b.rows) and a.end == b.end
    assert a.rows.shape[1] == small.controller().tables.kp.shape[0] + EXTRA
    # the search covers the clip from the controller's start and a period of its loop, window by window
    ctrl = small.controller()
    src = ctrl.source
    span = search_span(ctrl)
    assert span == pytest.approx((src.a + src.period - ctrl.start_frame()) * src.frame_time)
    assert len(a.starts) == int(np.ceil(span / 0.8 - 1e-9))
    assert a.end >= src.a + src.period - 1e-9
    assert a.period == src.period  # walked to its end: the last period's rows repeat
    f = a.end + 0.3 * src.period
    assert np.array_equal(a.at(f), a.at(f - src.period)) and np.array_equal(a.at(f + 5 * src.period), a.at(f))
    assert short.period == 0.0 and short.end < a.end and short.at(short.end + short.fade) is None


def test_a_run_with_the_correction_repeats_the_searched_path(small) -> None:
    corr = _search(small)
    sc = replace(small, correction=corr)
    span = search_span(sc.controller())
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=round(np.ceil(span / 0.8) * 0.8, 6)))
    assert out.outcome == "no_fall"
    assert ctrl.frame == pytest.approx(corr.end, abs=1e-9)  # the same reference frame, step for step
    plain, pctrl = run_scenario(small, RolloutSpec(seconds=out.sim_seconds))
    assert pctrl.frame != pytest.approx(corr.end, abs=1e-6)  # the correction changed the run


def test_the_correction_is_cached_and_read_back(small, tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    m, sc = small.built, small
    first, said = correction_for(m.model, m.hash, sc.controller, sc.clip, sc.cfg, sc.fall_criteria())
    assert "searched a correction" in said and "cached in" in said
    files = list((tmp_path / "bipedsim" / "corrections").glob("*.json"))
    assert len(files) == 1
    again, said = correction_for(m.model, m.hash, sc.controller, sc.clip, sc.cfg, sc.fall_criteria())
    assert said.startswith("reconstruct: the correction searched before")
    assert again.starts == first.starts and np.array_equal(again.rows, first.rows)
    # another setting is another search; a damaged cache file is searched again, not trusted
    files[0].write_text('{"correction": {"starts": [0], "rows": [[1e9]], "end": 1, "fade": 0}}')
    _, said = correction_for(m.model, m.hash, sc.controller, sc.clip, sc.cfg, sc.fall_criteria())
    assert "the cached one was unreadable" in said


def test_correction_lookup_and_fade() -> None:
    rows = np.array([[0.1] * (1 + EXTRA), [0.2] * (1 + EXTRA)])
    c = Correction(starts=(10.0, 20.0), rows=rows, end=30.0, fade=10.0)
    assert c.at(5.0) is None
    assert c.at(10.0)[0] == 0.1 and c.at(19.9)[0] == 0.1 and c.at(25.0)[0] == 0.2
    assert c.at(35.0)[0] == pytest.approx(0.1)  # half faded
    assert c.at(40.0) is None
    back = Correction.from_dict(c.to_dict(), hinges=1)
    assert back.starts == c.starts and np.array_equal(back.rows, c.rows)
    with pytest.raises(ValueError, match="rows of shape"):
        Correction.from_dict(c.to_dict(), hinges=2)
    # a repeated period: frames past the end read the last period's rows, phase for phase
    p = Correction(starts=(10.0, 20.0), rows=rows, end=30.0, period=15.0)
    assert p.at(31.0)[0] == 0.1 and p.at(36.0)[0] == 0.2 and p.at(46.0)[0] == 0.1 and p.at(1e4 + 0.5) is not None
    assert Correction.from_dict(p.to_dict(), hinges=1).period == 15.0
    with pytest.raises(ValueError, match="period"):
        Correction.from_dict(dict(p.to_dict(), period=25.0), hinges=1)
    bad = dict(c.to_dict(), rows=[[9.0] * 5, [0.0] * 5])
    with pytest.raises(ValueError, match="within"):
        Correction.from_dict(bad, hinges=1)


def test_the_search_is_asked_for_by_argument_then_environment_then_settings(monkeypatch) -> None:
    cfg = load_scenario(None, reconstruct=False).cfg
    monkeypatch.delenv("BIPEDSIM_RECONSTRUCT", raising=False)
    assert reconstruct_wanted(cfg, None) is True
    assert reconstruct_wanted(replace(cfg, reconstruct=replace(cfg.reconstruct, enabled=False)), None) is False
    monkeypatch.setenv("BIPEDSIM_RECONSTRUCT", "off")
    assert reconstruct_wanted(cfg, None) is False and reconstruct_wanted(cfg, True) is True
    monkeypatch.setenv("BIPEDSIM_RECONSTRUCT", "maybe")
    with pytest.raises(ConfigError, match="BIPEDSIM_RECONSTRUCT"):
        reconstruct_wanted(cfg, None)


def test_a_second_run_of_a_clip_makes_no_judging_runs(tmp_path, monkeypatch) -> None:
    """The first load of a clip searches, judges the correction and chooses whole clip or looped cycle;
    the second reads all three from the cache and runs nothing before the user's run."""
    from bvh_fixtures import standin

    import bipedsim.sim.judging as judging

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    cfg = load_scenario(None, reconstruct=False).cfg
    cfg = replace(cfg, reconstruct=replace(cfg.reconstruct, samples=2, keep=1, window_s=1.0, workers=1,
                                                              loop_cycles=0))
    runs: list[str] = []
    # the whole clip falls at once, its looped cycle stands: the run loops the cycle
    monkeypatch.setattr(judging, "_judged", lambda sc: runs.append(sc.cfg.source) or
                        ((1.0, 0.5) if sc.cfg.source == "clip" else (9.0, 0.5)))
    bvh = standin("human/games105_walk60__metres_crlf.bvh")
    first = load_scenario(cfg, bvh, reconstruct=True)
    assert runs and first.cfg.source == "cycle" and "loops the cycle" in first.extra["reconstruct"]
    runs.clear()
    again = load_scenario(cfg, bvh, reconstruct=True)
    assert runs == [] and again.cfg.source == "cycle" and again.correction is None
    assert "loops the cycle" in again.extra["reconstruct"]
    # a correction searched again (its cache file gone) makes the choice again
    for f in (tmp_path / "bipedsim" / "corrections").glob("*.json"):
        if not f.name.endswith(".source.json"):
            f.unlink()
    load_scenario(cfg, bvh, reconstruct=True)
    assert "clip" in runs and "cycle" in runs


def test_the_looped_cycle_is_run_where_it_walks_the_clip_better(small) -> None:
    """Whole clip or looped cycle: the one that stands longer, then the one whose root path keeps nearer
    the clip's; a tie keeps the whole clip."""
    from bipedsim.sim.judging import whole_or_looped

    def judge(results):
        return lambda sc: results[sc.cfg.source]

    sc = replace(small, cfg=replace(small.cfg, source="clip"))
    chosen, why = whole_or_looped(sc, judge({"clip": (20.0, 1.6), "cycle": (20.0, 0.3)}))
    assert chosen.cfg.source == "cycle" and "within 1.60 m" in why and "within 0.30 m" in why
    chosen, why = whole_or_looped(sc, judge({"clip": (20.0, 0.3), "cycle": (20.0, 1.6)}))
    assert chosen is sc and why is None
    chosen, why = whole_or_looped(sc, judge({"clip": (20.0, 0.3), "cycle": (20.0, 0.3)}))
    assert chosen is sc and why is None
    chosen, why = whole_or_looped(sc, judge({"clip": (5.0, 0.1), "cycle": (20.0, 2.0)}))
    assert chosen.cfg.source == "cycle" and "falls at 5.0 s" in why
    chosen, _ = whole_or_looped(sc, judge({"clip": (20.0, 2.0), "cycle": (5.0, 0.1)}))
    assert chosen is sc


def test_a_choice_cached_by_other_choosing_code_is_made_again(tmp_path, monkeypatch) -> None:
    from bipedsim.sim.reconstruct import cached_choice, remember_choice

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    remember_choice("k", "cycle", "why", "rule-a")
    assert cached_choice("k", "rule-a") == ("cycle", "why")
    assert cached_choice("k", "rule-b") is None
    assert cached_choice("other", "rule-a") is None


def test_the_tracking_cost_measures_height_above_the_ground_under_the_body(small) -> None:
    """On shaped ground the body's root height counts above the ground under it, as the clip's does above
    its flat floor: a body lifted with the ground costs what it costs on the flat."""
    import mujoco

    from bipedsim.sim.reconstruct import tracking_cost

    m = small.built.model
    q, v = small.clip.qpos, small.clip.qvel
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = q[5], v[5]
    cfg = small.cfg.reconstruct
    qadr = small.controller().hinges.qadr
    flat = tracking_cost(d, q, v, 5.0, qadr, cfg)
    d.qpos[2] += 0.3
    assert tracking_cost(d, q, v, 5.0, qadr, cfg, ground_z=0.3) == pytest.approx(flat, abs=1e-12)
    assert tracking_cost(d, q, v, 5.0, qadr, cfg) == pytest.approx(flat + cfg.height_weight * 0.3, abs=1e-9)


def test_the_judge_keeps_the_better_of_repeating_the_loop_and_fading_out(small) -> None:
    """A correction that repeats its last loop period is also judged fading out after it; the one that
    stands longer is kept (and compared with no correction at all)."""
    from bipedsim.sim.judging import judge_correction

    rows = np.zeros((2, small.controller().tables.kp.shape[0] + EXTRA))
    corr = Correction(starts=(10.0, 20.0), rows=rows, end=30.0, fade=10.0, period=15.0)

    def judged(stand: dict):
        return lambda sc: stand["none" if sc.correction is None else "repeat" if sc.correction.period else "fade"]

    keep, why, chosen = judge_correction(small, corr, judged({"repeat": (6.0, 0.2), "fade": (20.0, 0.3),
                                                               "none": (20.0, 0.9)}))
    assert keep and chosen.period == 0.0 and "repeats" not in why
    keep, why, chosen = judge_correction(small, corr, judged({"repeat": (20.0, 0.2), "fade": (8.0, 0.3),
                                                               "none": (3.0, 0.9)}))
    assert keep and chosen is corr and "repeats its last period" in why
    keep, _, _ = judge_correction(small, corr, judged({"repeat": (5.0, 0.2), "fade": (8.0, 0.3), "none": (9.0, 1.0)}))
    assert not keep
    # the search's best at the clip's end is one more candidate (it fades out after the clip)
    at_clip = Correction(starts=(10.0,), rows=rows[:1] + 0.01, end=12.0, fade=10.0)
    stand = {"repeat": (6.0, 0.2), "fade": (7.0, 0.3), "none": (20.0, 0.9)}
    by_end = lambda sc: (20.0, 0.4) if sc.correction is not None and sc.correction.end == 12.0 else judged(stand)(sc)  # noqa: E731
    keep, why, chosen = judge_correction(small, [corr, at_clip], by_end)
    assert keep and chosen is at_clip and "the clip's end" in why



def test_a_search_whose_run_falls_is_made_again_covering_the_loop(small, monkeypatch, tmp_path) -> None:
    """A search without the loop's cover whose run falls within the judging run is made again with the
    cover, judged with the first search's corrections; one whose run stands, one that stopped short, or
    one whose clip's looped cycle already walks the clip's path, is not. One read from the cache is made
    again only where the first run found it needed (and was stopped before the second search ended)."""
    import bipedsim.sim.judging as judging
    from bipedsim.sim.reconstruct import correction_key, remember_more

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))

    loops = replace(small, cfg=replace(small.cfg, reconstruct=replace(small.cfg.reconstruct, loop_cycles=2)))
    full = judging.judging_seconds(loops)
    short = replace(loops.cfg, reconstruct=replace(loops.cfg.reconstruct, cover_s=0.0))
    rows = np.zeros((1, small.controller().tables.kp.shape[0] + EXTRA))
    found = {0.0: Correction(starts=(10.0,), rows=rows, end=20.0, fade=10.0),
             20.0: Correction(starts=(10.0,), rows=rows + 0.01, end=90.0, fade=10.0)}
    searches: list[float] = []
    judged_with: list[int] = []

    def fake_search(stands: dict, cached: bool = False, reached: bool = True):
        def correction_for(model, h, ctrl, clip, cfg, fall, judge, state=None, cover_why=""):
            cover = cfg.reconstruct.cover_s
            searches.append(cover)
            if cached:
                return found[cover], "read"
            keep, _, corr = judge([found[cover]], reached)
            return (corr if keep else None), f"searched {cover:g}"
        return correction_for

    def judged(stands: dict, loop: tuple[float, float] = (20.0, 9.0)):
        def run(sc):
            judged_with.append(0)
            if sc.cfg.source == "cycle":
                return loop
            return stands[None if sc.correction is None else sc.correction.end], 0.1
        return run

    # the short search's run falls: searched again to cover_s; its correction, standing, is kept
    monkeypatch.setattr(judging, "correction_for", fake_search({}))
    corr, line, cfg = judging.searched_correction(loops, short, judged({None: 3.0, 20.0: 8.0, 90.0: full}))
    assert searches == [0.0, 20.0] and cfg == loops.cfg and corr is found[20.0]
    assert "falls at 8.0 s" in line and line.startswith("searched 0") and line.endswith("searched 20")
    # the first search's correction stands better than the second's: it is the one kept
    searches.clear()
    corr, _, _ = judging.searched_correction(loops, short, judged({None: 3.0, 20.0: 8.0, 90.0: 5.0}))
    assert searches == [0.0, 20.0] and corr is found[0.0]
    # the run stands: no second search
    searches.clear()
    corr, line, cfg = judging.searched_correction(loops, short, judged({None: 3.0, 20.0: full, 90.0: full}))
    assert searches == [0.0] and cfg == short and corr is found[0.0] and "falls" not in line
    # read from the cache: no judging run, no second search
    searches.clear()
    judged_with.clear()
    monkeypatch.setattr(judging, "correction_for", fake_search({}, cached=True))
    corr, _, cfg = judging.searched_correction(loops, short, judged({None: 3.0, 20.0: 3.0, 90.0: full}))
    assert searches == [0.0] and cfg == short and judged_with == []
    # read from the cache where the first run found a second search needed (and was stopped in it)
    searches.clear()
    remember_more(correction_key(loops.clip, loops.built.hash, short), True)
    corr, line, cfg = judging.searched_correction(loops, short, judged({None: 3.0, 20.0: 3.0, 90.0: full}))
    assert searches == [0.0, 20.0] and cfg == loops.cfg and "goes on over the loop" in line
    # the looped cycle stands within the path's tolerance: it is run, no longer search
    searches.clear()
    monkeypatch.setattr(judging, "correction_for", fake_search({}))
    judging.searched_correction(loops, short, judged({None: 3.0, 20.0: 8.0, 90.0: full}, loop=(full, 0.2)))
    assert searches == [0.0]
    # a first search that stopped short of its end (every sample fell): it would stop there again
    searches.clear()
    monkeypatch.setattr(judging, "correction_for", fake_search({}, reached=False))
    judging.searched_correction(loops, short, judged({None: 3.0, 20.0: 8.0, 90.0: full}))
    assert searches == [0.0]
    # where the cover adds nothing to the span searched (no loop searched), no second search either
    searches.clear()
    monkeypatch.setattr(judging, "correction_for", fake_search({}))
    short = replace(small.cfg, reconstruct=replace(small.cfg.reconstruct, cover_s=0.0))
    judging.searched_correction(small, short, judged({None: 3.0, 20.0: 8.0, 90.0: full}))
    assert searches == [0.0]


def test_a_longer_search_goes_on_from_a_shorter_one_with_the_same_result(small) -> None:
    """A search over a longer span (``cover_s``) given the state of a shorter one that reached its end
    finds what a search from the start finds, walking only the windows after the shorter one's."""
    from bipedsim.sim.reconstruct import search_corrections

    base = replace(small.cfg.reconstruct, loop_cycles=1, samples=1, keep=1, workers=1)
    short = replace(base, cover_s=0.0)
    span = search_span(replace(small, cfg=replace(small.cfg, reconstruct=short)).controller())
    long = replace(base, cover_s=span + 1.5)

    def search(cfg, state=None, ticks=None):
        c = small.controller()
        try:
            return search_corrections(small.built.model, c, cfg, small.fall_criteria(), state=state,
                                      progress=None if ticks is None else lambda t, _n: ticks.append(t))[0]
        finally:
            c.restore_model()

    fresh = search(long)
    state: dict = {}
    search(short, state)
    assert state, "a search that reached its end leaves its state"
    ticks: list[float] = []
    went_on = search(long, state, ticks)
    assert went_on.starts == fresh.starts and np.array_equal(went_on.rows, fresh.rows)
    assert went_on.end == fresh.end and ticks and ticks[0] > 1.0  # it started past the shorter span


def test_search_past_the_clip_is_bounded():
    """The loop searched after the clip: whole periods that fit in ``loop_max_s``, else that many seconds
    and no period to repeat."""
    from types import SimpleNamespace

    from bipedsim.sim.reconstruct import search_end

    def src(period: float) -> SimpleNamespace:  # 30 fps, the clip's last frame 299, the loop from frame 290
        return SimpleNamespace(clip=SimpleNamespace(num_frames=300), playlist=SimpleNamespace(loop={"r": [290.0]}),
                               a=290.0, period=period, frame_time=1 / 30)

    assert search_end(src(30.0), 2, None) == (350.0, True)
    assert search_end(src(30.0), 2, 5.0) == (350.0, True)  # two 1 s periods fit in 5 s
    assert search_end(src(100.0), 2, 5.0) == (390.0, True)  # one 3.3 s period fits, two do not
    assert search_end(src(240.0), 2, 5.0) == (449.0, False)  # an 8 s loop: 5 s past the clip, no repeat
    assert search_end(src(240.0), 0, 5.0) == (299.0, False)
    # cover_s: on over whole periods until at least 20 s (frame 600) from the run's start, past loop_cycles
    assert search_end(src(30.0), 2, 5.0, 0.0, 20.0) == (620.0, True)
    assert search_end(src(240.0), 2, 5.0, 0.0, 20.0) == (770.0, True)  # two 8 s periods to pass 20 s
    assert search_end(src(30.0), 2, 5.0, 200.0, 5.0) == (350.0, True)  # cover ends as soon: loop_cycles'


def test_a_window_that_keeps_failing_backs_the_search_up_further_each_time(small, monkeypatch) -> None:
    """SAMCON's backtracking: each failure in a row at one window backs the search up one window more,
    the windows up to it searched with 2, 4, then 8x the samples, and the count starts again past it."""
    from types import SimpleNamespace

    import bipedsim.sim.reconstruct as rec

    searched: list[tuple[int, int]] = []
    fails = {"left": 3}

    def fake_window(search, parents, rows, step, workers):
        w = step // search.per_window
        searched.append((w, len(rows)))
        if w == 3 and fails["left"]:
            fails["left"] -= 1
            return []  # every sample fell
        p = parents[0]
        return [rec._Node(None, SimpleNamespace(frame=float(w + 1)), p.starts + [float(w)], p.rows + [rows[0]], 0.0)]

    monkeypatch.setattr(rec, "_window", fake_window)
    cfg = replace(small.cfg.reconstruct, samples=3, window_s=0.3, retries=8)
    ctrl = small.controller()
    try:
        corr, _ = search_corrections(small.built.model, ctrl, cfg, small.fall_criteria())
    finally:
        ctrl.restore_model()
    assert searched[:15] == [(0, 3), (1, 3), (2, 3), (3, 3),  # fails: back up one window
                             (2, 6), (3, 6),  # fails again: back up two
                             (1, 12), (2, 12), (3, 12),  # and again: three
                             (0, 24), (1, 24), (2, 24), (3, 24),  # passes, with 8x the samples
                             (4, 3), (5, 3)]  # past it: the samples as set
    assert corr is not None and len(corr.starts) == len(searched) - 13 + 4


def test_the_loop_is_searched_to_cover_s_only_where_the_feedback_falls_on_it(small, tmp_path, monkeypatch) -> None:
    """``cover_s`` holds where the clip's best cycle looped by the feedback alone falls within a judging
    run; where it stands the whole run, the search stops ``loop_max_s`` after the clip (cover_s 0); a
    search cached before is used as it was, without a judging run."""
    from bipedsim.sim.judging import judging_seconds, search_settings
    from bipedsim.sim.reconstruct import correction_key

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    asked: list[str] = []

    def judge(stands: float):
        def judged(sc):
            asked.append(sc.cfg.source)
            return stands, 0.0
        return judged

    assert small.cfg.reconstruct.cover_s > 0
    full = judging_seconds(small)
    assert search_settings(small, judge(full)).reconstruct.cover_s == 0.0  # the loop walks: no cover
    assert search_settings(small, judge(full - 1.0)) == small.cfg  # it falls: the search covers the run
    # a run lasts whole physics steps: one a fraction of a step short of the judging run stood it through
    dt = small.built.model.opt.timestep
    assert search_settings(small, judge(full - 0.6 * dt)).reconstruct.cover_s == 0.0
    asked.pop()
    assert asked == ["cycle", "cycle"]
    short = search_settings(small, judge(full))
    folder = tmp_path / "bipedsim" / "corrections"
    folder.mkdir(parents=True)
    (folder / f"{correction_key(small.clip, small.built.hash, short)}.json").write_text("{}")
    assert search_settings(small, judge(0.0)) == short and len(asked) == 3  # read back, not judged again

