"""Controller configuration: ``controllers/*.yaml`` validated into typed objects.

The defaults live here, once: the dataclasses' defaults *are* the default controller (the humanoid's
sections in :mod:`~bipedsim.control.humanoid.settings`, the creature's in
:mod:`~bipedsim.control.creature.settings`, both importable from here).
``controllers/default.yaml`` is generated from them (``bipedsim config``, :func:`controller_yaml`; a test
keeps the two equal). A controller file is layered over these defaults: a file that names only
``pd.gains.hip.kp`` is the default controller with that one value changed (mappings are merged key by
key; lists and scalars replace).

Every key is checked; unknown keys, wrong types and impossible values (negative gains, reversed
limits, a fade that never ends) are rejected with the file and the dotted key named.
"""

from __future__ import annotations

import os
import re
import textwrap
from dataclasses import dataclass, field, fields, is_dataclass, replace
from typing import Any

import yaml

from bipedsim import config
from bipedsim.control.creature.settings import CreatureControlConfig
from bipedsim.control.humanoid.settings import (
    DEFAULT_GAINS,
    PD_MODES,
    BalanceConfig,
    CourseConfig,
    FadeConfig,
    FSMConfig,
    Gain,
    ModulationConfig,
    PDConfig,
    PlaneGains,
    PoseGait,
    PoseState,
    ReconstructConfig,
    ResyncConfig,
    StanceAnkleConfig,
    SwingFootConfig,
    TempoConfig,
    VelocityConfig,
)
from bipedsim.errors import ConfigError
from bipedsim.model.profile import JOINT_GROUPS, MASS_RANGE_KG
from bipedsim.reference.feasible import FeasibleConfig

__all__ = [
    "DEFAULT_GAINS", "PD_MODES", "SOURCES", "BalanceConfig", "BodyScaleConfig", "ControllerConfig", "CourseConfig",
    "CreatureControlConfig", "FSMConfig", "FadeConfig", "Gain", "ModulationConfig", "PDConfig", "PlaneGains",
    "PoseGait", "PoseState", "ResyncConfig", "StanceAnkleConfig", "SwingFootConfig", "TempoConfig", "VelocityConfig",
    "check_settings_for_body", "controller_yaml", "for_body", "for_reference", "load_controller", "merged",
    "unread_settings"]

SOURCES = ("clip", "cycle", "pose")
#: the slowest control step accepted (s): 20 Hz. A stance lasts 0.3-0.4 s; at a slower rate the FSM
#: sees a foot strike late and the balance feedback acts on a step already over
MAX_CONTROL_DT = 0.05
#: leg lengths (m, hip to ankle) the settings may be said to be for (``body:``): the legs of the
#: humanoids that can be built (0.6-3.0 m tall, :data:`~bipedsim.model.build.HUMANOID_BUILT_HEIGHT_M`),
#: with room; scaling to legs far outside them would multiply gains by absurd factors
LEG_RANGE_M = (0.2, 2.0)


@dataclass(frozen=True)
class BodyScaleConfig:
    """The bodies the settings hold for, and their scaling to another body (dynamic similarity).

    Every setting with a unit of length, time, force or torque holds for bodies whose legs (hip to ankle,
    the two legs' mean) are ``leg_min`` to ``leg_max`` m long and which weigh ``mass`` kg. Run on another
    body (legs L, mass m), each is scaled by the powers of the leg ratio and
    of m / ``mass`` its unit has (:data:`BODY_UNITS`: a length by the leg ratio, a time by its square
    root, a torque or a PD stiffness by the mass ratio times the leg ratio, ...); the leg ratio is L over
    the nearer end of the range (1 inside it). So a child's or a giant's body walking its clip at the
    same Froude number gets the same control. ``torque_scale`` multiplies the model's
    own joint torque limits (a group's ``pd.gains`` limit, when set, is scaled instead). A config
    recorded with a run has been scaled and names that run's body, so running it again on that body
    changes nothing. ``scale: false``: every value as written."""

    scale: bool = True
    leg_min: float = field(default=0.78, metadata={"min": LEG_RANGE_M[0], "max": LEG_RANGE_M[1]})  #: m
    leg_max: float = field(default=0.94, metadata={"min": LEG_RANGE_M[0], "max": LEG_RANGE_M[1]})  #: m
    mass: float = field(default=64.0, metadata={"min": MASS_RANGE_KG[0], "max": MASS_RANGE_KG[1]})  #: kg
    torque_scale: float = field(default=1.0, metadata={"gt": 0.0})  #: x the model's torque limits

    def validate(self) -> None:
        if self.leg_min > self.leg_max:
            raise ValueError(f"leg_min {self.leg_min} > leg_max {self.leg_max} (need leg_min <= leg_max)")


