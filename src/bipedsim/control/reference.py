"""Gait sources behind one interface: a reference clip (looped at gait events) or SIMBICON key poses.

A source answers, for a reference frame ``F`` (float, unwrapped: it only grows) and an FSM state:
hinge targets and target velocities, the pelvis's heading-free target orientation, each thigh's
heading-free world target (for the swing hip), and the reference's own COM offset from the stance
ankle and COM velocity (heading frame) so balance feedback can act on deviations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.balance import axis_rotation, heading_of, yaw_matrix
from bipedsim.control.config import PoseGait
from bipedsim.errors import ModelError
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.feasible import sole_heights
from bipedsim.model.gait import smooth
from bipedsim.model.plan import BodyPlanSet

FloatArray = npt.NDArray[np.float64]
SIDES = ("right", "left")
#: A rollout starts this fraction of a step after the first right-foot strike of the loop.
START_AFTER_STRIKE = 0.05


#: A course whose cycle moves the reference less than this (m) is a walk in place: it has no line to
#: hold, and the course law only follows its heading.
MIN_CYCLE_TRAVEL = 0.05


@dataclass(frozen=True)
class Course:
    """The reference's sway-free path over one loop of the clip, reference world frame (m, rad).

    The loop ("cycle" here) runs from a foot strike to a later strike of the same foot: one or more gait
    cycles. ``xy`` are course points, one per reference frame of the loop (first to last inclusive): the
    reference's centre of mass averaged over one loop centred on that frame, which removes the
    step-to-step sway and keeps any veer (an arc of radius R is kept R theta^2 / 24 inside, theta the
    loop's turn). ``heading`` is the pelvis heading averaged the same way (unwrapped). ``cycle`` =
    (angle rad, tx m, ty m) is the rigid planar motion that carries the loop's start onto its end,
    p -> R(angle) p + t: the looped clip's k-th loop is the course moved k times."""

    xy: tuple[tuple[float, float], ...]
    heading: tuple[float, ...]
    cycle: tuple[float, float, float]

    @property
    def travel(self) -> float:
        """How far (m) one cycle carries the course's first point."""
        x, y = self.xy[0]
        cyc = _Rigid.of(*self.cycle)
        x1, y1 = cyc.apply(x, y)
        return float(np.hypot(x1 - x, y1 - y))


def clip_course(com_xy: FloatArray, heading: FloatArray, root_xy: FloatArray, a: int, b: int) -> Course:
    """The :class:`Course` of a clip looped over frames [a, b]: ``com_xy`` (n, 2) its centre of mass,
    ``heading`` (n,) its pelvis heading (rad, unwrapped), ``root_xy`` (n, 2) its root, world frame.

    The loop's motion is the root's from a to b (both strikes of one foot, the same phase); frames half
    a loop beyond either end are the neighbouring loops moved by it, so the average is centred on every
    frame. It spans exactly one period P = b - a (P + 1 samples with half weights at the ends for an even
    P), which cancels every harmonic of a sway periodic in the loop."""
    period = b - a
    if period < 2:
        raise ModelError(f"a looped cycle needs at least 2 frames, got {period}")
    turn = float(heading[b] - heading[a])
    c, s = np.cos(turn), np.sin(turn)
    rot = np.array([[c, -s], [s, c]])
    shift = root_xy[b] - rot @ root_xy[a]
    half = period // 2
    before = (com_xy[b - half:b] - shift) @ rot  # R^T (p - t): the previous cycle
    after = com_xy[a + 1:a + half + 1] @ rot.T + shift
    ext_xy = np.vstack([before, com_xy[a:b + 1], after])
    ext_h = np.concatenate([heading[b - half:b] - turn, heading[a:b + 1], heading[a + 1:a + half + 1] + turn])
    if period % 2 == 0:
        w = np.ones(period + 1)
        w[0] = w[-1] = 0.5
    else:
        w = np.ones(period)
    w /= w.sum()
    xy = np.stack([np.convolve(ext_xy[:, k], w, mode="valid") for k in range(2)], axis=1)[:period + 1]
    h = np.convolve(ext_h, w, mode="valid")[:period + 1]
    # the last point is the first one moved by a cycle, exactly, so consecutive cycles join
    xy[-1] = rot @ xy[0] + shift
    h[-1] = h[0] + turn
    return Course(xy=tuple((float(x), float(y)) for x, y in xy), heading=tuple(float(v) for v in h),
                  cycle=(turn, float(shift[0]), float(shift[1])))


@dataclass(frozen=True)
class _Rigid:
    """A planar rigid motion p -> R(angle) p + (tx, ty) on plain floats."""

    angle: float
    c: float
    s: float
    tx: float
    ty: float

    @staticmethod
    def of(angle: float, tx: float, ty: float) -> _Rigid:
        return _Rigid(angle, math.cos(angle), math.sin(angle), tx, ty)

    def apply(self, x: float, y: float) -> tuple[float, float]:
        return self.c * x - self.s * y + self.tx, self.s * x + self.c * y + self.ty

    def rotate(self, x: float, y: float) -> tuple[float, float]:
        return self.c * x - self.s * y, self.s * x + self.c * y

    def then(self, other: _Rigid) -> _Rigid:
        """``other`` after ``self``: p -> other(self(p))."""
        tx, ty = other.apply(self.tx, self.ty)
        return _Rigid.of(self.angle + other.angle, tx, ty)

    def inverse(self) -> _Rigid:
        return _Rigid.of(-self.angle, -(self.c * self.tx + self.s * self.ty), -(-self.s * self.tx + self.c * self.ty))


class CourseTracker:
    """The body's place relative to the reference's course, per control step, on plain floats.

    At :meth:`reset` the reference's start (root position and pelvis heading at the start frame) is
    laid on the body's, so the course starts under the body and points where the reference points
    relative to it. :meth:`update` projects the centre of mass onto the course polyline (the nearest
    segment, searched from the last one forward or backward, crossing into the next or previous cycle)
    and returns the lateral offset (m, positive left of the course), its rate (m/s) and the course's
    heading there (rad, world)."""

    #: segments searched per step at most (a step moves the body a few millimetres: one or two suffice;
    #: a body moved further at once is caught up with over the next steps)
    MAX_SEARCH = 64

    def __init__(self, course: Course) -> None:
        self.xs = [p[0] for p in course.xy]
        self.ys = [p[1] for p in course.xy]
        self.hs = list(course.heading)
        self.n_seg = len(course.xy) - 1
        # per segment: direction, squared length and unit left normal (zero for a zero-length segment)
        self.dx = [self.xs[i + 1] - self.xs[i] for i in range(self.n_seg)]
        self.dy = [self.ys[i + 1] - self.ys[i] for i in range(self.n_seg)]
        self.ll = [x * x + y * y for x, y in zip(self.dx, self.dy)]
        norm = [math.sqrt(v) or 1.0 for v in self.ll]
        self.nx = [-y / n for y, n in zip(self.dy, norm)]
        self.ny = [x / n for x, n in zip(self.dx, norm)]
        self.cycle = _Rigid.of(*course.cycle)
        self.cycle_inv = self.cycle.inverse()
        self.moving = course.travel >= MIN_CYCLE_TRAVEL
        self.to_course = _Rigid.of(0.0, 0.0, 0.0)  #: world -> the current cycle's course coordinates
        self.origin = self.to_course  #: world -> the first cycle's course coordinates, as laid at reset
        self.seg = 0
        #: arc length (m) of the course from its first point to each point, and of one whole cycle
        self.arc = [0.0]
        for v in self.ll:
            self.arc.append(self.arc[-1] + math.sqrt(v))

    def reset(self, ref_pose: tuple[float, float, float], body_pose: tuple[float, float, float], seg: int) -> None:
        """``ref_pose``: the reference's root (x, y) (m) and pelvis heading (rad) at the start frame, in
        the course's own coordinates (its first cycle); ``body_pose``: the body's, world frame;
        ``seg``: the course segment of the start frame."""
        (rx, ry, rh), (bx, by, bh) = ref_pose, body_pose
        # course -> world: turn by bh - rh, then move the reference's root onto the body's
        tx, ty = _Rigid.of(bh - rh, 0.0, 0.0).apply(rx, ry)
        self.to_course = self.origin = _Rigid.of(bh - rh, bx - tx, by - ty).inverse()
        self.seg = min(max(seg, 0), self.n_seg - 1)

    #: cycles :meth:`locate` follows the course at most (a 20 s walk crosses about 20)
    MAX_CYCLES = 100_000

    def locate(self, cx: float, cy: float) -> tuple[float, float] | None:
        """Where a point (cx, cy) (world, m) lies along the course as laid at :meth:`reset`: (arc length
        m from the course's first point, counting whole cycles, negative before it; lateral offset m,
        positive left), by the nearest point of the course -- searched over whole cycles, from the first
        one on, independent of :meth:`update`. None for a course that does not move (a walk in place)."""
        if not self.moving:
            return None
        q = self.origin
        px, py = q.c * cx - q.s * cy + q.tx, q.s * cx + q.c * cy + q.ty
        length, loops, direction = self.arc[-1], 0, 0
        best = (0.0, 0.0)
        for _ in range(self.MAX_CYCLES):
            best_d, best_i, best_u = math.inf, 0, 0.0
            for i in range(self.n_seg):
                ex, ey = px - self.xs[i], py - self.ys[i]
                u = (ex * self.dx[i] + ey * self.dy[i]) / self.ll[i] if self.ll[i] > 0.0 else 0.0
                u = 0.0 if u < 0.0 else 1.0 if u > 1.0 else u
                fx, fy = ex - u * self.dx[i], ey - u * self.dy[i]
                d = fx * fx + fy * fy
                if d < best_d:
                    best_d, best_i, best_u = d, i, u
            i, u = best_i, best_u
            ex, ey = px - self.xs[i], py - self.ys[i]
            best = (loops * length + self.arc[i] + u * (self.arc[i + 1] - self.arc[i]),
                    ex * self.nx[i] + ey * self.ny[i])
            if i == self.n_seg - 1 and u >= 1.0 and direction >= 0:  # beyond this cycle's end: the next
                px, py = self.cycle_inv.apply(px, py)
                loops, direction = loops + 1, 1
            elif i == 0 and u <= 0.0 and direction <= 0:  # before its start: the previous one
                px, py = self.cycle.apply(px, py)
                loops, direction = loops - 1, -1
            else:
                break
        return best

    def update(self, cx: float, cy: float, vx: float, vy: float) -> tuple[float, float, float]:
        """(lateral offset m, lateral velocity m/s, course heading rad) of a centre of mass at (cx, cy)
        moving at (vx, vy), world frame."""
        q = self.to_course
        c, s = q.c, q.s
        px, py = c * cx - s * cy + q.tx, s * cx + c * cy + q.ty
        ux, uy = c * vx - s * vy, s * vx + c * vy
        xs, ys, dx, dy, ll, i, n = self.xs, self.ys, self.dx, self.dy, self.ll, self.seg, self.n_seg
        direction = 0
        for _ in range(self.MAX_SEARCH if self.moving else 0):
            u = ((px - xs[i]) * dx[i] + (py - ys[i]) * dy[i]) / ll[i] if ll[i] > 0.0 else 1.0
            if u > 1.0 and direction >= 0:
                direction, i = 1, i + 1
                if i == n:  # into the next cycle: its coordinates are this one's moved back by a cycle
                    i, q = 0, q.then(self.cycle_inv)
                    px, py = self.cycle_inv.apply(px, py)
                    ux, uy = self.cycle_inv.rotate(ux, uy)
            elif u < 0.0 and direction <= 0:
                direction, i = -1, i - 1
                if i < 0:
                    i, q = n - 1, q.then(self.cycle)
                    px, py = self.cycle.apply(px, py)
                    ux, uy = self.cycle.rotate(ux, uy)
            else:
                break
        self.seg, self.to_course = i, q
        if not self.moving or ll[i] <= 0.0:
            return 0.0, 0.0, self.hs[i] - q.angle
        ex, ey = px - xs[i], py - ys[i]
        u = (ex * dx[i] + ey * dy[i]) / ll[i]
        u = 0.0 if u < 0.0 else 1.0 if u > 1.0 else u
        nx, ny = self.nx[i], self.ny[i]
        return ex * nx + ey * ny, ux * nx + uy * ny, self.hs[i] + u * (self.hs[i + 1] - self.hs[i]) - q.angle


@dataclass
class Hinges:
    """The model's hinge joints: names, qpos and dof addresses, groups, sides."""

    names: list[str]
    qadr: npt.NDArray[np.int64]
    dadr: npt.NDArray[np.int64]
    jid: npt.NDArray[np.int64]
    groups: list[str]
    actuator: npt.NDArray[np.int64]  # actuator index driving each hinge

    @staticmethod
    def of(model: mujoco.MjModel, plan: BodyPlanSet) -> Hinges:
        group = {j.name: j.group for b in plan.bodies for j in b.joints}
        names, qadr, dadr, jid, groups, act = [], [], [], [], [], []
        act_of = {int(model.actuator_trnid[a, 0]): a for a in range(model.nu)}
        for j in range(model.njnt):
            if model.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                continue
            n = model.joint(j).name
            names.append(n)
            qadr.append(model.jnt_qposadr[j])
            dadr.append(model.jnt_dofadr[j])
            jid.append(j)
            groups.append(group.get(n, ""))
            act.append(act_of[j])
        return Hinges(names, np.array(qadr), np.array(dadr), np.array(jid), groups, np.array(act))

    def index(self, name: str) -> int:
        return self.names.index(name)


def foot_points(model: mujoco.MjModel, side: str) -> list[int]:
    """The bodies whose origins stand for a foot's lowest point: the foot (ankle) and its toe if any."""
    names = [f"{side}_foot", f"{side}_toe"]
    return [model.body(x).id for x in names if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, x) >= 0]


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

    def step_time(self) -> float:
        return 0.5


