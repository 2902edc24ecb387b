"""The child stands where its parent stood: where the blend lifts a foot the parent stood on, the
joints from the root down to that foot take less of the blend.

Blending rotates joints of one parent toward the other's: a dog's hips and spine turned half way to a
human's upright trunk stand the child on its hind legs with its fore paws at 0.8 of its height (the
dog x CMU 02_02 child, then measured a 0.5 m humanoid that falls at once); a horse's chest turned half
way toward a flamingo's rising spine holds its fore hooves 0.17 of its height above where the horse
puts them. A foot a parent stands on in its clip (A's; above x = 0.5 also B's others) is lifted
when its median height above the frame's lowest point, over the child's height, exceeds the height it
has in that parent (on the same bones) by more than :data:`FOOT_LIFT_TOL`; each common joint from the
root to it then moves half way from its x toward the motion of the parent nearer x (0: A's, 1: B's),
:data:`BLEND_HALVINGS` times, then to it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
import numpy.typing as npt

from bipedsim.model.source import motion_points
from bipedsim.motion.motion import Motion
from bipedsim.synthesis.breed.meta_skeleton import MetaSkeleton

FloatArray = npt.NDArray[np.float64]

#: a foot stands higher in the child than in its parent by more than this fraction of the body's height
#: (median over the clip): lifted (the feet of the children that walk move by at most 0.04)
FOOT_LIFT_TOL = 0.1
#: halvings of the blend on a lifted foot's chain before it takes the parent's motion whole
BLEND_HALVINGS = 3


def foot_heights(motion: Motion, names: Iterable[str]) -> dict[str, float]:
    """Median over the clip of each named joint's height above the frame's lowest point, as a fraction
    of the body's median height (``motion`` in the project frame)."""
    z = motion_points(motion).positions[..., 2]
    rel = z - z.min(axis=1, keepdims=True)
    height = float(np.median(rel.max(axis=1))) or 1e-9
    sk = motion.skeleton
    return {n: float(np.median(rel[:, sk.index(n)])) / height for n in names if n in sk.names}


def hold_feet_down(meta: MetaSkeleton, x: float, side: float, x_joints: dict[int, float],
                   feet: dict[str, float], child_of: Callable[[dict[int, float]], Motion]) -> dict[int, float]:
    """The per-joint x (meta joint -> x; others blend at ``x``) from ``x_joints`` under which no foot of
    ``feet`` (meta joint name -> its height in the side parent, :func:`foot_heights`) is lifted in the
    child ``child_of(x_joints)`` (see the module text); ``side``: the side parent's x (0: A, 1: B)."""
    sk = meta.skeleton
    common = set(meta.common)
    xj = dict(x_joints)
    for step in range(BLEND_HALVINGS + 1):
        now = foot_heights(child_of(xj), feet)
        lifted = [f for f, h in now.items() if h > feet[f] + FOOT_LIFT_TOL]
        if not lifted:
            break
        chain: set[int] = set()
        for f in lifted:
            j = sk.index(f)
            while j >= 0:
                if j in common:
                    chain.add(j)
                j = int(sk.parents[j])
        for j in chain:
            xj[j] = side if step == BLEND_HALVINGS else 0.5 * (xj.get(j, x) + side)
    return xj


__all__ = ["BLEND_HALVINGS", "FOOT_LIFT_TOL", "foot_heights", "hold_feet_down"]
