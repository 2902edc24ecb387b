"""The feasible reference's pelvis: the centre of mass shifted so its linear-inverted-pendulum ZMP follows
the stance feet (:func:`pendulum_shift`), and the pelvis lowered where a leg would be straighter than
allowed (:func:`pelvis_drop`). Shifts in m, world frame."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.ndimage import maximum_filter1d, uniform_filter1d
from scipy.sparse import diags, vstack
from scipy.sparse.linalg import spsolve

from bipedsim.reference.feasible_feet import FootPlan, _runs
from bipedsim.reference.feasible_legs import _Leg

FloatArray = npt.NDArray[np.float64]


GRAVITY = 9.81


def pendulum_shift(com: FloatArray, feet: dict[str, FootPlan], dt: float, weight: float) -> FloatArray:
    """(T, 2) horizontal shift (m) of the centre of mass ``com`` (T, 3) that makes its linear-inverted-
    pendulum ZMP, c - c''/w^2 (w^2 = g / the mean COM height), follow the stance feet's centre of pressure
    (one foot's in single support; in double support moving from the trailing foot's to the leading
    one's): least squares of ``weight`` x the ZMP's error against the shift itself, per axis."""
    n = len(com)
    w2 = GRAVITY / max(float(np.mean(com[:, 2])), 0.1)
    cops = np.stack([f.cop for f in feet.values()], axis=0)  # (S, T, 3)
    down = ~np.isnan(cops[..., 0])
    target = np.full((n, 2), np.nan)
    one = down.sum(axis=0) == 1
    for k in range(len(cops)):
        sel = one & down[k]
        target[sel] = cops[k, sel, :2]
    both = down.all(axis=0)
    for a, b in _runs(both):
        # the leading foot: the one whose stance began later
        start = [a - int(np.argmin(down[k, :a + 1][::-1])) if not down[k, :a + 1].all() else 0
                 for k in range(len(cops))]
        lead = int(np.argmax(start))
        u = (np.arange(a, b) - a + 0.5) / (b - a)
        target[a:b] = (1 - u)[:, None] * cops[1 - lead, a:b, :2] + u[:, None] * cops[lead, a:b, :2]
    rows = np.flatnonzero(~np.isnan(target[:, 0]))
    rows = rows[(rows > 0) & (rows < n - 1)]
    if len(rows) == 0 or weight <= 0:
        return np.zeros((n, 2))
    k2 = 1.0 / (w2 * dt * dt)
    # ZMP z = c - k2 (c[t-1] - 2 c[t] + c[t+1]) as a sparse operator on the whole path
    zmp = diags([-k2 * np.ones(n - 1), (1 + 2 * k2) * np.ones(n), -k2 * np.ones(n - 1)], [-1, 0, 1], format="csr")
    a_mat = vstack([diags(np.ones(n)), weight * zmp[rows]]).tocsc()
    out = np.zeros((n, 2))
    for ax in range(2):
        rhs = np.concatenate([np.zeros(n), weight * (target[rows, ax] - zmp[rows] @ com[:, ax])])
        out[:, ax] = spsolve((a_mat.T @ a_mat).tocsc(), a_mat.T @ rhs)
    return out


def pelvis_drop(kin: dict[str, dict[str, FloatArray]], feet: dict[str, FootPlan], legs: dict[str, _Leg],
                max_extension: float, dt: float, smooth_s: float) -> FloatArray:
    """(T,) how far (m) the pelvis goes down so that no leg reaches farther than ``max_extension`` of its
    length, spread over ``smooth_s`` s (a running maximum, then a moving average of as many frames)."""
    need = np.zeros(len(next(iter(kin.values()))["hip"]))
    for s, leg in legs.items():
        hip, ank = kin[s]["hip"], feet[s].ankle
        reach = max_extension * leg.length
        horiz = np.linalg.norm(hip[:, :2] - ank[:, :2], axis=1)
        dz = hip[:, 2] - ank[:, 2]
        ok = np.sqrt(np.maximum(reach ** 2 - horiz ** 2, 0.0))
        need = np.maximum(need, dz - ok)
    w = max(1, int(round(smooth_s / dt)))
    if w > 1:
        need = uniform_filter1d(maximum_filter1d(need, size=w, mode="nearest"), size=w, mode="nearest")
    return need
