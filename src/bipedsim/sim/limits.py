"""Bounds on what a run may ask for, shared by the rollout's callers and the push checks."""

from __future__ import annotations

#: Longest rollout accepted (s): an hour of simulated walking is far past any experiment here (the
#: longest test walks 60 s) and takes minutes; a larger value is a typo that would run for days.
MAX_ROLLOUT_S = 3600.0
