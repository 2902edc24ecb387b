"""The correction's reach: a feed-forward correction holds on the path it was made for and lets go of a
body pushed off it (``reconstruct.reach``, :class:`~bipedsim.control.humanoid.correction.Nominal`)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bipedsim.control.humanoid.correction import EXTRA, Correction, Nominal
from bipedsim.sim.push import Push
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario
from bipedsim.sim.scenario import nominal_path


def test_the_nominal_path_measures_the_capture_points_distance_by_frame() -> None:
    frames = np.array([10.0, 11.0, 12.0, 13.0])
    com = np.array([[0.0, 0.1, 1.0, 0.0], [0.1, 0.1, 1.0, 0.0], [0.2, 0.1, 1.0, 0.0], [-0.2, -0.1, 1.0, 0.0]])
    left = np.array([True, True, True, False])
    path = Nominal(frames=frames, com=com, left=left)
    assert path.deviation(11.2, (0.1, 0.1, 1.0, 0.0), True, 3.0) == pytest.approx(0.0)
    # d off by 0.1 m and v by 0.3 m/s in the same direction: the capture point 0.1 + 0.3 / 3 off
    assert path.deviation(11.0, (0.2, 0.1, 1.3, 0.0), True, 3.0) == pytest.approx(0.2)
    assert path.deviation(11.0, (0.1, 0.2, 1.0, 0.0), True, 3.0) == pytest.approx(0.1)  # sideways too
    assert path.deviation(12.9, (-0.2, -0.1, 1.0, 0.0), True, 3.0) == math.inf  # the other foot stands
    assert path.deviation(9.0, (0.0, 0.1, 1.0, 0.0), True, 3.0) is None  # before the path
    assert path.deviation(20.0, (0.0, 0.1, 1.0, 0.0), True, 3.0) is None  # after it, with no period
    # past the correction's end (13) its last period (2 frames) repeats, and so does the path
    looped = replace(path, end=13.0, period=2.0)
    assert looped.deviation(13.2, (0.1, 0.1, 1.0, 0.0), True, 3.0) == pytest.approx(0.0)  # as at 11.2
    assert looped.deviation(17.0, (0.1, 0.1, 1.0, 0.0), True, 3.0) == pytest.approx(0.0)  # as at 11.0
    # a strike a little sooner or later than the path's: the nearest sample on the same foot, in the window
    near = replace(path, window=1.0)
    assert near.deviation(12.9, (0.2, 0.1, 1.0, 0.0), True, 3.0) == pytest.approx(0.0)  # frame 12's sample
    assert replace(path, window=0.5).deviation(12.9, (0.2, 0.1, 1.0, 0.0), True, 3.0) == math.inf
    assert Nominal(frames=np.zeros(0), com=np.zeros((0, 4)), left=np.zeros(0, bool)).deviation(
        1.0, (0, 0, 0, 0), True, 3.0) is None


@pytest.fixture(scope="module")
def corrected():
    """The built-in walk under a correction made by hand: every hinge 0.03 rad off, the swing hip's
    sagittal angle 0.05 rad, over 4 s of its reference; it fades out over 1 s after."""
    sc = load_scenario(None, reconstruct=False)
    ctrl = sc.controller()
    start, ft = float(ctrl.start_frame()), ctrl.source.frame_time
    row = np.full(ctrl.tables.kp.shape[0] + EXTRA, 0.03)
    row[-4] = 0.05
    corr = Correction(starts=(start,), rows=row[None, :], end=start + 4.0 / ft, fade=1.0 / ft)
    return replace(sc, correction=corr)


def _applied(sc, spec, pushes=None):
    """A run of ``sc``: per control step, the time and the share of the correction's row applied."""
    shares = []

    def hook(t, data, ctrl) -> None:
        raw = ctrl.correction.at(ctrl.frame)
        if raw is not None and t > 0.0:
            used = ctrl._corr
            shares.append((t, 0.0 if used is None else float(used[0] / raw[0])))

    out, ctrl = run_scenario(sc, spec, hooks=[hook], pushes=pushes)
    return out, ctrl, np.array(shares)


def test_the_correction_holds_in_full_on_its_own_path(corrected) -> None:
    path = nominal_path(corrected)
    assert path is not None and len(path.frames) > 900  # 4 s of control steps (4 ms)
    assert np.all(np.diff(path.frames) >= 0.0)
    assert nominal_path(corrected) is path  # made once per scenario
    out, ctrl, shares = _applied(corrected, RolloutSpec(seconds=5.0))
    assert out.outcome == "no_fall" and np.all(shares[:, 1] == 1.0)
    # the same run as with no reach at all, to the bit
    no_reach = replace(corrected, cfg=replace(corrected.cfg, reconstruct=replace(corrected.cfg.reconstruct,
                                                                                    reach=0.0)))
    assert nominal_path(no_reach) is None
    out0, ctrl0 = run_scenario(no_reach, RolloutSpec(seconds=5.0))
    assert out0.distance_m == out.distance_m and ctrl0.frame == ctrl.frame


def test_a_pushed_body_walks_without_the_correction_until_it_is_back_on_its_path(corrected) -> None:
    push = Push(300.0, 90.0, 0.2, start=1.5)
    out, ctrl, shares = _applied(corrected, RolloutSpec(seconds=4.0), pushes=[push])
    before, after = shares[shares[:, 0] < 1.5, 1], shares[shares[:, 0] >= 1.5, 1]
    assert np.all(before == 1.0)
    assert np.any(after == 0.0) and np.any((after > 0.0) & (after < 1.0))  # let go, faded in between
    gone = int(np.argmax(after == 0.0))
    assert np.any(after[gone:] > 0.0)  # and taken up again where the body comes near its path


def test_a_disturbance_within_the_reach_keeps_the_correction_at_every_strike(corrected) -> None:
    """0.02 rad/s of initial velocity noise moves the strikes by a control step or two: the correction
    stays in full throughout (a strike a step off the path's is not the other foot)."""
    for seed in (1, 3):
        out, ctrl, shares = _applied(corrected, RolloutSpec(seconds=5.0, seed=seed, init_noise=0.02))
        assert out.outcome == "no_fall" and np.all(shares[:, 1] == 1.0)


def test_the_reach_covers_the_fade_and_is_made_for_the_settings_it_runs_with(corrected) -> None:
    push = Push(300.0, 90.0, 0.2, start=4.2)  # in the correction's fade (4-5 s)
    out, ctrl, shares = _applied(corrected, RolloutSpec(seconds=5.0), pushes=[push])
    assert np.all(shares[shares[:, 0] < 4.2, 1] == 1.0) and np.any(shares[shares[:, 0] >= 4.2, 1] < 1.0)
    path = nominal_path(corrected)
    assert path.frames[-1] > corrected.correction.end  # walked through the fade
    assert nominal_path(replace(corrected)) is path  # the same correction and settings: made once
    other = replace(corrected, cfg=replace(corrected.cfg, fsm=replace(corrected.cfg.fsm, contact_force=40.0)))
    assert nominal_path(other) is not path  # other settings walk another path
    assert nominal_path(corrected) is not None
