"""A creature's legs in its body plan: a trunk body that carries two legs and nothing else (a chest
whose head a mutation removed) joins two legs, it is no leg's root; a bird's toes stay one foot."""

from __future__ import annotations

from bipedsim.model import build_model
from bipedsim.model.creature_builder import creature_legs
from bipedsim.motion.helper_bones import without_joints
from bipedsim.motion.samples import horse_walk


def test_a_headless_chest_carries_two_fore_legs_not_one() -> None:
    horse = horse_walk(cycles=1).to_project_frame()
    headless = without_joints(horse, {"Neck"})  # the chest now ends only in the fore hooves
    for m in (horse, headless):
        legs = creature_legs(build_model(m, "creature").plan)
        assert len(legs) == 4, [(leg.root, leg.feet) for leg in legs]
        assert all(len(leg.feet) == 1 for leg in legs)
