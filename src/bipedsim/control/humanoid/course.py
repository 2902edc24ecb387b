"""The reference's course: its sway-free path, and the body's place along it.

:func:`clip_course` makes the :class:`Course` of a clip's loop (the centre of mass averaged over one
loop, so the walk's sway cancels and any veer stays); :func:`whole_course` puts the clip played once
before it (its turns, starts and stops); :class:`CourseTracker` lays it on the body at the
start and, each control step, places the centre of mass on it: the lateral offset (m, positive left),
its rate (m/s) and the course's heading there (rad). Positions m, world frame, Z up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError

FloatArray = npt.NDArray[np.float64]


#: A course whose cycle moves the reference less than this (m) is a walk in place: it has no line to
#: hold, and the course law only follows its heading.
MIN_CYCLE_TRAVEL = 0.05


@dataclass(frozen=True)
class Course:
    """The reference's sway-free path, reference world frame (m, rad): a part played once, then a loop.

    The loop ("cycle" here) runs from a foot strike to a later strike of the same foot: one or more gait
    cycles. ``xy`` are course points, one per reference frame from ``first_frame`` to the loop's last
    frame (inclusive): the reference's centre of mass averaged over one loop centred on that frame,
    which removes the step-to-step sway and keeps any veer (an arc of radius R is kept R theta^2 / 24
    inside, theta the loop's turn). ``heading`` is the pelvis heading averaged the same way (unwrapped).
    Points ``loop_from`` on are the loop; those before it are played once (the clip before its loop).
    ``cycle`` = (angle rad, tx m, ty m) is the rigid planar motion that carries the loop's start onto
    its end, p -> R(angle) p + t: the k-th repetition of the loop is the loop moved k times."""

    xy: tuple[tuple[float, float], ...]
    heading: tuple[float, ...]
    cycle: tuple[float, float, float]
    loop_from: int = 0  #: the index of the loop's first point
    first_frame: int = 0  #: the reference frame of the first point

    @property
    def travel(self) -> float:
        """How far (m) one cycle carries the loop's first point."""
        x, y = self.xy[self.loop_from]
        cyc = _Rigid.of(*self.cycle)
        x1, y1 = cyc.apply(x, y)
        return float(np.hypot(x1 - x, y1 - y))

    @property
    def once_length(self) -> float:
        """The length (m) of the part played once."""
        pts = np.asarray(self.xy[:self.loop_from + 1])
        return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()) if len(pts) > 1 else 0.0


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
                  cycle=(turn, float(shift[0]), float(shift[1])), first_frame=a)


