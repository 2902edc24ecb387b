"""Assemble a rollout from user-level choices: a controller YAML, a BVH (or the built-in walk), a body
profile. Used by ``bipedsim run``, sweeps and regression suites."""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from bipedsim.config import to_dict
from bipedsim.control import CONTROLLERS, Controller, CreatureControlConfig
from bipedsim.control.humanoid.correction import Correction
from bipedsim.control.humanoid.simbicon import SimbiconController, body_mass, leg_length
from bipedsim.control.settings import (
    ControllerConfig,
    check_settings_for_body,
    describe_body_scale,
    for_body,
    for_reference,
    load_controller,
)
from bipedsim.data import BUILTIN_WALK
from bipedsim.errors import ConfigError, ModelError
from bipedsim.files import atomic_write_json, versions
from bipedsim.model.build import BuiltModel, build_model, load_model
from bipedsim.model.builtin import builtin_humanoid_path
from bipedsim.model.creature_kind import AUTO, resolve_profile
from bipedsim.model.ground import Ground, Terrain, start_frame_of, terrain_of, with_ground
from bipedsim.motion.bvh import read_bvh
from bipedsim.reference.clip import ReferenceClip
from bipedsim.reference.feasible import feasible_clip
from bipedsim.reference.feasible_measure import measure, resolve_because
from bipedsim.reference.prepare import load_source
from bipedsim.reference.retarget import retarget
from bipedsim.sim.fidelity import measure_fidelity
from bipedsim.sim.push import Push, PushSchedule, check_pushes
from bipedsim.sim.reconstruct import cached_choice, correction_for, correction_key, has_correction, remember_choice
from bipedsim.sim.recorder import Recorder
from bipedsim.sim.rollout import FallCriteria, FloatArray, Outcome, RolloutSpec, control_every, rollout

#: body kinds a scenario can be built as (``--profile``); ``auto``: measured from the skeleton
#: (:func:`~bipedsim.model.creature_kind.detect_body_kind`)
PROFILES = (AUTO, "humanoid", "creature")


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


