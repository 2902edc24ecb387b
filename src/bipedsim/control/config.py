"""Controller configuration: ``controllers/*.yaml`` validated into typed objects.

The defaults live here, once: the dataclasses' defaults *are* the default controller.
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
from typing import Any, Literal

import yaml

from bipedsim import config
from bipedsim.control.creature_config import CreatureControlConfig
from bipedsim.errors import ConfigError
from bipedsim.model.feasible import FeasibleConfig
from bipedsim.model.profile import MASS_RANGE_KG

PD_MODES = ("pd", "pd_ref_velocity")
SOURCES = ("clip", "pose")
#: the slowest control step accepted (s): 20 Hz. A stance lasts 0.3-0.4 s; at a slower rate the FSM
#: sees a foot strike late and the balance feedback acts on a step already over
MAX_CONTROL_DT = 0.05
#: leg lengths (m, hip to ankle) the settings may be said to be for (``body:``): the legs of the
#: humanoids that can be built (0.6-3.0 m tall, :data:`~bipedsim.model.build.HUMANOID_BUILT_HEIGHT_M`),
#: with room; scaling to legs far outside them would multiply gains by absurd factors
LEG_RANGE_M = (0.2, 2.0)


@dataclass(frozen=True)
class Gain:
    """PD gains of one joint group (kp N*m/rad, kd N*m*s/rad) and an optional torque limit (N*m,
    ``null`` keeps the model's)."""

    kp: float = field(default=300.0, metadata={"min": 0.0})
    kd: float = field(default=30.0, metadata={"min": 0.0})
    torque_limit: float | None = field(default=None, metadata={"gt": 0.0})


#: the default controller's PD gains per joint group (kp N*m/rad, kd N*m*s/rad); the body's torque
#: limits are its profile's (``profiles/humanoid.yaml``, ``joints.<group>.torque``)
DEFAULT_GAINS: dict[str, Gain] = {
    "spine": Gain(1000.0, 100.0), "neck": Gain(100.0, 10.0), "hip": Gain(1000.0, 100.0),
    "knee": Gain(1000.0, 100.0), "ankle": Gain(300.0, 30.0), "toe": Gain(60.0, 6.0),
    "shoulder": Gain(300.0, 30.0), "elbow": Gain(300.0, 30.0)}


@dataclass(frozen=True)
class PDConfig:
    """PD tracking, eq. 1: tau = kp (theta_d - theta) - kd theta_dot.

    ``mode``: ``pd`` (the paper's absolute damping) or ``pd_ref_velocity`` (- kd (theta_dot -
    theta_dot_d)). With ``implicit_damping`` the -kd theta_dot term is MuJoCo joint damping, integrated
    implicitly (``implicitfast``), so kd can grow without shrinking the timestep (explicit damping of a
    thigh's twist, whose inertia is tiny, is unstable at 2 ms). That damping is passive: it acts on the
    stance hip too, beside the balance law's torque, and is not cut by torque limits."""

    mode: str = field(default="pd", metadata={"choices": PD_MODES})
    implicit_damping: bool = True
    #: the kp (theta_d - theta) term runs inside MuJoCo's position servos (force = kp (u - theta), clamped
    #: to the torque limit; target u = theta + tau / kp gives the controller's torque tau at the control
    #: step), so the stiffness acts on every physics step between control steps; ``false``: plain torque
    #: motors, held between control steps
    servo: bool = True
    #: with implicit damping, which joints' torque limits bound actuator and damping together while the
    #: joint is driven the way it moves (the actuator may give up to limit + kd |theta_dot|): ``all``,
    #: ``swing`` (the swing hip and knee), ``swing_hip``; ``off``: the limit bounds the actuator alone, so a
    #: joint driven at its limit tops out at limit / kd rad/s and a fast walk's swing lags
    net_limit: str = field(default="swing_hip", metadata={"choices": ("off", "swing", "swing_hip", "all")})
    #: feedforward (not in the paper): hold every swinging part against gravity (MuJoCo's bias forces) and
    #: let each loaded leg's knee and ankle carry its share of the body weight (J^T f)
    gravity_compensation: bool = True
    #: per joint group (:data:`DEFAULT_GAINS`); a group missing from a config built in Python takes its
    #: :data:`DEFAULT_GAINS` entry, unscaled
    gains: dict[str, Gain] = field(default_factory=lambda: dict(DEFAULT_GAINS))
    #: per joint, replacing its group's gains
    joint_gains: dict[str, Gain] = field(default_factory=dict)
    #: per joint, targets are clipped to [lo, hi] rad (default: the joint's range)
    target_limits: dict[str, tuple[float, float]] = field(default_factory=dict)

    def validate(self) -> None:
        for j, (lo, hi) in self.target_limits.items():
            if lo >= hi:
                raise ValueError(f"target_limits.{j}: limits reversed or empty: [{lo}, {hi}] (need lo < hi)")


@dataclass(frozen=True)
class TempoConfig:
    """Step tempo (not in the paper): the gait clock runs faster while the body outruns the reference.

    The reference's playback and the FSM's timers run at ``rate = clamp(1 + gain e, min, max)`` times
    real time, ``e`` the sagittal COM velocity's excess over the reference's mean speed beyond a
    ``deadband``. A body pushed forward steps sooner and swings its leg faster, so its legs stay under
    it. ``gain`` 0 switches it off; ``min`` below 1 also slows the clock for a body slower than the
    reference. The velocity is measured by the balance law: with ``balance.enabled: false`` the clock
    stays at real time."""

    gain: float = field(default=4.0, metadata={"min": 0.0})  #: rate per m/s of excess speed
    deadband: float = field(default=0.1, metadata={"min": 0.0})  #: m/s
    min: float = field(default=1.0, metadata={"gt": 0.0, "max": 1.0})  #: slowest rate (x real time)
    max: float = field(default=1.5, metadata={"min": 1.0})  #: fastest rate (x real time)


@dataclass(frozen=True)
class FSMConfig:
    """The gait machine: states 1-2 right stance / left swing, 3-4 left stance / right swing.

    States 1 and 3 last ``state1_time``; 2 and 4 end when the swing foot's vertical force exceeds
    ``contact_force``, after at least ``min_swing_time``. Those two times are on the gait clock, which
    runs at the ``tempo`` rate; ``max_wait`` is real time."""

    #: s (null: half the reference's mean step time)
    state1_time: float | None = field(default=0.3, metadata={"gt": 0.0})
    min_swing_time: float = field(default=0.2, metadata={"min": 0.0})  #: s, so a toe's brush is no strike
    contact_force: float = field(default=30.0, metadata={"gt": 0.0})  #: N on the swing sole's touch sensor
    #: s: longest hold of the reference at a strike frame while the swing foot is late (``resync.hold``)
    max_wait: float = field(default=0.4, metadata={"min": 0.0})
    tempo: TempoConfig = field(default_factory=lambda: TempoConfig())


@dataclass(frozen=True)
class PlaneGains:
    """Eq. 6's feedback gains in one plane: c_d (rad per m of COM offset), c_v (rad per m/s)."""

    cd: float = 0.5
    cv: float = 0.2


@dataclass(frozen=True)
class VelocityConfig:
    """Velocity tuning (Coros et al. 2010, sec. 5): a virtual force on the centre of mass.

    F = kv (v_target - v) forward in the heading frame, produced by the legs in contact in proportion to
    their loads through their knee and ankle hinges (Jacobian transpose of the chain from the fixed foot
    up to the COM). The target is the reference's mean walking speed, against the COM velocity
    low-passed over ``filter_s``. A 0 gain switches it off."""

    #: N per m/s of speed deficit: a body that walks slower than its reference is pushed on
    kv_sagittal: float = field(default=90.0, metadata={"min": 0.0})  #: N per m/s
    max_force: float = field(default=150.0, metadata={"gt": 0.0})  #: N, the horizontal force's norm
    #: s, time constant of the sagittal velocity's low-pass (0: raw), so the force answers the walk's
    #: lasting speed, not a push's transient
    filter_s: float = field(default=1.0, metadata={"min": 0.0})


@dataclass(frozen=True)
class CourseConfig:
    """Course control (not in the paper): the torso's heading target follows the reference's own path.

    The heading-frame steering of SIMBICON's and Coros et al.'s controllers, on the reference's path.

    The course is the reference's centre of mass averaged over the clip's loop (no sway, any veer kept),
    repeated with the loop's displacement and turn, laid at the start on the body's root and
    heading (``reference.Course``). Each control step the COM is projected onto it: e is the lateral
    offset (m, positive left of the course), e_dot its rate (m/s, low-passed over ``rate_filter`` s).
    Outside a ``deadband`` (the offset beyond it, e_b = e - deadband sign(e); inside it the law is
    silent) the torso law's heading target is the course's heading turned back toward it,

        heading_target = heading_ref + clamp(-steer_gain e_b - steer_damping e_dot, +-max_turn)

    ``enabled: false``: the heading target stays the pelvis heading at the start (a veering clip is
    walked straight)."""

    enabled: bool = True
    deadband: float = field(default=0.5, metadata={"min": 0.0})  #: m
    rate_filter: float = field(default=0.5, metadata={"gt": 0.0})  #: s, time constant of e_dot's low-pass
    steer_gain: float = field(default=0.15, metadata={"min": 0.0})  #: rad of turn per m of offset
    steer_damping: float = field(default=0.6, metadata={"min": 0.0})  #: rad of turn per m/s
    max_turn: float = field(default=0.25, metadata={"min": 0.0, "max": 1.5})  #: rad


@dataclass(frozen=True)
class BalanceConfig:
    """SIMBICON balance: the torso (pelvis) held in the world frame through the hips, and the swing hip.

    The swing hip's target is turned by the feedback theta_d = theta_d0 + c_d d + c_v v per plane (eq. 6);
    the hips' torques are split by the feet's loads (eq. 2-5)."""

    enabled: bool = True
    feedback: bool = True
    #: eq. 6 in the sagittal plane; a c_d above about 0.6 makes the built-in walk limp and crab
    sagittal: PlaneGains = field(default_factory=lambda: PlaneGains(0.55, 0.15))
    coronal: PlaneGains = field(default_factory=lambda: PlaneGains(0.55, 0.3))  #: eq. 6 sideways
    torso_kp: float = field(default=1000.0, metadata={"min": 0.0})  #: N*m/rad, the torso law's pitch
    roll_kp: float | None = field(default=None, metadata={"min": 0.0})  #: N*m/rad, roll (null: torso_kp)
    #: N*m*s/rad, the torso law's damping (roll, pitch and yaw), enough to hold the pelvis's yaw against
    #: the swing leg's reaction; it is explicit (once per control step) and turns unstable from about 250
    #: at 250 Hz control
    torso_kd: float = field(default=175.0, metadata={"min": 0.0})
    heading_kp: float = field(default=300.0, metadata={"min": 0.0})  #: N*m/rad, the torso law's yaw
    #: rad: the torso law's yaw target kept within this of the loaded stance foot's yaw plus the reference
    #: pelvis's own yaw from that foot (null: no limit). The ankles have no yaw hinge and a sole holds
    #: little torque about the vertical, so a pelvis turned far against its feet would spin the stance foot
    stance_yaw_limit: float | None = field(default=0.6, metadata={"gt": 0.0})
    #: the swing thigh tracks the reference thigh's heading-frame orientation, turned by eq. 6's feedback
    swing_hip_world: bool = True
    #: ankles aim the feet at the reference's world (heading-frame) orientation, so a foot lands and
    #: stays flat whatever the leg's tilt
    feet_world: bool = True
    #: the stance hip's torque split by the feet's loads (eq. 2-5); false: the stance hip takes all of it
    redistribution: bool = True
    max_feedback: float = field(default=0.6, metadata={"gt": 0.0})  #: rad, eq. 6's feedback angle at most
    #: Froude number Fr = v^2 / (g L) above which the sagittal c_d is scaled by (cd_froude / Fr) **
    #: cd_froude_power (null: c_d as given at every speed): on a long-striding fast walk the raw c_d d holds
    #: each swing leg back and the foot lands late and short
    cd_froude: float | None = field(default=0.13, metadata={"gt": 0.0})
    cd_froude_power: float = field(default=0.3, metadata={"min": 0.0})  #: the schedule's exponent
    velocity: VelocityConfig = field(default_factory=VelocityConfig)
    #: what d and v are measured against: "none" (SIMBICON: raw COM offset from the stance ankle and
    #: raw COM velocity), "mean_velocity" (velocity relative to the reference's mean walking velocity),
    #: "full" (deviations from the reference's own d and v on the current frame), "lateral_reference"
    #: (as mean_velocity, and the coronal d against the reference's own lateral d on the current frame:
    #: only a deviation from the walk's sway about the stance foot moves the swing leg sideways)
    relative: str = field(default="lateral_reference",
                          metadata={"choices": ("none", "mean_velocity", "full", "lateral_reference")})
    course: CourseConfig = field(default_factory=CourseConfig)


@dataclass(frozen=True)
class FadeConfig:
    """Gain fade (sec. 4.4): tracking gains drop while an external force acts.

    While a push acts the tracking gains are ``min_scale`` of their value; afterwards they return
    linearly over ``fade_in``. Balance stays on."""

    enabled: bool = False
    min_scale: float = field(default=0.3, metadata={"min": 0.0, "max": 1.0})  #: share of the gains kept
    fade_in: float = field(default=0.5, metadata={"gt": 0.0})  #: s back to full gains


@dataclass(frozen=True)
class ResyncConfig:
    """Resynchronisation (eq. 7-8): the reference's frame corrected at every foot strike.

    At every strike M = P_c / P_r (simulated step time over the reference's) is recorded. With
    ``enabled``, M > 1 moves the reference back and M < 1 forward, by ``gain`` x the distance (frames)
    to the reference's strike frame of that foot, at most ``max_frames``; ``hold`` pauses the reference
    at a strike frame while the swing foot has not landed (up to ``fsm.max_wait``)."""

    enabled: bool = False
    gain: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})  #: share of the frame difference
    max_frames: float = field(default=25.0, metadata={"min": 0.0})  #: clip frames per strike at most
    #: seconds over which the shift is applied (the reference plays faster or slower meanwhile);
    #: 0 jumps at once, which jerks every target
    spread: float = field(default=0.25, metadata={"min": 0.0})
    hold: bool = False


