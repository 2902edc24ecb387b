"""The gait cycle a clip is looped over, and what a clip's gait says about it (speed, step time).

:func:`best_cycle` scores every loop from a strike of one foot to a later strike of the same foot (with
a strike of the other foot between) on its seam's pose and velocity mismatch, its speed against the
clip's fastest loop and whether it is a walk; :func:`clip_cycle` picks the loop for a clip on a body.
Frames are clip frames; angles rad, lengths m, times s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.hinges import SIDES, Hinges
from bipedsim.errors import ModelError
from bipedsim.model.plan import BodyPlanSet
from bipedsim.reference.clip import ReferenceClip
from bipedsim.reference.feasible_measure import sole_heights
from bipedsim.reference.gait_events import cyclic_strikes, smooth
from bipedsim.reference.prepare import LOOP_OPEN_FACTOR, LOOP_SEAM_FRACTION, LOOP_STRIDE_S

FloatArray = npt.NDArray[np.float64]


#: The share of a clip's frames with both feet off the floor from which a clip without double support is
#: called a run or hop (:func:`running_note`): more than contact chatter, a frame in twenty.
FLIGHT_SHARE = 0.05
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
#: A loop whose root heading turns more than this (deg) a pass is named in the clip's printout
#: (:func:`loop_turn_note`): looped as captured, its course is a circle; after the whole clip it is
#: turned to the clip's own rate where that differs by as much (playlist.LOOP_TURN_MATCH_DEG). The 26
#: clips' best loops turn -8 to +6 deg but one (a 50 deg veer whose only loop lies inside it: 43 deg, docs/results.md).
CYCLE_TURN_NOTE_DEG = 15.0
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
    unknown). ``whole``: the clip is itself one loop of the cycle (:func:`loop_cycle`): ``a`` is its
    first frame and ``b`` its last, ``foot`` the foot in stance on frame ``a``, whose strike came last
    before the loop wrapped."""

    a: int
    b: int
    cost: float
    seam: float = 0.0
    alternates: bool = True
    step_balance: float = 1.0
    steady: float = 1.0
    stance_float: float = 0.0
    foot: str = "right"
    whole: bool = False


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
        floats = _stance_float(stance_low, a, b)
        cost = (seam + (1.0 - speed[(a, b)] / fastest)
                + max(0.0, 1.0 - balance / CYCLE_STEP_BALANCE) + max(0.0, 1.0 - steady / CYCLE_STEADY_SPEED)
                + max(0.0, floats - CYCLE_STANCE_FLOAT_M) / CYCLE_STANCE_SCALE_M)
        cycles[(a, b)] = Cycle(a, b, cost, seam, alternates, balance, steady, floats)
    best = min(c.cost for c in cycles.values())
    return max((c for c in cycles.values() if c.cost <= best + CYCLE_COST_TOLERANCE),
               key=lambda c: (c.b - c.a, -c.cost))


def _stance_float(stance_low: FloatArray | None, a: int, b: int) -> float:
    """The stance feet's mean distance (m) from the floor over frames a..b, the worse foot (0: not scored)."""
    if stance_low is None:
        return 0.0
    with np.errstate(invalid="ignore"):
        heights = [float(np.nanmean(np.abs(col))) for col in stance_low[a:b + 1].T if np.isfinite(col).any()]
    return max(heights, default=0.0)


def _rms(x: FloatArray) -> FloatArray:
    return np.sqrt(np.mean(np.asarray(x) ** 2, axis=-1))


def clip_period(q: FloatArray, frame_time: float) -> int | None:
    """The period (frames) of a clip that is itself one loop of a cycle, None where it is none: hinge
    angles ``q`` (T, H; rad), frames ``frame_time`` s apart. As
    :func:`~bipedsim.reference.prepare.repeat_loop` measures a motion's joints: the pose change (RMS over
    the hinges) from the last frame to the first lies within
    :data:`~bipedsim.reference.prepare.LOOP_SEAM_FRACTION` of the clip's change over
    :data:`~bipedsim.reference.prepare.LOOP_STRIDE_S` (its median, or at the clip's ends where that is
    larger), and the clip moves at both ends. The period is T - 1 where the last frame repeats the
    first, T where it leads into it (:data:`~bipedsim.reference.prepare.LOOP_OPEN_FACTOR`)."""
    n = len(q)
    k = max(1, int(round(LOOP_STRIDE_S / frame_time)))
    if n < 4 * k:
        return None
    stride = _rms(q[k:] - q[:-k])
    med = float(np.median(stride))
    ends = float(min(stride[0], stride[-1]))
    seam = float(_rms(q[-1] - q[0]))
    if med <= 0.0 or seam > LOOP_SEAM_FRACTION * max(med, ends) or ends < 0.5 * med:
        return None
    moved_on = q[-1] + 0.5 * ((q[-1] - q[-2]) + (q[1] - q[0]))  # the frame after the last
    return n if LOOP_OPEN_FACTOR * float(_rms(moved_on - q[0])) < seam else n - 1


