"""Hierarchical evolution: breed two parent motions into a child motion.

The four steps are separate functions:

0. Correspondence -- a static root at the floor with the body's translation on its child is folded
   away (:mod:`bipedsim.motion.reroot`); without a user mapping the joints are paired by role
   (:func:`bipedsim.motion.correspondence.correspondence`: names in the usual conventions, else structure and
   geometry). The pairs and why each was made go to the report and can be saved as a ``--map`` file.
1. :func:`crossover` -- a meta-skeleton holding every joint of both parents: joints that correspond
   (the pairs above, same names, or -- for the roots -- the structural rule that both roots are the
   bodies' roots) are kept once; the others are appended under the joint their parent maps to.
2. :func:`mutate` -- each joint's activity is the standard deviation over time of the angle its bone
   turns between consecutive frames (cos theta = X(t).X(t-1) / |X(t)||X(t-1)|). The parents' activity
   vectors are standardised and combined by PCA over the pair (the first principal component's
   weights); a joint then scores as its liveliest descendant (removing it removes them all), user
   weights are added (negative: more likely to go), and the N lowest-scored joints are removed with
   their subtrees.
3. :func:`survivor` -- parent A is sampled every ``sample_every`` frames; for each sample the window of
   parent B with the smallest motion difference (least "energy loss") is found; the correction d is
   the rotation from A to that B window on the joints both have (rotation vectors, interpolated between
   samples); the child is C(t) = C1(t) + x d(t), i.e. A's rotation turned by x of the correction.
   Joints only one parent has take that parent's motion (B's at the matched time).
4. :func:`floor_constraint` -- no joint below the floor: offending joints are lifted by the smallest
   rotation of the bone above them (a one-joint IK step, parents first); joints above stay unchanged.

All motions here are in the project frame (metres, Z up). The steps live in
:mod:`~bipedsim.synthesis.breed.meta_skeleton`, :mod:`~bipedsim.synthesis.breed.mutation`,
:mod:`~bipedsim.synthesis.breed.transfer` (with :mod:`~bipedsim.synthesis.breed.alignment`, the
rest-pose alignment) and :mod:`~bipedsim.synthesis.breed.floor`; this module runs them in order (:func:`breed`).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.motion.correspondence import correspondence
from bipedsim.motion.motion import Motion
from bipedsim.motion.reroot import fold_static_root
from bipedsim.motion.skeleton import Skeleton
from bipedsim.synthesis.breed.alignment import (
    _folded_b_joints,
    across_unpaired,
    in_rest_of,
    on_standing_rest,
    on_typical_rest,
)
from bipedsim.synthesis.breed.feasible import foot_heights, hold_feet_down
from bipedsim.synthesis.breed.floor import floor_constraint
from bipedsim.synthesis.breed.limits import X_RANGE, BreedError, max_breed_frames
from bipedsim.synthesis.breed.meta_skeleton import MetaSkeleton, crossover, load_joint_map
from bipedsim.synthesis.breed.mutation import joint_activity, leg_roots, mutate, support_joints
from bipedsim.synthesis.breed.transfer import blend, survivor

__all__ = ["X_RANGE", "BreedError", "BreedReport", "MetaSkeleton", "breed", "crossover", "depth_first",
           "floor_constraint", "joint_activity", "load_joint_map", "mutate", "prune", "survivor"]

FloatArray = npt.NDArray[np.float64]


def depth_first(motion: Motion) -> Motion:
    """The motion with its joints in depth-first order (each joint's subtree right after it), the
    order a BVH file lists them in: the crossover appends B's joints after all of A's, and a skeleton
    not in file order would be written with its channel columns out of step with its hierarchy."""
    sk = motion.skeleton
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(sk.children(j)))
    if order == list(range(sk.num_joints)):
        return motion
    new = {j: i for i, j in enumerate(order)}
    es = sorted(range(len(sk.end_site_parents)), key=lambda e: new[int(sk.end_site_parents[e])])
    out = Skeleton(names=tuple(sk.names[j] for j in order),
                   parents=np.array([-1 if sk.parents[j] < 0 else new[int(sk.parents[j])] for j in order]),
                   offsets=sk.offsets[order], channels=tuple(sk.channels[j] for j in order),
                   position_modes=tuple(sk.position_modes[j] for j in order),
                   end_site_parents=np.array([new[int(sk.end_site_parents[e])] for e in es], dtype=np.int64),
                   end_site_offsets=sk.end_site_offsets[es].reshape(-1, 3))
    return motion.copy(skeleton=out, rotations=motion.rotations[:, order],
                       translations=None if motion.translations is None else motion.translations[:, order])


# ---------------------------------------------------------------------- the whole breeding
@dataclass
class BreedReport:
    parents: list[str]
    x: float
    mutations: int
    kept_common: list[str] = field(default_factory=list)
    only_a: list[str] = field(default_factory=list)
    only_b: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)
    removed_with_subtrees: list[str] = field(default_factory=list)
    #: the parents' feet (joints measured as carrying them in their clips): never removed, nor above them
    feet_kept: list[str] = field(default_factory=list)
    activity: dict[str, float] = field(default_factory=dict)
    pca_weights: tuple[float, float] = (0.0, 0.0)
    floor_fixes: int = 0
    timings_s: dict[str, float] = field(default_factory=dict)
    child_joints: int = 0
    child_frames: int = 0
    #: joint of A -> joint of B, as a ``--map`` file holds it (the pairs the breeding used)
    correspondence: dict[str, str] = field(default_factory=dict)
    #: joint of A -> why it was paired ("left leg knee", "trunk below chest", "same name", "--map")
    correspondence_reasons: dict[str, str] = field(default_factory=dict)
    map_source: str = "roles"  #: "roles" (found automatically) or the --map file
    #: per parent ("A"/"B"): the static root folded away and the joint that became the root
    folded_roots: dict[str, dict[str, str]] = field(default_factory=dict)
    #: per parent: what decided its roles (names or geometry, and how the facing direction was found)
    role_evidence: dict[str, dict[str, str]] = field(default_factory=dict)
    #: per parent: joint -> the role found for it ("left leg knee", "chest", "trunk"...), paired or not
    roles: dict[str, dict[str, str]] = field(default_factory=dict)
    #: joint -> the parent ("A"/"B") whose motion it takes whole: a joint that carries a leg in one parent
    #: and none in the other (a dog's fore leg paired with a flamingo's wing, a dog's chest with a human's)
    #: moves as in the parent nearer x
    limbs_from_one_parent: dict[str, str] = field(default_factory=dict)
    #: joint -> the x it blends at, lowered (toward the side parent) so that no foot the side parent stands
    #: on is lifted by the blend (:mod:`~bipedsim.synthesis.breed.feasible`)
    feet_held_down: dict[str, float] = field(default_factory=dict)
    #: the body kind ``bipedsim run`` builds for the child ("humanoid"/"creature"; "" when not checked)
    body: str = ""
    #: whether ``bipedsim run`` detects that kind by itself (False: give it with --profile)
    body_detected: bool = True

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def prune(meta: MetaSkeleton, rotations: FloatArray, motion_a: Motion, removed: set[str]) -> tuple[Skeleton,
                                                                                                    list[int]]:
    sk = meta.skeleton
    keep = [j for j in range(sk.num_joints) if sk.names[j] not in removed]
    new_index = {j: k for k, j in enumerate(keep)}
    parents = [-1 if sk.parents[j] < 0 else new_index[int(sk.parents[j])] for j in keep]
    es = [(new_index[int(p)], sk.end_site_offsets[e]) for e, p in enumerate(sk.end_site_parents) if int(p) in new_index]
    child = Skeleton(names=tuple(sk.names[j] for j in keep), parents=np.array(parents),
                     offsets=sk.offsets[keep], channels=tuple(
                         tuple(c for c in sk.channels[j] if c.endswith("rotation")) if j else sk.channels[j]
                         for j in keep),
                     end_site_parents=np.array([p for p, _ in es], dtype=np.int64),
                     end_site_offsets=np.array([o for _, o in es]).reshape(-1, 3))
    return child, keep


def breed(a: Motion, b: Motion, *, x: float = 0.5, mutations: int = 5, weights: dict[str, float] | None = None,
          mapping: dict[str, str] | None = None, names: tuple[str, str] = ("A", "B")) -> tuple[Motion, BreedReport]:
    """Breed two motions (project frame) into a child motion on the pruned meta-skeleton.

    ``mapping``: joint of A -> joint of B, the whole correspondence (joints it leaves out are paired
    only when their names are equal); None: found by role. A static root at the floor is folded into
    the joint that carries the translation first (a mapping may name either)."""
    if not X_RANGE[0] <= x <= X_RANGE[1]:
        raise BreedError(f"x must be in [{X_RANGE[0]}, {X_RANGE[1]}] (0: parent A's motion, 1: B's), got {x}")
    most = max_breed_frames()
    for who, n in ((f"parent A {names[0]}", a.num_frames),
                   (f"parent B {names[1]}", int(b.duration / a.frame_time) + 1)):  # B is played at A's rate
        if n > most:
            raise BreedError(f"{who} has {n} frames at parent A's frame rate ({1 / a.frame_time:g} fps); breeding "
                             f"compares every frame of A with every frame of B, at most {most} frames each: cut "
                             "the file, or set BIPEDSIM_MAX_BREED_FRAMES to allow more")
    tm: dict[str, float] = {}
    t0 = time.perf_counter()
    a, fold_a = fold_static_root(a.to_project_frame())
    b, fold_b = fold_static_root(b.to_project_frame())
    # local rotations are blended: both parents rebased on their own typical pose (FK unchanged), so
    # that similar poses are similar rotations, small ones from the rest, whatever rest pose (along X,
    # standing) and twist of joint frames a file has
    folded = {p: {"root": f.root, "into": f.into} for p, f in (("A", fold_a), ("B", fold_b)) if f is not None}
    evidence: dict[str, dict[str, str]] = {}
    roles: dict[str, dict[str, str]] = {}
    if mapping is None:
        corr = correspondence(a, b)
        mapping, reasons, source = corr.pairs, corr.reasons, "roles"
        evidence = {"A": corr.roles_a.evidence, "B": corr.roles_b.evidence}
        roles = {"A": corr.roles_a.joint_roles(), "B": corr.roles_b.joint_roles()}
    else:
        alias_a = {fold_a.root: fold_a.into} if fold_a else {}
        alias_b = {fold_b.root: fold_b.into} if fold_b else {}
        mapping = {alias_a.get(k, k): alias_b.get(v, v) for k, v in mapping.items()}
        reasons, source = {k: "--map" for k in mapping}, "--map"
    tm["correspondence"] = time.perf_counter() - t0
    feet_a, feet_b = support_joints(a), support_joints(b)  # what each parent stands on, from its clip
    stood_a, stood_b = foot_heights(a, feet_a), foot_heights(b, feet_b)
    carry_a = carrying_joints(a.skeleton, leg_roots(a))
    carry_b = carrying_joints(b.skeleton, leg_roots(b))
    if not np.isclose(a.frame_time, b.frame_time):
        b = b.resample(a.fps)
    a, b = on_typical_rest(a), on_typical_rest(b)
    t0 = time.perf_counter()
    meta = crossover(a.skeleton, b.skeleton, mapping)
    # B's rotations re-expressed in A's rest pose: local rotations are blended, and rotations from
    # rest poses that differ (one along X, one standing) mean different poses
    b = in_rest_of(a.skeleton, b, {int(jb): i for i, jb in enumerate(meta.from_b[:a.num_joints]) if jb is not None})
    meta = crossover(a.skeleton, b.skeleton, mapping)
    act_a, act_b = joint_activity(a), joint_activity(b)  # from B's own FK, before the folding below
    b = across_unpaired(meta, a.skeleton, b)
    tm["crossover"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    feet = {i for i in range(meta.skeleton.num_joints)
            if (meta.from_a[i] is not None and a.skeleton.names[meta.from_a[i]] in feet_a)
            or (meta.from_b[i] is not None and b.skeleton.names[meta.from_b[i]] in feet_b)}
    mut = mutate(meta, act_a, act_b, mutations, weights, keep=feet)
    tm["mutation"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    one_parent = limb_roles(meta, a.skeleton, b.skeleton, carry_a, carry_b, x)
    surv = survivor(meta, a, b, x=x, x_joints=one_parent)
    tm["survivor"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    child_sk, keep = prune(meta, surv.rotations, a, set(mut.removed_all) | set(_folded_b_joints(meta, b.skeleton)))

    def child_of(x_joints: dict[int, float]) -> Motion:
        rot = blend(meta, a, b, x, surv.correction, surv.matched, x_joints)
        return Motion(skeleton=child_sk, frame_time=a.frame_time, root_translation=a.root_translation.copy(),
                      rotations=rot[:, keep], unit=1.0, up="z")

    # the side parent's feet, by their names in the child (B's through the pairing)
    # the feet the child stands on, by their names in the child, with the height each stood at in its
    # parent: A's feet on A's bones; above x 0.5 also B's other feet (a foot is measured on its own bones)
    stands_on = {meta.skeleton.names[i]: stood_a[a.skeleton.names[j]] for i, j in enumerate(meta.from_a)
                 if j is not None and a.skeleton.names[j] in stood_a}
    if x > ROLE_FROM_A_UP_TO_X:
        for i, j in enumerate(meta.from_b):
            if j is not None and b.skeleton.names[j] in stood_b and meta.skeleton.names[i] not in stands_on:
                stands_on[meta.skeleton.names[i]] = stood_b[b.skeleton.names[j]]
    stands_on = {n: h for n, h in stands_on.items() if n in child_sk.names}
    x_joints = hold_feet_down(meta, x, 0.0 if x <= ROLE_FROM_A_UP_TO_X else 1.0, one_parent, stands_on, child_of)
    child, fixes = floor_constraint(depth_first(child_of(x_joints)))
    child = on_standing_rest(child)  # the rest its body is built in: standing, left and right limbs alike
    tm["constraint"] = time.perf_counter() - t0
    sk = meta.skeleton
    limbs = sorted(sk.names[i] for i in one_parent)
    rep = BreedReport(parents=list(names), x=x, mutations=mutations,
                      kept_common=[sk.names[i] for i in meta.common],
                      only_a=[sk.names[i] for i in range(sk.num_joints) if meta.from_b[i] is None],
                      only_b=[sk.names[i] for i in range(sk.num_joints) if meta.from_a[i] is None],
                      removed=mut.removed, removed_with_subtrees=mut.removed_all, activity=mut.scores,
                      pca_weights=mut.pca_weights, floor_fixes=fixes, timings_s=tm,
                      child_joints=child_sk.num_joints, child_frames=child.num_frames,
                      correspondence=_pairs_used(meta, b.skeleton), correspondence_reasons=_reasons_used(meta, reasons),
                      map_source=source, folded_roots=folded, role_evidence=evidence, roles=roles,
                      feet_kept=sorted(meta.skeleton.names[i] for i in feet),
                      limbs_from_one_parent={n: ("A" if one_parent[sk.index(n)] == 0.0 else "B") for n in limbs},
                      feet_held_down={sk.names[i]: round(v, 4) for i, v in sorted(x_joints.items())
                                      if one_parent.get(i) != v})
    return child, rep


#: at this x or below a joint whose role differs between the parents moves as parent A's (the child's
#: bones are A's where they share joints), above it as B's
ROLE_FROM_A_UP_TO_X = 0.5


def carrying_joints(sk: Skeleton, leg_roots: set[str]) -> set[str]:
    """Names of the joints of ``sk`` that carry a leg (``leg_roots``: the legs' root joints): every
    joint of a leg, and every joint between the root and a leg's root (a dog's spine and chest carry
    its fore legs; a human's chest carries only arms)."""
    out: set[str] = set()
    for r in leg_roots:
        if r not in sk.names:
            continue
        out.update(sk.names[j] for j in sk.subtree(sk.index(r)))
        j = int(sk.parents[sk.index(r)])
        while j >= 0:
            out.add(sk.names[j])
            j = int(sk.parents[j])
    return out


def limb_roles(meta: MetaSkeleton, a: Skeleton, b: Skeleton, carry_a: set[str], carry_b: set[str],
               x: float) -> dict[int, float]:
    """Meta joints paired between the parents that carry a leg in one parent and none in the other
    (``carry_a``/``carry_b``: :func:`carrying_joints`, the legs measured from each clip) -> the x their
    motion takes: 0 (A's) when ``x`` <= :data:`ROLE_FROM_A_UP_TO_X`, else 1 (B's). Blended, such a joint
    is neither: a dog's fore leg turned half way to a flamingo's folded wing hangs 0.2-0.3 of the
    height above the floor (the child fell on it within 2 s), and a dog's chest turned half way to a
    human's upright one lifts its fore legs off the floor."""
    side = 0.0 if x <= ROLE_FROM_A_UP_TO_X else 1.0
    out: dict[int, float] = {}
    for i in meta.common:
        in_a = a.names[meta.from_a[i]] in carry_a  # type: ignore[index]
        in_b = b.names[meta.from_b[i]] in carry_b  # type: ignore[index]
        if in_a != in_b:
            out[i] = side
    return out


def _pairs_used(meta: MetaSkeleton, b: Skeleton) -> dict[str, str]:
    return {meta.skeleton.names[i]: b.names[meta.from_b[i]] for i in meta.common}  # type: ignore[index]


def _reasons_used(meta: MetaSkeleton, reasons: dict[str, str]) -> dict[str, str]:
    return {meta.skeleton.names[i]: reasons.get(meta.skeleton.names[i], "same name") for i in meta.common}
