"""The humanoid profile: a source skeleton reduced to the paper's physics skeleton.

Bodies: pelvis (free joint), torso (spine, 3 hinges), head (neck, 3 hinges), per side upper arm
(shoulder, 3), lower arm (elbow, 1; the hand is merged into it), thigh (hip, 3), shin (knee, 1), foot
(ankle, 1 or 2), toe (toe, 1; only when the source has a toe joint, else the foot reaches the toe tip).
Every other source joint (fingers, clavicles, extra spine and neck links, helper bones) is dropped:
its rotation is absorbed into the orientation fit of the body it belongs to.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.naming import HumanoidMap, MapFile, recognise_humanoid
from bipedsim.model.plan import BodyPlan, BodyPlanSet, FitPlan, GeomPlan, JointPlan, SitePlan
from bipedsim.model.profile import HumanoidProfile, JointSpec
from bipedsim.model.source import SourcePoints, motion_points, rest_points
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]

BASIS = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}
FORWARD = np.array([1.0, 0.0, 0.0])
#: Shortest bone (m) the builder accepts; shorter ones are zero-length for practical purposes.
MIN_BONE_M = 0.01
#: Touch-sensor sites reach this far below and above the sole (m).
TOUCH_MARGIN_M = 0.02


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
                hinge_plane: tuple[str, str, str] | None = None, hinge_axis: FloatArray | None = None) -> FloatArray:
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
    motion never shows the segment flat (one-frame files)."""
    pos = moving.positions
    eye = np.eye(3)
    if pos.ndim != 3 or pos.shape[0] < 3:
        return eye
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
        return eye
    bone = moving[points[1]][flat] - moving[points[0]][flat]
    if float(np.median(np.linalg.norm(bone, axis=1))) < MIN_BONE_M:
        return eye
    f_rest = np.asarray(forward, dtype=float)
    lateral_rest = np.cross([0.0, 0.0, 1.0], f_rest)
    if np.linalg.norm(lateral_rest) < 1e-6:
        return eye
    normal = None
    if hinge_plane is not None and hinge_axis is not None:
        a, b, c = (moving[n][flat] for n in hinge_plane)
        n = np.cross(b - a, c - b)
        size = np.linalg.norm(n, axis=1) / np.maximum(np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - b, axis=1),
                                                      1e-12)
        ok = size > np.sin(MIN_PLANE_BEND)
        if ok.sum() >= 3:
            normal, bone = n[ok] / np.linalg.norm(n[ok], axis=1, keepdims=True), bone[ok]
            # the knee bends one way: the normal on the foot's left-hand side (a straightened or
            # over-extended knee would flip the plane's orientation)
            left = np.cross([0.0, 0.0, 1.0], bone)
            normal = np.where(np.sum(normal * left, axis=1, keepdims=True) < 0, -normal, normal)
    if normal is None:
        # the lateral axis stays horizontal: pitch only (the bone's dip against the rest pose's)
        normal = np.cross(bone, [0.0, 0.0, 1.0])
        normal = normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        normal = np.where((normal @ lateral_rest)[:, None] < 0, -normal, normal)
        y_rest = lateral_rest
    else:
        y_rest = np.asarray(hinge_axis, dtype=float)
    # per flat frame: G = B A^T carries the rest frame A = (forward, lateral, ...) onto B = (bone, normal, ...)
    rest_frame = _frame_from(f_rest[None], y_rest[None])[0]
    frames = _frame_from(bone, normal)
    # the world vertical in body coordinates, G^T z = A B^T z, on each flat frame
    up_b = np.einsum("ij,tkj,k->ti", rest_frame, frames, np.array([0.0, 0.0, 1.0]))
    s = up_b.mean(axis=0)
    s = s / np.linalg.norm(s)
    angle = float(np.arccos(np.clip(s[2], -1.0, 1.0)))
    if angle < FLAT_MIN_TILT:
        return eye
    axis = np.cross([0.0, 0.0, 1.0], s)
    axis = axis / np.linalg.norm(axis)
    from scipy.spatial.transform import Rotation

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
    from scipy.spatial.transform import Rotation

    return [float(v) for v in Rotation.from_matrix(r).as_quat(scalar_first=True)]