@dataclass(frozen=True)
class ControllerConfig:
    """The whole controller: a humanoid's sections, and a creature's (``creature:``)."""

    name: str = "default"
    #: what the humanoid tracks: the whole reference ``clip`` as captured (then its best gait cycle looped),
    #: that ``cycle`` looped from the start, or SIMBICON's key ``pose`` gait (``pose_gait``)
    source: str = field(default="clip", metadata={"choices": SOURCES})
    #: seconds between control steps (null: every physics step); physics runs at the model's timestep
    control_dt: float | None = field(default=0.004, metadata={"gt": 0.0, "max": MAX_CONTROL_DT})
    pd: PDConfig = field(default_factory=PDConfig)
    fsm: FSMConfig = field(default_factory=FSMConfig)  #: the gait machine and its clock
    balance: BalanceConfig = field(default_factory=BalanceConfig)
    fade: FadeConfig = field(default_factory=FadeConfig)
    resync: ResyncConfig = field(default_factory=ResyncConfig)
    #: the feed-forward correction searched for a clip (sampling-based control reconstruction)
    reconstruct: ReconstructConfig = field(default_factory=ReconstructConfig)
    #: corrections of a capture's reference to the body (Lee, Kim & Lee 2010)
    modulation: ModulationConfig = field(default_factory=ModulationConfig)
    #: the reference made feasible for the built body before tracking (reference/feasible.py)
    reference: FeasibleConfig = field(default_factory=FeasibleConfig)
    pose_gait: PoseGait = field(default_factory=PoseGait)
    #: the body the values above are for, scaled to the body run (:func:`for_body`)
    body: BodyScaleConfig = field(default_factory=BodyScaleConfig)
    #: a creature's controller (control/creature/gait.py): used instead of the sections above when the
    #: body is a creature
    creature: CreatureControlConfig = field(default_factory=CreatureControlConfig)

    def validate(self) -> None:
        for g in self.pd.gains:
            if g not in JOINT_GROUPS and g != "ball":
                raise ValueError(f"pd.gains.{g}: unknown joint group; groups are {', '.join(JOINT_GROUPS)}, ball")


def merged(base: Any, over: Any) -> Any:
    """``over`` layered on ``base``: mappings merged key by key (recursively), anything else replaced."""
    if isinstance(base, dict) and isinstance(over, dict):
        out = dict(base)
        for k, v in over.items():
            out[k] = merged(base[k], v) if k in base else v
        return out
    return over


def load_controller(path: str | os.PathLike[str] | None = None) -> ControllerConfig:
    """A controller YAML file layered over the defaults, or the default controller (``None``)."""
    if path is None:
        return ControllerConfig()
    data = config.load_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping of keys, got {type(data).__name__}", path=path)
    return config.from_dict(ControllerConfig, merged(config.to_dict(ControllerConfig()), data), path=path)


#: the width (characters) of the YAML :func:`controller_yaml` writes
YAML_WIDTH = 120
#: what :func:`controller_yaml` writes above the default controller
DEFAULT_YAML_HEADER = """\
# The default controller: every key with its default value. Generated from the typed settings in
# src/bipedsim/control/settings.py by `bipedsim config > controllers/default.yaml`; do not edit (a test
# keeps the two equal). What each term computes: docs/controller.md. A controller file of your own names
# only the keys it changes; `bipedsim config FILE` prints it merged over these defaults.
"""


def controller_yaml(path: str | os.PathLike[str] | None = None) -> str:
    """The controller file ``path`` merged over the defaults (``None``: the defaults alone) as YAML text:
    every key, each section headed by its one-line summary. Reading the text back
    (:func:`load_controller`) gives the same settings."""
    cfg = load_controller(path)
    head = DEFAULT_YAML_HEADER if path is None else f"# {path} merged over the defaults (bipedsim config)\n"
    return head + "\n".join(_yaml_lines(cfg, "")) + "\n"


def _yaml_lines(obj: Any, pad: str) -> list[str]:
    """The fields of dataclass ``obj`` as YAML lines indented by ``pad``."""
    out: list[str] = []
    above: type | None = None  # the class summarised by the last comment (a run of one class gets one)
    for f in fields(obj):
        value = getattr(obj, f.name)
        if is_dataclass(value) and type(value) is not above:
            width = YAML_WIDTH - len(pad) - 2
            out += [f"{pad}# {line}" for line in textwrap.wrap(_summary(type(value)), width)]
        above = type(value) if is_dataclass(value) else None
        out += _yaml_entry(f.name, value, pad)
    return out


