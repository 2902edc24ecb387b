"""Static roots: recognise a root joint that never moves with the body's translation on its one child
(a layout common in game-motion datasets: ``joint_Root`` at the floor, the hips carrying 6 channels),
fold it away so the moving joint becomes the root, and -- for tests and examples -- build that layout
from an ordinary clip.

Folding keeps every global joint position and rotation: the child's new root transform is its old
global transform. Works in any unit and up axis (the motion's own).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.skeleton import POSITION_CHANNELS, Skeleton

FloatArray = npt.NDArray[np.float64]
#: A root is static when its translation moves less than this fraction of the skeleton's size and its
#: rotation turns less than :data:`STATIC_ROT_RAD` over the clip.
STATIC_FRACTION = 1e-4
STATIC_ROT_RAD = 1e-4
ROOT_CHANNELS = ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")


@dataclass(frozen=True)
class FoldedRoot:
    """A static root that was folded away: its name and the child that became the root."""

    root: str
    into: str


def skeleton_size(motion: Motion) -> float:
    """The largest distance between two joints of the first frame (motion units); 1 if it is zero."""
    p = motion[0:1].fk()[0][0]
    size = float(np.max(np.linalg.norm(p[:, None] - p[None], axis=-1))) if len(p) > 1 else 0.0
    return size if size > 0 else 1.0


def static_root_child(motion: Motion) -> int | None:
    """The joint carrying the body's translation under a static root, or None when the root moves (or
    has more than one child, or its child never translates: then there is nothing to fold)."""
    sk = motion.skeleton
    kids = sk.children(0)
    if len(kids) != 1 or motion.translations is None or not sk.has_positions(kids[0]):
        return None
    tol = STATIC_FRACTION * skeleton_size(motion)
    if np.ptp(motion.root_translation, axis=0).max() > tol:
        return None
    r = Rotation.from_quat(motion.rotations[:, 0])
    if np.max((r[0].inv() * r).magnitude()) > STATIC_ROT_RAD:
        return None
    c = kids[0]
    if np.ptp(motion.translations[:, c], axis=0).max() <= tol:
        return None
    return c


def fold_static_root(motion: Motion) -> tuple[Motion, FoldedRoot | None]:
    """The motion with a static root removed (see the module docstring), and what was folded (None:
    the motion is returned unchanged). Joints whose position channels never change get that
    translation as their OFFSET, so the result carries per-joint translations only where they move."""
    c = static_root_child(motion)
    if c is None:
        return motion, None
    sk = motion.skeleton
    pos, rot = motion.fk()
    keep = list(range(1, sk.num_joints))
    parents = np.array([-1 if j == c else int(sk.parents[j]) - 1 for j in keep])
    trans = motion.local_translations()[:, keep]
    offsets = sk.offsets[keep].copy()
    offsets[c - 1] = 0.0
    tol = STATIC_FRACTION * skeleton_size(motion)
    moving = [k for k in range(len(keep)) if k != c - 1 and np.ptp(trans[:, k], axis=0).max() > tol]
    for k in range(len(keep)):
        if k != c - 1 and k not in moving:
            offsets[k] = np.median(trans[:, k], axis=0)
    channels = list(sk.channels[j] for j in keep)
    modes = ["replace" if any(ch in POSITION_CHANNELS for ch in chs) else "" for chs in channels]
    es = [(int(p) - 1, o) for p, o in zip(sk.end_site_parents, sk.end_site_offsets) if int(p) != 0]
    folded_sk = Skeleton(names=tuple(sk.names[j] for j in keep), parents=parents, offsets=offsets,
                         channels=tuple(channels), position_modes=tuple(modes),
                         end_site_parents=np.array([p for p, _ in es], dtype=np.int64),
                         end_site_offsets=np.array([o for _, o in es]).reshape(-1, 3))
    rots = motion.rotations[:, keep].copy()
    rots[:, c - 1] = canonical_quat(Rotation.from_matrix(rot[:, c]).as_quat())
    out = motion.copy(skeleton=folded_sk, root_translation=pos[:, c], rotations=rots,
                      translations=trans if moving else None)
    return out, FoldedRoot(root=sk.names[0], into=sk.names[c])


def add_static_root(motion: Motion, name: str = "joint_Root") -> Motion:
    """The motion under a new static root joint ``name`` at the origin (the floor), its old root a
    child with 6 channels carrying the translation (OFFSET zero, so absolute and additive readings of
    the channels agree) -- the layout :func:`fold_static_root` undoes."""
    sk = motion.skeleton
    if name in sk.names:
        raise ValueError(f"the skeleton already has a joint {name!r}")
    channels = (ROOT_CHANNELS,) + (ROOT_CHANNELS if not sk.has_positions(0) else sk.channels[0],) + sk.channels[1:]
    offsets = np.vstack([np.zeros((2, 3)), sk.offsets[1:]])
    modes = ("replace", "replace") + tuple(sk.position_modes[1:])
    new_sk = Skeleton(names=(name,) + sk.names, parents=np.concatenate([[-1, 0], sk.parents[1:] + 1]),
                      offsets=offsets, channels=channels, position_modes=modes,
                      end_site_parents=sk.end_site_parents + 1, end_site_offsets=sk.end_site_offsets)
    t = motion.num_frames
    trans = np.concatenate([np.zeros((t, 1, 3)), motion.local_translations()], axis=1)
    rots = np.concatenate([np.tile([0.0, 0.0, 0.0, 1.0], (t, 1, 1)), motion.rotations], axis=1)
    return motion.copy(skeleton=new_sk, root_translation=np.zeros((t, 3)), rotations=rots, translations=trans)