def _matrix(quat: list[float] | None) -> FloatArray:
    if quat is None:
        return np.eye(3)
    from scipy.spatial.transform import Rotation

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
    from bipedsim.model.retarget import kabsch

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
    from bipedsim.model.retarget import kabsch

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
    sk = motion.skeleton
    hm = recognise_humanoid(sk, mapping)
    pts0 = rest_points(motion)
    yaw = _facing_yaw(pts0, hm)
    rest = pts0.turned(yaw)
    moving = motion_points(motion).turned(yaw)
    g = profile.geometry
    bodies: list[BodyPlan] = []
    markers: dict[str, list[str]] = {}
    legs = hm.legs
    thl, thr = legs["left"]["thigh"], legs["right"]["thigh"]
    assert thl and thr

    def gains(group: str) -> tuple[float, float]:
        kp, kd = profile.gains[group]
        return float(kp), float(kd)

    def vec(a: str, b: str) -> FloatArray:
        return rest[b] - rest[a]

    def check(v: FloatArray, a: str, b: str, what: str) -> FloatArray:
        if np.linalg.norm(v) < MIN_BONE_M:
            raise ModelError(f"zero-length bone: {what} from {a!r} to {b!r} is "
                             f"{np.linalg.norm(v) * 1000:.1f} mm long (need >= {MIN_BONE_M * 1000:.0f} mm)")
        return v

    # ----------------------------------------------------------------- model geometry Q
    Q: dict[str, FloatArray] = {hm.pelvis: rest[hm.pelvis]}
    pelvis_pts = [thl, thr, hm.torso_base]
    pv = calibrate_rigid(moving, hm.pelvis, pelvis_pts, hm.pelvis,
                         np.stack([vec(hm.pelvis, p) for p in pelvis_pts]))
    for p_, v in zip(pelvis_pts, pv):
        Q[p_] = Q[hm.pelvis] + v
    check(Q[thr] - Q[thl], thl, thr, "pelvis width")
    torso_pts = [hm.neck] + [hm.arms[s]["upper_arm"] for s in ("left", "right") if s in hm.arms]
    if len(torso_pts) == 1:
        torso_pts.append(hm.chest)
    torso_w = np.array([NECK_FIT_WEIGHT] + [1.0] * (len(torso_pts) - 1))
    tv = calibrate_rigid(moving, hm.torso_base, torso_pts, hm.chest,
                         np.stack([vec(hm.torso_base, p) for p in torso_pts]), torso_w)
    for p_, v in zip(torso_pts, tv):
        Q[p_] = Q[hm.torso_base] + v
    split = _split_spine(profile, rest, moving, hm, torso_pts, tv, torso_w)
    if split:
        # abdomen: spine base -> the split joint; chest: the rigid layout of neck and shoulders about it
        (av,) = calibrate_rigid(moving, hm.torso_base, [split], hm.torso_base, vec(hm.torso_base, split)[None])
        Q[split] = Q[hm.torso_base] + av
        tv = calibrate_rigid(moving, split, torso_pts, split, np.stack([vec(split, p) for p in torso_pts]),
                             torso_w)
        for p_, v in zip(torso_pts, tv):
            Q[p_] = Q[split] + v
    head_top = rest.tip(hm.head)
    Q[head_top] = Q[hm.neck] + vec(hm.neck, head_top)

    def chain(a: str, b: str) -> None:
        Q[b] = Q[a] + vec(a, b)

    # ----------------------------------------------------------------- pelvis, torso, head
    origin = Q[hm.pelvis]
    bodies.append(BodyPlan(
        name="pelvis", parent=None, pos=list(origin), source=hm.pelvis, segment="pelvis",
        geoms=[_capsule(Q[thl], Q[thr], origin, g.pelvis_radius, profile.masses["pelvis"])],
        fit=FitPlan(method="kabsch", origin=hm.pelvis, points=pelvis_pts, ref=f"bvh:{hm.pelvis}",
                    rest_vectors=[list(v) for v in pv])))
    markers[hm.pelvis] = ["body", "pelvis"]
    kp, kd = gains("spine")
    if split:
        ab = check(Q[split] - Q[hm.torso_base], hm.torso_base, split, "abdomen")
        ch = check(Q[hm.neck] - Q[split], split, hm.neck, "chest")
        share = float(np.linalg.norm(ab) / (np.linalg.norm(ab) + np.linalg.norm(ch)))
        bodies.append(BodyPlan(
            name="abdomen", parent="pelvis", pos=list(Q[hm.torso_base]), source=hm.torso_base,
            segment="torso",
            joints=_hinges("spine", profile.joints["spine"], ab, False, kp, kd, "spine"),
            geoms=[_capsule(Q[hm.torso_base], Q[split], Q[hm.torso_base], g.torso_radius,
                            share * profile.masses["torso"])],
            fit=FitPlan(method="aim", origin=hm.torso_base, points=[split], ref=f"bvh:{hm.torso_base}",
                        rest_vectors=[list(ab)])))
        bodies.append(BodyPlan(
            name="torso", parent="abdomen", pos=list(Q[split]), source=split, segment="torso",
            joints=_hinges("chest", profile.joints["spine"], ch, False, kp, kd, "spine"),
            geoms=[_capsule(Q[split], Q[hm.neck], Q[split], g.torso_radius,
                            (1.0 - share) * profile.masses["torso"])],
            fit=FitPlan(method="kabsch", origin=split, points=torso_pts, ref=f"bvh:{split}",
                        rest_vectors=[list(v) for v in tv], weights=list(torso_w))))
    else:
        torso_bone = check(Q[hm.neck] - Q[hm.torso_base], hm.torso_base, hm.neck, "torso")
        bodies.append(BodyPlan(
            name="torso", parent="pelvis", pos=list(Q[hm.torso_base]), source=hm.torso_base, segment="torso",
            joints=_hinges("spine", profile.joints["spine"], torso_bone, False, kp, kd, "spine"),
            geoms=[_capsule(Q[hm.torso_base], Q[hm.neck], Q[hm.torso_base], g.torso_radius,
                            profile.masses["torso"])],
            fit=FitPlan(method="kabsch", origin=hm.torso_base, points=torso_pts, ref=f"bvh:{hm.chest}",
                        rest_vectors=[list(v) for v in tv], weights=list(torso_w))))
    head_bone = check(vec(hm.neck, head_top), hm.neck, head_top, "neck to head top")
    kp, kd = gains("neck")
    centre = Q[hm.neck] + 0.6 * head_bone
    bodies.append(BodyPlan(
        name="head", parent="torso", pos=list(Q[hm.neck]), source=hm.neck, segment="head",
        joints=_hinges("neck", profile.joints["neck"], head_bone, False, kp, kd, "neck"),
        geoms=[GeomPlan(kind="sphere", size=[g.head_radius], pos=list(centre - Q[hm.neck]),
                        mass=profile.masses["head"])],
        fit=FitPlan(method="aim", origin=hm.neck, points=[head_top], ref=f"bvh:{hm.head}",
                    rest_vectors=[list(head_bone)])))
    # ----------------------------------------------------------------- arms
    for side in ("left", "right"):
        if side not in hm.arms:
            continue
        arm = hm.arms[side]
        mirror = side == "right"
        sh, el, wr = arm["upper_arm"], arm["elbow"], arm["wrist"]
        chain(sh, el)
        chain(el, wr)
        ub = check(vec(sh, el), sh, el, f"{side} upper arm")
        lb = check(vec(el, wr), el, wr, f"{side} lower arm")
        elbow_joint = _hinges(f"{side}_elbow", profile.joints["elbow"], lb, mirror, *gains("elbow"),
                              "elbow", parent_bone=ub)
        kp, kd = gains("shoulder")
        bodies.append(BodyPlan(
            name=f"{side}_upper_arm", parent="torso", pos=list(Q[sh]), source=sh, segment="upper_arm",
            joints=_hinges(f"{side}_shoulder", profile.joints["shoulder"], ub, mirror, kp, kd, "shoulder"),
            geoms=[_capsule(Q[sh], Q[el], Q[sh], g.upper_arm_radius, profile.masses["upper_arm"])],
            fit=FitPlan(method="twobone", origin=sh, points=[el, wr], ref=f"bvh:{sh}",
                        hinge_axis=elbow_joint[0].axis, rest_vectors=[list(ub), list(lb)],
                        hinge_range=elbow_joint[0].range)))
        bodies.append(BodyPlan(
            name=f"{side}_lower_arm", parent=f"{side}_upper_arm", pos=list(Q[el]), source=el,
            segment="lower_arm", joints=elbow_joint,
            geoms=[_capsule(Q[el], Q[wr], Q[el], g.lower_arm_radius, profile.masses["lower_arm"], inset=True)],
            sites=[SitePlan(name=f"{side}_wrist", pos=list(lb))],
            fit=FitPlan(method="hinge", origin=el, points=[wr], ref="parent",
                        hinge_axis=elbow_joint[0].axis, rest_vectors=[list(lb)])))
        markers[sh] = ["body", f"{side}_upper_arm"]
        markers[el] = ["body", f"{side}_lower_arm"]
        markers[wr] = ["site", f"{side}_wrist"]
    # ----------------------------------------------------------------- legs
    for side in ("left", "right"):
        leg = legs[side]
        mirror = side == "right"
        th, kn, an, toe = leg["thigh"], leg["knee"], leg["ankle"], leg["toe"]
        assert th and kn and an
        chain(th, kn)
        chain(kn, an)
        tb = check(vec(th, kn), th, kn, f"{side} thigh")
        sb = check(vec(kn, an), kn, an, f"{side} shin")
        knee_joint = _hinges(f"{side}_knee", profile.joints["knee"], sb, mirror, *gains("knee"), "knee",
                             parent_bone=tb)
        bodies.append(BodyPlan(
            name=f"{side}_thigh", parent="pelvis", pos=list(Q[th]), source=th, segment="thigh",
            joints=_hinges(f"{side}_hip", profile.joints["hip"], tb, mirror, *gains("hip"), "hip"),
            geoms=[_capsule(Q[th], Q[kn], Q[th], g.thigh_radius, profile.masses["thigh"])],
            fit=FitPlan(method="twobone", origin=th, points=[kn, an], ref=f"bvh:{th}",
                        hinge_axis=knee_joint[0].axis, rest_vectors=[list(tb), list(sb)],
                        hinge_range=knee_joint[0].range)))
        bodies.append(BodyPlan(
            name=f"{side}_shin", parent=f"{side}_thigh", pos=list(Q[kn]), source=kn, segment="shin",
            joints=knee_joint,
            geoms=[_capsule(Q[kn], Q[an], Q[kn], g.shin_radius, profile.masses["shin"], inset=True)],
            fit=FitPlan(method="hinge", origin=kn, points=[an], ref="parent",
                        hinge_axis=knee_joint[0].axis, rest_vectors=[list(sb)])))
        markers[th] = ["body", f"{side}_thigh"]
        markers[kn] = ["body", f"{side}_shin"]
        markers[an] = ["body", f"{side}_foot"]
        # feet: the sole sits at the lowest rest-pose point of the foot chain, in the frame where the
        # foot is flat on the floor (a skeleton's rest pose need not stand flat-footed)
        tip = rest.tip(toe) if toe else rest.tip(an)
        front_name = toe or tip
        chain(an, front_name)
        if toe:
            chain(toe, tip)
        else:
            Q[tip] = Q[front_name]
        front = Q[front_name]
        check(front - Q[an], an, front_name, f"{side} foot")
        rf = _flat_frame(moving, an, [an, front_name], front - Q[an], (th, kn, an), knee_joint[0].axis)
        front_f = rf.T @ (front - Q[an])
        tip_f = rf.T @ (Q[tip] - Q[an])
        sole = min(-0.03, tip_f[2], front_f[2])
        ankle_spec = profile.joints["ankle"]
        if profile.ankle_2dof:
            ankle_spec = JointSpec(axes=[*ankle_spec.axes, "x"],
                                   range=[*ankle_spec.range, list(profile.ankle_x_range)],
                                   torque=ankle_spec.torque)
        kp, kd = gains("ankle")
        heel_x = -g.heel_length
        x1 = front_f[0]
        top = g.foot_top
        foot_mass = profile.masses["foot"] + (0.0 if toe else profile.masses["toe"])
        half = [max((x1 - heel_x) / 2, 0.02), g.foot_width / 2, max((top - sole) / 2, 0.01)]
        centre = np.array([(heel_x + x1) / 2, 0.0, (top + sole) / 2])
        touch_c = np.array([centre[0], 0.0, sole + TOUCH_MARGIN_M / 2])
        bodies.append(BodyPlan(
            name=f"{side}_foot", parent=f"{side}_shin", pos=list(Q[an]), source=an, segment="foot",
            is_foot=True,
            joints=_hinges(f"{side}_ankle", ankle_spec, sb, mirror, kp, kd, "ankle"),
            geoms=[GeomPlan(kind="box", size=half, pos=list(rf @ centre), mass=foot_mass,
                            name=f"{side}_foot_geom", quat=_quat(rf))],
            sites=[SitePlan(name=f"{side}_foot_touch", pos=list(rf @ touch_c), kind="box", touch=True,
                            size=[half[0] + 0.005, half[1] + 0.005, TOUCH_MARGIN_M * 1.5], quat=_quat(rf))],
            fit=FitPlan(method="aim", origin=an, points=[front_name], ref=f"bvh:{an}",
                        rest_vectors=[list(front - Q[an])])))
        if toe:
            tip_vec = Q[tip] - Q[toe]
            if np.linalg.norm(tip_vec) < MIN_BONE_M:
                # no toe bone to measure: the toe's sole continues the foot's
                tip_vec = np.array([0.03, 0.0, 0.0])
                rt = rf
            else:
                rt = _flat_frame(moving, toe, [toe, tip], tip_vec, (th, kn, an), knee_joint[0].axis)
            # the sole's depth below the toe joint (foot frame), carried into the toe's frame
            sole_t = sole - (rf.T @ (Q[toe] - Q[an]))[2]
            tip_t = rt.T @ (Q[tip] - Q[toe])
            x2 = max(tip_t[0], 0.03)
            ttop = max(0.01, sole_t + 0.03)
            thalf = [x2 / 2, g.foot_width / 2, (ttop - sole_t) / 2]
            tc = np.array([x2 / 2, 0.0, (ttop + sole_t) / 2])
            ttc = np.array([tc[0], 0.0, sole_t + TOUCH_MARGIN_M / 2])
            bodies.append(BodyPlan(
                name=f"{side}_toe", parent=f"{side}_foot", pos=list(Q[toe]), source=toe, segment="toe",
                is_foot=True,
                joints=_hinges(f"{side}_toe", profile.joints["toe"], sb, mirror,
                               *gains("toe"), "toe"),
                geoms=[GeomPlan(kind="box", size=thalf, pos=list(rt @ tc), mass=profile.masses["toe"],
                                name=f"{side}_toe_geom", quat=_quat(rt))],
                sites=[SitePlan(name=f"{side}_toe_touch", pos=list(rt @ ttc), kind="box", touch=True,
                                size=[thalf[0] + 0.005, thalf[1] + 0.005, TOUCH_MARGIN_M * 1.5], quat=_quat(rt))],
                fit=FitPlan(method="aim", origin=toe, points=[tip], ref=f"bvh:{toe}",
                            rest_vectors=[list(tip_vec)])))
    # ----------------------------------------------------------------- mass scaling
    target = total_mass if total_mass is not None else profile.total_mass
    if target is not None:
        if not target > 0:
            raise ModelError(f"total mass must be > 0 kg, got {target}")
        built = sum(gm.mass for b in bodies for gm in b.geoms)
        for b in bodies:
            for gm in b.geoms:
                gm.mass *= target / built
    # stand the zero pose on the floor
    lift = -min(b.pos[2] + gm.pos[2] - float(np.abs(_matrix(gm.quat)[2]) @ gm.size)
                for b in bodies for gm in b.geoms if gm.kind == "box")
    for b in bodies:
        b.pos[2] += lift
    for b in bodies:
        b.pos = [float(v) for v in b.pos]
        if b.fit:
            b.fit.rest_vectors = [[float(x) for x in v] for v in b.fit.rest_vectors]
    from dataclasses import asdict

    return BodyPlanSet(name=name, profile="humanoid", bodies=bodies, heading_yaw=yaw,
                       source_names=list(sk.names), sim=asdict(profile.sim),
                       extra={"markers": markers, "roles": asdict(hm), "rest_lift": lift})
