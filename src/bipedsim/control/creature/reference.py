"""The clip as a legged creature's reference: the part of it that is played and looped, re-levelled on
the built body's legs, and its root velocity averaged over a window.

A body built from bone lengths stands its feet centimetres above or into the floor where the
capture's joints touched it (a paw or hoof floating 2-3 cm, a bird's stance foot sunk): the height
target, the start pose and the stance legs' reach would then disagree with the ground, so the
reference's root height is shifted frame by frame until its lowest leg touches the floor.
"""

from __future__ import annotations

from dataclasses import replace

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.legs import LegSet, geom_bottom
from bipedsim.reference.clip import ReferenceClip

#: frames whose root stands lower than this fraction of the clip's median root height are not part of
#: the walk (a dog lying down before it gets up)
STANDING_FRACTION = 0.75
#: the looped part of a clip spans at least this share of its standing frames
MIN_LOOP_SHARE = 0.5
#: frames whose lowest leg stands higher than this fraction of the standing root height are in flight
#: (a gallop's or a jump's): they keep the clip's own height, shifted by the median of the others
FLIGHT_FRACTION = 0.1


def loop_segment(clip: ReferenceClip, quat_idx: npt.NDArray[np.int64]) -> tuple[int, int]:
    """Frames [a, b) of the clip to play and loop: among the frames where the root stands (height at
    least STANDING_FRACTION of the median), the pair a < b, at least MIN_LOOP_SHARE of them apart, whose
    poses (joint rotations and root height) differ least, so the loop's seam is the smoothest the clip
    offers."""
    z = clip.qpos[:, 2]
    standing = np.flatnonzero(z >= STANDING_FRACTION * np.median(z))
    if len(standing) < 4:
        return 0, clip.num_frames
    lo, hi = int(standing[0]), int(standing[-1]) + 1
    q = clip.qpos[lo:hi][:, quat_idx]  # (n, balls, 4)
    feat_z = z[lo:hi] / max(float(np.median(z)), 1e-9)
    n = hi - lo
    gap = max(2, int(MIN_LOOP_SHARE * n))
    best, pair = np.inf, (lo, hi)
    for a in range(0, n - gap):
        dots = np.abs(np.einsum("jk,bjk->bj", q[a], q[a + gap:]))
        d = np.sum(1.0 - np.minimum(dots, 1.0), axis=1) + np.abs(feat_z[a + gap:] - feat_z[a])
        k = int(np.argmin(d))
        if d[k] < best:
            best, pair = float(d[k]), (lo + a, lo + a + gap + k)
    return pair


def level_on_legs(model: mujoco.MjModel, clip: ReferenceClip, legs: LegSet) -> tuple[FloatArray, FloatArray]:
    """Pose ``clip`` frame by frame on this body and measure each leg's lowest point (its lower end's
    geoms, as the contacts see them). Returns the root height shift (m, per frame) that puts the lowest
    leg on the floor in every frame where one is near it (below FLIGHT_FRACTION of the standing height;
    frames in flight take the median shift), and each leg's lowest point (frames, legs; m) after it."""
    n_leg = len(legs)
    data = mujoco.MjData(model)
    geoms = [legs.lower_geoms(i) for i in range(n_leg)]
    low = np.full((clip.num_frames, n_leg), np.inf)
    for f in range(clip.num_frames):
        data.qpos[:] = clip.qpos[f]
        mujoco.mj_kinematics(model, data)
        for i, gs in enumerate(geoms):
            if gs:
                low[f, i] = min(geom_bottom(model, data, g) for g in gs)
    ground = low.min(axis=1) if n_leg else np.zeros(clip.num_frames)
    near = ground < FLIGHT_FRACTION * legs.height
    fallback = -float(np.median(ground[near])) if near.any() else 0.0
    shift = np.where(near, -ground, fallback)
    return shift, low + shift[:, None]


def window_velocity(clip: ReferenceClip, window_s: float) -> FloatArray:
    """(frames, 2) the clip's horizontal root velocity (m/s, world), averaged over ``window_s`` s, the
    clip taken as a loop."""
    n = clip.num_frames
    w = max(1, int(round(window_s / clip.frame_time)))
    v = clip.qvel[:, 0:2]
    kernel = np.ones(w) / w
    return np.stack([np.convolve(np.concatenate([v[-w:, k], v[:, k], v[:w, k]]) if n > w
                                 else np.pad(v[:, k], w, mode="edge"), kernel, mode="same")[w:w + n]
                     for k in range(2)], axis=1)


class LoopedReference:
    """The clip a legged creature plays (see the module text): ``clip`` re-levelled on the legs,
    ``loop`` its frames [a, b) (measured on the clip as read), ``level_shift`` the root height shift
    (m) per frame, ``ref_low`` each leg's lowest point (m; frames x legs) and ``v_ref`` the windowed
    root velocity (m/s; frames x 2)."""

    def __init__(self, model: mujoco.MjModel, clip: ReferenceClip, legs: LegSet, quat_idx: npt.NDArray[np.int64],
                 window_s: float) -> None:
        self.level_shift, self.ref_low = level_on_legs(model, clip, legs)
        qpos = clip.qpos.copy()
        qpos[:, 2] += self.level_shift
        self.clip = replace(clip, qpos=qpos)
        self.v_ref = window_velocity(self.clip, window_s)
        self.loop = loop_segment(clip, quat_idx)

    def place_start(self, model: mujoco.MjModel, data: mujoco.MjData, frame: float) -> None:
        """The caller posed the clip as read at ``frame``: raise it to the re-levelled clip's height."""
        data.qpos[2] += self.level_shift[min(int(frame), self.clip.num_frames - 1)]
        mujoco.mj_forward(model, data)


__all__ = ["FLIGHT_FRACTION", "LoopedReference", "loop_segment", "window_velocity"]
