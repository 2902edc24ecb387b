"""The creature profile: any skeleton becomes a body (quadrupeds, birds, crabs, bred chimeras).

Rules:

- every source joint becomes a body with a ball joint, except a joint whose own bone (the longest
  segment from it to a child joint or End Site) is shorter than ``merge_fraction`` x the creature's
  size: turning it would move almost nothing, so it is **merged** into its parent's body (its children
  hang from the parent body at their rest positions; a leaf without an End Site always merges);
- each body carries one capsule per bone leaving it (to each child body, or to its End Sites), radius
  ``radius_fraction`` x bone length clamped to ``[radius_min, radius_max]`` x size, mass = density x
  volume (optionally scaled to ``total_mass``);
- ball-joint limits: the largest rotation the motion shows at that joint plus ``range_margin``, at
  least ``range_min``, at most pi;
- motors on every ball axis; torque limit ``torque_scale`` x (subtree mass) x (subtree reach) x g;
- a touch sensor on every end effector (a body with no child body); end effectors low over the motion
  are the first guess at the feet;
- on more than two legs, each leg's foot is the segment the clip stands on (:mod:`~bipedsim.model.creature_feet`):
  the highest segment of the leg whose bones' ends reach the floor on about as many of the clip's
  frames as the leg's most grounded segment; the segments below it (toes or fingers lying beside a
  sole or palm, a dewclaw that never touches) are **folded** into it (their capsules kept on the foot
  body, no joint of their own) and its touch site sits at its point nearest the floor. A leaf that
  carries stays the foot; bodies on two legs keep their leaves (their soles, added under the segment
  the toes spread from, are what meets the floor: model/creature_sole.py).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.model.creature_feet import carrying_feet, fold_feet, low_end_effectors
from bipedsim.model.creature_kind import MIN_LEG_JOINTS
from bipedsim.model.creature_sole import add_soles, lighten_legs
from bipedsim.model.creature_tree import BodyTree, reduce_skeleton, skeleton_extent
from bipedsim.model.plan import BodyPlan, BodyPlanSet, FitPlan, GeomPlan, JointPlan, SitePlan
from bipedsim.model.profile import CreatureProfile
from bipedsim.model.source import SourcePoints, motion_points, rest_points
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]

GRAVITY = 9.81
#: A bone shorter than this (m) cannot carry a capsule: the body gets a small sphere instead.
MIN_CAPSULE_M = 1e-3


#: The joints' passive damping and rotor inertia (the profile's ``sim.joint_damping``, ``sim.armature``:
#: absolute values) at most these shares of the body's own scales, M s^2 sqrt(g/s) (N m s) and M s^2
#: (kg m^2), M its mass, s its size: a small creature given a profile's absolute values would be damped
#: past its own scale on every joint and stiffen; bodies of ordinary size stay well under the caps.
DAMPING_SHARE = 0.1
ARMATURE_SHARE = 0.01

def _sized_sim(profile: CreatureProfile, mass: float, size: float) -> CreatureProfile:
    """``profile`` with its joint damping and armature held to :data:`DAMPING_SHARE` and
    :data:`ARMATURE_SHARE` of the body's own scales (a small creature's legs are not swung through
    syrup sized for a dog's)."""
    sim = profile.sim
    g = abs(float(sim.gravity)) or GRAVITY
    damping = min(sim.joint_damping, DAMPING_SHARE * mass * size * size * math.sqrt(g / max(size, 1e-9)))
    armature = min(sim.armature, ARMATURE_SHARE * mass * size * size)
    if damping == sim.joint_damping and armature == sim.armature:
        return profile
    return replace(profile, sim=replace(sim, joint_damping=damping, armature=armature))


