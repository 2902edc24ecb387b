"""The humanoid's :class:`SimbiconController` (behind the :class:`~bipedsim.control.base.Controller`
interface): PD tracking + gait FSM + SIMBICON balance, with the gain fade and resynchronisation.

One call maps (model, data, time) to actuator controls. Per control step:

1. The gait clock and the FSM advance; a foot strike is matched to the reference's (resynchronisation),
   and the reference frame F moves on (:mod:`~bipedsim.control.humanoid.stepping`).
2. PD tracking (eq. 1) of every hinge toward the reference, with the gravity feedforward
   (:mod:`~bipedsim.control.humanoid.tracking`).
3. Balance, when enabled: the course law steers the heading target, the torso law computes the pelvis's
   world torque (:mod:`~bipedsim.control.humanoid.torso`); eq. 6's feedback (:mod:`~bipedsim.control.humanoid.feedback`)
   and the swing-foot IK (:mod:`~bipedsim.control.humanoid.modulation`) turn the swing thigh's world target; the
   feet aim at their world targets (:mod:`~bipedsim.control.humanoid.feet`); the stance hip takes the rest, shared
   by the feet's loads (eq. 2-5, :mod:`~bipedsim.control.humanoid.hips`); velocity tuning's virtual force last.
4. Torque limits, and the actuators' controls.

The constants every step reads are one frozen :class:`~bipedsim.control.humanoid.tables.HumanoidTables`
(``self.tables``), built at construction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.base import Controller, register
from bipedsim.control.humanoid.correction import Correction, LiveCorrection, Nominal, torso_offset
from bipedsim.control.humanoid.feedback import feedback_angles, heading_frame_com, virtual_force
from bipedsim.control.humanoid.feet import feet_world
from bipedsim.control.humanoid.fsm import GaitFSM
from bipedsim.control.humanoid.ground import EdgeStep, feet_tilts, swing_over_ground, torso_lean
from bipedsim.control.humanoid.hips import split_hip_torques, swing_hip_torques
from bipedsim.control.humanoid.modulation import stance_tilt, swing_foot_ik
from bipedsim.control.humanoid.sources import SIDES, ClipSource, GaitSource, Hinges, PoseSource
from bipedsim.control.humanoid.stepping import Playback, ResyncEvent, advance, hurry, resync, tempo_rate
from bipedsim.control.humanoid.tables import HumanoidTables, build_tables
from bipedsim.control.humanoid.torso import CourseSteering, torso_heading, torso_torque
from bipedsim.control.humanoid.tracking import (
    Drive,
    fade_scale,
    gravity_feedforward,
    limit_torques,
    pd_torques,
    set_controls,
)
from bipedsim.control.settings import ControllerConfig, for_body
from bipedsim.errors import ModelError
from bipedsim.model.ground import Terrain
from bipedsim.model.plan import BodyPlanSet
from bipedsim.reference.clip import ReferenceClip

FloatArray = npt.NDArray[np.float64]
#: the shortest nominal swing state (s) a phase-timed push assumes when the reference's step is
#: shorter than ``state1_time`` (a key-pose gait)
MIN_SWING_STATE_S = 0.05
#: the order of the feet in recordings (trajectory.npz's contact_force columns)
FOOT_ORDER = ("left", "right")


@dataclass
class ControllerState:
    """What the controller did on its last step (for recording and plots)."""

    frame: float = 0.0
    fsm_state: int = 1
    gamma: float = 1.0
    fade: float = 1.0
    feedback_sagittal: float = 0.0
    feedback_coronal: float = 0.0
    tau_torso: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: world frame, N*m
    holding: bool = False
    virtual_force: tuple[float, float] = (0.0, 0.0)  #: velocity tuning, heading frame (N)
    tempo: float = 1.0  #: the gait clock's rate (fsm.tempo)
    course_offset: float = 0.0  #: the COM's lateral offset from the reference's course (m, positive left)
    heading_target: float = 0.0  #: the torso law's heading target (rad, world)


class SimbiconController(Controller):
    """PD tracking of a gait source (a clip or key poses) with the four-state FSM and SIMBICON balance."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, source: GaitSource, cfg: ControllerConfig) -> None:
        if plan.profile != "humanoid":
            raise ModelError("the balance controller drives humanoid bodies (two legs, a pelvis)")
        self.model = model
        self.plan = plan
        self.source = source
        # the settings made for this body however the controller is built (a no-op on settings
        # ``runner.load_scenario`` already scaled: they name the body they were scaled to)
        self.cfg = cfg = for_body(cfg, leg_length(model), body_mass(model))
        self.hinges = Hinges.of(model, plan)
        self.tables: HumanoidTables = build_tables(model, plan, source, cfg, self.hinges, leg_length(model))
        self.drive = Drive(model, self.tables, self.hinges.actuator, self.hinges.dadr, cfg)
        self.steering = CourseSteering(source.course(), cfg.balance.course)
        self.pelvis = self.root_body = self.tables.pelvis
        self.control_dt = cfg.control_dt
        self.starts_moving = isinstance(source, ClipSource)
        # the per-run state (reset by :meth:`reset`)
        self.fsm = GaitFSM(state1_time=cfg.fsm.state1_time or source.state1_time(),
                           min_swing_time=cfg.fsm.min_swing_time, contact_force=cfg.fsm.contact_force)
        self.playback = Playback(last_strike_frame=source.loop_start)
        self.state = ControllerState()
        self.frame = source.loop_start
        self.fade = 1.0
        self.force_active = False
        self.force_ended_at: float | None = None
        n = len(self.hinges.names)
        self.ctrl = np.zeros(model.nu)
        self.torque = np.zeros(n)  #: the torques (N*m) of the last control step
        self.tracking_error = np.zeros(n)
        self._qpos_now = np.zeros(model.nq)
        self._ff = np.zeros(n)  #: the last step's gravity feedforward (N*m)
        self._v_sag = self._vf_v = self.tables.speed  #: the sagittal COM velocity: last, and low-passed (m/s)
        self._com_hf = (0.0, 0.0, 0.0, 0.0)  #: the last step's COM offset from the stance ankle and velocity
        self._com_left = False  #: whether that stance ankle was the left
        # scratch refilled on every step (building a fresh array costs more than the product)
        self._jacp = np.zeros((3, model.nv))
        self._ry = np.eye(3)  #: the pelvis's heading rotation
        self._r_fb = np.eye(3)  #: the swing hip's feedback rotation
        self._r_torso = np.eye(3)  #: the torso law's heading when the stance foot's yaw limits it
        #: the feed-forward correction under the controller (:mod:`~bipedsim.control.humanoid.correction`)
        self.correction: Correction | LiveCorrection | None = None
        #: where the correction's own rollout had the body (None: none known), and a log of it being made
        self.nominal: Nominal | None = None
        self.nominal_log: list[tuple[float, float, float, float, float, bool]] | None = None
        self._corr: FloatArray | None = None  #: this step's offsets
        #: the ground's height and normal queries (:class:`~bipedsim.model.ground.Terrain`; None: flat at z = 0)
        self.terrain: Terrain | None = None
        #: the step length's change near an edge of :attr:`terrain`, planned per swing
        self.edge_step = EdgeStep()
        self.drive.scale_gains(1.0)  # the gain tables; the model itself is left as it was
        self.restore_model()

    # ------------------------------------------------------------------ setup
    def restore_model(self) -> None:
        """Undo the damping, gains and torque ranges this controller put into the model."""
        self.drive.restore()

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        """Start: reference at ``frame`` (default: the loop start, a right-foot strike), state 1."""
        self.frame = self.source.loop_start if frame is None else frame
        left = self.source.nearest_strike(self.frame, "left")
        right = self.source.nearest_strike(self.frame, "right")
        stance = self.source.stance_at(self.frame)
        start_left = (stance == "left" if stance is not None else
                      left is not None and right is not None and abs(left - self.frame) < abs(right - self.frame))
        self.fsm.state, self.fsm.time_in_state, self.fsm.step_time = (3 if start_left else 1), 0.0, 0.0
        self.fsm.strikes.clear()
        self.steering.reset(self.source, self.frame, data, self.pelvis)
        self.state.heading_target = self.steering.heading_target
        self.playback.reset(self.frame, t)
        self.edge_step.reset()
        self._v_sag = self._vf_v = self.tables.speed
        self.fade = 1.0
        self.drive.configure()
        self.drive.scale_gains(1.0)

    def start_frame(self) -> int:
        """A clip starts at its loop start (a foot strike); key poses at frame 0, at rest."""
        return int(round(self.source.start_frame())) if self.starts_moving else 0

    # ------------------------------------------------------------------ read-outs (the interface)
    @property
    def heading_target(self) -> float:
        """The torso law's heading target (rad, world)."""
        return self.steering.heading_target

    @property
    def resyncs(self) -> list[ResyncEvent]:
        """The foot strikes of this rollout as resynchronisation matched them."""
        return self.playback.resyncs

    def reference_qpos(self) -> FloatArray:
        """The reference pose now, as a full qpos (root where the reference has it)."""
        return self.source.reference_qpos(self.frame, self.fsm.state, self._qpos_now)

    def reference_speed(self) -> float:
        return float(self.source.speed_at(self.frame))

    def course_progress(self, data: mujoco.MjData) -> tuple[float, float] | None:
        """The centre of mass's progress (m) along the reference's course since :meth:`reset` (arc
        length between the nearest course points, whole loops counted) and its lateral offset (m,
        positive left) from the course now; None for a walk in place."""
        cx, cy, _ = data.subtree_com[self.pelvis].tolist()
        return self.steering.progress(cx, cy)

    def actuator_torques(self) -> FloatArray:
        """Torques per actuator (``data.ctrl`` holds servo targets for servo joints, not torques)."""
        out = np.zeros(self.model.nu)
        out[self.hinges.actuator] = self.torque
        return out

    def foot_names(self) -> tuple[str, ...]:
        return FOOT_ORDER

    def target_names(self) -> tuple[str, ...]:
        """The tracked hinges, in PD target order."""
        return tuple(self.hinges.names)

    def foot_forces(self, data: mujoco.MjData) -> list[float]:
        return [sum(float(data.sensordata[a]) for a in self.tables.touch[s]) for s in FOOT_ORDER]

    def gait_state(self) -> int:
        return self.fsm.state

    def time_in_state(self) -> float:
        return self.fsm.time_in_state

    def state_duration(self, state: int) -> float | None:
        """States 1 and 3 last ``state1_time``; 2 and 4 the rest of the reference's step (>= 50 ms)."""
        if state not in (1, 2, 3, 4):
            return None
        if state in (1, 3):
            return self.fsm.state1_time
        return max(self.source.step_time() - self.fsm.state1_time, MIN_SWING_STATE_S)

    def foot_strikes(self) -> list[tuple[float, str]]:
        return self.fsm.strikes

    def metrics(self) -> dict[str, object]:
        ratios = [r.ratio for r in self.resyncs]
        return {"resyncs": len(ratios), "mean_resync_ratio": float(np.mean(ratios)) if ratios else None}

    # ------------------------------------------------------------------ external force and fade
    def set_external_force(self, active: bool, t: float) -> None:
        """Tell the controller whether an external force (a push) acts now (sec. 4.4)."""
        if self.force_active and not active:
            self.force_ended_at = t
        self.force_active = active

    def _update_fade(self, t: float) -> None:
        scale = fade_scale(self.cfg.fade, self.force_active, self.force_ended_at, t)
        if scale != self.fade:
            self.fade = scale
            self.drive.scale_gains(scale)

    def _resync(self, foot: str, t: float) -> None:
        """A strike of ``foot`` at time ``t`` (:func:`~bipedsim.control.humanoid.stepping.resync`)."""
        self.frame = resync(self.playback, self.source, self.cfg.resync, self.frame, foot, t)

    # ------------------------------------------------------------------ the control law
    # This runs on every control step, so it is written for speed: slices instead of index arrays
    # where the hinges are contiguous, the balance maths on plain floats (numpy's per-call overhead
    # dominates on 3-vectors), numpy only for whole-body vectors and 3x3 products.
    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        cfg, tb, fsm = self.cfg, self.tables, self.fsm
        if cfg.fade.enabled:
            self._update_fade(t)
        sd = data.sensordata
        touch = sd[tb.touch_idx].tolist()
        forces = {"right": sum(touch[:tb.n_touch_right]), "left": sum(touch[tb.n_touch_right:])}
        # the gait clock: real time, faster while the body outruns the reference (fsm.tempo)
        speed = self.source.speed_at(self.frame)
        rate = tempo_rate(cfg.fsm.tempo, self._v_sag, speed) if cfg.fsm.tempo.gain > 0.0 else 1.0
        if t > 0.0:  # the COM is measured from the first step on
            rate = hurry(self.playback, cfg, self.source, self.frame, fsm.stance, self._com_hf, self.tables.omega, dt,
                         rate)
        dt_ref = dt * rate
        self.playback.clock += dt_ref
        # a strike is the swing foot's sole landing; its toe brushing the floor at lift-off is not
        struck = fsm.update(dt_ref, t, float(sd[tb.touch[fsm.swing][0]]))
        if struck is not None:
            self._resync(struck, t)
            self.playback.wait_time = 0.0
        self.frame, holding = advance(self.playback, self.source, cfg, fsm, self.frame, dt, dt_ref)
        q_d, qd_d = self.source.hinge_targets(self.frame, fsm.state)
        self._qpos_now = data.qpos
        q = data.qpos[tb.qsel]
        qd = data.qvel[tb.dsel]
        self.tracking_error = q - q_d  # against the reference itself, before limits and balance
        corr = self._corr = self.correction.at(self.frame) if self.correction is not None else None
        # the COM state below was measured last step, from that step's stance ankle (_com_left)
        if self.nominal_log is not None:  # the correction's own path being recorded (sim.scenario.nominal_path)
            if t > 0.0:  # the COM is measured from the first step on
                self.nominal_log.append((self.frame, *self._com_hf, self._com_left))
        elif corr is not None and self.nominal is not None and t > 0.0:  # the correction's reach
            reach = cfg.reconstruct.reach
            off = self.nominal.deviation(self.frame, self._com_hf, self._com_left, tb.omega)
            if off is not None and off > reach:
                w = max(0.0, 2.0 - off / reach)
                corr = self._corr = corr * w if w > 0.0 else None
        if corr is not None:
            q_d += corr[:self.tables.kp.shape[0]]
        if self.target_offset is not None:  # a policy's residual or absolute targets (Controller.target_offset)
            if self.target_absolute:
                q_d[:] = self.target_offset
            else:
                q_d += self.target_offset
        np.minimum(np.maximum(q_d, tb.tlo, out=q_d), tb.thi, out=q_d)
        tau = pd_torques(self.drive, q_d, q, qd, qd_d)
        if cfg.pd.gravity_compensation:
            self._ff = gravity_feedforward(tb, self.model, data, self._jacp, forces, fsm.stance)
            tau += self._ff
        st = self.state
        st.frame, st.fsm_state, st.fade, st.holding, st.tempo = self.frame, fsm.state, self.fade, holding, rate
        if cfg.balance.enabled:
            self._balance(data, q, qd, q_d, qd_d, tau, forces, dt, speed)
        self.torque = limit_torques(self.drive, tau, qd, fsm.swing)
        # a servo's target gives the unclipped torque (the servo clamps it); a net limit's, the clipped one
        set_controls(self.drive, self.ctrl, q, self.torque if tb.net_limit else tau, self.torque)
        return self.ctrl

    def _balance(self, data: mujoco.MjData, q: FloatArray, qd: FloatArray, q_d: FloatArray, qd_d: FloatArray,
                 tau: FloatArray, forces: dict[str, float], dt: float, speed: float) -> None:
        """The balance terms of one control step, in order: course steering, the torso law, swing-hip
        feedback (eq. 6), the feet's world targets, the hips' torque split (eq. 2-5), velocity tuning;
        ``speed`` the reference's walking speed now (m/s)."""
        b, tb, src, fsm, frame = self.cfg.balance, self.tables, self.source, self.fsm, self.frame
        stance, swing = fsm.stance, fsm.swing
        r_p = data.xmat[self.pelvis].reshape(3, 3)
        pm = data.xmat[self.pelvis].tolist()
        mujoco.mj_subtreeVel(self.model, data)
        cx, cy, _ = data.subtree_com[self.pelvis].tolist()
        vx, vy, _ = data.subtree_linvel[self.pelvis].tolist()
        heading = math.atan2(pm[3], pm[0])
        c, s = math.cos(heading), math.sin(heading)
        if tb.course_on:
            self.steering.steer(cx, cy, vx, vy, c, s, dt)
            self.state.course_offset = self.steering.offset
            self.state.heading_target = self.steering.heading_target
        ry = self._ry
        ry[0, 0], ry[0, 1], ry[1, 0], ry[1, 1] = c, -s, s, c
        corr = self._corr
        pelvis_ref = src.pelvis_target(frame, fsm.state)
        if corr is not None:
            pelvis_ref = torso_offset(float(corr[-2]), float(corr[-1])).dot(pelvis_ref)
        terrain = self.terrain if self.cfg.modulation.ground.enabled else None
        if terrain is not None:  # the torso leaned into a slope
            pelvis_ref = torso_lean(self.cfg.modulation.ground, terrain, tb, data, stance, c, s).dot(pelvis_ref)
        tau_torso = torso_torque(b, tb.roll_kp, self._torso_heading(data, forces), pelvis_ref,
                                 r_p, pm, data.qvel[3:6].tolist(), c, s)
        ax, ay, _ = data.xpos[tb.foot_body[stance]].tolist()
        self._com_hf = com = heading_frame_com(cx - ax, cy - ay, vx, vy, c, s)
        self._com_left = stance == "left"
        self._v_sag = com[2]
        fs, fc = feedback_angles(b, tb, src, frame, stance, com, speed)
        if corr is not None:
            fs, fc = fs + float(corr[-4]), fc + float(corr[-3])
        self.state.feedback_sagittal, self.state.feedback_coronal = fs, fc
        if tb.ik_on:
            fs += swing_foot_ik(self.cfg.modulation.swing_foot, tb, data, src.swing_leg(frame, swing),
                                src.swing_phase(frame, swing), swing, stance, self.drive.akp, q_d, tau)
        if terrain is not None:  # the step clear of an edge, the swing foot over the ground ahead
            gc, es = self.cfg.modulation.ground, self.edge_step
            fs += es.angle(gc, terrain, tb, data, swing, stance, c, s)
            fs += swing_over_ground(gc, terrain, tb, data, src.swing_leg(frame, swing), src.swing_phase(frame, swing),
                                    swing, stance, c, s, self.drive.akp, q_d, tau, es.short, es.over)
        if b.swing_hip_world:
            t_b = swing_hip_torques(tb, data, swing, src.thigh_target(frame, fsm.state, swing), r_p, ry, self._r_fb,
                                    fs, fc, q, qd, q_d, qd_d, self.fade, self.cfg.pd.gravity_compensation)
        else:
            hip = tb.hip[swing]
            t_b = tau[hip.sel].tolist() if isinstance(hip.sel, slice) else [float(tau[i]) for i in hip.idx_l]
        if b.feet_world:
            tilt = (stance_tilt(self.cfg.modulation.stance_ankle, com, *src.com_reference(frame, stance))
                    if tb.ankle_feedback_on else None)
            feet_world(tb, data, src, frame, fsm.state, stance, ry, tilt, q, qd, q_d, qd_d, tau, self.fade,
                       self._ff if self.cfg.pd.gravity_compensation else None, corr,
                       None if terrain is None else feet_tilts(self.cfg.modulation.ground, terrain, tb, data, c, s,
                                                              swing, self.edge_step.over))
        self.state.gamma = split_hip_torques(tb, data, tau, tau_torso, t_b, forces, stance, swing, b.redistribution)
        self.state.tau_torso = tau_torso
        if tb.velocity_on:  # last: the feet's world targets above set the ankle torques outright
            vc = b.velocity
            v0 = com[2]
            if vc.filter_s > 0.0:
                self._vf_v += (v0 - self._vf_v) * min(1.0, dt / vc.filter_s)
                v0 = self._vf_v
            self.state.virtual_force = (virtual_force(vc, tb, data, tau, forces, c, s, v0, speed), 0.0)

    def _torso_heading(self, data: mujoco.MjData, forces: dict[str, float]) -> FloatArray:
        """The torso law's heading rotation: the heading target's, within ``balance.stance_yaw_limit`` of
        the loaded stance foot's yaw (:func:`~bipedsim.control.humanoid.torso.torso_heading`)."""
        lim, stance = self.cfg.balance.stance_yaw_limit, self.fsm.stance
        loaded = lim is not None and forces[stance] > 0.0
        foot_ref = self.source.foot_target(self.frame, self.fsm.state, stance) if loaded else None
        return torso_heading(self.steering.r_heading, self._r_torso, lim, forces[stance], foot_ref,
                             data.xmat[self.tables.foot_body[stance]])


