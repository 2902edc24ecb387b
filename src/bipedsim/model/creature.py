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
- a touch sensor on every end effector (a body with no child body); end effectors in the lowest part
  of the rest pose count as feet.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.model.plan import BodyPlan, BodyPlanSet, FitPlan, GeomPlan, JointPlan, SitePlan
from bipedsim.model.profile import CreatureProfile
from bipedsim.model.source import motion_points, rest_points
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]

#: End effectors whose rest height is within this fraction of the body's height from the bottom are
#: feet (contact labels, fall detection).
FOOT_HEIGHT_FRACTION = 0.25
GRAVITY = 9.81
#: A bone shorter than this (m) cannot carry a capsule: the body gets a small sphere instead.
MIN_CAPSULE_M = 1e-3


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "_-." else "_" for c in name)


def creature_plan(motion: Motion, profile: CreatureProfile, *, total_mass: float | None = None,
                  name: str = "creature") -> BodyPlanSet:
    """The creature body plan for a motion's skeleton (motion in the project frame: m, Z up)."""
    sk = motion.skeleton
    rest = rest_points(motion)
    pos = rest.positions[:sk.num_joints]
    pts_all = rest.positions
    size = float(np.max(pts_all.max(axis=0) - pts_all.min(axis=0)))
    if size <= 0:
        raise ModelError("the skeleton has no extent: every joint sits at one point")
    lengths = np.linalg.norm(sk.offsets, axis=1)
    if sk.num_joints > 1 and np.all(lengths[1:] < 1e-9):
        raise ModelError("zero-length bones: every joint offset is zero")

    # which joints become bodies: a joint whose own bone -- the longest segment from it to a child
    # joint or End Site -- is short moves almost nothing when it turns, so it merges into its parent
    bone = np.zeros(sk.num_joints)
    for c in range(1, sk.num_joints):
        p = int(sk.parents[c])
        bone[p] = max(bone[p], float(np.linalg.norm(pos[c] - pos[p])))
    for e, p in enumerate(sk.end_site_parents):
        bone[p] = max(bone[p], float(np.linalg.norm(pts_all[sk.num_joints + e] - pos[p])))
    body_of = np.arange(sk.num_joints)
    for j in range(1, sk.num_joints):
        if bone[j] < profile.merge_fraction * size:
            body_of[j] = body_of[sk.parents[j]]
    kept = sorted({int(b) for b in body_of})
    if len(kept) < 2:
        # one rigid body has nothing to move: a rollout of it would "track" the clip with RMSE 0
        raise ModelError(
            f"every one of the {sk.num_joints} joints merges into the root: each bone is shorter than "
            f"merge_fraction {profile.merge_fraction:g} x the body's size {size:.3g} m "
            f"(longest bone {bone.max():.3g} m), so the body would be one rigid piece with no joint to "
            "drive; give a creature profile YAML with a smaller merge_fraction (convert --profile-file)")
    names = {j: _safe(sk.names[j]) for j in kept}
    children: dict[int, list[int]] = {j: [] for j in kept}
    for j in kept:
        if j != 0:
            children[int(body_of[sk.parents[j]])].append(j)
    ends: dict[int, list[FloatArray]] = {j: [] for j in kept}
    for e, p in enumerate(sk.end_site_parents):
        ends[int(body_of[p])].append(rest.positions[sk.num_joints + e])

    # joint ranges from the motion: local rotation of each kept joint relative to its parent body
    moving = motion_points(motion)
    ranges: dict[int, float] = {}
    for j in kept:
        if j == 0:
            continue
        gp = moving.rotations[:, int(body_of[sk.parents[j]])]  # type: ignore[index]
        gj = moving.rotations[:, j]  # type: ignore[index]
        local = np.transpose(gp, (0, 2, 1)) @ gj
        ang = np.linalg.norm(Rotation.from_matrix(local).as_rotvec(), axis=1)
        ranges[j] = float(min(np.pi, max(profile.range_min, ang.max() + profile.range_margin)))

    lo_r, hi_r = profile.radius_min * size, profile.radius_max * size
    bodies: list[BodyPlan] = []
    mass_of: dict[int, float] = {}
    # feet: end effectors that spend the motion low -- median height above the frame's lowest point
    # within FOOT_HEIGHT_FRACTION of the body's median height
    leaves = [j for j in kept if not children[j]]
    zs = moving.positions[:, :, 2]
    rel = zs - zs.min(axis=1, keepdims=True)
    body_h = float(np.median(rel.max(axis=1))) or 1e-9
    def tip_index(j: int) -> int:
        e = [k for k, p in enumerate(sk.end_site_parents) if body_of[p] == j]
        return sk.num_joints + e[0] if e else j
    feet = {j for j in leaves if np.median(rel[:, tip_index(j)]) <= FOOT_HEIGHT_FRACTION * body_h} or set(leaves)
    for j in kept:
        targets = [pos[c] for c in children[j]] + ends[j]
        geoms = []
        for t in targets:
            length = float(np.linalg.norm(t - pos[j]))
            if length < MIN_CAPSULE_M:
                continue
            r = float(np.clip(profile.radius_fraction * length, lo_r, hi_r))
            vol = np.pi * r * r * length + 4.0 / 3.0 * np.pi * r ** 3
            geoms.append(GeomPlan(kind="capsule", size=[r], fromto=[0.0, 0.0, 0.0, *(t - pos[j])],
                                  mass=profile.density * vol))
        if not geoms:
            r = float(lo_r)
            geoms.append(GeomPlan(kind="sphere", size=[r], pos=[0.0, 0.0, 0.0],
                                  mass=profile.density * 4.0 / 3.0 * np.pi * r ** 3))
        mass_of[j] = sum(g.mass for g in geoms)
        sites = []
        if j in leaves:
            tip = ends[j][0] if ends[j] else pos[j]
            r = max(g.size[0] for g in geoms) + 0.01 * size
            sites.append(SitePlan(name=f"{names[j]}_touch", pos=list(tip - pos[j]), size=[r], touch=True))
        joints = []
        if j != 0:
            joints.append(JointPlan(name=f"{names[j]}_ball", kind="ball", axis=[0.0, 0.0, 1.0],
                                    range=[0.0, ranges[j]], group="ball"))
        bodies.append(BodyPlan(name=names[j], parent=None if j == 0 else names[int(body_of[sk.parents[j]])],
                               pos=[float(v) for v in pos[j]], source=sk.names[j], joints=joints, geoms=geoms,
                               sites=sites, fit=FitPlan(method="ref", origin=sk.names[j], ref=f"bvh:{sk.names[j]}"),
                               is_foot=j in feet))
    target = total_mass if total_mass is not None else profile.total_mass
    scale = 1.0
    if target is not None:
        scale = target / sum(mass_of.values())
        for b in bodies:
            for g in b.geoms:
                g.mass *= scale
    # motor strength from the subtree each joint carries
    order = {j: i for i, j in enumerate(kept)}
    sub_mass = {j: mass_of[j] * scale for j in kept}
    reach = {j: 0.0 for j in kept}
    for j in reversed(kept):
        tips = [pos[c] for c in children[j]] + ends[j]
        reach[j] = max([float(np.linalg.norm(t - pos[j])) for t in tips] +
                       [float(np.linalg.norm(pos[c] - pos[j])) + reach[c] for c in children[j]] + [0.0])
        for c in children[j]:
            sub_mass[j] += sub_mass[c]
    kp_unit, kd_unit = profile.gains
    for j in kept:
        if j == 0:
            continue
        b = bodies[order[j]]
        scale_j = sub_mass[j] * max(reach[j], 0.05 * size)
        b.joints[0].torque = float(profile.torque_scale * scale_j * GRAVITY)
        b.joints[0].kp = float(kp_unit * scale_j)
        b.joints[0].kd = float(kd_unit * scale_j)
    lift = -min(b.pos[2] - (g.size[0] if g.kind != "box" else g.size[2]) for b in bodies for g in b.geoms)
    for b in bodies:
        b.pos[2] += lift
    markers = {sk.names[j]: ["body", names[j]] for j in kept}
    return BodyPlanSet(name=name, profile="creature", bodies=bodies, heading_yaw=0.0,
                       source_names=list(sk.names), sim=asdict(profile.sim),
                       extra={"markers": markers, "merged": [sk.names[j] for j in range(sk.num_joints)
                                                             if body_of[j] != j],
                              "size_m": size, "rest_lift": lift})
