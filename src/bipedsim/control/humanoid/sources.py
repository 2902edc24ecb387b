"""Gait sources behind one interface: a reference clip (looped at gait events) or SIMBICON key poses.

A source answers, for a reference frame ``F`` (float, unwrapped: it only grows) and an FSM state:
hinge targets and target velocities, the pelvis's heading-free target orientation, each thigh's
heading-free world target (for the swing hip), and the reference's own COM offset from the stance
ankle and COM velocity (heading frame) so balance feedback can act on deviations.

The course (:mod:`~bipedsim.control.humanoid.course`), the cycle (:mod:`~bipedsim.control.humanoid.cycles`)
and the hinge table (:mod:`~bipedsim.control.humanoid.hinges`) have modules of their own;
their names are importable from here too.
"""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import axis_rotation, heading_of, yaw_matrix
from bipedsim.control.humanoid.course import MIN_CYCLE_TRAVEL, Course, CourseTracker, clip_course, whole_course
from bipedsim.control.humanoid.cycles import (
    CLIP_SPEED_SMOOTH_S,
    CYCLE_COST_TOLERANCE,
    CYCLE_SEAM_WARN,
    CYCLE_STANCE_FLOAT_M,
    CYCLE_STANCE_SCALE_M,
    CYCLE_STEADY_SPEED,
    CYCLE_STEP_BALANCE,
    CYCLE_VELOCITY_TIME_S,
    SEAM_BLEND_S,
    Cycle,
    best_cycle,
    blend_seam,
    clip_cycle,
    clip_speed,
    describe_clip,
    stance_heights,
    step_time,
)
from bipedsim.control.humanoid.hinges import SIDES, Hinges, foot_points
from bipedsim.control.humanoid.playlist import cycle_playlist, whole_playlist
from bipedsim.control.humanoid.settings import PoseGait
from bipedsim.errors import ModelError
from bipedsim.model.plan import BodyPlanSet
from bipedsim.reference.clip import ReferenceClip

FloatArray = npt.NDArray[np.float64]
#: A rollout starts this fraction of a step after the first right-foot strike of the loop.
START_AFTER_STRIKE = 0.05

__all__ = [
    "CLIP_SPEED_SMOOTH_S", "CYCLE_COST_TOLERANCE", "CYCLE_SEAM_WARN", "CYCLE_STANCE_FLOAT_M", "CYCLE_STANCE_SCALE_M",
    "CYCLE_STEADY_SPEED", "CYCLE_STEP_BALANCE", "CYCLE_VELOCITY_TIME_S", "MIN_CYCLE_TRAVEL", "SEAM_BLEND_S", "SIDES",
    "START_AFTER_STRIKE", "ClipSource", "Course", "CourseTracker", "Cycle", "GaitSource", "Hinges", "PoseSource",
    "best_cycle", "blend_seam", "clip_course", "clip_cycle", "clip_speed", "describe_clip", "foot_points",
    "stance_heights", "step_time"]


