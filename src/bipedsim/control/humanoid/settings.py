"""The humanoid controller's settings: the sections of a controller file a humanoid's controller reads.

PD tracking (``pd``), the gait machine (``fsm``), SIMBICON balance (``balance``), the gain fade (``fade``),
resynchronisation (``resync``), reference modulation (``modulation``) and the key-pose gait (``pose_gait``).
Each dataclass's defaults are the default controller's; :class:`~bipedsim.control.settings.ControllerConfig`
puts them together with the body scaling and the creature's section. Units: kp N*m/rad, kd N*m*s/rad,
c_d rad/m, c_v rad/(m/s), times s, lengths m, forces N, angles rad.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

PD_MODES = ("pd", "pd_ref_velocity")


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
class CaptureConfig:
    """Capture-point step timing (after Pratt et al. 2006): the step hurried while the linear inverted
    pendulum's capture point lies off the reference's, so a pushed body's swing ends early.

    The capture point's offset from the stance ankle is ``d + v / omega`` per plane (heading frame, m),
    ``omega = sqrt(g / L)`` with L the body's leg length (m). Its deviation from the reference's
    (``d_ref + v_ref / omega``), less that deviation's running mean over ``bias_s`` (the simulated walk's
    own steady offset from its reference), beyond ``deadband`` runs the gait clock at ``1 + tempo_gain``
    x the deviation's size (m) times real time, at most ``max_rate``; where ``fsm.tempo`` asks for a
    faster clock, that one runs."""

    #: off by default: it lifts the built-in walk's push thresholds (docs/pushes.md) but trips the
    #: generated 1.35-1.5 m/s walks in their first steps
    enabled: bool = False
    #: m, above the deviation the walk's own steps make (within a step it swings by about +-0.07 m), so
    #: only a push hurries the step
    deadband: float = field(default=0.1, metadata={"min": 0.0})
    tempo_gain: float = field(default=4.0, metadata={"min": 0.0})  #: gait clock rate per m of deviation
    max_rate: float = field(default=1.5, metadata={"min": 1.0})  #: x real time, the hurried clock at most
    #: s, time constant of the deviation's running mean: longer than a push's response (about a step)
    bias_s: float = field(default=2.0, metadata={"gt": 0.0})


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

    A walk can crab: its travel runs at an angle to its pelvis heading that the reference's does not
    have (an asymmetric gait on another body), and turning the heading alone then only turns the crab.
    The crab is measured, the direction of the COM velocity less the pelvis heading, both low-passed over
    ``crab_filter_s`` s, less the reference's own (the course's direction less its heading), and the
    heading target is turned against it (at most ``max_crab`` rad; the estimate low-passed over the same
    time), so the travel, not the pelvis, follows the course. ``crab_filter_s: 0`` turns this off.

    ``enabled: false``: the heading target stays the pelvis heading at the start (a veering clip is
    walked straight)."""

    enabled: bool = True
    deadband: float = field(default=0.5, metadata={"min": 0.0})  #: m
    rate_filter: float = field(default=0.5, metadata={"gt": 0.0})  #: s, time constant of e_dot's low-pass
    steer_gain: float = field(default=0.15, metadata={"min": 0.0})  #: rad of turn per m of offset
    steer_damping: float = field(default=0.6, metadata={"min": 0.0})  #: rad of turn per m/s
    max_turn: float = field(default=0.25, metadata={"min": 0.0, "max": 1.5})  #: rad
    #: s, time constant of the crab's measurement and of its compensation: a stride or two, so the sway
    #: within a stride averages out and a turn of the heading is followed before it reads as crab
    crab_filter_s: float = field(default=2.0, metadata={"min": 0.0})
    max_crab: float = field(default=0.8, metadata={"min": 0.0, "max": 1.5})  #: rad, the compensation at most


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
    capture: CaptureConfig = field(default_factory=CaptureConfig)


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
class ReconstructConfig:
    """Sampling-based control reconstruction (Liu et al. 2010; :mod:`bipedsim.sim.reconstruct`): a
    feed-forward correction of the targets, searched window by window along the clip, that keeps the
    body on it; the balance feedback acts on top. ``enabled``: ``bipedsim run --bvh`` searches (or
    reads its cache) before the run.

    Per window of ``window_s`` s, ``samples`` rollouts from the ``keep`` best states so far, each with
    offsets drawn around its parent's (x ``coherence``) with standard deviations ``hinge_sigma`` (every
    hinge's target), ``feedback_sigma`` (the swing hip's feedback angles) and ``torso_sigma`` (the
    torso's pitch and roll), all rad. A state's cost against the clip at the same time: the weights
    (per rad, m or m/s) of its hinge RMS error, root orientation, horizontal position, height and
    horizontal velocity."""

    enabled: bool = True
    window_s: float = field(default=0.3, metadata={"min": 0.01, "max": 1.0})
    samples: int = field(default=100, metadata={"min": 1, "max": 10000})
    keep: int = field(default=10, metadata={"min": 1, "max": 1000})
    coherence: float = field(default=0.7, metadata={"min": 0.0, "max": 1.0})
    hinge_sigma: float = field(default=0.06, metadata={"min": 0.0, "max": 1.0})
    feedback_sigma: float = field(default=0.05, metadata={"min": 0.0, "max": 1.0})
    torso_sigma: float = field(default=0.03, metadata={"min": 0.0, "max": 1.0})
    pose_weight: float = field(default=1.0, metadata={"min": 0.0})
    root_weight: float = field(default=1.0, metadata={"min": 0.0})
    position_weight: float = field(default=1.0, metadata={"min": 0.0})
    height_weight: float = field(default=3.0, metadata={"min": 0.0})
    velocity_weight: float = field(default=1.0, metadata={"min": 0.0})
    #: failures answered by backing up (one window more per failure in a row at a window, with 2, 4, then
    #: 8x the samples) where every sample of a window fell, in all; then the correction ends where the
    #: search got to
    retries: int = field(default=8, metadata={"min": 0, "max": 1000})
    seed: int = field(default=0, metadata={"min": 0})  #: the search's random draws
    #: loop periods searched after the clip (the clip's best cycle, looped from its end); the run then
    #: repeats the correction of the last one, phase for phase. 0: the search ends with the clip and the
    #: correction fades out over ``fade_s``, as it does where the search could not reach the end
    loop_cycles: int = field(default=2, metadata={"min": 0, "max": 20})
    #: s of the loop searched at most after the clip's end (null: no bound): the search's cost grows with
    #: its span, and a loop of many strides would double a 10 s clip's. Whole periods that fit are searched
    #: and repeated; where not one fits, the search ends this long after the clip and its correction fades
    loop_max_s: float | None = field(default=5.0, metadata={"gt": 0.0})
    #: s from the run's start the search covers at least, in whole loop periods after the clip, where the
    #: clip's best cycle looped by the feedback alone falls within a judging run, or where a run with a
    #: search's correction without the cover falls in it (sim/judging.py search_settings,
    #: searched_correction): a loop the feedback does not walk is walked under its correction for a run
    #: this long (the judge's shortest, JUDGE_MIN_S). 0: never
    cover_s: float = field(default=20.0, metadata={"min": 0.0, "max": 600.0})
    #: seconds over which a correction without a searched loop fades out after its end: long enough for
    #: the feedback to take the corrected gait over gradually
    fade_s: float = field(default=3.0, metadata={"min": 0.0, "max": 10.0})
    #: m: the correction's reach. It was searched for one path of the body (its own noiseless run from
    #: the start); it holds in full while the body's capture point (d + v / omega) lies within this of
    #: that path's at the same reference frame on the same stance foot, fades linearly to nothing at
    #: twice this, so a pushed or disturbed body walks by the feedback alone until it is back near the
    #: path (docs/controller.md, *Reconstruction*, has how far bodies go off it). 0: the correction acts
    #: everywhere
    reach: float = field(default=0.1, metadata={"min": 0.0, "max": 10.0})
    #: processes sampling each window (0: one per core this process may use); the result is the same
    workers: int = field(default=0, metadata={"min": 0, "max": 256})


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
class GroundConfig:
    """The reference adapted to the ground under the feet (SIMBICON's slopes and steps; acts only on a
    ground other than the flat floor, :mod:`bipedsim.model.ground`).

    - swing: the swing ankle's target is raised by the ground's rise from under the stance foot to the
      highest point from the swing toe to ``lookahead`` m past the stance toe (the step to come), plus
      ``clearance`` sin(pi phase) m while that rise is up; where the ground ahead drops, lowered by
      the drop over the step's first half; clipped to [-``max_drop``, ``max_raise``] (the knee and
      thigh by two-link IK);
    - feet: each foot's world target tilted by ``foot_tilt`` x the ground's pitch and roll under it
      (heel to toe), so it lands flat on a slope (a rise steeper than ``max_tilt`` rad is a step's
      edge, not followed);
    - torso: leaned forward by ``lean`` x the ground's rise (rad per rad) under the stance foot along
      the heading (back on a descent);
    - steps near an edge: at each swing's start the footfall is foreseen (the stance ankle plus the
      feet's gap along the heading); where a rise or drop of at least ``edge_height`` m lies under
      that foot or within ``edge_margin`` m of its heel or toe, the step is lengthened or shortened
      (the nearer, at most ``max_shift`` m) to land clear of it, turning the swing hip's target by
      ``shift_gain`` rad per m; while an edge up lies between the swing toe and the footfall's, the
      swing foot's toe is raised ``toe_lift`` rad."""

    enabled: bool = True
    lookahead: float = field(default=0.1, metadata={"min": 0.0})  #: m
    clearance: float = field(default=0.04, metadata={"min": 0.0})  #: m
    max_raise: float = field(default=0.2, metadata={"min": 0.0})  #: m
    max_drop: float = field(default=0.12, metadata={"min": 0.0})  #: m
    foot_tilt: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})  #: share of the ground's tilt
    max_tilt: float = field(default=0.35, metadata={"min": 0.0})  #: rad
    lean: float = field(default=0.5, metadata={"min": 0.0})  #: rad of torso lean per rad of slope
    edge_height: float = field(default=0.02, metadata={"min": 0.0})  #: m
    edge_margin: float = field(default=0.1, metadata={"min": 0.0})  #: m
    max_shift: float = field(default=0.15, metadata={"min": 0.0})  #: m (0: steps are not adjusted)
    shift_gain: float = field(default=0.5, metadata={"min": 0.0})  #: rad of swing hip per m of step
    toe_lift: float = field(default=0.3, metadata={"min": 0.0})  #: rad, the swing toe raised below an edge up


@dataclass(frozen=True)
class ModulationConfig:
    """Reference modulation for tracking real captures (Lee, Kim & Lee 2010), each term switchable."""

    swing_foot: SwingFootConfig = field(default_factory=SwingFootConfig)
    stance_ankle: StanceAnkleConfig = field(default_factory=StanceAnkleConfig)
    #: the reference adapted to a shaped ground (slopes, steps, rough ground)
    ground: GroundConfig = field(default_factory=GroundConfig)


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
