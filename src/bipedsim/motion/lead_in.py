"""Leading frames that are no part of a take: the T-pose or rest pose some releases put before the
capture (CMU's MotionBuilder release, Character Creator rigs), or the few frames blending out of it.

They are found by measuring the clip, not by name: a capture changes its pose by a bounded amount from
one frame to the next, so a first frame whose pose lies several times the clip's own fast frame-to-frame
change away from every later frame is a jump no capture makes in one frame, and a pose the take never
returns to. Dropped at reading (:func:`~bipedsim.motion.bvh.read_bvh`), everything after it -- the body,
the reference, the clip's speed -- sees the take alone.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]

#: A leading frame is no part of the take when its pose lies farther than this multiple of the clip's
#: fast frame-to-frame change (:data:`LEAD_IN_STEP_PERCENTILE`) from every later frame: a clean capture's
#: largest steps stay within about twice that, a frame blending out of a T-pose lies 4-7 times it, the
#: T-pose itself 20 times.
LEAD_IN_JUMP = 4.0
#: The clip's fast frame-to-frame change: this percentile of its pose changes between consecutive frames
#: (a high percentile, not the largest: one glitching joint mid-take must not hide the lead-in).
LEAD_IN_STEP_PERCENTILE = 95.0
#: ...and never closer than this (deg, RMS over the joints): a clip that holds still after its first
#: frame makes any change a jump; a rest pose differs from a take's pose by tens of degrees at the
#: shoulders.
LEAD_IN_MIN_DEG = 2.0
#: At most this long (s) of leading frames are dropped (a T-pose and the frames blending out of it);
#: later frames belong to the take however they move.
LEAD_IN_MAX_S = 0.1
#: A clip shorter than this (frames, after the lead-in's longest) has too few frame-to-frame changes to
#: measure a jump against: nothing is dropped.
LEAD_IN_MIN_FRAMES = 10


def pose_distance(rotations: FloatArray, frame: int, joints: list[int]) -> FloatArray:
    """(T,) the angle (deg) between frame ``frame``'s pose and every frame's: the RMS over ``joints`` of
    each joint's local rotation angle between the two frames. ``rotations``: (T, J, 4) quaternions."""
    q = rotations[:, joints]
    dot = np.abs(np.einsum("tjk,jk->tj", q, q[frame]))
    ang = 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))
    return np.degrees(np.sqrt(np.mean(ang ** 2, axis=1)))


def _steps(rotations: FloatArray, joints: list[int]) -> FloatArray:
    """(T - 1,) the pose change (deg, RMS over ``joints``) from each frame to the next."""
    q = rotations[:, joints]
    dot = np.abs(np.einsum("tjk,tjk->tj", q[1:], q[:-1]))
    ang = 2.0 * np.arccos(np.clip(dot, 0.0, 1.0))
    return np.degrees(np.sqrt(np.mean(ang ** 2, axis=1)))


def lead_in_frames(motion: Motion) -> tuple[int, float, float]:
    """How many first frames of ``motion`` are no part of its take (see the module's text), the first
    one's distance (deg) to the nearest later pose, and the clip's fast frame-to-frame change (deg).

    Frame ``k`` (from 0, while the previous one was dropped, within :data:`LEAD_IN_MAX_S`) is dropped
    when its pose (the local rotations of every joint below the root that has rotation channels: the
    pose, not the heading) lies farther than :data:`LEAD_IN_JUMP` times the clip's
    :data:`LEAD_IN_STEP_PERCENTILE`-percentile frame-to-frame change, and at least
    :data:`LEAD_IN_MIN_DEG`, from every later frame. Units and axes do not matter (rotations only)."""
    sk = motion.skeleton
    joints = [j for j in range(1, sk.num_joints) if sk.rotation_order(j)]
    limit = max(1, int(round(LEAD_IN_MAX_S / motion.frame_time)))
    if not joints or motion.num_frames < limit + LEAD_IN_MIN_FRAMES:
        return 0, 0.0, 0.0
    rot = motion.rotations
    fast = float(np.percentile(_steps(rot[limit:], joints), LEAD_IN_STEP_PERCENTILE))
    jump = max(LEAD_IN_JUMP * fast, LEAD_IN_MIN_DEG)
    n, first = 0, 0.0
    while n < limit:
        nearest = float(pose_distance(rot, n, joints)[n + 1:].min())
        if n == 0:
            first = nearest
        if nearest <= jump:
            break
        n += 1
    return n, first, fast


def drop_lead_in(motion: Motion, notes: list[str] | None = None) -> tuple[Motion, int]:
    """``motion`` without its leading frames that are no part of the take (:func:`lead_in_frames`) and
    how many were dropped; a line saying so is appended to ``notes``."""
    n, first, fast = lead_in_frames(motion)
    if not n:
        return motion, 0
    if notes is not None:
        what = "frame 0" if n == 1 else f"frames 0-{n - 1}"
        notes.append(f"lead-in: {what} of {motion.num_frames} dropped: frame 0's pose lies {first:.1f} deg "
                     f"(RMS over the joints) from every later frame, {first / max(fast, 1e-9):.0f} times the "
                     f"clip's fast change from frame to frame ({fast:.2f} deg): a T-pose or rest pose before the "
                     "take" + ("" if n == 1 else ", and the frames blending out of it"))
    return motion[n:], n
