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

The fits live in :mod:`~bipedsim.model.orientations`, the split into hinges in
:mod:`~bipedsim.model.hinge_angles`, the feet's heights and the floor in :mod:`~bipedsim.reference.clip_floor`.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.model.hinge_angles import _hinge_angles, _in_range_euler, hinge_basis
from bipedsim.model.orientations import fit_orientations, kabsch
from bipedsim.model.plan import BodyPlanSet, model_hash, plan_from_model
from bipedsim.model.source import SourcePoints, motion_points
from bipedsim.motion.motion import Motion
from bipedsim.reference.clip import ReferenceClip, contact_labels, debounce, foot_speeds, gait_events
from bipedsim.reference.clip_floor import _put_on_floor, floor_tilt, foot_heights, geom_lowest_z
from bipedsim.reference.gait_events import contacts_from_strikes, load_events, side_contacts

__all__ = ["fit_orientations", "floor_tilt", "foot_heights", "geom_lowest_z", "hinge_basis", "kabsch",
           "leading_glitch_frames", "marker_positions", "retarget", "source_marker_positions", "velocities"]

FloatArray = npt.NDArray[np.float64]


#: A humanoid foot's shortest swing (s): a shorter lift is a shuffle or a pivot, not a step (a walk's
#: swing lasts 0.3-0.5 s).
MIN_SWING_S = 0.15


def retarget(motion: Motion, model: mujoco.MjModel, *, plan: BodyPlanSet | None = None,
             xml: str | None = None, contact_height: float = 0.05, contact_speed: float = 0.5,
             source: str = "", trim_glitches: bool = True,
             events: str | os.PathLike[str] | None = None, events_skip: int = 0) -> ReferenceClip:
    """Retarget a motion (project frame: metres, Z up) onto a model built by bipedsim.

    Contacts: a humanoid's heel and toe each touch when near their own ground level and nearly still,
    thresholds measured on the clip (:mod:`bipedsim.reference.gait_events`); a creature's feet when the lowest
    point is below ``contact_height`` (m) and it moves slower than ``contact_speed`` (m/s). With ``trim_glitches``,
    leading frames that jump away from the rest of the take (the T-pose frame some releases start
    with) are dropped; ``clip.trimmed_frames`` says how many. ``events``: a YAML of foot strikes given
    by hand (:func:`bipedsim.reference.gait_events.load_events`; frames of the file, of which the
    reader dropped the first ``events_skip`` before the motion, a lead-in) that replaces the detected ones.
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
    if plan.profile == "humanoid":  # heel and toe separately, thresholds measured on the clip (reference.gait_events)
        groups = [[feet.index(f) for f in fs] for fs in side_feet.values()]
        grouped = debounce(side_contacts(low, fpos, motion.frame_time, groups), motion.frame_time,
                           min_gap=MIN_SWING_S)
    else:
        speed_g = _group_min(foot_speeds(fpos, motion.frame_time), feet, side_feet)
        grouped = debounce(contact_labels(low_g, speed_g, contact_height, contact_speed), motion.frame_time)
    if events is not None:
        skip = trimmed + events_skip
        given = load_events(events, list(side_feet), motion.num_frames + skip, motion.frame_time)
        given = {f: [s - skip for s in v if s >= skip] for f, v in given.items()}
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
