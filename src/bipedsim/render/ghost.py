"""The ghost of ``bipedsim render --ghost``: the clip drawn beside the simulated body.

During the clip's own duration the ghost is the clip at the run's time (frame ``start_frame + t /
frame_time``, as :mod:`bipedsim.sim.fidelity` compares it, not the controller's resynchronised
reference frame), its root where the clip's goes once the clip is turned and moved so that its start
matches the body's, and ``offset`` m to the clip's left so that both are seen (0: overlaid); a body
that drifts off the clip's course shows as the ghost leaving its place beside it. After the clip's end,
and for a trajectory that keeps no clip (key poses, older files), the ghost is the controller's
reference pose (``ref_qpos``) ``offset`` m to the body's left.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.sim.fidelity import clip_seconds, heading_axis, headings, interp_rows, root_of, yaw_matrix
from bipedsim.sim.recorder import Trajectory

FloatArray = npt.NDArray[np.float64]

#: Colours (RGBA) of the ghost: the clip, and the controller's reference after the clip's end.
CLIP_RGBA = (0.3, 0.6, 1.0, 0.35)
REFERENCE_RGBA = (0.4, 0.9, 0.5, 0.35)


def _yaw_quat(angle: float) -> FloatArray:
    return np.array([math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)])


class Ghost:
    """The ghost's pose at any time of a recorded run on ``model`` (see the module's text)."""

    def __init__(self, model: mujoco.MjModel, tr: Trajectory, offset: float = 1.0) -> None:
        self.tr = tr
        self.offset = offset
        self.root, self.adr = root_of(model)
        clip = tr.clip_pose_frames()
        self.clip: FloatArray | None = None
        if clip is None:
            return
        qpos, self.frame_time, self.start = clip
        self.span = clip_seconds(len(qpos), self.frame_time, self.start)
        if self.span <= 0:
            return
        self.clip = np.asarray(qpos, dtype=np.float64)
        a = self.adr
        at_start = np.array([self.start])
        self.axis = heading_axis(interp_rows(self.clip[:, a + 3:a + 7], at_start)[0])
        self.clip_yaw = headings(self.clip[:, a + 3:a + 7], self.axis)
        body_yaw0 = float(headings(tr.qpos[:1, a + 3:a + 7], self.axis)[0])
        self.turn = body_yaw0 - float(interp_rows(self.clip_yaw, at_start)[0])
        self.rot = yaw_matrix(self.turn)
        self.clip_xy0 = interp_rows(self.clip[:, a:a + 2], at_start)[0]
        self.body_xy0 = np.asarray(tr.qpos[0, a:a + 2], dtype=np.float64)

    def shows_clip(self, t: float) -> bool:
        """Whether at time ``t`` (s) the ghost is the clip (else the controller's reference)."""
        return self.clip is not None and t <= self.span + 1e-9

    def pose(self, t: float, i: int, body_xmat: FloatArray) -> FloatArray:
        """The ghost's qpos at time ``t`` (s), sample ``i`` of the trajectory (for the reference after
        the clip), the body's root orientation ``body_xmat`` (3x3, for its left)."""
        a = self.adr
        if self.shows_clip(t):
            assert self.clip is not None
            k = int(np.clip(round(self.start + t / self.frame_time), 0, len(self.clip) - 1))
            q = self.clip[k].copy()
            q[a:a + 2] = self.rot @ (q[a:a + 2] - self.clip_xy0) + self.body_xy0
            turned = np.zeros(4)
            mujoco.mju_mulQuat(turned, _yaw_quat(self.turn), q[a + 3:a + 7])
            q[a + 3:a + 7] = turned
            yaw = float(self.clip_yaw[k]) + self.turn
            q[a:a + 2] += self.offset * np.array([-math.sin(yaw), math.cos(yaw)])
            return q
        q = np.asarray(self.tr.ref_qpos[i], dtype=np.float64).copy()
        q[a:a + 2] = self.tr.qpos[i, a:a + 2]  # the reference's pose and heading at the body's place
        left = np.array([-body_xmat[1, 0], body_xmat[0, 0]])
        q[a:a + 2] += self.offset * left / max(float(np.linalg.norm(left)), 1e-9)
        return q

    def rgba(self, t: float) -> tuple[float, float, float, float]:
        return CLIP_RGBA if self.shows_clip(t) else REFERENCE_RGBA

    def label(self, t: float) -> str:
        """What the ghost is at ``t``, for the frame's caption."""
        return "ghost: clip" if self.shows_clip(t) else "ghost: reference"


__all__ = ["CLIP_RGBA", "REFERENCE_RGBA", "Ghost"]
