"""A creature's feet: the end effectors low over its motion, then on more than two legs the segments
the clip stands on (see :func:`carrying_feet`), with what hangs below them folded in (:func:`fold_feet`).

Heights in m (world z, project frame); shares of the motion's frames in 0-1.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from bipedsim.model.creature_kind import MIN_LEG_JOINTS
from bipedsim.model.creature_sole import SOLE_MAX_LEGS
from bipedsim.model.creature_tree import BodyTree
from bipedsim.model.source import SourcePoints

FloatArray = npt.NDArray[np.float64]

#: End effectors whose rest height is within this fraction of the body's height from the bottom are
#: feet (contact labels, fall detection).
FOOT_HEIGHT_FRACTION = 0.25
#: a segment is at the floor on a frame when the lowest of its bones' ends is within this fraction of the
#: body's size (m/m) of the whole body's lowest point on that frame: more than a foot's own thickness (a
#: sole's joints sit a centimetre or two above its toes' tips), less than a hoof's joint stands over its tip
CONTACT_TOLERANCE_FRACTION = 0.02
#: along a leg, a segment carries when it is at the floor on at least this share of the standing frames
#: its leg's most carrying segment is (0-1): a sole and the toes flat beside it both do
CARRY_RATIO = 0.5
#: a frame counts when the body stands: its joints' mean height over its lowest point at least this share
#: of its median over the motion (0-1); a shin or forearm resting on the floor while the animal lies (the
#: tenth of a take that gets up) carries nothing
STANDING_FRACTION = 0.75


def low_end_effectors(tree: BodyTree, moving: SourcePoints) -> set[int]:
    """The end effectors (kept joints with no child body) that spend the motion low: median height of
    their tip above the frame's lowest point within FOOT_HEIGHT_FRACTION of the body's median height;
    every end effector when none does."""
    sk = tree.skeleton
    leaves = [j for j in tree.kept if not tree.children[j]]
    zs = moving.positions[:, :, 2]
    rel = zs - zs.min(axis=1, keepdims=True)
    body_h = float(np.median(rel.max(axis=1))) or 1e-9

    def tip_index(j: int) -> int:
        e = [k for k, p in enumerate(sk.end_site_parents) if tree.body_of[p] == j]
        return sk.num_joints + e[0] if e else j

    return {j for j in leaves if np.median(rel[:, tip_index(j)]) <= FOOT_HEIGHT_FRACTION * body_h} or set(leaves)


def _segment_bottoms(tree: BodyTree, moving: SourcePoints) -> dict[int, FloatArray]:
    """Per kept joint: the lowest of its bones' far ends (m, world z; one per frame): the child joints
    and End Sites its body reaches, where the segment meets the floor when it stands on it (its own
    joint is its parent's bone's end); the joint itself for a body with no bone."""
    zs = moving.positions[:, :, 2]
    return {j: zs[:, [t for _, t in tree.bone_points(j)] or [j]].min(axis=1) for j in tree.kept}


def carrying_feet(tree: BodyTree, moving: SourcePoints, size: float,
                  legs: Sequence[tuple[str, Sequence[str]]]) -> dict[int, int]:
    """Each foot whose leg stands on a segment above it -> that segment (kept joints; {} when every leaf
    carries, or on at most SOLE_MAX_LEGS legs). ``legs``: each leg's root body and its feet (body names).

    A segment is at the floor on a frame when the lowest end of its bones is within
    CONTACT_TOLERANCE_FRACTION x ``size`` (m) of the whole body's lowest point; only the frames the body
    stands on count (STANDING_FRACTION). Along each foot's chain from its leg's root (at least
    MIN_LEG_JOINTS bodies kept in the leg), a segment carries when it is at the floor on at least
    CARRY_RATIO of the frames the chain's most often grounded segment is, and the foot is
    the highest segment that carries: what hangs below it and touches too (toes or fingers lying flat
    beside a sole or palm) is part of the same foot, what hangs below and never touches (a dewclaw) is no
    foot at all. A chain never at the floor keeps its leaf."""
    if len(legs) <= SOLE_MAX_LEGS:
        return {}
    bottoms = _segment_bottoms(tree, moving)
    floor = np.min(np.stack(list(bottoms.values())), axis=0)
    mean_h = moving.positions[:, :, 2].mean(axis=1) - floor
    standing = mean_h >= STANDING_FRACTION * float(np.median(mean_h))
    tol = CONTACT_TOLERANCE_FRACTION * size
    share = {j: float(np.mean((b - floor <= tol)[standing])) for j, b in bottoms.items()}
    by_name = {tree.names[j]: j for j in tree.kept}
    out: dict[int, int] = {}
    for leg_root, leg_feet in legs:
        root = by_name[leg_root]
        for f in leg_feet:
            chain = [by_name[f]]
            while chain[-1] != root:
                chain.append(tree.parent_body(chain[-1]))
            chain.reverse()  # the leg's root first
            below = chain[MIN_LEG_JOINTS - 1:]
            most = max(share[j] for j in below)
            carrying = [j for j in below if most > 0 and share[j] >= CARRY_RATIO * most]
            if carrying and carrying[0] != by_name[f]:
                out[by_name[f]] = carrying[0]
    return out


def fold_feet(tree: BodyTree, rest: SourcePoints, moving: SourcePoints, feet: set[int],
          carrying: dict[int, int]) -> tuple[BodyTree, set[int]]:
    """``tree`` with every body below a carrying segment (``carrying``'s values) folded into it: their
    bones become the segment's, their joints merge into its body; returns the tree and its feet (each of
    ``feet`` replaced by the carrying segment above it). The folded foot's touch point is its joint or
    End Site with the lowest median height above the body's lowest point over the motion."""
    sk = tree.skeleton

    def top_above(j: int, tops: set[int]) -> int | None:
        while j != 0:
            j = tree.parent_body(j)
            if j in tops:
                return j
        return None

    tops = set(carrying.values())
    tops = {c for c in tops if top_above(c, tops) is None}  # a segment below another is folded into it
    body_of = tree.body_of.copy()
    folded: dict[int, list[tuple[FloatArray, FloatArray]]] = {c: [] for c in tops}
    kept = []
    for j in tree.kept:  # parents first
        top = top_above(j, tops)
        if top is None:
            kept.append(j)
            continue
        folded[top] += tree.bones(j)
        body_of[tree.body_of == j] = top
    for c in tops:
        folded[c] += [(tree.pos[c], tree.pos[k]) for k in tree.children[c]]
    zs = moving.positions[:, :, 2]
    rel = zs - zs.min(axis=1, keepdims=True)
    tips = {}
    for c in tops:
        points = [k for k in range(sk.num_joints) if body_of[k] == c]
        points += [sk.num_joints + e for e, p in enumerate(sk.end_site_parents) if body_of[p] == c]
        low = min(points, key=lambda k: float(np.median(rel[:, k])))
        tips[c] = rest.positions[low]
    new = BodyTree(skeleton=sk, pos=tree.pos, body_of=body_of, kept=kept,
                children={j: [] if j in tops else list(tree.children[j]) for j in kept},
                ends={j: tree.ends[j] for j in kept}, names={j: tree.names[j] for j in kept},
                folded=folded, tips=tips)
    return new, {int(body_of[f]) for f in feet}


__all__ = ["CARRY_RATIO", "CONTACT_TOLERANCE_FRACTION", "FOOT_HEIGHT_FRACTION", "STANDING_FRACTION", "carrying_feet",
           "fold_feet", "low_end_effectors"]
