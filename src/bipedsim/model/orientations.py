"""Each body's world orientation over a motion, fitted to the source by its body plan's method
(:class:`~bipedsim.model.plan.FitPlan`): ``kabsch`` (the rotation that best carries the body's rest points
onto the motion's, lightly pulled toward a reference joint's rotation), ``aim`` (a reference rotation
turned so the bone points as the motion's does), ``twobone`` (aim, with the twist that lets the child's
hinge reach the end joint), ``hinge`` and ``ref``. Rotations (T, 3, 3), world frame."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.model.hinge_angles import _wrap
from bipedsim.model.plan import BodyPlanSet, FitPlan
from bipedsim.model.source import SourcePoints

FloatArray = npt.NDArray[np.float64]


#: Weight of the reference rotation in a Kabsch fit, relative to 1 m of point spread.
KABSCH_REF_WEIGHT = 1e-3
#: Below this bend (rad) between the two bones, ``twobone`` keeps the reference twist.
TWOBONE_MIN_BEND = np.radians(2.0)


def _unit(v: FloatArray) -> FloatArray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _min_rotation(a: FloatArray, b: FloatArray) -> FloatArray:
    """(T, 3, 3) smallest rotations taking directions ``a`` to ``b`` (T, 3)."""
    a, b = _unit(a), _unit(b)
    axis = np.cross(a, b)
    s = np.linalg.norm(axis, axis=-1)
    c = np.sum(a * b, axis=-1)
    angle = np.arctan2(s, c)
    # antiparallel: any axis perpendicular to a
    perp = np.cross(a, np.array([1.0, 0.0, 0.0]))
    perp = np.where(np.linalg.norm(perp, axis=-1, keepdims=True) < 1e-6,
                    np.cross(a, np.array([0.0, 1.0, 0.0])), perp)
    axis = np.where((s < 1e-9)[:, None], _unit(perp), axis / np.maximum(s, 1e-12)[:, None])
    return Rotation.from_rotvec(axis * angle[:, None]).as_matrix()


def kabsch(rest_vecs: FloatArray, cur_vecs: FloatArray, ref: FloatArray,
           weights: FloatArray | None = None) -> FloatArray:
    """(T, 3, 3) rotations minimising sum w_i |R r_i - c_i|^2 (+ a small pull toward ``ref``).

    rest_vecs (N, 3), cur_vecs (T, N, 3), ref (T, 3, 3)."""
    w = np.ones(len(rest_vecs)) if weights is None else np.asarray(weights, dtype=float)
    h = np.einsum("n,ni,tnj->tij", w, rest_vecs, cur_vecs)
    scale = max(float(np.sum(rest_vecs ** 2)), 1e-6)
    h = h + KABSCH_REF_WEIGHT * scale * np.transpose(ref, (0, 2, 1))  # pairs e_k -> ref e_k
    u, _, vt = np.linalg.svd(h)
    v = np.transpose(vt, (0, 2, 1))
    d = np.sign(np.linalg.det(v @ np.transpose(u, (0, 2, 1))))
    dm = np.zeros((len(h), 3, 3))
    dm[:, 0, 0] = 1.0
    dm[:, 1, 1] = 1.0
    dm[:, 2, 2] = d
    return v @ dm @ np.transpose(u, (0, 2, 1))


def _twobone_twist(g: FloatArray, u: FloatArray, w: FloatArray, axis0: FloatArray,
                   child0: FloatArray, hinge_range: list[float] | None = None) -> FloatArray:
    """Twist ``g`` (T, 3, 3) about the bone ``u`` so the child's hinge, rotating the rest child bone
    ``child0`` about ``g @ axis0``, can reach the child bone ``w``: the hinge axis must make the same
    angle with ``w`` as ``axis0`` makes with ``child0``. Of the two twists that do, the smaller."""
    uh = _unit(u)
    wh = _unit(w)
    a = np.einsum("tij,j->ti", g, axis0 / np.linalg.norm(axis0))
    along = np.sum(a * uh, axis=-1, keepdims=True)
    ap = a - along * uh
    bp = np.cross(uh, ap)
    cos_beta = float(np.dot(axis0, child0) / (np.linalg.norm(axis0) * np.linalg.norm(child0)))
    big_a = np.sum(ap * wh, axis=-1)
    big_b = np.sum(bp * wh, axis=-1)
    c = cos_beta - along[:, 0] * np.sum(uh * wh, axis=-1)
    r = np.hypot(big_a, big_b)
    base = np.arctan2(big_b, big_a)
    delta = np.arccos(np.clip(c / np.maximum(r, 1e-12), -1.0, 1.0))
    cands = np.stack([base + delta, base - delta], axis=1)
    cands = (cands + np.pi) % (2 * np.pi) - np.pi
    cost = np.abs(cands)
    if hinge_range is not None:
        # prefer the twist whose child hinge angle lies in range (a knee bends forward, not back)
        lo, hi = hinge_range
        for k in range(2):
            gk = Rotation.from_rotvec(uh * cands[:, k:k + 1]).as_matrix() @ g
            ak = np.einsum("tij,j->ti", gk, axis0 / np.linalg.norm(axis0))
            sk = np.einsum("tij,j->ti", gk, child0)
            p0 = sk - np.sum(sk * ak, axis=-1, keepdims=True) * ak
            p1 = wh - np.sum(wh * ak, axis=-1, keepdims=True) * ak
            ang = np.arctan2(np.sum(ak * np.cross(p0, p1), axis=-1), np.sum(p0 * p1, axis=-1))
            outside = np.maximum(lo - ang, 0.0) + np.maximum(ang - hi, 0.0)
            cost[:, k] += 10.0 * outside
    phi = np.take_along_axis(cands, np.argmin(cost, axis=1)[:, None], axis=1)[:, 0]
    bend = np.linalg.norm(np.cross(uh, wh), axis=-1)
    phi = np.where((r > 1e-9) & (bend > np.sin(TWOBONE_MIN_BEND)) | (abs(cos_beta) > 0.05), phi, 0.0)
    phi = _continuous_twist(phi, cands, bend)
    return Rotation.from_rotvec(uh * phi[:, None]).as_matrix() @ g


#: A limb bent less than this (rad) has an ill-conditioned twist: a nearly straight knee or elbow is
#: reached by almost any twist, so the capture's noise (or a knee passing through straight into a
#: slight hyperextension) flips it by up to pi between frames (games105's hips near frames 110/146).
TWOBONE_RELIABLE_BEND = np.radians(10.0)


def _continuous_twist(phi: FloatArray, cands: FloatArray, bend: FloatArray) -> FloatArray:
    """Twists (T,) made continuous through nearly straight frames: where the limb bends less than
    :data:`TWOBONE_RELIABLE_BEND` (``bend``: sines, T), the twist interpolated in time from the reliable
    frames around (unwrapped), the candidate (``cands`` (T, 2)) nearest it taken and eased in as the
    bend grows from :data:`TWOBONE_MIN_BEND`."""
    ang = np.arcsin(np.clip(bend, 0.0, 1.0))
    good = ang >= TWOBONE_RELIABLE_BEND
    if good.all() or not good.any():
        return phi
    t = np.arange(len(phi))
    base = np.interp(t, t[good], np.unwrap(phi[good]))
    near = np.take_along_axis(cands, np.argmin(np.abs(_wrap(cands - base[:, None])), axis=1)[:, None], axis=1)[:, 0]
    w = np.clip((ang - TWOBONE_MIN_BEND) / (TWOBONE_RELIABLE_BEND - TWOBONE_MIN_BEND), 0.0, 1.0)
    w = w * w * (3.0 - 2.0 * w)
    out = base + w * _wrap(near - base)
    return np.where(good, phi, _wrap(out))


def fit_orientations(plan: BodyPlanSet, pts: SourcePoints) -> dict[str, FloatArray]:
    """World rotation matrices (T, 3, 3) of every body over the motion."""
    out: dict[str, FloatArray] = {}
    n = pts.positions.shape[0]
    for b in plan.bodies:
        f = b.fit
        if f is None:
            raise ModelError(f"body {b.name!r} has no fit plan")
        if f.ref == "parent":
            ref = out[b.parent] if b.parent else np.tile(np.eye(3), (n, 1, 1))
        elif f.ref.startswith("bvh:"):
            ref = pts.rotation(f.ref[4:])
        else:
            ref = np.tile(np.eye(3), (n, 1, 1))
        o_cur = pts[f.origin]
        rv = np.asarray(f.rest_vectors, dtype=float)
        method = _FIT_METHODS.get(f.method)
        if method is None:
            raise ModelError(f"body {b.name!r}: unknown fit method {f.method!r}")
        out[b.name] = method(f, pts, ref, o_cur, rv)
    return out


def _fit_ref(f: FitPlan, pts: SourcePoints, ref: FloatArray, o_cur: FloatArray, rv: FloatArray) -> FloatArray:
    """``ref``: the reference rotation (T, 3, 3) itself."""
    return ref.copy()


def _fit_kabsch(f: FitPlan, pts: SourcePoints, ref: FloatArray, o_cur: FloatArray, rv: FloatArray) -> FloatArray:
    """``kabsch``: the rotations (T, 3, 3) that best carry the rest vectors ``rv`` (N, 3; m) onto the
    motion's vectors from the origin ``o_cur`` (T, 3; m) to ``f.points``."""
    cv = np.stack([pts[p] - o_cur for p in f.points], axis=1)
    return kabsch(rv, cv, ref, f.weights)


