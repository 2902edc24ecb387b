"""The tuning objective: what a candidate controller is scored on (lower is better).

For each reference clip a candidate runs an unperturbed walk of the experiment's ``seconds`` and every
rollout of the experiment (pushes). Each gives dimensionless terms, averaged over the references:

========== =====================================================================================
term        what it measures
========== =====================================================================================
walk_fall   the walk fell (1) plus the fraction of its length lost to the fall: 0 for a walk that
            stands to the end, up to 2
pushes      the fraction of the experiment's rollouts not survived (a push that never happened,
            ``push_not_applied``, counts as not survived)
fall_time   the mean fraction of each pushed rollout's time after its push lost to a fall: tells a
            fall at once from a fall at the end, where ``pushes`` sees both alike
deviation   the pushed rollouts' mean peak centre-of-mass deviation from the unpushed walk's (in the 2 s
            after the push), per metre of the root's starting height, capped at DEVIATION_CAP; a
            rollout that fell counts as the cap. The margin: among controllers that survive every
            push, the one the pushes move least
speed       the walk's speed error against the reference, |v - v_ref| / max(v_ref, SPEED_FLOOR_MPS)
tracking    the walk's tracking RMSE (rad)
effort      the walk's mean absolute mechanical power of the actuators per kg of body (W/kg):
            sum |torque x joint velocity|
steps       the guard against degenerate gaits: the shortfall of the walk's real steps below
            ``min_steps`` x the steps the reference takes in as long; a real step is a foot
            touching down after at least ``min_swing`` x the reference's median swing time in the
            air, so a body that slides on its feet or shuffles them scores badly. 0 for a
            reference without foot strikes (a flying clip)
========== =====================================================================================

score = sum over terms of weight x term; the weights are :class:`Objective`'s fields (the defaults
here are the one place they are set; a tune file's ``objective:`` block overrides any of them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

#: Terms of the objective, in the order history.csv lists them.
TERMS = ("walk_fall", "pushes", "fall_time", "deviation", "speed", "tracking", "effort", "steps")
#: The speed error is relative to the reference's speed, or to this (m/s) for a clip that barely moves.
SPEED_FLOOR_MPS = 0.2
#: The deviation term's cap (root heights): a fall, or a push that carried the body this far.
DEVIATION_CAP = 2.0
#: A foot is on the ground when its vertical contact force exceeds this fraction of the body's weight.
TOUCH_WEIGHT_FRACTION = 0.05


@dataclass(frozen=True)
class Objective:
    """Weights of the objective's terms (see the module's table), and the step guard's settings. A
    walk that falls costs more than any push set (10 vs 4 + 2): a tune never trades the plain walk for
    pushes survived."""

    walk_fall: float = field(default=10.0, metadata={"min": 0.0})
    pushes: float = field(default=4.0, metadata={"min": 0.0})
    fall_time: float = field(default=2.0, metadata={"min": 0.0})
    deviation: float = field(default=1.0, metadata={"min": 0.0})
    speed: float = field(default=1.0, metadata={"min": 0.0})
    tracking: float = field(default=2.0, metadata={"min": 0.0})
    effort: float = field(default=0.01, metadata={"min": 0.0})
    steps: float = field(default=2.0, metadata={"min": 0.0})
    #: the fraction of the reference's step count a walk must take in real steps
    min_steps: float = field(default=0.5, metadata={"min": 0.0, "max": 1.0})
    #: a real step's time in the air, as a fraction of the reference's median swing time
    min_swing: float = field(default=0.5, metadata={"min": 0.0, "max": 1.0})

    def score(self, terms: dict[str, float]) -> float:
        return float(sum(getattr(self, k) * terms[k] for k in TERMS))


@dataclass(frozen=True)
class Cadence:
    """What the reference clip says about stepping: foot strikes per second (all feet) and the median
    time a foot spends in the air (s) between lifting off and striking."""

    strikes_per_s: float
    swing_s: float

    @staticmethod
    def of_clip(clip: Any) -> Cadence:
        strikes, swings = 0, []
        for ev in clip.events.values():
            strikes += len(ev.get("strike", []))
            for lift in ev.get("liftoff", []):
                later = [s for s in ev.get("strike", []) if s > lift]
                if later:
                    swings.append((later[0] - lift) * clip.frame_time)
        rate = strikes / clip.duration if clip.duration > 0 else 0.0
        return Cadence(strikes_per_s=rate, swing_s=float(np.median(swings)) if swings else 0.0)


class GaitMeter:
    """A rollout hook (called after every control step) measuring the walk's mechanical effort and its
    real steps: touch-downs (vertical force above :data:`TOUCH_WEIGHT_FRACTION` of the weight) after
    at least ``min_air_s`` in the air."""

    def __init__(self, model: mujoco.MjModel, min_air_s: float) -> None:
        self.mass = float(np.sum(model.body_mass))
        self.threshold = TOUCH_WEIGHT_FRACTION * self.mass * -float(model.opt.gravity[2])
        self.min_air_s = min_air_s
        self.energy_j = 0.0
        self.real_steps = 0
        self._t = 0.0
        self._lifted: dict[int, float | None] = {}

    def __call__(self, t: float, data: mujoco.MjData, ctrl: Any) -> None:
        dt, self._t = t - self._t, t
        self.energy_j += float(np.abs(data.actuator_force * data.actuator_velocity).sum()) * dt
        for i, f in enumerate(ctrl.foot_forces(data)):
            lifted = self._lifted.get(i)
            if f < self.threshold:
                if lifted is None:
                    self._lifted[i] = t
            elif i not in self._lifted or lifted is not None:
                if lifted is not None and t - lifted >= self.min_air_s:
                    self.real_steps += 1
                self._lifted[i] = None

    def power_per_kg(self, seconds: float) -> float:
        """Mean absolute mechanical power per kg (W/kg) over ``seconds``."""
        return self.energy_j / seconds / self.mass if seconds > 0 else 0.0


def walk_terms(out: Any, meter: GaitMeter, cadence: Cadence, seconds: float, weights: Objective) -> dict[str, float]:
    """The terms measured on the unperturbed walk (an :class:`~bipedsim.sim.rollout.Outcome`)."""
    fell = out.outcome != "no_fall"
    lasted = out.sim_seconds if fell else seconds
    ref = out.reference_speed_mps
    expected = weights.min_steps * cadence.strikes_per_s * seconds
    return {"walk_fall": float(fell) + (1.0 - min(lasted, seconds) / seconds),
            "speed": abs(out.mean_speed_mps - ref) / max(ref, SPEED_FLOOR_MPS),
            "tracking": float(out.tracking_rmse_rad),
            "effort": meter.power_per_kg(out.sim_seconds),
            "steps": max(0.0, 1.0 - meter.real_steps / expected) if expected > 0 else 0.0}


def push_terms(outcomes: list[tuple[Any, float]], seconds: float, height: float) -> dict[str, float]:
    """The terms of the pushed rollouts: (outcome, push start s) each; ``height``: the root's starting
    height (m), the body's size for the deviation."""
    lost, moved = [], []
    for out, start in outcomes:
        peak = out.extra.get("peak_com_deviation_m")
        if out.outcome in ("fall", "diverged"):
            span = max(seconds - start, 1e-9)
            lost.append(min(1.0, max(0.0, (seconds - out.sim_seconds) / span)))
            moved.append(DEVIATION_CAP)
        else:
            lost.append(0.0)
            moved.append(DEVIATION_CAP if peak is None else min(DEVIATION_CAP, peak / height))
    failed = [out.outcome != "no_fall" for out, _ in outcomes]
    return {"pushes": float(np.mean(failed)) if failed else 0.0,
            "fall_time": float(np.mean(lost)) if lost else 0.0,
            "deviation": float(np.mean(moved)) if moved else 0.0}


__all__ = ["DEVIATION_CAP", "SPEED_FLOOR_MPS", "TERMS", "TOUCH_WEIGHT_FRACTION", "Cadence", "GaitMeter", "Objective",
           "push_terms", "walk_terms"]