@dataclass(frozen=True)
class SwingFootConfig:
    """Swing-foot height by two-link leg IK (Lee, Kim & Lee 2010).

    The swing ankle's target, the reference's hip-to-ankle vector, is raised by ``height_gain`` x (the
    reference foot's height above the stance foot - the simulated one's) + ``lift`` sin(pi phase) (m,
    phase 0-1 through the step), clipped to [-``max_drop``, ``max_raise``]; the swing knee and the world
    thigh target follow (law of cosines on the thigh and shin lengths). ``enabled``: true, false, or
    "auto" -- on where the clip's legs are re-solved for the body (``reference: {feasible: auto}``: every
    capture, not the built-in walk generated for it; resolved by :func:`for_reference`)."""

    enabled: bool | Literal["auto"] = "auto"
    height_gain: float = field(default=0.5, metadata={"min": 0.0})  #: m of raise per m of height deficit
    lift: float = field(default=0.04, metadata={"min": 0.0})  #: m
    max_raise: float = field(default=0.15, metadata={"min": 0.0})  #: m
    max_drop: float = field(default=0.05, metadata={"min": 0.0})  #: m
    #: m: acts only while the swing foot is more than this below its reference height (0: always), so a
    #: swing that clears the floor as its reference does is left alone
    deadband: float = field(default=0.01, metadata={"min": 0.0})


