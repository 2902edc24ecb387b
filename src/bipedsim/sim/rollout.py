"""The rollout loop, the one for every body: controller + physics + fall detection + metrics ->
:class:`Outcome`.

``sim/`` never knows where a clip came from or which controller runs: it takes a model, its body plan
and a :class:`~bipedsim.control.base.Controller`, and its hooks (pushes, the recorder) use only that
interface.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.base import Controller
from bipedsim.errors import ConfigError
from bipedsim.model.creature_builder import trunk_bodies
from bipedsim.model.ground import ground_geoms, terrain_of
from bipedsim.model.plan import BodyPlanSet
from bipedsim.sim.push import PushSchedule

FloatArray = npt.NDArray[np.float64]
#: A rollout with pushes that walked to its end without one of them (a phase-timed push whose gait
#: state never came in time, or that the end of the run cut short): not a survived push.
PUSH_NOT_APPLIED = "push_not_applied"
OUTCOMES = ("no_fall", "fall", "diverged", PUSH_NOT_APPLIED)


#: Longest interval (s) between fall checks: past a second a fall is seen long after it happened.
MAX_CHECK_EVERY_S = 1.0

#: How far (a share of the physics timestep) a control period may lie from a whole number of physics
#: steps and still count as that number: room for the rounding of decimal periods (0.006 / 0.002 is
#: 2.9999999999999996), not for a different period.
CONTROL_DT_TOLERANCE = 1e-6


def control_every(period: float | None, timestep: float, *, path: str | os.PathLike[str] | None = None,
                  key: str = "control_dt") -> int:
    """Physics steps per control step for a control ``period`` (s; None: every physics step) on a model
    whose physics runs at ``timestep`` (s). The controller acts between physics steps, so a period must be
    a whole number (at least one) of them: a shorter one or one between two multiples would run at
    another period than the one recorded with the run, and is a :class:`ConfigError` naming ``key`` (in
    the file at ``path``) and the timestep."""
    if period is None:
        return 1
    k = round(period / timestep) if math.isfinite(period) and period > 0 else 0
    if k >= 1 and abs(k * timestep - period) <= CONTROL_DT_TOLERANCE * timestep:
        return int(k)
    what = "shorter than" if period < timestep else "not a whole multiple of"
    steps = period / timestep if math.isfinite(period) else 1.0
    near = sorted({max(1, math.floor(steps)), max(1, math.ceil(steps))})
    raise ConfigError(f"a control period of {period:g} s is {what} the physics timestep {timestep:g} s: the "
                      "controller acts between physics steps; give a multiple of the timestep ("
                      + " or ".join(f"{n * timestep:g} s" for n in near) + ") or null (every physics step)",
                      path=path, key=key)


@dataclass(frozen=True)
class FallCriteria:
    """When the character has fallen (any criterion, checked every ``check_every`` s). The ``fall:``
    block of experiment and suite files is validated into this type.

    ``non_foot_contact``: a body other than the feet (and the ``allowed`` bodies) touches the floor.
    ``pelvis_height_fraction``: the root body (pelvis) below this fraction of its height at the start.
    ``torso_tilt``: the torso (a body without one: the root) tilted more than this many rad -- from
    vertical (``tilt_from: world``, an upright body) or from the reference's own root orientation at
    that moment (``reference``: a creature whose root frame is not upright, a dog lying along X).
    """

    non_foot_contact: bool = True
    allowed: tuple[str, ...] = ()
    pelvis_height_fraction: float = field(default=0.55, metadata={"min": 0.0, "max": 1.0})
    #: rad; past pi every tilt is within it (the check compares cosines)
    torso_tilt: float = field(default=1.0, metadata={"gt": 0.0, "max": math.pi})
    check_every: float = field(default=0.01, metadata={"gt": 0.0, "max": MAX_CHECK_EVERY_S})
    tilt_from: str = field(default="world", metadata={"choices": ("world", "reference")})
    #: a creature's trunk (its root body and the bodies between it and the legs' roots) touching the
    #: floor is a fall, whatever ``non_foot_contact`` says (knees, a head or a tail may touch)
    trunk_contact: bool = False

    @staticmethod
    def for_body(profile: str, support: bool = False) -> FallCriteria:
        """The default criteria of a body kind: the humanoid's above; a creature falls when its root
        drops below 0.4 of its starting height (body-height loss), tilts 1.4 rad from the reference's root
        at that moment, or its trunk touches the ground (knees, head or tail may); a supported creature
        (held by an external wrench) is never judged fallen."""
        if profile != "creature":
            return FallCriteria()
        if support:
            return FallCriteria(non_foot_contact=False, pelvis_height_fraction=0.0, torso_tilt=math.pi)
        return FallCriteria(non_foot_contact=False, pelvis_height_fraction=0.4, torso_tilt=1.4,
                            tilt_from="reference", trunk_contact=True)


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


class FallDetector:
    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, crit: FallCriteria, data: mujoco.MjData,
                 root: int = 1) -> None:
        self.crit = crit
        #: the ground's geoms (a flat floor's one, or a shaped ground's several)
        self.floor = ground_geoms(model)
        #: the ground's height under the pelvis (None: flat at z = 0)
        self.terrain = terrain_of(model)
        ok_bodies = {model.body(b).id for b in (*plan.foot_bodies, *crit.allowed)}
        #: a contact between the floor and one of these geoms is a fall (a plain set: the per-check loop
        #: over a walking body's few contacts beats numpy's per-call cost)
        self._bad_geoms = {g for g in range(model.ngeom)
                           if model.geom_bodyid[g] not in ok_bodies and model.geom_bodyid[g] != 0} \
            if crit.non_foot_contact else set()
        if crit.trunk_contact and plan.profile == "creature":
            trunk = {model.body(b).id for b in trunk_bodies(plan)}
            self._bad_geoms |= {g for g in range(model.ngeom) if model.geom_bodyid[g] in trunk}
        self.pelvis = root
        torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")
        self.torso = torso if torso >= 0 else root
        self.h0 = self._height(data)
        self.min_height = crit.pelvis_height_fraction * self.h0
        self.min_up = float(np.cos(crit.torso_tilt))
        self.model = model

    def check(self, data: mujoco.MjData, ctrl: Controller | None = None) -> str | None:
        """The reason the character has fallen, or None (this runs every few ms: a walking body has a
        handful of contacts, so a plain loop over them beats numpy's per-call cost)."""
        c = self.crit
        if self._bad_geoms and data.ncon:
            floor, bad = self.floor, self._bad_geoms
            for g1, g2 in data.contact.geom.tolist():
                if (g1 in floor and g2 in bad) or (g2 in floor and g1 in bad):
                    other = g2 if g1 in floor else g1
                    return f"{self.model.body(self.model.geom_bodyid[other]).name} touched the ground"
        if self._height(data) < self.min_height:
            return f"{self.model.body(self.pelvis).name} below {c.pelvis_height_fraction:.2f} of its starting height"
        if c.tilt_from == "reference" and ctrl is not None:
            if self._up_from_reference(data, ctrl) < self.min_up:
                return f"root tilted more than {c.torso_tilt:.2f} rad from the reference's root"
        elif data.xmat[self.torso, 8] < self.min_up:  # the torso's up axis, z component
            return f"torso tilted more than {c.torso_tilt:.2f} rad"
        return None

    def _height(self, data: mujoco.MjData) -> float:
        """The pelvis's height (m) above the ground under it."""
        x, y, z = data.xpos[self.pelvis].tolist()
        return z if self.terrain is None else z - self.terrain.height(x, y)

    def _up_from_reference(self, data: mujoco.MjData, ctrl: Controller) -> float:
        """cos of the angle between world up and where the body's frame now carries the direction
        that was world up in the reference's root frame (yaw does not count)."""
        ref = np.zeros(9)
        mujoco.mju_quat2Mat(ref, ctrl.reference_qpos()[3:7])
        v = ref.reshape(3, 3)[2]  # world z in the reference root's frame: R_ref^T z
        r = data.xmat[self.pelvis].reshape(3, 3)
        return float(r[2].dot(v))  # z-component of R v


_INSTABILITY = (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                mujoco.mjtWarning.mjWARN_BADCTRL)
_INSTABILITY_IDX = tuple(int(w) for w in _INSTABILITY)


class MujocoWarnings:
    """MuJoCo's warnings (an unstable simulation, a full contact buffer) collected in ``messages`` while
    started, instead of going to MuJoCo's default handler, which prints them and appends them to a
    MUJOCO_LOG.TXT in the working directory. The rollout reports them in its outcome (``diverged``,
    with the text); the warning counters in ``data.warning`` are unaffected. Process-wide while active
    (MuJoCo has one handler); ``stop`` puts the previous handler back."""

    def __init__(self) -> None:
        self.messages: list[str] = []
        self._old: Any = None

    def start(self) -> MujocoWarnings:
        self._old = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self.messages.append)
        return self

    def stop(self) -> None:
        mujoco.set_mju_user_warning(self._old)

    def __enter__(self) -> MujocoWarnings:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def reason(self, what: str) -> str:
        """``what`` with MuJoCo's first message, if it gave one."""
        return f"{what}: {self.messages[0]}" if self.messages else what


