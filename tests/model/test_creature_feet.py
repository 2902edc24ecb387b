"""A creature's feet are the segments its clip stands on, found from the clip's contacts: a toe that
hangs off a hoof above the floor is folded into the hoof, which stays the foot; a leaf that carries
stays the foot, unchanged; a forearm that rests on the floor while the body lies is no foot."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from bvh_fixtures import E, J, relaid

from bipedsim.control.creature.many_legs import ManyLegs
from bipedsim.model import build_model, creature_feet
from bipedsim.model.creature_builder import Leg, creature_legs
from bipedsim.model.creature_feet import carrying_feet
from bipedsim.model.creature_tree import reduce_skeleton, skeleton_extent
from bipedsim.model.profile import CreatureProfile
from bipedsim.model.source import SourcePoints, motion_points, rest_points
from bipedsim.motion.motion import Motion
from bipedsim.motion.samples import horse_walk

HOOVES = ("LeftFoot", "LeftHand", "RightFoot", "RightHand")
#: where each stand-in toe hangs from its hoof (m, hoof frame: halfway down the hoof's bone, 4 cm above its
#: tip) and where the toe ends (m, from the toe: up and forward, 12 cm long -- past the merge length)
TOE_AT, TOE_END = (0.03, 0.0, -0.04), (0.06, 0.0, 0.10)


def _horse() -> Motion:
    return horse_walk(cycles=1).to_project_frame()


def _horse_with_raised_toes() -> Motion:
    """The shipped horse with a toe on each hoof that never reaches the floor (a dewclaw): the hoof
    carries the horse, the toe is the leaf."""
    m = _horse()
    sk = m.skeleton
    joints = [J(n, None if p < 0 else sk.names[p], n) for n, p in zip(sk.names, sk.parents)]
    ends = [E(sk.names[p], tuple(o)) for p, o in zip(sk.end_site_parents, sk.end_site_offsets)]
    for hoof in HOOVES:
        joints.append(J(f"{hoof}Toe", hoof, hoof, TOE_AT))
        ends.append(E(f"{hoof}Toe", TOE_END))
    return relaid(m, joints, ends)


def test_a_leaf_held_above_the_floor_folds_into_the_segment_that_carries() -> None:
    built = build_model(_horse_with_raised_toes(), "creature")
    plan = built.plan
    assert sorted(plan.foot_bodies) == sorted(HOOVES)  # not the toes, the leaves
    names = {b.name for b in plan.bodies}
    assert not any(n.endswith("Toe") for n in names)  # no joint of their own
    assert sorted(plan.extra["folded_feet"]) == sorted(HOOVES)
    legs = creature_legs(plan)
    assert sorted(f for leg in legs for f in leg.feet) == sorted(HOOVES)
    for hoof in HOOVES:
        body = next(b for b in plan.bodies if b.name == hoof)
        # the toe's bone is kept as a capsule of the hoof, reaching the toe's end
        ends = [np.asarray(g.fromto[3:6]) for g in body.geoms if g.fromto is not None]
        reach = np.array(TOE_AT) + np.array(TOE_END)
        assert min(float(np.linalg.norm(e - reach)) for e in ends) < 1e-6
        assert any(s.name == f"{hoof}_touch" for s in body.sites)
    data = mujoco.MjData(built.model)
    for _ in range(50):
        mujoco.mj_step(built.model, data)
    assert np.isfinite(data.qpos).all()


def test_leaves_that_carry_stay_the_feet() -> None:
    plan = build_model(_horse(), "creature").plan
    assert sorted(plan.foot_bodies) == sorted(HOOVES)
    assert "folded_feet" not in plan.extra


#: the share of the take the stand-in horse lies for, and its joints' heights over the floor then (a
#: share of the standing ones): well under creature_feet.STANDING_FRACTION
LYING_SHARE, LYING_HEIGHT = 0.4, 0.3


def test_a_forearm_on_the_floor_while_the_body_lies_is_no_foot(monkeypatch: pytest.MonkeyPatch) -> None:
    """The first LYING_SHARE of the horse's frames squashed toward the floor (the body lying) with each
    fore leg's knee on it and its hoof raised: the forearms' ends are at the floor on more frames than
    the hooves are, yet only the standing frames count."""
    m = _horse()
    rest = rest_points(m)
    size = skeleton_extent(rest)
    tree = reduce_skeleton(rest, CreatureProfile().merge_fraction, size)
    moving = motion_points(m)
    pos = moving.positions.copy()
    z = pos[..., 2]
    lie = slice(0, int(LYING_SHARE * len(z)))
    low = z[lie].min(axis=1, keepdims=True)
    z[lie] = low + LYING_HEIGHT * (z[lie] - low)
    for hoof in ("LeftHand", "RightHand"):
        z[lie, moving.index[hoof]] = low[:, 0]  # the knee down
        z[lie, moving.index[f"{hoof}/end0"]] = low[:, 0] + 0.1 * size  # the hoof folded up
    lying = SourcePoints(moving.skeleton, pos, moving.rotations)
    legs = [(leg.root, leg.feet) for leg in creature_legs(build_model(m, "creature").plan)]
    assert carrying_feet(tree, lying, size, legs) == {}
    monkeypatch.setattr(creature_feet, "STANDING_FRACTION", 0.0)  # every frame counted
    forearm = {tree.names[f]: tree.names[c] for f, c in carrying_feet(tree, lying, size, legs).items()}
    assert forearm["LeftHand"] == "LeftForeArm" and forearm["RightHand"] == "RightForeArm"


class _Legs:
    legs = [Leg(root="LeftUpLeg", bodies=("LeftUpLeg", "LeftLeg", "LeftFoot"), feet=("LeftFoot",)),
            Leg(root="LeftArm", bodies=("LeftArm", "LeftForeArm", "LeftHand"), feet=("LeftHand",))]


def test_a_sole_s_own_joint_is_turned_a_paw_s_is_held() -> None:
    rules = ManyLegs(folded_feet=("LeftFoot",))
    assert rules.held_feet(_Legs(), 0) == ()  # type: ignore[arg-type]
    assert rules.held_feet(_Legs(), 1) == ("LeftHand",)  # type: ignore[arg-type]
