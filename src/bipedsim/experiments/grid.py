"""A push grid (an experiment's ``grid:``): the lists whose cross product is the set of rollouts --
magnitudes, directions, durations, gait phases or start times, vertical forces, controllers, pushed
bodies and grounds. Forces N, durations and times s, directions degrees from the heading."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from bipedsim.model.ground import check_ground


def ground_label(terms: Sequence[str]) -> str:
    """A ground's label in rows and summaries: its terms as given, joined by ``+``; ``flat`` for none."""
    return "+".join(terms) or "flat"


@dataclass(frozen=True)
class Grid:
    """The cross product of these lists is the set of rollouts (times ``repeats``)."""

    magnitude: tuple[float, ...] = (200.0,)
    direction: tuple[float, ...] = (0.0,)
    duration: tuple[float, ...] = (0.2,)
    #: gait phases [state, fraction]; or ``start`` times (s); one of the two
    phase: tuple[tuple[int, float], ...] = ()
    start: tuple[float, ...] = ()
    vertical: tuple[float, ...] = (0.0,)
    #: controller YAML files (relative to the experiment file); empty: the default controller
    controller: tuple[str, ...] = ()
    #: bodies pushed (``torso``, ``pelvis``, ``left_upper_arm``, ...); empty: the experiment's ``body``
    body: tuple[str, ...] = ()
    #: grounds, each a list of ``bipedsim run --ground`` terms (``[]``: flat); empty: the experiment's
    #: ``ground``
    ground: tuple[tuple[str, ...], ...] = ()

    def validate(self) -> None:
        for key in ("magnitude", "direction", "duration", "vertical"):
            if not getattr(self, key):
                raise ValueError(f"{key}: empty list -- the grid would have no rollouts")
        for key in ("magnitude", "direction", "duration", "vertical", "phase", "start", "controller", "body"):
            values = getattr(self, key)
            twice = next((v for i, v in enumerate(values) if v in values[:i]), None)
            if twice is not None:
                # two equal rollouts would share one row key: a resumed sweep would run only one
                raise ValueError(f"{key}: {list(twice) if isinstance(twice, tuple) else twice} is listed twice; "
                                 "use repeats to run a rollout more than once")
        labels = [ground_label(g) for g in self.ground]
        for i, g in enumerate(self.ground):
            check_ground(g, key=f"ground[{i}]")
            if labels[i] in labels[:i]:
                raise ValueError(f"ground: {labels[i]} is listed twice; use repeats to run a rollout more than once")
        if not self.phase and not self.start:
            raise ValueError("phase: give gait phases ([state, fraction]) or start times (start)")
        if self.phase and self.start:
            raise ValueError("phase: give either phases or start times, not both")
        for m in self.magnitude:
            if m < 0:
                raise ValueError(f"magnitude: must be >= 0 N, got {m}")
        for d in self.duration:
            if not d > 0:
                raise ValueError(f"duration: must be > 0 s, got {d}")
        for s in self.start:
            if s < 0:
                raise ValueError(f"start: must be >= 0 s, got {s}")
        for st, fr in self.phase:
            if st not in (1, 2, 3, 4) or not 0.0 <= fr <= 1.0:
                raise ValueError(f"phase: [state 1-4, fraction 0-1], got [{st}, {fr}]")

    def size(self) -> int:
        """Rollouts per repeat (the product of the list lengths)."""
        return math.prod(len(v) or 1 for v in (self.controller, self.body, self.ground, self.magnitude,
                                               self.direction, self.duration, self.phase or self.start,
                                               self.vertical))


__all__ = ["Grid", "ground_label"]