#: Seam cost: joint-velocity mismatch (rad/s) counts at this time scale (s) against pose mismatch (rad).
CYCLE_VELOCITY_TIME_S = 0.1
#: Loops whose cost is within this (rad) of the best are equally good; the longest of them is kept
#: (more of the capture, fewer seams per second).
CYCLE_COST_TOLERANCE = 0.05
#: A walking loop's steps (strike to the other foot's strike) are alike: a loop whose shortest step lasts
#: less than this fraction of its longest costs 1 - ratio / this (a start, a stop or a shuffle between
#: two strikes a few frames apart is no step of a walk).
CYCLE_STEP_BALANCE = 0.6
#: A walking loop travels steadily: a loop whose slowest step (the root's travel from strike to strike
#: over its time) is slower than this fraction of its fastest costs 1 - ratio / this (a loop over the
#: start's or the stop's ramp). A 30 fps walk's steps differ by up to 25 % (strike times to a frame).
CYCLE_STEADY_SPEED = 0.7
#: A loop whose stance feet rest farther than this (m) from the floor, on average over its stance
#: frames (the worse foot), costs the excess per :data:`CYCLE_STANCE_SCALE_M` (a crouch, a kneel or a
#: capture whose floor is not under the walk).
CYCLE_STANCE_FLOAT_M = 0.03
CYCLE_STANCE_SCALE_M = 0.1
#: A loop whose seam (pose and velocity mismatch, rad) is above this is said to be no clean gait cycle:
#: the shared and public walks that the default tracks loop within 0.55 (the 02_02 pair), the two that
#: have no steady stretch of walking do not (CMU 131's one and a half cycles between a leap and a stop
#: 0.885, a Xia walk 1.36; docs/controller.md, *Cycles*)
CYCLE_SEAM_WARN = 0.6
#: Seconds before the loop's end over which its last frames are blended into the frames one loop
#: earlier, so that the seam is continuous.
SEAM_BLEND_S = 0.2


