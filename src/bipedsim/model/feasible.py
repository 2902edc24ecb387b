"""A feasible lower-body reference built from a real walk: what the controller is asked to
track made physically possible for the built body.

A capture's legs cannot be replayed as they are by a box-footed body: its stance feet roll from heel
to toe, float or sink by centimetres and slide; its stance knees straighten to the singularity; its
swing toes drag (docs/controller.md, *Feasible reference*). From the clip's own gait events (the
contacts :mod:`bipedsim.model.gait` measured) and footprints, every frame gets:

- **stance feet** planted at the clip's footprint: per stance, the ankle's median position and the
  foot's median heading over the stance's flattest frames (the sole's tilt in its lowest third), where
  the sole lies level on z = 0; where the clip's sole pitches more than :data:`FLAT_BAND`, the foot
  rolls by the excess over its heel edge (toes up) or its ball (heel up: the toe joint, the toe box
  kept level), that pivot held in place -- no sliding, float or sink;
- **swing feet** on the clip's path, moved smoothly (smoothstep over the swing) from the footprint
  they leave to the one they reach, the heading turned from one footprint's to the next, the clip's
  pitch, the box's lowest corner at least ``clearance`` x the leg length x sin(pi u) above the floor
  (u: the swing's progress) and never lower than the clip's own foot;
- **the pelvis** where the clip has it (or, with ``pendulum`` > 0, moved so its centre of mass moves
  as a linear inverted pendulum over the stance feet, :func:`pendulum_shift`), lowered wherever a leg
  would be straighter than ``max_extension`` of its length (hip joint to ankle over thigh + shin), the
  lowering spread over ``smooth_s`` so it does not jerk;
- **leg hinges** by inverse kinematics on the built MuJoCo body: per leg and frame a projected
  Levenberg-Marquardt on the foot's position and sole orientation (and the toe's, when the body has
  one), within the joints' ranges, warm-started from the previous frame, lightly pulled toward the
  clip's own angles (the redundancy a 3-DOF hip leaves);

and the upper body stays the clip's. ``blend`` mixes the clip's legs (0) and the feasible ones (1).
Step timing, lengths, widths and turns are the clip's, so its speed is too.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.ndimage import maximum_filter1d, uniform_filter1d
from scipy.sparse import diags, vstack
from scipy.sparse.linalg import spsolve
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.retarget import velocities

FloatArray = npt.NDArray[np.float64]
SIDES = ("right", "left")


#: Longest spread (s) of the pelvis lowering: past a few strides it is the whole clip's mean, and the
#: window is counted in frames (1e300 s overflowed).
MAX_SMOOTH_S = 10.0
#: Largest weight of the pendulum term: far past the point where the least squares follow the pendulum's
#: ZMP alone (1e4 and 1e6 walk the built-in walk alike); 1e300 overflowed the solve.
MAX_PENDULUM_WEIGHT = 1e6


@dataclass(frozen=True)
class FeasibleConfig:
    """The controller YAML's ``reference:`` block: whether a real clip's legs are made feasible for the
    built body before tracking (:func:`feasible_clip`), and how."""

    #: build the feasible lower-body reference (stance feet planted flat, swing clearance, pelvis
    #: lowered off a straight knee, legs by IK on the body): true, false, or "auto" -- every capture,
    #: and a clip generated for the body (the built-in walk) only where its legs measure infeasible
    #: (:func:`resolve_because`, :func:`infeasible_because`: hinges out of range, a leg straighter than
    #: ``max_extension``, stance feet floating)
    feasible: bool | Literal["auto"] = "auto"
    #: 0: the clip's legs, 1: the feasible ones (hinge angles and pelvis height mixed linearly)
    blend: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})
    #: longest leg (hip joint to ankle) as a fraction of thigh + shin (gaitgen's 0.985)
    max_extension: float = field(default=0.985, metadata={"gt": 0.5, "max": 1.0})
    #: the swing sole's least peak height above the floor as a fraction of the leg length
    clearance: float = field(default=0.11, metadata={"min": 0.0, "max": 0.5})
    #: seconds over which the pelvis lowering is spread
    smooth_s: float = field(default=0.15, metadata={"min": 0.0, "max": MAX_SMOOTH_S})
    #: weight of the linear inverted pendulum on the pelvis's horizontal path (0: the clip's path): the
    #: centre of mass moved so that its pendulum ZMP, c - c''/w^2, stays near the stance feet's centre of
    #: pressure (least squares against staying on the clip's path)
    pendulum: float = field(default=0.0, metadata={"min": 0.0, "max": MAX_PENDULUM_WEIGHT})


#: Share of a stance's frames (the sole's least tilted) whose ankle positions and headings make the
#: footprint: a rolling foot is flat in the middle of its stance.
FLAT_SHARE = 1.0 / 3.0
#: IK residual weights: foot position (per m), sole tilt (per rad), foot heading (per rad), toe tilt
#: and heading, pull toward the clip's angles (per rad).
W_POS, W_TILT, W_YAW, W_TOE, W_REG = 1.0, 0.3, 0.1, 0.1, 0.01
#: IK iterations per frame at most, and the step (rad) below which it stops.
IK_ITERS, IK_TOL = 30, 1e-7
#: A solve that leaves the foot farther than this (m) from its target is restarted with the knee bent
#: :data:`KNEE_ESCAPE` (rad) off its straight end: from a straight knee, bending moves the foot only to
#: second order toward the hip, so the solver stalls there with the leg at full length (games105's
#: first frame, 3.6 cm short, the leg 1.000 of its length).
IK_REACH_TOL, KNEE_ESCAPE = 0.005, 0.3
#: A knee within this (rad) of its straight end counts as straight (the restart's case).
KNEE_STRAIGHT = 1e-3


@dataclass
class _Leg:
    """One leg's bodies, hinges (qpos/dof addresses, ranges) and lengths on the built model."""

    side: str
    thigh: int
    foot: int
    toe: int | None
    foot_geom: int
    toe_geom: int | None
    qadr: npt.NDArray[np.int64]
    dadr: npt.NDArray[np.int64]
    lo: FloatArray
    hi: FloatArray
    length: float  #: thigh + shin (m)
    toe_dofs: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))
    knee_dofs: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))

    @staticmethod
    def of(model: mujoco.MjModel, side: str) -> _Leg:
        def body(name: str) -> int | None:
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{side}_{name}")
            return None if b < 0 else int(b)

        thigh, shin, foot, toe = body("thigh"), body("shin"), body("foot"), body("toe")
        if thigh is None or shin is None or foot is None:
            raise ModelError(f"the feasible reference needs a humanoid leg ({side} thigh, shin, foot)")
        bodies = [b for b in (thigh, shin, foot, toe) if b is not None]
        jids = [j for j in range(model.njnt) if model.jnt_bodyid[j] in bodies
                and model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
        geom = {b: next((g for g in range(model.ngeom) if model.geom_bodyid[g] == b
                         and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX), None) for b in (foot, toe)}
        if geom[foot] is None:
            raise ModelError(f"the feasible reference needs box feet ({side} foot has no box)")
        length = float(np.linalg.norm(model.body_pos[shin]) + np.linalg.norm(model.body_pos[foot]))
        return _Leg(side, thigh, foot, toe, int(geom[foot]), None if toe is None else geom[toe],
                    np.array([model.jnt_qposadr[j] for j in jids]), np.array([model.jnt_dofadr[j] for j in jids]),
                    model.jnt_range[jids, 0].copy(), model.jnt_range[jids, 1].copy(), length,
                    np.array([model.jnt_bodyid[j] == toe for j in jids]),
                    np.array([model.jnt_bodyid[j] == shin for j in jids]))


def _runs(flags: npt.NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[start, end) of each run of True."""
    d = np.diff(np.concatenate([[0], flags.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def _yaw(r: FloatArray) -> FloatArray:
    """Heading (rad) of the x axis of rotations (T, 3, 3)."""
    return np.arctan2(r[..., 1, 0], r[..., 0, 0])


def _tilt(r: FloatArray) -> FloatArray:
    """Angle (rad) between the z axis of rotations (T, 3, 3) and the vertical."""
    return np.arccos(np.clip(r[..., 2, 2], -1.0, 1.0))


def _smoothstep(u: FloatArray) -> FloatArray:
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


@dataclass
class FootPlan:
    """Per side and frame, where the feasible reference puts the foot: the ankle (foot body origin,
    (T, 3) m), the sole box's world rotation (T, 3, 3), the toe box's (T, 3, 3; level where the foot
    rolls over its toes) and ``stance`` (T,), the clip's contact."""

    ankle: FloatArray
    sole: FloatArray
    toe: FloatArray
    stance: npt.NDArray[np.bool_]
    #: (T, 3) the point the stance foot bears on (the pivot it rolls over, the sole's middle when flat;
    #: NaN in the swing)
    cop: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))


