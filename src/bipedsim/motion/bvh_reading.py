"""Which reading of a BVH file's values is the body: whether each joint's position channels replace its
OFFSET or add to it, and which axis is up, chosen together by scoring every reading for a plausible body
(:func:`~bipedsim.motion.conventions.score_reading`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.errors import BVHError
from bipedsim.motion.bvh_channels import _channels_to_motion
from bipedsim.motion.conventions import (
    AMBIGUOUS_SCORE_MARGIN,
    BVH_DEFAULT_UP,
    STANDING_HIP_MIN,
    ReadingScore,
    guess_unit,
    guess_up_axis,
    score_reading,
)
from bipedsim.motion.motion import Motion
from bipedsim.motion.skeleton import POSITION_CHANNELS, Skeleton

FloatArray = npt.NDArray[np.float64]

#: Frames sampled over a clip to guess its up axis and unit.
SIZE_SAMPLE_FRAMES = 50


def _position_modes(sk: Skeleton, data: FloatArray, col: list[int]) -> tuple[tuple[str, ...], dict[str, str],
                                                                           list[int]]:
    """Decide per joint whether its position channels replace or add to the OFFSET.

    Absolute channels sit near the OFFSET, additive ones near zero. Per axis, the distance of the
    channel values' median from the OFFSET and from zero is measured in units of that axis's own spread
    (10-90 %): an axis the joint travels along (a walk's forward axis) says little, the axis it holds
    (the hips' height) decides. Returns the modes, a reason per joint, and the joints whose choice is
    weak (the distances within a factor of 3), whose alternative reading is scored as well.
    """
    modes: list[str] = []
    reasons: dict[str, str] = {}
    weak: list[int] = []
    scale = float(np.median(np.linalg.norm(sk.offsets[1:], axis=1))) if sk.num_joints > 1 else 1.0
    floor = 1e-3 * (scale if scale > 0 else 1.0)
    for j, name in enumerate(sk.names):
        if not sk.has_positions(j):
            modes.append("")
            continue
        off = sk.offsets[j]
        if not np.any(off):
            modes.append("replace")
            reasons[name] = "OFFSET is zero: replace and add agree"
            continue
        d_rep = d_add = 0.0
        for k, c in enumerate(sk.channels[j]):
            if c not in POSITION_CHANNELS:
                continue
            v = data[:, col[j] + k]
            a = POSITION_CHANNELS.index(c)
            spread = float(np.percentile(v, 90) - np.percentile(v, 10)) + floor
            med = float(np.median(v))
            d_rep += abs(med - off[a]) / spread
            d_add += abs(med) / spread
        if d_rep <= d_add:
            modes.append("replace")
            reasons[name] = (f"channel values sit near the OFFSET ({d_rep:.3g} vs {d_add:.3g} spreads from "
                             "zero): absolute")
        else:
            modes.append("add")
            reasons[name] = (f"channel values sit near zero ({d_add:.3g} vs {d_rep:.3g} spreads from the "
                             "OFFSET): added to OFFSET")
        if max(d_rep, d_add) < 3.0 * min(d_rep, d_add) + 1.0:
            weak.append(j)
    return tuple(modes), reasons, weak


#: Position-channel modes a caller may force (``--positions``): every joint's channels are absolute
#: (``replace`` the OFFSET) or added to the OFFSET.
POSITION_MODE_NAMES = {"absolute": "replace", "offset": "add"}


def _forced_modes(sk: Skeleton, positions: str, path: str) -> tuple[str, ...]:
    if positions not in POSITION_MODE_NAMES:
        raise BVHError(f"position mode must be one of {', '.join(POSITION_MODE_NAMES)}, got {positions!r}", path)
    m = POSITION_MODE_NAMES[positions]
    return tuple(m if sk.has_positions(j) else "" for j in range(sk.num_joints))


def _candidate_modes(sk: Skeleton, modes: tuple[str, ...], weak: list[int]) -> list[tuple[str, ...]]:
    """The position-mode readings worth scoring: the per-joint choice, and with its weak choices flipped."""
    out = [modes]
    weak = [j for j in weak if j != 0]  # the root's mode only moves the whole body: nothing to score
    if weak:
        flip = {"replace": "add", "add": "replace"}
        out.append(tuple(flip[m] if j in weak else m for j, m in enumerate(modes)))
    return out


def _sample_points(motion: Motion) -> tuple[FloatArray, FloatArray]:
    """Joint positions and joints + End Sites of a few frames spread over the clip (frame 0 alone may
    be a T-pose, a sitting dog...)."""
    sample = motion[::max(1, motion.num_frames // SIZE_SAMPLE_FRAMES)]
    pos_s = sample.fk()[0]
    pts = np.concatenate([pos_s, sample.end_site_positions()], axis=1)
    tj = motion.travel_joint()
    if tj:  # a static root (at the floor, or anywhere) is no part of the body's extent
        sk = motion.skeleton
        above = [j for j in range(sk.num_joints) if tj in sk.subtree(j) and j != tj]
        keep = np.ones(pts.shape[1], dtype=bool)
        keep[above] = False
        pts = pts[:, keep]
    return pos_s, pts


def _choose_reading(sk: Skeleton, frame_time: float, data: FloatArray, mode_options: list[tuple[str, ...]],
                    ups: tuple[str, ...]) -> tuple[Motion, str, str, str]:
    """Score every (position modes, up axis) reading of the file (:func:`score_reading`) and keep the
    most plausible body; where the most plausible one is not Y up and stands no body on its legs (its hip
    under :data:`~bipedsim.motion.conventions.STANDING_HIP_MIN` leg lengths above the feet), nothing
    tells the up axis and the best Y-up reading is kept (the BVH convention). Returns the motion, the up
    axis, why, and a note on the alternatives ("" when the choice is clear)."""
    scored = []
    for modes in mode_options:
        motion = _channels_to_motion(sk.replace(position_modes=modes), frame_time, data)
        pos_s, pts = _sample_points(motion)
        for up in ups:
            sc = score_reading(sk.names, sk.parents, pos_s, up)
            if sc is not None and not guess_unit(pts, up).fits:
                sc = ReadingScore(sc.score + 1.0, sc.hip_ratio, sc.floor_spread, sc.vertical_travel, sc.floor_offset)
            scored.append((sc, modes, up, motion, pos_s))
    if any(s[0] is None for s in scored):
        # no feet to measure: one reading by the root-above-feet rule
        motion, pos_s = scored[0][3], scored[0][4]
        if len(ups) == 1:
            return motion, ups[0], "given by the caller", ""
        g = guess_up_axis(sk.names, pos_s, sk.parents)
        return motion, g.axis, g.reason, ""
    scored.sort(key=lambda s: s[0].score)
    best = scored[0]

    differ = [j for j in range(sk.num_joints) if len({m[j] for m in mode_options}) > 1]

    def label(s: tuple) -> str:
        modes = "".join(f", {sk.names[j]} {'absolute' if s[1][j] == 'replace' else 'added to OFFSET'}"
                        for j in differ)
        return f"{s[2].upper()} up{modes}"

    if best[2] != BVH_DEFAULT_UP and best[0].hip_ratio < STANDING_HIP_MIN and len(ups) > 1:
        # no reading stands the body on its legs: the other axis won on a floor that is no floor
        default = next(s for s in scored if s[2] == BVH_DEFAULT_UP)
        reason = (f"no reading shows a body on its legs ({label(best)}: hip {best[0].hip_ratio:.2f} leg lengths "
                  f"above the lowest foot, under {STANDING_HIP_MIN}); read {label(default)}, the BVH convention")
        note = "the up axis is the BVH convention, nothing in the clip tells it; force one with --up y|z"
        return default[3], default[2], reason, note
    reason = f"most plausible reading ({label(best)}): {best[0].text()}"
    note = ""
    if len(scored) > 1 and scored[1][0].score - best[0].score < AMBIGUOUS_SCORE_MARGIN:
        note = (f"ambiguous: {label(scored[1])} scores {scored[1][0].score:.2f} against {best[0].score:.2f}; "
                "force a reading with --up y|z" + (" and --positions absolute|offset" if len(mode_options) > 1 else ""))
    return best[3], best[2], reason, note
