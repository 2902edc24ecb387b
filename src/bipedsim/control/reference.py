"""Gait sources behind one interface: a reference clip (looped at gait events) or SIMBICON key poses.

A source answers, for a reference frame ``F`` (float, unwrapped: it only grows) and an FSM state:
hinge targets and target velocities, the pelvis's heading-free target orientation, each thigh's
heading-free world target (for the swing hip), and the reference's own COM offset from the stance
ankle and COM velocity (heading frame) so balance feedback can act on deviations.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.balance import axis_rotation, heading_of, yaw_matrix
from bipedsim.control.config import PoseGait
from bipedsim.errors import ModelError
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.plan import BodyPlanSet

FloatArray = npt.NDArray[np.float64]
SIDES = ("right", "left")
#: A rollout starts this fraction of a step after the first right-foot strike of the loop.
START_AFTER_STRIKE = 0.05


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

    def nearest_strike(self, f: float, side: str) -> float | None:
        return None

    def state1_time(self) -> float:
        return 0.3

    def speed(self) -> float:
        return 0.0

    def step_time(self) -> float:
        return 0.5


class ClipSource(GaitSource):
    """A :class:`ReferenceClip`, looped from its first right-foot strike to its last one."""

    def __init__(self, clip: ReferenceClip, model: mujoco.MjModel, plan: BodyPlanSet, hinges: Hinges) -> None:
        if clip.qpos.shape[1] != model.nq:
            raise ModelError(f"reference clip has {clip.qpos.shape[1]} coordinates, the model {model.nq}: "
                             f"retarget the motion onto this model")
        if plan.profile != "humanoid":
            raise ModelError("the balance controller needs the humanoid profile (two legs)")
        self.clip = clip
        self.frame_time = clip.frame_time
        ri = clip.foot_names.index("right")
        li = clip.foot_names.index("left")
        rs = clip.events["right"]["strike"]
        ls = clip.events["left"]["strike"]
        if len(rs) < 2 or not ls:
            raise ModelError(f"the reference clip ({clip.source or 'clip'}) has {len(rs)} right and {len(ls)} "
                             f"left foot strikes: need two right strikes with a left one between to loop a "
                             f"gait cycle")
        self.a, self.b = float(rs[0]), float(rs[-1])
        self.period = self.b - self.a
        self.loop_start = self.a
        self.strikes = {"right": np.array([s for s in rs if self.a <= s < self.b], dtype=float),
                        "left": np.array([s for s in ls if self.a <= s < self.b], dtype=float)}
        if len(self.strikes["left"]) == 0:
            raise ModelError("no left foot strike inside the looped cycle")
        del ri, li
        self.hinge_qadr = hinges.qadr
        self.q = clip.qpos[:, hinges.qadr]
        self.qd = clip.qvel[:, hinges.dadr]
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
        root = clip.qpos[:, :2]
        self._speed = float(np.linalg.norm(root[int(self.b)] - root[int(self.a)]) / (self.period * self.frame_time))
        steps = np.sort(np.concatenate([self.strikes["right"], self.strikes["left"]]))
        self._step = float(np.mean(np.diff(np.append(steps, self.b)))) * self.frame_time

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

    def start_frame(self) -> float:
        """Where a rollout starts: just after the loop's first right-foot strike, when that foot
        already carries weight (starting exactly on the strike frame leaves neither foot loaded)."""
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