def load_scenario(config: str | os.PathLike[str] | ControllerConfig | None = None,
                  bvh: str | os.PathLike[str] | None = None, *,
                  scale: float | str | None = None, up: str | None = None, mass: float | None = None,
                  profile: str | None = AUTO, support: bool = False, positions: str | None = None,
                  events: str | os.PathLike[str] | None = None, fps: float | None = None,
                  reconstruct: bool | None = None, ground: Ground | None = None) -> Scenario:
    """The built-in humanoid and walk, or a body of ``profile`` built from ``bvh`` and its motion
    retargeted onto it (``auto``: the kind measured from the skeleton, :func:`resolve_profile`). A
    controller YAML (or its settings, a :class:`ControllerConfig`) configures the humanoid's controller and
    how its reference is prepared (``reference:``), its ``creature:`` section a creature's controller;
    ``support`` (root support, or the section's ``support``) is a creature's. ``scale``, ``up``,
    ``positions`` and ``fps`` (the capture's frame rate) say how to read ``bvh``
    (:func:`~bipedsim.motion.bvh.read_bvh`). A controller file that changes settings the body's controller
    never reads (:func:`~bipedsim.control.settings.check_settings_for_body`) or a humanoid's ``control_dt``
    that is no whole number of physics steps (:func:`~bipedsim.sim.rollout.control_every`) is refused,
    naming the file and the keys. A humanoid tracking the whole of a ``bvh`` clip gets its feed-forward
    correction (:func:`~bipedsim.sim.reconstruct.correction_for`: searched, or read from the cache)
    when ``reconstruct`` says so (None: :func:`reconstruct_wanted`), and then loops the clip's best cycle
    instead where that walks the clip better (:func:`whole_or_looped`). ``ground`` (default flat)
    replaces the floor before a correction is searched (:func:`on_ground`): the search walks the same
    ground, its tracking cost measuring heights above it."""
    profile = AUTO if profile is None else profile
    if profile not in PROFILES:
        raise ConfigError(f"unknown body profile {profile!r}; profiles: {', '.join(PROFILES)}", key="profile")
    if bvh is None and profile == AUTO:
        profile = "humanoid"  # the built-in walk
    cfg = config if isinstance(config, ControllerConfig) else load_controller(config)
    motion = info = None
    if bvh is not None:
        raw, info, motion, profile = load_source(bvh, scale=scale, up=up, positions=positions, profile=profile,
                                                    support=support, creature_support=cfg.creature.support, fps=fps)
        if profile == "creature":
            support = support or cfg.creature.support
    if profile != "creature" and support:
        raise ConfigError("root support holds a creature's root; it needs the creature profile", key="support")
    if profile == "creature" and bvh is None:
        raise ConfigError("the creature profile needs a motion: give a BVH (--bvh FILE)", key="profile")
    config_path = None if config is None or isinstance(config, ControllerConfig) else str(config)
    if config_path is not None:  # a file's settings this body's controller would not read
        check_settings_for_body(cfg, profile, path=config_path)
    if bvh is None:
        raw, info = read_bvh(BUILTIN_WALK)
        motion = raw.to_project_frame()
        built = load_model(builtin_humanoid_path())
        if mass is not None:
            built = build_model(motion, "humanoid", total_mass=mass, name="humanoid")
        src = str(BUILTIN_WALK)
    else:
        built = build_model(motion, profile, total_mass=mass, name=Path(bvh).stem, source=bvh)
        src = str(bvh)
    extra: dict[str, Any] = {}
    if profile == "humanoid":  # the settings' lengths, times and torques scaled to this body
        control_every(cfg.control_dt, float(built.model.opt.timestep), path=config_path)
        leg, kg = leg_length(built.model), body_mass(built.model)
        note = describe_body_scale(cfg.body, leg, kg)
        if note:
            extra["body_scale"] = note
        cfg = for_body(cfg, leg, kg)
    clip = retarget(motion, built.model, plan=built.plan, xml=built.xml, source=src, events=events,
                    events_skip=getattr(info, "lead_in_frames", 0) if bvh is not None else 0)
    resolved = False
    if cfg.reference.feasible is not False and profile == "humanoid":  # reference/feasible.py
        forced = cfg.reference.feasible is True
        generated = bvh is None or Path(bvh).resolve() == Path(BUILTIN_WALK).resolve()  # the built-in walk
        why = ["reference: {feasible: true}"] if forced else resolve_because(measure(clip, built.model),
                                                                              cfg.reference, generated)
        if why:
            clip = feasible_clip(clip, built.model, cfg.reference)
            extra["feasible"] = why
            resolved = True
    cfg = for_reference(cfg, resolved)  # the "auto" modulation terms act on a re-solved reference
    sc = Scenario(built=built, clip=clip, cfg=cfg, source_path=src, config_path=config_path, motion=motion,
                  bvh_info=info, extra=extra, creature_cfg=replace(cfg.creature, support=support))
    sc = on_ground(sc, ground)  # the search walks the ground the run walks (its key: the body with it)
    search = reconstruct_wanted(cfg, reconstruct)
    # a capture's (the built-in walk was made for its body and tracks without one)
    if search and bvh is not None and profile == "humanoid" and cfg.source == "clip":
        judged = judge_once()
        searched = search_settings(sc, judged)
        sc.correction, sc.extra["reconstruct"] = correction_for(
            sc.built.model, sc.built.hash, replace(sc, cfg=searched).controller, clip, searched, sc.fall_criteria(),
            lambda c: judge_correction(sc, c, judged))
        key = correction_key(clip, sc.built.hash, searched)
        rule = choice_rule()
        chosen = cached_choice(key, rule)
        if chosen is None:
            sc, fallback = whole_or_looped(sc, judged)
            remember_choice(key, sc.cfg.source, fallback, rule)
        else:
            fallback = chosen[1]
            sc = looped(sc) if chosen[0] == "cycle" else sc
        if fallback:
            sc.extra["reconstruct"] += "\n" + fallback
    return sc


def search_settings(sc: Scenario, judged: Judge) -> ControllerConfig:
    """The settings ``sc``'s search runs with: its own, or ``reconstruct.cover_s`` 0 where the clip's best
    cycle looped by the feedback alone (:func:`looped`) stands a whole judging run (:func:`_judged`): a
    loop the controller walks needs no open-loop correction past ``loop_max_s``, which would only make the
    run more sensitive to a disturbance. A search cached with either is used without a judging run."""
    cfg = sc.cfg
    if cfg.reconstruct.cover_s <= 0.0:
        return cfg
    short = replace(cfg, reconstruct=replace(cfg.reconstruct, cover_s=0.0))
    for settings in (cfg, short):  # the search run before, whichever it was
        if has_correction(correction_key(sc.clip, sc.built.hash, settings)):
            return settings
    try:
        t_loop, _ = judged(looped(sc))
    except ModelError:  # no cycle to loop: nothing past the clip to search
        return cfg
    return short if t_loop >= judging_seconds(sc) - 1e-9 else cfg