@dataclass(frozen=True)
class StanceAnkleConfig:
    """Stance-ankle feedback (Lee, Kim & Lee 2010): the stance foot tilted by the COM's error.

    The stance foot's world target is pitched toe-down by ``kv`` x (COM velocity - the reference's) +
    ``kd`` x (COM offset from the stance ankle - the reference's) (rad per m/s, rad per m; sagittal and
    coronal), clipped to +-``max_angle`` rad. ``enabled``: as :class:`SwingFootConfig`'s."""

    enabled: bool | Literal["auto"] = "auto"
    kv: float = field(default=0.1, metadata={"min": 0.0})  #: rad per m/s
    kd: float = field(default=0.1, metadata={"min": 0.0})  #: rad per m
    max_angle: float = field(default=0.2, metadata={"min": 0.0})  #: rad


@dataclass(frozen=True)
class ModulationConfig:
    """Reference modulation for tracking real captures (Lee, Kim & Lee 2010), each term switchable."""

    swing_foot: SwingFootConfig = field(default_factory=SwingFootConfig)
    stance_ankle: StanceAnkleConfig = field(default_factory=StanceAnkleConfig)


@dataclass(frozen=True)
class PoseState:
    """SIMBICON key pose of one state (rad): swing hip (world, sagittal), knees, ankles, torso."""

    swing_hip: float = 0.0
    swing_knee: float = 0.0
    swing_ankle: float = 0.0
    stance_knee: float = 0.0
    stance_ankle: float = 0.0
    torso: float = 0.0


