"""Where a clip's feet meet the floor: the lowest point of each foot body's geoms on every frame, the
tilt of the capture's floor under the stance feet, and the clip levelled and lifted so its feet touch
z = 0. Heights in m, world frame (Z up)."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def _put_on_floor(qpos: FloatArray, low: FloatArray, fpos: FloatArray, dt: float,
                  speed: float) -> tuple[FloatArray, tuple[float, float] | None, float]:
    """Level a tilted capture floor (:func:`floor_tilt`), then lift so the lowest point any foot
    reaches touches z = 0. Shifts the root height in ``qpos`` (T, nq) and the foot positions ``fpos``
    (T, F, 3; m) in place; returns the feet's lowest points ``low`` (T, F; m) shifted alike, the floor
    slope (or None) and the lift (m)."""
    tilt = floor_tilt(low, fpos, dt, speed)
    if tilt is not None:
        dz = -(tilt[0] * qpos[:, 0] + tilt[1] * qpos[:, 1])
        qpos[:, 2] += dz
        low = low + dz[:, None]
        fpos[..., 2] += dz[:, None]
    lift = -float(np.min(low))
    qpos[:, 2] += lift
    low = low + lift
    fpos[..., 2] += lift
    return low, tilt, lift


#: Minimum stance samples and horizontal spread (m) for fitting the capture's floor plane.
FLOOR_FIT_MIN_SAMPLES = 20
FLOOR_FIT_MIN_SPREAD_M = 0.5
#: Largest floor slope (rise per metre) corrected; steeper means real terrain, not a tilted capture.
FLOOR_FIT_MAX_SLOPE = 0.05


def floor_tilt(low: FloatArray, pos: FloatArray, dt: float, speed: float) -> tuple[float, float] | None:
    """Slope (dz/dx, dz/dy) of the floor under the stance feet, or None if it cannot be told.

    Stance samples: a foot moving slower than ``speed`` and in the lowest 30 % of its heights. The
    plane is fitted by least squares, refitted without samples more than 2 cm off.
    """
    if len(low) < 3:
        return None
    sp = np.linalg.norm(np.gradient(pos[..., :2], dt, axis=0), axis=-1)
    mask = (sp < speed) & (low <= np.percentile(low, 30, axis=0))
    xy, z = pos[..., :2][mask], low[mask]
    if len(z) < FLOOR_FIT_MIN_SAMPLES:
        return None
    # fit the slope only along directions the feet actually cover (a straight walk spans one)
    centred = xy - xy.mean(axis=0)
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    spread = 4.0 * sv / np.sqrt(len(z))  # ~ the samples' extent along each principal direction
    dirs = vt[spread >= FLOOR_FIT_MIN_SPREAD_M]
    if len(dirs) == 0:
        return None
    a = np.concatenate([centred @ dirs.T, np.ones((len(z), 1))], axis=1)
    coef = np.linalg.lstsq(a, z, rcond=None)[0]
    keep = np.abs(a @ coef - z) < 0.02
    if keep.sum() >= FLOOR_FIT_MIN_SAMPLES:
        coef = np.linalg.lstsq(a[keep], z[keep], rcond=None)[0]
    slope = coef[:-1] @ dirs  # back to (dz/dx, dz/dy)
    if np.hypot(*slope) > FLOOR_FIT_MAX_SLOPE:
        return None
    return float(slope[0]), float(slope[1])


def foot_heights(model: mujoco.MjModel, qpos: FloatArray, feet: list[str]) -> tuple[FloatArray, FloatArray]:
    """Lowest point (T, F) of each foot body's geoms and the body positions (T, F, 3) per frame."""
    data = mujoco.MjData(model)
    bids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f) for f in feet]
    geoms = [[gi for gi in range(model.ngeom) if model.geom_bodyid[gi] == b] for b in bids]
    low = np.zeros((len(qpos), len(feet)))
    pos = np.zeros((len(qpos), len(feet), 3))
    for t, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for k, gl in enumerate(geoms):
            low[t, k] = min(geom_lowest_z(model, data, gi) for gi in gl)
            pos[t, k] = data.xpos[bids[k]]
    return low, pos


def geom_lowest_z(model: mujoco.MjModel, data: mujoco.MjData, gi: int) -> float:
    """Lowest world z of a geom (box, capsule or sphere) in the current pose."""
    c = data.geom_xpos[gi]
    r = data.geom_xmat[gi].reshape(3, 3)
    s = model.geom_size[gi]
    typ = model.geom_type[gi]
    if typ == mujoco.mjtGeom.mjGEOM_BOX:
        return float(c[2] - np.abs(r[2]) @ s)
    if typ == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return float(c[2] - abs(r[2, 2]) * s[1] - s[0])
    return float(c[2] - s[0])
