"""The whole clip as the humanoid's reference: its frames as captured, then its best cycle looped."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from bipedsim.control.humanoid.course import Course, CourseTracker, whole_course
from bipedsim.control.humanoid.cycles import Cycle
from bipedsim.control.humanoid.playlist import LOOP_TURN_MATCH_DEG, root_heading, whole_playlist
from bipedsim.control.humanoid.sources import ClipSource
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


@pytest.fixture(scope="module")
def builtin():
    return load_scenario(None, reconstruct=False)


def test_whole_clip_plays_the_clip_then_a_copy_of_its_cycle_from_its_last_strike(builtin) -> None:
    ctrl = builtin.controller()
    src = ctrl.source
    assert isinstance(src, ClipSource) and src.whole
    clip, pl, cyc = builtin.clip, src.playlist, src.cycle
    cut = pl.a
    # frames before the cut are the clip's own
    assert np.array_equal(pl.qpos[:cut, :7], clip.qpos[:cut, :7])
    # the cut is the clip's last strike of the cycle's foot, and the loop one cycle long after it
    assert cut == max(clip.events[cyc.foot]["strike"])
    assert pl.b - pl.a == cyc.b - cyc.a
    # the copy starts where the clip's root is at the cut, turned as the clip is there
    assert np.allclose(pl.qpos[cut, :2], clip.qpos[cut, :2])
    assert root_heading(pl.qpos[cut:cut + 1])[0] == pytest.approx(root_heading(clip.qpos[cut:cut + 1])[0], abs=1e-9)
    # every strike before the cut is played once; the loop's are the cycle's moved to the cut
    for side in ("left", "right"):
        assert list(src.once[side]) == [s for s in clip.events[side]["strike"] if s < cut]
        assert list(src.strikes[side]) == [s - cyc.a + cut for s in clip.events[side]["strike"] if cyc.a <= s < cyc.b]


def test_the_looped_cycle_source_is_unchanged_by_the_whole_clip(builtin) -> None:
    whole = builtin.controller().source
    cyc = replace(builtin, cfg=replace(builtin.cfg, source="cycle")).controller().source
    assert not cyc.whole and cyc.start_frame() > cyc.a
    assert np.array_equal(cyc.qpos_played, builtin.clip.qpos)
    # a looped cycle's speed is the loop's everywhere; the whole clip's follows the clip before its loop
    assert cyc.speed_at(0.0) == cyc.speed() and whole.speed_at(whole.b + 10.0) == whole.speed()
    assert len(set(whole._speeds)) > 1


def test_whole_clip_starts_at_its_first_strike_and_walks(builtin) -> None:
    out, ctrl = run_scenario(builtin, RolloutSpec(seconds=6.0))
    first = min(min(builtin.clip.events[s]["strike"]) for s in ("left", "right"))
    assert first < ctrl.start_frame() < first + 10
    assert out.outcome == "no_fall"
    assert out.mean_speed_mps > 0.5 * builtin.controller().source.speed()


def _line_then_turn() -> Course:
    """A course played once along x for 2 m, then a 1 m loop that turns 90 degrees left each pass."""
    once = [(0.1 * i, 0.0) for i in range(20)]
    loop = [(2.0 + 0.1 * i, 0.0) for i in range(11)]
    # the loop carries its first point (2, 0) onto its last (3, 0) turned by +90 degrees: p -> R p + t
    t = (3.0 - 0.0, 0.0 - 2.0)
    return Course(xy=tuple(once + loop), heading=tuple([0.0] * 31), cycle=(np.pi / 2, *t), loop_from=20)


def test_a_course_played_once_then_looped_is_followed_into_its_loops() -> None:
    tr = CourseTracker(_line_then_turn())
    tr.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0)
    # along the part played once, then the loop's first pass: progress is the distance walked
    for x in np.arange(0.05, 2.95, 0.05):
        off, _, h = tr.update(float(x), 0.1, 1.0, 0.0)
        assert off == pytest.approx(0.1) and h == pytest.approx(0.0)
    assert tr.locate(2.5, 0.0)[0] == pytest.approx(2.5)
    # past the first pass the next one turns left: its points are the loop's moved by the cycle
    x, y = 3.001, 0.5
    off, _, h = tr.update(x, y, 0.0, 1.0)
    assert h == pytest.approx(np.pi / 2) and tr.loops == 1
    assert tr.locate(x, y)[0] == pytest.approx(3.5)
    # before the course's start there is nothing to go back to (the part played once is not a loop)
    tr.reset((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0)
    tr.update(-0.5, 0.0, -1.0, 0.0)
    assert tr.seg == 0 and tr.loops == 0


def test_whole_course_keeps_the_clip_turn_and_averages_out_the_sway() -> None:
    n, a, b = 400, 300, 360
    t = np.arange(n) / 60.0
    sway = 0.03 * np.sin(2 * np.pi * t / (b - a) * 60.0)  # one sway period per loop
    com = np.column_stack([t, sway])
    heading = np.zeros(n)
    co = whole_course(com, heading, com, a, b)
    xy = np.asarray(co.xy)
    assert len(xy) == b + 1 and co.loop_from == a and co.first_frame == 0
    inner = xy[(b - a) // 2:a]
    assert np.max(np.abs(inner[:, 1])) < 0.003  # the sway, 3 cm, is gone away from the ends
    assert np.allclose(inner[:, 0], t[(b - a) // 2:a], atol=1e-9)


def _veer_then_straight(frames: int = 91, loop_turn: float = np.radians(43.0)):
    """A clip at 30 fps: 30 frames veering ``loop_turn`` left (its only loop, frames 0-30, right strikes
    at 0 and 30, a left at 15), then 60 frames straight on; root at 1.5 m/s along its heading."""
    dt = 1 / 30
    yaw = np.concatenate([loop_turn * np.arange(31) / 30, np.full(frames - 31, loop_turn)])
    qpos = np.zeros((frames, 9))  # a free joint and two hinges
    qpos[0, :2] = 0.0
    for k in range(1, frames):
        qpos[k, :2] = qpos[k - 1, :2] + 1.5 * dt * np.array([np.cos(yaw[k]), np.sin(yaw[k])])
    qpos[:, 2] = 0.9
    qpos[:, 3], qpos[:, 6] = np.cos(yaw / 2), np.sin(yaw / 2)
    qpos[:, 7] = 0.3 * np.sin(2 * np.pi * np.arange(frames) / 30)
    qvel = np.zeros((frames, 8))
    qvel[:, 0], qvel[:, 1], qvel[:, 5] = 1.5 * np.cos(yaw), 1.5 * np.sin(yaw), np.gradient(yaw, dt)
    contacts = np.ones((frames, 2), dtype=bool)
    events = {"right": {"strike": [0, 30, 60, 90]}, "left": {"strike": [15, 45, 75]}}
    clip = SimpleNamespace(num_frames=frames, qpos=qpos, qvel=qvel, frame_time=dt, foot_names=["left", "right"],
                           contacts=contacts, events=events)
    return clip, Cycle(a=0, b=30, cost=0.0)


def test_a_loop_found_inside_a_veer_is_played_turning_as_the_clip_ends() -> None:
    clip, cyc = _veer_then_straight()
    hq = clip.qpos[:, 7:9]
    hqd = np.gradient(hq, clip.frame_time, axis=0)
    pl = whole_playlist(clip, cyc, hq, hqd, 3, np.array([7, 8]))
    cut = pl.a
    assert cut == 90 and pl.b - cut == 30
    heading = np.unwrap(root_heading(pl.qpos))
    # the clip's last 30 frames turn 0 deg, so its loop, a 43 deg veer as captured, is played straight on
    assert heading[pl.b] - heading[cut] == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(np.linalg.norm(pl.qpos[cut:pl.b + 1, 3:7], axis=1), 1.0)
    # its travel keeps its length, turned frame by frame: 1.5 m/s along the played heading
    steps = np.diff(pl.qpos[cut:pl.b + 1, :2], axis=0)
    assert np.allclose(np.linalg.norm(steps, axis=1), 1.5 / 30)
    assert np.allclose(pl.qvel[cut:pl.b + 1, :2], 1.5 * np.column_stack([np.cos(heading[cut:pl.b + 1]),
                                                                         np.sin(heading[cut:pl.b + 1])]))
    # the yaw rate added (the root's local z is the world's here): the captured 43 deg a pass less 43
    # (the copy's last frame, the veer's end, has half the rate in the fixture's central differences)
    assert np.allclose(pl.qvel[cut:pl.b, 5], 0.0, atol=1e-9)
    # the hinges are the captured ones
    assert np.array_equal(pl.qpos[cut + 3:pl.b + 1, 7:9], hq[3:31])


def test_a_loop_that_turns_as_the_clip_does_is_played_as_captured() -> None:
    # a clip that circles all along: its loop turns as its end does, and is left as it is
    clip, cyc = _veer_then_straight(frames=91)
    yaw = np.radians(43.0) * np.arange(91) / 30
    clip.qpos[:, 3], clip.qpos[:, 6] = np.cos(yaw / 2), np.sin(yaw / 2)
    pl = whole_playlist(clip, cyc, clip.qpos[:, 7:9], np.zeros((91, 2)), 3, np.array([7, 8]))
    heading = np.unwrap(root_heading(pl.qpos))
    assert heading[pl.b] - heading[pl.a] == pytest.approx(np.radians(43.0))
    # and a loop that veers less than LOOP_TURN_MATCH_DEG is left as captured whatever the clip's end does
    clip, cyc = _veer_then_straight(loop_turn=np.radians(0.8 * LOOP_TURN_MATCH_DEG))
    pl = whole_playlist(clip, cyc, clip.qpos[:, 7:9], np.zeros((91, 2)), 3, np.array([7, 8]))
    heading = np.unwrap(root_heading(pl.qpos))
    assert heading[pl.b] - heading[pl.a] == pytest.approx(np.radians(0.8 * LOOP_TURN_MATCH_DEG))
