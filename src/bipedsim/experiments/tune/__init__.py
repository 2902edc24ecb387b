"""Automatic controller tuning: CMA-ES (the ``cma`` package) over a controller's values, each candidate
scored by rollouts (an unperturbed walk and an experiment's pushes, on one or several reference clips),
in parallel and resumable. ``bipedsim tune TUNE.yaml --out DIR``; see docs/tuning.md."""

from __future__ import annotations

from bipedsim.experiments.tune.cmaes import format_tune_summary, interrupted_message, run_tune
from bipedsim.experiments.tune.objective import TERMS, Objective
from bipedsim.experiments.tune.spec import Tune, TuneSpec, load_tune

__all__ = ["TERMS", "Objective", "Tune", "TuneSpec", "format_tune_summary", "interrupted_message", "load_tune",
           "run_tune"]
