"""What a shared take shows of its body that its generated stand-in (``bvh_fixtures.py``, the project's
walk in the take's joint names) does not, added to the stand-in: a spine that bends as it walks (CMU
131_01's shortens 5 cm between its lower back and its shoulders as the performer leans); a joint on its
parent (the neck on the chest joint in D. Holden's CMU releases)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion, canonical_quat


def _rest_positions(m: Motion) -> np.ndarray:
    """(J, 3) the joints' positions in the rest pose (every rotation the identity), the root at 0."""
    sk = m.skeleton
    p = np.zeros((sk.num_joints, 3))
    for j in range(1, sk.num_joints):
        p[j] = p[sk.parents[j]] + sk.offsets[j]
    return p


def bent_spine(m: Motion, joint: str, left: str, right: str, amplitude: float, period_s: float) -> Motion:
    """``m`` with the body above its ``joint`` bowing forward from upright to ``amplitude`` rad and back
    every ``period_s``, about the body's lateral axis (from joint ``right`` to joint ``left`` in the rest
    pose, whose joint frames are the world's, as in a BVH file's identity pose)."""
    rest = _rest_positions(m)
    sk = m.skeleton
    axis = rest[sk.index(left)] - rest[sk.index(right)]
    axis /= np.linalg.norm(axis)
    t = np.arange(m.num_frames) * m.frame_time
    bow = Rotation.from_rotvec(amplitude * np.sin(np.pi * t / period_s)[:, None] ** 2 * axis)
    j = sk.index(joint)
    rot = m.rotations.copy()
    rot[:, j] = (Rotation.from_quat(rot[:, j]) * bow).as_quat()
    return m.copy(rotations=canonical_quat(rot))


def joint_on_its_parent(m: Motion, joint: str) -> Motion:
    """``m`` with ``joint`` moved onto its parent (its OFFSET zero, its children's OFFSETs longer by it),
    as D. Holden's CMU releases put the neck on the chest joint: the body it poses is the same where
    ``joint`` turns with its parent, the bones below it hang from the parent's position."""
    sk = m.skeleton
    j = sk.index(joint)
    offsets = sk.offsets.copy()
    for c in sk.children(j):
        offsets[c] += offsets[j]
    ends = sk.end_site_offsets.copy()
    ends[sk.end_site_parents == j] += offsets[j]
    offsets[j] = 0.0
    return m.copy(skeleton=sk.replace(offsets=offsets, end_site_offsets=ends))
