"""A scenario -- a built body, its reference clip, its controller's settings and correction -- and the
one rollout of it every command runs (:func:`run_scenario`). Built from user-level choices by
:func:`bipedsim.sim.runner.load_scenario`."""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from bipedsim.config import to_dict
from bipedsim.control import CONTROLLERS, Controller, CreatureControlConfig
from bipedsim.control.humanoid.correction import Correction, Nominal
from bipedsim.control.humanoid.simbicon import SimbiconController, body_mass, leg_length
from bipedsim.control.settings import ControllerConfig, for_body, for_reference
from bipedsim.files import atomic_write_json, versions
from bipedsim.model.build import BuiltModel
from bipedsim.model.ground import Ground, Terrain, terrain_of
from bipedsim.reference.clip import ReferenceClip
from bipedsim.sim.push import Push, PushSchedule, check_pushes
from bipedsim.sim.rollout import FallCriteria, FloatArray, Outcome, RolloutSpec, rollout


@dataclass
class Scenario:
    """Everything one rollout needs: a built body, its reference clip and its controller's settings
    (``cfg`` for the humanoid's SIMBICON controller, ``creature_cfg`` for a creature's)."""

    built: BuiltModel
    clip: ReferenceClip
    cfg: ControllerConfig
    source_path: str
    config_path: str | None
    motion: Any = None  #: the source motion, project frame
    bvh_info: Any = None  #: what reading the source BVH found (unit, up axis)
    extra: dict[str, Any] = field(default_factory=dict)
    creature_cfg: CreatureControlConfig = field(default_factory=CreatureControlConfig)
    #: the feed-forward correction a humanoid's controller runs with (:mod:`bipedsim.sim.reconstruct`)
    correction: Correction | None = None
    #: the ground the body walks on (:mod:`bipedsim.model.ground`; the default: flat)
    ground: Ground = field(default_factory=Ground)

    @property
    def terrain(self) -> Terrain | None:
        """Height and normal queries of :attr:`ground` (None: flat at z = 0), as the controller gets them."""
        return terrain_of(self.built.model)

    @property
    def profile(self) -> str:
        return self.built.plan.profile

    @property
    def tracks_clip(self) -> bool:
        """Whether the controller tracks :attr:`clip` (every creature; a humanoid unless its gait source
        is SIMBICON's key poses, ``source: pose``), so the run can be judged against it."""
        return self.profile == "creature" or self.cfg.source != "pose"

    def controller(self) -> Controller:
        """A fresh controller for this body, from the registry of controllers by body kind."""
        cfg = self.creature_cfg if self.profile == "creature" else self.cfg
        ctrl = CONTROLLERS[self.profile](self.built.model, self.built.plan, self.clip, cfg)
        if self.correction is not None and isinstance(ctrl, SimbiconController):
            ctrl.correction = self.correction
            ctrl.nominal = nominal_path(self)
        if isinstance(ctrl, SimbiconController):
            ctrl.terrain = self.terrain
        return ctrl

    def foot_names(self, ctrl: Controller | None = None) -> tuple[str, ...]:
        """The feet the controller reports contact forces for (the recorder's columns); ``ctrl``: a
        controller of this scenario already made (else one is made to ask)."""
        return (ctrl or self.controller()).foot_names()

    def check_pushes(self, pushes: list[Push], ctrl: Controller | None = None) -> None:
        """The pushes fit this body: bodies it has, gait states its controller has (before any run);
        ``ctrl`` as for :meth:`foot_names`."""
        if pushes:
            PushSchedule(self.built.model, list(pushes)).check_controller(ctrl or self.controller())

    def fall_criteria(self) -> FallCriteria:
        return FallCriteria.for_body(self.profile, support=self.creature_cfg.support)

    def controller_config(self) -> dict[str, Any]:
        """The controller's settings as recorded with an outcome."""
        return to_dict(self.creature_cfg) if self.profile == "creature" else to_dict(self.cfg)


#: s: a strike this much sooner or later than the correction's path's counts as the path's (Nominal.window)
STRIKE_WINDOW_S = 0.05