@dataclass(frozen=True)
class Cycle:
    """A loop of a clip from one strike of ``foot`` ``a`` to a later one ``b`` (frames) with a strike of
    the other foot between (the right foot's, unless the clip has no such loop); ``cost``: its seam
    mismatch plus the penalties below (rad, see :func:`best_cycle`). ``seam``: the pose and velocity
    mismatch alone (rad); ``alternates``: its strikes alternate feet; ``step_balance``: its shortest
    step over its longest; ``steady``: its slowest step's root speed over its fastest;
    ``stance_float``: its stance feet's mean distance from the floor (m, the worse foot; 0 when
    unknown)."""

    a: int
    b: int
    cost: float
    seam: float = 0.0
    alternates: bool = True
    step_balance: float = 1.0
    steady: float = 1.0
    stance_float: float = 0.0
    foot: str = "right"


def _loop_shape(a: int, b: int, right: list[int], left: list[int], root_xy: FloatArray,
                frame_time: float) -> tuple[bool, float, float]:
    """(strikes alternate, shortest step / longest, slowest step's root speed / fastest) of the loop
    from strike ``a`` to strike ``b`` of the foot whose strikes are ``right`` (the other's ``left``)."""
    events = sorted([(t, "right") for t in right if a <= t <= b] + [(t, "left") for t in left if a < t < b])
    alternates = all(events[k][1] != events[k + 1][1] for k in range(len(events) - 1))
    times = np.array([t for t, _ in events])
    steps = np.diff(times)
    balance = float(steps.min() / steps.max()) if len(steps) and steps.max() > 0 else 0.0
    speeds = np.linalg.norm(np.diff(root_xy[times], axis=0), axis=1) / (np.maximum(steps, 1) * frame_time)
    steady = float(speeds.min() / speeds.max()) if len(speeds) and speeds.max() > 0 else 0.0
    return alternates, balance, steady