def creature_plan(motion: Motion, profile: CreatureProfile, *, total_mass: float | None = None,
                  name: str = "creature") -> BodyPlanSet:
    """The creature body plan for a motion's skeleton (motion in the project frame: m, Z up)."""
    sk = motion.skeleton
    rest = rest_points(motion)
    size = skeleton_extent(rest)
    tree = reduce_skeleton(rest, profile.merge_fraction, size)
    moving = motion_points(motion)
    ranges = _ball_ranges(tree, moving, profile)
    feet = low_end_effectors(tree, moving)
    bodies, legs = _bodies_and_legs(tree, ranges, feet, profile, size, name)
    carrying = carrying_feet(tree, moving, size, [(leg.root, leg.feet) for leg in legs])
    if carrying:
        tree, feet = fold_feet(tree, rest, moving, feet, carrying)
        bodies, legs = _bodies_and_legs(tree, ranges, feet, profile, size, name)
    lighten_legs(bodies, legs)  # two legs: at most a human's share of the mass (model/creature_sole.py)
    mass_of = {j: sum(g.mass for g in b.geoms) for j, b in zip(tree.kept, bodies)}
    target = total_mass if total_mass is not None else profile.total_mass
    scale = _scale_masses(bodies, mass_of, target)
    masses = {j: m * scale for j, m in mass_of.items()}
    profile = _sized_sim(profile, sum(masses.values()), size)
    _set_motors(bodies, tree, masses, profile, size, _leg_loads(bodies, tree, legs, sum(masses.values())))
    lift = _stand_on_floor(bodies)
    body_source = {tree.names[j]: {sk.names[k] for k in range(sk.num_joints) if tree.body_of[k] == j}
                   for j in tree.kept}
    soles = add_soles(bodies, legs, moving, rest, body_source)  # two legs: flat feet (model/creature_sole.py)
    markers = {sk.names[j]: ["body", tree.names[j]] for j in tree.kept}
    return BodyPlanSet(name=name, profile="creature", bodies=bodies, heading_yaw=0.0,
                       source_names=list(sk.names), sim=asdict(profile.sim),
                       extra={"markers": markers, "merged": [sk.names[j] for j in range(sk.num_joints)
                                                             if tree.body_of[j] != j],
                              "size_m": size, "rest_lift": lift, "soles": soles,
                              **({"folded_feet": [tree.names[j] for j in sorted(tree.folded)]} if tree.folded else {})})


def _bodies_and_legs(tree: BodyTree, ranges: dict[int, float], feet: set[int], profile: CreatureProfile,
                     size: float, name: str) -> tuple[list[BodyPlan], list[Leg]]:
    """The bodies of ``tree`` (``feet``: the kept joints that are feet) and the legs they make."""
    bodies = [_body(tree, j, ranges.get(j), j in feet, profile, size) for j in tree.kept]
    legs = creature_legs(BodyPlanSet(name=name, profile="creature", bodies=bodies, heading_yaw=0.0, source_names=[],
                                     sim={}))
    return bodies, legs


def _ball_ranges(tree: BodyTree, moving: SourcePoints, profile: CreatureProfile) -> dict[int, float]:
    """Ball-joint limit (rad) of each kept non-root joint: the largest rotation of its body relative
    to its parent body over the motion plus ``range_margin``, at least ``range_min``, at most pi."""
    assert moving.rotations is not None
    ranges: dict[int, float] = {}
    for j in tree.kept:
        if j == 0:
            continue
        gp = moving.rotations[:, tree.parent_body(j)]
        gj = moving.rotations[:, j]
        local = np.transpose(gp, (0, 2, 1)) @ gj
        ang = np.linalg.norm(Rotation.from_matrix(local).as_rotvec(), axis=1)
        ranges[j] = float(min(np.pi, max(profile.range_min, ang.max() + profile.range_margin)))
    return ranges


def _geoms(tree: BodyTree, j: int, profile: CreatureProfile, size: float) -> list[GeomPlan]:
    """Body ``j``'s geoms (body frame, m, kg): a capsule along each bone leaving it (to each child body
    and End Site), radius ``radius_fraction`` x length clamped to [radius_min, radius_max] x ``size``,
    mass density x volume; a sphere of the smallest radius when no bone is long enough."""
    pos = tree.pos
    geoms = []
    for a, t in tree.bones(j):
        length = float(np.linalg.norm(t - a))
        if length < MIN_CAPSULE_M:
            continue
        r = _capsule_radius(length, profile, size)
        vol = np.pi * r * r * length + 4.0 / 3.0 * np.pi * r ** 3
        geoms.append(GeomPlan(kind="capsule", size=[r], fromto=[*(a - pos[j]), *(t - pos[j])],
                              mass=profile.density * vol))
    if not geoms:
        r = float(profile.radius_min * size)
        geoms.append(GeomPlan(kind="sphere", size=[r], pos=[0.0, 0.0, 0.0],
                              mass=profile.density * 4.0 / 3.0 * np.pi * r ** 3))
    return geoms


def _capsule_radius(length: float, profile: CreatureProfile, size: float) -> float:
    """A bone's capsule radius (m): ``radius_fraction`` x its ``length`` (m), clamped to [radius_min,
    radius_max] x the creature's ``size`` (m)."""
    return float(np.clip(profile.radius_fraction * length, profile.radius_min * size, profile.radius_max * size))