def _fit_aim(f: FitPlan, pts: SourcePoints, ref: FloatArray, o_cur: FloatArray, rv: FloatArray) -> FloatArray:
    """``aim``: ``ref`` (T, 3, 3) turned by the smallest rotation that makes the rest bone ``rv[0]``
    point from the origin ``o_cur`` (T, 3; m) at ``f.points[0]``."""
    u = pts[f.points[0]] - o_cur
    return _min_rotation(np.einsum("tij,j->ti", ref, rv[0]), u) @ ref


def _fit_twobone(f: FitPlan, pts: SourcePoints, ref: FloatArray, o_cur: FloatArray, rv: FloatArray) -> FloatArray:
    """``twobone``: the ``aim`` at the middle joint ``f.points[0]``, twisted so the child's hinge
    ``f.hinge_axis`` can reach the end joint ``f.points[1]`` (:func:`_twobone_twist`)."""
    g = _fit_aim(f, pts, ref, o_cur, rv)
    u = pts[f.points[0]] - o_cur
    assert f.hinge_axis is not None
    return _twobone_twist(g, u, pts[f.points[1]] - pts[f.points[0]], np.asarray(f.hinge_axis), rv[1], f.hinge_range)


def _fit_hinge(f: FitPlan, pts: SourcePoints, ref: FloatArray, o_cur: FloatArray, rv: FloatArray) -> FloatArray:
    """``hinge``: the parent's frame ``ref`` (T, 3, 3) rotated about the hinge ``f.hinge_axis`` until
    the rest bone ``rv[0]`` points from the origin ``o_cur`` (T, 3; m) as near ``f.points[0]`` as the
    hinge allows."""
    assert f.hinge_axis is not None
    a = _unit(np.einsum("tij,j->ti", ref, np.asarray(f.hinge_axis)))
    s0 = np.einsum("tij,j->ti", ref, rv[0])
    w = pts[f.points[0]] - o_cur
    p0 = s0 - np.sum(s0 * a, axis=-1, keepdims=True) * a
    p1 = w - np.sum(w * a, axis=-1, keepdims=True) * a
    theta = np.arctan2(np.sum(a * np.cross(p0, p1), axis=-1), np.sum(p0 * p1, axis=-1))
    return Rotation.from_rotvec(a * theta[:, None]).as_matrix() @ ref


#: Fit methods by :attr:`FitPlan.method` name: (fit plan, source points, reference rotations (T, 3, 3),
#: origin positions (T, 3; m), rest vectors (N, 3; m)) -> world rotations (T, 3, 3).
_FIT_METHODS: dict[str, Callable[[FitPlan, SourcePoints, FloatArray, FloatArray, FloatArray], FloatArray]] = {
    "ref": _fit_ref,
    "kabsch": _fit_kabsch,
    "aim": _fit_aim,
    "twobone": _fit_twobone,
    "hinge": _fit_hinge,
}