def best_cycle(q: FloatArray, qd: FloatArray, root_xy: FloatArray, right: list[int], left: list[int],
               frame_time: float, stance_low: FloatArray | None = None) -> Cycle | None:
    """The loop of a clip to play: over every pair of right strikes (a, b) with a left strike between,
    the cost is the seam's mismatch -- RMS of the hinge angles ``q`` (T, H; rad) between frames a and b
    plus RMS of the velocities ``qd`` (rad/s) times :data:`CYCLE_VELOCITY_TIME_S` -- plus how much slower
    than the clip's fastest loop it travels (its mean root speed, ``root_xy`` (T, 2) m, as a fraction:
    a start-walk-stop clip loops its walking part, not its start and stop), plus whether it is a walk:

    - its strikes alternate feet (R, L, R, ...): loops that do not are left out while any loop does;
    - its steps last alike (:data:`CYCLE_STEP_BALANCE`) and travel alike (:data:`CYCLE_STEADY_SPEED`);
    - its stance feet rest on the floor (:data:`CYCLE_STANCE_FLOAT_M`): ``stance_low`` (T, 2), the right
      and left feet's lowest points (m), NaN where the foot is not in stance (None: not scored).

    Of the loops within :data:`CYCLE_COST_TOLERANCE` of the best, the longest. None when no pair has a
    left strike between."""
    pairs = [(a, b) for i, a in enumerate(right) for b in right[i + 1:] if any(a < s < b for s in left)]
    if not pairs:
        return None
    shape = {p: _loop_shape(*p, right, left, root_xy, frame_time) for p in pairs}
    if any(shape[p][0] for p in pairs):
        pairs = [p for p in pairs if shape[p][0]]
    speed = {p: float(np.linalg.norm(root_xy[p[1]] - root_xy[p[0]])) / ((p[1] - p[0]) * frame_time) for p in pairs}
    fastest = max(speed.values()) or 1.0
    cycles = {}
    for a, b in pairs:
        alternates, balance, steady = shape[(a, b)]
        seam = float(np.sqrt(np.mean((q[a] - q[b]) ** 2)))
        seam += CYCLE_VELOCITY_TIME_S * float(np.sqrt(np.mean((qd[a] - qd[b]) ** 2)))
        floats = 0.0
        if stance_low is not None:
            with np.errstate(invalid="ignore"):
                heights = [float(np.nanmean(np.abs(col))) for col in stance_low[a:b + 1].T
                           if np.isfinite(col).any()]
            floats = max(heights, default=0.0)
        cost = (seam + (1.0 - speed[(a, b)] / fastest)
                + max(0.0, 1.0 - balance / CYCLE_STEP_BALANCE) + max(0.0, 1.0 - steady / CYCLE_STEADY_SPEED)
                + max(0.0, floats - CYCLE_STANCE_FLOAT_M) / CYCLE_STANCE_SCALE_M)
        cycles[(a, b)] = Cycle(a, b, cost, seam, alternates, balance, steady, floats)
    best = min(c.cost for c in cycles.values())
    return max((c for c in cycles.values() if c.cost <= best + CYCLE_COST_TOLERANCE),
               key=lambda c: (c.b - c.a, -c.cost))


