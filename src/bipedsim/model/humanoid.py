"""The humanoid profile: a source skeleton reduced to the paper's physics skeleton.

Bodies: pelvis (free joint), torso (spine, 3 hinges), head (neck, 3 hinges), per side upper arm
(shoulder, 3), lower arm (elbow, 1; the hand is merged into it), thigh (hip, 3), shin (knee, 1), foot
(ankle, 1 or 2), toe (toe, 1; only when the source has a toe joint, else the foot reaches the toe tip).
Every other source joint (fingers, clavicles, extra spine and neck links, helper bones) is dropped:
its rotation is absorbed into the orientation fit of the body it belongs to.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.model.naming import HumanoidMap, MapFile, map_from_roles, recognise_humanoid
from bipedsim.model.plan import BodyPlan, BodyPlanSet, FitPlan, GeomPlan, JointPlan, SitePlan
from bipedsim.model.profile import HumanoidProfile, JointSpec, load_profile
from bipedsim.model.retarget import _min_rotation, kabsch
from bipedsim.model.source import SourcePoints, motion_points, rest_points
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]

BASIS = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}
FORWARD = np.array([1.0, 0.0, 0.0])
#: Shortest bone (m) the builder accepts; shorter ones are zero-length for practical purposes.
MIN_BONE_M = 0.01
#: The shortest toe box (m), toe joint to tip.
MIN_TOE_M = 0.03
#: Touch-sensor sites reach this far below and above the sole (m).
TOUCH_MARGIN_M = 0.02
#: Touch-sensor boxes reach this far (m) beyond the sides of the foot and toe boxes.
TOUCH_PAD_M = 0.005


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


#: The named sides are taken as mirrored when the knees (and the feet, where measured) face the other
#: way from the hips' named sides by more than this (a cosine; real skeletons measure +0.39 to +1.00 for
#: the knees and +0.61 to +1.00 for the feet, a skeleton with its side names swapped -0.92 to -0.99).
MIRRORED_SIDES_COS = -0.5
#: The knees' bend is evidence when they leave the hip-ankle line by at least this much on average (m):
#: a motion with straight legs (a T-pose, a stand) says nothing about where its knees point.
MIN_KNEE_BEND_M = 0.03


def side_evidence(moving: SourcePoints, hm: HumanoidMap) -> dict[str, float]:
    """How well the legs agree with the hips' named sides, over the motion ``moving`` (project frame, Z
    up): with forward the named left hip minus the right, crossed with up, ``knee`` is the mean cosine
    between forward and where the knees leave the hip-ankle line (weighted by how far), ``foot`` the
    same for the feet (ankle to toe, or to the ankle's end site), both horizontal; +1: the names' forward,
    -1: the opposite. A value is left out when the motion cannot tell (straight knees, no foot point);
    ``knee_bend_m`` is the knees' mean distance from the hip-ankle line."""
    legs = hm.legs
    left = moving[legs["left"]["thigh"]] - moving[legs["right"]["thigh"]]  # type: ignore[index]
    fwd = np.cross(left, [0.0, 0.0, 1.0])
    fwd[..., 2] = 0.0
    fwd /= np.linalg.norm(fwd, axis=-1, keepdims=True) + 1e-12
    knee = [0.0, 0.0]
    foot = [0.0, 0.0]
    for leg in legs.values():
        h, k, a = moving[leg["thigh"]], moving[leg["knee"]], moving[leg["ankle"]]  # type: ignore[index]
        u = (a - h) / (np.linalg.norm(a - h, axis=-1, keepdims=True) + 1e-12)
        e = (k - h) - np.sum((k - h) * u, axis=-1, keepdims=True) * u
        e[..., 2] = 0.0
        knee[0] += float(np.sum(e * fwd))
        knee[1] += float(np.sum(np.linalg.norm(e, axis=-1)))
        ends = [n for n in moving.names if n.startswith(f"{leg['ankle']}/end")]
        tip = leg["toe"] or (ends[0] if ends else None)
        if tip is not None:
            d = moving[tip] - a
            d[..., 2] = 0.0
            foot[0] += float(np.sum(d * fwd))
            foot[1] += float(np.sum(np.linalg.norm(d, axis=-1)))
    frames = max(1, int(np.prod(fwd.shape[:-1])))
    out = {"knee_bend_m": knee[1] / (2 * frames)}
    if out["knee_bend_m"] >= MIN_KNEE_BEND_M:
        out["knee"] = knee[0] / knee[1]
    if foot[1] > 1e-9:
        out["foot"] = foot[0] / foot[1]
    return out


def mirrored_sides(evidence: dict[str, float]) -> bool:
    """Whether the legs face away from the hips' named sides (:func:`side_evidence`): the knees bend
    backward of the named forward (below :data:`MIRRORED_SIDES_COS`) and the feet, where measured, point
    backward too. Without bent knees nothing is exchanged: a foot's end site alone can point back (the BVH
    specification's sample), and a body left as named is no worse than the file says."""
    if evidence.get("knee", 1.0) >= MIRRORED_SIDES_COS:
        return False
    return evidence.get("foot", -1.0) < MIRRORED_SIDES_COS


def check_sides(moving: SourcePoints, hm: HumanoidMap) -> tuple[HumanoidMap, dict[str, Any] | None]:
    """The roles ``hm`` found from names, with left and right exchanged when the legs face away from the
    named sides over the motion ``moving`` (:func:`mirrored_sides`), and the evidence for
    :func:`sides_note` (None when the names' sides were kept)."""
    ev = side_evidence(moving, hm)
    if not mirrored_sides(ev):
        return hm, None
    note = {"named_left": hm.legs["left"]["thigh"], "named_right": hm.legs["right"]["thigh"],
            **{k: round(v, 2) for k, v in ev.items()}}
    return _swap_sides(hm), note


def _swap_sides(hm: HumanoidMap) -> HumanoidMap:
    """The same roles with left and right exchanged (legs, and arms where there are both)."""
    legs = {"left": hm.legs["right"], "right": hm.legs["left"]}
    arms = {"left": hm.arms["right"], "right": hm.arms["left"]} if len(hm.arms) == 2 else hm.arms
    return HumanoidMap(pelvis=hm.pelvis, torso_base=hm.torso_base, chest=hm.chest, neck=hm.neck, head=hm.head,
                       legs=legs, arms=arms)


def _facing_yaw(pts: SourcePoints, hm: HumanoidMap) -> float:
    """Yaw (rad) about +z that turns the rest pose to face +x (from the hips: forward = left x up)."""
    left = pts[hm.legs["left"]["thigh"]] - pts[hm.legs["right"]["thigh"]]  # type: ignore[index]
    fwd = np.cross(left, [0.0, 0.0, 1.0])
    if np.hypot(fwd[0], fwd[1]) < 1e-9:
        raise ModelError("cannot tell which way the rest pose faces: the hip joints coincide")
    return float(-np.arctan2(fwd[1], fwd[0]))


#: Stance frames for the flat-foot frame: foot points within this height (m) of their lowest level and
#: the joint slower than FLAT_SPEED (m/s); tilts under FLAT_MIN_TILT (rad) are left at the rest frame.
FLAT_HEIGHT_M = 0.02
FLAT_SPEED = 0.3
FLAT_MIN_TILT = 0.02
#: Largest sole pitch (rad) against the rest pose.
MAX_SOLE_PITCH = 0.6
#: Smallest knee bend (rad) at which the hip-knee-ankle plane defines the foot's lateral axis.
MIN_PLANE_BEND = 0.05


def _flat_frame(moving: SourcePoints, joint: str, points: list[str], forward: FloatArray,
                hinge_plane: tuple[str, str, str] | None = None, hinge_axis: FloatArray | None = None,
                hinge_world: FloatArray | None = None) -> FloatArray:
    """Axes (columns, body coordinates) of a foot segment's sole. The sole must be level when the
    motion has the segment flat on the floor (all ``points`` at their lowest level and ``joint``
    still), not in the rest pose, which need not stand flat-footed.

    On those frames the segment's orientation is the one the model can give it: its forward bone
    ``forward`` (rest pose) turned onto ``points[0] -> points[1]``, and its lateral axis ``hinge_axis``
    (the knee's, rest pose; the ankle and toe hinges are parallel to it) onto the normal of the leg's
    plane ``hinge_plane`` (hip, knee, ankle), where the twobone fit puts the knee hinge. A 1-DOF
    ankle cannot roll the foot, so the leg's plane on the floor sets the sole's roll: the sole is the
    rest frame turned so that its normal is vertical on the mean flat frame (pitch and roll, at
    most MAX_SOLE_PITCH). Without ``hinge_plane`` (or where the leg is too straight to define its
    plane) only the pitch is corrected. Identity when the correction is under FLAT_MIN_TILT or the
    motion never shows the segment flat (one-frame files). ``hinge_world`` (T, 3): where the motion
    puts ``hinge_axis`` on each frame, given when the segment's roll is not the leg plane's (a 2-DOF
    ankle rolls the foot as the capture does: :meth:`_HumanoidBuilder._foot_hinge_world`)."""
    eye = np.eye(3)
    flat = _flat_frames(moving, joint, points)
    if flat is None:
        return eye
    bone = moving[points[1]][flat] - moving[points[0]][flat]
    if float(np.median(np.linalg.norm(bone, axis=1))) < MIN_BONE_M:
        return eye
    f_rest = np.asarray(forward, dtype=float)
    lateral_rest = np.cross([0.0, 0.0, 1.0], f_rest)
    if np.linalg.norm(lateral_rest) < 1e-6:
        return eye
    plane = None
    if hinge_world is not None and hinge_axis is not None:
        plane = hinge_world[flat] / np.linalg.norm(hinge_world[flat], axis=1, keepdims=True), bone
    elif hinge_plane is not None and hinge_axis is not None:
        plane = _leg_plane_normals(moving, flat, hinge_plane, bone)
    if plane is None:
        normal, y_rest = _pitch_normals(bone, lateral_rest), lateral_rest
    else:
        (normal, bone), y_rest = plane, np.asarray(hinge_axis, dtype=float)
    return _levelling_rotation(f_rest, y_rest, bone, normal)


def _flat_frames(moving: SourcePoints, joint: str, points: list[str]) -> npt.NDArray[np.bool_] | None:
    """Frames (T,) on which a foot segment lies flat: every one of ``points`` within FLAT_HEIGHT_M (m)
    of its lowest level (its 10th height percentile) and ``joint`` still; None when fewer than 3
    frames (or fewer than 3 in the motion) qualify."""
    pos = moving.positions
    if pos.ndim != 3 or pos.shape[0] < 3:
        return None
    h = np.stack([moving[p][:, 2] for p in points], axis=1)
    low = np.all(h < np.percentile(h, 10, axis=0) + FLAT_HEIGHT_M, axis=1)
    j = moving[joint]
    speed = np.zeros(len(j))
    speed[1:] = np.linalg.norm(np.diff(j, axis=0), axis=1)
    # frame time is not known here: "still" = moving less than FLAT_SPEED at 120 fps, or 10 % of the
    # median per-frame motion for slower captures
    still = speed <= max(FLAT_SPEED / 120.0, 0.1 * float(np.median(speed[1:])))
    flat = low & still
    if flat.sum() < 3:
        return None
    return flat


def _leg_plane_normals(moving: SourcePoints, flat: npt.NDArray[np.bool_], hinge_plane: tuple[str, str, str],
                       bone: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """Unit normals (N, 3, world frame) of the leg's plane ``hinge_plane`` (hip, knee, ankle) on the
    flat frames where the knee bends at least MIN_PLANE_BEND, turned to the foot's left, with the foot
    bones ``bone`` of those frames; None when fewer than 3 frames bend enough."""
    a, b, c = (moving[n][flat] for n in hinge_plane)
    n = np.cross(b - a, c - b)
    size = np.linalg.norm(n, axis=1) / np.maximum(np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1),
                                                  1e-12)
    ok = size > np.sin(MIN_PLANE_BEND)
    if ok.sum() < 3:
        return None
    normal, bone = n[ok] / np.linalg.norm(n[ok], axis=1, keepdims=True), bone[ok]
    # the knee bends one way: the normal on the foot's left-hand side (a straightened or
    # over-extended knee would flip the plane's orientation)
    left = np.cross([0.0, 0.0, 1.0], bone)
    return np.where(np.sum(normal * left, axis=1, keepdims=True) < 0, -normal, normal), bone


def _pitch_normals(bone: FloatArray, lateral_rest: FloatArray) -> FloatArray:
    """Horizontal unit lateral axes (N, 3, world frame) normal to the foot bones ``bone``, on the side
    of ``lateral_rest``: the sole keeps its roll and only its pitch (the bone's dip against the rest
    pose's) is corrected."""
    normal = np.cross(bone, [0.0, 0.0, 1.0])
    normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    return np.where((normal @ lateral_rest)[:, None] < 0, -normal, normal)


def _levelling_rotation(f_rest: FloatArray, y_rest: FloatArray, bone: FloatArray, normal: FloatArray) -> FloatArray:
    """Rotation (3, 3, body coordinates) that levels the sole: turns the world vertical, averaged over
    the flat frames where the rest frame (``f_rest``, ``y_rest``) is carried onto (``bone``,
    ``normal``), back onto +z; at most MAX_SOLE_PITCH (rad), identity under FLAT_MIN_TILT."""
    # per flat frame: G = B A^T carries the rest frame A = (forward, lateral, ...) onto B = (bone, normal, ...)
    rest_frame = _frame_from(f_rest[None], y_rest[None])[0]
    frames = _frame_from(bone, normal)
    # the world vertical in body coordinates, G^T z = A B^T z, on each flat frame
    up_b = np.einsum("ij,tkj,k->ti", rest_frame, frames, np.array([0.0, 0.0, 1.0]))
    s = up_b.mean(axis=0)
    s = s / np.linalg.norm(s)
    angle = float(np.arccos(np.clip(s[2], -1.0, 1.0)))
    if angle < FLAT_MIN_TILT:
        return np.eye(3)
    axis = np.cross([0.0, 0.0, 1.0], s)
    axis = axis / np.linalg.norm(axis)
    return Rotation.from_rotvec(axis * min(angle, MAX_SOLE_PITCH)).as_matrix()


def _frame_from(x: FloatArray, y: FloatArray) -> FloatArray:
    """(T, 3, 3) right-handed frames (columns) with y along ``y`` and x along ``x`` made normal to it."""
    y = y / np.linalg.norm(y, axis=1, keepdims=True)
    x = x - np.sum(x * y, axis=1, keepdims=True) * y
    x = x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-12)
    return np.stack([x, y, np.cross(x, y)], axis=2)


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