def on_ground(sc: Scenario, ground: Ground | None) -> Scenario:
    """``sc`` with its body on ``ground`` (None or flat: ``sc`` itself), the ground laid from the root's
    start along the reference's walking direction
    (:func:`~bipedsim.model.ground.start_frame_of`)."""
    if ground is None or ground.flat:
        return sc
    start = sc.controller().start_frame()
    frame = start_frame_of(sc.clip.qpos, start, sc.clip.frame_time)
    return replace(sc, built=with_ground(sc.built, ground, frame), ground=ground,
                   extra={k: v for k, v in sc.extra.items() if k != "nominal_com"})


#: the environment variable that turns the per-clip search off (``0``, ``off``, ``false``, ``no``) or on
#: for every run that does not say (a test suite, a batch of quick looks)
RECONSTRUCT_ENV = "BIPEDSIM_RECONSTRUCT"


def reconstruct_wanted(cfg: ControllerConfig, asked: bool | None) -> bool:
    """Whether a humanoid's clip gets its searched correction: as ``asked`` (``--no-reconstruct``, the
    API's argument), else as :data:`RECONSTRUCT_ENV` says, else as the settings' ``reconstruct.enabled``."""
    if asked is not None:
        return asked
    env = os.environ.get(RECONSTRUCT_ENV, "").strip().lower()
    if env in ("0", "off", "false", "no"):
        return False
    if env in ("1", "on", "true", "yes"):
        return True
    if env:
        raise ConfigError(f"{RECONSTRUCT_ENV}={env!r}: say on or off (1/0, true/false, yes/no)", key=RECONSTRUCT_ENV)
    return cfg.reconstruct.enabled


#: seconds a correction is judged over beyond the clip's end (the fade into the loop, a few steps of it)
JUDGE_BEYOND_S = 5.0
#: the shortest judging run (s): what a run of a short clip is judged by (a walk holds 20 s)
JUDGE_MIN_S = 20.0


def judging_seconds(sc: Scenario) -> float:
    """How long a judging run of ``sc`` lasts (s): its clip and :data:`JUDGE_BEYOND_S` beyond, at least
    :data:`JUDGE_MIN_S`."""
    return max(JUDGE_MIN_S, sc.clip.duration + JUDGE_BEYOND_S)


def _judged(sc: Scenario) -> tuple[float, float]:
    """One run of ``sc`` over its clip and :data:`JUDGE_BEYOND_S` beyond (at least :data:`JUDGE_MIN_S`): how
    long it stands (s) and the
    largest distance of its root path from the clip's (m, :func:`~bipedsim.sim.fidelity.measure_fidelity`)."""
    seconds = judging_seconds(sc)
    rec = Recorder(sc.built.model, record_hz=30.0, seconds=seconds)
    out, ctrl = run_scenario(sc, RolloutSpec(seconds=seconds), hooks=[rec])
    tr = rec.trajectory()
    fid = measure_fidelity(sc.built.model, tr.time, tr.qpos, sc.clip.qpos, sc.clip.frame_time,
                           ctrl.start_frame(), run_seconds=out.sim_seconds)
    return out.sim_seconds, fid.path_max_m if fid is not None else math.inf


Judge = Callable[[Scenario], tuple[float, float]]


def judge_once() -> Judge:
    """:func:`_judged`, remembering each (source, correction)'s result: the checks of one scenario share
    their runs (the whole clip with its kept correction is run once, not once per check)."""
    seen: dict[tuple[str, object], tuple[float, float]] = {}

    def judged(sc: Scenario) -> tuple[float, float]:
        c = sc.correction  # by content: a variant made for one check is another correction
        key = (sc.cfg.source, None if c is None else (c.starts, c.rows.tobytes(), c.end, c.fade, c.period))
        if key not in seen:
            seen[key] = _judged(sc)
        return seen[key]

    return judged


