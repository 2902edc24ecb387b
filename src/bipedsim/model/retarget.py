"""Retargeting: a :class:`Motion` onto a built model, giving a :class:`ReferenceClip`.

Each body's world orientation is fitted to the source motion (see :class:`~bipedsim.model.plan.FitPlan`):

- ``kabsch``: the rotation that best carries the body's rest-pose points (relative to its origin) onto
  where the motion puts them (least squares, SVD), lightly regularised toward a reference joint's
  rotation so it stays defined when the points are nearly collinear;
- ``aim``: a reference rotation turned by the smallest rotation that makes the bone point where the
  motion's does (keeps the reference's twist);
- ``twobone``: aim at the middle joint, with the twist that puts the end joint in the plane of the
  child's hinge -- so a 3-DOF hip plus a 1-DOF knee reproduce knee and ankle positions exactly (same
  for shoulder + elbow).

Local rotations ``G_parent^T G_body`` are then split into the body's joints: hinge sets by intrinsic
Euler decomposition on their axes, single hinges by the twist about their axis, ball joints as
quaternions. Velocities come from ``mj_differentiatePos`` (central differences on the manifold).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.model.clip import ReferenceClip, contact_labels, debounce, foot_speeds, gait_events
from bipedsim.model.gait import contacts_from_strikes, load_events, side_contacts
from bipedsim.model.plan import BodyPlanSet, FitPlan, model_hash, plan_from_model
from bipedsim.model.source import SourcePoints, motion_points
from bipedsim.motion.motion import Motion

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


def _wrap(a: FloatArray) -> FloatArray:
    return (a + np.pi) % (2 * np.pi) - np.pi


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


#: A humanoid foot's shortest swing (s): a shorter lift is a shuffle or a pivot, not a step (a walk's
#: swing lasts 0.3-0.5 s).
MIN_SWING_S = 0.15


def retarget(motion: Motion, model: mujoco.MjModel, *, plan: BodyPlanSet | None = None,
             xml: str | None = None, contact_height: float = 0.05, contact_speed: float = 0.5,
             source: str = "", trim_glitches: bool = True,
             events: str | os.PathLike[str] | None = None) -> ReferenceClip:
    """Retarget a motion (project frame: metres, Z up) onto a model built by bipedsim.

    Contacts: a humanoid's heel and toe each touch when near their own ground level and nearly still,
    thresholds measured on the clip (:mod:`bipedsim.model.gait`); a creature's feet when the lowest
    point is below ``contact_height`` (m) and it moves slower than ``contact_speed`` (m/s). With ``trim_glitches``,
    leading frames that jump away from the rest of the take (the T-pose frame some releases start
    with) are dropped; ``clip.trimmed_frames`` says how many. ``events``: a YAML of foot strikes given
    by hand (:func:`bipedsim.model.gait.load_events`; frames of the file) that replaces the detected ones.
    """
    plan = plan or plan_from_model(model)
    trimmed = leading_glitch_frames(motion) if trim_glitches else 0
    if trimmed:
        motion = motion[trimmed:]
    if list(motion.skeleton.names) != list(plan.source_names):
        raise ModelError("this motion's skeleton is not the one the model was built from "
                         f"({motion.num_joints} joints vs {len(plan.source_names)}); convert its BVH first")
    pts = motion_points(motion).turned(plan.heading_yaw)
    qpos = _pose_qpos(model, plan, pts, fit_orientations(plan, pts))
    feet = plan.foot_bodies or [b.name for b in plan.bodies]
    low, fpos = foot_heights(model, qpos, feet)
    low, tilt, lift = _put_on_floor(qpos, low, fpos, motion.frame_time, contact_speed)
    qvel = velocities(model, qpos, motion.frame_time)
    side_feet = _foot_groups(plan, feet)
    low_g = _group_min(low, feet, side_feet)
    if plan.profile == "humanoid":  # heel and toe separately, thresholds measured on the clip (model.gait)
        groups = [[feet.index(f) for f in fs] for fs in side_feet.values()]
        grouped = debounce(side_contacts(low, fpos, motion.frame_time, groups), motion.frame_time,
                           min_gap=MIN_SWING_S)
    else:
        speed_g = _group_min(foot_speeds(fpos, motion.frame_time), feet, side_feet)
        grouped = debounce(contact_labels(low_g, speed_g, contact_height, contact_speed), motion.frame_time)
    if events is not None:
        given = load_events(events, list(side_feet), motion.num_frames + trimmed, motion.frame_time)
        given = {f: [s - trimmed for s in v if s >= trimmed] for f, v in given.items()}
        grouped = contacts_from_strikes(given, list(side_feet), motion.num_frames)
    return ReferenceClip(qpos=qpos, qvel=qvel, frame_time=motion.frame_time, contacts=grouped,
                         foot_names=list(side_feet), foot_heights=low_g,
                         events=gait_events(grouped, list(side_feet)),
                         model_hash=model_hash(xml) if xml is not None else "",
                         joint_names=[model.joint(i).name for i in range(model.njnt)], source=source,
                         vertical_shift=lift, trimmed_frames=trimmed,
                         floor_slope=(0.0, 0.0) if tilt is None else tilt)


def _pose_qpos(model: mujoco.MjModel, plan: BodyPlanSet, pts: SourcePoints, g: dict[str, FloatArray]) -> FloatArray:
    """(T, nq) joint positions for the bodies' world rotations ``g`` (T, 3, 3 each): the root's free
    joint at the source root (m) and rotation, each other body's local rotation ``G_parent^T G_body``
    as a ball quaternion or split into its hinge angles (rad)."""
    qpos = np.zeros((pts.positions.shape[0], model.nq))
    for b in plan.bodies:
        if b.parent is None:
            qpos[:, 0:3] = pts[b.source]
            qpos[:, 3:7] = Rotation.from_matrix(g[b.name]).as_quat(scalar_first=True)
            continue
        local = np.transpose(g[b.parent], (0, 2, 1)) @ g[b.name]
        if not b.joints:
            continue
        if b.joints[0].kind == "ball":
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, b.joints[0].name)
            adr = model.jnt_qposadr[jid]
            qpos[:, adr:adr + 4] = Rotation.from_matrix(local).as_quat(scalar_first=True)
            continue
        ang = _hinge_angles(local, [np.asarray(j.axis) for j in b.joints])
        if len(b.joints) == 3:
            ang = _in_range_euler(ang, np.array([j.range for j in b.joints], dtype=float),
                                  hinge_basis([np.asarray(j.axis) for j in b.joints])[1])
        for k, j in enumerate(b.joints):
            jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            qpos[:, model.jnt_qposadr[jid]] = ang[:, k]
    return qpos


def _put_on_floor(qpos: FloatArray, low: FloatArray, fpos: FloatArray, dt: float,
                  speed: float) -> tuple[FloatArray, tuple[float, float] | None, float]:
    """Level a tilted capture floor (:func:`floor_tilt`), then lift so the lowest point any foot
    reaches touches z = 0. Shifts the root height in ``qpos`` (T, nq) and the foot positions ``fpos``
    (T, F, 3; m) in place; returns the feet's lowest points ``low`` (T, F; m) shifted alike, the floor
    slope (or None) and the lift (m)."""
    tilt = floor_tilt(low, fpos, dt, speed)
    if tilt is not None:
        dz = -(tilt[0] * qpos[:, 0] + tilt[1] * qpos[:, 1])
        qpos[:, 2] += dz
        low = low + dz[:, None]
        fpos[..., 2] += dz[:, None]
    lift = -float(np.min(low))
    qpos[:, 2] += lift
    low = low + lift
    fpos[..., 2] += lift
    return low, tilt, lift


#: Minimum stance samples and horizontal spread (m) for fitting the capture's floor plane.
FLOOR_FIT_MIN_SAMPLES = 20
FLOOR_FIT_MIN_SPREAD_M = 0.5
#: Largest floor slope (rise per metre) corrected; steeper means real terrain, not a tilted capture.
FLOOR_FIT_MAX_SLOPE = 0.05


def floor_tilt(low: FloatArray, pos: FloatArray, dt: float, speed: float) -> tuple[float, float] | None:
    """Slope (dz/dx, dz/dy) of the floor under the stance feet, or None if it cannot be told.

    Stance samples: a foot moving slower than ``speed`` and in the lowest 30 % of its heights. The
    plane is fitted by least squares, refitted without samples more than 2 cm off.
    """
    if len(low) < 3:
        return None
    sp = np.linalg.norm(np.gradient(pos[..., :2], dt, axis=0), axis=-1)
    mask = (sp < speed) & (low <= np.percentile(low, 30, axis=0))
    xy, z = pos[..., :2][mask], low[mask]
    if len(z) < FLOOR_FIT_MIN_SAMPLES:
        return None
    # fit the slope only along directions the feet actually cover (a straight walk spans one)
    centred = xy - xy.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    spread = 4.0 * sv / np.sqrt(len(z))  # ~ the samples' extent along each principal direction
    dirs = vt[spread >= FLOOR_FIT_MIN_SPREAD_M]
    if len(dirs) == 0:
        return None
    a = np.concatenate([centred @ dirs.T, np.ones((len(z), 1))], axis=1)
    coef = np.linalg.lstsq(a, z, rcond=None)[0]
    keep = np.abs(a @ coef - z) < 0.02
    if keep.sum() >= FLOOR_FIT_MIN_SAMPLES:
        coef = np.linalg.lstsq(a[keep], z[keep], rcond=None)[0]
    slope = coef[:-1] @ dirs  # back to (dz/dx, dz/dy)
    if np.hypot(*slope) > FLOOR_FIT_MAX_SLOPE:
        return None
    return float(slope[0]), float(slope[1])


#: The pose change behind :func:`leading_glitch_frames` is measured over this stride (s), not per frame:
#: a T-pose frame blended out over 4 frames at 120 fps is one frame at 30 fps.
GLITCH_STRIDE_S = 1.0 / 30.0


def leading_glitch_frames(motion: Motion, jump: float = 5.0, settle: float = 3.0, limit_s: float = 0.1) -> int:
    """How many first frames are not part of the take (a T-pose frame, or a few frames blending out
    of one, as some releases start with): the pose change over :data:`GLITCH_STRIDE_S` (the largest
    joint displacement relative to the root) from the first frame must exceed ``jump`` x the clip's
    median change over that stride, and frames are dropped while the change to the next frame stays
    above ``settle`` x its median, for at most ``limit_s`` seconds: a glitch's first change is about ten
    times the median, a take's own first change a small multiple of it."""
    dt = motion.frame_time
    k = max(1, int(round(GLITCH_STRIDE_S / dt)))
    limit = max(1, int(round(limit_s / dt)))
    if motion.num_frames < 4 * limit + k:
        return 0
    pos = motion.fk()[0]
    rel = pos - pos[:, :1]
    stride = np.linalg.norm(rel[k:] - rel[:-k], axis=-1).max(axis=1)
    if stride[0] <= jump * (float(np.median(stride)) + 1e-9):
        return 0
    step = np.linalg.norm(np.diff(rel, axis=0), axis=-1).max(axis=1)  # the blend's end, frame by frame
    med = float(np.median(step)) + 1e-9
    n = 1
    while n < limit and step[n] > settle * med:
        n += 1
    return n