def blend_seam(rows: FloatArray, a: int, b: int, frames: int) -> FloatArray:
    """``rows`` (T, K) with the loop [a, b)'s last ``frames`` rows eased (smoothstep) into the rows one
    loop earlier (the same phase), so that playing b - 1 then a is continuous. Rows outside are kept."""
    out = rows.copy()
    frames = min(frames, a, b - a - 1)
    if frames < 1:
        return out
    period = b - a
    for k in range(frames):
        t = b - frames + k
        s = (k + 1) / frames
        s = s * s * (3.0 - 2.0 * s)
        out[t] = (1.0 - s) * rows[t] + s * rows[t - period]
    return out


def clip_cycle(clip: ReferenceClip, model: mujoco.MjModel, plan: BodyPlanSet,
               hinges: Hinges | None = None) -> Cycle | None:
    """The cycle :class:`ClipSource` loops for this clip on this model (None: no loop): :func:`best_cycle`
    on its hinges, root and strikes, and its stance feet's heights above the floor (not scored for a
    body without box feet)."""
    h = hinges or Hinges.of(model, plan)
    rs, ls = clip.events["right"]["strike"], clip.events["left"]["strike"]
    args = (clip.qpos[:, h.qadr], clip.qvel[:, h.dadr], clip.qpos[:, :2])
    low = stance_heights(clip, model)
    c = best_cycle(*args, list(rs), list(ls), clip.frame_time, stance_low=low)
    if c is None:
        # a clip with one right strike between two left ones (a short capture of one cycle) loops from
        # left strike to left strike; its rollout starts in left stance (``SimbiconController.reset``)
        c = best_cycle(*args, list(ls), list(rs), clip.frame_time, stance_low=low)
        if c is not None:
            c = replace(c, foot="left")
    return c


