"""Leg inverse kinematics on the built body: per leg and frame, a projected Levenberg-Marquardt on the
foot's position and sole orientation (and the toe's), within the joints' ranges, lightly pulled toward the
clip's angles, restarted with the knee bent where it stalls with the leg straight. Angles in rad."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.reference.feasible_legs import _Leg

FloatArray = npt.NDArray[np.float64]


#: IK residual weights: foot position (per m), sole tilt (per rad), foot heading (per rad), toe tilt
#: and heading, pull toward the clip's angles (per rad).
W_POS, W_TILT, W_YAW, W_TOE, W_REG = 1.0, 0.3, 0.1, 0.1, 0.01
#: IK iterations per frame at most, and the step (rad) below which it stops.
IK_ITERS, IK_TOL = 30, 1e-7
#: A solve that leaves the foot farther than this (m) from its target is restarted with the knee bent
#: :data:`KNEE_ESCAPE` (rad) off its straight end: from a straight knee, bending moves the foot only to
#: second order toward the hip, so the solver stalls there with the leg at full length (games105's
#: first frame, 3.6 cm short, the leg 1.000 of its length).
IK_REACH_TOL, KNEE_ESCAPE = 0.005, 0.3
#: A knee within this (rad) of its straight end counts as straight (the restart's case).
KNEE_STRAIGHT = 1e-3


def _log(r: FloatArray) -> FloatArray:
    """The rotation vector of a 3x3 rotation (scipy's per-call cost is 100 us; this ~5 us)."""
    c = min(max((r[0, 0] + r[1, 1] + r[2, 2] - 1.0) * 0.5, -1.0), 1.0)
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    ang = float(np.arccos(c))
    if ang < 1e-6:
        return 0.5 * v
    if np.pi - ang < 1e-3:
        return Rotation.from_matrix(r).as_rotvec()
    return (ang / (2.0 * np.sin(ang))) * v


def solve_leg(model: mujoco.MjModel, data: mujoco.MjData, leg: _Leg, q0: FloatArray, q_clip: FloatArray,
              ankle: FloatArray, r_sole: FloatArray, r_toe: FloatArray) -> FloatArray:
    """Leg hinge angles (within their ranges) putting the foot body's origin at ``ankle`` (m) with its
    sole box level at heading ``psi`` (and the toe box level alike), from ``q0``; ``data.qpos`` holds
    the rest of the pose. Projected Levenberg-Marquardt on the body's own kinematics."""
    r_fg = data.geom_xmat  # views refreshed by mj_kinematics
    q = np.clip(q0.copy(), leg.lo, leg.hi)
    jacp = np.zeros((3, model.nv))
    jacr = np.zeros((3, model.nv))
    lam = 1e-4
    nres = 6 + (3 if leg.toe_geom is not None else 0) + len(q)
    res = np.zeros(nres)
    jac = np.zeros((nres, len(q)))
    wrot = np.array([W_TILT, W_TILT, W_YAW])

    def evaluate(qq: FloatArray) -> float:
        data.qpos[leg.qadr] = qq
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        res[:3] = W_POS * (data.xpos[leg.foot] - ankle)
        rg = r_fg[leg.foot_geom].reshape(3, 3)
        res[3:6] = wrot * _log(rg @ r_sole.T)
        mujoco.mj_jacBody(model, data, jacp, jacr, leg.foot)
        jac[:3] = W_POS * jacp[:, leg.dadr]
        jac[3:6] = wrot[:, None] * jacr[:, leg.dadr]
        if leg.toe_geom is not None and leg.toe is not None:
            rt = r_fg[leg.toe_geom].reshape(3, 3)
            res[6:9] = W_TOE * _log(rt @ r_toe.T)
            mujoco.mj_jacBody(model, data, jacp, jacr, leg.toe)
            jac[6:9] = W_TOE * jacr[:, leg.dadr]
        res[-len(qq):] = W_REG * (qq - q_clip)
        jac[-len(qq):] = W_REG * np.eye(len(qq))
        return float(res @ res)

    cost = evaluate(q)
    for _ in range(IK_ITERS):
        g = jac.T @ res
        h = jac.T @ jac
        r0, j0 = res.copy(), jac.copy()
        step = np.linalg.solve(h + lam * np.diag(np.diag(h) + 1e-9), -g)
        qn = np.clip(q + step, leg.lo, leg.hi)
        cn = evaluate(qn)
        if cn < cost:
            moved = float(np.max(np.abs(qn - q)))
            q, cost, lam = qn, cn, max(lam * 0.3, 1e-9)
            if moved < IK_TOL:
                break
        else:
            res[:], jac[:] = r0, j0
            lam *= 10.0
            if lam > 1e6:
                break
    data.qpos[leg.qadr] = q
    return q


def solve_reaching(model: mujoco.MjModel, data: mujoco.MjData, leg: _Leg, q0: FloatArray, q_clip: FloatArray,
                   ankle: FloatArray, r_sole: FloatArray, r_toe: FloatArray) -> FloatArray:
    """:func:`solve_leg`, restarted with the knee bent (:data:`KNEE_ESCAPE`) where it ended with the knee
    straight and the foot more than :data:`IK_REACH_TOL` off its target; the solution nearer the target
    is kept."""
    q = solve_leg(model, data, leg, q0, q_clip, ankle, r_sole, r_toe)
    if not leg.knee_dofs.any():
        return q
    lo, hi = leg.lo[leg.knee_dofs], leg.hi[leg.knee_dofs]
    straight = np.where(np.abs(lo) <= np.abs(hi), lo, hi)  # the end of the range nearer 0: a straight knee
    miss = float(np.linalg.norm(data.xpos[leg.foot] - ankle))
    if miss <= IK_REACH_TOL or np.any(np.abs(q[leg.knee_dofs] - straight) > KNEE_STRAIGHT):
        return q
    bent = q.copy()
    bent[leg.knee_dofs] = np.clip(straight + np.sign(lo + hi) * KNEE_ESCAPE, lo, hi)
    q2 = solve_leg(model, data, leg, bent, q_clip, ankle, r_sole, r_toe)
    if float(np.linalg.norm(data.xpos[leg.foot] - ankle)) < miss:
        return q2
    data.qpos[leg.qadr] = q
    mujoco.mj_kinematics(model, data)
    return q