def _yaml_entry(key: str, value: Any, pad: str) -> list[str]:
    """One key: on one line when its value is a scalar, a list, or a mapping of those that fits in
    :data:`YAML_WIDTH`; else the key and its entries below, indented."""
    data = config.to_dict(value)
    line = f"{pad}{key}: {_flow(data)}"
    nested = isinstance(data, dict) and any(isinstance(v, dict) for v in data.values())
    if not isinstance(data, dict) or not data or (not nested and len(line) <= YAML_WIDTH):
        return [line]
    if is_dataclass(value):
        return [f"{pad}{key}:", *_yaml_lines(value, pad + "  ")]
    return [f"{pad}{key}:", *(x for k, v in value.items() for x in _yaml_entry(k, v, pad + "  "))]


def _flow(data: Any) -> str:
    """``data`` in YAML's one-line (flow) form."""
    return yaml.safe_dump([data], default_flow_style=True, width=10**9, sort_keys=False).strip()[1:-1]


def _summary(cls: type) -> str:
    """The first sentence of a settings class's docstring, on one line, without reST markup."""
    text = " ".join((cls.__doc__ or "").split("\n\n")[0].split())
    text = re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", "`")
    return re.split(r"(?<=\.)\s+(?=[A-Z`])", text)[0]


#: the top-level keys of a controller file every body's controller reads (the rest are read by one kind)
SHARED_KEYS = frozenset({"name"})
#: the section only a creature's controller reads; every other key but :data:`SHARED_KEYS` is read only
#: by a humanoid's (SIMBICON) controller
CREATURE_SECTION = "creature"
#: most keys an error about unread settings lists (then "... and N more")
_LISTED_KEYS = 8


