"""A rollout's verdict as it is reported: the :class:`Outcome` type, the recovery figures of a pushed run
(recovery time, centre-of-mass deviation, steps to recover) and the pushes that did not act in full.
:class:`~bipedsim.sim.rollout.Rollout` makes one when it finishes."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.control.base import Controller

FloatArray = npt.NDArray[np.float64]
#: A rollout with pushes that walked to its end without one of them (a phase-timed push whose gait
#: state never came in time, or that the end of the run cut short): not a survived push.
PUSH_NOT_APPLIED = "push_not_applied"
OUTCOMES = ("no_fall", "fall", "diverged", PUSH_NOT_APPLIED)


@dataclass
class Outcome:
    """One rollout's verdict, metrics and provenance."""

    outcome: str
    sim_seconds: float
    fall_time_s: float | None
    fall_reason: str | None
    foot_strikes: int
    distance_m: float
    mean_speed_mps: float
    reference_speed_mps: float
    tracking_rmse_rad: float
    wall_seconds: float
    steps: int
    resyncs: int
    mean_resync_ratio: float | None
    config: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    #: the COM's progress (m) along the reference's own course over the run, over ``sim_seconds``
    #: (``mean_speed_mps`` counts displacement in any direction); None without a course (in place)
    course_speed_mps: float | None = None
    #: the COM's lateral offset (m, positive left) from the reference's course at the end
    course_offset_m: float | None = None
    versions: dict[str, str] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    #: the run against its clip over the clip's own duration (:meth:`bipedsim.sim.fidelity.Fidelity.to_dict`:
    #: root path distances m, path and speed ratios, joint-position error cm); None where not measured
    #: (a run without a recorder, key poses)
    fidelity: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

#: After a push, tracking counts as recovered once the error stays below the larger of
#: RECOVERY_FACTOR x its pre-push median and that median + RECOVERY_MARGIN_RAD, for RECOVERY_HOLD_S.
RECOVERY_FACTOR = 1.5
RECOVERY_MARGIN_RAD = 0.03
RECOVERY_HOLD_S = 0.5
#: Window (s) before a push over which the centre of mass's course is fitted, and after it over which
#: the deviation from that course is measured.
COM_FIT_S, COM_DEVIATION_S = 1.0, 2.0


def recovery_metrics(schedule: Any, t: FloatArray, err: FloatArray, com: FloatArray, strikes: list[float],
                     spec: Any, nominal: tuple[FloatArray, FloatArray] | None = None) -> dict[str, Any]:
    """Recovery time (s after the push ends), peak centre-of-mass deviation (m) and foot strikes
    taken until recovered. The deviation is measured from the same rollout without the push
    (``nominal``: times and COM) when given, else from the COM's straight pre-push course."""
    out: dict[str, Any] = {"push_start_s": schedule.first_start, "push_end_s": schedule.last_end,
                           "recovery_time_s": None, "peak_com_deviation_m": None, "steps_to_recover": None}
    t0, t1 = schedule.first_start, schedule.last_end
    if t0 is None or len(t) == 0:
        return out
    before = (t >= t0 - COM_FIT_S) & (t < t0)
    if before.sum() >= 2:
        base = float(np.median(err[before]))
        thr = max(RECOVERY_FACTOR * base, base + RECOVERY_MARGIN_RAD)
        a = np.stack([t[before], np.ones(before.sum())], axis=1)
        coef = np.linalg.lstsq(a, com[before], rcond=None)[0]
        after = (t >= t0) & (t <= t0 + COM_DEVIATION_S)
        if after.any() and nominal is not None and len(nominal[0]):
            nt, nc = nominal
            pred = np.stack([np.interp(t[after], nt, nc[:, k]) for k in range(2)], axis=1)
            out["peak_com_deviation_m"] = float(np.max(np.linalg.norm(com[after] - pred, axis=1)))
        elif after.any():
            pred = np.stack([t[after], np.ones(after.sum())], axis=1) @ coef
            out["peak_com_deviation_m"] = float(np.max(np.linalg.norm(com[after] - pred, axis=1)))
        hold = max(1, int(round(RECOVERY_HOLD_S / max(np.median(np.diff(t)), 1e-6))))
        idx = np.flatnonzero(t >= t1)
        below = err < thr
        for k in idx:
            if k + hold <= len(t) and below[k:k + hold].all():
                out["recovery_time_s"] = float(t[k] - t1)
                out["steps_to_recover"] = int(sum(1 for s in strikes if t0 <= s <= t[k]))
                break
    return out


def not_applied(schedule: Any, sim_seconds: float, dt: float) -> list[str]:
    """The pushes of ``schedule`` that did not act in full within ``sim_seconds`` (s), each as
    "MAG:DIR:DUR:START: why". A push fires on the first physics step (``dt`` s) at or after its start,
    so one that ends up to a step past the run's end counts as applied."""
    out = [f"{p.describe()}: never started (its gait state did not come before the run ended at "
           f"{sim_seconds:g} s)" if p.start is None else f"{p.describe()}: never started (the run ended at "
           f"{sim_seconds:g} s)" for p in schedule.pending]
    for a in schedule.fired:
        if a.end > sim_seconds + dt * 1.5:
            out.append(f"{a.push.describe()}: started at {a.start:.3f} s, cut short by the end of the run at "
                       f"{sim_seconds:g} s")
    return out


def _outcome(ctrl: Controller, spec: Any, schedule: Any, verdict: tuple[str, float | None, str | None],
             step: int, dt: float, dist: float, rmse: float, series: tuple[FloatArray, FloatArray, FloatArray],
             nominal_com: tuple[FloatArray, FloatArray] | None, record_com: bool,
             course: tuple[float, float] | None = None) -> Outcome:
    """The rollout's verdict and metrics once the loop has ended at physics step ``step`` (its index)
    having moved the root ``dist`` m; ``series``: time, tracking error and COM per control period;
    ``course``: the COM's (progress, offset) on the reference's course (m), or None."""
    outcome, fall_t, reason = verdict
    sim_s = (step + 1) * dt
    dist = dist if outcome != "diverged" else 0.0
    course = course if outcome != "diverged" else None
    metrics = ctrl.metrics()
    strikes = ctrl.foot_strikes()
    extra: dict[str, Any] = {k: v for k, v in metrics.items() if k not in ("resyncs", "mean_resync_ratio")}
    series_t, series_err, series_com = series
    if schedule is not None:
        extra.update(recovery_metrics(schedule, series_t, series_err, series_com, [s[0] for s in strikes],
                                      spec, nominal_com))
        # only a run that reached its end: a fall or divergence is one, pushed in full or not
        missed = not_applied(schedule, sim_s, dt) if outcome == "no_fall" else []
        if missed:
            extra["pushes_not_applied"] = missed
            outcome = PUSH_NOT_APPLIED
    if record_com:
        extra["com_series"] = (series_t.copy(), series_com.copy())
    return Outcome(outcome=outcome, sim_seconds=sim_s, fall_time_s=fall_t, fall_reason=reason,
                   foot_strikes=len(strikes), distance_m=dist, mean_speed_mps=dist / sim_s if sim_s > 0 else 0.0,
                   reference_speed_mps=ctrl.reference_speed(), tracking_rmse_rad=rmse, wall_seconds=0.0,
                   steps=step + 1, resyncs=int(metrics.get("resyncs", 0)),
                   mean_resync_ratio=metrics.get("mean_resync_ratio"), seed=spec.seed, extra=extra,
                   course_speed_mps=course[0] / sim_s if course is not None and sim_s > 0 else None,
                   course_offset_m=course[1] if course is not None else None)