def diverged(data: mujoco.MjData) -> str | None:
    # a sum of squares is finite only if every term is (and a state so large that it overflows has
    # diverged anyway); dot products and a plain loop over four counters: this runs every few ms
    q, v = data.qpos, data.qvel
    if not math.isfinite(float(q.dot(q)) + float(v.dot(v))):
        return "non-finite state (NaN/Inf)"
    counts = data.warning.number
    for w, i in zip(_INSTABILITY, _INSTABILITY_IDX):
        if counts[i]:
            return f"MuJoCo instability warning {mujoco.mjtWarning(w).name}"
    return None


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


@dataclass
class RolloutSpec:
    seconds: float = 10.0
    seed: int = 0
    #: standard deviation (rad/s, m/s) of noise added to the initial velocities, drawn from ``seed``
    init_noise: float = 0.0
    #: seconds between control steps, a whole number of physics steps (:func:`control_every`); None: the
    #: controller's own (``control_dt`` of its settings; None there: every physics step)
    control_dt: float | None = None
    #: ``None``: the body kind's default (:meth:`FallCriteria.for_body`)
    fall: FallCriteria | None = None
    start_frame: float | None = None


def _push_schedule(model: mujoco.MjModel, pushes: list[Any] | None, ctrl: Controller,
                   before_step: list[Hook]) -> Any:
    """The pushes' schedule, first of the hooks run before each physics step (None without pushes)."""
    if not pushes:
        return None
    schedule = PushSchedule(model, list(pushes))
    schedule.check_controller(ctrl)
    before_step.insert(0, schedule)
    return schedule


