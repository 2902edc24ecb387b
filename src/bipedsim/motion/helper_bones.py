"""Control, IK and helper bones that are no part of the animal: found by measuring the clip, names a hint.

Game and DCC rigs (Blender, Maya, Mixamo-style animal rigs) export, beside the skeleton, bones that drive
or decorate it: IK targets and poles, ``ZeroOut``/``Armature`` placeholders, twist and mesh helpers. Built
as bodies, an IK target at the floor is taken for a foot and a pole in front of the knee for a leg; the
body falls at once. A bone is left out when the clip shows it is no part of the body:

- **it does not follow its parent chain**: its distance to its parent changes over the clip (an IK
  target or pole animated by its own translation; a skeleton's bones keep their length), or a leaf
  moves with a joint of another chain (a target on the foot it drives);
- **it sits off the body**: a leaf bone longer than :data:`OFF_BODY_FRACTION` of the body's size that
  the body never comes near (a target or locator parked far from the skeleton);
- **it never moves relative to the root and has no child** (a rigid leaf: a placeholder, a prop or
  mesh bone) -- only together with a helper's name (:data:`HELPER_NAME_HINTS`) or a zero-length bone:
  a still head or tail is a body part;
- **it lies on its parent's bone and has no child** (a twist or share bone on a limb).

Names alone never remove a bone. A helper's subtree goes with it only when every joint in it is a
helper too; a helper that carries body joints stays (removing it would move them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bipedsim.motion.motion import Motion
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]

#: a bone whose length varies (standard deviation over the clip) by more than this fraction of the
#: body's size does not follow its parent chain (a skeleton's bones are rigid; float noise is ~1e-6)
LENGTH_VARIATION_FRACTION = 0.01
#: a leaf bone longer than this fraction of the body's size, whose tip stays this far from every
#: other joint, sits off the body (a limb's longest bone is about 0.3 of the body's size)
OFF_BODY_FRACTION = 0.4
#: a subtree whose points move less than this fraction of the body's size relative to the root
#: (standard deviation in the root's frame) never moves relative to the root
STILL_FRACTION = 0.002
#: a leaf within this fraction of the body's size of its parent's bone to a sibling lies on that bone
ON_BONE_FRACTION = 0.02
#: a bone shorter than this fraction of the body's size has zero length (sits on its parent)
ZERO_LENGTH_FRACTION = 1e-3
#: a skeleton with fewer joints than this is no rig with helpers (a synthetic chain's long leaf is its body)
MIN_RIG_JOINTS = 8
#: lower-case name fragments of rig helpers: a hint that confirms a measured still bone, never alone
HELPER_NAME_HINTS = ("ik", "pole", "target", "ctrl", "control", "zeroout", "armature", "helper", "twist",
                     "roll", "mesh", "null", "locator", "nub", "dummy", "prop")


@dataclass(frozen=True)
class HelperBones:
    """What :func:`find_helper_bones` measured: helper joint name -> the reason, one line."""

    reasons: dict[str, str]

    @property
    def names(self) -> set[str]:
        return set(self.reasons)

    def describe(self) -> str:
        return ", ".join(f"{k} ({v})" for k, v in self.reasons.items()) or "none"


def _hinted(name: str) -> bool:
    low = name.lower()
    return any(h in low for h in HELPER_NAME_HINTS)


def _size(pts: FloatArray) -> float:
    ext = np.median(pts.max(axis=1) - pts.min(axis=1), axis=0)
    return float(np.max(ext)) or 1e-9


def find_helper_bones(motion: Motion) -> HelperBones:
    """The joints of ``motion`` (any frame, any unit) that are rig helpers, not body parts (module text)."""
    sk = motion.skeleton
    n = sk.num_joints
    if n < MIN_RIG_JOINTS or motion.num_frames < 2:
        return HelperBones({})
    pos, rot = motion.fk()  # (T, J, 3), (T, J, 3, 3) world rotations
    size = _size(pos)
    parents = np.asarray(sk.parents)
    kids = [sk.children(j) for j in range(n)]
    ends_of = {j: [e for e, p in enumerate(sk.end_site_parents) if int(p) == j] for j in range(n)}
    ends = motion.end_site_positions() if len(sk.end_site_parents) else np.zeros((motion.num_frames, 0, 3))
    # points in the root's frame: what moves relative to the root
    root_r = rot[:, 0]
    rel = np.einsum("tji,tkj->tki", root_r, pos - pos[:, :1])
    reasons: dict[str, str] = {}
    for j in range(1, n):
        p = int(parents[j])
        length = np.linalg.norm(pos[:, j] - pos[:, p], axis=1)
        if float(length.std()) > LENGTH_VARIATION_FRACTION * size:
            reasons[sk.names[j]] = f"its distance to {sk.names[p]} varies by {length.std() / size:.3f} of the body"
            continue
        if kids[j]:
            continue
        tip = pos[:, j] if not ends_of[j] else ends[:, ends_of[j][0]]
        others = [k for k in range(n) if k != j and k != p]
        anc, a = set(), p
        while a >= 0:
            anc.add(a)
            a = int(parents[a])
        apart = [k for k in others if k not in anc]
        if apart and not ends_of[j]:
            d = np.median(np.linalg.norm(pos[:, apart] - pos[:, j][:, None], axis=2), axis=0)
            k = apart[int(np.argmin(d))]
            if float(d.min()) < ON_BONE_FRACTION * size:
                reasons[sk.names[j]] = f"a leaf that moves with {sk.names[k]}, not its parent chain (a target)"
                continue
        if float(np.median(length)) > OFF_BODY_FRACTION * size and others:
            gap = np.linalg.norm(pos[:, others] - tip[:, None], axis=2).min(axis=1)
            if float(np.median(gap)) > OFF_BODY_FRACTION * size:
                reasons[sk.names[j]] = f"a leaf {np.median(length) / size:.2f} of the body long, off the body"
                continue
        still = float(rel[:, j].std(axis=0).max()) < STILL_FRACTION * size and p == 0
        zero = float(np.median(length)) < ZERO_LENGTH_FRACTION * size and not ends_of[j]
        if still and (_hinted(sk.names[j]) or zero):
            reasons[sk.names[j]] = "a leaf that never moves relative to the root" + (
                " (helper name)" if _hinted(sk.names[j]) else " (zero length)")
            continue
        if _hinted(sk.names[j]) and not ends_of[j]:
            sibs = [k for k in kids[p] if k != j]
            for s in sibs:
                a, b = pos[:, p], pos[:, s]
                ab = b - a
                u = np.clip(np.sum((pos[:, j] - a) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-12), 0, 1)
                d = np.linalg.norm(a + u[:, None] * ab - pos[:, j], axis=1)
                if float(np.median(d)) < ON_BONE_FRACTION * size and 0.05 < float(np.median(u)) < 0.95:
                    reasons[sk.names[j]] = f"a leaf on the bone {sk.names[p]} -> {sk.names[s]} (twist/share)"
                    break
    # a helper carrying body joints stays: only whole helper subtrees go
    names = set(reasons)
    kept = {k: v for k, v in reasons.items()
            if all(sk.names[i] in names for i in sk.subtree(sk.index(k)))}
    return HelperBones(kept)


def without_joints(motion: Motion, drop: set[str]) -> Motion:
    """``motion`` without the joints named in ``drop`` and their subtrees (the root is never dropped);
    every other joint's forward kinematics unchanged."""
    sk = motion.skeleton
    gone: set[int] = set()
    for name in drop:
        if name in sk.names and sk.index(name) != 0:
            gone.update(sk.subtree(sk.index(name)))
    if not gone:
        return motion
    keep = [j for j in range(sk.num_joints) if j not in gone]
    new = {old: i for i, old in enumerate(keep)}
    es = [(new[int(p)], o) for p, o in zip(sk.end_site_parents, sk.end_site_offsets) if int(p) in new]
    child = Skeleton(names=tuple(sk.names[j] for j in keep),
                     parents=np.array([-1 if j == 0 else new[int(sk.parents[j])] for j in keep], dtype=np.int64),
                     offsets=sk.offsets[keep], channels=tuple(sk.channels[j] for j in keep),
                     position_modes=tuple(sk.position_modes[j] for j in keep) if sk.position_modes else (),
                     end_site_parents=np.array([p for p, _ in es], dtype=np.int64),
                     end_site_offsets=np.array([o for _, o in es], dtype=np.float64).reshape(-1, 3))
    return motion.copy(skeleton=child, rotations=motion.rotations[:, keep],
                       translations=None if motion.translations is None else motion.translations[:, keep])


def drop_helper_bones(motion: Motion) -> tuple[Motion, HelperBones]:
    """``motion`` without its rig helpers (:func:`find_helper_bones`), and what was found."""
    found = find_helper_bones(motion)
    return without_joints(motion, found.names), found


__all__ = ["HelperBones", "drop_helper_bones", "find_helper_bones", "without_joints"]
