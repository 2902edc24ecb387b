"""Stance contact measure (bipedsim.sim.contacts) on the planned gait."""

from __future__ import annotations

import numpy as np
import pytest
from creature_clips import dog_clip

from bipedsim.sim.contacts import StanceContacts
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario


class _Fake:
    """A two-legged 'controller' whose contact state is scripted."""

    def __init__(self, rows):
        self.rows = iter(rows)

    def contact_state(self, data, t):
        return next(self.rows)


def test_summary_counts_shares_switches_and_deciles():
    # leg 0: stance for 10 steps (progress 0.0 .. 0.9), on the floor only in the second half, one
    # switch; then 5 swing steps, one on the floor. Leg 1: always in stance and down.
    rows = [([True, True], [k >= 5, True], [k / 10, k / 10]) for k in range(10)]
    rows += [([False, True], [k == 0, True], [-1.0, 0.5]) for k in range(5)]
    hook = StanceContacts(after_s=0.0)
    fake = _Fake(rows)
    for k in range(len(rows)):
        hook(0.01 * k, None, fake)
    s = hook.summary()
    assert s["stance_share"] == pytest.approx([0.5, 1.0])
    assert s["swing_share"][0] == pytest.approx(0.2)
    assert s["switches"][0] == pytest.approx(1.0)  # one stance (no start seen: counted as one)
    assert s["by_decile"][0][:5] == [0.0] * 5 and s["by_decile"][0][5:] == [1.0] * 5
    # legs down per step: leg 1 always, leg 0 on steps 5-10 (6 of 15 steps two legs, 9 one, none zero)
    assert s["legs_down"] == pytest.approx([0.0, 9 / 15, 6 / 15])


def test_hook_ignores_controllers_without_contact_state():
    hook = StanceContacts(after_s=0.0)
    hook(1.0, None, object())
    assert hook.summary()["stance_share"] == []


def test_dog_stance_feet_mostly_on_the_floor():
    """On the walking dog (without ``../shared`` the generated one of ``creature_clips.py``), each leg's
    planned stance is on the floor at least 40 % of the time over 1-3 s (the shared dog: 0.61-0.75; the
    generated one: 0.45-0.65; the front feet land late, the hind ones chatter; see docs/creatures.md),
    and a swinging foot is on the floor less than 25 % of its swing."""
    sc = load_scenario(bvh=dog_clip())
    hook = StanceContacts()
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=3.0), hooks=[hook])
    assert out.fall_time_s is None
    s = hook.summary()
    assert len(s["stance_share"]) == 4
    assert min(s["stance_share"]) >= 0.4, s["stance_share"]
    assert max(s["swing_share"]) < 0.25, s["swing_share"]
    assert np.all(np.isfinite(np.array(s["by_decile"])))
