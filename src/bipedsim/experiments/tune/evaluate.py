"""Scoring one candidate controller (in whichever process): for every reference, the unperturbed walk
and the experiment's rollouts, through the one rollout path (:func:`~bipedsim.sim.runner.run_scenario`)."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from bipedsim import config
from bipedsim.control.settings import ControllerConfig
from bipedsim.experiments.experiment import Row
from bipedsim.experiments.tune.objective import TERMS, Cadence, GaitMeter, Objective, push_terms, walk_terms
from bipedsim.experiments.tune.spec import CONFIG_CLASSES
from bipedsim.sim.rollout import FallCriteria, RolloutSpec
from bipedsim.sim.runner import Scenario, load_scenario, run_scenario, settings_for

_SCENARIOS: dict[Any, Scenario] = {}


@dataclass(frozen=True)
class Setup:
    """What every candidate of one tune shares (sent with each task: small, picklable)."""

    references: tuple[str | None, ...]
    profile: str
    support: bool
    rows: tuple[Row, ...]
    seconds: float
    init_noise: float
    fall: dict[str, Any] | None
    objective: Objective


#: one candidate for a worker: (candidate number, controller settings as a mapping, setup)
Task = tuple[int, dict[str, Any], Setup]


def _scenario(reference: str | None, profile: str, support: bool, settings: Any = None) -> Scenario:
    """The body and clip of a reference, built once per process and per way of preparing the clip
    (a humanoid's ``reference:`` block, which candidates rarely change; the rest is only settings)."""
    prepared = getattr(settings, "reference", None) if profile == "humanoid" else None
    body = getattr(settings, "body", None) if profile == "humanoid" else None  # scales the reference's times
    key = (reference, profile, support, repr(prepared), repr(body))
    if key not in _SCENARIOS:
        controller = None if prepared is None else ControllerConfig(reference=prepared, body=body)
        _SCENARIOS[key] = load_scenario(controller, reference, profile=profile, support=support)
    return _SCENARIOS[key]


def with_settings(sc: Scenario, settings: Any) -> Scenario:
    """``sc`` with another controller's settings (and none of the first one's cached rollouts); a
    humanoid's made for the scenario's body and reference as ``bipedsim run`` makes them
    (:func:`~bipedsim.sim.runner.settings_for`)."""
    if sc.profile == "creature":
        return dataclasses.replace(sc, creature_cfg=settings, extra={})
    return dataclasses.replace(sc, cfg=settings_for(sc, settings), extra={})


def evaluate_reference(sc: Scenario, setup: Setup) -> dict[str, float]:
    """The objective's terms for one reference's scenario (already holding the candidate's settings)."""
    fall = None if setup.fall is None else FallCriteria(**setup.fall)
    cadence = Cadence.of_clip(sc.clip)
    meter = GaitMeter(sc.built.model, setup.objective.min_swing * cadence.swing_s)
    # the unpushed walk starts from the reference's own state: the objective's walk terms compare candidates
    # on one deterministic walk; the noise is for the pushed rows, one draw per row's seed
    walk, _ = run_scenario(sc, RolloutSpec(seconds=setup.seconds, seed=0, init_noise=0.0, fall=fall),
                           hooks=[meter])
    terms = walk_terms(walk, meter, cadence, setup.seconds, setup.objective)
    pushed = []
    for row in setup.rows:
        noise = setup.init_noise if row.init_noise is None else row.init_noise  # a replica's own
        spec = RolloutSpec(seconds=setup.seconds, seed=row.seed, init_noise=noise, fall=fall)
        out, _ = run_scenario(sc, spec, pushes=[row.push])
        start = out.extra.get("push_start_s")
        pushed.append((out, float(start if start is not None else row.push.start or 0.0)))
    terms.update(push_terms(pushed, setup.seconds, height=float(sc.clip.qpos[0, 2])))
    terms["survived"] = float(sum(o.outcome == "no_fall" for o, _ in pushed))
    terms["walk_s"] = float(walk.sim_seconds)
    return terms


def evaluate(task: Task) -> dict[str, Any]:
    """Score one candidate: its terms averaged over the references, the score, and the counts of
    pushes survived (summed) and of the walks' seconds (the shortest)."""
    t0 = time.perf_counter()
    number, settings, setup = task
    cfg = config.from_dict(CONFIG_CLASSES[setup.profile], settings)
    per_ref = [evaluate_reference(with_settings(_scenario(r, setup.profile, setup.support, cfg), cfg), setup)
               for r in setup.references]
    terms = {k: float(np.mean([t[k] for t in per_ref])) for k in TERMS}
    return {"candidate": number, "score": setup.objective.score(terms), **terms,
            "survived": int(sum(t["survived"] for t in per_ref)), "rollouts": len(setup.rows) * len(per_ref),
            "walk_s": min(t["walk_s"] for t in per_ref), "wall_seconds": round(time.perf_counter() - t0, 3)}


__all__ = ["Setup", "Task", "evaluate", "evaluate_reference", "with_settings"]
