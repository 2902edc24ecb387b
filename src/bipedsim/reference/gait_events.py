"""Foot contacts and gait events of a real walk, measured from the clip itself.

Each foot point (a humanoid's heel -- the foot body -- and toe, separately) is in contact on a frame
when it is near its own ground level and nearly still:

- the signals are smoothed over :data:`SMOOTH_S` seconds first (noise, any frame rate);
- ground: the lowest point of that foot over a moving window (:func:`ground_level`: a floor that
  drifts over the capture); the point's resting level: its :data:`LEVEL_PERCENTILE` th-percentile height above
  that ground (a heel rests higher than a toe); "near" is within
  :data:`HEIGHT_FRACTION` of the point's lift (its 95th-percentile height above the level), within
  :data:`MIN_HEIGHT_M` .. :data:`MAX_HEIGHT_M` -- a shuffling walk lifts its feet 5 cm, a march 30 cm;
- "still": horizontal speed below :data:`SPEED_FRACTION` of the point's fast speed (its
  95th-percentile speed: the swing), at least :data:`MIN_SPEED_MPS` -- a capture's stance foot slides.

A stance begins near and still and lasts while the point stays within :data:`HOLD_FACTOR` of both
thresholds (hysteresis). A side is in contact when its heel or its toe is; contact runs are debounced
(:func:`~bipedsim.reference.clip.debounce`). Gait events given by hand (:func:`load_events`) replace the
detected strikes where detection fails.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import numpy.typing as npt
from scipy.ndimage import minimum_filter1d

from bipedsim.config import load_yaml
from bipedsim.errors import ConfigError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Smoothing window (s) of heights and positions before speeds are taken.
SMOOTH_S = 0.05
#: Window (s) over which the lowest foot point is the ground (:func:`ground_level`).
GROUND_WINDOW_S = 1.5
#: Percentile of a point's heights above the ground taken as its resting level.
LEVEL_PERCENTILE = 5.0
#: A point is near the ground within this fraction of its lift (95th percentile above the level; a
#: stance foot rolling from heel to toe changes its lowest point by a few centimetres)...
HEIGHT_FRACTION = 0.6
#: ...and never closer than this (m): a capture's resting foot jitters by a centimetre or two...
MIN_HEIGHT_M = 0.02
#: ...nor farther (m): a high step (a stair, an obstacle) says nothing about how high a foot rests.
MAX_HEIGHT_M = 0.04
#: A point is still below this fraction of its swing speed (95th-percentile horizontal speed)...
SPEED_FRACTION = 0.15
#: ...and below at least this (m/s).
MIN_SPEED_MPS = 0.2
#: Hysteresis: once down, a point stays down while within this factor of both thresholds (a stance
#: foot rocks from heel to toe and slides a little without lifting).
HOLD_FACTOR = 2.0


def smooth(x: FloatArray, dt: float, seconds: float = SMOOTH_S) -> FloatArray:
    """Moving average over ``seconds`` along axis 0 (edges padded with their values)."""
    w = int(round(seconds / dt))
    if w < 2 or len(x) < 2:
        return np.asarray(x, dtype=float)
    w = min(w | 1, len(x) | 1)
    pad = w // 2
    xp = np.concatenate([np.repeat(x[:1], pad, axis=0), x, np.repeat(x[-1:], pad, axis=0)])
    c = np.cumsum(np.concatenate([np.zeros_like(x[:1]), xp]), axis=0)
    return (c[w:] - c[:-w]) / w


def ground_level(low: FloatArray, dt: float, window: float = GROUND_WINDOW_S) -> FloatArray:
    """(T,) the ground under the feet: the lowest foot point over a moving window of ``window``
    seconds (long enough to hold a stance of each foot), so a capture whose floor drifts (a tilted or
    uneven capture volume, a calibration drift) keeps a level under each step."""
    w = max(1, int(round(window / dt)))
    return minimum_filter1d(low.min(axis=1), size=w, mode="nearest")


def point_contacts(low: FloatArray, pos: FloatArray, dt: float) -> BoolArray:
    """(T, P) contact flags of foot points: ``low`` (T, P) lowest heights (m), ``pos`` (T, P, 3)
    positions (m, Z up), ``dt`` the frame time (s). See the module docstring for the rule."""
    low_s = smooth(low, dt)
    pos_s = smooth(pos, dt)
    speed = (np.linalg.norm(np.gradient(pos_s[..., :2], dt, axis=0), axis=-1) if len(pos) > 1
             else np.zeros(low.shape))
    low_s = low_s - ground_level(low_s, dt)[:, None]
    level = np.percentile(low_s, LEVEL_PERCENTILE, axis=0)
    lift = np.percentile(low_s, 95, axis=0) - level
    h_thr = np.clip(HEIGHT_FRACTION * lift, MIN_HEIGHT_M, MAX_HEIGHT_M)
    v_thr = np.maximum(SPEED_FRACTION * np.percentile(speed, 95, axis=0), MIN_SPEED_MPS)
    above = low_s - level
    edge = max(1, int(round(SMOOTH_S / dt)))
    enter = (above < h_thr) & (speed < v_thr)
    stay = (above < HOLD_FACTOR * h_thr) & (speed < HOLD_FACTOR * v_thr)
    out = np.zeros_like(enter)
    for k in range(enter.shape[1]):  # hysteresis: a stance begins near and still, lasts while roughly so
        on = False
        for t in range(enter.shape[0]):
            on = bool(enter[t, k] or (on and stay[t, k]))
            out[t, k] = on
        # a stance under way when the clip starts reads as beginning within the smoothing window
        first = int(np.argmax(out[:, k])) if out[:, k].any() else -1
        if 0 < first <= edge:
            out[:first, k] = True
    return out


def side_contacts(low: FloatArray, pos: FloatArray, dt: float, groups: list[list[int]]) -> BoolArray:
    """(T, S) contact flags per side: a side touches when any of its points (indices ``groups[s]``
    into the columns of ``low``/``pos``) does. Each side measures its own ground (a capture's two feet
    need not agree on the floor: one toe marker may sit centimetres low)."""
    return np.stack([point_contacts(low[:, g], pos[:, g], dt).any(axis=1) for g in groups], axis=1)


def cyclic_strikes(contacts: BoolArray) -> list[list[int]]:
    """Per side (column of ``contacts``, (T, S)), the frames where a contact begins when the T frames are
    one loop of a cycle, frame 0 following frame T - 1: a foot down on frame 0 and up on the last frame
    strikes at frame 0, which a clip read once never shows (its first frame has no frame before it)."""
    c = np.asarray(contacts, dtype=bool)
    begins = c & ~np.roll(c, 1, axis=0)
    return [np.flatnonzero(begins[:, s]).tolist() for s in range(c.shape[1])]


# ---------------------------------------------------------------------- events by hand
def load_events(path: str | os.PathLike[str], feet: list[str], num_frames: int,
                frame_time: float) -> dict[str, list[int]]:
    """Foot strikes given by hand: a YAML mapping ``left:``/``right:`` to lists of strike times,
    as frame numbers (integers) or seconds (``1.25s``), e.g.::

        right: [12, 140, 268]
        left: [76, 204]

    Returns per foot the strike frames, sorted; errors name the file and key."""
    p = Path(path)
    raw = load_yaml(p)
    if not isinstance(raw, dict):
        raise ConfigError("gait events must be a mapping of foot to strike frames, e.g. "
                          "'right: [12, 140]' and 'left: [76]'", path=p)
    unknown = set(raw) - set(feet)
    if unknown:
        raise ConfigError(f"unknown foot {sorted(unknown)[0]!r}; feet: {', '.join(feet)}", path=p,
                          key=str(sorted(unknown)[0]))
    out: dict[str, list[int]] = {}
    for foot in feet:
        vals = raw.get(foot, [])
        if not isinstance(vals, list):
            raise ConfigError("must be a list of strike frames (or times like '1.25s')", path=p, key=foot)
        frames = []
        for v in vals:
            f = _frame_of(v, frame_time)
            if f is None or not 0 <= f < num_frames:
                raise ConfigError(f"{v!r} is not a frame in 0..{num_frames - 1} (or a time like '1.25s' within "
                                  f"{(num_frames - 1) * frame_time:.3f} s)", path=p, key=foot)
            frames.append(f)
        out[foot] = sorted(frames)
    return out


def _frame_of(v: object, frame_time: float) -> int | None:
    if isinstance(v, bool):
        return None
    if isinstance(v, int):
        return v
    if isinstance(v, str) and v.strip().endswith("s"):
        try:
            return int(round(float(v.strip()[:-1]) / frame_time))
        except ValueError:
            return None
    return None


def contacts_from_strikes(strikes: dict[str, list[int]], feet: list[str], num_frames: int) -> BoolArray:
    """(T, S) contact flags from strikes alone: each foot is down from a strike until the other foot's
    next strike plus a double-support share of the step (:data:`HAND_DOUBLE_SUPPORT`)."""
    out = np.zeros((num_frames, len(feet)), dtype=bool)
    everything = sorted((f, s) for s in feet for f in strikes.get(s, []))
    for i, (f, s) in enumerate(everything):
        nxt = next((g for g, t in everything[i + 1:] if t != s), None)
        if nxt is None:
            end = num_frames
        else:
            step = nxt - f
            end = min(num_frames, nxt + int(round(HAND_DOUBLE_SUPPORT * step)))
        out[f:end, feet.index(s)] = True
    return out


#: With events given by hand, a foot stays down this fraction of a step past the other foot's strike
#: (a walk's double support is about 10-20 % of a step).
HAND_DOUBLE_SUPPORT = 0.15
