"""A humanoid's segment shapes: limb capsules, foot and toe boxes with their touch-sensor boxes, and the
rotation conversions (matrix <-> MuJoCo quaternion) their frames use. Sizes in m, body coordinates."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.model.plan import GeomPlan, SitePlan

FloatArray = npt.NDArray[np.float64]


#: Touch-sensor sites reach this far below and above the sole (m).
TOUCH_MARGIN_M = 0.02
#: Touch-sensor boxes reach this far (m) beyond the sides of the foot and toe boxes.
TOUCH_PAD_M = 0.005


#: Limb capsules stop this many radii short of the distal joint, so a shin's rounded end does not
#: reach below the ankle (a foot flat on the floor must not let the shin touch it).
DISTAL_INSET = 1.0


def _capsule(a: FloatArray, b: FloatArray, origin: FloatArray, radius: float, mass: float,
             inset: bool = False) -> GeomPlan:
    if inset:
        v = b - a
        n = float(np.linalg.norm(v))
        b = b - v / max(n, 1e-9) * min(DISTAL_INSET * radius, 0.3 * n)
    return GeomPlan(kind="capsule", size=[radius], fromto=[*(a - origin), *(b - origin)], mass=mass)


def _quat(r: FloatArray) -> list[float] | None:
    """MuJoCo quaternion (w, x, y, z) of a rotation matrix; None for the identity."""
    if np.allclose(r, np.eye(3)):
        return None
    return [float(v) for v in Rotation.from_matrix(r).as_quat(scalar_first=True)]


def _matrix(quat: list[float] | None) -> FloatArray:
    """Rotation matrix of a MuJoCo quaternion (w, x, y, z); the identity for None."""
    if quat is None:
        return np.eye(3)
    return Rotation.from_quat(quat, scalar_first=True).as_matrix()


def _sole_box(prefix: str, half: list[float], centre: FloatArray, sole: float, frame: FloatArray,
              mass: float) -> tuple[GeomPlan, SitePlan]:
    """A foot segment's box geom (half sizes ``half`` and ``centre`` in m, sole frame ``frame``, body
    coordinates) and its touch-sensor box, TOUCH_PAD_M wider each side, from TOUCH_MARGIN_M below the
    sole height ``sole`` (m, sole frame) to twice that above it."""
    touch_c = np.array([centre[0], 0.0, sole + TOUCH_MARGIN_M / 2])
    geom = GeomPlan(kind="box", size=half, pos=list(frame @ centre), mass=mass, name=f"{prefix}_geom", sole=True,
                    quat=_quat(frame))
    site = SitePlan(name=f"{prefix}_touch", pos=list(frame @ touch_c), kind="box", touch=True,
                    size=[half[0] + TOUCH_PAD_M, half[1] + TOUCH_PAD_M, TOUCH_MARGIN_M * 1.5], quat=_quat(frame))
    return geom, site
