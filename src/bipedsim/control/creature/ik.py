"""Inverse kinematics of a creature's legs on the built body: damped least squares on each leg's
ball-joint degrees of freedom (warm-started from the last solution, pulled toward a posture in the null
space), each ball joint kept inside its range. A foot's own joints (a paw's, a toe's) are left at the
posture: a foot bent to reach is a foot folded under the load, and past its joint range.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.tracking import ball_joints

#: the orientation (3x3, world) leg i's foot site is aimed at, or None
Attitude = Callable[[int], "FloatArray | None"]

#: share of a ball joint's range the IK may use (the rest a margin to MuJoCo's limit)
RANGE_SHARE = 0.95


class LegIK:
    """Each leg's joints solved so its foot site reaches a target (m, world) and, where asked, its
    orientation (see the module text). ``sites``: the site each leg is placed by; ``held``: per leg,
    the foot bodies whose own joints stay at the posture."""

    def __init__(self, model: mujoco.MjModel, legs: LegSet, sites: list[int], held: list[tuple[str, ...]]) -> None:
        self.model, self.sites = model, sites
        #: the MjData the IK poses (never the simulation's)
        self.data = mujoco.MjData(model)
        #: the length (m) a rotation's radian weighs as, and the damping's scale: the leg height
        self.scale = legs.height
        leg_dofs = set(np.concatenate(legs.dofs).tolist()) if len(legs) else set()
        #: (qpos address, range less a margin, rad) of each limited leg ball joint
        self.limits = [(int(model.jnt_qposadr[j]), RANGE_SHARE * float(model.jnt_range[j, 1]))
                       for j in ball_joints(model) if model.jnt_limited[j] and int(model.jnt_dofadr[j]) in leg_dofs]
        #: per leg, the degrees of freedom the IK turns: the leg's, less its held feet's own
        self.dofs = []
        for i, feet in enumerate(held):
            foot_dofs = {int(model.body_dofadr[model.body(f).id]) + k for f in feet for k in range(3)
                         if model.body_dofnum[model.body(f).id]}
            self.dofs.append(np.array([v for v in legs.dofs[i] if v not in foot_dofs], dtype=np.int64))
        #: the last solution (a full qpos): the warm start of the next plan
        self.q = np.zeros(model.nq)

    def solve(self, q: FloatArray, feet: FloatArray, posture: FloatArray, pull: float, iters: int = 4,
              damping: float = 0.02, attitude: Attitude | None = None) -> None:
        """Each leg's joints (in ``q``, in place) so its foot site reaches ``feet[i]`` (m, world): damped
        least squares over the leg's DOFs (damping x the leg height), pulled toward ``posture`` (a qpos)
        by ``pull`` per iteration in the null space; ``attitude(i)``: the world orientation leg ``i``'s
        site is aimed at too, or None (its position only). The result is kept as :attr:`q`."""
        m, d = self.model, self.data
        lam2 = (damping * self.scale) ** 2
        jac, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for _ in range(iters):
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            dq = np.zeros(m.nv)
            diff = np.zeros(m.nv)
            mujoco.mj_differentiatePos(m, diff, 1.0, q, posture)
            for i, dofs in enumerate(self.dofs):
                err = feet[i] - d.site_xpos[self.sites[i]]
                mujoco.mj_jacSite(m, d, jac, jacr, self.sites[i])
                j = jac[:, dofs]
                # asked here, after the site's Jacobian: a first call may pose self.data to measure
                att = attitude(i) if attitude is not None else None
                if att is not None:  # the foot's attitude too, its radians weighed as leg_height m
                    cur = d.site_xmat[self.sites[i]].reshape(3, 3)
                    rot = Rotation.from_matrix(att @ cur.T).as_rotvec()
                    err = np.concatenate([err, self.scale * rot])
                    j = np.vstack([j, self.scale * jacr[:, dofs]])
                inv = np.linalg.solve(j @ j.T + lam2 * np.eye(len(err)), np.eye(len(err)))
                step = j.T @ inv @ err
                null = diff[dofs] - j.T @ inv @ (j @ diff[dofs])
                dq[dofs] = step + pull * null
            mujoco.mj_integratePos(m, q, dq, 1.0)
            self.clamp(q)
        self.q[:] = q

    def clamp(self, q: FloatArray) -> None:
        """Each leg ball joint's rotation (in ``q``, in place) kept inside its range (the cone MuJoCo
        enforces): a target past it is one the leg cannot take."""
        for qa, lim in self.limits:
            w = q[qa]
            v = q[qa + 1:qa + 4]
            angle = 2.0 * math.atan2(float(np.linalg.norm(v)), abs(float(w)))
            if angle > lim:
                axis = v / max(float(np.linalg.norm(v)), 1e-12) * (1.0 if w >= 0 else -1.0)
                q[qa] = math.cos(lim / 2)
                q[qa + 1:qa + 4] = axis * math.sin(lim / 2)

    def site_positions(self) -> FloatArray:
        """(legs, 3) each leg's site (m, world) as :attr:`data` is posed."""
        return np.array([self.data.site_xpos[s] for s in self.sites]).reshape(len(self.sites), 3)


__all__ = ["Attitude", "LegIK"]
