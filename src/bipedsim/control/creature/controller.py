"""The creature's controller (behind :class:`~bipedsim.control.base.Controller`), for any skeleton: one
class that holds its parts, chosen at construction.

- the **body** (:class:`~bipedsim.control.creature.tracking.CreatureBody`): its ball joints, gains,
  limits, mass;
- **PD tracking** of the clip on every ball joint, with the optional **root support**
  (:class:`~bipedsim.control.creature.tracking.Tracking`): the whole control without a balance, and
  the control of every gait while the root is supported;
- with a balance (``balance``; the registered controller always has one): the **legs**
  (:class:`~bipedsim.control.creature.legs.LegSet`), the clip as their **reference** (looped,
  re-levelled: :class:`~bipedsim.control.creature.reference.LoopedReference`) and the **gait** its
  ``gait`` names -- the planned gait (:class:`~bipedsim.control.creature.gait.PlannedGait`, the
  default; its rules by leg count: :func:`leg_rules`) or the clip-timed balance
  (:class:`~bipedsim.control.creature.balance.ClipBalance`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from bipedsim.control.base import Controller, FloatArray, register
from bipedsim.control.creature.balance import ClipBalance
from bipedsim.control.creature.biped import BipedRules
from bipedsim.control.creature.gait import PlannedGait
from bipedsim.control.creature.leap import Leap, LeapSettings, lead_time, push_time
from bipedsim.control.creature.legs import LegSet
from bipedsim.control.creature.many_legs import ManyLegs
from bipedsim.control.creature.planner import LegRules
from bipedsim.control.creature.reference import LoopedReference
from bipedsim.control.creature.settings import CreatureBalanceConfig, CreatureControlConfig
from bipedsim.control.creature.tracking import CreatureBody, Tracking, quat_error_rotvecs
from bipedsim.model.plan import BodyPlanSet
from bipedsim.reference.clip import ReferenceClip


def leg_rules(plan: BodyPlanSet, body: CreatureBody, legs: LegSet, ref: LoopedReference,
              cfg: CreatureControlConfig) -> LegRules:
    """The planned gait's rules for these legs: two legs walk the dynamic gait of
    :class:`~bipedsim.control.creature.biped.BipedRules` (``cfg.biped``), any other number the
    quasi-static one of :class:`~bipedsim.control.creature.many_legs.ManyLegs` (the plan's soles and palms,
    ``extra["folded_feet"]``, turned by their own joints)."""
    if len(legs) == 2:
        return BipedRules(plan, body, legs, ref, cfg.biped)
    return ManyLegs(tuple(plan.extra.get("folded_feet", ())))


class CreatureController(Controller):
    """PD tracking of a clip on every ball joint of a creature body, and with ``balance`` the legged
    gait it names (see the module text)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                 cfg: CreatureControlConfig | None = None, balance: CreatureBalanceConfig | None = None) -> None:
        self.model, self.plan = model, plan
        self.cfg = cfg or CreatureControlConfig()
        self.control_dt = None
        self.body = CreatureBody(model, plan)
        self.root_body = self.body.root_body
        self._feet = [model.body(f).id for f in plan.foot_bodies]
        self._foot_names = tuple(plan.foot_bodies)
        self.legs: LegSet | None = None
        self.reference: LoopedReference | None = None
        self.gait: PlannedGait | ClipBalance | None = None
        #: how the body leaps (:meth:`leap`), the leaps made (their records: :meth:`Leap.record`), the
        #: leap under way and a leap asked for (time s, take-off velocity m/s), started at the next step
        self.leap_settings = LeapSettings()
        self.leaps: list[Leap] = []
        self._leaping: Leap | None = None
        self._leap_asked: tuple[float, FloatArray] | None = None
        if balance is None:
            self.track = Tracking(self.body, clip, self.cfg)
            #: the clip frames [a, b) a rollout plays (the part a gait loops)
            self.loop = (0, clip.num_frames)
            return
        self.legs = LegSet(model, plan, self.body, clip)
        self.reference = LoopedReference(model, clip, self.legs, self.body.quat_idx, balance.velocity_window_s)
        self.loop = self.reference.loop
        self.track = Tracking(self.body, self.reference.clip, self.cfg, self.loop)
        if balance.gait == "clip":
            self.gait = ClipBalance(self.body, self.legs, self.reference, self.track, balance)
            return
        rules = leg_rules(plan, self.body, self.legs, self.reference, self.cfg)
        self.gait = PlannedGait(self.body, self.legs, self.reference, self.track, rules.balance(balance), rules,
                                self.cfg.support)
        # only the planned gait plans each leg's stance (sim.contacts.StanceContacts reads it where present)
        self.contact_state = self.gait.contact_state

    # ------------------------------------------------------------------ the control step
    def start_frame(self) -> int:
        return self.loop[0]

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        self.track.reset(self.loop[0] if frame is None else frame, t)
        self.leaps, self._leaping, self._leap_asked = [], None, None
        if self.gait is None or self.cfg.support:
            return
        # the caller posed the clip's start; the gait starts from the re-levelled one
        self.reference.place_start(self.model, data, self.track.frame)
        self.gait.reset(data, t)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        if self.gait is None or self.cfg.support:
            return self.track.step(data, t)
        tau = self._leap_step(model, data, t, dt)
        return tau if tau is not None else self.gait.step(model, data, t, dt)

    # ------------------------------------------------------------------ the leap
    def can_leap(self) -> bool:
        """Whether :meth:`leap` does anything: the planned gait walks (not the clip-timed balance, not
        root support)."""
        return isinstance(self.gait, PlannedGait) and not self.cfg.support

    def leap(self, t: float, velocity: FloatArray) -> None:
        """Leap from time ``t`` (s) toward the take-off ``velocity`` (m/s, world; rising): crouch, push,
        fly, land, then walk on from where the body landed (:class:`~bipedsim.control.creature.leap.Leap`).
        The take-off comes :meth:`leap_lead_s` after ``t``. Without a planned gait nothing changes."""
        if self.can_leap() and self._leaping is None:
            v = np.asarray(velocity, dtype=float).reshape(3)
            push_time(1.0, v)  # a velocity that does not rise is refused here
            self._leap_asked = (float(t), v)

    def leap_lead_s(self, velocity: FloatArray) -> float:
        """The time (s) from :meth:`leap`'s ``t`` to the take-off of a leap toward ``velocity``: its
        crouch and push."""
        return lead_time(self.gait, np.asarray(velocity, dtype=float).reshape(3), self.leap_settings)

    def leap_set_s(self) -> float:
        """The time (s) from :meth:`leap`'s ``t`` to the set, when the feet are planted for the push (the
        walked crouch)."""
        return self.leap_settings.crouch_time / self.gait.legs.omega0

    def leap_footprint(self) -> tuple[float, float]:
        """The feet's reach (m) ahead of the root along its heading in the gait's neutral stance: the
        foremost foot's and the hindmost's (negative behind the root). A leap over a gap plants its
        front feet short of the near edge and lands its hind feet past the far one."""
        x = self.gait.stance.feet[:, 0]
        return float(np.max(x)), float(np.min(x))

    def _leap_step(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float = 0.0) -> FloatArray | None:
        """The leap's torques while one is under way (one asked for starts at its time), else None."""
        if self._leap_asked is not None and t >= self._leap_asked[0] - 1e-9:
            self._leaping = Leap(self.gait, data, t, self._leap_asked[1], self.leap_settings)
            self.leaps.append(self._leaping)
            self._leap_asked = None
        if self._leaping is None:
            return None
        tau = self._leaping.step(model, data, t, dt)
        if tau is None:
            self._leaping = None
        return tau

    def steer(self, t: float, yaw: float) -> None:
        """Turn the planned walk toward heading ``yaw`` (rad about world Z; the body's forward axis,
        :meth:`heading`) from time ``t`` (s): a caller following a course (a world's path) steers with
        it. Without a planned path (the clip-timed balance, root support) nothing changes."""
        if isinstance(self.gait, PlannedGait) and not self.cfg.support:
            self.gait.planner.turn_to(t, yaw)

    def walk_speed(self) -> float | None:
        """The planned walk's speed (m/s, past its ramp); None: no planned gait."""
        if not isinstance(self.gait, PlannedGait) or self.cfg.support:
            return None
        return float(self.gait.planner.clock.v_des)

    def set_walk_speed(self, t: float, speed: float) -> None:
        """Walk the planned gait on at ``speed`` (m/s) from time ``t`` (s) (a caller slowing for a turn);
        without a planned gait nothing changes."""
        if isinstance(self.gait, PlannedGait) and not self.cfg.support:
            self.gait.planner.set_speed(t, speed)

    def turn_support(self) -> float | None:
        """The planned gait's support half-width over its standing height (dimensionless: the widest
        foot's lateral offset in the neutral stance over the leg height): a turn at speed v and rate w
        carries the body out sideways at v w, which the feet hold up to about g x this. None: no
        planned gait."""
        if not isinstance(self.gait, PlannedGait) or self.cfg.support:
            return None
        half = float(np.max(np.abs(self.gait.stance.feet[:, 1])))
        return half / max(float(self.gait.legs.height), 1e-3)

    @property
    def leaping(self) -> bool:
        """Whether a leap is under way (asked for, or not yet landed and walking)."""
        return self._leaping is not None or self._leap_asked is not None

    def restore_model(self) -> None:
        self.body.restore()

    # ------------------------------------------------------------------ read-outs
    @property
    def frame(self) -> float:
        """The clip frame played now (a float: between frames)."""
        return self.track.frame

    @frame.setter
    def frame(self, value: float) -> None:
        self.track.frame = value

    @property
    def target_offset(self) -> FloatArray | None:  # type: ignore[override]
        """The PD targets' offset (rad; three rotation-vector components per ball joint, flat), held by
        the body (:meth:`CreatureBody.joint_error` applies it); None: none."""
        off = self.body.target_offset
        return None if off is None else off.ravel()

    @target_offset.setter
    def target_offset(self, value: FloatArray | None) -> None:
        self.body.target_offset = None if value is None else np.asarray(value, dtype=float).reshape(-1, 3)

    @property
    def target_absolute(self) -> bool:  # type: ignore[override]
        return self.body.target_absolute

    @target_absolute.setter
    def target_absolute(self, value: bool) -> None:
        self.body.target_absolute = bool(value)

    def target_names(self) -> tuple[str, ...]:
        """Each ball joint's rotation-vector components (``name:x``, ``:y``, ``:z``, joint frame)."""
        return tuple(f"{n}:{a}" for n in self.body.joint_names for a in "xyz")

    @property
    def tracking_error(self) -> FloatArray:
        """Per ball joint, the last control step's rotation error (rad)."""
        return self.track.tracking_error

    @tracking_error.setter
    def tracking_error(self, value: FloatArray) -> None:
        self.track.tracking_error = value

    def reference_qpos(self) -> FloatArray:
        """The planned pose while the planned gait walks, else the clip's frame now."""
        if self.gait is not None and self.gait.target is not None:
            return self.gait.target
        return self.track.reference_qpos()

    def reference_speed(self) -> float:
        return self.gait.reference_speed() if self.gait is not None else self.track.speed

    def heading(self, data: mujoco.MjData) -> float:
        return self.gait.heading(data) if self.gait is not None else super().heading(data)

    def actuator_torques(self) -> FloatArray:
        return self.body.torque

    def foot_names(self) -> tuple[str, ...]:
        return self._foot_names

    def foot_forces(self, data: mujoco.MjData) -> list[float]:
        """Each foot body's vertical contact force with anything (N), from MuJoCo's contacts."""
        out = [0.0] * len(self._feet)
        if not data.ncon:
            return out
        f6 = np.zeros(6)
        for i in range(data.ncon):
            con = data.contact[i]
            for k, b in enumerate(self._feet):
                if b in (self.model.geom_bodyid[con.geom1], self.model.geom_bodyid[con.geom2]):
                    mujoco.mj_contactForce(self.model, data, i, f6)
                    # the normal force along the contact frame's first axis, its world z share
                    out[k] += abs(f6[0] * con.frame[2])
        return out

    def foot_strikes(self) -> list[tuple[float, str]]:
        return self.gait.foot_strikes() if self.gait is not None else []

    def metrics(self) -> dict[str, object]:
        return self.gait.metrics() if self.gait is not None else self.track.metrics()


@register("creature")
def make_creature_controller(model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip,
                             cfg: CreatureControlConfig | None = None,
                             balance: CreatureBalanceConfig | None = None) -> CreatureController:
    """The creature's controller with its balance: ``balance``, or the configuration's (the planned gait,
    ``gait: planned``, by default; the clip-timed balance with ``gait: clip``)."""
    balance = balance or (cfg or CreatureControlConfig()).balance
    return CreatureController(model, plan, clip, cfg, balance)


__all__ = ["CreatureBalanceConfig", "CreatureControlConfig", "CreatureController", "leg_rules",
           "make_creature_controller", "quat_error_rotvecs"]