class GaitSource:
    """Interface of a gait source (see module docstring)."""

    frame_time: float = 1.0 / 60.0
    loop_start: float = 0.0

    def hinge_targets(self, f: float, state: int) -> tuple[FloatArray, FloatArray]:
        raise NotImplementedError

    def pelvis_target(self, f: float, state: int) -> FloatArray:
        raise NotImplementedError

    def thigh_target(self, f: float, state: int, side: str) -> FloatArray:
        raise NotImplementedError

    def foot_target(self, f: float, state: int, side: str) -> FloatArray | None:
        """Heading-free world orientation of a foot, or None to leave the ankle to joint tracking."""
        return None

    def com_reference(self, f: float, stance: str) -> tuple[FloatArray, FloatArray]:
        """(d_ref, v_ref): COM minus stance ankle and COM velocity, heading frame, horizontal (m, m/s)."""
        return np.zeros(2), np.zeros(2)

    def lateral_reference(self, f: float, stance: str) -> float:
        """The lateral part of ``d_ref`` (m): the walk's own sway of the COM about the stance foot."""
        return float(self.com_reference(f, stance)[0][1])

    def reference_qpos(self, f: float, state: int, qpos_now: FloatArray) -> FloatArray:
        """The reference pose as a full qpos (for the ghost): hinge targets on the current root."""
        q = qpos_now.copy()
        q[self.hinge_qadr] = self.hinge_targets(f, state)[0]
        return q

    def next_strike(self, f: float, side: str) -> float | None:
        """The first reference strike frame of ``side`` at or after ``f`` (unwrapped), if known."""
        return None

    def swing_leg(self, f: float, side: str) -> tuple[float, float, float] | None:
        """The reference's leg of ``side`` at frame ``f``: the ankle from the hip, forward and up in
        the heading frame (m), and the foot's height above the other foot (m, each foot's lowest of its
        ankle and toe origins); None if unknown."""
        return None

    def swing_phase(self, f: float, swing: str) -> float | None:
        """How far the reference is through ``swing``'s step at frame ``f``: 0 at the other foot's
        last strike, 1 at this foot's next (None if unknown)."""
        return None

    def nearest_strike(self, f: float, side: str) -> float | None:
        return None

    def state1_time(self) -> float:
        return 0.3

    def course(self) -> Course:
        """The reference's course: for a source without a path of its own, straight ahead from the
        start (a 1 m segment repeated, heading 0)."""
        return Course(xy=((0.0, 0.0), (1.0, 0.0)), heading=(0.0, 0.0), cycle=(0.0, 1.0, 0.0))

    def course_start(self, f: float) -> tuple[tuple[float, float, float], int]:
        """Where the reference is at frame ``f`` in its course's coordinates (the first cycle): root
        (x, y) (m) and pelvis heading (rad), and the course segment the frame falls in."""
        return (0.0, 0.0, 0.0), 0

    def speed(self) -> float:
        return 0.0

    def speed_at(self, f: float) -> float:
        """The walking speed (m/s) the reference asks for at frame ``f``: :meth:`speed` unless it changes."""
        return self.speed()

    def stance_at(self, f: float) -> str | None:
        """The stance foot at frame ``f`` where the reference says (None: from its nearest strikes)."""
        return None

    def step_time(self) -> float:
        return 0.5


