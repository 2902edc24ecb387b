"""The humanoid body plan built step by step (:class:`_HumanoidBuilder`): the rigid pelvis and torso,
the trunk bodies, head, arms and legs with their hinges, the feet with level soles and touch sensors,
masses, and the zero pose stood on the floor."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.flat_foot import _flat_frame
from bipedsim.model.humanoid_bones import MIN_BONE_M, MIN_TOE_M, _check_bone, _hinges
from bipedsim.model.humanoid_geoms import _capsule, _matrix, _sole_box
from bipedsim.model.humanoid_proportions import mass_from_legs
from bipedsim.model.humanoid_sides import _facing_yaw, check_sides, humanoid_roles
from bipedsim.model.naming import MapFile
from bipedsim.model.orientations import _min_rotation
from bipedsim.model.plan import BodyPlan, BodyPlanSet, FitPlan, GeomPlan, JointPlan, SitePlan
from bipedsim.model.profile import HumanoidProfile, JointSpec
from bipedsim.model.rigid_layout import NECK_FIT_WEIGHT, _split_spine, calibrate_rigid
from bipedsim.model.source import motion_points, rest_points
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]


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
        (0): a humanoid's are its controller's (``pd.gains``, :data:`bipedsim.control.settings.DEFAULT_GAINS`)."""
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
        (:func:`bipedsim.control.humanoid.simbicon.leg_length` on the built model)."""
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
