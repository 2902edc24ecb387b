"""Which body kind a skeleton is, measured from its motion: a human-like upright biped gets the
humanoid body and balance controller, anything else (quadrupeds, birds, bred chimeras) the creature's.

Nothing here reads joint names. From the motion's joint and End Site positions (project frame: m, Z up):

- **feet**: end effectors whose tip spends the motion low (median height above the frame's lowest
  point within :data:`FOOT_HEIGHT_FRACTION` of the body's median height);
- **legs**: each foot's chain walked up from the tip while the joint's whole subtree ends only in
  feet; feet sharing that leg root are one leg (a bird's three toes), and the leg root is never the
  skeleton's root; a leg bends (at least :data:`MIN_LEG_JOINTS` joints from its root to the foot): a
  single bone hanging low from the trunk (a flying reptile's short tail) cannot step;
- **trunk**: the direction from the legs' roots (hips) to the centroid of every joint that is in no
  leg; upright when it is within :data:`UPRIGHT_MAX_RAD` of vertical;
- **arms**: non-leg chains that leave the trunk sideways (their tips farther from the trunk's line
  than :data:`ARM_REACH_FRACTION` of the height);
- **proportions**: the hips at :data:`HIP_HEIGHT_RANGE` of the standing height.

Humanoid = two legs, an upright trunk above the hips, arms, human proportions; else creature.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from bipedsim.errors import ModelError
from bipedsim.model.source import motion_points
from bipedsim.motion.bvh import read_bvh
from bipedsim.motion.helper_bones import drop_helper_bones
from bipedsim.motion.motion import Motion, check_extent
from bipedsim.motion.reroot import fold_static_root

if TYPE_CHECKING:
    from bipedsim.motion.bvh import BVHInfo

#: the ``--profile`` value that measures the body kind from the skeleton
AUTO = "auto"
#: an end effector is a foot when its median tip height is within this fraction of the body's height
FOOT_HEIGHT_FRACTION = 0.25
#: a leg has at least this many joints from its root down to its foot (a hip and a knee)
MIN_LEG_JOINTS = 2
#: a joint from which two branches each reach down from at least this fraction of the body's height to
#: the floor joins two legs (a pelvis bone between the root and both thighs, as in MakeHuman's skeleton);
#: a foot's toes branch near the floor
LEG_BRANCH_FRACTION = 0.15
#: a tip within this fraction of the body's height of a leg's bone is a helper's on that bone (twist,
#: roll and share bones, mesh helpers: ActorCore's CalfTwist and KneeShareBone, HumanIK's LegRoll,
#: MotionBuilder's *_RIGMESH), no branch of its own: the leg is walked up past it
HELPER_FRACTION = 0.05
#: largest angle (rad) from vertical of the hips -> upper-body-centroid line of an upright trunk: a
#: human walk leans 3-16 deg, a crouch 50, a flamingo's body 101 (the bones' length-weighted
#: centroid, :func:`_trunk_centroid`)
UPRIGHT_MAX_RAD = np.radians(60.0)
#: hip height as a fraction of the standing height (top of the body) for human proportions: 0.53 of
#: the stature with a head (Drillis & Contini), up to about 0.65 of the shoulder height when the head is
#: missing (a bred child whose head a mutation removed), more in a crouch; 0.8 leaves that margin
HIP_HEIGHT_RANGE = (0.35, 0.8)
#: an arm's tip lies at least this fraction of the height from the trunk's line (any frame's median),
ARM_REACH_FRACTION = 0.12
#: or its chain is at least this fraction of the height long, along its bones from where it leaves the
#: spine (the joints up to the highest tip): arms hanging by the sides of a slender walker (a Rokoko
#: take's fingertips 0.07-0.10 of the height from the trunk's line) are 0.4-0.5 of the height long from
#: the chest, 0.4 to the wrist; a head is part of the spine, and a neck's side branches are short
ARM_LENGTH_FRACTION = 0.3


@dataclass(frozen=True)
class BodyKind:
    """What :func:`detect_body_kind` measured and decided."""

    kind: str  #: "humanoid" or "creature"
    legs: tuple[tuple[str, tuple[str, ...]], ...]  #: (leg root joint, its feet' joints) per leg
    trunk_tilt_rad: float  #: hips -> upper-body centroid, angle from vertical (median over frames)
    hip_height_fraction: float  #: hip height / standing height (median over frames)
    arms: int  #: non-leg chains reaching sideways from the trunk
    reason: str  #: one line: why this kind

    def describe(self) -> str:
        return (f"{self.kind}: {len(self.legs)} legs, trunk {np.degrees(self.trunk_tilt_rad):.0f} deg from "
                f"vertical, hips at {self.hip_height_fraction:.2f} of the height, {self.arms} arms ({self.reason})")


def _subtree_tips(parents: np.ndarray, end_parents: list[int], n: int) -> list[set[int]]:
    """Per joint, the tips (End Site indices offset by ``n``, or leaf joints) of its subtree."""
    tips: list[set[int]] = [set() for _ in range(n)]
    has_child = np.zeros(n, dtype=bool)
    has_child[[p for p in parents[1:]]] = True
    for e, p in enumerate(end_parents):
        tips[p].add(n + e)
    for j in range(n):
        if not has_child[j] and not tips[j]:
            tips[j].add(j)
    for j in range(n - 1, 0, -1):  # parents come first in a skeleton
        tips[int(parents[j])] |= tips[j]
    return tips


def _chain_joints(parents: np.ndarray, j: int, root: int) -> int:
    """How many joints the chain from ``root`` down to its descendant ``j`` holds (both counted)."""
    k = 1
    while j != root:
        j = int(parents[j])
        k += 1
    return k


def detect_body_kind(motion: Motion) -> BodyKind:
    """The body kind of ``motion``'s skeleton (see the module text); ``motion`` in any frame."""
    if motion.up != "z" or motion.unit != 1.0:
        motion = motion.to_project_frame()
    sk = motion.skeleton
    n = sk.num_joints
    pts = motion_points(motion).positions  # (T, n + ends, 3)
    # a static root above the joint that carries the travel (a game export's joint at the floor or
    # anywhere) is no part of the body: its height, trunk and arms are measured without it
    body = np.ones(pts.shape[1], dtype=bool)
    j = motion.travel_joint()
    while j > 0:
        j = int(sk.parents[j])
        body[j] = False
    z = pts[:, :, 2]
    rel = z - z[:, body].min(axis=1, keepdims=True)
    height = float(np.median(rel[:, body].max(axis=1))) or 1e-9
    parents = np.asarray(sk.parents)
    tips = _subtree_tips(parents, list(sk.end_site_parents), n)
    all_tips = sorted(set().union(*tips)) if n else []
    low = {t for t in all_tips if np.median(rel[:, t]) <= FOOT_HEIGHT_FRACTION * height}
    def tall(c: int) -> bool:  # the branch at joint c reaches from well above the floor down to it
        under = [t for t in tips[c] if t in low]
        return bool(under) and float(np.median(z[:, c] - z[:, under].min(axis=1))) >= LEG_BRANCH_FRACTION * height

    def joins_legs(p: int) -> bool:  # p is where two legs meet (a pelvis bone above both), not a foot's toes
        return sum(tall(int(c)) for c in np.flatnonzero(parents == p) if c != p) >= 2

    def on_bones(t: int, chain: list[int]) -> bool:  # tip t lies on one of the bones joining ``chain``
        pt = pts[:, t]
        best = np.full(pts.shape[0], np.inf)
        for a, b in zip(chain[:-1], chain[1:]):
            pa, ab = pts[:, a], pts[:, b] - pts[:, a]
            u = np.clip(np.sum((pt - pa) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-12), 0.0, 1.0)
            best = np.minimum(best, np.linalg.norm(pa + u[:, None] * ab - pt, axis=1))
        return float(np.median(best)) <= HELPER_FRACTION * height

    legs: dict[int, list[int]] = {}
    for t in sorted(low):
        j = t if t < n else int(sk.end_site_parents[t - n])
        chain = [t, j] if t >= n else [j]  # the foot's tip up to j: a helper's tip on these bones is no branch
        while j > 0 and parents[j] > 0 and not joins_legs(int(parents[j])):
            p = int(parents[j])
            if not all(u in low or on_bones(u, chain + [p]) for u in tips[p]):
                break
            j = p
            chain.append(j)
        if j == 0 or _chain_joints(parents, t if t < n else int(sk.end_site_parents[t - n]), j) < MIN_LEG_JOINTS:
            continue
        legs.setdefault(j, []).append(t)
    in_leg = np.zeros(n, dtype=bool)
    for root in legs:
        stack = [root]
        while stack:
            j = stack.pop()
            in_leg[j] = True
            stack.extend(int(c) for c in np.flatnonzero(parents == j) if c != j)
    hips = pts[:, list(legs), :].mean(axis=1) if legs else pts[:, 0, :]
    trunk = ~in_leg & body[:n]
    d = _trunk_centroid(pts, parents, sk.end_site_parents, trunk, n) - hips
    tilt = float(np.median(np.arctan2(np.linalg.norm(d[:, :2], axis=1), d[:, 2])))
    hip_frac = float(np.median((hips[:, 2] - z[:, body].min(axis=1)) / np.maximum(rel[:, body].max(axis=1), 1e-9)))
    axis = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)

    def joint_of(t: int) -> int:
        return t if t < n else int(sk.end_site_parents[t - n])

    upper_tips = [t for t in all_tips if not in_leg[joint_of(t)] and t not in low and body[t]]
    # the spine: the joints from the root up to the highest tip (the head's); an arm leaves it
    spine = set()
    if upper_tips:
        j = joint_of(max(upper_tips, key=lambda t: float(np.median(rel[:, t]))))
        while j >= 0:
            spine.add(j)
            j = int(parents[j])
    arms = 0
    for t in upper_tips:
        v = pts[:, t] - hips
        off = np.linalg.norm(v - np.sum(v * axis, axis=1, keepdims=True) * axis, axis=1)
        length, a = 0.0, t  # along the bones from the tip back to the spine
        while a not in spine and a > 0:
            b = joint_of(a) if a >= n else int(parents[a])
            length += float(np.median(np.linalg.norm(pts[:, a] - pts[:, b], axis=1)))
            a = b
        if np.median(off) >= ARM_REACH_FRACTION * height or length >= ARM_LENGTH_FRACTION * height:
            arms += 1
    named = tuple((sk.names[r], tuple(sk.names[t] if t < n else f"{sk.names[sk.end_site_parents[t - n]]}/End Site"
                                      for t in ts)) for r, ts in legs.items())
    kind, reason = _decide(len(legs), tilt, hip_frac, arms)
    return BodyKind(kind=kind, legs=named, trunk_tilt_rad=tilt, hip_height_fraction=hip_frac, arms=arms,
                    reason=reason)