#: Weight of the neck against the shoulders when fitting the torso's orientation: the shoulders
#: are where the arms hang, so they matter more than the neck base.
NECK_FIT_WEIGHT = 0.05
#: Calibration passes for the rigid pelvis and torso (fit, average, refit).
CALIBRATION_PASSES = 3
#: Further passes that centre each point between its extremes (minimax instead of least squares).
MIDRANGE_PASSES = 3


def calibrate_rigid(pts: SourcePoints, origin: str, points: list[str], ref_joint: str,
                    rest_vecs: FloatArray, weights: FloatArray | None = None) -> FloatArray:
    """Where a rigid body's points sit relative to its origin, as the motion shows them on average.

    The source may move these points relative to each other (CMU's hip helper joints, clavicles,
    several spine links); a rigid body cannot. Fit the body's orientation on every frame, express the
    points in that frame, average, and repeat: the result is the rigid layout closest to the motion.
    """
    cur = np.stack([pts[p] - pts[origin] for p in points], axis=1)
    ref = pts.rotation(ref_joint)
    vecs = rest_vecs
    for k in range(CALIBRATION_PASSES + MIDRANGE_PASSES):
        r = kabsch(vecs, cur, ref, weights)
        local = np.einsum("tji,tnj->tni", r, cur)
        # mean first; then the midrange, which minimises the worst frame's error per axis
        vecs = local.mean(axis=0) if k < CALIBRATION_PASSES else 0.5 * (local.min(axis=0) + local.max(axis=0))
    return vecs