def stance_heights(clip: ReferenceClip, model: mujoco.MjModel) -> FloatArray | None:
    """(T, 2) the right and left feet's lowest points (m; 0 = on the floor) where the clip has them in
    stance, NaN elsewhere; None for a body whose feet are not boxes."""
    try:
        low = sole_heights(model, clip.qpos)
    except ModelError:
        return None
    out = np.full((clip.num_frames, 2), np.nan)
    for k, s in enumerate(SIDES):
        stance = clip.contacts[:, clip.foot_names.index(s)].astype(bool)
        out[stance, k] = low[s][stance]
    return out


#: Window (s) over which the root's path is smoothed before its length is the clip's travel.
CLIP_SPEED_SMOOTH_S = 0.5


def clip_speed(clip: ReferenceClip) -> float:
    """The clip's own average horizontal speed (m/s): the length of the root's path, smoothed over
    :data:`CLIP_SPEED_SMOOTH_S` (the capture's jitter and the walk's sway are no travel), over the whole
    clip (start and stop included), over its duration."""
    if clip.duration <= 0:
        return 0.0
    root = smooth(clip.qpos[:, :2], clip.frame_time, CLIP_SPEED_SMOOTH_S)
    return float(np.linalg.norm(np.diff(root, axis=0), axis=1).sum()) / clip.duration