def loop_cycle(q: FloatArray, qd: FloatArray, contacts: npt.NDArray[np.bool_], frame_time: float,
               stance_low: FloatArray | None = None) -> Cycle | None:
    """The cycle of a clip that is itself one loop of a walk (:func:`clip_period`: a game animation's
    walk cycle, in place or travelling), None where the clip is no loop or no walk: its frames from the
    first to the last, its strikes read on the loop wrapped (:func:`~bipedsim.reference.gait_events.cyclic_strikes`:
    frame 0 follows the loop's last frame), each foot striking at least once. ``q``/``qd`` (T, H) hinge
    angles (rad) and rates (rad/s); ``contacts`` (T, 2) the right and left feet down; ``stance_low`` as
    :func:`best_cycle` takes it. Its cost is :func:`best_cycle`'s for the loop (seam, steps alike, stance
    feet on the floor; the only loop, at the clip's own speed, its steps' travel not scored)."""
    period = clip_period(q, frame_time)
    if period is None:
        return None
    strikes = dict(zip(SIDES, cyclic_strikes(np.asarray(contacts, dtype=bool)[:period])))
    if not all(strikes.values()):
        return None
    events = sorted((t, s) for s in SIDES for t in strikes[s])
    alternates = all(events[k][1] != events[(k + 1) % len(events)][1] for k in range(len(events)))
    times = np.array([t for t, _ in events] + [events[0][0] + period])
    steps = np.diff(times)
    balance = float(steps.min() / steps.max()) if steps.max() > 0 else 0.0
    foot = events[0][1] if events[0][0] == 0 else events[-1][1]  # the stance foot on frame 0
    a, b = 0, len(q) - 1
    seam = float(np.sqrt(np.mean((q[a] - q[b]) ** 2)))
    seam += CYCLE_VELOCITY_TIME_S * float(np.sqrt(np.mean((qd[a] - qd[b]) ** 2)))
    floats = _stance_float(stance_low, a, b)
    cost = (seam + max(0.0, 1.0 - balance / CYCLE_STEP_BALANCE)
            + max(0.0, floats - CYCLE_STANCE_FLOAT_M) / CYCLE_STANCE_SCALE_M)
    return Cycle(a, b, cost, seam, alternates, balance, 1.0, floats, foot, whole=True)


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
    body without box feet); for a clip with no such loop that is itself one loop of a walk (a game
    animation's walk cycle, one strike per foot), the whole clip (:func:`loop_cycle`)."""
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
    if c is None:
        feet = np.column_stack([clip.contacts[:, clip.foot_names.index(s)] for s in SIDES])
        c = loop_cycle(args[0], args[1], feet, clip.frame_time, stance_low=low)
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


def running_note(contacts: npt.NDArray[np.bool_]) -> str | None:
    """A line saying the clip is no walk, or None: its feet (``contacts``, (T, 2) bool per frame) are never
    both on the floor, and both are off it in at least :data:`FLIGHT_SHARE` of its frames. A walk has
    double support in every step (the definition of walking); the humanoid controller's four-state gait
    has no flight phase to track a run, hop or leap with."""
    c = np.asarray(contacts, dtype=bool)
    if c.ndim != 2 or c.shape[0] == 0 or c.shape[1] != 2 or c.all(axis=1).any():
        return None
    flight = float((~c.any(axis=1)).mean())
    if flight < FLIGHT_SHARE:
        return None
    return (f"the clip's feet are never both on the floor, and both are off it in {flight * 100:.0f} % of its "
            "frames: it runs or hops, and the controller walks (its gait has no flight phase), so the body "
            "may fall within its first steps")


def root_heading(qpos: FloatArray) -> FloatArray:
    """(T,) the root body's heading (rad): its x axis's yaw, from the free joint's quaternion."""
    w, x, y, z = (qpos[:, 3 + k] for k in range(4))
    return np.arctan2(2.0 * (x * y + w * z), 1.0 - 2.0 * (y * y + z * z))


def loop_turn_extra(qpos: FloatArray, a: int, b: int) -> float:
    """The turn (rad) a pass of the loop over frames [a, b] of the clip ``qpos`` is given after the whole
    clip: where the loop turns more than :data:`CYCLE_TURN_NOTE_DEG` a pass, and more than that otherwise
    than the clip's own last loop-length, the difference, so that it turns at the clip's rate; else 0."""
    heading = np.unwrap(root_heading(qpos))
    turn = float(heading[b] - heading[a])
    n = len(qpos) - 1
    extra = float(heading[n] - heading[max(0, n - (b - a))]) - turn
    if abs(math.degrees(turn)) < CYCLE_TURN_NOTE_DEG or abs(math.degrees(extra)) < CYCLE_TURN_NOTE_DEG:
        return 0.0
    return extra


def loop_turn_note(qpos: FloatArray, a: int, b: int, frame_time: float) -> str | None:
    """A clause for a loop over frames [a, b] of the clip ``qpos`` that turns more than
    :data:`CYCLE_TURN_NOTE_DEG` a pass: how much, the circle it walks looped as captured (its radius from
    the root's travel over the loop) and how much the clip's own last loop-length turns, which after the
    whole clip it follows where the two differ by as much (``playlist.whole_playlist``); None for a loop
    that turns less."""
    heading = np.unwrap(root_heading(qpos))
    turn = float(heading[b] - heading[a])
    if abs(math.degrees(turn)) < CYCLE_TURN_NOTE_DEG:
        return None
    travel = float(np.linalg.norm(qpos[b, :2] - qpos[a, :2]))
    n = len(qpos) - 1
    end = math.degrees(float(heading[n] - heading[max(0, n - (b - a))]))
    circle = (f"a circle of about {travel / (2.0 * math.sin(abs(turn) / 2.0)):.1f} m radius" if travel >= 0.05
              else "turning on the spot")
    own = f"the clip's own last {(b - a) * frame_time:.2f} s turn {end:+.0f} deg"
    if loop_turn_extra(qpos, a, b):  # playlist.whole_playlist turns it to the clip's
        return (f"the loop turns {math.degrees(turn):+.0f} deg each pass ({circle} looped as captured, as "
                f"source: cycle walks it); after the whole clip it is played turning as {own}")
    return (f"the loop turns {math.degrees(turn):+.0f} deg each pass, so looped (after the clip, or throughout "
            f"with source: cycle) the reference walks {circle} ({own})")


def describe_clip(clip: ReferenceClip, model: mujoco.MjModel, plan: BodyPlanSet) -> list[str]:
    """Lines saying what was found in a humanoid's reference clip: the feet and their strikes, the cycle
    looped and its speed, the whole clip's speed."""
    lines = [f"reference: {clip.num_frames} frames at {1 / clip.frame_time:.4g} fps, feet "
             + ", ".join(f"{f} ({len(clip.events[f]['strike'])} strikes at frames {clip.events[f]['strike']})"
                         for f in clip.foot_names)]
    c = clip_cycle(clip, model, plan)
    if c is None:
        lines.append("cycle: no gait cycle in this clip (it needs two strikes of one foot with one of the other "
                     "between): after the clip the body holds its last frame; --events gives strikes by hand")
    if c is not None:
        root = clip.qpos[:, :2]
        loop_v = float(np.linalg.norm(root[c.b] - root[c.a])) / ((c.b - c.a) * clip.frame_time)
        how = (f" (the whole clip, one loop of a walk; {c.foot} foot in stance at its start)" if c.whole
               else " (left strike to left strike)" if c.foot == "left" else "")
        lines.append(f"cycle: frames {c.a}-{c.b}{how} "
                     f"({(c.b - c.a) * clip.frame_time:.2f} s, cost {c.cost:.3f}: seam "
                     f"{c.seam:.3f}, steps {c.step_balance:.2f} alike, step speeds {c.steady:.2f} alike, stance "
                     f"feet {c.stance_float * 100:.1f} cm off the floor) at {loop_v:.2f} m/s; the whole clip "
                     f"{clip_speed(clip):.2f} m/s")
        turning = loop_turn_note(clip.qpos, c.a, c.b, clip.frame_time)
        if turning:
            lines.append(f"cycle: {turning}")
        if c.seam > CYCLE_SEAM_WARN:
            lines.append(f"cycle: no clean gait cycle in this clip: the best loop's ends differ by {c.seam:.2f} rad "
                         f"(pose and velocity; a steady walk's loop closes within {CYCLE_SEAM_WARN}), so every "
                         "loop jumps at its seam and the walk may not be tracked; a take with two or more "
                         "cycles of steady walking loops cleanly")
    note = running_note(clip.contacts)
    return lines + ([f"gait: {note}"] if note else [])
