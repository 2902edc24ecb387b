"""The source skeleton reduced to a creature's bodies: which joints become bodies (the rest merge into
their parents), each body's bones, children and End Sites (rest pose, m, project frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.source import SourcePoints
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]


def safe_name(name: str) -> str:
    """``name`` with every character MuJoCo names should not hold replaced by ``_``."""
    return "".join(c if c.isalnum() or c in "_-." else "_" for c in name)


def skeleton_extent(rest: SourcePoints) -> float:
    """The creature's size (m): the largest extent of its rest pose (joints and End Sites) along x, y
    or z. A ModelError for a skeleton with no extent or only zero-length bones."""
    sk = rest.skeleton
    pts = rest.positions
    size = float(np.max(pts.max(axis=0) - pts.min(axis=0)))
    if size <= 0:
        raise ModelError("the skeleton has no extent: every joint sits at one point")
    lengths = np.linalg.norm(sk.offsets, axis=1)
    if sk.num_joints > 1 and np.all(lengths[1:] < 1e-9):
        raise ModelError("zero-length bones: every joint offset is zero")
    return size


@dataclass
class BodyTree:
    """The source skeleton reduced to the creature's bodies (rest pose, m, project frame).

    ``body_of[j]``: the joint whose body joint ``j`` belongs to (itself when kept); ``kept``: the joints
    that are bodies, in skeleton order (parents first); ``children[j]``: the kept joints hanging from
    body ``j``; ``ends[j]``: rest positions (m) of the End Sites on body ``j``; ``names[j]``: body names.
    """

    skeleton: Skeleton
    pos: FloatArray
    body_of: npt.NDArray[np.int_]
    kept: list[int]
    children: dict[int, list[int]]
    ends: dict[int, list[FloatArray]]
    names: dict[int, str]
    #: a foot's bones (rest start and end points, m) when segments below it were folded into it
    folded: dict[int, list[tuple[FloatArray, FloatArray]]] = field(default_factory=dict)
    #: a folded foot's touch point (rest, m): the point of it nearest the floor over the clip
    tips: dict[int, FloatArray] = field(default_factory=dict)

    def parent_body(self, j: int) -> int:
        """The kept joint whose body is the parent of kept joint ``j`` (not the root)."""
        return int(self.body_of[self.skeleton.parents[j]])

    def bones(self, j: int) -> list[tuple[FloatArray, FloatArray]]:
        """Body ``j``'s bones as (start, end) rest points (m): from its joint to each child body and End
        Site, and for a foot with folded segments, theirs as well."""
        own = [(self.pos[j], t) for t in [self.pos[c] for c in self.children[j]] + self.ends[j]]
        return own + self.folded.get(j, [])

    def bone_points(self, j: int) -> list[tuple[int, int]]:
        """Body ``j``'s bones as (start, end) indices into the skeleton's points (joints, then End Sites)."""
        sk = self.skeleton
        ends = [sk.num_joints + e for e, p in enumerate(sk.end_site_parents) if self.body_of[p] == j]
        return [(j, t) for t in list(self.children[j]) + ends]


def _own_bones(rest: SourcePoints) -> FloatArray:
    """(J,) length (m) of each joint's own bone: the longest segment from it to a child joint or End
    Site (0 for a leaf without an End Site)."""
    sk = rest.skeleton
    pos = rest.positions[:sk.num_joints]
    bone = np.zeros(sk.num_joints)
    for c in range(1, sk.num_joints):
        p = int(sk.parents[c])
        bone[p] = max(bone[p], float(np.linalg.norm(pos[c] - pos[p])))
    for e, p in enumerate(sk.end_site_parents):
        bone[p] = max(bone[p], float(np.linalg.norm(rest.positions[sk.num_joints + e] - pos[p])))
    return bone


def reduce_skeleton(rest: SourcePoints, merge_fraction: float, size: float) -> BodyTree:
    """Which joints become bodies: a joint whose own bone is shorter than ``merge_fraction`` x the
    creature's ``size`` (m) moves almost nothing when it turns, so it merges into its parent's body
    (its children hang from that body at their rest positions)."""
    sk = rest.skeleton
    bone = _own_bones(rest)
    body_of = np.arange(sk.num_joints)
    for j in range(1, sk.num_joints):
        if bone[j] < merge_fraction * size:
            body_of[j] = body_of[sk.parents[j]]
    kept = sorted({int(b) for b in body_of})
    if len(kept) < 2:
        # one rigid body has nothing to move: a rollout of it would "track" the clip with RMSE 0
        raise ModelError(
            f"every one of the {sk.num_joints} joints merges into the root: each bone is shorter than "
            f"merge_fraction {merge_fraction:g} x the body's size {size:.3g} m "
            f"(longest bone {bone.max():.3g} m), so the body would be one rigid piece with no joint to "
            "drive; give a creature profile YAML with a smaller merge_fraction (convert --profile-file)")
    children: dict[int, list[int]] = {j: [] for j in kept}
    for j in kept:
        if j != 0:
            children[int(body_of[sk.parents[j]])].append(j)
    ends: dict[int, list[FloatArray]] = {j: [] for j in kept}
    for e, p in enumerate(sk.end_site_parents):
        ends[int(body_of[p])].append(rest.positions[sk.num_joints + e])
    return BodyTree(skeleton=sk, pos=rest.positions[:sk.num_joints], body_of=body_of, kept=kept, children=children,
                     ends=ends, names={j: safe_name(sk.names[j]) for j in kept})


__all__ = ["BodyTree", "reduce_skeleton", "safe_name", "skeleton_extent"]
