"""Many rollouts: push and gain sweeps (:mod:`.sweep`, local processes or Ray through :mod:`.backends`),
experiment files (:mod:`.experiment`), regression suites (:mod:`.regress`) and CMA-ES tuning
(:mod:`.tune`)."""

from __future__ import annotations
