"""Rollouts: the physics loop, pushes, fall detection, metrics, the recorder."""

from __future__ import annotations

from bipedsim.sim.rollout import FallCriteria, Outcome, RolloutSpec, rollout

__all__ = ["FallCriteria", "Outcome", "RolloutSpec", "rollout"]
