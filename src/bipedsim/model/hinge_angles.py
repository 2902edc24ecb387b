"""Local rotations split into a body's hinge angles (rad): a hinge set by intrinsic Euler decomposition
on its axes (in the axes' own basis where they are not along x, y and z), a single hinge by the twist
about its axis, and of a 3-hinge joint's two equivalent Euler triples the one within its ranges."""

from __future__ import annotations

import warnings

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError

FloatArray = npt.NDArray[np.float64]


def _wrap(a: FloatArray) -> FloatArray:
    return (a + np.pi) % (2 * np.pi) - np.pi


#: Largest |cos| between two hinge axes of one joint still taken as perpendicular (about 0.06 deg off).
HINGE_ORTHO_TOL = 1e-3


def hinge_basis(axes: list[FloatArray]) -> tuple[str, FloatArray, FloatArray | None]:
    """How a set of 2 or 3 hinge axes (applied in order) splits a rotation: an intrinsic Euler
    sequence, the sign of each hinge's angle against that sequence's, and the basis (3, 3; columns)
    the rotation is expressed in first -- None when every axis lies along x, y or z (the sequence's
    letters are then those axes). Other axes must be mutually perpendicular: the basis is then the
    first axis, the second, and their cross product (the third hinge, if any, along it or against it),
    and the sequence XYZ."""
    units = [np.asarray(a, dtype=float) / np.linalg.norm(a) for a in axes]
    letters, signs = [], []
    for a in units:
        k = int(np.argmax(np.abs(a)))
        letters.append("xyz"[k])
        signs.append(float(np.sign(a[k])))
    aligned = all(np.isclose(abs(np.asarray(a, dtype=float)[int(np.argmax(np.abs(a)))]), 1.0) for a in axes)
    if aligned and len(set(letters)) == len(letters):
        seq = "".join(letters)
        if len(seq) == 2:
            seq += next(c for c in "xyz" if c not in seq)
        return seq, np.array(signs), None
    for i in range(len(units)):
        for j in range(i + 1, len(units)):
            if abs(float(units[i] @ units[j])) > HINGE_ORTHO_TOL:
                raise ModelError(f"hinge axes {np.round(axes[i], 4).tolist()} and {np.round(axes[j], 4).tolist()} "
                                 f"of one joint are not perpendicular (angle "
                                 f"{np.degrees(np.arccos(np.clip(units[i] @ units[j], -1, 1))):.2f} deg): "
                                 "a hinge set splits a rotation only on perpendicular axes")
    e1 = units[0]
    e2 = units[1] - (units[1] @ e1) * e1
    e2 /= np.linalg.norm(e2)
    e3 = np.cross(e1, e2)
    sgn = [1.0, 1.0] + ([float(np.sign(units[2] @ e3))] if len(units) == 3 else [])
    return "xyz", np.array(sgn), np.stack([e1, e2, e3], axis=1)


def _hinge_angles(local: FloatArray, axes: list[FloatArray]) -> FloatArray:
    """(T, k) hinge angles reproducing local rotations (T, 3, 3) with hinges on ``axes`` in order
    (1 axis: the rotation's twist about it; 2: the best the pair reproduces, the third Euler angle
    dropped; 3: exact). Axes along x, y or z take the Euler sequence of their letters; other axes
    must be perpendicular (:func:`hinge_basis`)."""
    if len(axes) == 1:
        q = Rotation.from_matrix(local).as_quat()  # x y z w
        a = axes[0] / np.linalg.norm(axes[0])
        ang = 2.0 * np.arctan2(q[:, :3] @ a, q[:, 3])
        return ((ang + np.pi) % (2 * np.pi) - np.pi)[:, None]
    seq, signs, basis = hinge_basis(axes)
    if basis is not None:  # a rotation about basis @ e_i is basis R_i basis^T
        local = np.einsum("ji,tjk,kl->til", basis, local, basis)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        eul = Rotation.from_matrix(local).as_euler(seq.upper())
    return eul[:, :len(axes)] * signs[:len(axes)]


def _in_range_euler(ang: FloatArray, ranges: FloatArray, signs: FloatArray) -> FloatArray:
    """Three hinge angles (T, 3) as the one of the two equivalent Euler triples -- (a, b, c) and
    (a + pi, pi - b, c + pi) on the unsigned axes -- that leaves the joint's ``ranges`` (3, 2) the
    least, the nearer the previous frame's on a tie. Near the middle hinge's +-pi/2 (an arm raised
    sideways) the decomposition wraps its outer angles by 2 pi from frame to frame (CMU 131's right
    shoulder: 1.59 rad beyond its range); the other triple is the same rotation within range."""
    raw = ang * signs
    alt = np.stack([raw[:, 0] + np.pi, np.pi - raw[:, 1], raw[:, 2] + np.pi], axis=1)
    cands = [_wrap(raw) * signs, _wrap(alt) * signs]
    excess = [np.sum(np.maximum(ranges[:, 0] - c, 0) + np.maximum(c - ranges[:, 1], 0), axis=1) for c in cands]
    out = np.where((excess[1] < excess[0] - 1e-9)[:, None], cands[1], cands[0])
    for t in np.flatnonzero(np.abs(excess[0] - excess[1]) <= 1e-9):  # a tie: the nearer the frame before
        if t > 0:
            d = [float(np.sum(np.abs(_wrap(c[t] - out[t - 1])))) for c in cands]
            out[t] = cands[int(d[1] < d[0])][t]
    return out
