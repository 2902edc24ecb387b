"""The creature controller's settings (one source of defaults), read from the ``creature:`` section of a
controller YAML (:func:`~bipedsim.control.settings.load_controller`): root support and the legged
balance's dimensionless gains (scaled by the body's mass, size and gravity in the controllers).

Kept apart from the controllers so the YAML loader can import them without importing the controllers."""

from __future__ import annotations

from dataclasses import dataclass, field

#: Longest window (s) over which a clip's velocity is averaged: past a clip's loop the average is the
#: whole clip's, and a far longer window would be an array too large to allocate.
MAX_WINDOW_S = 10.0
#: Highest standing root height, as a fraction of the clip's: the legs cannot reach the floor from much
#: higher than the clip's own height (the IK's targets would be out of reach).
MAX_HEIGHT_FRACTION = 1.5
#: Re-planning period (s) bounds. The plan's reference velocities are its change over the period, but
#: the plan is only remade at a control step (a creature's: every physics step, 2 ms in the shipped
#: profiles): a shorter period would divide a step's change by less than the step and inflate them. Past
#: a second the plan no longer follows a step.
MIN_PLAN_DT_S, MAX_PLAN_DT_S = 0.002, 1.0


@dataclass(frozen=True)
class CreatureBalanceConfig:
    """Dimensionless gains of the creature balance (scaled by mass, size and gravity)."""

    #: height and attitude PD: natural frequency as a multiple of sqrt(g/L); damping ratio
    height_freq: float = field(default=1.0, metadata={"gt": 0.0})
    attitude_freq: float = field(default=2.0, metadata={"gt": 0.0})
    damping_ratio: float = field(default=1.0, metadata={"min": 0.0})
    #: share of the body weight carried by the virtual force (the rest by PD tracking)
    gravity_comp: float = field(default=0.5, metadata={"min": 0.0, "max": 1.5})
    #: speed control (clip-timed balance): horizontal force m x speed_gain x sqrt(g/L) x (v_d - v)
    speed_gain: float = field(default=0.5, metadata={"min": 0.0})
    #: swing-foot placement of the clip-timed balance per (m/s) of velocity error, in units of sqrt(L/g) s
    placement: float = field(default=4.0, metadata={"min": 0.0})
    #: largest placement shift, as a fraction of the standing root height
    max_placement: float = field(default=1.0, metadata={"min": 0.0})
    #: friction coefficient the stance feet's forces are held to (their horizontal part within the cone)
    friction: float = field(default=0.8, metadata={"gt": 0.0})
    #: longest wait (s) of the clip's clock for a foot that should have landed
    max_wait_s: float = field(default=0.1, metadata={"min": 0.0})
    #: PD on the velocity error kd (qdot_ref - qdot) instead of damping kd qdot alone
    velocity_feedforward: bool = True
    #: window (s) over which the clip's root velocity is averaged for the speed target
    velocity_window_s: float = field(default=0.5, metadata={"gt": 0.0, "max": MAX_WINDOW_S})
    # ---- the planned gait (``gait: planned``, control/creature/gait.py); ``clip``: the clip-timed balance
    # (control/creature/balance.py)
    gait: str = field(default="planned", metadata={"choices": ("planned", "clip")})
    #: walking speed as a fraction of the clip's mean root speed, at most (the legs' measured reach may
    #: lower it: control/creature/reach.py)
    speed_fraction: float = field(default=0.8, metadata={"min": 0.0})
    #: the legs' swings in one cycle, summed, as a share of the cycle (each leg swings share/n: on four
    #: legs 0.9/4, a duty factor of 0.775); a shorter total swing shortens each swing and, where the
    #: shortest swing binds, slows the walk
    swing_share: float = field(default=0.9, metadata={"gt": 0.0, "max": 1.0})
    #: footfall pattern: ``sequence`` (one leg after another in the clip's order, swing_share/n each) or
    #: ``clip`` (the clip's own phases and swing share, e.g. a trot's diagonal pairs)
    phases: str = field(default="sequence", metadata={"choices": ("sequence", "clip")})
    #: the sequence's order where the clip lifts no leg (its contact labels empty): ``wave`` (one
    #: side's legs from the hindmost forward, then the other side's: the lateral-sequence walk of walking
    #: quadrupeds) or ``legs`` (the legs' own order, as the skeleton lists them)
    footfall_fallback: str = field(default="wave", metadata={"choices": ("wave", "legs")})
    #: largest swing of one leg as a share of the cycle
    max_swing_fraction: float = field(default=0.45, metadata={"gt": 0.0, "max": 0.9})
    #: longest stride (the distance a foot moves in one cycle) as a fraction of the standing root
    #: height, held at every cycle (a longer stride overreaches the legs, and at the shortest cycle its
    #: swing is too fast to land where planned); the reach is measured in steps up to it
    stride_fraction: float = field(default=0.9, metadata={"gt": 0.0})
    #: shortest swing (s)
    min_swing_s: float = field(default=0.12, metadata={"gt": 0.0})
    #: the shortest swing scaled with the leg: at least this x sqrt(L/g) s (L: the standing root height;
    #: ``min_swing_s`` then the floor; 0: ``min_swing_s`` alone)
    min_swing_froude: float = field(default=0.0, metadata={"min": 0.0})
    #: root height as a fraction of the clip's median
    height_fraction: float = field(default=1.0, metadata={"gt": 0.0, "max": MAX_HEIGHT_FRACTION})
    #: each foot at least this multiple of its hip's lateral offset from the hips' mid-line
    stance_width: float = field(default=2.0, metadata={"min": 0.0})
    #: swing-foot lift as a fraction of the standing root height
    step_height: float = field(default=0.12, metadata={"min": 0.0})
    #: a stance foot's target this fraction of the standing root height below the floor: its leg
    #: presses it down (at 0 a foot the body's bounce lifts is held in the air, not pushed back down)
    stance_press: float = field(default=0.0, metadata={"min": 0.0})
    #: share of the way the centre of mass moves toward the next support's centroid; time constant (s)
    com_shift: float = field(default=1.0, metadata={"min": 0.0})
    shift_time_s: float = field(default=0.1, metadata={"min": 0.0})
    #: the shift scaled by what an inverted pendulum follows at the gait's frequency: the supports'
    #: centroid sways once per cycle (period P), and a centre of mass at height h swaying by a at 2 pi / P
    #: needs its centre of pressure to sway by a (1 + (2 pi / P)^2 h / g); the shift is com_shift /
    #: (1 + (2 pi / P)^2 h / g) of the way (a fast cycle of a tall body little of it, a slow quasi-static
    #: walk nearly all of it). Off: com_shift of the way at any cycle
    com_shift_dynamic: bool = True
    #: 1: the centre of mass shifts only sideways (across the walking direction), 0: also along it
    lateral_only: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})
    #: swing-foot placement of the planned gait per (m/s) of velocity error, in units of sqrt(L/g) s
    step_placement: float = field(default=1.0, metadata={"min": 0.0})
    #: the body's horizontal virtual force held to what the planned support can carry: the zero-moment
    #: point it implies (the centre of mass's ground point less height x force / weight) stays inside
    #: the stance feet's polygon (a force that stops a pushed body faster tips it over the feet)
    zmp_limit: bool = False
    #: each foot's stance sweep centred in the reach of its own leg (ahead and behind measured apart,
    #: a hind leg that reaches little ahead steps further back), the sweep the narrowest leg's; off:
    #: the sweep is +-(the shortest reach of any leg in either direction)
    centre_sweep: bool = False
    #: the sweeps are centred as by ``centre_sweep`` where that widens the stance's sweep (its reach) at
    #: least this many times, measured on the built body's legs (1: always, as centring never narrows
    #: it -- every leg's reach ahead and behind differs, a fore leg's from a hind leg's, and the
    #: symmetric sweep is held to the shortest of them all); 0: only ``centre_sweep``
    centre_sweep_gain: float = field(default=1.0, metadata={"min": 0.0})
    #: with the sweeps centred (by either setting), the horizontal virtual force held as by ``zmp_limit``:
    #: the centred feet's centroid stands off the centre of mass
    centre_sweep_zmp: bool = True
    #: a push's catch (more than two legs): while the centre of mass's capture point c + v / w (w =
    #: sqrt(g / h)) lies out to one side beyond that side's outermost stance foot by more than
    #: ``capture_margin`` x the stance's half-width, that side's leg that would lift soonest starts its
    #: swing now (the gait's clock moved on to it; the legs between keep their feet down); a swinging
    #: leg on that side lands further out by ``capture_step`` x the distance of the capture point beyond
    #: its landing point, at most its outward reach measured by IK on the built body (0: off; a walk
    #: whose capture point stays between its feet is untouched)
    capture_step: float = field(default=2.0, metadata={"min": 0.0})
    capture_margin: float = field(default=0.0, metadata={"min": 0.0})
    #: the legs' IK is solved for a root attitude at most this far (rad, its tilt: roll and pitch) from
    #: the real one (0: for the planned attitude). Posed for the upright plan, a body rolled onto one
    #: side has its low side's feet driven into the floor (thrown up) and its high side's held off it;
    #: the limit bounds the legs' attitude correction like a saturated spring (more than two legs)
    ik_tilt_limit: float = field(default=0.1, metadata={"min": 0.0})
    #: the planned gait's body PD (root position and velocity) natural frequency, x sqrt(g/L)
    body_freq: float = field(default=2.0, metadata={"min": 0.0})
    #: a swinging leg's joint stiffness as a share of its stance stiffness (damping x its square root)
    swing_stiffness: float = field(default=0.25, metadata={"gt": 0.0, "max": 1.0})
    #: time constant (s) with which the planned path follows the body (0: a rigid path)
    path_follow_s: float = field(default=0.2, metadata={"min": 0.0})
    #: IK's null-space pull toward the neutral leg pose (share per iteration)
    posture_pull: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})
    #: standing time before the first step (s), speed ramp (s), re-planning period (s)
    settle_s: float = field(default=0.5, metadata={"min": 0.0})
    speed_ramp_s: float = field(default=1.0, metadata={"gt": 0.0})
    plan_dt_s: float = field(default=0.01, metadata={"min": MIN_PLAN_DT_S, "max": MAX_PLAN_DT_S})


