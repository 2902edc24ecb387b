"""The terms a ground is written in (``slope:DEG``, ``step:HEIGHT_M:DISTANCE_M``,
``rough:AMPLITUDE_M:WAVELENGTH_M[:SEED]``, ``friction:MU``): their parts and ranges, each term's
numbers checked. :class:`bipedsim.model.ground.Ground` is made from them."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from bipedsim.errors import ConfigError

#: steepest slope (degrees) a ground may have: past it a walk needs climbing, not balance
MAX_SLOPE_DEG = 30.0
#: highest step (m, up or down): about a shin's length
MAX_STEP_M = 0.5
#: highest rough-ground amplitude (m) and the wavelengths (m) it may be made of
MAX_ROUGH_M = 0.2
ROUGH_WAVELENGTH_M = (0.2, 20.0)
#: the friction coefficients a ground may have (0: ice that no contact can stand on)
FRICTION_RANGE = (0.05, 5.0)
#: rough ground's height fields (m): behind the start, ahead of it at the least (also where steps may
#: lie, and the stretch whose waves' peak is scaled to the amplitude) and to each side
BEHIND_M, AHEAD_M, HALF_WIDTH_M = 5.0, 50.0, 5.0
#: a plane-based ground's boxes (a step's higher levels) reach this far (m) ahead, behind and to each
#: side: an hour's run, the longest a run may be, at 2.8 m/s stays on them (a box's size costs nothing)
PLANE_AHEAD_M, PLANE_BEHIND_M, PLANE_HALF_WIDTH_M = 10_000.0, 100.0, 100.0
#: the most samples rough ground's height fields hold, together (~4 bytes each in the model, ~8 in
#: model.xml): past :data:`AHEAD_M` they reach as far ahead as these allow at their spacing
ROUGH_MAX_SAMPLES = 200_000
#: a step is at least this far (m) ahead of the start: the body starts on one level
MIN_STEP_DISTANCE_M = 0.5

TERMS = ("slope", "step", "rough", "friction")
SYNTAX = ("slope:DEG, step:HEIGHT_M:DISTANCE_M, rough:AMPLITUDE_M:WAVELENGTH_M[:SEED], friction:MU "
          "(or flat)")


@dataclass(frozen=True)
class Step:
    """A step ``height_m`` up (negative: down) at ``distance_m`` ahead of the start."""

    height_m: float
    distance_m: float


@dataclass(frozen=True)
class Rough:
    """Uneven ground: heights within +-``amplitude_m`` (m), waves about ``wavelength_m`` long, drawn
    from ``seed``."""

    amplitude_m: float
    wavelength_m: float
    seed: int = 0


def _split(raw: str, key: str, path: str | os.PathLike[str] | None) -> tuple[str, list[float]]:
    """A term's kind and its numbers."""
    kind, *parts = raw.strip().split(":")
    kind = kind.strip().lower()
    if kind == "flat" and not parts:
        return kind, []
    if kind not in TERMS:
        raise ConfigError(f"unknown ground {raw!r}; give {SYNTAX}", path=path, key=key)
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ConfigError(f"{raw!r}: the values after {kind}: must be numbers ({SYNTAX})", path=path,
                          key=key) from None
    if not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{raw!r}: the values must be finite numbers", path=path, key=key)
    return kind, values


def _count(values: list[float], lo: int, hi: int, syntax: str) -> None:
    if not lo <= len(values) <= hi:
        raise ValueError(f"expected {syntax}")


def _slope(values: list[float]) -> float:
    _count(values, 1, 1, "slope:DEG")
    (deg,) = values
    if abs(deg) > MAX_SLOPE_DEG:
        raise ValueError(f"a slope is at most {MAX_SLOPE_DEG:g} degrees up or down, got {deg:g}")
    return deg


def _step(values: list[float]) -> Step:
    _count(values, 2, 2, "step:HEIGHT_M:DISTANCE_M")
    h, d = values
    if h == 0 or abs(h) > MAX_STEP_M:
        raise ValueError(f"a step's height is not 0 and at most {MAX_STEP_M:g} m up or down, got {h:g}")
    if not MIN_STEP_DISTANCE_M <= d < AHEAD_M:
        raise ValueError(f"a step lies {MIN_STEP_DISTANCE_M:g} m to {AHEAD_M:g} m ahead of the start, got {d:g}")
    return Step(height_m=h, distance_m=d)


def _rough(values: list[float]) -> Rough:
    _count(values, 2, 3, "rough:AMPLITUDE_M:WAVELENGTH_M[:SEED]")
    a, w = values[:2]
    if not 0 < a <= MAX_ROUGH_M:
        raise ValueError(f"the amplitude is > 0 and at most {MAX_ROUGH_M:g} m, got {a:g}")
    lo, hi = ROUGH_WAVELENGTH_M
    if not lo <= w <= hi:
        raise ValueError(f"the wavelength is {lo:g} m to {hi:g} m, got {w:g}")
    seed = values[2] if len(values) == 3 else 0.0
    if seed < 0 or seed != int(seed):
        raise ValueError(f"the seed is a whole number >= 0, got {seed:g}")
    return Rough(amplitude_m=a, wavelength_m=w, seed=int(seed))


def _friction(values: list[float]) -> float:
    _count(values, 1, 1, "friction:MU")
    (mu,) = values
    lo, hi = FRICTION_RANGE
    if not lo <= mu <= hi:
        raise ValueError(f"the friction coefficient is {lo:g} to {hi:g}, got {mu:g}")
    return mu
