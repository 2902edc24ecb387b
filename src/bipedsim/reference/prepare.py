"""A motion read from a BVH file made ready for the body built from it -- the one way through for
``run``, sweeps, suites, tunes, ``convert`` and ``info``: an export's held tail dropped, a short loop
repeated, a standing rest pose, a length for a foot or head that has none, and for a walk in place its
root travel rebuilt from the stance feet (:func:`load_source`).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.model.creature_kind import AUTO, detect_body_kind, read_source
from bipedsim.model.humanoid import with_tips
from bipedsim.motion.conventions import foot_joints
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.rest import standing_rest
from bipedsim.reference.gait_events import LEVEL_PERCENTILE, smooth

if TYPE_CHECKING:
    from bipedsim.motion.bvh import BVHInfo

FloatArray = npt.NDArray[np.float64]


# ---------------------------------------------------------------------- walks in place
#: A clip walks in place when its root travels slower than this fraction of its feet's swing speed
#: (95th-percentile horizontal speed of the foot joints relative to the root).
IN_PLACE_SPEED_FRACTION = 0.05
#: The root's travel is the length of its horizontal path smoothed over this window (s, about a
#: stride: the sway of a walk in place is no travel), over the clip's duration -- not its net
#: displacement, which a walk that comes back (a figure eight, there and back) also has near zero.
IN_PLACE_SMOOTH_S = 1.0


def in_place(motion: Motion, feet: list[int] | None = None) -> bool:
    """Whether ``motion`` (project frame: m, Z up) steps without travelling: its root (the travelling
    joint, :meth:`Motion.travel`; its path smoothed over :data:`IN_PLACE_SMOOTH_S`, whatever its net
    displacement) moves less than :data:`IN_PLACE_SPEED_FRACTION` of the speed its
    feet swing at (a treadmill walk, a game animation exported in place). ``feet``: the foot joints'
    indices (default: a human skeleton's, by name)."""
    feet = foot_joints(motion.skeleton.names) if feet is None else feet
    if len(feet) < 2 or motion.num_frames < 3:
        return False
    dt = motion.frame_time
    root = motion.travel()
    pos = motion.fk()[0][:, feet]
    rel = pos[..., :2] - root[:, None, :2]
    swing = float(np.percentile(np.linalg.norm(np.gradient(rel, dt, axis=0), axis=-1), 95))
    path = smooth(root[:, :2], dt, IN_PLACE_SMOOTH_S)
    travel = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) / motion.duration
    return swing > 0 and travel < IN_PLACE_SPEED_FRACTION * swing


#: Root rebuilding (:func:`reconstruct_root`): a point's height above its resting level is weighed in
#: units of this fraction of its lift (95th percentile above the level)...
PIVOT_HEIGHT_FRACTION = 0.2
#: ...against a jump of the rebuilt root velocity, in units of this fraction of the feet's swing speed
#: (95th-percentile relative speed): a change of pivot is cheap only where both points move alike.
PIVOT_JUMP_FRACTION = 0.1
#: ...and a point behind the root costs this per :data:`PIVOT_BEHIND_SCALE` of the root's height above the
#: feet it lies behind (per 10 ms): through double support the leading foot takes the weight, while a
#: capture's trailing toe often slides as it unloads.
PIVOT_BEHIND_WEIGHT = 1.0
PIVOT_BEHIND_SCALE = 0.1


def _angular_velocity(rot: FloatArray, dt: float) -> FloatArray:
    """(T, 3) world angular velocity of a body from its rotation matrices (T, 3, 3), central differences."""
    w = np.zeros((len(rot), 3))
    if len(rot) > 1:
        r = Rotation.from_matrix(rot)
        d = (r[1:] * r[:-1].inv()).as_rotvec() / dt
        w[0], w[-1] = d[0], d[-1]
        w[1:-1] = 0.5 * (d[1:] + d[:-1])
    return w