def _foot_groups(plan: BodyPlanSet, feet: list[str]) -> dict[str, list[str]]:
    """Humanoid feet group by side (foot + toe); creature end effectors stand alone."""
    if plan.profile == "humanoid":
        return {s: [f for f in feet if f.startswith(s + "_")] for s in ("left", "right")}
    return {f: [f] for f in feet}


def _group_min(low: FloatArray, feet: list[str], groups: dict[str, list[str]]) -> FloatArray:
    return np.stack([low[:, [feet.index(f) for f in fs]].min(axis=1) for fs in groups.values()], axis=1)


def foot_heights(model: mujoco.MjModel, qpos: FloatArray, feet: list[str]) -> tuple[FloatArray, FloatArray]:
    """Lowest point (T, F) of each foot body's geoms and the body positions (T, F, 3) per frame."""
    data = mujoco.MjData(model)
    bids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f) for f in feet]
    geoms = [[gi for gi in range(model.ngeom) if model.geom_bodyid[gi] == b] for b in bids]
    low = np.zeros((len(qpos), len(feet)))
    pos = np.zeros((len(qpos), len(feet), 3))
    for t, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for k, gl in enumerate(geoms):
            low[t, k] = min(geom_lowest_z(model, data, gi) for gi in gl)
            pos[t, k] = data.xpos[bids[k]]
    return low, pos


