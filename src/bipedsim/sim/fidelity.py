"""How closely a run reproduced its clip, over the clip's own duration.

The clip is compared by time, not by the controller's reference frame (which resynchronisation moves
back and forth): at simulated time ``t`` (s) the clip is at frame ``start_frame + t / frame_time``, from
the frame the run started at to the clip's last frame, ``(num_frames - 1 - start_frame) * frame_time``
seconds in all. A run that falls sooner is compared over the part it simulated (:attr:`Fidelity.covered`).

Figures (SI inside; the joint error in cm as it is reported):

- root path: the body's root (the body of the free joint: the humanoid's pelvis, a creature's root) and
  the clip's, horizontal (x, y), each averaged over :data:`SMOOTH_S` (centred) so that the side-to-side
  sway of stepping leaves the comparison, the clip's turned and moved once so that its position and
  heading at the start are the body's; the largest and the final distance between the two (m), the
  length of each path (m) and their ratio;
- speed: each root's mean horizontal speed (m/s; positions :data:`SPEED_DT_S` apart, not smoothed, so
  sway counts) and their ratio;
- joints: every body's position relative to the root, in the root's heading frame (drift and heading
  are the root path's to report), body against clip, the distance averaged over bodies and samples (cm).

Everything here is a pure function of arrays and a MuJoCo model (forward kinematics only).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.sim.recorder import Trajectory

FloatArray = npt.NDArray[np.float64]

#: Window (s) of the centred moving average of the root paths: a step or two, so a walk's sideways
#: sway (one period per stride) averages out and turns (several seconds) stay.
SMOOTH_S = 1.0
#: Spacing (s) of the root positions the mean speeds are measured from: coarse enough to leave out
#: contact jitter, fine enough to keep each step's motion.
SPEED_DT_S = 0.1
#: A clip whose smoothed root path is shorter than this (m) is in place: no path ratio.
MIN_CLIP_PATH_M = 0.05
#: A clip slower than this (m/s, mean horizontal root speed) has no speed ratio.
MIN_CLIP_SPEED_MPS = 0.02
#: A root axis counts as horizontal enough to give the heading when its floor projection is at least
#: this long (a unit axis tilted at most 45 degrees from the floor).
HEADING_AXIS_MIN = math.cos(math.pi / 4)
#: The goal a clip's root path is judged by: the body's stays within max(PATH_TOLERANCE_M,
#: PATH_TOLERANCE_SHARE x the clip's path length) of the clip's and covers PATH_RATIO_RANGE of its length.
PATH_TOLERANCE_M = 0.5
PATH_TOLERANCE_SHARE = 0.10
PATH_RATIO_RANGE = (0.7, 1.5)
#: A run counts as having covered the whole clip when it lasted to within this share of a sample of its end.
_END_SLACK = 1.5


@dataclass(frozen=True)
class Fidelity:
    """A run against its clip (see the module's text). Lengths in m, speeds in m/s, times in s."""

    clip_seconds: float  #: the clip's duration from the frame the run started at (s)
    compared_seconds: float  #: the part of it compared (s): all of it, or up to the run's end or fall
    covered: float  #: compared_seconds / clip_seconds (0..1)
    path_max_m: float  #: largest distance between the smoothed, start-aligned root paths (m)
    path_final_m: float  #: their distance at the end of the compared part (m)
    clip_path_m: float  #: length of the clip's smoothed root path over the compared part (m)
    body_path_m: float  #: length of the body's smoothed root path over the same time (m)
    path_ratio: float | None  #: body_path_m / clip_path_m; None for a clip in place (< MIN_CLIP_PATH_M)
    clip_speed_mps: float  #: the clip's mean horizontal root speed (m/s)
    body_speed_mps: float  #: the body's (m/s)
    speed_ratio: float | None  #: body over clip; None for a clip slower than MIN_CLIP_SPEED_MPS
    joint_error_cm: float  #: mean body-position error relative to the root, heading frame (cm)
    start_frame: float  #: the clip frame the run started at
    samples: int  #: recorded samples compared

    @property
    def path_tolerance_m(self) -> float:
        """How far (m) the body's path may stray from the clip's: max(0.5 m, 10 % of the clip's path)."""
        return max(PATH_TOLERANCE_M, PATH_TOLERANCE_SHARE * self.clip_path_m)

    @property
    def path_ok(self) -> bool:
        """The whole clip was simulated, the body's path stayed within :attr:`path_tolerance_m` of the
        clip's and (a clip that travels) covered 70-150 % of its length."""
        lo, hi = PATH_RATIO_RANGE
        ratio_ok = self.path_ratio is None or lo <= self.path_ratio <= hi
        return self.covered >= 1.0 and self.path_max_m <= self.path_tolerance_m and ratio_ok

    def to_dict(self) -> dict[str, Any]:
        """The figures, the goal's tolerance and verdict, as written to ``outcome.json``."""
        return dict(asdict(self), path_tolerance_m=self.path_tolerance_m, path_ok=self.path_ok)

    def describe(self) -> str:
        """One line: ``fidelity over the clip's 10.20 s: path within 0.31 m (final 0.12 m), 96 % of the
        clip's path, speed x0.97, joints 4.1 cm``."""
        if self.covered >= 1.0:
            span = f"over the clip's {self.clip_seconds:.2f} s"
        else:
            span = (f"over {self.compared_seconds:.2f} s of the clip's {self.clip_seconds:.2f} s "
                    f"({100 * self.covered:.0f} %, the run ended sooner)")
        path = (f"{100 * self.path_ratio:.0f} % of the clip's path ({self.clip_path_m:.2f} m)"
                if self.path_ratio is not None else f"clip in place ({self.clip_path_m:.2f} m of path)")
        speed = f"speed x{self.speed_ratio:.2f}" if self.speed_ratio is not None else "speed -"
        return (f"fidelity {span}: path within {self.path_max_m:.2f} m (final {self.path_final_m:.2f} m), "
                f"{path}, {speed}, joints {self.joint_error_cm:.1f} cm")


# ---------------------------------------------------------------------- the pieces
def clip_seconds(num_frames: int, frame_time: float, start_frame: float) -> float:
    """The clip's duration (s) from ``start_frame`` to its last frame (0 when it starts at or past it)."""
    return max(0.0, (num_frames - 1 - start_frame) * frame_time)


def clip_frames_at(t: FloatArray, start_frame: float, frame_time: float) -> FloatArray:
    """The clip's (fractional) frame at simulated times ``t`` (s) of a run that started at ``start_frame``."""
    return start_frame + np.asarray(t, dtype=np.float64) / frame_time


def interp_rows(rows: FloatArray, frames: FloatArray) -> FloatArray:
    """``rows`` (N, ...) linearly interpolated at fractional indices ``frames`` (clamped to 0 .. N - 1)."""
    rows = np.asarray(rows, dtype=np.float64)
    f = np.clip(np.asarray(frames, dtype=np.float64), 0.0, len(rows) - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, len(rows) - 1)
    w = (f - i0).reshape(-1, *([1] * (rows.ndim - 1)))
    return rows[i0] * (1.0 - w) + rows[i1] * w


def moving_average(t: FloatArray, x: FloatArray, window_s: float = SMOOTH_S) -> FloatArray:
    """``x`` (T, ...) sampled at increasing times ``t`` (s), averaged over a centred window of
    ``window_s`` s; near the ends the window holds only the samples there are."""
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    lo = np.searchsorted(t, t - window_s / 2, side="left")
    hi = np.searchsorted(t, t + window_s / 2, side="right")
    c = np.concatenate([np.zeros((1, *x.shape[1:])), np.cumsum(x, axis=0)])
    return (c[hi] - c[lo]) / (hi - lo).reshape(-1, *([1] * (x.ndim - 1)))


def path_length(xy: FloatArray) -> float:
    """Length (m) of the polyline through the points ``xy`` (T, 2)."""
    return float(np.linalg.norm(np.diff(np.asarray(xy, dtype=np.float64), axis=0), axis=1).sum())


def root_of(model: mujoco.MjModel) -> tuple[int, int]:
    """(body id, qpos address) of the model's free joint, its root; :class:`ValueError` without one."""
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    if not len(free):
        raise ValueError("the model has no free joint (no root to follow)")
    j = int(free[0])
    return int(model.jnt_bodyid[j]), int(model.jnt_qposadr[j])


def _matrices(quats: FloatArray) -> FloatArray:
    """Rotation matrices (N, 3, 3) of MuJoCo quaternions (N, 4: w x y z)."""
    q = np.asarray(quats, dtype=np.float64).reshape(-1, 4)
    return Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()


def heading_axis(quat: FloatArray) -> int:
    """The root axis (0 x, 1 y, 2 z) that gives the heading of a root turned by ``quat`` (w x y z): the
    first that lies within 45 degrees of the floor (x for an upright humanoid's pelvis; another for a
    creature whose root frame is turned), else the most horizontal."""
    r = _matrices(quat)[0]
    horiz = np.hypot(r[0], r[1])  # floor projection of each axis (columns)
    ok = np.flatnonzero(horiz >= HEADING_AXIS_MIN)
    return int(ok[0]) if len(ok) else int(np.argmax(horiz))


def headings(quats: FloatArray, axis: int) -> FloatArray:
    """Yaw (rad, about world z, unwrapped) of root ``axis`` for each quaternion (N, 4: w x y z)."""
    m = _matrices(quats)
    return np.unwrap(np.arctan2(m[:, 1, axis], m[:, 0, axis]))


def yaw_matrix(angle: float) -> FloatArray:
    """2x2 rotation (rad, counter-clockwise seen from above)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def align_start(clip_xy: FloatArray, clip_yaw0: float, body_xy0: FloatArray, body_yaw0: float) -> FloatArray:
    """The clip's root path ``clip_xy`` (T, 2; m) turned about its first point by ``body_yaw0 -
    clip_yaw0`` (rad) and moved so that it starts at ``body_xy0``."""
    clip_xy = np.asarray(clip_xy, dtype=np.float64)
    rot = yaw_matrix(body_yaw0 - clip_yaw0)
    return (clip_xy - clip_xy[0]) @ rot.T + np.asarray(body_xy0, dtype=np.float64)


def local_positions(model: mujoco.MjModel, qpos: FloatArray, axis: int) -> FloatArray:
    """Every body's position (m) but the world's and the root's, relative to the root, in the root's
    heading frame (turned by minus the yaw of root ``axis``; z stays up), per pose: (N, bodies, 3)."""
    root, adr = root_of(model)
    bodies = [b for b in range(1, model.nbody) if b != root]
    data = mujoco.MjData(model)
    qpos = np.asarray(qpos, dtype=np.float64)
    yaw = headings(qpos[:, adr + 3:adr + 7], axis)
    out = np.empty((len(qpos), len(bodies), 3))
    for i, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        rel = data.xpos[bodies] - data.xpos[root]
        c, s = math.cos(yaw[i]), math.sin(yaw[i])
        out[i, :, 0] = c * rel[:, 0] + s * rel[:, 1]
        out[i, :, 1] = -s * rel[:, 0] + c * rel[:, 1]
        out[i, :, 2] = rel[:, 2]
    return out


def mean_speed(t: FloatArray, xy: FloatArray, dt: float = SPEED_DT_S) -> float:
    """Mean horizontal speed (m/s) of positions ``xy`` (T, 2; m) at times ``t`` (s), measured on
    positions ``dt`` s apart (the last interval shorter)."""
    t = np.asarray(t, dtype=np.float64)
    span = float(t[-1] - t[0])
    if span <= 0:
        return 0.0
    grid = np.append(np.arange(t[0], t[-1], dt), t[-1])
    g = np.stack([np.interp(grid, t, xy[:, k]) for k in range(2)], axis=1)
    return path_length(g) / span


# ---------------------------------------------------------------------- the whole measure
def measure_fidelity(model: mujoco.MjModel, time: FloatArray, qpos: FloatArray, clip_qpos: FloatArray,
                     frame_time: float, start_frame: float, *, run_seconds: float | None = None,
                     smooth_s: float = SMOOTH_S) -> Fidelity | None:
    """A run's recorded samples (``time`` s, ``qpos`` per sample) against its clip (``clip_qpos`` per
    frame, ``frame_time`` s per frame) on ``model``, the run having started at clip frame
    ``start_frame`` (see the module's text). ``run_seconds``: how long the run lasted (s; default: the
    last sample's time); the clip counts as covered when the run lasted past its end. None when there
    is nothing to compare (the run started at the clip's last frame, or fewer than 2 samples)."""
    time = np.asarray(time, dtype=np.float64)
    span = clip_seconds(len(clip_qpos), frame_time, start_frame)
    if span <= 0 or len(time) < 2:
        return None
    keep = time <= span + 1e-9
    t, q = time[keep], np.asarray(qpos, dtype=np.float64)[keep]
    if len(t) < 2:
        return None
    sample_dt = float(np.median(np.diff(time)))
    lasted = float(run_seconds) if run_seconds is not None else float(time[-1]) + sample_dt
    covered = 1.0 if lasted + _END_SLACK * sample_dt >= span else max(0.0, float(t[-1]) / span)
    _, adr = root_of(model)
    cq = np.asarray(clip_qpos, dtype=np.float64)
    frames = clip_frames_at(t, start_frame, frame_time)
    axis = heading_axis(interp_rows(cq[:, adr + 3:adr + 7], np.array([start_frame]))[0])
    body_yaw = headings(q[:, adr + 3:adr + 7], axis)
    clip_yaw0 = float(interp_rows(headings(cq[:, adr + 3:adr + 7], axis), np.array([start_frame]))[0])
    body_xy = q[:, adr:adr + 2]
    clip_xy = align_start(interp_rows(cq[:, adr:adr + 2], frames), clip_yaw0, body_xy[0], float(body_yaw[0]))
    sb, sc = moving_average(t, body_xy, smooth_s), moving_average(t, clip_xy, smooth_s)
    dist = np.linalg.norm(sb - sc, axis=1)
    clip_path, body_path = path_length(sc), path_length(sb)
    clip_v, body_v = mean_speed(t, clip_xy), mean_speed(t, body_xy)
    lo = int(np.floor(frames.min()))
    hi = min(int(np.ceil(frames.max())), len(cq) - 1)
    clip_local = local_positions(model, cq[lo:hi + 1], axis)
    ref = interp_rows(clip_local, frames - lo)
    err = np.linalg.norm(local_positions(model, q, axis) - ref, axis=2)
    return Fidelity(clip_seconds=span, compared_seconds=float(t[-1] - t[0]) if covered < 1.0 else span,
                    covered=covered, path_max_m=float(dist.max()), path_final_m=float(dist[-1]),
                    clip_path_m=clip_path, body_path_m=body_path,
                    path_ratio=body_path / clip_path if clip_path >= MIN_CLIP_PATH_M else None,
                    clip_speed_mps=clip_v, body_speed_mps=body_v,
                    speed_ratio=body_v / clip_v if clip_v >= MIN_CLIP_SPEED_MPS else None,
                    joint_error_cm=100.0 * float(err.mean()) if err.size else 0.0,
                    start_frame=float(start_frame), samples=int(len(t)))


def trajectory_fidelity(model: mujoco.MjModel, tr: Trajectory, run_seconds: float | None = None) -> Fidelity | None:
    """:func:`measure_fidelity` of a recorded run against the clip its trajectory keeps
    (:meth:`~bipedsim.sim.recorder.Trajectory.with_clip`); None when it keeps none."""
    clip = tr.clip_pose_frames()
    if clip is None:
        return None
    clip_qpos, frame_time, start = clip
    return measure_fidelity(model, tr.time, tr.qpos, clip_qpos, frame_time, start, run_seconds=run_seconds)


__all__ = ["Fidelity", "SMOOTH_S", "SPEED_DT_S", "align_start", "clip_frames_at", "clip_seconds", "heading_axis",
           "headings", "interp_rows", "local_positions", "mean_speed", "measure_fidelity", "moving_average",
           "path_length", "root_of", "trajectory_fidelity"]