def looped(sc: Scenario) -> Scenario:
    """``sc`` looping its clip's best cycle (``source: cycle``), without a correction (one is searched
    for the whole clip)."""
    return replace(sc, cfg=replace(sc.cfg, source="cycle"), correction=None)


def whole_or_looped(sc: Scenario, judged: Judge = _judged) -> tuple[Scenario, str | None]:
    """``sc`` tracking its whole clip (with its correction, if any), or the clip's best cycle looped
    (``source: cycle``) where that does better over a judging run (:func:`_judged`, :func:`_better`): it
    stands longer, or as long with its root path nearer the clip's. The scenario to run and a line saying
    which was chosen (None: the whole clip)."""
    whole = judged(sc)
    cycle = looped(sc)
    try:
        loop = judged(cycle)
    except ModelError:  # no cycle to loop
        return sc, None
    if not _better(loop, whole) or _better(whole, loop):
        return sc, None
    over = f"over max({JUDGE_MIN_S:g} s, the clip and {JUDGE_BEYOND_S:g} s beyond)"
    why = (f"the whole clip falls at {whole[0]:.1f} s where its best cycle looped stands {loop[0]:.1f} s ({over})"
           if loop[0] > whole[0] + 1e-9 else
           f"both stand {whole[0]:.1f} s ({over}), the whole clip's root path keeps within {whole[1]:.2f} m of the "
           f"clip's, its best cycle looped within {loop[1]:.2f} m")
    return cycle, (f"reference: {why}: the run loops the cycle (source: cycle); --no-reconstruct tracks the whole "
                   "clip anyway")


def choice_rule() -> str:
    """A digest of the code that chooses between the whole clip and its looped cycle (this module): a
    choice cached by other code is made again."""
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]


def _better(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether judging result ``a`` (stood s, path distance m) beats ``b``: it stands longer, or as long
    with its root path nearer the clip's."""
    return a[0] > b[0] + 1e-9 or (a[0] >= b[0] - 1e-9 and a[1] <= b[1])


def judge_correction(sc: Scenario, corrs: Correction | list[Correction], judged: Judge = _judged
                     ) -> tuple[bool, str, Correction]:
    """Whether ``sc`` tracks its clip better with the best of ``corrs`` than without, and the correction
    to keep: each way, one run over the clip and :data:`JUDGE_BEYOND_S` beyond; the one that stands
    longer wins, then the one whose root path stays nearer the clip's
    (:func:`~bipedsim.sim.fidelity.measure_fidelity`). A correction that repeats its last loop period is
    also run fading out after it instead (feedback alone walks the loop on). Also a clause saying how
    they compared."""
    cands = [corrs] if isinstance(corrs, Correction) else list(corrs)
    cands += [replace(c, period=0.0) for c in cands if c.period > 0.0]
    corr, with_ = cands[0], judged(replace(sc, correction=cands[0]))
    for c in cands[1:]:
        r = judged(replace(sc, correction=c))
        if _better(r, with_) and not _better(with_, r):
            corr, with_ = c, r
    (t_with, d_with), (t_without, d_without) = with_, judged(sc)
    keep = _better(with_, (t_without, d_without))
    told = (f"with it the root path keeps within {d_with:.2f} m of the clip's, without {d_without:.2f} m"
            if abs(t_with - t_without) < 1e-9 else f"with it the body stands {t_with:.1f} s, without {t_without:.1f} s")
    clip_end = sc.clip.num_frames - 1
    after = ("; after the searched loop it repeats its last period" if corr.period > 0.0
             else "; the search's best at the clip's end, fading out after it" if corr.end <= clip_end + 1e-9
             else "; it fades out after the searched loop")
    return keep, ("kept: " if keep else "not kept: ") + told + (after if keep else ""), corr


def settings_for(sc: Scenario, settings: ControllerConfig) -> ControllerConfig:
    """A humanoid controller's ``settings`` made for this scenario's body and reference as
    :func:`load_scenario` makes its own: scaled to the body (:func:`~bipedsim.control.settings.for_body`)
    and the ``"auto"`` modulation switches resolved for its reference
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


__all__ = ["AUTO", "PROFILES", "SEED_NOISE", "resolve_profile", "Scenario", "load_scenario", "run_scenario",
           "run_seeds", "seed_noise", "write_outcome", "on_ground"]