def reconstruct_root(motion: Motion, feet: list[int] | None = None) -> Motion:
    """The motion with its horizontal root travel rebuilt from its feet, for a walk in place.

    A stance foot does not slide: it rolls about a contact on the floor. For a foot point ``p`` of a body
    turning at ``w`` (its joint's world angular velocity) about a contact at floor height, the world
    velocity's horizontal part is ``w x (0, 0, h)`` (``h`` the point's height above the floor; the spin about
    the vertical is neglected), so in place (velocities relative to the root) the root moves at
    ``-(v_rel(p) - w x (0, 0, h))`` -- the heel rocker and toe-off need no heel point. Candidates: every
    foot joint (``feet``: a human skeleton's, by name, when omitted) and every End Site on one. Which point
    bears the weight on each frame is the path (Viterbi) minimising its height above its own resting
    level (:data:`PIVOT_HEIGHT_FRACTION` of its lift) plus the jumps of the rebuilt root velocity between
    frames (:data:`PIVOT_JUMP_FRACTION` of the swing speed) plus how far the point lies behind the root
    (:data:`PIVOT_BEHIND_WEIGHT`: the leading foot takes the weight through double support): speed cannot
    tell stance from swing here (in place, a stance foot moves back as fast as a swing foot moves
    forward), height, continuity and the weight's way forward can.
    The floor is the clip's 5th-percentile lowest foot point. ``motion`` in the project frame (m, Z up);
    the vertical stays as it is. Where a capture's feet slide the rebuilt speed dips at the strikes
    (``tests/model/test_layouts.py`` compares the rebuilt travel with a walk's own)."""
    sk = motion.skeleton
    feet = foot_joints(sk.names) if feet is None else feet
    dt = motion.frame_time
    jpos, jrot = motion.fk()
    ends = motion.end_site_positions((jpos, jrot))
    pts = [jpos[:, f] for f in feet]
    spin = [_angular_velocity(jrot[:, f], dt) for f in feet]
    for e, p in enumerate(sk.end_site_parents):
        if p in feet:
            pts.append(ends[:, e])
            spin.append(_angular_velocity(jrot[:, p], dt))
    pos = smooth(np.stack(pts, axis=1), dt)  # (T, P, 3)
    w = smooth(np.stack(spin, axis=1), dt)
    rel = np.gradient(pos[..., :2], dt, axis=0)  # relative to the root: it stands still
    z = pos[..., 2]
    h = z - np.percentile(z.min(axis=1), 5)  # above the floor
    roll = np.stack([w[..., 1] * h, -w[..., 0] * h], axis=-1)  # w x (0, 0, h), horizontal
    cand = -(rel - roll)  # (T, P, 2) the root velocity if point p bears the weight
    rest = np.percentile(h, LEVEL_PERCENTILE, axis=0)
    lift = np.maximum(np.percentile(h, 95, axis=0) - rest, 1e-3)
    cost_h = (dt / 0.01) * (np.maximum(h - rest, 0.0) / (PIVOT_HEIGHT_FRACTION * lift)) ** 2  # per 10 ms
    # the weight passes to the leading foot: a point behind the root (along the way the candidates say
    # the body travels) costs in proportion to how far behind, in PIVOT_BEHIND_SCALE of the root's height
    root = motion.travel()
    way = np.median(cand, axis=1)
    way /= np.maximum(np.linalg.norm(way, axis=-1, keepdims=True), 1e-9)
    behind = -((pos[..., :2] - root[:, None, :2]) * way[:, None, :]).sum(axis=-1)
    scale = PIVOT_BEHIND_SCALE * max(float(np.median(root[:, 2] - z.min(axis=1))), 1e-3)
    cost_h += (dt / 0.01) * PIVOT_BEHIND_WEIGHT * np.maximum(behind, 0.0) / scale
    v_scale = PIVOT_JUMP_FRACTION * max(float(np.percentile(np.linalg.norm(rel, axis=-1), 95)), 1e-6)
    n, p_ = cost_h.shape
    back = np.zeros((n, p_), dtype=int)
    total = cost_h[0].copy()
    for t in range(1, n):
        jump = np.linalg.norm(cand[t][:, None, :] - cand[t - 1][None, :, :], axis=-1) / v_scale  # (to, from)
        step = total[None, :] + jump ** 2
        back[t] = np.argmin(step, axis=1)
        total = step[np.arange(p_), back[t]] + cost_h[t]
    k = np.empty(n, dtype=int)
    k[-1] = int(np.argmin(total))
    for t in range(n - 1, 0, -1):
        k[t - 1] = back[t, k[t]]
    v_root = cand[np.arange(n), k]
    path = np.concatenate([np.zeros((1, 2)), np.cumsum(0.5 * (v_root[1:] + v_root[:-1]) * dt, axis=0)])
    out = motion.root_translation.copy()
    out[:, :2] += path
    return motion.copy(root_translation=out)