def rigid_residual(pts: SourcePoints, origin: str, points: list[str], ref_joint: str, vecs: FloatArray,
                   weights: FloatArray | None = None) -> FloatArray:
    """Worst distance (m) over the motion between each point and where the rigid layout ``vecs``,
    fitted per frame, puts it."""
    cur = np.stack([pts[p] - pts[origin] for p in points], axis=1)
    r = kabsch(vecs, cur, pts.rotation(ref_joint), weights)
    return np.linalg.norm(np.einsum("tij,nj->tni", r, vecs) - cur, axis=-1).max(axis=0)


#: Shortest abdomen and chest (m) of a two-segment spine.
MIN_SPINE_SEGMENT_M = 0.05


def _split_joint(rest: SourcePoints, hm: HumanoidMap) -> str | None:
    """Where a two-segment spine bends: the chest joint, or the nearest spine joint below it that
    leaves both segments at least MIN_SPINE_SEGMENT_M long (some skeletons put the neck on the chest)."""
    sk = rest.skeleton
    j = sk.index(hm.chest)
    base = sk.index(hm.torso_base)
    while j >= 0 and j != base:
        name = sk.names[j]
        if (np.linalg.norm(rest[hm.neck] - rest[name]) >= MIN_SPINE_SEGMENT_M
                and np.linalg.norm(rest[name] - rest[hm.torso_base]) >= MIN_SPINE_SEGMENT_M):
            return name
        j = int(sk.parents[j])
    return None


def _split_spine(profile: HumanoidProfile, rest: SourcePoints, moving: SourcePoints, hm: HumanoidMap,
                 torso_pts: list[str], tv: FloatArray, torso_w: FloatArray) -> str | None:
    """The joint where the torso splits into two segments, or None (see ``spine_segments`` in the
    humanoid profile)."""
    if profile.spine_segments == 1:
        return None
    at = _split_joint(rest, hm)
    if at is None:
        if profile.spine_segments == 2:
            raise ModelError(f"spine_segments: 2 needs a spine joint between {hm.torso_base!r} and the neck "
                             f"{hm.neck!r} at least {MIN_SPINE_SEGMENT_M * 100:.0f} cm from both; "
                             f"this skeleton has none")
        return None
    if profile.spine_segments == 2:
        return at
    worst = rigid_residual(moving, hm.torso_base, torso_pts, hm.chest, tv, torso_w)[1:]  # the shoulders
    return at if worst.size and worst.max() > profile.spine_split_tol else None


def humanoid_plan(motion: Motion, profile: HumanoidProfile, *, mapping: MapFile | None = None,
                  total_mass: float | None = None, name: str = "humanoid") -> BodyPlanSet:
    """The humanoid body plan for a motion's skeleton (motion in the project frame: m, Z up).

    Limb geometry comes from the skeleton's rest pose; the layout of the rigid pelvis (hips, spine
    base) and torso (neck, shoulders) is calibrated on the motion (:func:`calibrate_rigid`).
    """
    b = _HumanoidBuilder(motion, profile, mapping)
    b.fit_pelvis()
    b.fit_torso()
    b.add_pelvis()
    b.add_trunk()
    b.add_head()
    for side in ("left", "right"):
        if side in b.hm.arms:
            b.add_arm(side)
    for side in ("left", "right"):
        b.add_leg(side)
    b.scale_masses(total_mass if total_mass is not None else b.profile_mass())
    return b.plan(name, b.stand_on_floor())


def toes_note(extra: dict[str, Any]) -> str | None:
    """The line saying a body's toes were given a person's foot length (a body plan's ``extra``, where
    :meth:`_HumanoidBuilder.toe_length_without_tip` records it); None when its toes were measured."""
    toes = extra.get("toes_without_tip")
    if not toes:
        return None
    t = next(iter(toes.values()))
    return (f"the skeleton's toes end without a tip ({', '.join(toes)}); the soles reach {t['sole_m']:.2f} m heel "
            f"to toe tip, a {t['height_m']:.2f} m person's foot (profile geometry.foot_length_share "
            f"{t['foot_length_share']:g})")


