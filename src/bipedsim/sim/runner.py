"""Assemble a rollout from user-level choices: a controller YAML, a BVH (or the built-in walk), a body
profile. Used by ``bipedsim run``, sweeps and regression suites."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

from bipedsim.control.humanoid.simbicon import body_mass, leg_length
from bipedsim.control.settings import (
    ControllerConfig,
    check_settings_for_body,
    describe_body_scale,
    for_body,
    for_reference,
    load_controller,
)
from bipedsim.data import BUILTIN_WALK
from bipedsim.errors import ConfigError
from bipedsim.model.build import build_model, load_model
from bipedsim.model.builtin import builtin_humanoid_path
from bipedsim.model.creature_kind import AUTO, resolve_profile
from bipedsim.model.ground import Ground, start_frame_of, with_ground
from bipedsim.motion.bvh import read_bvh
from bipedsim.reference.feasible import feasible_clip
from bipedsim.reference.feasible_measure import measure, resolve_because
from bipedsim.reference.prepare import load_source
from bipedsim.reference.retarget import retarget
from bipedsim.sim.judging import (
    JUDGE_BEYOND_S,
    JUDGE_MIN_S,
    judge_correction,
    judging_seconds,
    looped,
    search_settings,
    whole_or_looped,
    with_correction,
)
from bipedsim.sim.rollout import control_every
from bipedsim.sim.scenario import (
    SEED_NOISE,
    Scenario,
    reading_record,
    record_made,
    run_scenario,
    run_seeds,
    seed_noise,
    settings_for,
    start_state,
    write_outcome,
)

#: body kinds a scenario can be built as (``--profile``); ``auto``: measured from the skeleton
#: (:func:`~bipedsim.model.creature_kind.detect_body_kind`)
PROFILES = (AUTO, "humanoid", "creature")


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
    instead where that walks the clip better (:func:`~bipedsim.sim.judging.whole_or_looped`). ``ground`` (default flat)
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
        sc = with_correction(sc)
    return sc


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


__all__ = ["AUTO", "PROFILES", "SEED_NOISE", "resolve_profile", "Scenario", "load_scenario", "run_scenario",
           "run_seeds", "seed_noise", "write_outcome", "on_ground", "settings_for", "start_state", "record_made",
           "JUDGE_BEYOND_S", "JUDGE_MIN_S", "judge_correction", "judging_seconds", "looped", "search_settings",
           "whole_or_looped", "reading_record"]
