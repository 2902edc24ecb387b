"""A feed-forward correction under the humanoid controller: offsets found per short window of the clip.

Sampling-based control reconstruction (Liu et al. 2010, "Sampling-based contact-rich motion control")
finds, window by window, offsets of the controller's targets that keep the simulated body on the clip;
:mod:`bipedsim.sim.reconstruct` runs that search. The result is a :class:`Correction`: from each
window's first reference frame on, one row of offsets added to the targets, until the next window's.
It is looked up by the reference frame, not by time, so where the gait clock is hurried or held the
offsets stay with the part of the clip they were found for; the balance feedback acts on top. A
:class:`Nominal` is the path the correction was found for: off it, beyond ``reconstruct.reach``, the
controller lets the correction go (docs/controller.md, *Reconstruction*).

A row holds, in order (rad): one offset per hinge (added to its PD target; the ankles' to their
world-frame targets' angles), then the swing hip's sagittal and coronal feedback angles (added to eq. 6's
``c_d d + c_v v``), then the torso's pitch and roll (turning the pelvis's target about the heading
frame's lateral and forward axes).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
#: offsets per row beyond the hinges': swing hip sagittal, swing hip coronal, torso pitch, torso roll
EXTRA = 4


@dataclass(frozen=True)
class Correction:
    """Offset rows (K, hinges + :data:`EXTRA`) (rad), row k from reference frame ``starts[k]`` until
    ``starts[k + 1]``; none before the first. From ``end`` on: with a ``period`` (frames, the looped
    cycle's, searched to its end at least once) the rows of the last period repeat, phase for phase;
    without one the last row fades out linearly over ``fade`` frames (the controller alone carries on)."""

    starts: tuple[float, ...]
    rows: FloatArray
    end: float
    fade: float = 0.0
    period: float = 0.0

    def __post_init__(self) -> None:
        self.rows.setflags(write=False)

    @property
    def hinges(self) -> int:
        return int(self.rows.shape[1]) - EXTRA

    def at(self, frame: float) -> FloatArray | None:
        """The offsets at reference ``frame``; None where there are none."""
        if frame >= self.end and self.period > 0.0:
            frame -= self.period * (math.floor((frame - self.end) / self.period) + 1.0)
        elif frame >= self.end:
            left = 1.0 - (frame - self.end) / self.fade if self.fade > 0.0 else 0.0
            return self.rows[-1] * left if left > 0.0 else None
        k = bisect.bisect_right(self.starts, frame) - 1
        return self.rows[k] if k >= 0 else None

    def to_dict(self) -> dict[str, object]:
        return {"starts": list(self.starts), "rows": self.rows.tolist(), "end": self.end, "fade": self.fade,
                "period": self.period}

    @staticmethod
    def from_dict(d: dict[str, object], hinges: int) -> Correction:
        """A correction read back (:meth:`to_dict`); ValueError if its shape or values are wrong."""
        starts = tuple(float(v) for v in d["starts"])  # type: ignore[union-attr]
        rows = np.asarray(d["rows"], dtype=float)
        end = float(d["end"])  # type: ignore[arg-type]
        fade = float(d["fade"])  # type: ignore[arg-type]
        period = float(d.get("period", 0.0))  # type: ignore[arg-type]
        if rows.ndim != 2 or rows.shape != (len(starts), hinges + EXTRA):
            raise ValueError(f"rows of shape {rows.shape}, expected ({len(starts)}, {hinges + EXTRA})")
        if not (np.all(np.isfinite(rows)) and np.all(np.abs(rows) <= math.pi)):
            raise ValueError("offsets must be finite angles within +-pi rad")
        if (list(starts) != sorted(starts) or not all(math.isfinite(v) for v in (end, fade, period))
                or fade < 0.0 or period < 0.0):
            raise ValueError("window starts must be increasing frames, the end finite, the fade and the period "
                             ">= 0 frames")
        if period > 0.0 and (not starts or end - period < starts[0]):
            raise ValueError("a repeated period must lie within the searched frames")
        return Correction(starts=starts, rows=rows, end=end, fade=fade, period=period)


@dataclass(frozen=True)
class Nominal:
    """Where a correction's own rollout had the body, by reference frame: the path a correction was
    searched for (a noiseless run with it from the start), so that a run knows when it has left it.

    ``frames`` (N,) the reference frame of each control step (not decreasing), ``com`` (N, 4) the centre
    of mass's offset from the stance ankle and its velocity in the heading frame (m, m/s; the balance
    law's d and v), ``left`` (N,) whether that stance ankle was the left. ``end`` and ``period`` (frames):
    the correction's; past ``end`` a frame is looked up a whole number of periods earlier, as the
    correction's rows are (no period: the path is known up to its last frame only). ``window`` (frames):
    where the nearest sample stands on the other foot (a strike a little sooner or later than the
    path's), the nearest on the same foot within this many frames is compared."""

    frames: FloatArray
    com: FloatArray
    left: npt.NDArray[np.bool_]
    end: float = math.inf
    period: float = 0.0
    window: float = 0.0

    def __post_init__(self) -> None:
        # plain lists: the lookup runs on every control step, where numpy's per-call cost dominates
        object.__setattr__(self, "_f", [float(v) for v in self.frames])
        object.__setattr__(self, "_c", [tuple(float(x) for x in r) for r in np.asarray(self.com).reshape(-1, 4)])
        object.__setattr__(self, "_l", [bool(v) for v in self.left])

    def deviation(self, frame: float, com: tuple[float, float, float, float], left: bool,
                  omega: float) -> float | None:
        """How far (m) the body's capture point (``d + v / omega`` per plane, ``com`` as :attr:`com`, from
        the ``left`` or right stance ankle) lies from the path's at reference ``frame``: inf where the
        path stands on the other foot, None where the path does not reach ``frame``."""
        f: list[float] = self._f  # type: ignore[attr-defined]
        n = len(f)
        if n == 0:
            return None
        if frame >= self.end and self.period > 0.0:
            frame -= self.period * (math.floor((frame - self.end) / self.period) + 1.0)
        if frame < f[0] or frame > f[-1]:
            return None
        k = bisect.bisect_left(f, frame)
        if k > 0 and (k == n or frame - f[k - 1] <= f[k] - frame):
            k -= 1
        side: list[bool] = self._l  # type: ignore[attr-defined]
        if side[k] != left:  # the nearest sample on the same foot, within the window
            lo, hi, best = k - 1, k + 1, -1
            while best < 0 and (lo >= 0 and frame - f[lo] <= self.window or hi < n and f[hi] - frame <= self.window):
                if lo >= 0 and side[lo] == left and frame - f[lo] <= self.window:
                    best = lo
                elif hi < n and side[hi] == left and f[hi] - frame <= self.window:
                    best = hi
                lo, hi = lo - 1, hi + 1
            if best < 0:
                return math.inf
            k = best
        c = self._c[k]  # type: ignore[attr-defined]
        return math.hypot(com[0] - c[0] + (com[2] - c[2]) / omega, com[1] - c[1] + (com[3] - c[3]) / omega)


class LiveCorrection:
    """The correction a search is building: one row at a time, set by the search for its window
    (:meth:`set`); :meth:`at` gives it on every control step and notes the frame the row began at."""

    def __init__(self, hinges: int) -> None:
        self.row = np.zeros(hinges + EXTRA)
        self.started: float | None = None  #: the reference frame of the row's first control step

    def set(self, row: FloatArray) -> None:
        self.row = row
        self.started = None

    def at(self, frame: float) -> FloatArray:
        if self.started is None:
            self.started = frame
        return self.row


def torso_offset(pitch: float, roll: float) -> FloatArray:
    """The heading-frame rotation turning the pelvis's target by ``pitch`` about the lateral axis, then
    ``roll`` about the forward axis (rad)."""
    cp, sp, cr, sr = math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
    r_y = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    r_x = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return r_x.dot(r_y)