@dataclass(frozen=True)
class BipedGaitConfig:
    """Timing of the two-legged planned gait, in units of sqrt(L/g) (L: the standing root height)."""

    #: double support between the swings
    double_support: float = field(default=0.15, metadata={"min": 0.0})
    #: longest swing (the clip's median swing otherwise)
    max_swing: float = field(default=0.8, metadata={"gt": 0.0})
    #: before the first step: the body moves this share of the way over its first stance sole, in
    #: ``start_s`` sqrt(L/g) s (or the planned gait's settle_s, the longer)
    pre_shift: float = field(default=0.3, metadata={"min": 0.0, "max": 1.0})
    start_s: float = field(default=3.0, metadata={"min": 0.0})
    # ---- the planned gait's settings that differ on two legs (CreatureBalanceConfig's, for bipeds)
    #: root height as a fraction of the clip's: bent legs reach sideways (straight ones cannot follow
    #: the body off their foot)
    height_fraction: float = field(default=0.85, metadata={"gt": 0.0, "max": MAX_HEIGHT_FRACTION})
    #: the IK's null-space pull toward the neutral leg pose: small, or it keeps feet off their targets
    #: (a bent leg reaching sideways is far from its neutral pose)
    posture_pull: float = field(default=0.05, metadata={"min": 0.0, "max": 1.0})
    #: swing-foot lift as a fraction of the root height
    step_height: float = field(default=0.08, metadata={"min": 0.0})
    #: walking speed as a fraction of the clip's, at most
    speed_fraction: float = field(default=0.65, metadata={"min": 0.0})
    #: the stance legs' body PD (root velocity toward the wanted one) natural frequency, x sqrt(g/L)
    body_freq: float = field(default=1.5, metadata={"min": 0.0})
    #: a stance ankle's torque at most this x body weight x the sole's half size (0: no cap)
    ankle_cap: float = field(default=2.0, metadata={"min": 0.0})


@dataclass(frozen=True)
class CreatureControlConfig:
    """Gains of the root support (per kg of body mass: N/m, N*s/m for the position; the rotation's
    are a tenth of these, N*m/rad and N*m*s/rad per kg) and whether the clip loops."""

    support: bool = False
    support_kp: float = field(default=20.0, metadata={"min": 0.0})
    support_kd: float = field(default=2.0, metadata={"min": 0.0})
    loop: bool = True
    #: the legged balance (control/creature/gait.py, or with ``gait: clip`` control/creature/balance.py)
    balance: CreatureBalanceConfig = field(default_factory=CreatureBalanceConfig)
    #: a two-legged creature's planned gait (control/creature/biped.py): its timing, and the settings of
    #: ``balance`` that it replaces on two legs
    biped: BipedGaitConfig = field(default_factory=BipedGaitConfig)


__all__ = ["BipedGaitConfig", "CreatureBalanceConfig", "CreatureControlConfig"]