@dataclass(frozen=True)
class PoseGait:
    """SIMBICON's key-pose gait (``source: pose``): state A (timed), then state B (until contact)."""

    state_a: PoseState = field(default_factory=lambda: PoseState(0.5, 1.1, -0.2, 0.05, 0.0, 0.0))
    state_b: PoseState = field(default_factory=lambda: PoseState(-0.1, 0.05, -0.15, 0.1, 0.0, 0.0))
    state_a_time: float = field(default=0.3, metadata={"gt": 0.0})  #: s
    elbow: float = -0.3  #: rad, both elbows' target


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
    #: what the humanoid tracks: the reference ``clip``, or SIMBICON's key ``pose`` gait (``pose_gait``)
    source: str = field(default="clip", metadata={"choices": SOURCES})
    #: seconds between control steps (null: every physics step); physics runs at the model's timestep
    control_dt: float | None = field(default=0.004, metadata={"gt": 0.0, "max": MAX_CONTROL_DT})
    pd: PDConfig = field(default_factory=PDConfig)
    fsm: FSMConfig = field(default_factory=FSMConfig)  #: the gait machine and its clock
    balance: BalanceConfig = field(default_factory=BalanceConfig)
    fade: FadeConfig = field(default_factory=FadeConfig)
    resync: ResyncConfig = field(default_factory=ResyncConfig)
    #: corrections of a capture's reference to the body (Lee, Kim & Lee 2010)
    modulation: ModulationConfig = field(default_factory=ModulationConfig)
    #: the reference made feasible for the built body before tracking (model/feasible.py)
    reference: FeasibleConfig = field(default_factory=FeasibleConfig)
    pose_gait: PoseGait = field(default_factory=PoseGait)
    #: the body the values above are for, scaled to the body run (:func:`for_body`)
    body: BodyScaleConfig = field(default_factory=BodyScaleConfig)
    #: a creature's controller (control/creature_gait.py): used instead of the sections above when the
    #: body is a creature
    creature: CreatureControlConfig = field(default_factory=CreatureControlConfig)

    def validate(self) -> None:
        from bipedsim.model.profile import JOINT_GROUPS

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
# src/bipedsim/control/config.py by `bipedsim config > controllers/default.yaml`; do not edit (a test
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
    (``reference: {feasible: auto}`` re-solves every capture, :func:`bipedsim.model.feasible.resolve_because`),
    false otherwise (the built-in walk generated for the body; a clip tracked as it is, ``feasible:
    false``): the modulation corrects a capture's legs to the body, and would only move the built-in
    walk off its course."""
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
    "fade.fade_in": "time", "resync.spread": "time",
    "modulation.swing_foot.lift": "length", "modulation.swing_foot.max_raise": "length",
    "modulation.swing_foot.max_drop": "length", "modulation.swing_foot.deadband": "length",
    "modulation.stance_ankle.kv": "per_speed", "modulation.stance_ankle.kd": "per_length",
    "reference.smooth_s": "time", "pose_gait.state_a_time": "time"}

#: the humanoid settings with no unit to scale: angles (rad), ratios, weights, counts of clip frames,
#: lengths given as a share of the leg (``reference.clearance``), and ``control_dt``, which stays with the
#: physics timestep (neither is scaled)
BODY_UNSCALED: frozenset[str] = frozenset({
    "control_dt", "fsm.tempo.min", "fsm.tempo.max", "balance.max_feedback", "balance.stance_yaw_limit",
    "balance.cd_froude", "balance.cd_froude_power", "balance.course.max_turn", "fade.min_scale", "resync.gain",
    "resync.max_frames", "modulation.swing_foot.height_gain", "modulation.stance_ankle.max_angle",
    "reference.blend", "reference.max_extension", "reference.clearance", "reference.pendulum", "body.leg_min",
    "body.leg_max", "body.mass", "body.torque_scale"})


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
