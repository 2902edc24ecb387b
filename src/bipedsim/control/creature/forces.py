"""The creature's virtual forces on its stance feet: a wanted wrench on the body shared among the feet
that touch the ground, each foot's force kept inside its friction cone, and a horizontal force held to
what the support polygon can carry (the zero-moment point inside it).

Forces in N, torques in N*m, points in m; world frame, Z up.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from bipedsim.control.base import FloatArray


def distribute_wrench(force: FloatArray, torque: FloatArray, points: FloatArray, com: FloatArray,
                      reg: float = 1e-6) -> FloatArray:
    """(N, 3) least-norm contact forces (N) at ``points`` (N, 3; m, world) whose sum is ``force`` and
    whose moment about ``com`` is ``torque`` (N*m), as nearly as the points allow."""
    n = len(points)
    a = np.zeros((6, 3 * n))
    for i, p in enumerate(points):
        r = p - com
        a[0:3, 3 * i:3 * i + 3] = np.eye(3)
        a[3:6, 3 * i:3 * i + 3] = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    w = np.concatenate([force, torque])
    scale = max(float(np.trace(a @ a.T)) / 6.0, 1e-9)
    f = a.T @ np.linalg.solve(a @ a.T + reg * scale * np.eye(6), w)
    return f.reshape(n, 3)


def in_cone(f: FloatArray, friction: float) -> FloatArray:
    """``f`` (N) with a pushing vertical part (>= 0) and its horizontal part inside the friction cone
    of coefficient ``friction``."""
    fz = max(float(f[2]), 0.0)
    h = f[0:2]
    n = float(np.linalg.norm(h))
    cap = friction * fz
    if n > cap:
        h = h * (cap / n)
    return np.array([h[0], h[1], fz])


def zmp_limited(force_h: FloatArray, com: FloatArray, feet: FloatArray, weight: float) -> FloatArray:
    """The horizontal force ``force_h`` (N, world) on a body of ``weight`` (N) with its centre of mass
    at ``com`` (m, world), scaled down (never turned) so the zero-moment point it implies,
    com_xy - h force_h / weight (h: the centre of mass's height over the feet), stays inside the convex
    hull of ``feet`` (k, 3; m, world). Fewer than three feet, or feet in a line, leave it as it is."""
    if len(feet) < 3:
        return force_h
    try:
        hull = ConvexHull(feet[:, 0:2])
    except QhullError:
        return force_h
    h = float(com[2] - feet[:, 2].mean())
    u = -h * np.asarray(force_h) / weight
    alpha = 1.0
    for nx, ny, off in hull.equations:  # n . x + off <= 0 inside
        inside = -(nx * com[0] + ny * com[1] + off)
        out = nx * u[0] + ny * u[1]
        if out > 1e-12:
            alpha = min(alpha, max(inside, 0.0) / out)
    return alpha * np.asarray(force_h)


__all__ = ["distribute_wrench", "in_cone", "zmp_limited"]
