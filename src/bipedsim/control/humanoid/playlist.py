"""What a clip source plays: the frames, where its loop is, and its strikes.

``source: clip`` plays the whole clip as captured, frame 0 to its end (its turns, speed changes, starts
and stops), then its best gait cycle (:func:`~bipedsim.control.humanoid.cycles.best_cycle`) looped from
where the clip left off: one copy of the cycle is appended at the clip's last strike of the cycle's
foot, turned and moved so that it starts where the clip's pelvis is there (a loop that turns unlike the
clip's end, turned evenly over its pass to the clip's own rate: :data:`LOOP_TURN_MATCH_DEG`), and eased
into over :data:`~bipedsim.control.humanoid.cycles.SEAM_BLEND_S`; the source then loops that copy. A clip with
no gait cycle (a gesture, a single step) holds its last frame after its end.

``source: cycle`` loops the best cycle from its first strike on, never playing the rest of the clip.

Frames are clip frames (the appended copy continues the numbering); angles rad, lengths m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.cycles import CYCLE_TURN_NOTE_DEG, Cycle, blend_seam, loop_turn_extra, root_heading
from bipedsim.control.humanoid.hinges import SIDES
from bipedsim.reference.clip import ReferenceClip

FloatArray = npt.NDArray[np.float64]

#: frames appended after a clip with no gait cycle: its last frame, held
HOLD_FRAMES = 2
#: deg a pass: a loop whose heading turns more than this, and more than this otherwise than the clip's
#: own over its last loop-length, is turned at the clip's rate (:func:`_turn_copy`; the rule is
#: :func:`~bipedsim.control.humanoid.cycles.loop_turn_extra`): looped as captured, a loop found inside a
#: veer the clip then leaves walks a circle after the clip
LOOP_TURN_MATCH_DEG = CYCLE_TURN_NOTE_DEG


@dataclass(frozen=True)
class Playlist:
    """The frames a clip source plays, the loop [a, b) it repeats after them, and the strikes.

    ``qpos``/``qvel``: (N, nq)/(N, nv) the frames; ``q``/``qd``: (N, H) their hinge angles and rates with
    the seams eased; ``contacts``: (N, 2) the feet in ``SIDES`` order; ``once``: per foot the strike frames before ``a``
    (played once); ``loop``: those in [a, b) (repeated every ``b - a`` frames); ``clip_end``: the last
    frame played as captured (later frames are the loop's copy or the held last frame)."""

    qpos: FloatArray
    qvel: FloatArray
    q: FloatArray
    qd: FloatArray
    contacts: npt.NDArray[np.bool_]
    a: int
    b: int
    once: dict[str, FloatArray]
    loop: dict[str, FloatArray]
    whole: bool
    clip_end: int


def _strikes(clip: ReferenceClip, side: str) -> list[int]:
    return [int(s) for s in clip.events[side]["strike"]]


def _feet(clip: ReferenceClip) -> npt.NDArray[np.bool_]:
    return np.column_stack([clip.contacts[:, clip.foot_names.index(s)] for s in SIDES]).astype(bool)


def cycle_playlist(clip: ReferenceClip, cycle: Cycle, hq: FloatArray, hqd: FloatArray, blend: int) -> Playlist:
    """The best cycle looped (``source: cycle``): the clip's frames, its loop the cycle's."""
    a, b = cycle.a, cycle.b
    loop = {s: np.array([t for t in _strikes(clip, s) if a <= t < b], dtype=float) for s in SIDES}
    return Playlist(qpos=clip.qpos, qvel=clip.qvel, q=blend_seam(hq, a, b, blend), qd=blend_seam(hqd, a, b, blend),
                    contacts=_feet(clip), a=a, b=b, once={s: np.zeros(0) for s in SIDES}, loop=loop, whole=False,
                    clip_end=clip.num_frames - 1)


def whole_playlist(clip: ReferenceClip, cycle: Cycle | None, hq: FloatArray, hqd: FloatArray, blend: int,
                   hinge_qadr: npt.NDArray[np.integer]) -> Playlist:
    """The whole clip, then ``cycle`` looped from the clip's last strike of its foot (see the module's
    text); ``hq``/``hqd`` the clip's hinge angles and rates, ``blend`` the seams' easing (frames),
    ``hinge_qadr`` where the hinges sit in qpos."""
    n = clip.num_frames
    feet = _feet(clip)
    if cycle is None:
        last = np.repeat(clip.qpos[-1:], HOLD_FRAMES, axis=0)
        still = np.zeros((HOLD_FRAMES, clip.qvel.shape[1]))
        once = {s: np.array(_strikes(clip, s), dtype=float) for s in SIDES}
        return Playlist(qpos=np.vstack([clip.qpos, last]), qvel=np.vstack([clip.qvel, still]),
                        q=np.vstack([hq, np.repeat(hq[-1:], HOLD_FRAMES, axis=0)]),
                        qd=np.vstack([hqd, np.zeros((HOLD_FRAMES, hqd.shape[1]))]),
                        contacts=np.vstack([feet, np.repeat(feet[-1:], HOLD_FRAMES, axis=0)]),
                        a=n - 1, b=n - 1 + HOLD_FRAMES, once=once, loop={s: np.zeros(0) for s in SIDES},
                        whole=True, clip_end=n - 1)
    ca, cb = cycle.a, cycle.b
    period = cb - ca
    # the clip's last strike of the cycle's foot (a cycle of the whole clip, seen only wrapped, may have
    # none: its loop then starts where the cycle does)
    cut = max((s for s in _strikes(clip, cycle.foot) if s >= ca), default=ca)
    # the copy: the cycle's frames ca..cb turned by the heading change and moved onto the clip's root at cut
    heading = np.unwrap(root_heading(clip.qpos))
    turn = float(heading[cut] - heading[ca])
    c, s = math.cos(turn), math.sin(turn)
    rot = np.array([[c, -s], [s, c]])
    copy_q = clip.qpos[ca:cb + 1].copy()
    copy_q[:, :2] = (copy_q[:, :2] - clip.qpos[ca, :2]) @ rot.T + clip.qpos[cut, :2]
    yaw = np.array([math.cos(turn / 2), 0.0, 0.0, math.sin(turn / 2)])
    for row in copy_q:
        quat = np.empty(4)
        mujoco.mju_mulQuat(quat, yaw, row[3:7])
        row[3:7] = quat
    copy_v = clip.qvel[ca:cb + 1].copy()
    copy_v[:, :2] = copy_v[:, :2] @ rot.T  # the free joint's linear velocity is world; its angular, local
    # a loop that turns, otherwise than the clip's own last loop-length, turns at the clip's rate
    extra = loop_turn_extra(clip.qpos, ca, cb)
    if extra:
        _turn_copy(copy_q, copy_v, extra, clip.frame_time)
    # the copy's hinges with the loop's own seam eased, then the clip eased into the copy after the cut
    loop_q = blend_seam(hq, ca, cb, blend)[ca:cb + 1]
    loop_qd = blend_seam(hqd, ca, cb, blend)[ca:cb + 1]
    q = np.vstack([hq[:cut], loop_q])
    qd = np.vstack([hqd[:cut], loop_qd])
    ease = min(blend, n - 1 - cut, period - 1)
    for k in range(ease):
        w = (k + 1) / (ease + 1)
        w = w * w * (3.0 - 2.0 * w)
        q[cut + k] = (1.0 - w) * hq[cut + k] + w * loop_q[k]
        qd[cut + k] = (1.0 - w) * hqd[cut + k] + w * loop_qd[k]
    qpos = np.vstack([clip.qpos[:cut], copy_q])
    qpos[:, hinge_qadr] = q
    once = {side: np.array([t for t in _strikes(clip, side) if t < cut], dtype=float) for side in SIDES}
    loop = {side: np.array([t - ca + cut for t in _strikes(clip, side) if ca <= t < cb], dtype=float)
            for side in SIDES}
    return Playlist(qpos=qpos, qvel=np.vstack([clip.qvel[:cut], copy_v]), q=q, qd=qd,
                    contacts=np.vstack([feet[:cut], feet[ca:cb + 1]]), a=cut, b=cut + period, once=once,
                    loop=loop, whole=True, clip_end=cut)


def _turn_copy(copy_q: FloatArray, copy_v: FloatArray, extra: float, frame_time: float) -> None:
    """Turn the loop's copy (qpos ``copy_q``, qvel ``copy_v``, in place) by ``extra`` rad more over its
    pass, evenly from its first frame (0) to its last (all of it): its root's travel turned frame by
    frame, its orientation turned about the vertical, its linear velocity (world) turned and its angular
    velocity (local) given the added yaw rate. The hinges are as captured."""
    if len(copy_q) < 2:
        return
    m = len(copy_q) - 1
    rate = extra / (m * frame_time)
    steps = np.diff(copy_q[:, :2], axis=0)
    xy = copy_q[0, :2].copy()
    for k in range(m + 1):
        ang = extra * k / m
        c, s = math.cos(ang), math.sin(ang)
        if k:
            dx, dy = steps[k - 1]
            xy = xy + np.array([c * dx - s * dy, s * dx + c * dy])
            copy_q[k, :2] = xy
        quat = np.empty(4)
        mujoco.mju_mulQuat(quat, np.array([math.cos(ang / 2), 0.0, 0.0, math.sin(ang / 2)]), copy_q[k, 3:7])
        copy_q[k, 3:7] = quat
        vx, vy = copy_v[k, :2]
        copy_v[k, :2] = (c * vx - s * vy, s * vx + c * vy)
        frame = np.empty(9)
        mujoco.mju_quat2Mat(frame, quat)
        copy_v[k, 3:6] += rate * frame.reshape(3, 3)[2]  # the world's vertical in the root's frame