def _trunk_centroid(pts: np.ndarray, parents: np.ndarray, end_parents: np.ndarray, trunk: np.ndarray,
                    n: int) -> np.ndarray:
    """(T, 3) centroid of the bones hanging from the ``trunk`` joints (the body less its legs), each
    bone's midpoint weighted by its length: where the upper body's mass lies. A count of joints would
    put it in the hands of a skeleton with fingers (Mixamo and Perception Neuron rigs: 40 of their
    ~60 joints; their walks measured 51-80 deg from vertical by joint count), or on a cluster of twist
    bones; the root (a point, no bone) counts by the bones from it."""
    child = [j for j in range(1, n) if trunk[int(parents[j])]] + [n + e for e, p in enumerate(end_parents)
                                                                     if trunk[int(p)]]
    by_count = pts[:, :n][:, trunk].mean(axis=1) if trunk.any() else pts[:, 0]
    if not child:
        return by_count
    par = [int(parents[c]) if c < n else int(end_parents[c - n]) for c in child]
    a, b = pts[:, par], pts[:, child]
    w = np.linalg.norm(b - a, axis=2)  # (T, bones)
    tot = w.sum(axis=1, keepdims=True)
    return np.where(tot > 1e-9, (0.5 * (a + b) * w[:, :, None]).sum(axis=1) / np.maximum(tot, 1e-9), by_count)