def nominal_path(sc: Scenario) -> Nominal | None:
    """Where the scenario's correction keeps the body (:class:`Nominal`): its noiseless rollout from the
    controller's start over the searched frames and the correction's fade after them, made once per
    scenario, correction, settings and ground. None without a correction, with ``reconstruct.reach`` 0,
    or where the reference frame does not move on at every control step (a resynchronisation that holds
    or moves it back: frames would not name the path's places)."""
    corr = sc.correction
    if corr is None or sc.profile != "humanoid" or sc.cfg.reconstruct.reach <= 0.0:
        return None
    memo = sc.extra.setdefault("nominal", {})
    key = (id(corr), sc.built.hash, tuple(sc.ground.terms()))
    kept = memo.get(key)
    if kept is None or kept[0] is not corr or kept[1] != sc.cfg:
        ctrl = CONTROLLERS[sc.profile](sc.built.model, sc.built.plan, sc.clip, sc.cfg)
        assert isinstance(ctrl, SimbiconController)
        ctrl.correction, ctrl.terrain, ctrl.nominal_log = corr, sc.terrain, []
        src = ctrl.source
        span = corr.end + (corr.fade if corr.period <= 0.0 else 0.0) - ctrl.start_frame()
        seconds = max(0.0, span * src.frame_time)
        if seconds > 0.0:
            spec, qpos0, qvel0, _ = start_state(sc, RolloutSpec(seconds=seconds), ctrl)
            rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=qpos0, initial_qvel=qvel0)
        log = ctrl.nominal_log
        frames = np.array([r[0] for r in log])
        path = None
        if len(frames) and np.all(np.diff(frames) > 0.0):
            path = Nominal(frames=frames, com=np.array([r[1:5] for r in log]).reshape(-1, 4),
                           left=np.array([r[5] for r in log], dtype=bool), end=corr.end, period=corr.period,
                           window=STRIKE_WINDOW_S / src.frame_time)
        memo[key] = kept = (corr, sc.cfg, path)  # the correction kept with it, so its id is not reused
    return kept[2]


def settings_for(sc: Scenario, settings: ControllerConfig) -> ControllerConfig:
    """A humanoid controller's ``settings`` made for this scenario's body and reference as
    :func:`~bipedsim.sim.runner.load_scenario` makes its own: scaled to the body
    (:func:`~bipedsim.control.settings.for_body`) and the ``"auto"`` modulation switches resolved for its reference
    (:func:`~bipedsim.control.settings.for_reference`). Both leave settings already made so unchanged."""
    m = sc.built.model
    return for_reference(for_body(settings, leg_length(m), body_mass(m)), "feasible" in sc.extra)


def run_scenario(sc: Scenario, spec: RolloutSpec, *, hooks: list | None = None, before_step: list | None = None,
                 progress: Any = None, pushes: list | None = None) -> tuple[Outcome, Controller]:
    """Run one rollout of any body from its controller's start frame (the reference pose and velocity
    there).

    The run length and the pushes are checked first (:func:`~bipedsim.sim.push.check_pushes`: every
    rollout, from ``bipedsim run``, a sweep or a suite, goes through here); errors name the command
    line's ``--seconds`` and ``--push`` (sweeps and suites check their files, with file and key, when
    they load them)."""
    check_pushes(list(pushes or []), spec.seconds)
    ctrl = sc.controller()
    spec, qpos0, qvel0, noise = start_state(sc, spec, ctrl)
    nominal = None
    if pushes:
        # the same rollout without pushes, for the centre-of-mass deviation (cached per scenario);
        # everything that changes that rollout is in the key. The seed only matters with initial
        # noise: without it, rollouts of other seeds share one
        key = (spec.seconds, spec.seed if noise is not None else 0, spec.init_noise, spec.start_frame, spec.fall,
               spec.control_dt)
        cache = sc.extra.setdefault("nominal_com", {})
        if key not in cache:
            o, _ = rollout(sc.built.model, sc.built.plan, sc.controller(), spec, initial_qpos=qpos0,
                           initial_qvel=qvel0, qvel_noise=noise, record_com=True)
            cache[key] = o.extra["com_series"]
        nominal = cache[key]
    out, ctrl = rollout(sc.built.model, sc.built.plan, ctrl, spec, initial_qpos=qpos0, initial_qvel=qvel0,
                        qvel_noise=noise, hooks=hooks, before_step=before_step, progress=progress, pushes=pushes,
                        nominal_com=nominal)
    record_made(out, sc, spec, pushes)
    return out, ctrl