def leg_length(model: mujoco.MjModel) -> float:
    """A humanoid's leg length (m): hip to knee plus knee to ankle, the two legs' mean."""
    return sum(float(np.linalg.norm(model.body_pos[model.body(f"{s}_shin").id]))
               + float(np.linalg.norm(model.body_pos[model.body(f"{s}_foot").id])) for s in SIDES) / 2


def body_mass(model: mujoco.MjModel) -> float:
    """A body's total mass (kg)."""
    return float(np.sum(model.body_mass[1:]))


@register("humanoid")
def make_humanoid(model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip, cfg: ControllerConfig
                  ) -> SimbiconController:
    """The humanoid's controller: tracking ``clip`` (``source: clip``) or SIMBICON's key poses (``pose``), its
    settings (the key poses' times among them) scaled to the body first."""
    cfg = for_body(cfg, leg_length(model), body_mass(model))
    return SimbiconController(model, plan, gait_source(model, plan, clip, cfg), cfg)


def gait_source(model: mujoco.MjModel, plan: BodyPlanSet, clip: ReferenceClip, cfg: ControllerConfig) -> GaitSource:
    """What the humanoid tracks: the clip (``source: clip``) or SIMBICON's key poses (``pose``)."""
    h = Hinges.of(model, plan)
    if cfg.source == "pose":
        return PoseSource(cfg.pose_gait, h)
    return ClipSource(clip, model, plan, h, whole=cfg.source == "clip")