def creature_motion(motion: Motion, notes: list[str] | None = None) -> Motion:
    """A creature's motion (project frame) with, for a walk in place (:func:`in_place`, its feet measured
    from the skeleton: :func:`~bipedsim.model.creature_kind.detect_body_kind`), its root travel rebuilt
    from the stance feet (:func:`reconstruct_root`): a bird walking on a treadmill slides its stance foot
    back as fast as it would walk. What was done is appended to ``notes``."""
    notes = notes if notes is not None else []
    names = list(motion.skeleton.names)
    feet = sorted({names.index(f.split("/")[0]) for _, fs in detect_body_kind(motion).legs for f in fs})
    if not in_place(motion, feet):
        return motion
    out = reconstruct_root(motion, feet)
    root = out.travel()[:, :2]
    notes.append(f"walks in place: root travel rebuilt from the stance feet "
                 f"({np.linalg.norm(root[-1] - root[0]):.2f} m in {out.duration:.2f} s)")
    return out


#: A clip is one loop of a cycle (a game animation's walk cycle) when its last pose is within this multiple
#: of its pose change over :data:`LOOP_STRIDE_S` of its first pose (relative to the root: the pose, not
#: the travel) -- the change's median over the clip, or the change at the clip's ends where that is larger
#: (a cycle cut mid-swing moves fastest at its seam) -- and it moves at both ends (a clip from a stand to
#: a stand has like ends too)...
LOOP_SEAM_FRACTION = 1.5
#: ...the stride (s) over which pose changes are compared (a rate of its own: any frame rate alike)...
LOOP_STRIDE_S = 1.0 / 30.0
#: ...and such a clip shorter than this (s) is repeated to at least this long, so that its strikes
#: can loop (two right strikes with a left between) and its travel can be measured.
LOOP_REPEAT_S = 3.0
#: A loop's last frame leads into its first (an export that leaves the first pose out at the end: the
#: cycle is all its frames) rather than repeating it (the cycle is one frame shorter) when the first pose
#: lies nearer, by at least this factor, to the last one moved on by the ends' own frame-to-frame change
#: than to the last one itself; where the two are alike (a capture's cut cycle, whose ends differ by
#: more than a frame's change), the last frame is taken as repeating the first.
LOOP_OPEN_FACTOR = 2.0
#: trailing frames that repeat the last moving frame exactly, for at least this long (s), are an export's
#: padding, not motion: no capture holds every channel to the last digit
HELD_TAIL_S = 0.25


def trim_held_tail(motion: Motion, notes: list[str] | None = None) -> Motion:
    """``motion`` without the trailing frames that repeat its last moving frame exactly (every rotation
    and the root's translation equal), when there are at least :data:`HELD_TAIL_S` of them and something
    moves before them: an export that walks 30-90 of its 250 frames and holds the last pose for the
    rest would otherwise move at a fifth of its walk's speed and hide its loop (a note says what was
    dropped)."""
    n = motion.num_frames
    if n < 3:
        return motion
    rot = motion.rotations.reshape(n, -1)
    same = np.all(rot[1:] == rot[:-1], axis=1) & np.all(motion.root_translation[1:] == motion.root_translation[:-1],
                                                        axis=1)
    if motion.translations is not None:
        same &= np.all(motion.translations[1:].reshape(n - 1, -1) == motion.translations[:-1].reshape(n - 1, -1),
                       axis=1)
    k = 0
    while k < n - 1 and same[n - 2 - k]:
        k += 1
    if k == n - 1 or k * motion.frame_time < HELD_TAIL_S:
        return motion
    if notes is not None:
        notes.append(f"held pose: the last {k} frames repeat frame {n - 1 - k} exactly (an export's padding, "
                     f"{k * motion.frame_time:.2f} s): dropped")
    return motion[:n - k]