class ClipSource(GaitSource):
    """A :class:`ReferenceClip` played as :mod:`~bipedsim.control.humanoid.playlist` says: whole (its
    frames as captured, then its best cycle looped; ``whole=True``) or its best gait cycle looped
    (:func:`best_cycle`; the seam blended, :func:`blend_seam`)."""

    def __init__(self, clip: ReferenceClip, model: mujoco.MjModel, plan: BodyPlanSet, hinges: Hinges,
                 whole: bool = False) -> None:
        if clip.qpos.shape[1] != model.nq:
            raise ModelError(f"reference clip has {clip.qpos.shape[1]} coordinates, the model {model.nq}: "
                             f"retarget the motion onto this model")
        if plan.profile != "humanoid":
            raise ModelError("the balance controller needs the humanoid profile (two legs)")
        self.clip = clip
        self.frame_time = clip.frame_time
        rs = clip.events["right"]["strike"]
        ls = clip.events["left"]["strike"]
        hq, hqd = clip.qpos[:, hinges.qadr], clip.qvel[:, hinges.dadr]
        cycle = clip_cycle(clip, model, plan, hinges)
        if cycle is None and not whole:
            raise ModelError(f"the reference clip ({clip.source or 'clip'}) has {len(rs)} right and {len(ls)} "
                             f"left foot strikes (right at frames {rs}, left at {ls}; {clip.num_frames} frames at "
                             f"{1 / clip.frame_time:.4g} fps): a gait cycle to loop needs two strikes of one foot "
                             "with one of the other foot between. If the clip walks a whole cycle, give its "
                             "strikes by hand: --events FILE, a YAML like 'right: [12, 140]' and 'left: [76]' "
                             "(frames, or times like '1.2s'); a shorter clip cannot be looped")
        self.cycle = cycle
        blend = int(round(SEAM_BLEND_S / clip.frame_time))
        pl = (whole_playlist(clip, cycle, hq, hqd, blend, hinges.qadr) if whole
              else cycle_playlist(clip, cycle, hq, hqd, blend))
        self.playlist = pl
        self.whole = whole
        self.a, self.b = float(pl.a), float(pl.b)
        self.period = self.b - self.a
        self.loop_start = 0.0 if whole else self.a
        self.strikes = pl.loop
        self.once = pl.once
        self.hinge_qadr = hinges.qadr
        self.q, self.qd = pl.q, pl.qd
        self.qpos_played = pl.qpos
        self.nh = self.q.shape[1]
        self.q_qd = np.ascontiguousarray(np.hstack([self.q, self.qd]))  # one interpolation per step
        n = self.n = len(pl.qpos)
        self._last_f, self._last_k = float("nan"), 0
        none = (float("nan"), float("nan"), None)
        self._next_memo: dict[str, tuple[float, float, float | None]] = {s: none for s in SIDES}
        self._last_memo: dict[str, tuple[float, float, float | None]] = {s: none for s in SIDES}
        data = mujoco.MjData(model)
        pelvis = model.body("pelvis").id
        thighs = {s: model.body(f"{s}_thigh").id for s in SIDES}
        self.foot_hf = {s: np.zeros((n, 3, 3)) for s in SIDES}
        feet = {s: model.body(f"{s}_foot").id for s in SIDES}
        self.pelvis_hf = np.zeros((n, 3, 3))
        self.thigh_hf = {s: np.zeros((n, 3, 3)) for s in SIDES}
        com = np.zeros((n, 3))
        ankle = {s: np.zeros((n, 3)) for s in SIDES}
        heading = np.zeros(n)
        hip = {s: np.zeros((n, 3)) for s in SIDES}
        low = {s: np.zeros(n) for s in SIDES}
        self.foot_points = {s: foot_points(model, s) for s in SIDES}
        for t in range(n):
            data.qpos[:] = pl.qpos[t]
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            r = data.xmat[pelvis].reshape(3, 3)
            heading[t] = heading_of(r)
            ry = yaw_matrix(-heading[t])
            self.pelvis_hf[t] = ry @ r
            for s in SIDES:
                self.thigh_hf[s][t] = ry @ data.xmat[thighs[s]].reshape(3, 3)
                self.foot_hf[s][t] = ry @ data.xmat[feet[s]].reshape(3, 3)
                ankle[s][t] = data.xpos[feet[s]]
                hip[s][t] = ry @ (data.xpos[feet[s]] - data.xpos[thighs[s]])
                low[s][t] = min(float(data.xpos[b, 2]) for b in self.foot_points[s])
            com[t] = data.subtree_com[pelvis]
        vel = np.gradient(com, self.frame_time, axis=0)
        self.d_ref = {}
        self.v_ref = np.zeros((n, 2))
        for t in range(n):
            ry = yaw_matrix(-heading[t])
            self.v_ref[t] = (ry @ vel[t])[:2]
        for s in SIDES:
            dd = np.zeros((n, 2))
            for t in range(n):
                dd[t] = (yaw_matrix(-heading[t]) @ (com[t] - ankle[s][t]))[:2]
            self.d_ref[s] = dd
        self._d_lat = {s: self.d_ref[s][:, 1].tolist() for s in SIDES}  # per-step reads on plain floats
        # the swing leg's reference geometry (reference modulation): hip-to-ankle forward and up, the
        # foot's height above the other foot
        other = {"left": "right", "right": "left"}
        self._leg = {s: np.column_stack([hip[s][:, 0], hip[s][:, 2], low[s] - low[other[s]]])
                     for s in SIDES}
        root = pl.qpos[:, :2]
        a, b = int(self.a), int(self.b)
        self._speed = float(np.linalg.norm(root[b] - root[a]) / (self.period * self.frame_time))
        steps = np.sort(np.concatenate([self.strikes["right"], self.strikes["left"]]))
        self._step = (float(np.mean(np.diff(np.append(steps, self.b)))) * self.frame_time if len(steps)
                      else step_time(clip) or GaitSource.step_time(self))
        self._heading = heading
        if whole:
            self._course = whole_course(com[:, :2], np.unwrap(heading), root, a, b)
            xy = np.asarray(self._course.xy)
            # the clip's own speed along its course before the loop (m/s); the loop's mean speed after
            self._speeds = (np.linalg.norm(np.diff(xy[:a + 1], axis=0), axis=1) / self.frame_time).tolist()
        else:
            self._course = clip_course(com[:, :2], np.unwrap(heading), root, a, b)
            self._speeds = []

    def course(self) -> Course:
        return self._course

    def course_start(self, f: float) -> tuple[tuple[float, float, float], int]:
        w = self.wrap(f)
        t = min(int(round(w)), self.n - 1)
        x, y = self.qpos_played[t, :2].tolist()
        seg = min(max(int(w - self._course.first_frame), 0), len(self._course.xy) - 2)
        return (x, y, float(self._heading[t])), seg

    # ------------------------------------------------------------------ frames
    # (these run on every control step: plain float maths, one interpolation for q and qdot)
    def wrap(self, f: float) -> float:
        if f < self.a:
            return f
        return self.a + (f - self.a) % self.period

    def _pair(self, f: float) -> tuple[int, int, float]:
        """Rows (i, j) and weight u of frame ``f``: value = row_i (1 - u) + row_j u."""
        w = self.wrap(f)
        i = int(w // 1.0)
        u = w - i
        j = i + 1
        if j >= self.b and self.a <= i:
            j = int(self.a) + (j - int(self.b))
        last = self.n - 1
        return (i if i < last else last), (j if j < last else last), u

    def _interp(self, arr: FloatArray, f: float) -> FloatArray:
        i, j, u = self._pair(f)
        lo = arr[i]
        return lo + u * (arr[j] - lo)

    def _nearest(self, f: float) -> int:
        # asked several times per control step for the same frame (pelvis, thigh, feet)
        if f != self._last_f:
            self._last_f, self._last_k = f, int(round(self.wrap(f))) % self.n
        return self._last_k

    def hinge_targets(self, f: float, state: int) -> tuple[FloatArray, FloatArray]:
        both = self._interp(self.q_qd, f)
        return both[:self.nh], both[self.nh:]

    def pelvis_target(self, f: float, state: int) -> FloatArray:
        return self.pelvis_hf[self._nearest(f)]

    def thigh_target(self, f: float, state: int, side: str) -> FloatArray:
        return self.thigh_hf[side][self._nearest(f)]

    def foot_target(self, f: float, state: int, side: str) -> FloatArray | None:
        return self.foot_hf[side][self._nearest(f)]

    def reference_qpos(self, f: float, state: int, qpos_now: FloatArray) -> FloatArray:
        """The clip's pose at frame ``f`` (nearest frame), root where the clip has it."""
        return self.qpos_played[self._nearest(f)].copy()

    def com_reference(self, f: float, stance: str) -> tuple[FloatArray, FloatArray]:
        return self._interp(self.d_ref[stance], f), self._interp(self.v_ref, f)

    def lateral_reference(self, f: float, stance: str) -> float:
        i, j, u = self._pair(f)
        lo, hi = self._d_lat[stance][i], self._d_lat[stance][j]
        return lo + u * (hi - lo)

    def _strikes_near(self, f: float, side: str) -> FloatArray:
        if not self.whole:
            k = np.floor((f - self.a) / self.period)
            base = self.strikes[side]
            return np.concatenate([base + (k + d) * self.period for d in (-1, 0, 1, 2)])
        # the strikes played once near f, then the loop's repetitions from its first on
        once = self.once[side]
        lo, hi = np.searchsorted(once, [f - 2 * self.period, f + 3 * self.period])
        k = max(np.floor((f - self.a) / self.period), 0.0)
        base = self.strikes[side]
        loop = np.concatenate([base + (k + d) * self.period for d in (-1, 0, 1, 2)])
        return np.concatenate([once[lo:hi], loop[loop >= self.a]])

    def stance_at(self, f: float) -> str | None:
        """The foot the body stands on at frame ``f`` of the whole clip: the one in contact, or of two
        the one that stays down longer (None for a looped cycle, which starts on its strike)."""
        if not self.whole:
            return None
        t = min(int(round(self.wrap(f))), self.n - 1)
        on = self.playlist.contacts[t]
        if on.sum() == 1:
            return SIDES[int(np.argmax(on))]
        if on.sum() == 2:
            rest = self.playlist.contacts[t:]
            lift = [int(np.argmin(rest[:, k])) if not rest[:, k].all() else len(rest) for k in range(2)]
            return SIDES[int(np.argmax(lift))]
        return None

    def speed_at(self, f: float) -> float:
        """The reference's walking speed at frame ``f`` (m/s): along its course before the loop (the
        clip's speed changes, its starts and stops), the loop's mean speed in the loop."""
        if f >= self.a or not self._speeds:
            return self._speed
        i = int(f) if f > 0.0 else 0
        return self._speeds[min(i, len(self._speeds) - 1)]

    # next_strike and swing_phase run on every control step; their answers change only at strikes, so
    # each is kept with the span of frames it holds for: (low, high, answer)
    def next_strike(self, f: float, side: str) -> float | None:
        lo, hi, v = self._next_memo[side]
        if lo < f - 1e-9 <= hi:
            return v
        c = self._strikes_near(f, side)
        after = c[c >= f - 1e-9]
        if not len(after):
            return None
        v = float(after.min())
        before = c[c < v]
        # the answer holds from just after the strike before it (or from f) to itself
        self._next_memo[side] = (float(before.max()) if len(before) else f - 1e-9 - 1e-12, v, v)
        return v

    def _last_strike(self, f: float, side: str) -> float | None:
        """The last strike frame of ``side`` at or before ``f`` (unwrapped), if known."""
        lo, hi, v = self._last_memo[side]
        if lo <= f + 1e-9 < hi:
            return v
        c = self._strikes_near(f, side)
        upto = c[c <= f + 1e-9]
        if not len(upto):
            return None
        v = float(upto.max())
        later = c[c > v]
        # the answer holds from itself to just before the next strike (or up to f)
        self._last_memo[side] = (v, float(later.min()) if len(later) else f + 1e-9 + 1e-12, v)
        return v

    def nearest_strike(self, f: float, side: str) -> float | None:
        c = self._strikes_near(f, side)
        return float(c[np.argmin(np.abs(c - f))]) if len(c) else None

    def swing_leg(self, f: float, side: str) -> tuple[float, float, float] | None:
        x, z, h = self._interp(self._leg[side], f).tolist()
        return x, z, h

    def swing_phase(self, f: float, swing: str) -> float | None:
        nxt = self.next_strike(f, swing)
        prv = self._last_strike(f, "left" if swing == "right" else "right")
        if nxt is None or prv is None:
            return None
        return (f - prv) / max(nxt - prv, 1e-6)

    def start_frame(self) -> float:
        """Where a rollout starts: a looped cycle just after its first strike (the right foot's, or the
        left's for a left-to-left loop), when that foot already carries weight (starting exactly on the
        strike frame leaves neither foot loaded); the whole clip just after its first strike."""
        after = max(1.0, round(START_AFTER_STRIKE * self._step / self.frame_time))
        if not self.whole:
            return self.a + after
        # at the clip's first strike, as a looped cycle starts on its own: the gait machine takes over
        # with a foot just planted (a capture may begin anywhere in a step, or standing, which the walking
        # controller does not hold)
        first = min((float(v[0]) for v in (self.once["left"], self.once["right"]) if len(v)), default=self.a)
        return first + after

    def state1_time(self) -> float:
        return 0.5 * self._step

    def speed(self) -> float:
        return self._speed

    def step_time(self) -> float:
        return self._step


class PoseSource(GaitSource):
    """SIMBICON's per-state key poses (no clip): state A (1, 3) for ``state_a_time`` then state B
    (2, 4) until the swing foot lands. The swing hip target is a world-frame sagittal angle."""

    def __init__(self, gait: PoseGait, hinges: Hinges) -> None:
        self.gait = gait
        self.hinges = hinges
        self.hinge_qadr = hinges.qadr
        self.n = len(hinges.names)
        self.frame_time = 1.0 / 60.0

        def idx(name: str) -> int | None:
            return hinges.names.index(name) if name in hinges.names else None

        self.idx = {k: idx(k) for k in ("left_knee", "right_knee", "left_ankle", "right_ankle", "left_elbow",
                                        "right_elbow", "spine_y")}
        if self.idx["left_knee"] is None or self.idx["right_knee"] is None:
            raise ModelError("the pose-target gait needs a humanoid with knees")

    def _pose(self, state: int):  # noqa: ANN202
        return self.gait.state_a if state in (1, 3) else self.gait.state_b

    def hinge_targets(self, f: float, state: int) -> tuple[FloatArray, FloatArray]:
        p = self._pose(state)
        stance, swing = ("right", "left") if state in (1, 2) else ("left", "right")
        q = np.zeros(self.n)
        for name, val in ((f"{swing}_knee", p.swing_knee), (f"{stance}_knee", p.stance_knee),
                          (f"{swing}_ankle", p.swing_ankle), (f"{stance}_ankle", p.stance_ankle),
                          ("left_elbow", self.gait.elbow), ("right_elbow", self.gait.elbow)):
            i = self.idx.get(name)
            if i is not None:
                q[i] = val
        return q, np.zeros(self.n)

    def pelvis_target(self, f: float, state: int) -> FloatArray:
        # torso lean forward is a negative rotation about y (x forward, z up)
        return axis_rotation(np.array([0.0, 1.0, 0.0]), self._pose(state).torso)

    def thigh_target(self, f: float, state: int, side: str) -> FloatArray:
        return axis_rotation(np.array([0.0, 1.0, 0.0]), -self._pose(state).swing_hip)

    def state1_time(self) -> float:
        return self.gait.state_a_time