def start_state(sc: Scenario, spec: RolloutSpec, ctrl: Controller
                ) -> tuple[RolloutSpec, FloatArray, FloatArray, FloatArray | None]:
    """Where a rollout of ``sc`` under ``ctrl`` starts: ``spec`` with its start frame (the controller's,
    when it starts moving) and fall criteria (the scenario's) filled in, the initial qpos and qvel (the
    clip's at that frame, the seed's velocity noise added) and that noise (None without)."""
    frame = ctrl.start_frame()
    spec = replace(spec, start_frame=float(frame) if spec.start_frame is None and ctrl.starts_moving
                   else spec.start_frame, fall=spec.fall or sc.fall_criteria())
    qpos0 = sc.clip.qpos[frame].copy()
    qvel0 = sc.clip.qvel[frame].copy() if ctrl.starts_moving else np.zeros(sc.built.model.nv)
    noise = seed_noise(spec, qvel0.shape)
    if noise is not None:
        qvel0 = qvel0 + noise
    return spec, qpos0, qvel0, noise


def record_made(out: Outcome, sc: Scenario, spec: RolloutSpec, pushes: list | None = None) -> None:
    """Record in ``out`` what made it: the scenario, the run's settings and pushes, the versions."""
    out.config = {"profile": sc.profile, "controller": sc.controller_config(), "controller_file": sc.config_path,
                  "reference": sc.source_path, "model": sc.built.plan.name, "model_hash": sc.built.hash,
                  "seconds": spec.seconds, "fall": to_dict(spec.fall), "init_noise": spec.init_noise,
                  "timestep_s": float(sc.built.model.opt.timestep),
                  "pushes": [to_dict(p) for p in (pushes or [])], "reading": reading_record(sc.bvh_info),
                  "ground": sc.ground.terms()}
    out.versions = versions()


def seed_noise(spec: RolloutSpec, shape: tuple[int, ...]) -> FloatArray | None:
    """The initial velocity noise of ``spec`` (rad/s, m/s): Gaussian with standard deviation
    ``spec.init_noise``, drawn from a generator seeded with ``spec.seed`` -- every seed, 0 included, so a
    sweep's rows all get the noise its file records; None without noise (``init_noise`` 0)."""
    if not spec.init_noise > 0:
        return None
    return np.random.default_rng(spec.seed).normal(scale=spec.init_noise, size=shape)


def reading_record(info: Any) -> dict[str, Any] | None:
    """How the reference's BVH file was read (unit, up axis, frame rate, each with where it came from),
    for a run's recorded config: a file read another way is another reference."""
    if info is None:
        return None
    return {"unit_m_per_unit": info.unit_scale, "unit": info.unit_source, "up": info.up, "up_source": info.up_source,
            "fps": info.fps, "fps_source": info.frame_time_source}


#: the initial velocity noise (rad/s, m/s; standard deviation) of seeds 1.. in :func:`run_seeds`:
#: a human walk's and a creature's (docs/controller.md)
SEED_NOISE = {"humanoid": 0.02, "creature": 0.05}


def run_seeds(sc: Scenario, seconds: float, seeds: int = 3, noise: float | None = None,
              start: int = 0) -> list[Outcome]:
    """Rollouts of seeds ``start`` .. ``seeds`` - 1: seed 0 from the reference's own start, each later seed with
    ``noise`` (default: :data:`SEED_NOISE` for the body's kind) of Gaussian noise added to the initial
    velocities. A walk's single outcome is chaotic (the same walk falls or not on a few mrad/s), so its
    measures are counted or taken as medians over these runs."""
    if seeds < 1:
        raise ValueError(f"seeds: need at least 1, got {seeds}")
    sd = SEED_NOISE.get(sc.profile, SEED_NOISE["humanoid"]) if noise is None else noise
    return [run_scenario(sc, RolloutSpec(seconds=seconds, seed=s, init_noise=sd if s else 0.0))[0]
            for s in range(start, seeds)]


def write_outcome(out: Outcome, folder: str | os.PathLike[str]) -> Path:
    path = Path(folder) / "outcome.json"
    atomic_write_json(path, out.to_dict())
    return path
