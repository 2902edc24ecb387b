"""Cycles of a clip (issue 19): the loop chosen by pose and velocity match at its seam and by steady
travel; the seam blended."""

from __future__ import annotations

import numpy as np

from bipedsim.control.reference import CYCLE_COST_TOLERANCE, best_cycle, blend_seam


def _walk(n: int = 600, dt: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hinge angles of a 1 s gait cycle; the root speeds up over the first second and slows down over
    the last (a start-walk-stop clip), walking 1.2 m/s between."""
    t = np.arange(n) * dt
    q = np.stack([np.sin(2 * np.pi * t), 0.5 * np.cos(2 * np.pi * t)], axis=1)
    q[:100] *= np.linspace(0.2, 1, 100)[:, None]  # the start: small steps
    q[-100:] *= np.linspace(1, 0.2, 100)[:, None]
    v = np.clip(np.minimum(t, t[-1] - t), 0, 1) * 1.2
    root = np.stack([np.cumsum(v) * dt, np.zeros(n)], axis=1)
    return q, np.gradient(q, dt, axis=0), root


def test_the_walking_part_is_looped_not_the_start_and_stop() -> None:
    q, qd, root = _walk()
    right = [0, 100, 200, 300, 400, 500, 599]
    left = [50, 150, 250, 350, 450, 550]
    c = best_cycle(q, qd, root, right, left, 0.01)
    assert c is not None and c.a >= 100 and c.b <= 500 and c.b - c.a >= 100
    # of equally good loops the longest: 100 -> 500 walks steadily all along
    assert (c.a, c.b) == (100, 500)
    assert c.cost <= CYCLE_COST_TOLERANCE + 1e-9


def test_no_loop_without_a_left_strike_between() -> None:
    q, qd, root = _walk()
    assert best_cycle(q, qd, root, [100, 200], [250], 0.01) is None


def test_seam_blend_makes_the_loop_continuous_and_keeps_the_rest() -> None:
    rows = np.arange(100, dtype=float)[:, None] * np.ones((1, 2))  # a ramp: a jump of 40 at the seam
    out = blend_seam(rows, 30, 70, 10)
    assert np.allclose(out[:60], rows[:60]) and np.allclose(out[70:], rows[70:])
    # played in a loop, b - 1 then a: the last row is the row before a, so the step is the clip's own
    assert np.allclose(out[69], rows[29])
    assert np.allclose(out[30] - out[69], rows[30] - rows[29])
    # the 40 jump spread over 10 frames: smoothstep slope at most 1.5 x 40 / 10, plus the ramp of 1
    assert np.abs(np.diff(out[59:70, 0])).max() <= 1.5 * 40 / 10 + 1 + 1e-9