def sides_note(extra: dict[str, Any]) -> str | None:
    """The line saying a body's left and right were taken from where its legs face, not from its joint
    names (a body plan's ``extra``, or a build summary); None when the names' sides were kept."""
    s = extra.get("sides_from_geometry")
    if not s:
        return None
    parts = [(w, s[k]) for k, w in (("knee", "knees bend"), ("foot", "feet point")) if k in s]
    how = " and ".join(w for w, _ in parts)
    cos = " and ".join(f"{c:+.2f}" for _, c in parts)
    return (f"the skeleton's side names are mirrored: with its named left hip on its left, its {how} backward "
            f"(cosine {cos} with that forward); {s['named_left']!r} is built as the right leg and "
            f"{s['named_right']!r} as the left (give a mapping YAML with --map to name the sides yourself)")


def mass_from_legs(leg_length: float, profile: HumanoidProfile) -> float:
    """A person's mass (kg) for legs ``leg_length`` m long (hip to ankle): the height the legs are
    ``profile.leg_share`` of, at the body-mass index ``profile.mass_bmi`` (kg/m^2)."""
    if not leg_length > 0:
        raise ModelError(f"a body's mass from its legs needs legs > 0 m, got {leg_length}")
    return profile.mass_bmi * (leg_length / profile.leg_share) ** 2


#: a head that ends where it begins (no neck joint, and a head End Site of no length: SNU's 15-joint rig)
#: is given a crown this fraction of the body's height above its joint, up the spine (chin to crown 0.13
#: of the stature, Drillis & Contini)
HEAD_TOP_SHARE = 0.13
#: a foot with no toe joint and no length (the ankle's End Site of no length: Perception Neuron exports)
#: reaches a person's foot length forward (``geometry.foot_length_share``), its tip this fraction of the
#: height below the ankle (the ankle's height, 0.039 of the stature in Winter's table)
ANKLE_HEIGHT_SHARE = 0.039


def humanoid_roles(motion: Motion, mapping: MapFile | None = None) -> tuple[HumanoidMap, bool]:
    """The humanoid roles of ``motion``'s skeleton: from its names (and ``mapping``), else -- the names
    say nothing (anonymous or foreign joint names) and no mapping is given -- the limbs found from its
    geometry (:func:`~bipedsim.model.naming.map_from_roles`). Returns them and whether the names gave
    them; a :class:`ModelError` saying what is missing when neither does."""
    try:
        return recognise_humanoid(motion.skeleton, mapping), True
    except ModelError:
        derived = map_from_roles(motion) if mapping is None else None
        if derived is None:
            raise
        return recognise_humanoid(motion.skeleton, derived), False


def with_tips(motion: Motion, notes: list[str] | None = None, profile: HumanoidProfile | None = None) -> Motion:
    """``motion`` (project frame, a standing rest pose) with a length given to the bones a humanoid's
    body needs and its skeleton leaves without one: a foot with no toe joint whose End Site lies on the
    ankle, a head with no neck whose End Site lies on the head joint. Each gets an End Site at a
    person's proportions for the body's height (legs / ``leg_share``) in the rest pose's forward or up
    direction, so it turns with the captured joint; what was done is appended to ``notes``. Unchanged
    where the tips have length or no humanoid roles are found (the builder says what is missing)."""
    sk = motion.skeleton
    try:
        hm = humanoid_roles(motion)[0]
    except ModelError:
        return motion
    prof = profile if profile is not None else _default_profile()
    rest = rest_points(motion)

    def reach(joint: str, origin: str) -> float:  # farthest point of ``joint``'s subtree from ``origin``
        return max(float(np.linalg.norm(rest[n] - rest[origin])) for n in rest.below(joint))

    legs = [hm.legs[sd] for sd in ("left", "right")]
    leg = float(np.mean([np.linalg.norm(rest[lg["knee"]] - rest[lg["thigh"]])  # type: ignore[index]
                         + np.linalg.norm(rest[lg["ankle"]] - rest[lg["knee"]]) for lg in legs]))  # type: ignore[index]
    height = leg / prof.leg_share
    up = np.array([0.0, 0.0, 1.0])
    fwd = np.cross(rest[legs[0]["thigh"]] - rest[legs[1]["thigh"]], up)  # type: ignore[index]
    tips: dict[str, FloatArray] = {}
    made: list[str] = []
    for sd, lg in zip(("left", "right"), legs):
        an, toe = lg["ankle"], lg["toe"]
        assert an
        if toe and float(np.linalg.norm(rest[toe] - rest[an])) >= MIN_BONE_M:
            continue
        if reach(an, an) >= MIN_BONE_M or np.linalg.norm(fwd[:2]) < 1e-9:
            continue
        ahead = prof.geometry.foot_length_share * height - prof.geometry.heel_length
        tips[an] = fwd / np.linalg.norm(fwd) * ahead - up * ANKLE_HEIGHT_SHARE * height
        made.append(f"{sd} foot")
    if reach(hm.head, hm.neck) < MIN_BONE_M:
        spine = rest[hm.head] - rest[hm.torso_base]
        d = spine / np.linalg.norm(spine) if np.linalg.norm(spine) > 1e-9 else up
        tips[hm.head] = d * HEAD_TOP_SHARE * height
        made.append("head")
    if not tips:
        return motion
    par, off = list(sk.end_site_parents), [np.asarray(o, dtype=float) for o in sk.end_site_offsets]
    for joint, vec in tips.items():
        j = sk.index(joint)
        if j in par:
            off[par.index(j)] = vec
        else:
            par.append(j)
            off.append(vec)
    if notes is not None:
        what = " and ".join(made)
        notes.append(f"the skeleton's {what} {'end where they begin' if len(made) > 1 else 'ends where it begins'} "
                     "(no toe or neck joint, an End Site of no length): given a person's proportions for a "
                     f"{height:.2f} m body (a foot {prof.geometry.foot_length_share:g} of the height heel to toe, a "
                     f"head {HEAD_TOP_SHARE:g} of it above its joint)")
    return motion.copy(skeleton=sk.replace(end_site_parents=np.array(par, dtype=np.int64),
                                           end_site_offsets=np.array(off).reshape(-1, 3)))


def _default_profile() -> HumanoidProfile:
    prof = load_profile("humanoid")
    assert isinstance(prof, HumanoidProfile)
    return prof