def _decide(legs: int, tilt: float, hip_frac: float, arms: int) -> tuple[str, str]:
    if legs != 2:
        return "creature", f"{legs} legs, not 2"
    if tilt > UPRIGHT_MAX_RAD:
        return "creature", f"trunk not upright (more than {np.degrees(UPRIGHT_MAX_RAD):.0f} deg from vertical)"
    lo, hi = HIP_HEIGHT_RANGE
    if not lo <= hip_frac <= hi:
        return "creature", f"hips at {hip_frac:.2f} of the height, outside {lo:g}-{hi:g}"
    if arms < 2:
        return "creature", "fewer than two arms"
    return "humanoid", "two legs, upright trunk above the hips, arms"


def resolve_profile(motion: Motion, profile: str | None = AUTO, *, support: bool = False,
                    source: str = "the motion") -> str:
    """The body kind to build ``motion`` (project frame) as: ``profile`` when it names one; for
    ``auto`` (or None) a creature when root ``support`` is asked for, else the kind measured from the
    skeleton. A skeleton in which fewer than two legs are found (feet: end effectors that stay low) is
    refused: it is probably misread, or needs ``--profile`` to say what it is."""
    if profile not in (None, AUTO):
        return str(profile)
    if support:
        return "creature"
    kind = detect_body_kind(motion)
    if len(kind.legs) < 2:
        raise ModelError(f"{source}: cannot tell the body kind: {len(kind.legs)} leg(s) found (a leg ends in "
                         "end effectors that stay near the ground); the file may be misread (check `bipedsim "
                         "info`, give --scale/--up) or give --profile humanoid|creature")
    return kind.kind