def _outcome(ctrl: Controller, spec: RolloutSpec, schedule: Any, verdict: tuple[str, float | None, str | None],
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


#: A hook called after every control step: (t, data, controller) -> None. Pushes and recorders use it.
Hook = Callable[[float, mujoco.MjData, Controller], None]


def walk_window(model: mujoco.MjModel, data: mujoco.MjData, ctrl: Controller, step: int, n: int, every: int,
                check_every: int, falls: FallDetector) -> bool:
    """``n`` physics steps of :func:`rollout`'s loop from physics step ``step`` (control, then ``every``
    physics steps; the fall and divergence checks every ``check_every``), without hooks or pushes: a
    window of the reconstruction search (:mod:`bipedsim.sim.reconstruct`). Whether the body is still up."""
    dt = model.opt.timestep
    end = step + n
    while step < end:
        data.ctrl[:] = ctrl(model, data, step * dt, dt * every)
        k = min(every, end - step)
        before = step // check_every
        mujoco.mj_step(model, data, k)
        step += k
        if step // check_every > before and (diverged(data) or falls.check(data, ctrl)):
            return False
    return True


def rollout(model: mujoco.MjModel, plan: BodyPlanSet, ctrl: Controller,
            spec: RolloutSpec, *, initial_qpos: FloatArray | None = None, initial_qvel: FloatArray | None = None,
            qvel_noise: FloatArray | None = None,
            hooks: list[Hook] | None = None, before_step: list[Hook] | None = None,
            progress: Callable[[float], None] | None = None, pushes: list[Any] | None = None,
            nominal_com: tuple[FloatArray, FloatArray] | None = None,
            record_com: bool = False) -> tuple[Outcome, Controller]:
    """Run one rollout of any body under ``ctrl``. The model's state starts at ``initial_qpos``/
    ``initial_qvel`` (the reference's pose at its start when given by the caller; ``qvel_noise``, the
    seed's noise already in it, is added again when the controller's reset re-poses the body and sets
    its velocities, as a creature's standing start does). Returns the outcome and the controller."""
    t0 = time.perf_counter()
    data = mujoco.MjData(model)
    if initial_qpos is not None:
        data.qpos[:] = initial_qpos
    if initial_qvel is not None:
        data.qvel[:] = initial_qvel
    mujoco.mj_forward(model, data)
    mj_warnings = MujocoWarnings().start()
    try:
        ctrl.reset(data, spec.start_frame)
        if qvel_noise is not None and initial_qvel is not None and not np.array_equal(data.qvel, initial_qvel):
            data.qvel[:] += qvel_noise  # the reset set the velocities: the seed's noise on those
            mujoco.mj_forward(model, data)
        fall = spec.fall or FallCriteria.for_body(plan.profile)
        falls = FallDetector(model, plan, fall, data, root=ctrl.root_body)
        dt = model.opt.timestep
        every = control_every(spec.control_dt if spec.control_dt is not None else ctrl.control_dt, dt)
        check_every = max(1, int(round(fall.check_every / dt)))
        n_steps = int(round(spec.seconds / dt))
        start_xy = data.qpos[0:2].copy()
        err2, n_err = 0.0, 0
        outcome, fall_t, reason = "no_fall", None, None
        step = 0
        hooks = list(hooks or [])
        before_step = list(before_step or [])
        schedule = _push_schedule(model, pushes, ctrl, before_step)
        # per control period: time (s), RMS tracking error (rad), COM xy (m); preallocated, not lists of
        # floats and small arrays that cost ~10x the memory on long runs
        n_ctrl = -(-n_steps // every) if schedule is not None or record_com else 0
        series_t, series_err = np.empty(n_ctrl), np.empty(n_ctrl)
        series_com = np.empty((n_ctrl, 2))
        n_series = 0
        # one pass per control period: control, then `every` physics steps (in one mj_step call
        # when no hook needs to see each step); fall checks once per `check_every` physics steps
        step, checks, next_progress = 0, 0, 1.0
        while step < n_steps:
            t = step * dt
            u = ctrl(model, data, t, dt * every)
            data.ctrl[:] = u
            e = ctrl.tracking_error
            ee = float(e.dot(e))
            err2 += ee
            n_err += len(e)
            if n_ctrl:
                series_t[n_series] = t
                series_err[n_series] = (ee / len(e)) ** 0.5
                series_com[n_series] = data.subtree_com[1, :2]
                n_series += 1
            for hk in hooks:
                hk(t, data, ctrl)
            k = min(every, n_steps - step)
            if before_step:
                for i in range(k):
                    for hk in before_step:
                        hk((step + i) * dt, data, ctrl)
                    mujoco.mj_step(model, data)
            else:
                mujoco.mj_step(model, data, k)
            step += k
            if step // check_every > checks or step >= n_steps:
                checks = step // check_every
                bad = diverged(data)
                if bad:
                    outcome, fall_t, reason = "diverged", step * dt, mj_warnings.reason(bad)
                    break
                why = falls.check(data, ctrl)
                if why:
                    outcome, fall_t, reason = "fall", step * dt, why
                    break
                if progress is not None and step * dt >= next_progress:
                    progress(step * dt)
                    next_progress += 1.0
        step = max(step - 1, 0)  # index of the last physics step taken
        series = (series_t[:n_series], series_err[:n_series], series_com[:n_series])
        result = _outcome(ctrl, spec, schedule, (outcome, fall_t, reason), step, dt,
                          float(np.linalg.norm(data.qpos[0:2] - start_xy)), float(np.sqrt(err2 / max(n_err, 1))),
                          series, nominal_com, record_com, ctrl.course_progress(data))
        result.wall_seconds = time.perf_counter() - t0
        return result, ctrl
    finally:
        mj_warnings.stop()
        ctrl.restore_model()
