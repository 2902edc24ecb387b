"""A humanoid's bones and hinges: the axis conventions (x forward, z up), the shortest bone the builder
accepts, and the hinge joints of one joint group with axes from the profile (mirrored on the right side)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.plan import JointPlan
from bipedsim.model.profile import JointSpec

FloatArray = npt.NDArray[np.float64]


BASIS = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}
FORWARD = np.array([1.0, 0.0, 0.0])
#: Shortest bone (m) the builder accepts; shorter ones are zero-length for practical purposes.
MIN_BONE_M = 0.01
#: The shortest toe box (m), toe joint to tip.
MIN_TOE_M = 0.03


def _axis_vec(name: str) -> FloatArray:
    sign = -1.0 if name.startswith("-") else 1.0
    return sign * BASIS[name.lstrip("-")]


def _mirror_axis(v: FloatArray) -> FloatArray:
    """A rotation axis (pseudo-vector) reflected through the sagittal (x-z) plane."""
    return np.array([-v[0], v[1], -v[2]])


def _flex_axis(bone: FloatArray, parent_bone: FloatArray | None = None) -> FloatArray:
    """Flexion axis ``forward x bone`` (positive rotation swings the bone backward), made
    perpendicular to the parent bone too when given."""
    a = np.cross(FORWARD, bone)
    if parent_bone is not None:
        pb = parent_bone / np.linalg.norm(parent_bone)
        a = a - np.dot(a, pb) * pb
    n = np.linalg.norm(a)
    if n < 1e-6:
        return BASIS["y"].copy()
    return a / n


def _hinges(prefix: str, spec: JointSpec, bone: FloatArray, mirror: bool, kp: float, kd: float,
            group: str, parent_bone: FloatArray | None = None) -> list[JointPlan]:
    """Hinge joints for one joint group: axes from the spec (mirrored on the right side)."""
    if spec.axes == "auto":
        b = np.abs(bone / np.linalg.norm(bone))
        twist = "xyz"[int(np.argmax(b))]
        rest = [a for a in "xyz" if a != twist]
        first = "y" if "y" in rest else "x"
        order = [first, next(a for a in rest if a != first), twist]
        axes = [BASIS[a] for a in order]
        ranges = [spec.range[a] for a in order]
        labels = order
    else:
        axes, labels = [], []
        for a in spec.axes:
            if a == "flex":
                axes.append(_flex_axis(bone, parent_bone))
                labels.append("y")  # the flexion axis is the lateral one (y for a bone hanging down)
            else:
                v = _axis_vec(a)
                axes.append(_mirror_axis(v) if mirror else v)
                labels.append(a.lstrip("-"))
        ranges = list(spec.range)
    joints = []
    for ax, rg, lab in zip(axes, ranges, labels):
        name = prefix if len(axes) == 1 else f"{prefix}_{lab}"
        joints.append(JointPlan(name=name, kind="hinge", axis=[float(v) for v in ax],
                                range=[float(rg[0]), float(rg[1])], torque=spec.torque, kp=kp, kd=kd,
                                group=group))
    return joints


def _check_bone(v: FloatArray, a: str, b: str, what: str) -> FloatArray:
    """``v`` (m), the bone from joint ``a`` to ``b``; a ModelError when shorter than MIN_BONE_M."""
    if np.linalg.norm(v) < MIN_BONE_M:
        raise ModelError(f"zero-length bone: {what} from {a!r} to {b!r} is "
                         f"{np.linalg.norm(v) * 1000:.1f} mm long (need >= {MIN_BONE_M * 1000:.0f} mm)")
    return v