def step_time(clip: ReferenceClip) -> float | None:
    """The clip's step time (s): the median interval between consecutive strikes of either foot; None
    with fewer than two strikes."""
    strikes = sorted(s for f in clip.foot_names for s in clip.events[f]["strike"])
    if len(strikes) < 2:
        return None
    return float(np.median(np.diff(strikes))) * clip.frame_time


def describe_clip(clip: ReferenceClip, model: mujoco.MjModel, plan: BodyPlanSet) -> list[str]:
    """Lines saying what was found in a humanoid's reference clip: the feet and their strikes, the cycle
    looped and its speed, the whole clip's speed."""
    lines = [f"reference: {clip.num_frames} frames at {1 / clip.frame_time:.4g} fps, feet "
             + ", ".join(f"{f} ({len(clip.events[f]['strike'])} strikes at frames {clip.events[f]['strike']})"
                         for f in clip.foot_names)]
    c = clip_cycle(clip, model, plan)
    if c is not None:
        root = clip.qpos[:, :2]
        loop_v = float(np.linalg.norm(root[c.b] - root[c.a])) / ((c.b - c.a) * clip.frame_time)
        lines.append(f"cycle: frames {c.a}-{c.b}{' (left strike to left strike)' if c.foot == 'left' else ''} "
                     f"({(c.b - c.a) * clip.frame_time:.2f} s, cost {c.cost:.3f}: seam "
                     f"{c.seam:.3f}, steps {c.step_balance:.2f} alike, step speeds {c.steady:.2f} alike, stance "
                     f"feet {c.stance_float * 100:.1f} cm off the floor) at {loop_v:.2f} m/s; the whole clip "
                     f"{clip_speed(clip):.2f} m/s")
        if c.seam > CYCLE_SEAM_WARN:
            lines.append(f"cycle: no clean gait cycle in this clip: the best loop's ends differ by {c.seam:.2f} rad "
                         f"(pose and velocity; a steady walk's loop closes within {CYCLE_SEAM_WARN}), so every "
                         "loop jumps at its seam and the walk may not be tracked; a take with two or more "
                         "cycles of steady walking loops cleanly")
    return lines


