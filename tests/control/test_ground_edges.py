"""Footsteps near a step's edge (control/humanoid/ground.py): edges found along the heading, the shift
that lands a foot clear of them, and a short walk over a 10 cm step up where the unadjusted walk's
footfall lands with its toe at the step's face."""

from __future__ import annotations

import pytest

from bipedsim.control.humanoid.ground import FOOT_SPAN_M, EdgeStep, edges_along, step_shift
from bipedsim.control.humanoid.settings import GroundConfig
from bipedsim.model.ground import Ground, Terrain
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

CFG = GroundConfig()


def test_edges_along_finds_a_step_up_and_down_and_not_a_slope() -> None:
    t = Terrain(Ground.parse(["slope:8", "step:0.1:3", "step:-0.1:4"]))
    edges = edges_along(t, 0.0, 0.0, 1.0, 0.0, 2.0, 5.0, CFG.edge_height)
    assert len(edges) == 2
    assert edges[0] == pytest.approx(3.0, abs=0.01) and edges[1] == pytest.approx(4.0, abs=0.01)
    assert edges_along(t, 0.0, 0.0, 1.0, 0.0, 0.5, 2.9, CFG.edge_height) == []


def test_a_footfall_clear_of_every_edge_is_not_moved() -> None:
    heel, toe = FOOT_SPAN_M
    assert step_shift(CFG, 2.0, []) == 0.0
    assert step_shift(CFG, 2.0, [2.0 + toe + CFG.edge_margin + 0.01]) == 0.0
    assert step_shift(CFG, 2.0, [2.0 + heel - CFG.edge_margin - 0.01]) == 0.0


def test_a_toe_at_the_face_is_pulled_short_and_a_heel_on_the_edge_pushed_past_it() -> None:
    heel, toe = FOOT_SPAN_M
    m = CFG.edge_margin
    # the toe just short of the edge: the nearer way out is shorter, toe margin m before it
    d = step_shift(CFG, 2.0, [2.0 + toe + 0.02])
    assert d == pytest.approx(0.02 - m)
    # the heel just before the edge: the nearer way out is longer, the heel margin m past it
    d = step_shift(CFG, 2.0, [2.0 + heel + 0.02])
    assert d == pytest.approx(0.02 + m)
    assert abs(step_shift(CFG, 2.0, [2.05])) <= CFG.max_shift


def test_no_shift_when_switched_off() -> None:
    off = GroundConfig(max_shift=0.0)
    assert step_shift(off, 2.0, [2.1]) == 0.0


def test_edge_step_resets() -> None:
    es = EdgeStep(swing="left", shift=0.1, foreseen=(1.0, 0.0), bias=0.02, crossing=True)
    es.reset()
    assert (es.swing, es.shift, es.foreseen, es.bias, es.crossing) == (None, 0.0, None, 0.0, False)
    assert es.short is None and es.over is None


def test_the_walk_climbs_a_step_whose_edge_meets_its_toe() -> None:
    # unadjusted, the built-in walk's fourth footfall lands with its toe at this step's face and it
    # falls at 3.8 s; adjusted, it is on the top level by 4 s and standing at 5 s
    sc = load_scenario(ground=Ground.parse(["step:0.1:3"]))
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=5.0))
    assert out.outcome == "no_fall", out.fall_reason
    assert out.distance_m > 4.0