def geom_lowest_z(model: mujoco.MjModel, data: mujoco.MjData, gi: int) -> float:
    """Lowest world z of a geom (box, capsule or sphere) in the current pose."""
    c = data.geom_xpos[gi]
    r = data.geom_xmat[gi].reshape(3, 3)
    s = model.geom_size[gi]
    typ = model.geom_type[gi]
    if typ == mujoco.mjtGeom.mjGEOM_BOX:
        return float(c[2] - np.abs(r[2]) @ s)
    if typ == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return float(c[2] - abs(r[2, 2]) * s[1] - s[0])
    return float(c[2] - s[0])


def velocities(model: mujoco.MjModel, qpos: FloatArray, dt: float) -> FloatArray:
    """(T, nv) joint velocities: central differences on the configuration manifold."""
    t = len(qpos)
    qvel = np.zeros((t, model.nv))
    if t < 2:
        return qvel
    v = np.zeros(model.nv)
    for i in range(t):
        a, b = max(i - 1, 0), min(i + 1, t - 1)
        mujoco.mj_differentiatePos(model, v, (b - a) * dt, qpos[a], qpos[b])
        qvel[i] = v
    return qvel


def marker_positions(model: mujoco.MjModel, clip: ReferenceClip, plan: BodyPlanSet) -> dict[str, FloatArray]:
    """Model positions (T, 3) of the source joints the reduction kept (kinematic replay)."""
    data = mujoco.MjData(model)
    markers = plan.extra.get("markers", {})
    out = {k: np.zeros((clip.num_frames, 3)) for k in markers}
    for t in range(clip.num_frames):
        data.qpos[:] = clip.qpos[t]
        mujoco.mj_kinematics(model, data)
        for src, (kind, name) in markers.items():
            if kind == "body":
                out[src][t] = data.xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)]
            else:
                out[src][t] = data.site_xpos[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)]
    return out


def source_marker_positions(motion: Motion, clip: ReferenceClip, plan: BodyPlanSet) -> dict[str, FloatArray]:
    """The same joints' positions in the source motion, in the model's frame (turned, lifted)."""
    motion = motion[clip.trimmed_frames:]
    pts = motion_points(motion).turned(plan.heading_yaw)
    out = {}
    for src in plan.extra.get("markers", {}):
        p = pts[src].copy()
        root = pts[plan.bodies[0].source]
        p[:, 2] += clip.vertical_shift - clip.floor_slope[0] * root[:, 0] - clip.floor_slope[1] * root[:, 1]
        out[src] = p
    return out