def read_source(path: str | os.PathLike[str], *, scale: float | str | None = None, up: str | None = None,
                  positions: str | None = None, profile: str | None = AUTO,
                  support: bool = False, fps: float | None = None,
                  fold_root: bool = True) -> tuple[Motion, BVHInfo, Motion, str]:
    """A BVH file read for the body it will build: the raw motion and what reading found, the motion in
    the project frame, and the body kind (:func:`resolve_profile`). A creature's unit, when guessed, is
    guessed from its largest extent, not a standing human's height: a bred dog x horse with its head up
    would otherwise read as a 1.3 m human in inches (2.54 x too large). ``fold_root``: a static root at
    the floor is folded away (False: left for the caller, as breeding reports it)."""
    raw, info = read_bvh(path, scale=scale, up=up, positions=positions, fps=fps)
    check_extent(raw, path)  # nothing below is computed from a corrupt or misread motion
    raw = _without_helpers(raw, info)
    motion = raw.to_project_frame()
    forced = profile not in (None, AUTO)
    profile = resolve_profile(motion, profile, support=support, source=str(path))
    # the unit follows what the skeleton is, not the controller asked for: a human walk run with
    # --profile creature keeps a human's unit (its largest extent would read CMU's inches as cm)
    shaped = profile == "creature" and (not forced or detect_body_kind(motion).kind == "creature")
    if shaped and info.unit_source == "guessed" and info.upright:
        raw, info = read_bvh(path, up=up, positions=positions, upright=False, fps=fps)
        check_extent(raw, path)  # read at another unit
        raw = _without_helpers(raw, info)
        motion = raw.to_project_frame()
    # a static root at the floor with the body's translation on its one child (a game-data layout):
    # the floor joint is folded away, not built as a bone
    raw, folded = fold_static_root(raw) if fold_root else (raw, None)
    if folded is not None:
        motion = raw.to_project_frame()
    return raw, info, motion, profile


def _without_helpers(raw: Motion, info: BVHInfo) -> Motion:
    """``raw`` without its rig's control, IK and helper bones (:mod:`bipedsim.motion.helper_bones`,
    measured from the clip), with a line in ``info.notes`` naming them."""
    body, found = drop_helper_bones(raw)
    if found.names:
        info.notes.append(f"rig helpers left out of the body ({len(found.names)}): {found.describe()}")
    return body


__all__ = ["AUTO", "BodyKind", "detect_body_kind", "read_source", "resolve_profile"]
