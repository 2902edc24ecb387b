"""Where the feasible reference puts each foot (:func:`plan_feet`): stance feet planted at the clip's
footprints, level or rolled over the heel or ball by the clip's pitch beyond a flat band; swing feet on the
clip's path moved from one footprint to the next with a clearance above the floor. Positions in m, world
frame (Z up)."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.reference.clip import ReferenceClip
from bipedsim.reference.feasible_legs import _Leg

FloatArray = npt.NDArray[np.float64]


#: Share of a stance's frames (the sole's least tilted) whose ankle positions and headings make the
#: footprint: a rolling foot is flat in the middle of its stance.
FLAT_SHARE = 1.0 / 3.0


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
