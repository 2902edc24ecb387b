"""Transition blending: time warp of two intervals to one length m, and the blend weights.

``B_n = FI'_n P(n) + TI'_n (1 - P(n))`` with ``P(n) = n^2 / m^2`` (quadratic Bezier weights), ``n`` the
frames left in the transition (m at its first frame: all FI, the clip left; 0 at its last: all TI, the
clip entered, which it joins with zero slope). Linear and smoothstep weights are here for comparison
(benchmarks/world.py).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def quadratic_weights(m: int) -> FloatArray:
    """P(n) = n^2 / m^2 for n = m, m-1, ..., 0 (the weight of the clip left, per transition frame)."""
    n = np.arange(m, -1, -1, dtype=float)
    return n * n / float(m * m) if m > 0 else np.zeros(1)


def linear_weights(m: int) -> FloatArray:
    """A linear cross-fade: n / m."""
    n = np.arange(m, -1, -1, dtype=float)
    return n / float(m) if m > 0 else np.zeros(1)


def smoothstep_weights(m: int) -> FloatArray:
    """Smoothstep: 3u^2 - 2u^3 with u = n / m."""
    u = linear_weights(m)
    return 3 * u * u - 2 * u ** 3


WEIGHTS: dict[str, Callable[[int], FloatArray]] = {"quadratic": quadratic_weights, "linear": linear_weights,
                                                   "smoothstep": smoothstep_weights}


def warp_times(start: float, length: float, m: int) -> FloatArray:
    """Frame positions (fractional) of an interval of ``length`` frames from ``start``, time-warped to m + 1
    samples (linear in time): start, start + length/m, ..., start + length."""
    return start + np.linspace(0.0, length, m + 1)


def slerp(q0: FloatArray, q1: FloatArray, t: FloatArray | float) -> FloatArray:
    """Spherical interpolation of unit quaternions (..., 4), scalar last; ``t`` broadcast over (...)."""
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None] if np.ndim(t) else float(t)
    d = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(d < 0, -q1, q1)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    s = np.sin(theta)
    small = s < 1e-6
    s = np.where(small, 1.0, s)
    a = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / s)
    b = np.where(small, t, np.sin(t * theta) / s)
    out = a * q0 + b * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)
