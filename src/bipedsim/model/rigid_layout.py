"""Rigid layouts of points the motion moves relative to each other: the pelvis (hips, spine base) and
torso (neck, shoulders) calibrated on the motion, and where a humanoid's spine splits into abdomen and
chest when one rigid torso cannot follow it. Positions in m, project frame (Z up)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.naming import HumanoidMap
from bipedsim.model.orientations import kabsch
from bipedsim.model.profile import HumanoidProfile
from bipedsim.model.source import SourcePoints

FloatArray = npt.NDArray[np.float64]


#: Weight of the neck against the shoulders when fitting the torso's orientation: the shoulders
#: are where the arms hang, so they matter more than the neck base.
NECK_FIT_WEIGHT = 0.05
#: Calibration passes for the rigid pelvis and torso (fit, average, refit).
CALIBRATION_PASSES = 3
#: Further passes that centre each point between its extremes (minimax instead of least squares).
MIDRANGE_PASSES = 3


def calibrate_rigid(pts: SourcePoints, origin: str, points: list[str], ref_joint: str,
                    rest_vecs: FloatArray, weights: FloatArray | None = None) -> FloatArray:
    """Where a rigid body's points sit relative to its origin, as the motion shows them on average.

    The source may move these points relative to each other (CMU's hip helper joints, clavicles,
    several spine links); a rigid body cannot. Fit the body's orientation on every frame, express the
    points in that frame, average, and repeat: the result is the rigid layout closest to the motion.
    """
    cur = np.stack([pts[p] - pts[origin] for p in points], axis=1)
    ref = pts.rotation(ref_joint)
    vecs = rest_vecs
    for k in range(CALIBRATION_PASSES + MIDRANGE_PASSES):
        r = kabsch(vecs, cur, ref, weights)
        local = np.einsum("tji,tnj->tni", r, cur)
        # mean first; then the midrange, which minimises the worst frame's error per axis
        vecs = local.mean(axis=0) if k < CALIBRATION_PASSES else 0.5 * (local.min(axis=0) + local.max(axis=0))
    return vecs


def rigid_residual(pts: SourcePoints, origin: str, points: list[str], ref_joint: str, vecs: FloatArray,
                   weights: FloatArray | None = None) -> FloatArray:
    """Worst distance (m) over the motion between each point and where the rigid layout ``vecs``,
    fitted per frame, puts it."""
    cur = np.stack([pts[p] - pts[origin] for p in points], axis=1)
    r = kabsch(vecs, cur, pts.rotation(ref_joint), weights)
    return np.linalg.norm(np.einsum("tij,nj->tni", r, vecs) - cur, axis=-1).max(axis=0)


#: Shortest abdomen and chest (m) of a two-segment spine.
MIN_SPINE_SEGMENT_M = 0.05


def _split_joint(rest: SourcePoints, hm: HumanoidMap) -> str | None:
    """Where a two-segment spine bends: the chest joint, or the nearest spine joint below it that
    leaves both segments at least MIN_SPINE_SEGMENT_M long (some skeletons put the neck on the chest)."""
    sk = rest.skeleton
    j = sk.index(hm.chest)
    base = sk.index(hm.torso_base)
    while j >= 0 and j != base:
        name = sk.names[j]
        if (np.linalg.norm(rest[hm.neck] - rest[name]) >= MIN_SPINE_SEGMENT_M
                and np.linalg.norm(rest[name] - rest[hm.torso_base]) >= MIN_SPINE_SEGMENT_M):
            return name
        j = int(sk.parents[j])
    return None


def _split_spine(profile: HumanoidProfile, rest: SourcePoints, moving: SourcePoints, hm: HumanoidMap,
                 torso_pts: list[str], tv: FloatArray, torso_w: FloatArray) -> str | None:
    """The joint where the torso splits into two segments, or None (see ``spine_segments`` in the
    humanoid profile)."""
    if profile.spine_segments == 1:
        return None
    at = _split_joint(rest, hm)
    if at is None:
        if profile.spine_segments == 2:
            raise ModelError(f"spine_segments: 2 needs a spine joint between {hm.torso_base!r} and the neck "
                             f"{hm.neck!r} at least {MIN_SPINE_SEGMENT_M * 100:.0f} cm from both; "
                             f"this skeleton has none")
        return None
    if profile.spine_segments == 2:
        return at
    worst = rigid_residual(moving, hm.torso_base, torso_pts, hm.chest, tv, torso_w)[1:]  # the shoulders
    return at if worst.size and worst.max() > profile.spine_split_tol else None