def _kinematics(model: mujoco.MjModel, qpos: FloatArray, legs: dict[str, _Leg]) -> dict[str, dict[str, FloatArray]]:
    """Per side: hip joint positions (T, 3), ankle positions (T, 3), sole-box rotations (T, 3, 3) and
    the sole's lowest point (T,) over the clip's frames."""
    data = mujoco.MjData(model)
    n = len(qpos)
    out = {s: {"hip": np.zeros((n, 3)), "ankle": np.zeros((n, 3)), "sole": np.zeros((n, 3, 3)),
               "low": np.zeros(n)} for s in legs}
    for t in range(n):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        for s, leg in legs.items():
            o = out[s]
            o["hip"][t] = data.xpos[leg.thigh]
            o["ankle"][t] = data.xpos[leg.foot]
            o["sole"][t] = data.geom_xmat[leg.foot_geom].reshape(3, 3)
            o["low"][t] = min(_lowest(model, data, g) for g in (leg.foot_geom, leg.toe_geom) if g is not None)
    return out


def _com_path(model: mujoco.MjModel, qpos: FloatArray) -> FloatArray:
    """(T, 3) the body's centre of mass over the frames."""
    data = mujoco.MjData(model)
    out = np.zeros((len(qpos), 3))
    for t in range(len(qpos)):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        out[t] = data.subtree_com[1]
    return out