def _check_bone(v: FloatArray, a: str, b: str, what: str) -> FloatArray:
    """``v`` (m), the bone from joint ``a`` to ``b``; a ModelError when shorter than MIN_BONE_M."""
    if np.linalg.norm(v) < MIN_BONE_M:
        raise ModelError(f"zero-length bone: {what} from {a!r} to {b!r} is "
                         f"{np.linalg.norm(v) * 1000:.1f} mm long (need >= {MIN_BONE_M * 1000:.0f} mm)")
    return v


class _HumanoidBuilder:
    """Builds a humanoid body plan step by step (see :func:`humanoid_plan` for the order).

    Frames: every point and vector is in the project frame (m, Z up) with the skeleton turned by
    ``yaw`` about +z to face +x. ``q`` maps source joint (and End Site) names to where the model puts
    them in its zero pose: the rigid pelvis and torso layouts come from the motion, the limbs from
    the rest pose chained joint to joint. Bodies are appended parents first.
    """

    # set by fit_pelvis: the pelvis's points and their rigid layout (N, 3; m) about the pelvis joint
    pelvis_pts: list[str]
    pelvis_vecs: FloatArray
    # set by fit_torso: the torso's points, their layout (m) about the spine base (or ``split``) and
    # fit weights; the joint where the spine splits (None: one torso); the head top (an End Site)
    torso_pts: list[str]
    torso_vecs: FloatArray
    torso_w: FloatArray
    split: str | None
    head_top: str

    def __init__(self, motion: Motion, profile: HumanoidProfile, mapping: MapFile | None) -> None:
        self.source_names = list(motion.skeleton.names)
        self.skel = motion.skeleton
        self.profile = profile
        self.geometry = profile.geometry
        #: the evidence on which the named sides were exchanged (None: they were kept)
        self.sides_note: dict[str, Any] | None = None
        moving = motion_points(motion)
        self.hm, by_name = humanoid_roles(motion, mapping)
        if by_name and mapping is None:  # sides from names: checked against where the legs face
            self.hm, self.sides_note = check_sides(moving, self.hm)
        pts0 = rest_points(motion)
        for lg in self.hm.legs.values():
            # a toe joint on the ankle (SNU's LeftToe -> LeftToeEnd of no length) is no toe: the foot
            # runs from the ankle to the farthest point below it
            if lg["toe"] and lg["ankle"] and np.linalg.norm(pts0[lg["toe"]] - pts0[lg["ankle"]]) < MIN_BONE_M:
                lg["toe"] = None
        self.yaw = _facing_yaw(pts0, self.hm)
        self.rest = pts0.turned(self.yaw)
        self.moving = moving.turned(self.yaw)
        self.bodies: list[BodyPlan] = []
        self.markers: dict[str, list[str]] = {}
        self.q: dict[str, FloatArray] = {}
        self.mass_note: dict[str, float] | None = None  #: how the mass was found from the legs (auto)
        #: per side, the sole a toe without a tip was given (:meth:`toe_length_without_tip`)
        self.toe_note: dict[str, dict[str, float]] = {}
        thl, thr = self.hm.legs["left"]["thigh"], self.hm.legs["right"]["thigh"]
        assert thl and thr
        self.hips = (thl, thr)

    # ----------------------------------------------------------------- small helpers
    def _vec(self, a: str, b: str) -> FloatArray:
        """Rest-pose bone (m) from ``a`` to ``b``."""
        return self.rest[b] - self.rest[a]

    def _rest_vecs(self, origin: str, points: list[str]) -> FloatArray:
        """(N, 3) rest-pose vectors (m) from ``origin`` to each of ``points``."""
        return np.stack([self._vec(origin, p) for p in points])

    def _chain(self, a: str, b: str) -> None:
        """Place ``b`` at its rest-pose offset from ``a``."""
        self.q[b] = self.q[a] + self._vec(a, b)

    def _place(self, origin: str, points: list[str], vecs: FloatArray) -> None:
        """Place ``points`` at the rigid layout ``vecs`` (N, 3; m) about ``origin``."""
        for p, v in zip(points, vecs):
            self.q[p] = self.q[origin] + v

    def _group_hinges(self, prefix: str, group: str, bone: FloatArray, mirror: bool = False, *,
                      spec: JointSpec | None = None, parent_bone: FloatArray | None = None) -> list[JointPlan]:
        """The hinges of one joint group, with the group's spec (unless ``spec``). They carry no PD gains
        (0): a humanoid's are its controller's (``pd.gains``, :data:`bipedsim.control.config.DEFAULT_GAINS`)."""
        spec = spec if spec is not None else self.profile.joints[group]
        return _hinges(prefix, spec, bone, mirror, 0.0, 0.0, group, parent_bone=parent_bone)

    # ----------------------------------------------------------------- rigid layouts (q)
    def fit_pelvis(self) -> None:
        """The pelvis: hips and spine base about the pelvis joint, calibrated on the motion."""
        hm, (thl, thr) = self.hm, self.hips
        self.q[hm.pelvis] = self.rest[hm.pelvis]
        self.pelvis_pts = [thl, thr, hm.torso_base]
        self.pelvis_vecs = calibrate_rigid(self.moving, hm.pelvis, self.pelvis_pts, hm.pelvis,
                                           self._rest_vecs(hm.pelvis, self.pelvis_pts))
        self._place(hm.pelvis, self.pelvis_pts, self.pelvis_vecs)
        _check_bone(self.q[thr] - self.q[thl], thl, thr, "pelvis width")

    def fit_torso(self) -> None:
        """The torso: neck and shoulders (or chest, without arms) about the spine base, calibrated on
        the motion; when the spine splits (:func:`_split_spine`), the abdomen's bone to the split joint
        and the layout about that joint instead. Then the head top at its rest offset from the neck."""
        hm, moving = self.hm, self.moving
        pts = [hm.neck] + [hm.arms[s]["upper_arm"] for s in ("left", "right") if s in hm.arms]
        if len(pts) == 1:
            pts.append(hm.chest)
        w = np.array([NECK_FIT_WEIGHT] + [1.0] * (len(pts) - 1))
        vecs = calibrate_rigid(moving, hm.torso_base, pts, hm.chest, self._rest_vecs(hm.torso_base, pts), w)
        self._place(hm.torso_base, pts, vecs)
        split = _split_spine(self.profile, self.rest, moving, self.hm, pts, vecs, w)
        if split:
            # abdomen: spine base -> the split joint; chest: the rigid layout of neck and shoulders about it
            av = calibrate_rigid(moving, hm.torso_base, [split], hm.torso_base, self._rest_vecs(hm.torso_base, [split]))
            self._place(hm.torso_base, [split], av)
            vecs = calibrate_rigid(moving, split, pts, split, self._rest_vecs(split, pts), w)
            self._place(split, pts, vecs)
        self.torso_pts, self.torso_vecs, self.torso_w, self.split = pts, vecs, w, split
        self.head_top = self._head_top()
        self._chain(hm.neck, self.head_top)

    def _head_top(self) -> str:
        """The point that ends the head: the head's tip, or -- when that is degenerate (a zero-length
        End Site on the head joint, a head joint on the neck) -- the point of the head's subtree
        farthest from the neck, the head joint included."""
        hm, rest = self.hm, self.rest
        top = rest.tip(hm.head)
        if np.linalg.norm(rest[top] - rest[hm.neck]) >= MIN_BONE_M:
            return top
        return max(rest.below(hm.head), key=lambda n: float(np.linalg.norm(rest[n] - rest[hm.neck])))

    # ----------------------------------------------------------------- trunk bodies
    def add_pelvis(self) -> None:
        """The root body: a capsule between the hips, oriented by the calibrated pelvis layout."""
        hm, (thl, thr) = self.hm, self.hips
        origin = self.q[hm.pelvis]
        self.bodies.append(BodyPlan(
            name="pelvis", parent=None, pos=list(origin), source=hm.pelvis, segment="pelvis",
            geoms=[_capsule(self.q[thl], self.q[thr], origin, self.geometry.pelvis_radius,
                            self.profile.masses["pelvis"])],
            fit=FitPlan(method="kabsch", origin=hm.pelvis, points=self.pelvis_pts, ref=f"bvh:{hm.pelvis}",
                        rest_vectors=[list(v) for v in self.pelvis_vecs])))
        self.markers[hm.pelvis] = ["body", "pelvis"]

    def add_trunk(self) -> None:
        """The torso body on the spine hinges, or abdomen and torso when the spine splits."""
        if self.split:
            self._add_abdomen_and_chest(self.split)
        else:
            self._add_torso()

    def _add_torso(self) -> None:
        """One rigid torso from the spine base to the neck; the mass is the profile's torso mass."""
        hm, q = self.hm, self.q
        bone = _check_bone(q[hm.neck] - q[hm.torso_base], hm.torso_base, hm.neck, "torso")
        self.bodies.append(BodyPlan(
            name="torso", parent="pelvis", pos=list(q[hm.torso_base]), source=hm.torso_base, segment="torso",
            joints=self._group_hinges("spine", "spine", bone),
            geoms=[_capsule(q[hm.torso_base], q[hm.neck], q[hm.torso_base], self.geometry.torso_radius,
                            self.profile.masses["torso"])],
            fit=FitPlan(method="kabsch", origin=hm.torso_base, points=self.torso_pts, ref=f"bvh:{hm.chest}",
                        rest_vectors=[list(v) for v in self.torso_vecs], weights=list(self.torso_w))))

    def _add_abdomen_and_chest(self, split: str) -> None:
        """Abdomen (spine base to ``split``) and chest (``split`` to the neck, named torso), each on
        spine-group hinges; the torso mass is shared between them by length."""
        hm, q, radius, mass = self.hm, self.q, self.geometry.torso_radius, self.profile.masses["torso"]
        ab = _check_bone(q[split] - q[hm.torso_base], hm.torso_base, split, "abdomen")
        ch = _check_bone(q[hm.neck] - q[split], split, hm.neck, "chest")
        share = float(np.linalg.norm(ab) / (np.linalg.norm(ab) + np.linalg.norm(ch)))
        self.bodies.append(BodyPlan(
            name="abdomen", parent="pelvis", pos=list(q[hm.torso_base]), source=hm.torso_base,
            segment="torso",
            joints=self._group_hinges("spine", "spine", ab),
            geoms=[_capsule(q[hm.torso_base], q[split], q[hm.torso_base], radius, share * mass)],
            fit=FitPlan(method="aim", origin=hm.torso_base, points=[split], ref=f"bvh:{hm.torso_base}",
                        rest_vectors=[list(ab)])))
        self.bodies.append(BodyPlan(
            name="torso", parent="abdomen", pos=list(q[split]), source=split, segment="torso",
            joints=self._group_hinges("chest", "spine", ch),
            geoms=[_capsule(q[split], q[hm.neck], q[split], radius, (1.0 - share) * mass)],
            fit=FitPlan(method="kabsch", origin=split, points=self.torso_pts, ref=f"bvh:{split}",
                        rest_vectors=[list(v) for v in self.torso_vecs], weights=list(self.torso_w))))

    def add_head(self) -> None:
        """The head on the neck hinges: a sphere 60 % of the way from the neck to the head top."""
        hm, q = self.hm, self.q
        bone = _check_bone(self._vec(hm.neck, self.head_top), hm.neck, self.head_top, "neck to head top")
        centre = q[hm.neck] + 0.6 * bone
        self.bodies.append(BodyPlan(
            name="head", parent="torso", pos=list(q[hm.neck]), source=hm.neck, segment="head",
            joints=self._group_hinges("neck", "neck", bone),
            geoms=[GeomPlan(kind="sphere", size=[self.geometry.head_radius], pos=list(centre - q[hm.neck]),
                            mass=self.profile.masses["head"])],
            fit=FitPlan(method="aim", origin=hm.neck, points=[self.head_top], ref=f"bvh:{hm.head}",
                        rest_vectors=[list(bone)])))

    def _two_bone(self, side: str, a: str, b: str, c: str, segments: tuple[str, str], joints: tuple[str, str],
                  parent: str, radii: tuple[float, float], bones: tuple[str, str]
                  ) -> tuple[FloatArray, FloatArray, list[JointPlan]]:
        """A limb of two bodies on one side: the upper (3 hinges named ``joints[0]``, twobone fit) from
        source joint ``a`` to ``b`` under ``parent``, the lower (hinge ``joints[1]``) from ``b`` to ``c``,
        the right side's axes mirrored. Returns the upper and lower bone vectors and the lower hinge."""
        mirror, q, masses = side == "right", self.q, self.profile.masses
        upper, lower = segments
        self._chain(a, b)
        self._chain(b, c)
        ub = _check_bone(self._vec(a, b), a, b, f"{side} {bones[0]}")
        lb = _check_bone(self._vec(b, c), b, c, f"{side} {bones[1]}")
        hinge = self._group_hinges(f"{side}_{joints[1]}", joints[1], lb, mirror, parent_bone=ub)
        self.bodies.append(BodyPlan(
            name=f"{side}_{upper}", parent=parent, pos=list(q[a]), source=a, segment=upper,
            joints=self._group_hinges(f"{side}_{joints[0]}", joints[0], ub, mirror),
            geoms=[_capsule(q[a], q[b], q[a], radii[0], masses[upper])],
            fit=FitPlan(method="twobone", origin=a, points=[b, c], ref=f"bvh:{a}",
                        hinge_axis=hinge[0].axis, rest_vectors=[list(ub), list(lb)],
                        hinge_range=hinge[0].range)))
        self.bodies.append(BodyPlan(
            name=f"{side}_{lower}", parent=f"{side}_{upper}", pos=list(q[b]), source=b, segment=lower,
            joints=hinge, geoms=[_capsule(q[b], q[c], q[b], radii[1], masses[lower], inset=True)],
            fit=FitPlan(method="hinge", origin=b, points=[c], ref="parent",
                        hinge_axis=hinge[0].axis, rest_vectors=[list(lb)])))
        self.markers[a] = ["body", f"{side}_{upper}"]
        self.markers[b] = ["body", f"{side}_{lower}"]
        return ub, lb, hinge

    # ----------------------------------------------------------------- limbs
    def add_arm(self, side: str) -> None:
        """Upper arm (3 shoulder hinges, twobone fit) and lower arm (elbow hinge; the hand merged, a
        wrist site at its end) on one side; the right side's axes mirrored."""
        sh, el, wr = (self.hm.arms[side][k] for k in ("upper_arm", "elbow", "wrist"))
        g = self.geometry
        _, lb, _ = self._two_bone(side, sh, el, wr, ("upper_arm", "lower_arm"), ("shoulder", "elbow"), "torso",
                                  (g.upper_arm_radius, g.lower_arm_radius), ("upper arm", "lower arm"))
        self.bodies[-1].sites.append(SitePlan(name=f"{side}_wrist", pos=list(lb)))
        self.markers[wr] = ["site", f"{side}_wrist"]

    def add_leg(self, side: str) -> None:
        """Thigh (3 hip hinges, twobone fit), shin (knee hinge), foot and, when the source has a toe
        joint, toe on one side; the right side's axes mirrored."""
        leg = self.hm.legs[side]
        th, kn, an = leg["thigh"], leg["knee"], leg["ankle"]
        assert th and kn and an
        g = self.geometry
        _, sb, knee = self._two_bone(side, th, kn, an, ("thigh", "shin"), ("hip", "knee"), "pelvis",
                                     (g.thigh_radius, g.shin_radius), ("thigh", "shin"))
        self.markers[an] = ["body", f"{side}_foot"]
        foot_frame, sole = self._add_foot(side, sb, np.asarray(knee[0].axis))
        if leg["toe"]:
            self._add_toe(side, sb, np.asarray(knee[0].axis), foot_frame, sole)

    # ----------------------------------------------------------------- feet
    def _ankle_spec(self) -> JointSpec:
        """The ankle's joint spec, with the profile's roll hinge (x) added for a 2-DOF ankle."""
        spec = self.profile.joints["ankle"]
        if self.profile.ankle_2dof:
            spec = JointSpec(axes=[*spec.axes, "x"], range=[*spec.range, list(self.profile.ankle_x_range)],
                             torque=spec.torque)
        return spec

    def _ankle_hinges(self, side: str, shin_bone: FloatArray, sole_normal: FloatArray) -> list[JointPlan]:
        """The ankle's hinges: flexion, and with a 2-DOF ankle the roll hinge, about the sole's long
        axis (the sole's normal x the flexion axis, on the side of the profile's x): the rotation two
        hinges cannot give, about their cross product, is then a turn about the sole's normal, so the
        retargeted sole lies as the captured one does (about the body's x, it would tilt the sole
        by the foot's yaw on the shin x the sole's pitch in the body, 5-7 degrees on Bandai)."""
        joints = self._group_hinges(f"{side}_ankle", "ankle", shin_bone, side == "right", spec=self._ankle_spec())
        if len(joints) == 2:
            flex, given = np.asarray(joints[0].axis), np.asarray(joints[1].axis)
            roll = np.cross(sole_normal, flex)
            if np.linalg.norm(roll) > 1e-6:
                roll = roll / np.linalg.norm(roll) * (1.0 if roll @ given >= 0 else -1.0)
                joints[1].axis = [float(v) for v in roll]
        return joints

    def _foot_hinge_world(self, ankle: str, front: str, rest_bone: FloatArray,
                          axis: FloatArray) -> FloatArray | None:
        """With a 2-DOF ankle, the world direction (T, 3) of the foot's hinge ``axis`` (rest pose) on
        each frame, as the retarget's ``aim`` fit turns the foot (the ankle joint's captured rotation,
        turned so ``rest_bone`` points at ``front``; the two hinges reproduce its sole to a few degrees);
        None for a 1-DOF ankle, whose foot rolls with the leg's plane, or without captured rotations."""
        if not self.profile.ankle_2dof or self.moving.rotations is None:
            return None
        ref = self.moving.rotation(ankle)
        g = _min_rotation(np.einsum("tij,j->ti", ref, rest_bone), self.moving[front] - self.moving[ankle]) @ ref
        return np.einsum("tij,j->ti", g, np.asarray(axis, dtype=float))

    def _add_foot(self, side: str, shin_bone: FloatArray, knee_axis: FloatArray) -> tuple[FloatArray, float]:
        """The foot: a box from ``heel_length`` behind the ankle to the toe joint (or, without one, the
        toe tip), its sole at the lowest rest-pose point of the foot chain in the frame where the foot
        is flat on the floor (a skeleton's rest pose need not stand flat-footed). Returns that sole
        frame (3, 3; columns, foot body coordinates) and the sole's height (m) below the ankle in it."""
        leg = self.hm.legs[side]
        th, kn, an, toe = leg["thigh"], leg["knee"], leg["ankle"], leg["toe"]
        assert th and kn and an
        q, g, masses = self.q, self.geometry, self.profile.masses
        tip = self.rest.tip(toe) if toe else self.rest.tip(an)
        front_name = toe or tip
        self._chain(an, front_name)
        if toe:
            self._chain(toe, tip)
        else:
            q[tip] = q[front_name]
        front = q[front_name]
        _check_bone(front - q[an], an, front_name, f"{side} foot")
        hw = self._foot_hinge_world(an, front_name, front - q[an], knee_axis)
        rf = _flat_frame(self.moving, an, [an, front_name], front - q[an], (th, kn, an), knee_axis, hw)
        front_f = rf.T @ (front - q[an])
        tip_f = rf.T @ (q[tip] - q[an])
        sole = min(-0.03, tip_f[2], front_f[2])
        heel_x = -g.heel_length
        x1 = front_f[0]
        top = g.foot_top
        half = [max((x1 - heel_x) / 2, 0.02), g.foot_width / 2, max((top - sole) / 2, 0.01)]
        centre = np.array([(heel_x + x1) / 2, 0.0, (top + sole) / 2])
        geom, site = _sole_box(f"{side}_foot", half, centre, sole, rf,
                               masses["foot"] + (0.0 if toe else masses["toe"]))
        self.bodies.append(BodyPlan(
            name=f"{side}_foot", parent=f"{side}_shin", pos=list(q[an]), source=an, segment="foot",
            is_foot=True,
            joints=self._ankle_hinges(side, shin_bone, rf[:, 2]),
            geoms=[geom], sites=[site],
            fit=FitPlan(method="aim", origin=an, points=[front_name], ref=f"bvh:{an}",
                        rest_vectors=[list(front - q[an])])))
        return rf, sole

    def _add_toe(self, side: str, shin_bone: FloatArray, knee_axis: FloatArray, foot_frame: FloatArray,
                 sole: float) -> None:
        """The toe: a box from the toe joint to the toe tip whose sole continues the foot's
        (``foot_frame`` and ``sole`` from :meth:`_add_foot`), levelled on the toe's own flat frames."""
        leg = self.hm.legs[side]
        th, kn, an, toe = leg["thigh"], leg["knee"], leg["ankle"], leg["toe"]
        assert th and kn and an and toe
        q, g = self.q, self.geometry
        tip = self.rest.tip(toe)
        tip_vec = q[tip] - q[toe]
        no_tip = bool(np.linalg.norm(tip_vec) < MIN_BONE_M)
        if no_tip:
            # no toe bone to measure (a zero-length end site): the toe's sole continues the foot's,
            # as far as a person's foot of this body's height reaches (toe_length_without_tip)
            tip_vec = np.array([self.toe_length_without_tip(side, foot_frame), 0.0, 0.0])
            rt = foot_frame
        else:
            hw = self._foot_hinge_world(an, toe, q[toe] - q[an], knee_axis)
            rt = _flat_frame(self.moving, toe, [toe, tip], tip_vec, (th, kn, an), knee_axis, hw)
        # the sole's depth below the toe joint (foot frame), carried into the toe's frame
        sole_t = sole - (foot_frame.T @ (q[toe] - q[an]))[2]
        tip_t = tip_vec if no_tip else rt.T @ (q[tip] - q[toe])
        x2 = max(tip_t[0], MIN_TOE_M)
        ttop = max(0.01, sole_t + 0.03)
        half = [x2 / 2, g.foot_width / 2, (ttop - sole_t) / 2]
        centre = np.array([x2 / 2, 0.0, (ttop + sole_t) / 2])
        geom, site = _sole_box(f"{side}_toe", half, centre, sole_t, rt, self.profile.masses["toe"])
        self.bodies.append(BodyPlan(
            name=f"{side}_toe", parent=f"{side}_foot", pos=list(q[toe]), source=toe, segment="toe",
            is_foot=True,
            joints=self._group_hinges(f"{side}_toe", "toe", shin_bone, side == "right"),
            geoms=[geom], sites=[site],
            fit=FitPlan(method="aim", origin=toe, points=[tip], ref=f"bvh:{toe}",
                        rest_vectors=[list(tip_vec)])))

    def toe_length_without_tip(self, side: str, foot_frame: FloatArray) -> float:
        """The toe box's length (m) for a toe whose skeleton gives no tip: the sole then reaches the
        length of a person's foot of this body's height, ``geometry.foot_length_share`` x the height
        (the legs over ``leg_share``: foot 0.152, hip to ankle 0.491 of the height in Winter's
        anthropometric table), from the heel (``heel_length`` behind the ankle); at least
        :data:`MIN_TOE_M`. Without it such a foot is as short as its skeleton's ankle-to-toe bone
        (Bandai-Namco's and the Holden CMU layouts': 14-16 cm of sole on a 1.6-1.7 m body)."""
        leg = self.hm.legs[side]
        an, toe = leg["ankle"], leg["toe"]
        assert an and toe
        g = self.geometry
        height = self.leg_length() / self.profile.leg_share
        toe_x = float((foot_frame.T @ (self.q[toe] - self.q[an]))[0])
        length = max(g.foot_length_share * height - g.heel_length - toe_x, MIN_TOE_M)
        self.toe_note[side] = {"sole_m": round(g.heel_length + toe_x + length, 3), "height_m": round(height, 3),
                               "foot_length_share": g.foot_length_share}
        return length

    # ----------------------------------------------------------------- whole body
    def leg_length(self) -> float:
        """The legs' length (m): hip to knee plus knee to ankle in the rest pose, the two sides' mean
        (:func:`bipedsim.control.simbicon.leg_length` on the built model)."""
        total = 0.0
        for side in ("left", "right"):
            leg = self.hm.legs[side]
            total += float(np.linalg.norm(self._vec(leg["thigh"], leg["knee"]))
                           + np.linalg.norm(self._vec(leg["knee"], leg["ankle"])))
        return total / 2

    def profile_mass(self) -> float | None:
        """The profile's total mass (kg): a number, from the legs (``auto``), or None (the segments'
        own masses, summed)."""
        m = self.profile.total_mass
        if m != "auto":
            return m
        legs = self.leg_length()
        self.mass_note = {"legs_m": round(legs, 4), "height_m": round(legs / self.profile.leg_share, 3),
                          "bmi": self.profile.mass_bmi}
        return mass_from_legs(legs, self.profile)

    def scale_masses(self, target: float | None) -> None:
        """Scale every geom's mass so the body weighs ``target`` (kg); nothing for None."""
        if target is None:
            return
        if not target > 0:
            raise ModelError(f"total mass must be > 0 kg, got {target}")
        built = sum(gm.mass for b in self.bodies for gm in b.geoms)
        for b in self.bodies:
            for gm in b.geoms:
                gm.mass *= target / built

    def stand_on_floor(self) -> float:
        """Lift the zero pose so the lowest foot box corner touches z = 0; returns the lift (m)."""
        lift = -min(b.pos[2] + gm.pos[2] - float(np.abs(_matrix(gm.quat)[2]) @ gm.size)
                    for b in self.bodies for gm in b.geoms if gm.kind == "box")
        for b in self.bodies:
            b.pos[2] += lift
        return lift

    def plan(self, name: str, lift: float) -> BodyPlanSet:
        """The finished plan (positions and rest vectors as plain floats); ``lift`` (m) from
        :meth:`stand_on_floor`."""
        for b in self.bodies:
            b.pos = [float(v) for v in b.pos]
            if b.fit:
                b.fit.rest_vectors = [[float(x) for x in v] for v in b.fit.rest_vectors]
        return BodyPlanSet(name=name, profile="humanoid", bodies=self.bodies, heading_yaw=self.yaw,
                           source_names=self.source_names, sim=asdict(self.profile.sim),
                           extra={"markers": self.markers, "roles": asdict(self.hm), "rest_lift": lift,
                                  **({"mass_from_legs": self.mass_note} if self.mass_note else {}),
                                  **({"toes_without_tip": self.toe_note} if self.toe_note else {}),
                                  **({"sides_from_geometry": self.sides_note} if self.sides_note else {})})


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