def _leads_into_first(rel: FloatArray) -> bool:
    """Whether a loop's last frame leads into its first rather than repeating it (:data:`LOOP_OPEN_FACTOR`):
    ``rel`` (T, J, 3) the joints relative to the root."""
    closed = float(np.linalg.norm(rel[-1] - rel[0], axis=-1).max())
    moved_on = rel[-1] + 0.5 * ((rel[-1] - rel[-2]) + (rel[1] - rel[0]))  # the frame after the last
    opened = float(np.linalg.norm(moved_on - rel[0], axis=-1).max())
    return LOOP_OPEN_FACTOR * opened < closed


def _first_appended(motion: Motion) -> Motion:
    """``motion`` with its first frame appended after its last, moved on horizontally by the loop's
    travel (the last frame's, plus one frame at the rate of the clip's ends): a loop whose last frame
    leads into its first, closed."""
    tj = motion.travel_joint()
    u = "xyz".index(motion.up)
    held = motion.root_translation if tj == 0 else motion.translations[:, tj]  # the travel's channel
    shift = held[-1] - held[0] + 0.5 * ((held[-1] - held[-2]) + (held[1] - held[0]))
    shift[u] = 0.0
    root = np.vstack([motion.root_translation, motion.root_translation[:1] + (shift if tj == 0 else 0.0)])
    trans = None
    if motion.translations is not None:
        trans = np.concatenate([motion.translations, motion.translations[:1]])
        trans[-1, tj] += shift if tj != 0 else 0.0
        if tj == 0:
            trans[-1, 0] = root[-1]
    return motion.copy(root_translation=root, rotations=np.concatenate([motion.rotations, motion.rotations[:1]]),
                       translations=trans)


def repeat_loop(motion: Motion, notes: list[str] | None = None) -> Motion:
    """A short clip that is itself one loop of a cycle, repeated to :data:`LOOP_REPEAT_S` (else the
    clip unchanged): a cut gait cycle (both strikes' frames kept) closes within a few centimetres, about
    one stride's pose change (:data:`LOOP_SEAM_FRACTION`). The last frame is taken as the next
    loop's first and the pose it misses it by is spread over the loop (loop closure), unless it leads
    into the first (:func:`_leads_into_first`: a cycle exported without its closing frame), then the cycle
    is all its frames. Each copy is shifted by the loop's horizontal travel (a cycle exported with its
    root motion walks on; one exported in place stays, and its travel is rebuilt from its feet
    afterwards); a turn over the loop is not repeated. What was done is appended to ``notes``."""
    n = motion.num_frames
    dt = motion.frame_time
    k = max(1, int(round(LOOP_STRIDE_S / dt)))
    if n < 4 * k or motion.duration >= LOOP_REPEAT_S:
        return motion
    pos = motion.fk()[0]
    rel = pos - pos[:, :1]
    stride = np.linalg.norm(rel[k:] - rel[:-k], axis=-1).max(axis=1)
    med = float(np.median(stride))
    seam = float(np.linalg.norm(rel[-1] - rel[0], axis=-1).max())
    if med <= 0.0 or seam > LOOP_SEAM_FRACTION * max(med, min(stride[0], stride[-1])) \
            or min(stride[0], stride[-1]) < 0.5 * med:
        return motion
    opened = _leads_into_first(rel)
    if opened:
        motion = _first_appended(motion)
        n += 1
    # loop closure: the last frame is taken as the next loop's first, and the pose it misses it by is
    # spread over the loop (each joint's rotation turned by a growing share of its offset, the
    # translations shifted alike), so the copies join without a jump
    period = n - 1
    ramp = np.arange(n) / period  # 0 at the first frame, 1 at the last
    off = (Rotation.from_quat(motion.rotations[0]) * Rotation.from_quat(motion.rotations[-1]).inv()).as_rotvec()
    turn = Rotation.from_rotvec((ramp[:, None, None] * off).reshape(-1, 3))
    rots = (turn * Rotation.from_quat(motion.rotations.reshape(-1, 4))).as_quat().reshape(motion.rotations.shape)
    tj = motion.travel_joint()
    travel = motion.travel()
    u = "xyz".index(motion.up)
    loop_shift = travel[n - 1] - travel[0]
    loop_shift[u] = 0.0
    root = motion.root_translation.copy()
    root[:, u] += ramp * (root[0, u] - root[-1, u])
    trans = None
    if motion.translations is not None:
        trans = motion.translations.copy()
        gap = trans[0] - trans[-1]
        gap[tj] = 0.0  # the travel joint's translation is the loop's travel
        if tj != 0:
            gap[tj, u] = trans[0, tj, u] - trans[-1, tj, u]
        trans += ramp[:, None, None] * gap
    reps = int(np.ceil(LOOP_REPEAT_S / (period * dt)))
    shifts = np.repeat(np.arange(reps), period)[:, None] * loop_shift  # (reps * period, 3)
    idx = np.tile(np.arange(period), reps)
    root = root[idx] + (shifts if tj == 0 else 0.0)
    if trans is not None:
        trans = trans[idx]
        trans[:, tj] += shifts
        if tj == 0:
            trans[:, 0] = root
    rots = rots[idx]
    out = motion.copy(root_translation=root, rotations=canonical_quat(rots), translations=trans)
    if notes is not None:
        ends = (f"its last frame leads into its first ({n - 1} frames, a cycle of {period})" if opened else
                f"the clip ends in the pose it starts with ({n} frames, a cycle of {period})")
        notes.append(f"a loop: {ends}; repeated {reps} times ({out.duration:.2f} s)")
    return out


