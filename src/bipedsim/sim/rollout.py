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
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.base import Controller
from bipedsim.errors import ConfigError
from bipedsim.model.creature_builder import trunk_bodies
from bipedsim.model.ground import ground_geoms, terrain_of
from bipedsim.model.plan import BodyPlanSet
from bipedsim.sim.outcome import (  # noqa: F401 - the outcome's names, where they were always imported from
    COM_DEVIATION_S,
    COM_FIT_S,
    OUTCOMES,
    PUSH_NOT_APPLIED,
    RECOVERY_FACTOR,
    RECOVERY_HOLD_S,
    RECOVERY_MARGIN_RAD,
    Outcome,
    _outcome,
    not_applied,
    recovery_metrics,
)
from bipedsim.sim.push import PushSchedule

FloatArray = npt.NDArray[np.float64]

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
    (MuJoCo has one handler), so a rollout holds it only during a step (several rollouts may be open at
    once: a vector of environments); ``stop`` puts the previous handler back."""

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


class Rollout:
    """One rollout of any body under ``ctrl``, a control period at a time: the one loop, as a stepper.

    Made, it has created the simulation state (``data``) and started the controller at the rollout's
    start; :meth:`step` runs one control period (the controller sets the controls, the hooks run, the
    physics steps, the fall and divergence checks when due; MuJoCo's warnings collected meanwhile) and says
    whether the rollout goes on; :meth:`finish` gives the :class:`Outcome`; :meth:`close` (or leaving a
    ``with`` block) puts the controller's model changes back.
    :func:`rollout` drives it to the end; :mod:`bipedsim.envs` drives it a step per action. The model's
    state starts at ``initial_qpos``/``initial_qvel`` (the reference's pose at its start when given by
    the caller; ``qvel_noise``, the seed's noise already in it, is added again when the controller's
    reset re-poses the body and sets its velocities, as a creature's standing start does). ``data``: the
    simulation state to run in (reset first); None: a new one."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, ctrl: Controller, spec: RolloutSpec, *,
                 initial_qpos: FloatArray | None = None, initial_qvel: FloatArray | None = None,
                 qvel_noise: FloatArray | None = None, hooks: list[Hook] | None = None,
                 before_step: list[Hook] | None = None, progress: Callable[[float], None] | None = None,
                 pushes: list[Any] | None = None, nominal_com: tuple[FloatArray, FloatArray] | None = None,
                 record_com: bool = False, data: mujoco.MjData | None = None) -> None:
        self._t0 = time.perf_counter()
        self.model, self.plan, self.ctrl, self.spec = model, plan, ctrl, spec
        self.progress, self.nominal_com, self.record_com = progress, nominal_com, record_com
        if data is None:
            data = mujoco.MjData(model)
        else:  # a state the caller keeps (a viewer shows it), reset to the model's defaults
            mujoco.mj_resetData(model, data)
        self.data = data
        if initial_qpos is not None:
            data.qpos[:] = initial_qpos
        if initial_qvel is not None:
            data.qvel[:] = initial_qvel
        mujoco.mj_forward(model, data)
        self.warnings = MujocoWarnings()  # MuJoCo's handler is ours only within a step (rollouts interleave)
        self._closed = False
        try:
            self._start(initial_qvel, qvel_noise, hooks, before_step, pushes)
        except BaseException:
            self.close()
            raise

    def _start(self, initial_qvel: FloatArray | None, qvel_noise: FloatArray | None, hooks: list[Hook] | None,
               before_step: list[Hook] | None, pushes: list[Any] | None) -> None:
        model, data, ctrl, spec = self.model, self.data, self.ctrl, self.spec
        ctrl.reset(data, spec.start_frame)
        if qvel_noise is not None and initial_qvel is not None and not np.array_equal(data.qvel, initial_qvel):
            data.qvel[:] += qvel_noise  # the reset set the velocities: the seed's noise on those
            mujoco.mj_forward(model, data)
        fall = spec.fall or FallCriteria.for_body(self.plan.profile)
        self.falls = FallDetector(model, self.plan, fall, data, root=ctrl.root_body)
        self.dt = dt = model.opt.timestep
        #: physics steps per control period; between fall checks; in the whole rollout
        self.every = control_every(spec.control_dt if spec.control_dt is not None else ctrl.control_dt, dt)
        self.check_every = max(1, int(round(fall.check_every / dt)))
        self.n_steps = int(round(spec.seconds / dt))
        self.start_xy = data.qpos[0:2].copy()
        self.err2, self.n_err = 0.0, 0
        #: "no_fall", "fall" or "diverged"; the time (s) and reason of a fall or divergence
        self.verdict: tuple[str, float | None, str | None] = ("no_fall", None, None)
        self.hooks = list(hooks or [])
        self.before_step = list(before_step or [])
        self.schedule = _push_schedule(model, pushes, ctrl, self.before_step)
        # per control period: time (s), RMS tracking error (rad), COM xy (m); preallocated, not lists of
        # floats and small arrays that cost ~10x the memory on long runs
        n_ctrl = -(-self.n_steps // self.every) if self.schedule is not None or self.record_com else 0
        self.series_t, self.series_err = np.empty(n_ctrl), np.empty(n_ctrl)
        self.series_com = np.empty((n_ctrl, 2))
        self.n_series = 0
        #: physics steps taken; fall checks done; the next progress report (s)
        self.step_index, self.checks, self.next_progress = 0, 0, 1.0
        self.done = self.n_steps <= 0

    @property
    def time(self) -> float:
        """Simulated time now (s)."""
        return self.step_index * self.dt

    def step(self) -> bool:
        """One control period: control, then ``every`` physics steps (in one mj_step call when no hook
        needs to see each step); the fall and divergence checks once per ``check_every`` physics steps
        and at the end. Whether the rollout goes on (False once it has ended: its length reached, a
        fall, a divergence)."""
        if self.done:
            return False
        self.warnings.start()
        try:
            return self._step()
        finally:
            self.warnings.stop()

    def _step(self) -> bool:
        model, data, ctrl, dt, every = self.model, self.data, self.ctrl, self.dt, self.every
        step, n_steps = self.step_index, self.n_steps
        t = step * dt
        u = ctrl(model, data, t, dt * every)
        data.ctrl[:] = u
        e = ctrl.tracking_error
        ee = float(e.dot(e))
        self.err2 += ee
        self.n_err += len(e)
        if len(self.series_t):
            i = self.n_series
            self.series_t[i] = t
            self.series_err[i] = (ee / len(e)) ** 0.5
            self.series_com[i] = data.subtree_com[1, :2]
            self.n_series = i + 1
        for hk in self.hooks:
            hk(t, data, ctrl)
        k = min(every, n_steps - step)
        if self.before_step:
            for i in range(k):
                for hk in self.before_step:
                    hk((step + i) * dt, data, ctrl)
                mujoco.mj_step(model, data)
        else:
            mujoco.mj_step(model, data, k)
        step += k
        self.step_index = step
        if step // self.check_every > self.checks or step >= n_steps:
            self.checks = step // self.check_every
            bad = diverged(data)
            if bad:
                self.verdict = ("diverged", step * dt, self.warnings.reason(bad))
                self.done = True
                return False
            why = self.falls.check(data, ctrl)
            if why:
                self.verdict = ("fall", step * dt, why)
                self.done = True
                return False
            if self.progress is not None and step * dt >= self.next_progress:
                self.progress(step * dt)
                self.next_progress += 1.0
        self.done = step >= n_steps
        return not self.done

    def finish(self) -> Outcome:
        """The rollout's :class:`Outcome` as it stands (after the last :meth:`step`: its verdict)."""
        data, ctrl = self.data, self.ctrl
        last = max(self.step_index - 1, 0)  # index of the last physics step taken
        n = self.n_series
        series = (self.series_t[:n], self.series_err[:n], self.series_com[:n])
        result = _outcome(ctrl, self.spec, self.schedule, self.verdict, last, self.dt,
                          float(np.linalg.norm(data.qpos[0:2] - self.start_xy)),
                          float(np.sqrt(self.err2 / max(self.n_err, 1))), series, self.nominal_com, self.record_com,
                          ctrl.course_progress(data))
        result.wall_seconds = time.perf_counter() - self._t0
        return result

    def close(self) -> None:
        """The controller's model changes put back (once)."""
        if self._closed:
            return
        self._closed = True
        self.ctrl.restore_model()

    def __enter__(self) -> Rollout:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def rollout(model: mujoco.MjModel, plan: BodyPlanSet, ctrl: Controller,
            spec: RolloutSpec, *, initial_qpos: FloatArray | None = None, initial_qvel: FloatArray | None = None,
            qvel_noise: FloatArray | None = None,
            hooks: list[Hook] | None = None, before_step: list[Hook] | None = None,
            progress: Callable[[float], None] | None = None, pushes: list[Any] | None = None,
            nominal_com: tuple[FloatArray, FloatArray] | None = None,
            record_com: bool = False) -> tuple[Outcome, Controller]:
    """Run one rollout of any body under ``ctrl`` to its end (:class:`Rollout`, stepped until it has
    ended). Returns the outcome and the controller."""
    with Rollout(model, plan, ctrl, spec, initial_qpos=initial_qpos, initial_qvel=initial_qvel,
                 qvel_noise=qvel_noise, hooks=hooks, before_step=before_step, progress=progress, pushes=pushes,
                 nominal_com=nominal_com, record_com=record_com) as run:
        while run.step():
            pass
        return run.finish(), ctrl