def _lowest(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    r = data.geom_xmat[g].reshape(3, 3)
    return float(data.geom_xpos[g][2] - np.abs(r[2]) @ model.geom_size[g])


def _rot_y(theta: FloatArray) -> FloatArray:
    """(T, 3, 3) rotations by ``-theta`` about y: the x axis (a foot's forward) tipped up by theta."""
    c, s = np.cos(theta), np.sin(theta)
    r = np.zeros((len(theta), 3, 3))
    r[:, 0, 0] = c
    r[:, 0, 2] = -s
    r[:, 2, 0] = s
    r[:, 2, 2] = c
    r[:, 1, 1] = 1.0
    return r


def _yaws(psi: FloatArray) -> FloatArray:
    c, s = np.cos(psi), np.sin(psi)
    r = np.zeros((len(psi), 3, 3))
    r[:, 0, 0], r[:, 0, 1], r[:, 1, 0], r[:, 1, 1], r[:, 2, 2] = c, -s, s, c, 1.0
    return r


@dataclass
class _FootShape:
    """A foot's points in its level sole frame (the sole box's axes, heading 0), from the ankle (m):
    the box's corners, the heel and front bottom edges' midpoints and the pivot it rolls over at
    push-off (the toe joint, else the front edge)."""

    corners: FloatArray
    heel: FloatArray
    front: FloatArray
    ball: FloatArray
    toe_length: float = 0.0

    @staticmethod
    def of(model: mujoco.MjModel, leg: _Leg) -> _FootShape:
        g = leg.foot_geom
        r_g = Rotation.from_quat(model.geom_quat[g], scalar_first=True).as_matrix()
        c = r_g.T @ model.geom_pos[g]
        sx, sy, sz = model.geom_size[g]
        corners = np.array([c + [i * sx, j * sy, k * sz] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
        heel, front = c + [-sx, 0.0, -sz], c + [sx, 0.0, -sz]
        ball = r_g.T @ model.body_pos[leg.toe] if leg.toe is not None else front
        toe_length = 2.0 * float(model.geom_size[leg.toe_geom][0]) if leg.toe_geom is not None else 0.0
        return _FootShape(corners, heel, front, ball, toe_length)


#: A stance foot's pitch (rad) within this band of level counts as flat (the capture's jitter).
FLAT_BAND = 0.05


def plan_feet(model: mujoco.MjModel, clip: ReferenceClip, legs: dict[str, _Leg],
              kin: dict[str, dict[str, FloatArray]], clearance: float) -> dict[str, FootPlan]:
    """Footprints and swing paths per side (see the module docstring)."""
    n = clip.num_frames
    out = {}
    for s, leg in legs.items():
        k = kin[s]
        shape = _FootShape.of(model, leg)
        stance = clip.contacts[:, clip.foot_names.index(s)].astype(bool)
        yaw_clip = np.unwrap(_yaw(k["sole"]))
        pitch = np.arcsin(np.clip(k["sole"][:, 2, 0], -1.0, 1.0))  # toes up > 0
        # the clip's pitch less a flat band: a stance foot rolls over its heel (toes up) or its ball
        pitch = np.sign(pitch) * np.maximum(np.abs(pitch) - FLAT_BAND, 0.0)
        tilt = _tilt(k["sole"])
        heading = yaw_clip.copy()
        flat_ankle = k["ankle"].copy()
        prints: list[tuple[int, int, FloatArray, float]] = []
        h0 = -float(shape.heel[2])
        for a, b in _runs(stance):
            cut = np.quantile(tilt[a:b], FLAT_SHARE)
            flat = np.arange(a, b)[tilt[a:b] <= cut + 1e-12]
            p = np.median(k["ankle"][flat, :2], axis=0)
            psi = float(np.median(yaw_clip[flat]))
            prints.append((a, b, np.array([p[0], p[1], h0]), psi))
            flat_ankle[a:b] = [p[0], p[1], h0]
            heading[a:b] = psi
        rot = _yaws(heading) @ _rot_y(pitch)
        ankle = k["ankle"].copy()
        # stance: rolled over the heel edge or the ball, which stays where the flat foot puts it
        st = np.flatnonzero(stance)
        cop = np.full((n, 3), np.nan)
        if len(st):
            y = _yaws(heading[st])
            pivot = np.where((pitch[st] > 0)[:, None], shape.heel[None], shape.ball[None])
            fixed = flat_ankle[st] + np.einsum("tij,tj->ti", y, pivot)
            ankle[st] = fixed - np.einsum("tij,tj->ti", rot[st], pivot)
            mid = np.where((np.abs(pitch[st]) < 1e-9)[:, None], 0.5 * (shape.heel + shape.front)[None], pivot)
            cop[st] = flat_ankle[st] + np.einsum("tij,tj->ti", y, mid)
        # swings (and the frames before the first stance / after the last): the clip's path moved
        # from the footprint left to the one reached, its sole at least the clearance above the floor
        starts = [0] + [b for _, b, _, _ in prints]
        ends = [a for a, _, _, _ in prints] + [n]
        for j, (start, end) in enumerate(zip(starts, ends)):
            if end <= start:
                continue
            left = prints[j - 1] if j > 0 else None
            reach = prints[j] if j < len(prints) else None
            t = np.arange(start, end)
            u = (t - start + 1) / (end - start + 1)
            both = left is not None and reach is not None
            w = _smoothstep(u) if both else np.full(len(t), 0.0 if left is not None else 1.0)
            d0 = None if left is None else ankle[start - 1] - k["ankle"][start - 1]
            d1 = None if reach is None else ankle[end] - k["ankle"][end]
            d0 = d1 if d0 is None else d0
            d1 = d0 if d1 is None else d1
            if d0 is None or d1 is None:
                continue  # no stance at all: the clip's path as it is
            ankle[t, :2] = k["ankle"][t, :2] + (1 - w)[:, None] * d0[None, :2] + w[:, None] * d1[None, :2]
            y0 = left[3] if left is not None else reach[3]  # type: ignore[index]
            y1 = reach[3] if reach is not None else y0
            heading[t] = (1 - w) * y0 + w * y1
            rot[t] = _yaws(heading[t]) @ _rot_y(pitch[t])
            lift = clearance * leg.length * np.sin(np.pi * u) if both else 0.0
            lowest = np.min(np.einsum("tij,cj->tci", rot[t], shape.corners)[..., 2], axis=1)
            ankle[t, 2] = np.maximum(np.maximum(k["low"][t], 0.0), lift) - lowest
        toe = rot.copy()
        ball = stance & (pitch < 0)
        toe[ball] = _yaws(heading[ball])
        if shape.toe_length > 0.0:
            # a swing foot pitched heel up (leaving the floor) bends its toe just enough to keep the tip
            # on the floor, as a toe does as it peels off: turning with the foot, a toe reaches below
            # the floor by its length x the pitch, and snaps from bent to straight at liftoff
            sw = np.flatnonzero(~stance & (pitch < 0))
            if len(sw):
                ball_sole = np.array([shape.ball[0], 0.0, shape.heel[2]])
                z_ball = ankle[sw, 2] + np.einsum("tj,j->t", rot[sw, 2, :], ball_sole)
                need = np.arcsin(np.clip(-z_ball / shape.toe_length, -1.0, 1.0))
                toe[sw] = _yaws(heading[sw]) @ _rot_y(np.maximum(pitch[sw], np.minimum(need, 0.0)))
        out[s] = FootPlan(ankle=ankle, sole=rot, toe=toe, stance=stance, cop=cop)
    return out


GRAVITY = 9.81


def pendulum_shift(com: FloatArray, feet: dict[str, FootPlan], dt: float, weight: float) -> FloatArray:
    """(T, 2) horizontal shift (m) of the centre of mass ``com`` (T, 3) that makes its linear-inverted-
    pendulum ZMP, c - c''/w^2 (w^2 = g / the mean COM height), follow the stance feet's centre of pressure
    (one foot's in single support; in double support moving from the trailing foot's to the leading
    one's): least squares of ``weight`` x the ZMP's error against the shift itself, per axis."""
    n = len(com)
    w2 = GRAVITY / max(float(np.mean(com[:, 2])), 0.1)
    cops = np.stack([f.cop for f in feet.values()], axis=0)  # (S, T, 3)
    down = ~np.isnan(cops[..., 0])
    target = np.full((n, 2), np.nan)
    one = down.sum(axis=0) == 1
    for k in range(len(cops)):
        sel = one & down[k]
        target[sel] = cops[k, sel, :2]
    both = down.all(axis=0)
    for a, b in _runs(both):
        # the leading foot: the one whose stance began later
        start = [a - int(np.argmin(down[k, :a + 1][::-1])) if not down[k, :a + 1].all() else 0
                 for k in range(len(cops))]
        lead = int(np.argmax(start))
        u = (np.arange(a, b) - a + 0.5) / (b - a)
        target[a:b] = (1 - u)[:, None] * cops[1 - lead, a:b, :2] + u[:, None] * cops[lead, a:b, :2]
    rows = np.flatnonzero(~np.isnan(target[:, 0]))
    rows = rows[(rows > 0) & (rows < n - 1)]
    if len(rows) == 0 or weight <= 0:
        return np.zeros((n, 2))
    k2 = 1.0 / (w2 * dt * dt)
    # ZMP z = c - k2 (c[t-1] - 2 c[t] + c[t+1]) as a sparse operator on the whole path
    zmp = diags([-k2 * np.ones(n - 1), (1 + 2 * k2) * np.ones(n), -k2 * np.ones(n - 1)], [-1, 0, 1], format="csr")
    a_mat = vstack([diags(np.ones(n)), weight * zmp[rows]]).tocsc()
    out = np.zeros((n, 2))
    for ax in range(2):
        rhs = np.concatenate([np.zeros(n), weight * (target[rows, ax] - zmp[rows] @ com[:, ax])])
        out[:, ax] = spsolve((a_mat.T @ a_mat).tocsc(), a_mat.T @ rhs)
    return out


def pelvis_drop(kin: dict[str, dict[str, FloatArray]], feet: dict[str, FootPlan], legs: dict[str, _Leg],
                max_extension: float, dt: float, smooth_s: float) -> FloatArray:
    """(T,) how far (m) the pelvis goes down so that no leg reaches farther than ``max_extension`` of its
    length, spread over ``smooth_s`` s (a running maximum, then a moving average of as many frames)."""
    need = np.zeros(len(next(iter(kin.values()))["hip"]))
    for s, leg in legs.items():
        hip, ank = kin[s]["hip"], feet[s].ankle
        reach = max_extension * leg.length
        horiz = np.linalg.norm(hip[:, :2] - ank[:, :2], axis=1)
        dz = hip[:, 2] - ank[:, 2]
        ok = np.sqrt(np.maximum(reach ** 2 - horiz ** 2, 0.0))
        need = np.maximum(need, dz - ok)
    w = max(1, int(round(smooth_s / dt)))
    if w > 1:
        need = uniform_filter1d(maximum_filter1d(need, size=w, mode="nearest"), size=w, mode="nearest")
    return need


def _log(r: FloatArray) -> FloatArray:
    """The rotation vector of a 3x3 rotation (scipy's per-call cost is 100 us; this ~5 us)."""
    c = min(max((r[0, 0] + r[1, 1] + r[2, 2] - 1.0) * 0.5, -1.0), 1.0)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    ang = float(np.arccos(c))
    if ang < 1e-6:
        return 0.5 * v
    if np.pi - ang < 1e-3:
        return Rotation.from_matrix(r).as_rotvec()
    return (ang / (2.0 * np.sin(ang))) * v


def solve_leg(model: mujoco.MjModel, data: mujoco.MjData, leg: _Leg, q0: FloatArray, q_clip: FloatArray,
              ankle: FloatArray, r_sole: FloatArray, r_toe: FloatArray) -> FloatArray:
    """Leg hinge angles (within their ranges) putting the foot body's origin at ``ankle`` (m) with its
    sole box level at heading ``psi`` (and the toe box level alike), from ``q0``; ``data.qpos`` holds
    the rest of the pose. Projected Levenberg-Marquardt on the body's own kinematics."""
    r_fg = data.geom_xmat  # views refreshed by mj_kinematics
    q = np.clip(q0.copy(), leg.lo, leg.hi)
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    lam = 1e-4
    nres = 6 + (3 if leg.toe_geom is not None else 0) + len(q)
    res = np.zeros(nres)
    jac = np.zeros((nres, len(q)))
    wrot = np.array([W_TILT, W_TILT, W_YAW])

    def evaluate(qq: FloatArray) -> float:
        data.qpos[leg.qadr] = qq
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        res[:3] = W_POS * (data.xpos[leg.foot] - ankle)
        rg = r_fg[leg.foot_geom].reshape(3, 3)
        res[3:6] = wrot * _log(rg @ r_sole.T)
        mujoco.mj_jacBody(model, data, jacp, jacr, leg.foot)
        jac[:3] = W_POS * jacp[:, leg.dadr]
        jac[3:6] = wrot[:, None] * jacr[:, leg.dadr]
        if leg.toe_geom is not None and leg.toe is not None:
            rt = r_fg[leg.toe_geom].reshape(3, 3)
            res[6:9] = W_TOE * _log(rt @ r_toe.T)
            mujoco.mj_jacBody(model, data, jacp, jacr, leg.toe)
            jac[6:9] = W_TOE * jacr[:, leg.dadr]
        res[-len(qq):] = W_REG * (qq - q_clip)
        jac[-len(qq):] = W_REG * np.eye(len(qq))
        return float(res @ res)

    cost = evaluate(q)
    for _ in range(IK_ITERS):
        g = jac.T @ res
        h = jac.T @ jac
        r0, j0 = res.copy(), jac.copy()
        step = np.linalg.solve(h + lam * np.diag(np.diag(h) + 1e-9), -g)
        qn = np.clip(q + step, leg.lo, leg.hi)
        cn = evaluate(qn)
        if cn < cost:
            moved = float(np.max(np.abs(qn - q)))
            q, cost, lam = qn, cn, max(lam * 0.3, 1e-9)
            if moved < IK_TOL:
                break
        else:
            res[:], jac[:] = r0, j0
            lam *= 10.0
            if lam > 1e6:
                break
    data.qpos[leg.qadr] = q
    return q


def solve_reaching(model: mujoco.MjModel, data: mujoco.MjData, leg: _Leg, q0: FloatArray, q_clip: FloatArray,
                   ankle: FloatArray, r_sole: FloatArray, r_toe: FloatArray) -> FloatArray:
    """:func:`solve_leg`, restarted with the knee bent (:data:`KNEE_ESCAPE`) where it ended with the knee
    straight and the foot more than :data:`IK_REACH_TOL` off its target; the solution nearer the target
    is kept."""
    q = solve_leg(model, data, leg, q0, q_clip, ankle, r_sole, r_toe)
    if not leg.knee_dofs.any():
        return q
    lo, hi = leg.lo[leg.knee_dofs], leg.hi[leg.knee_dofs]
    straight = np.where(np.abs(lo) <= np.abs(hi), lo, hi)  # the end of the range nearer 0: a straight knee
    miss = float(np.linalg.norm(data.xpos[leg.foot] - ankle))
    if miss <= IK_REACH_TOL or np.any(np.abs(q[leg.knee_dofs] - straight) > KNEE_STRAIGHT):
        return q
    bent = q.copy()
    bent[leg.knee_dofs] = np.clip(straight + np.sign(lo + hi) * KNEE_ESCAPE, lo, hi)
    q2 = solve_leg(model, data, leg, bent, q_clip, ankle, r_sole, r_toe)
    if float(np.linalg.norm(data.xpos[leg.foot] - ankle)) < miss:
        return q2
    data.qpos[leg.qadr] = q
    mujoco.mj_kinematics(model, data)
    return q


def feasible_clip(clip: ReferenceClip, model: mujoco.MjModel, cfg: FeasibleConfig | None = None) -> ReferenceClip:
    """The clip with its lower body made feasible for ``model`` (module docstring); the upper body,
    contacts, events and timing are kept. ``cfg.blend`` mixes the clip's legs (0) and the feasible ones."""
    cfg = cfg or FeasibleConfig(feasible=True)
    if set(SIDES) - set(clip.foot_names):
        raise ModelError(f"the feasible reference needs left and right feet, the clip has {clip.foot_names}")
    legs = {s: _Leg.of(model, s) for s in SIDES}
    kin = _kinematics(model, clip.qpos, legs)
    feet = plan_feet(model, clip, legs, kin, cfg.clearance)
    base = clip.qpos.copy()
    if cfg.pendulum > 0:
        base[:, :2] += pendulum_shift(_com_path(model, clip.qpos), feet, clip.frame_time, cfg.pendulum)
        kin = _kinematics(model, base, legs)
    drop = pelvis_drop(kin, feet, legs, cfg.max_extension, clip.frame_time, cfg.smooth_s)
    qpos = base.copy()
    qpos[:, 2] -= drop
    data = mujoco.MjData(model)
    solved = {s: np.zeros((clip.num_frames, len(leg.qadr))) for s, leg in legs.items()}
    prev = {s: clip.qpos[0, leg.qadr].copy() for s, leg in legs.items()}
    for t in range(clip.num_frames):
        data.qpos[:] = qpos[t]
        for s, leg in legs.items():
            f = feet[s]
            q = solve_reaching(model, data, leg, prev[s], clip.qpos[t, leg.qadr], f.ankle[t], f.sole[t], f.toe[t])
            solved[s][t] = prev[s] = q
    w = cfg.blend
    out = clip.qpos.copy()
    out[:, :3] += w * (qpos[:, :3] - clip.qpos[:, :3])
    for s, leg in legs.items():
        out[:, leg.qadr] = (1.0 - w) * clip.qpos[:, leg.qadr] + w * solved[s]
    qvel = velocities(model, out, clip.frame_time)
    return replace(clip, qpos=out, qvel=qvel)


#: What :func:`infeasible_because` allows: share of frames with a leg hinge more than 0.05 rad out of
#: its range, the leg's extension beyond ``max_extension``, and the stance feet's lowest point above or
#: below the floor (m). The built-in walk measures 0 %, +0.000 and 2.2 cm; every shared capture leaves at
#: least one (docs/controller.md, *Feasible reference*).
TOLERANCE_OUT_OF_RANGE = 0.05
TOLERANCE_EXTENSION = 0.005
TOLERANCE_FLOAT_M = 0.03


def resolve_because(measured: dict[str, float], cfg: FeasibleConfig, generated: bool) -> list[str]:
    """Why ``feasible: auto`` re-solves a clip's legs (empty: it tracks them as they are). A clip
    ``generated`` for the body (the built-in walk) is re-solved only where it measures infeasible
    (:func:`infeasible_because`); a capture always is, since the body was built from its skeleton, not
    posed by it: a capture within the tolerances can still be untrackable as it is."""
    why = infeasible_because(measured, cfg)
    if why or generated:
        return why
    return [f"a capture, re-solved though within the tolerances: legs out of range on "
            f"{measured['legs_out_of_range']:.0%} of frames, a leg {measured['max_extension']:.3f} of its "
            f"length straight, stance feet {measured['stance_low_min'] * 100:.1f} to "
            f"{measured['stance_low_max'] * 100:.1f} cm from the floor"]


def infeasible_because(measured: dict[str, float], cfg: FeasibleConfig) -> list[str]:
    """Why a clip's legs, as :func:`measure` found them, are not feasible for the body (empty: they are)."""
    why = []
    if measured["legs_out_of_range"] > TOLERANCE_OUT_OF_RANGE:
        why.append(f"leg hinges out of range on {measured['legs_out_of_range']:.0%} of frames")
    if measured["max_extension"] > cfg.max_extension + TOLERANCE_EXTENSION:
        why.append(f"a leg {measured['max_extension']:.3f} of its length straight (at most {cfg.max_extension})")
    if max(measured["stance_low_max"], -measured["stance_low_min"]) > TOLERANCE_FLOAT_M:
        why.append(f"stance feet {measured['stance_low_min'] * 100:.1f} to {measured['stance_low_max'] * 100:.1f} cm "
                   "from the floor")
    return why


def sole_heights(model: mujoco.MjModel, qpos: FloatArray) -> dict[str, FloatArray]:
    """Per side, the lowest point (m; 0 = on the floor) of the foot's sole and toe boxes on each frame
    of ``qpos`` (T, nq): what :func:`measure` reads for the stance feet's distance from the floor."""
    legs = {s: _Leg.of(model, s) for s in SIDES}
    kin = _kinematics(model, qpos, legs)
    return {s: kin[s]["low"] for s in SIDES}


def measure(clip: ReferenceClip, model: mujoco.MjModel) -> dict[str, float]:
    """How feasible a clip's legs are for ``model`` (the properties :func:`feasible_clip` builds):

    - ``out_of_range``: share of frames with any hinge more than 0.05 rad outside its range;
      ``legs_out_of_range``: the same over the legs' hinges;
    - ``max_extension``: the longest hip-joint-to-ankle distance over the leg's length (thigh + shin);
    - ``stance_low_min`` / ``stance_low_max``: the stance feet's lowest point (m; 0 = on the floor);
    - ``flat_slide``: the largest horizontal travel (m) of a stance ankle over the frames of one stance
      where its sole lies flat (tilt below :data:`FLAT_BAND`), from their median;
    - ``flat_tilt``: the largest sole tilt (rad) on the frames of a stance flatter than the band."""
    legs = {s: _Leg.of(model, s) for s in SIDES}
    kin = _kinematics(model, clip.qpos, legs)
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    q = clip.qpos[:, model.jnt_qposadr[hinges]]
    out = np.maximum(model.jnt_range[hinges, 0] - q, 0) + np.maximum(q - model.jnt_range[hinges, 1], 0)
    leg_cols = np.isin(model.jnt_qposadr[hinges], np.concatenate([leg.qadr for leg in legs.values()]))
    res = {"out_of_range": float(np.mean((out > 0.05).any(axis=1))),
           "legs_out_of_range": float(np.mean((out[:, leg_cols] > 0.05).any(axis=1))),
           "max_extension": 0.0, "stance_low_min": np.inf, "stance_low_max": -np.inf, "flat_slide": 0.0,
           "flat_tilt": 0.0}
    for s, leg in legs.items():
        k = kin[s]
        ext = np.linalg.norm(k["hip"] - k["ankle"], axis=1) / leg.length
        res["max_extension"] = max(res["max_extension"], float(ext.max()))
        stance = clip.contacts[:, clip.foot_names.index(s)].astype(bool)
        if stance.any():
            res["stance_low_min"] = min(res["stance_low_min"], float(k["low"][stance].min()))
            res["stance_low_max"] = max(res["stance_low_max"], float(k["low"][stance].max()))
        tilt = _tilt(k["sole"])
        for a, b in _runs(stance):
            flat = np.arange(a, b)[tilt[a:b] < FLAT_BAND]
            if len(flat) < 2:
                continue
            xy = k["ankle"][flat, :2]
            res["flat_slide"] = max(res["flat_slide"],
                                    float(np.linalg.norm(xy - np.median(xy, axis=0), axis=1).max()))
            res["flat_tilt"] = max(res["flat_tilt"], float(tilt[flat].max()))
    return res