def humanoid_motion(motion: Motion, notes: list[str] | None = None) -> Motion:
    """A motion read from a file (any frame) made ready for a humanoid: the project frame, an export's
    held tail dropped (:func:`trim_held_tail`), a short loop repeated (:func:`repeat_loop`), a standing
    rest pose (:func:`~bipedsim.motion.rest.standing_rest`), a length for a foot or head that has none
    (:func:`~bipedsim.model.humanoid.with_tips`) and, for a walk in place (:func:`in_place`), its root
    travel rebuilt from the stance feet (:func:`reconstruct_root`). What was done is appended to
    ``notes`` (lines for the user)."""
    notes = notes if notes is not None else []
    m = repeat_loop(trim_held_tail(motion.to_project_frame(), notes), notes)
    standing = standing_rest(m)
    if standing is not m:
        notes.append("rest pose: the file's identity pose is no standing body (bone-aligned joint frames); "
                     "rebased on the frame whose feet are closest together")
    standing = with_tips(standing, notes)
    if in_place(standing):
        standing = reconstruct_root(standing)
        root = standing.travel()[:, :2]
        notes.append(f"walks in place: root travel rebuilt from the stance feet "
                     f"({np.linalg.norm(root[-1] - root[0]):.2f} m in {standing.duration:.2f} s)")
    return standing


def motion_for_body(raw: Motion, motion: Motion, kind: str, notes: list[str], support: bool = False) -> Motion:
    """The motion a body of ``kind`` is built from, as every command prepares it: for a humanoid
    :func:`humanoid_motion` of the file's ``raw`` motion (a short loop repeated, a standing rest pose, the
    travel of a walk in place), for a creature without root ``support`` :func:`creature_motion` of its
    project-frame ``motion`` (a walk in place), else ``motion``. What was done is appended to ``notes``."""
    if kind == "humanoid":
        return humanoid_motion(raw, notes)
    return motion if support else creature_motion(motion, notes)


def load_source(path: str | os.PathLike[str], *, scale: float | str | None = None, up: str | None = None,
                   positions: str | None = None, profile: str | None = AUTO, support: bool = False,
                   creature_support: bool = False, fps: float | None = None) -> tuple[Motion, BVHInfo, Motion, str]:
    """A BVH file read as every command builds a body from it -- one way through for ``run``, sweeps,
    suites, tunes and ``convert``: :func:`~bipedsim.model.creature_kind.read_source` (reading, body kind,
    unit, a static floor root folded), then :func:`motion_for_body` (root support: ``support``, or
    ``creature_support`` from a creature's controller). Returns the raw motion, what reading found (its
    ``notes`` extended), the motion to build from (project frame) and the body kind."""
    raw, info, motion, kind = read_source(path, scale=scale, up=up, positions=positions, profile=profile,
                                            support=support, fps=fps)
    return raw, info, motion_for_body(raw, motion, kind, info.notes, support or creature_support), kind
