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
from bipedsim.model.source import SourcePoints, rest_points
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
                labels.append("")
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


def _capsule(a: FloatArray, b: FloatArray, origin: FloatArray, radius: float, mass: float) -> GeomPlan:
    return GeomPlan(kind="capsule", size=[radius], fromto=[*(a - origin), *(b - origin)], mass=mass)


def _facing_yaw(pts: SourcePoints, hm: HumanoidMap) -> float:
    """Yaw (rad) about +z that turns the rest pose to face +x (from the hips: forward = left x up)."""
    left = pts[hm.legs["left"]["thigh"]] - pts[hm.legs["right"]["thigh"]]  # type: ignore[index]
    fwd = np.cross(left, [0.0, 0.0, 1.0])
    if np.hypot(fwd[0], fwd[1]) < 1e-9:
        raise ModelError("cannot tell which way the rest pose faces: the hip joints coincide")
    return float(-np.arctan2(fwd[1], fwd[0]))


def humanoid_plan(motion: Motion, profile: HumanoidProfile, *, mapping: MapFile | None = None,
                  total_mass: float | None = None, name: str = "humanoid") -> BodyPlanSet:
    """The humanoid body plan for a motion's skeleton (motion in the project frame: m, Z up)."""
    sk = motion.skeleton
    hm = recognise_humanoid(sk, mapping)
    pts0 = rest_points(motion)
    yaw = _facing_yaw(pts0, hm)
    pts = pts0.turned(yaw)
    g = profile.geometry
    bodies: list[BodyPlan] = []
    markers: dict[str, list[str]] = {}

    def P(n: str) -> FloatArray:  # noqa: N802 - a point, as in the equations
        return pts[n]

    def gains(group: str) -> tuple[float, float]:
        kp, kd = profile.gains[group]
        return float(kp), float(kd)

    def bone(a: str, b: str, what: str) -> FloatArray:
        v = P(b) - P(a)
        if np.linalg.norm(v) < MIN_BONE_M:
            raise ModelError(f"zero-length bone: {what} from {a!r} to {b!r} is "
                             f"{np.linalg.norm(v) * 1000:.1f} mm long (need >= {MIN_BONE_M * 1000:.0f} mm)")
        return v

    legs = hm.legs
    # ----------------------------------------------------------------- pelvis
    thl, thr = legs["left"]["thigh"], legs["right"]["thigh"]
    assert thl and thr
    bone(thl, thr, "pelvis width")
    origin = P(hm.pelvis)
    bodies.append(BodyPlan(
        name="pelvis", parent=None, pos=list(origin), source=hm.pelvis, segment="pelvis",
        geoms=[_capsule(P(thl), P(thr), origin, g.pelvis_radius, profile.masses["pelvis"])],
        fit=FitPlan(method="kabsch", origin=hm.pelvis, points=[thl, thr, hm.torso_base],
                    ref=f"bvh:{hm.pelvis}")))
    markers[hm.pelvis] = ["body", "pelvis"]
    # ----------------------------------------------------------------- torso and head
    torso_bone = bone(hm.torso_base, hm.neck, "torso")
    kp, kd = gains("spine")
    torso_pts = [hm.neck] + [hm.arms[s]["upper_arm"] for s in ("left", "right") if s in hm.arms]
    if len(torso_pts) == 1:
        torso_pts.append(hm.chest)
    bodies.append(BodyPlan(
        name="torso", parent="pelvis", pos=list(P(hm.torso_base)), source=hm.torso_base, segment="torso",
        joints=_hinges("spine", profile.joints["spine"], torso_bone, False, kp, kd, "spine"),
        geoms=[_capsule(P(hm.torso_base), P(hm.neck), P(hm.torso_base), g.torso_radius,
                        profile.masses["torso"])],
        fit=FitPlan(method="kabsch", origin=hm.torso_base, points=torso_pts, ref=f"bvh:{hm.chest}")))
    head_top = pts.tip(hm.head)
    head_bone = bone(hm.neck, head_top, "neck to head top")
    kp, kd = gains("neck")
    centre = P(hm.neck) + 0.6 * (P(head_top) - P(hm.neck))
    bodies.append(BodyPlan(
        name="head", parent="torso", pos=list(P(hm.neck)), source=hm.neck, segment="head",
        joints=_hinges("neck", profile.joints["neck"], head_bone, False, kp, kd, "neck"),
        geoms=[GeomPlan(kind="sphere", size=[g.head_radius], pos=list(centre - P(hm.neck)),
                        mass=profile.masses["head"])],
        fit=FitPlan(method="aim", origin=hm.neck, points=[head_top], ref=f"bvh:{hm.head}")))
    # ----------------------------------------------------------------- arms
    for side in ("left", "right"):
        if side not in hm.arms:
            continue
        arm = hm.arms[side]
        mirror = side == "right"
        sh, el, wr = arm["upper_arm"], arm["elbow"], arm["wrist"]
        ub, lb = bone(sh, el, f"{side} upper arm"), bone(el, wr, f"{side} lower arm")
        elbow_joint = _hinges(f"{side}_elbow", profile.joints["elbow"], lb, mirror, *gains("elbow"),
                              "elbow", parent_bone=ub)
        kp, kd = gains("shoulder")
        bodies.append(BodyPlan(
            name=f"{side}_upper_arm", parent="torso", pos=list(P(sh)), source=sh, segment="upper_arm",
            joints=_hinges(f"{side}_shoulder", profile.joints["shoulder"], ub, mirror, kp, kd, "shoulder"),
            geoms=[_capsule(P(sh), P(el), P(sh), g.upper_arm_radius, profile.masses["upper_arm"])],
            fit=FitPlan(method="twobone", origin=sh, points=[el, wr], ref=f"bvh:{sh}",
                        hinge_axis=elbow_joint[0].axis)))
        bodies.append(BodyPlan(
            name=f"{side}_lower_arm", parent=f"{side}_upper_arm", pos=list(P(el)), source=el,
            segment="lower_arm", joints=elbow_joint,
            geoms=[_capsule(P(el), P(wr), P(el), g.lower_arm_radius, profile.masses["lower_arm"])],
            sites=[SitePlan(name=f"{side}_wrist", pos=list(P(wr) - P(el)))],
            fit=FitPlan(method="hinge", origin=el, points=[wr], ref="parent",
                        hinge_axis=elbow_joint[0].axis)))
        markers[sh] = ["body", f"{side}_upper_arm"]
        markers[el] = ["body", f"{side}_lower_arm"]
        markers[wr] = ["site", f"{side}_wrist"]
    # ----------------------------------------------------------------- legs
    for side in ("left", "right"):
        leg = legs[side]
        mirror = side == "right"
        th, kn, an, toe = leg["thigh"], leg["knee"], leg["ankle"], leg["toe"]
        assert th and kn and an
        tb, sb = bone(th, kn, f"{side} thigh"), bone(kn, an, f"{side} shin")
        knee_joint = _hinges(f"{side}_knee", profile.joints["knee"], sb, mirror, *gains("knee"), "knee",
                             parent_bone=tb)
        bodies.append(BodyPlan(
            name=f"{side}_thigh", parent="pelvis", pos=list(P(th)), source=th, segment="thigh",
            joints=_hinges(f"{side}_hip", profile.joints["hip"], tb, mirror, *gains("hip"), "hip"),
            geoms=[_capsule(P(th), P(kn), P(th), g.thigh_radius, profile.masses["thigh"])],
            fit=FitPlan(method="twobone", origin=th, points=[kn, an], ref=f"bvh:{th}",
                        hinge_axis=knee_joint[0].axis)))
        bodies.append(BodyPlan(
            name=f"{side}_shin", parent=f"{side}_thigh", pos=list(P(kn)), source=kn, segment="shin",
            joints=knee_joint,
            geoms=[_capsule(P(kn), P(an), P(kn), g.shin_radius, profile.masses["shin"])],
            fit=FitPlan(method="hinge", origin=kn, points=[an], ref="parent",
                        hinge_axis=knee_joint[0].axis)))
        markers[th] = ["body", f"{side}_thigh"]
        markers[kn] = ["body", f"{side}_shin"]
        markers[an] = ["body", f"{side}_foot"]
        # feet: the sole sits at the lowest rest-pose point of the foot chain
        tip = pts.tip(toe) if toe else pts.tip(an)
        front = P(toe) if toe else P(tip)
        bone(an, toe or tip, f"{side} foot")
        sole = min(P(an)[2] - 0.03, P(tip)[2], front[2])
        ankle_spec = profile.joints["ankle"]
        if profile.ankle_2dof:
            ankle_spec = JointSpec(axes=[*ankle_spec.axes, "x"],
                                   range=[*ankle_spec.range, list(profile.ankle_x_range)],
                                   torque=ankle_spec.torque)
        kp, kd = gains("ankle")
        heel_x = P(an)[0] - g.heel_length
        x1 = front[0]
        top = P(an)[2] + g.foot_top
        foot_mass = profile.masses["foot"] + (0.0 if toe else profile.masses["toe"])
        half = [max((x1 - heel_x) / 2, 0.02), g.foot_width / 2, max((top - sole) / 2, 0.01)]
        centre = np.array([(heel_x + x1) / 2, P(an)[1], (top + sole) / 2])
        touch_c = np.array([centre[0], centre[1], sole + TOUCH_MARGIN_M / 2])
        bodies.append(BodyPlan(
            name=f"{side}_foot", parent=f"{side}_shin", pos=list(P(an)), source=an, segment="foot",
            is_foot=True,
            joints=_hinges(f"{side}_ankle", ankle_spec, front - P(an), mirror, kp, kd, "ankle"),
            geoms=[GeomPlan(kind="box", size=half, pos=list(centre - P(an)), mass=foot_mass,
                            name=f"{side}_foot_geom")],
            sites=[SitePlan(name=f"{side}_foot_touch", pos=list(touch_c - P(an)), kind="box", touch=True,
                            size=[half[0] + 0.005, half[1] + 0.005, TOUCH_MARGIN_M * 1.5])],
            fit=FitPlan(method="aim", origin=an, points=[toe or tip], ref=f"bvh:{an}")))
        if toe:
            x2 = max(P(tip)[0], P(toe)[0] + 0.03)
            ttop = max(P(toe)[2] + 0.01, sole + 0.03)
            thalf = [(x2 - P(toe)[0]) / 2, g.foot_width / 2, (ttop - sole) / 2]
            tc = np.array([(x2 + P(toe)[0]) / 2, P(toe)[1], (ttop + sole) / 2])
            ttc = np.array([tc[0], tc[1], sole + TOUCH_MARGIN_M / 2])
            bone(toe, tip, f"{side} toe") if np.linalg.norm(P(tip) - P(toe)) > 0 else None
            bodies.append(BodyPlan(
                name=f"{side}_toe", parent=f"{side}_foot", pos=list(P(toe)), source=toe, segment="toe",
                is_foot=True,
                joints=_hinges(f"{side}_toe", profile.joints["toe"], np.array([1.0, 0, 0]), mirror,
                               *gains("toe"), "toe"),
                geoms=[GeomPlan(kind="box", size=thalf, pos=list(tc - P(toe)), mass=profile.masses["toe"],
                                name=f"{side}_toe_geom")],
                sites=[SitePlan(name=f"{side}_toe_touch", pos=list(ttc - P(toe)), kind="box", touch=True,
                                size=[thalf[0] + 0.005, thalf[1] + 0.005, TOUCH_MARGIN_M * 1.5])],
                fit=FitPlan(method="aim", origin=toe, points=[tip], ref=f"bvh:{toe}")))
    # ----------------------------------------------------------------- mass scaling
    target = total_mass if total_mass is not None else profile.total_mass
    if target is not None:
        if not target > 0:
            raise ModelError(f"total mass must be > 0 kg, got {target}")
        built = sum(gm.mass for b in bodies for gm in b.geoms)
        for b in bodies:
            for gm in b.geoms:
                gm.mass *= target / built
    # stand the rest pose on the floor
    lift = -min(b.pos[2] + gm.pos[2] - gm.size[2] for b in bodies for gm in b.geoms if gm.kind == "box")
    for b in bodies:
        b.pos[2] += lift
    from dataclasses import asdict

    return BodyPlanSet(name=name, profile="humanoid", bodies=bodies, heading_yaw=yaw,
                       source_names=list(sk.names), sim=asdict(profile.sim),
                       extra={"markers": markers, "roles": asdict(hm), "rest_lift": lift})