def _body(tree: BodyTree, j: int, ball_range: float | None, is_foot: bool, profile: CreatureProfile,
          size: float) -> BodyPlan:
    """Kept joint ``j``'s body at its rest position (m): its geoms, a ball joint limited to
    ``ball_range`` (rad; none on the root, which gets the free joint), a touch site at the tip of an
    end effector, oriented like the source joint."""
    sk, pos, names = tree.skeleton, tree.pos, tree.names
    geoms = _geoms(tree, j, profile, size)
    sites = []
    if not tree.children[j]:
        tip = tree.tips[j] if j in tree.tips else tree.ends[j][0] if tree.ends[j] else pos[j]
        r = max(g.size[0] for g in geoms) + 0.01 * size
        sites.append(SitePlan(name=f"{names[j]}_touch", pos=list(tip - pos[j]), size=[r], touch=True))
    joints = []
    if j != 0:
        assert ball_range is not None
        joints.append(JointPlan(name=f"{names[j]}_ball", kind="ball", axis=[0.0, 0.0, 1.0],
                                range=[0.0, ball_range], group="ball"))
    return BodyPlan(name=names[j], parent=None if j == 0 else names[tree.parent_body(j)],
                    pos=[float(v) for v in pos[j]], source=sk.names[j], joints=joints, geoms=geoms,
                    sites=sites, fit=FitPlan(method="ref", origin=sk.names[j], ref=f"bvh:{sk.names[j]}"),
                    is_foot=is_foot)


def _scale_masses(bodies: list[BodyPlan], mass_of: dict[int, float], target: float | None) -> float:
    """Scale every geom's mass so the bodies (masses ``mass_of``, kg) weigh ``target`` (kg) in all;
    returns the factor (1 for None)."""
    if target is None:
        return 1.0
    scale = target / sum(mass_of.values())
    for b in bodies:
        for g in b.geoms:
            g.mass *= scale
    return scale


def _subtrees(tree: BodyTree, mass: dict[int, float]) -> tuple[dict[int, float], dict[int, float]]:
    """Per kept joint: the mass (kg) of the subtree it carries (``mass``: each body's own) and the
    subtree's reach (m), the farthest bone tip from the joint along the tree."""
    pos = tree.pos
    sub_mass = dict(mass)
    reach = {j: 0.0 for j in tree.kept}
    for j in reversed(tree.kept):
        tips = [t for _, t in tree.bones(j)]
        reach[j] = max([float(np.linalg.norm(t - pos[j])) for t in tips] +
                       [float(np.linalg.norm(pos[c] - pos[j])) + reach[c] for c in tree.children[j]] + [0.0])
        for c in tree.children[j]:
            sub_mass[j] += sub_mass[c]
    return sub_mass, reach


def _leg_loads(bodies: list[BodyPlan], tree: BodyTree, legs: list[Leg], total: float) -> dict[int, float]:
    """The mass (kg) each leg joint holds up when its leg stands: the body's ``total`` mass times
    min(1, 2 / legs) (a biped stands on one leg, a quadruped trots on two), for every joint of a leg
    including its feet (the ground pushes on the foot: a paw sized for the paw alone folds under the body)."""
    if not legs:
        return {}
    share = total * min(1.0, 2.0 / len(legs))
    by_name = {tree.names[j]: j for j in tree.kept}
    return {by_name[b]: share for leg in legs for b in leg.bodies}


#: Largest stiffness of a joint's PD as (natural frequency x timestep)^2 of the subtree it turns, with
#: the subtree's inertia taken as mass x reach^2: PD torques are explicit, so a stiff light body
#: (a foot, a toe) must stay far inside the explicit integrator's limit of 4.
MAX_STIFFNESS_STEP = 0.25


#: a leg joint's motor turns it at this many sqrt(g / reach) rad/s against its damping (on top of holding
#: its load): a swing the gait needs
LEG_SWING_RATE = 2.0


def _set_motors(bodies: list[BodyPlan], tree: BodyTree, mass: dict[int, float], profile: CreatureProfile,
                size: float, loads: dict[int, float] | None = None) -> None:
    """Motor strength from the load each ball joint carries: torque limit (N m) ``torque_scale`` x load x
    reach (at least 5 % of ``size``) x g, gains the profile's unit gains x load x reach, the stiffness
    capped at MAX_STIFFNESS_STEP. The load is the subtree's mass, or for a leg joint the body weight
    share it holds up (``loads``, kg); the damping at most critical for the subtree (inertia taken as
    its mass x reach^2). ``mass``: each body's own mass (kg), after scaling."""
    sub_mass, reach = _subtrees(tree, mass)
    kp_unit, kd_unit = profile.gains
    dt = profile.sim.timestep
    for b, j in zip(bodies, tree.kept):
        if j == 0:
            continue
        r = max(reach[j], 0.05 * size)
        load = max(sub_mass[j], (loads or {}).get(j, 0.0))
        b.joints[0].torque = float(profile.torque_scale * load * r * GRAVITY)
        # the joint's armature (rotor inertia) turns with it: a light paw or toe is stiff enough to stand on
        inertia = sub_mass[j] * r * r + profile.sim.armature
        kp = min(kp_unit * load * r, MAX_STIFFNESS_STEP * inertia / (dt * dt))
        b.joints[0].kp = float(kp)
        # no more than critical damping of the subtree it swings: a leg sized for the body's weight
        # would otherwise swing through syrup
        b.joints[0].kd = float(min(kd_unit * load * r, 2.0 * np.sqrt(kp * inertia)))
        if j in (loads or {}):
            # a leg joint also swings its leg against its own damping: the motor reaches LEG_SWING_RATE
            # sqrt(g / reach) rad/s against it (the damping alone otherwise caps a dog's hip at 6 rad/s)
            b.joints[0].torque += float(b.joints[0].kd * LEG_SWING_RATE * np.sqrt(GRAVITY / r))


