"""A standing rest pose for a motion whose identity pose is no standing body.

Bodies are built from the rest pose (every rotation identity); a file whose joint frames are
bone-aligned (every bone along +X, the pose made by the rotations) would otherwise build a body lying
down. :func:`standing_rest` finds the feet by name, else by geometry (:mod:`bipedsim.motion.roles`),
and rebases the motion on a standing frame.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.motion.conventions import axis_index, foot_joints, horizontal_axes, legs_root
from bipedsim.motion.motion import Motion
from bipedsim.motion.roles import find_roles
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]

#: Name fragments of the joints that end an arm.
HAND_TOKENS = ("hand", "wrist")

#: A rest pose stands when every foot is below the legs' root by at least this fraction of its leg's
#: length (a bird's folded leg drops less than a human's straight one, a bone-aligned rest pose not at all).
REST_FOOT_DROP = 0.1


def standing_rest(motion: Motion) -> Motion:
    """``motion``, or -- when its rest pose (every rotation identity) is no standing body: a foot
    not below the legs' root by :data:`REST_FOOT_DROP` of its leg's length along ``up``, or the rest of
    the body (its bones' length-weighted centroid) below that root -- the same motion
    :meth:`~bipedsim.motion.motion.Motion.rebased` on the frame whose feet are closest together, each leg
    and arm on the frame where it is straightest (:func:`_straightest_limb_frames`, turned to the main
    frame's heading)."""
    sk = motion.skeleton
    feet = foot_joints(sk.names) or _feet_by_geometry(motion)
    if len(feet) < 2:
        return motion
    offsets = sk.offsets if motion.translations is None else np.median(motion.translations, axis=0)
    offsets = offsets.copy()
    offsets[0] = 0.0
    rest = Motion(skeleton=sk.replace(offsets=offsets), frame_time=1.0, root_translation=np.zeros((1, 3)),
                  rotations=np.tile([0.0, 0.0, 0.0, 1.0], (1, sk.num_joints, 1)), up=motion.up).fk()[0][0]
    hip = legs_root(sk.parents, feet)
    u = axis_index(motion.up)
    bone = np.linalg.norm(offsets, axis=1)
    standing = True
    for f in feet:
        chain = [a for a in range(sk.num_joints) if a in _chain_between(sk.parents, hip, f)]
        if rest[hip, u] - rest[f, u] < REST_FOOT_DROP * bone[chain].sum():
            standing = False
    # and the upper body above the legs' root: a rig whose spine bones point down in its identity
    # pose (a Rokoko export: every spine OFFSET -y, the rotations turning it up) stands on its head
    legs = {a for f in feet for a in _chain_between(sk.parents, hip, f)}
    upper = [a for a in range(1, sk.num_joints) if a not in legs and a != hip]
    if upper:
        par = sk.parents[upper]
        w = bone[upper]
        if w.sum() > 0.0:
            mid = 0.5 * (rest[upper, u] + rest[par, u])
            if float((mid * w).sum() / w.sum()) < rest[hip, u]:
                standing = False
    if standing:
        return motion
    # the trunk from the frame whose feet are closest together, each limb from the frame where it
    # is straightest: joint limits are measured from this pose, and one frame for the whole body
    # leaves a bent knee or elbow at rest (references beyond the joint's range)
    allpos = motion.fk()[0]
    pos = allpos[:, feet][..., list(horizontal_axes(motion.up))]  # (T, F, 2)
    spread = np.linalg.norm(pos - pos.mean(axis=1, keepdims=True), axis=2).sum(axis=1)
    return motion.rebased(int(np.argmin(spread)), _straightest_limb_frames(sk, allpos, hip, feet))


def _feet_by_geometry(motion: Motion) -> list[int]:
    """The legs' ankle and toe joints found from the skeleton's structure and motion
    (:func:`~bipedsim.motion.roles.find_roles`), for joints whose names say nothing; [] if none."""
    try:
        roles = find_roles(motion.to_project_frame())
    except (ValueError, IndexError, ModelError):
        return []
    return sorted(j for limb in roles.limbs if limb.kind == "leg"
                  for role, j in limb.roles.items() if role in ("ankle", "toe"))


def _straightest_limb_frames(sk: Skeleton, pos: FloatArray, hip: int, feet: list[int]) -> dict[int, int]:
    """Per limb (its first joint: a leg below the legs' root, an arm two joints above a hand), the frame
    where it is straightest (its end farthest from its first joint for the bones between): joint
    limits are measured from the rest pose, so a rest knee or elbow must not be bent."""
    out: dict[int, int] = {}
    bone = np.linalg.norm(sk.offsets, axis=1)
    ends = [f for f in feet if not any(a in feet for a in _chain_between(sk.parents, hip, f)[1:])]
    ends_tops = [(f, _chain_between(sk.parents, hip, f)[-1]) for f in ends]
    hands = [i for i, n in enumerate(sk.names) if any(t in n.lower() for t in HAND_TOKENS)]
    for h in hands:
        a = int(sk.parents[h])
        top = int(sk.parents[a]) if a > 0 else -1
        if top > 0 and not any(t in sk.subtree(h) for t in hands if t != h):
            ends_tops.append((h, top))
    for end, top in ends_tops:
        chain = _chain_between(sk.parents, int(sk.parents[top]), end)
        length = float(bone[chain[:-1]].sum()) if len(chain) > 1 else 0.0
        if length <= 0 or top in out:
            continue
        reach = np.linalg.norm(pos[:, end] - pos[:, top], axis=1) / length
        out[top] = int(np.argmax(reach))
    return out


def _chain_between(parents: npt.NDArray[np.int64], top: int, j: int) -> list[int]:
    """Joints from ``j`` up to (not including) its ancestor ``top``."""
    out = []
    while j >= 0 and j != top:
        out.append(j)
        j = int(parents[j])
    return out
