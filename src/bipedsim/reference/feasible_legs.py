"""A humanoid leg on the built MuJoCo body, as the feasible reference uses it: its bodies, hinges (qpos and
dof addresses, ranges) and length, and the legs' kinematics over a clip's frames (hip and ankle positions,
sole rotations, the sole's lowest point; the centre of mass). Positions in m, world frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError

FloatArray = npt.NDArray[np.float64]


SIDES = ("right", "left")


@dataclass
class _Leg:
    """One leg's bodies, hinges (qpos/dof addresses, ranges) and lengths on the built model."""

    side: str
    thigh: int
    foot: int
    toe: int | None
    foot_geom: int
    toe_geom: int | None
    qadr: npt.NDArray[np.int64]
    dadr: npt.NDArray[np.int64]
    lo: FloatArray
    hi: FloatArray
    length: float  #: thigh + shin (m)
    toe_dofs: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))
    knee_dofs: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))

    @staticmethod
    def of(model: mujoco.MjModel, side: str) -> _Leg:
        def body(name: str) -> int | None:
            b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{side}_{name}")
            return None if b < 0 else int(b)

        thigh, shin, foot, toe = body("thigh"), body("shin"), body("foot"), body("toe")
        if thigh is None or shin is None or foot is None:
            raise ModelError(f"the feasible reference needs a humanoid leg ({side} thigh, shin, foot)")
        bodies = [b for b in (thigh, shin, foot, toe) if b is not None]
        jids = [j for j in range(model.njnt) if model.jnt_bodyid[j] in bodies
                and model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
        geom = {b: next((g for g in range(model.ngeom) if model.geom_bodyid[g] == b
                         and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX), None) for b in (foot, toe)}
        if geom[foot] is None:
            raise ModelError(f"the feasible reference needs box feet ({side} foot has no box)")
        length = float(np.linalg.norm(model.body_pos[shin]) + np.linalg.norm(model.body_pos[foot]))
        return _Leg(side, thigh, foot, toe, int(geom[foot]), None if toe is None else geom[toe],
                    np.array([model.jnt_qposadr[j] for j in jids]), np.array([model.jnt_dofadr[j] for j in jids]),
                    model.jnt_range[jids, 0].copy(), model.jnt_range[jids, 1].copy(), length,
                    np.array([model.jnt_bodyid[j] == toe for j in jids]),
                    np.array([model.jnt_bodyid[j] == shin for j in jids]))


def _kinematics(model: mujoco.MjModel, qpos: FloatArray, legs: dict[str, _Leg]) -> dict[str, dict[str, FloatArray]]:
    """Per side: hip joint positions (T, 3), ankle positions (T, 3), sole-box rotations (T, 3, 3) and
    the sole's lowest point (T,) over the clip's frames."""
    data = mujoco.MjData(model)
    n = len(qpos)
    out = {s: {"hip": np.zeros((n, 3)), "ankle": np.zeros((n, 3)), "sole": np.zeros((n, 3, 3)),
               "low": np.zeros(n)} for s in legs}
    for t in range(n):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        for s, leg in legs.items():
            o = out[s]
            o["hip"][t] = data.xpos[leg.thigh]
            o["ankle"][t] = data.xpos[leg.foot]
            o["sole"][t] = data.geom_xmat[leg.foot_geom].reshape(3, 3)
            o["low"][t] = min(_lowest(model, data, g) for g in (leg.foot_geom, leg.toe_geom) if g is not None)
    return out


def _com_path(model: mujoco.MjModel, qpos: FloatArray) -> FloatArray:
    """(T, 3) the body's centre of mass over the frames."""
    data = mujoco.MjData(model)
    out = np.zeros((len(qpos), 3))
    for t in range(len(qpos)):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        out[t] = data.subtree_com[1]
    return out


def _lowest(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    r = data.geom_xmat[g].reshape(3, 3)
    return float(data.geom_xpos[g][2] - np.abs(r[2]) @ model.geom_size[g])
