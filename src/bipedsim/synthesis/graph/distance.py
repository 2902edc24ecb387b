"""Point-cloud distance between motion windows (Kovar, Gleicher & Pighin 2002), vectorised.

Frame i of one clip and frame j of another are compared through windows of ``k`` frames: the joint
positions of frames i..i+k-1 (resp. j..j+k-1) form two point clouds. The second cloud may be turned
about the vertical axis by theta and shifted on the floor by (x0, y0); the distance is the smallest
weighted sum of squared point distances over those transforms, which has a closed form:

    A = sum w (h . h') - (hbar . hbar') / W,   B = sum w (h x h') - (hbar x hbar') / W
    theta = atan2(B, A),   D = sum w |p|^2 + sum w |p'|^2 - |hbar|^2/W - |hbar'|^2/W
                              - 2 sqrt(A^2 + B^2) - 2 sum w z z'

with h the horizontal components, hbar = sum w h, x the 2-D cross product. All (i, j) pairs come from
a handful of matrix products -- no Python loop over frame pairs. Frame: Z up.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def windows(positions: FloatArray, k: int) -> FloatArray:
    """(T, J, 3) positions -> (T - k + 1, k * J, 3) clouds of k consecutive frames."""
    t = positions.shape[0]
    if t < k:
        raise ValueError(f"a clip of {t} frames has no window of {k} frames")
    v = np.lib.stride_tricks.sliding_window_view(positions, k, axis=0)  # (T-k+1, J, 3, k)
    return np.ascontiguousarray(np.moveaxis(v, 3, 1)).reshape(t - k + 1, k * positions.shape[1], 3)


def align_2d(p: FloatArray, q: FloatArray, w: FloatArray | None = None) -> tuple[float, float, float, float]:
    """Closed-form (theta, x0, y0, D) turning cloud ``q`` onto ``p`` (both (n, 3), Z up)."""
    w = np.ones(len(p)) if w is None else np.asarray(w, dtype=float)
    ws = w.sum()
    xb, yb = w @ p[:, 0], w @ p[:, 1]
    xq, yq = w @ q[:, 0], w @ q[:, 1]
    a = w @ (p[:, 0] * q[:, 0] + p[:, 1] * q[:, 1]) - (xb * xq + yb * yq) / ws
    b = w @ (p[:, 1] * q[:, 0] - p[:, 0] * q[:, 1]) - (yb * xq - xb * yq) / ws
    theta = float(np.arctan2(b, a))
    c, s = np.cos(theta), np.sin(theta)
    x0 = (xb - (c * xq - s * yq)) / ws
    y0 = (yb - (s * xq + c * yq)) / ws
    r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    d = float(w @ np.sum((p - (q @ r.T + [x0, y0, 0.0])) ** 2, axis=1))
    return theta, float(x0), float(y0), d


def apply_2d(points: FloatArray, theta: float, x0: float, y0: float) -> FloatArray:
    c, s = np.cos(theta), np.sin(theta)
    r = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return points @ r.T + np.array([x0, y0, 0.0])


#: Window values (windows x k x joints) compared at once: bounds the temporaries of one block of the
#: distance matrix (about a dozen float64 arrays of this many values, 100 MB) whatever the clips' length.
BLOCK_VALUES = 1_000_000


def distance_matrix(pa: FloatArray, pb: FloatArray, k: int, weights: FloatArray | None = None) -> FloatArray:
    """D[i, j] between the window starting at frame i of ``pa`` and at frame j of ``pb``
    ((T, J, 3) positions each); weights per joint (J,) or None. Computed in blocks of windows (at most
    :data:`BLOCK_VALUES` window values each), so memory beyond the result does not grow with the clips."""
    j = pa.shape[1]
    w = np.tile(np.ones(j) if weights is None else np.asarray(weights, dtype=float), k)
    na_, nb_ = pa.shape[0] - k + 1, pb.shape[0] - k + 1
    if na_ < 1 or nb_ < 1:
        raise ValueError(f"a clip of {min(pa.shape[0], pb.shape[0])} frames has no window of {k} frames")
    block = max(1, BLOCK_VALUES // (k * j))
    if na_ <= block and nb_ <= block:
        return _block(windows(pa, k), windows(pb, k), w)
    out = np.empty((na_, nb_))
    for i0 in range(0, na_, block):
        wa = windows(pa[i0:i0 + block + k - 1], k)
        for j0 in range(0, nb_, block):
            wb = windows(pb[j0:j0 + block + k - 1], k)
            out[i0:i0 + len(wa), j0:j0 + len(wb)] = _block(wa, wb, w)
    return out


def _block(wa: FloatArray, wb: FloatArray, w: FloatArray) -> FloatArray:
    """The distances between windows ``wa`` (Na, n, 3) and ``wb`` (Nb, n, 3), point weights ``w`` (n,)."""
    ws = float(w.sum())
    xa, ya, za = wa[..., 0] * w, wa[..., 1] * w, wa[..., 2] * w  # weighted (Na, n)
    xb, yb, zb = wb[..., 0], wb[..., 1], wb[..., 2]
    sxa, sya = xa.sum(axis=1), ya.sum(axis=1)
    sxb, syb = (xb * w).sum(axis=1), (yb * w).sum(axis=1)
    a = xa @ xb.T + ya @ yb.T - (np.outer(sxa, sxb) + np.outer(sya, syb)) / ws
    b = ya @ xb.T - xa @ yb.T - (np.outer(sya, sxb) - np.outer(sxa, syb)) / ws
    na = (xa * wa[..., 0]).sum(1) + (ya * wa[..., 1]).sum(1) - (sxa ** 2 + sya ** 2) / ws
    nb = ((xb ** 2 + yb ** 2) * w).sum(1) - (sxb ** 2 + syb ** 2) / ws
    zz = (za * wa[..., 2]).sum(1)[:, None] + ((zb ** 2) * w).sum(1)[None, :] - 2.0 * za @ zb.T
    d = na[:, None] + nb[None, :] - 2.0 * np.sqrt(a * a + b * b) + zz
    return np.maximum(d, 0.0)