class ClipSource(GaitSource):
    """A :class:`ReferenceClip`, looped over its best gait cycle (:func:`best_cycle`; the seam blended,
    :func:`blend_seam`)."""

    def __init__(self, clip: ReferenceClip, model: mujoco.MjModel, plan: BodyPlanSet, hinges: Hinges) -> None:
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
        if cycle is None:
            raise ModelError(f"the reference clip ({clip.source or 'clip'}) has {len(rs)} right and {len(ls)} "
                             f"left foot strikes (right at frames {rs}, left at {ls}; {clip.num_frames} frames at "
                             f"{1 / clip.frame_time:.4g} fps): a gait cycle to loop needs two strikes of one foot "
                             "with one of the other foot between. If the clip walks a whole cycle, give its "
                             "strikes by hand: --events FILE, a YAML like 'right: [12, 140]' and 'left: [76]' "
                             "(frames, or times like '1.2s'); a shorter clip cannot be looped")
        self.cycle = cycle
        self.a, self.b = float(cycle.a), float(cycle.b)
        self.period = self.b - self.a
        self.loop_start = self.a
        self.strikes = {"right": np.array([s for s in rs if self.a <= s < self.b], dtype=float),
                        "left": np.array([s for s in ls if self.a <= s < self.b], dtype=float)}
        self.hinge_qadr = hinges.qadr
        blend = int(round(SEAM_BLEND_S / clip.frame_time))
        self.q = blend_seam(hq, cycle.a, cycle.b, blend)
        self.qd = blend_seam(hqd, cycle.a, cycle.b, blend)
        self.nh = self.q.shape[1]
        self.q_qd = np.ascontiguousarray(np.hstack([self.q, self.qd]))  # one interpolation per step
        n = self.n = clip.num_frames
        self._last_f, self._last_k = float("nan"), 0
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
            data.qpos[:] = clip.qpos[t]
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
        root = clip.qpos[:, :2]
        self._speed = float(np.linalg.norm(root[int(self.b)] - root[int(self.a)]) / (self.period * self.frame_time))
        steps = np.sort(np.concatenate([self.strikes["right"], self.strikes["left"]]))
        self._step = float(np.mean(np.diff(np.append(steps, self.b)))) * self.frame_time
        self._heading = heading
        self._course = clip_course(com[:, :2], np.unwrap(heading), clip.qpos[:, :2], int(self.a), int(self.b))

    def course(self) -> Course:
        return self._course

    def course_start(self, f: float) -> tuple[tuple[float, float, float], int]:
        w = self.wrap(f)
        t = min(int(round(w)), self.n - 1)
        x, y = self.clip.qpos[t, :2].tolist()
        seg = min(max(int(w - self.a), 0), len(self._course.xy) - 2)
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
        return self.clip.qpos[self._nearest(f)].copy()

    def com_reference(self, f: float, stance: str) -> tuple[FloatArray, FloatArray]:
        return self._interp(self.d_ref[stance], f), self._interp(self.v_ref, f)

    def lateral_reference(self, f: float, stance: str) -> float:
        i, j, u = self._pair(f)
        lo, hi = self._d_lat[stance][i], self._d_lat[stance][j]
        return lo + u * (hi - lo)

    def _strikes_near(self, f: float, side: str) -> FloatArray:
        k = np.floor((f - self.a) / self.period)
        base = self.strikes[side]
        return np.concatenate([base + (k + d) * self.period for d in (-1, 0, 1, 2)])

    def next_strike(self, f: float, side: str) -> float | None:
        c = self._strikes_near(f, side)
        c = c[c >= f - 1e-9]
        return float(c.min()) if len(c) else None

    def nearest_strike(self, f: float, side: str) -> float | None:
        c = self._strikes_near(f, side)
        return float(c[np.argmin(np.abs(c - f))])

    def swing_leg(self, f: float, side: str) -> tuple[float, float, float] | None:
        x, z, h = self._interp(self._leg[side], f).tolist()
        return x, z, h

    def swing_phase(self, f: float, swing: str) -> float | None:
        nxt = self.next_strike(f, swing)
        c = self._strikes_near(f, "left" if swing == "right" else "right")
        c = c[c <= f + 1e-9]
        if nxt is None or not len(c):
            return None
        prv = float(c.max())
        return (f - prv) / max(nxt - prv, 1e-6)

    def start_frame(self) -> float:
        """Where a rollout starts: just after the loop's first strike (the right foot's, or the left's
        for a left-to-left loop), when that foot already carries weight (starting exactly on the strike
        frame leaves neither foot loaded)."""
        return self.a + max(1.0, round(START_AFTER_STRIKE * self._step / self.frame_time))

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