def changed_keys(a: Any, b: Any, prefix: str = "") -> list[str]:
    """The dotted keys at which plain data ``a`` and ``b`` (mappings of mappings, as
    :func:`~bipedsim.config.to_dict` makes) differ: a value in one and not the other, or unequal."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: list[str] = []
        for k in [*a, *(k for k in b if k not in a)]:
            key = f"{prefix}.{k}" if prefix else str(k)
            out += changed_keys(a.get(k), b.get(k), key) if k in a and k in b else [key]
        return out
    return [] if a == b else [prefix]


def unread_settings(cfg: ControllerConfig, profile: str) -> list[str]:
    """The settings of ``cfg`` that a ``profile`` body's controller would not read, as dotted keys: on a
    creature every key a humanoid's controller reads, on a humanoid the ``creature:`` section. Only values
    that differ from the defaults count: those are what a file changed (``controllers/default.yaml``
    restates every default, both kinds', and serves either)."""
    changed = changed_keys(config.to_dict(cfg), config.to_dict(ControllerConfig()))
    if profile == "creature":
        return [k for k in changed if k.split(".")[0] not in SHARED_KEYS | {CREATURE_SECTION}]
    return [k for k in changed if k.split(".")[0] == CREATURE_SECTION]


def check_settings_for_body(cfg: ControllerConfig, profile: str, path: str | os.PathLike[str] | None = None,
                            key: str | None = None) -> None:
    """Refuse a controller (the file at ``path``; ``key``: where a file names it) that changes settings
    the ``profile`` body's controller never reads (:func:`unread_settings`): they would be ignored without
    a word. The error names every such key."""
    unread = unread_settings(cfg, profile)
    if not unread:
        return
    listed = ", ".join(unread[:_LISTED_KEYS]) + (f" and {len(unread) - _LISTED_KEYS} more"
                                                  if len(unread) > _LISTED_KEYS else "")
    if profile == "creature":
        why = (f"sets {listed}, which only a humanoid's controller reads; this body is a creature, whose "
               f"controller reads only the '{CREATURE_SECTION}:' section: drop them, or put a creature's "
               f"settings under '{CREATURE_SECTION}:'")
    else:
        why = (f"sets {listed}, which only a creature's controller reads; this body is a humanoid, whose "
               f"controller ignores the '{CREATURE_SECTION}:' section: drop it, or run a creature "
               "(--profile creature)")
    raise ConfigError(why, path=path, key=key)


def for_reference(cfg: ControllerConfig, resolved: bool) -> ControllerConfig:
    """``cfg`` with every ``"auto"`` reference-modulation switch (``modulation.swing_foot``,
    ``modulation.stance_ankle``) made true for a reference whose legs were ``resolved`` for the body
    (``reference: {feasible: auto}`` re-solves every capture,
    :func:`bipedsim.reference.feasible_measure.resolve_because`), false otherwise (the built-in walk
    generated for the body; a clip tracked as it is, ``feasible: false``): the modulation corrects a
    capture's legs to the body, and would only move the built-in walk off its course."""
    mod = cfg.modulation
    sf, sa = mod.swing_foot, mod.stance_ankle
    if sf.enabled != "auto" and sa.enabled != "auto":
        return cfg
    sf = replace(sf, enabled=resolved) if sf.enabled == "auto" else sf
    sa = replace(sa, enabled=resolved) if sa.enabled == "auto" else sa
    return replace(cfg, modulation=replace(mod, swing_foot=sf, stance_ankle=sa))


#: unit -> (power of the leg-length ratio, power of the mass ratio): how a setting in that unit scales
#: between dynamically similar bodies (g fixed; times scale with sqrt(L / g), speeds with sqrt(g L))
BODY_UNITS: dict[str, tuple[float, float]] = {
    "length": (1.0, 0.0), "time": (0.5, 0.0), "speed": (0.5, 0.0), "per_length": (-1.0, 0.0),
    "per_speed": (-0.5, 0.0), "force": (0.0, 1.0), "force_per_speed": (-0.5, 1.0),
    "stiffness": (1.0, 1.0), "damping": (1.5, 1.0)}

#: every humanoid controller setting that has a unit, by dotted key (rad and ratios do not scale)
BODY_SCALED: dict[str, str] = {
    "fsm.state1_time": "time", "fsm.min_swing_time": "time", "fsm.contact_force": "force",
    "fsm.max_wait": "time", "fsm.tempo.gain": "per_speed", "fsm.tempo.deadband": "speed",
    "balance.sagittal.cd": "per_length", "balance.sagittal.cv": "per_speed",
    "balance.coronal.cd": "per_length", "balance.coronal.cv": "per_speed",
    "balance.torso_kp": "stiffness", "balance.roll_kp": "stiffness", "balance.torso_kd": "damping",
    "balance.heading_kp": "stiffness",
    "balance.velocity.kv_sagittal": "force_per_speed",
    "balance.velocity.max_force": "force", "balance.velocity.filter_s": "time",
    "balance.course.deadband": "length", "balance.course.rate_filter": "time",
    "balance.course.steer_gain": "per_length", "balance.course.steer_damping": "per_speed",
    "balance.course.crab_filter_s": "time",
    "balance.capture.deadband": "length", "balance.capture.tempo_gain": "per_length",
    "balance.capture.bias_s": "time",
    "fade.fade_in": "time", "resync.spread": "time",
    "modulation.swing_foot.lift": "length", "modulation.swing_foot.max_raise": "length",
    "modulation.swing_foot.max_drop": "length", "modulation.swing_foot.deadband": "length",
    "modulation.stance_ankle.kv": "per_speed", "modulation.stance_ankle.kd": "per_length",
    "modulation.ground.lookahead": "length", "modulation.ground.clearance": "length",
    "modulation.ground.max_raise": "length", "modulation.ground.max_drop": "length",
    "modulation.ground.edge_margin": "length", "modulation.ground.max_shift": "length",
    "modulation.ground.shift_gain": "per_length",
    "reference.smooth_s": "time", "pose_gait.state_a_time": "time", "reconstruct.reach": "length"}

#: the humanoid settings with no unit to scale: angles (rad), ratios, weights, counts of clip frames,
#: lengths given as a share of the leg (``reference.clearance``), and ``control_dt``, which stays with the
#: physics timestep (neither is scaled)
BODY_UNSCALED: frozenset[str] = frozenset({
    "control_dt", "fsm.tempo.min", "fsm.tempo.max", "balance.max_feedback", "balance.stance_yaw_limit",
    "balance.capture.max_rate",
    "balance.cd_froude", "balance.cd_froude_power", "balance.course.max_turn",
    "balance.course.max_crab", "fade.min_scale", "resync.gain",
    "resync.max_frames", "modulation.swing_foot.height_gain", "modulation.stance_ankle.max_angle",
    "modulation.ground.foot_tilt", "modulation.ground.max_tilt", "modulation.ground.lean",
    # the ground's own geometry (what counts as an edge) and an angle
    "modulation.ground.edge_height", "modulation.ground.toe_lift",
    "reference.blend", "reference.max_extension", "reference.clearance", "reference.pendulum", "body.leg_min",
    "body.leg_max", "body.mass", "body.torque_scale",
    # the search's own settings: angles, weights and its windows' times, the same for any body
    "reconstruct.window_s", "reconstruct.coherence", "reconstruct.hinge_sigma", "reconstruct.feedback_sigma",
    "reconstruct.torso_sigma", "reconstruct.pose_weight", "reconstruct.root_weight",
    "reconstruct.position_weight", "reconstruct.height_weight", "reconstruct.velocity_weight", "reconstruct.fade_s",
    "reconstruct.loop_max_s", "reconstruct.cover_s"})


def _scaled_gain(g: Gain, f_kp: float, f_kd: float) -> Gain:
    return Gain(g.kp * f_kp, g.kd * f_kd, None if g.torque_limit is None else g.torque_limit * f_kp)


def _replace_path(obj: Any, keys: list[str], value: Any) -> Any:
    if len(keys) == 1:
        return replace(obj, **{keys[0]: value})
    return replace(obj, **{keys[0]: _replace_path(getattr(obj, keys[0]), keys[1:], value)})


def body_ratios(b: BodyScaleConfig, leg_length: float, mass: float) -> tuple[float, float]:
    """(leg ratio, mass ratio) a body with legs ``leg_length`` m and ``mass`` kg is scaled by from the
    bodies ``b`` names; (1, 1) inside them or with ``scale: false``."""
    if not b.scale:
        return 1.0, 1.0
    ref = b.leg_min if leg_length < b.leg_min else b.leg_max if leg_length > b.leg_max else leg_length
    lam, mu = leg_length / ref, mass / b.mass
    return (1.0 if abs(lam - 1.0) < 1e-12 else lam), (1.0 if abs(mu - 1.0) < 1e-12 else mu)


def describe_body_scale(b: BodyScaleConfig, leg_length: float, mass: float) -> str | None:
    """What :func:`for_body` does to a body with legs ``leg_length`` m and ``mass`` kg, in words (None:
    nothing)."""
    lam, mu = body_ratios(b, leg_length, mass)
    if lam == 1.0 and mu == 1.0:
        return None
    span = f"{b.leg_min:.2f} m" if b.leg_min == b.leg_max else f"{b.leg_min:.2f}-{b.leg_max:.2f} m"
    torque = BODY_UNITS["stiffness"]
    torques = f"torques and PD gains x{lam ** torque[0] * mu ** torque[1]:.3f}"
    if lam == 1.0:  # the mass alone: forces and torques alike
        scaled = f"forces, {torques}"
    else:
        scaled = (f"lengths x{lam:.3f}, times x{lam ** 0.5:.3f}, {torques}"
                  + (f", forces x{mu:.3f}" if mu != 1.0 else ""))
    return (f"settings scaled to the body (legs {leg_length:.2f} m, {mass:.1f} kg; the settings are for legs "
            f"{span}, {b.mass:.1f} kg): {scaled} (body: {{scale: false}} keeps them as written)")


def for_body(cfg: ControllerConfig, leg_length: float, mass: float) -> ControllerConfig:
    """``cfg`` scaled from the bodies it names (``body``) to one with legs ``leg_length`` m long (hip to
    ankle, the legs' mean) weighing ``mass`` kg (:class:`BodyScaleConfig`), naming that body when it
    scaled anything."""
    b = cfg.body
    if leg_length <= 0.0 or mass <= 0.0:
        raise ConfigError(f"a body to scale the controller to needs legs and mass > 0, got legs {leg_length} m, "
                          f"mass {mass} kg", key="body")
    lam, mu = body_ratios(b, leg_length, mass)
    if lam == 1.0 and mu == 1.0:
        return cfg
    factor = {u: lam ** a * mu ** c for u, (a, c) in BODY_UNITS.items()}
    out = cfg
    for key, unit in BODY_SCALED.items():
        keys = key.split(".")
        v: Any = out
        for k in keys:
            v = getattr(v, k)
        if v is not None:
            out = _replace_path(out, keys, v * factor[unit])
    f_kp, f_kd = factor["stiffness"], factor["damping"]
    pd = replace(out.pd, gains={k: _scaled_gain(g, f_kp, f_kd) for k, g in out.pd.gains.items()},
                 joint_gains={k: _scaled_gain(g, f_kp, f_kd) for k, g in out.pd.joint_gains.items()})
    legs = (leg_length, leg_length) if lam != 1.0 else (b.leg_min, b.leg_max)
    return replace(out, pd=pd, body=replace(b, leg_min=legs[0], leg_max=legs[1], mass=mass,
                                            torque_scale=b.torque_scale * f_kp))