def _stand_on_floor(bodies: list[BodyPlan]) -> float:
    """Lift the zero pose so that the lowest of (body origin height - geom radius), over every geom,
    is z = 0; returns the lift (m)."""
    lift = -min(b.pos[2] - g.size[0] for b in bodies for g in b.geoms)
    for b in bodies:
        b.pos[2] += lift
    return lift


@dataclass(frozen=True)
class Leg:
    """One leg of a creature body: the body it hangs from the trunk by (``root``), its chain of
    bodies from there down (``bodies``, the root first) and the foot bodies it ends in (``feet``: one,
    or several toes)."""

    root: str
    bodies: tuple[str, ...]
    feet: tuple[str, ...]


#: a body from which two branches each reach a foot along at least this fraction of the longest
#: root-to-foot chain joins two legs (a chest whose head a mutation removed carries both fore legs);
#: a bird's toes branch within a few percent of it
LEG_JOIN_FRACTION = 0.25


def creature_legs(plan: BodyPlanSet) -> list[Leg]:
    """The legs of a creature body plan: each foot body's chain walked up while the body's subtree
    ends only in feet and does not join two legs (:data:`LEG_JOIN_FRACTION`), never up to the root
    body; feet sharing that leg root are one leg; a chain of
    fewer than MIN_LEG_JOINTS bodies (one bone hanging from the trunk) is no leg. In the order of the
    first foot of each leg in ``plan.foot_bodies``."""
    feet = set(plan.foot_bodies)
    parent = {b.name: b.parent for b in plan.bodies}
    children: dict[str, list[str]] = {b.name: [] for b in plan.bodies}
    for b in plan.bodies:
        if b.parent is not None:
            children[b.parent].append(b.name)

    leaves: dict[str, set[str]] = {}
    for b in reversed(plan.bodies):  # parents come first: children are done before their parent
        kids = children[b.name]
        leaves[b.name] = {b.name} if not kids else set().union(*(leaves[k] for k in kids))

    pos = {b.name: np.asarray(b.pos, dtype=float) for b in plan.bodies}

    def reach(b: str) -> float:  # (m) along the bones from b's parent down to b's farthest foot
        best = 0.0
        for f in leaves[b] & feet:
            d, x = 0.0, f
            while x != b:
                d += float(np.linalg.norm(pos[x] - pos[parent[x]]))  # type: ignore[index]
                x = parent[x]  # type: ignore[assignment]
            best = max(best, d + float(np.linalg.norm(pos[b] - pos[parent[b]])))  # type: ignore[index]
        return best

    longest = max((reach(c) for b in plan.bodies for c in children[b.name] if b.parent is None), default=0.0)

    def joins_legs(p: str) -> bool:  # two branches of p each carry a foot from a leg's length away
        return sum(reach(c) >= LEG_JOIN_FRACTION * longest for c in children[p] if leaves[c] & feet) >= 2

    roots: dict[str, list[str]] = {}
    for f in plan.foot_bodies:
        r, joints = f, 1
        while (parent[r] is not None and parent[parent[r]] is not None and leaves[parent[r]] <= feet
               and not joins_legs(parent[r])):  # type: ignore[arg-type]
            r = parent[r]  # type: ignore[assignment]
            joints += 1
        if parent[r] is None or joints < MIN_LEG_JOINTS:
            continue
        roots.setdefault(r, []).append(f)
    legs = []
    for r, fs in roots.items():
        chain, stack = [], [r]
        while stack:
            b = stack.pop(0)
            chain.append(b)
            stack.extend(children[b])
        legs.append(Leg(root=r, bodies=tuple(chain), feet=tuple(fs)))
    return legs


def trunk_bodies(plan: BodyPlanSet) -> set[str]:
    """The creature's trunk: its root body and every body between it and a leg's root."""
    parent = {b.name: b.parent for b in plan.bodies}
    out = {b.name for b in plan.bodies if b.parent is None}
    for leg in creature_legs(plan):
        p = parent[leg.root]
        while p is not None:
            out.add(p)
            p = parent[p]
    return out