def whole_course(com_xy: FloatArray, heading: FloatArray, root_xy: FloatArray, a: int, b: int) -> Course:
    """The :class:`Course` of a reference played from frame 0 to ``a`` once, then looped over [a, b]
    (arrays as :func:`clip_course`'s, covering frames 0 to ``b``). The loop's points are
    :func:`clip_course`'s; a frame before ``a`` gets the centre of mass and heading averaged over a
    window of one loop centred on it, so the path keeps the clip's turns, starts and stops and loses its
    sway (the first half loop, which has no whole window, continues the averaged path's first stretch
    backwards)."""
    loop = clip_course(com_xy, heading, root_xy, a, b)
    half = (b - a) // 2
    pts, hs = [], []
    for t in range(min(half, a), a):
        pts.append(com_xy[t - half:t + half + 1].mean(axis=0))
        hs.append(float(heading[t - half:t + half + 1].mean()))
    if a > half:  # the first half loop, without a whole window: the averaged path's first stretch (up to
        # half a loop) carried back at its mean step
        k = min(half, len(pts) - 1)
        step_xy = (pts[k] - pts[0]) / k if k > 0 else np.zeros(2)
        step_h = (hs[k] - hs[0]) / k if k > 0 else 0.0
        pts = [pts[0] - (half - t) * step_xy for t in range(half)] + pts
        hs = [hs[0] - (half - t) * step_h for t in range(half)] + hs
    else:  # a loop that starts within half a loop of the clip's start: its first point there
        pts = [np.asarray(loop.xy[0])] * a
        hs = [loop.heading[0]] * a
    xy = tuple((float(x), float(y)) for x, y in pts) + loop.xy
    return Course(xy=xy, heading=tuple(hs) + loop.heading, cycle=loop.cycle, loop_from=a, first_frame=0)


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
        self.loop_from = course.loop_from  #: the loop's first segment (those before it are played once)
        self.loops = 0  #: repetitions of the loop passed since the course's start (the current segment's)
        self.moving = course.travel >= MIN_CYCLE_TRAVEL or course.once_length >= MIN_CYCLE_TRAVEL
        self.to_course = _Rigid.of(0.0, 0.0, 0.0)  #: world -> the current cycle's course coordinates
        self.origin = self.to_course  #: world -> the first cycle's course coordinates, as laid at reset
        self.seg = 0
        #: arc length (m) of the course from its first point to each point, and of one whole cycle
        self.arc = [0.0]
        for v in self.ll:
            self.arc.append(self.arc[-1] + math.sqrt(v))
        self.loop_length = self.arc[-1] - self.arc[self.loop_from]  #: arc length (m) of one loop

    def reset(self, ref_pose: tuple[float, float, float], body_pose: tuple[float, float, float], seg: int) -> None:
        """``ref_pose``: the reference's root (x, y) (m) and pelvis heading (rad) at the start frame, in
        the course's own coordinates (its first cycle); ``body_pose``: the body's, world frame;
        ``seg``: the course segment of the start frame."""
        (rx, ry, rh), (bx, by, bh) = ref_pose, body_pose
        # course -> world: turn by bh - rh, then move the reference's root onto the body's
        tx, ty = _Rigid.of(bh - rh, 0.0, 0.0).apply(rx, ry)
        self.to_course = self.origin = _Rigid.of(bh - rh, bx - tx, by - ty).inverse()
        self.seg = min(max(seg, 0), self.n_seg - 1)
        self.loops = 0

    #: cycles :meth:`locate` follows the course at most (a 20 s walk crosses about 20)
    MAX_CYCLES = 100_000

    def locate(self, cx: float, cy: float) -> tuple[float, float] | None:
        """Where a point (cx, cy) (world, m) lies along the course as laid at :meth:`reset`: (arc length
        m from the course's first point, counting whole loops, negative before it for a course that is
        all loop; lateral offset m, positive left), by the nearest point of the course -- searched loop
        by loop from the first, independent of :meth:`update`. None for a course that does not move
        (a walk in place)."""
        if not self.moving:
            return None
        q = self.origin
        px, py = q.c * cx - q.s * cy + q.tx, q.s * cx + q.c * cy + q.ty
        p, loops, direction = self.loop_from, 0, 0
        best = (0.0, 0.0)
        for _ in range(self.MAX_CYCLES):
            lo = p if loops > 0 else 0  # a repeated loop has no part played once
            best_d, best_i, best_u = math.inf, lo, 0.0
            for i in range(lo, self.n_seg):
                ex, ey = px - self.xs[i], py - self.ys[i]
                u = (ex * self.dx[i] + ey * self.dy[i]) / self.ll[i] if self.ll[i] > 0.0 else 0.0
                u = 0.0 if u < 0.0 else 1.0 if u > 1.0 else u
                fx, fy = ex - u * self.dx[i], ey - u * self.dy[i]
                d = fx * fx + fy * fy
                if d < best_d:
                    best_d, best_i, best_u = d, i, u
            i, u = best_i, best_u
            ex, ey = px - self.xs[i], py - self.ys[i]
            best = (self._arc_at(loops, i) + u * (self.arc[i + 1] - self.arc[i]), ex * self.nx[i] + ey * self.ny[i])
            if i == self.n_seg - 1 and u >= 1.0 and direction >= 0:  # beyond this loop's end: the next
                px, py = self.cycle_inv.apply(px, py)
                loops, direction = loops + 1, 1
            elif i == lo and u <= 0.0 and direction <= 0 and (p == 0 or loops > 0):  # the previous loop
                px, py = self.cycle.apply(px, py)
                loops, direction = loops - 1, -1
            else:
                break
        return best

    def _arc_at(self, loops: int, i: int) -> float:
        """The arc length (m) from the course's first point to point ``i`` of repetition ``loops``."""
        if self.loop_from == 0:
            return loops * self.arc[-1] + self.arc[i]
        if loops == 0:
            return self.arc[i]
        return self.arc[-1] + (loops - 1) * self.loop_length + self.arc[i] - self.arc[self.loop_from]

    def update(self, cx: float, cy: float, vx: float, vy: float) -> tuple[float, float, float]:
        """(lateral offset m, lateral velocity m/s, course heading rad) of a centre of mass at (cx, cy)
        moving at (vx, vy), world frame."""
        q = self.to_course
        c, s = q.c, q.s
        px, py = c * cx - s * cy + q.tx, s * cx + c * cy + q.ty
        ux, uy = c * vx - s * vy, s * vx + c * vy
        xs, ys, dx, dy, ll, i, n = self.xs, self.ys, self.dx, self.dy, self.ll, self.seg, self.n_seg
        p, loops = self.loop_from, self.loops
        direction = 0
        for _ in range(self.MAX_SEARCH if self.moving else 0):
            u = ((px - xs[i]) * dx[i] + (py - ys[i]) * dy[i]) / ll[i] if ll[i] > 0.0 else 1.0
            if u > 1.0 and direction >= 0:
                direction, i = 1, i + 1
                if i == n:  # into the next loop: its coordinates are this one's moved back by a cycle
                    i, q, loops = p, q.then(self.cycle_inv), loops + 1
                    px, py = self.cycle_inv.apply(px, py)
                    ux, uy = self.cycle_inv.rotate(ux, uy)
            elif u < 0.0 and direction <= 0:
                if i - 1 < (p if loops > 0 else 0):
                    if p > 0 and loops == 0:  # the course's start: nothing before it
                        break
                    i, q, loops = n - 1, q.then(self.cycle), loops - 1  # into the previous loop
                    px, py = self.cycle.apply(px, py)
                    ux, uy = self.cycle.rotate(ux, uy)
                else:
                    i = i - 1
                direction = -1
            else:
                break
        self.seg, self.to_course, self.loops = i, q, loops
        if not self.moving or ll[i] <= 0.0:
            return 0.0, 0.0, self.hs[i] - q.angle
        ex, ey = px - xs[i], py - ys[i]
        u = (ex * dx[i] + ey * dy[i]) / ll[i]
        u = 0.0 if u < 0.0 else 1.0 if u > 1.0 else u
        nx, ny = self.nx[i], self.ny[i]
        return ex * nx + ey * ny, ux * nx + uy * ny, self.hs[i] + u * (self.hs[i + 1] - self.hs[i]) - q.angle

    def crab(self) -> float:
        """The reference's own crab on the current segment (rad, positive left): the course's direction
        there less its averaged pelvis heading (0 on a segment of zero length or a walk in place)."""
        i = self.seg
        if not self.moving or self.ll[i] <= 0.0:
            return 0.0
        return math.remainder(math.atan2(self.dy[i], self.dx[i]) - 0.5 * (self.hs[i] + self.hs[i + 1]), 2.0 * math.pi)
