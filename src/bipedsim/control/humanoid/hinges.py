"""A humanoid model's hinge joints as the controller indexes them, and its feet's lowest points."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.model.plan import BodyPlanSet

#: the sides, in the order the controller's tables list them
SIDES = ("right", "left")


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


def foot_points(model: mujoco.MjModel, side: str) -> list[int]:
    """The bodies whose origins stand for a foot's lowest point: the foot (ankle) and its toe if any."""
    names = [f"{side}_foot", f"{side}_toe"]
    return [model.body(x).id for x in names if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, x) >= 0]
