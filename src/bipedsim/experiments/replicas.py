"""Replicas of a push grid's cells, the threshold protocol's perturbations (docs/pushes.md): replica 0 as
a single trial runs the cell; replicas 1.. start from seeded initial velocity noise with the push moved by
a seeded phase offset."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace

import numpy as np

from bipedsim.sim.push import Push


@dataclass(frozen=True)
class Replicas:
    """Each grid cell run ``count`` times, as a threshold protocol: replica 0 as a single trial runs it,
    replicas 1.. from a perturbed state (Gaussian noise on the initial velocities) with the push moved by a
    small phase offset. A cell's magnitude counts as survived when at least ``survive`` of its replicas
    survive it; its threshold is the largest magnitude survived so, with every lower magnitude too."""

    count: int = field(default=5, metadata={"min": 1})
    #: replicas that must survive a magnitude for the cell to count it survived
    survive: int = field(default=4, metadata={"min": 1})
    #: standard deviation (rad/s, m/s) of the noise on replicas 1..'s initial velocities: a few mrad/s
    #: already change which step a push meets
    noise: float = field(default=0.02, metadata={"min": 0.0})
    #: largest phase offset (fraction of the gait state's nominal duration, +-) of a phase-timed push
    phase_offset: float = field(default=0.1, metadata={"min": 0.0, "max": 1.0})
    #: largest offset (s, +-) of a push given a start time
    start_offset: float = field(default=0.1, metadata={"min": 0.0})

    def validate(self) -> None:
        if self.survive > self.count:
            raise ValueError(f"survive: {self.survive} of {self.count} replicas cannot survive; at most count")

    def offset(self, seed: int, replica: int, cell: str, span: float) -> float:
        """The offset (+- ``span``) of ``replica`` at ``cell`` (the cell's identity without its magnitude:
        a cell's magnitudes share one, so its ladder of magnitudes meets one gait), drawn from ``seed``;
        0 for replica 0."""
        if replica == 0 or span <= 0:
            return 0.0
        cell_int = int(hashlib.sha1(cell.encode()).hexdigest()[:8], 16)
        return float(np.random.default_rng([seed, replica, cell_int]).uniform(-span, span))

    def shifted(self, push: Push, seed: int, replica: int, cell: str) -> tuple[Push, float]:
        """``push`` moved by its replica's offset (kept within its state, or at or after 0 s) and the
        offset applied (fraction of the state, or s)."""
        if push.state is not None:
            off = self.offset(seed, replica, cell, self.phase_offset)
            frac = min(max(push.fraction + off, 0.0), 1.0)
            return replace(push, fraction=frac), frac - push.fraction
        assert push.start is not None
        off = self.offset(seed, replica, cell, self.start_offset)
        start = max(push.start + off, 0.0)
        return replace(push, start=start), start - push.start

    def init_noise(self, replica: int) -> float:
        """The initial velocity noise (rad/s, m/s) of ``replica``: none for replica 0."""
        return 0.0 if replica == 0 else self.noise
