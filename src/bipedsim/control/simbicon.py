"""The humanoid's :class:`SimbiconController` (behind the :class:`~bipedsim.control.base.Controller`
interface): PD tracking + gait FSM + SIMBICON balance + fade + resynchronisation.

One call maps (model, data, time) to actuator controls (joint torques, N*m). Per control step:

1. FSM update from the swing foot's touch sensor; on a foot strike, resynchronise the reference.
2. Advance the reference frame F by dt / frame_time (held at a strike frame while the swing foot is
   late, if configured).
3. PD tracking (eq. 1) of every hinge toward the reference, scaled by the fade factor.
4. Balance (when enabled): course control turns the heading target toward the reference's own course
   (``balance.course``, :meth:`SimbiconController._steer`); world-frame pelvis torque tau_torso toward it; the
   swing hip tracks a world-frame thigh target turned by the feedback theta_d0 + c_d d + c_v v (eq. 6)
   in the sagittal and coronal planes; the stance hip takes the rest, redistributed by the feet's load
   (eq. 2-5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.balance import (
    axis_rotation,
    beyond,
    course_turn,
    euler_from_matrix,
    feedback_angle,
    heading_of,
    hinges_to_world,
    hinges_to_world3,
    hip_torques3,
    sagittal_cd,
    stance_share,
    world_to_hinges3,
    yaw_matrix,
    yaw_within,
)
from bipedsim.control.base import Controller, register
from bipedsim.control.config import DEFAULT_GAINS, ControllerConfig, for_body
from bipedsim.control.fsm import GaitFSM
from bipedsim.control.reference import SIDES, ClipSource, CourseTracker, GaitSource, Hinges, PoseSource, foot_points
from bipedsim.errors import ConfigError, ModelError
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.plan import BodyPlanSet
from bipedsim.model.retarget import hinge_basis

FloatArray = npt.NDArray[np.float64]
#: the shortest nominal swing state (s) a phase-timed push assumes when the reference's step is
#: shorter than ``state1_time`` (a key-pose gait)
MIN_SWING_STATE_S = 0.05
#: With ``pd.net_limit``: the joint speed (rad/s) up to which a servo's force range leaves room for the
#: damping's share beside the torque limit.
NET_LIMIT_SPEED = 20.0
#: the order of the feet in recordings (trajectory.npz's contact_force columns)
FOOT_ORDER = ("left", "right")


@dataclass
class ResyncEvent:
    time: float
    foot: str
    frame_before: float
    frame_after: float
    ratio: float  #: M = P_c / P_r


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
        self.cfg = for_body(cfg, leg_length(model), body_mass(model))
        self.hinges = Hinges.of(model, plan)
        jplan = {j.name: j for b in plan.bodies for j in b.joints}
        self._gain_table(jplan)
        self._leg_tables(jplan)
        self._model_tables()
        self._foot_tables()
        self._gait_state()
        self._hot_path_tables()
        self._apply_damping(1.0)  # the gain tables; the model itself is left as it was
        self.restore_model()

    def _gain_table(self, jplan: dict) -> None:
        """kp, kd (N*m/rad, N*m*s/rad) and torque limits (N*m) per hinge: the joint's own entry in
        ``pd.joint_gains``, else its group's in ``pd.gains`` (or :data:`DEFAULT_GAINS`, for a config built
        in Python without it), else the joint plan's; target ranges."""
        model, cfg = self.model, self.cfg
        n = len(self.hinges.names)
        self.kp = np.zeros(n)
        self.kd = np.zeros(n)
        # the model's limits are the profile's, for any body: scaled to this one (``body.torque_scale``)
        self.limit = np.abs(model.actuator_ctrlrange[self.hinges.actuator, 1]) * cfg.body.torque_scale
        for i, name in enumerate(self.hinges.names):
            g = cfg.pd.gains.get(self.hinges.groups[i]) or DEFAULT_GAINS.get(self.hinges.groups[i])
            kp, kd = (g.kp, g.kd) if g else (jplan[name].kp, jplan[name].kd)
            lim = g.torque_limit if g and g.torque_limit else None
            jg = cfg.pd.joint_gains.get(name)
            if jg:
                kp, kd = jg.kp, jg.kd
                lim = jg.torque_limit or lim
            self.kp[i], self.kd[i] = kp, kd
            if lim:
                self.limit[i] = lim
        unknown = [j for j in (*cfg.pd.joint_gains, *cfg.pd.target_limits) if j not in self.hinges.names]
        if unknown:
            raise ConfigError(f"names joint {unknown[0]!r}, which the model does not have; hinges are "
                              f"{', '.join(self.hinges.names)}", key="pd.joint_gains")
        # targets stay inside the joints' ranges (a retargeted clip may reach past them)
        self.tlo = model.jnt_range[self.hinges.jid, 0].copy()
        self.thi = model.jnt_range[self.hinges.jid, 1].copy()
        for j, (lo, hi) in cfg.pd.target_limits.items():
            self.tlo[self.hinges.index(j)], self.thi[self.hinges.index(j)] = lo, hi

    def _leg_tables(self, jplan: dict) -> None:
        """Hip and ankle hinge indices, world-axis joint ids and Euler decompositions of their axes."""
        model = self.model
        # hips: hinge indices, world-axis joint ids, Euler decomposition of their axis sets
        self.hip = {}
        for s in SIDES:
            names = [f"{s}_hip_y", f"{s}_hip_x", f"{s}_hip_z"]
            idx = np.array([self.hinges.index(x) for x in names])
            axes = [np.asarray(jplan[x].axis) for x in names]
            order = tuple(int(np.argmax(np.abs(a))) for a in axes)
            signs = np.array([np.sign(a[k]) for a, k in zip(axes, order)])
            self.hip[s] = (idx, self.hinges.jid[idx], order, signs)
        # ankles: hinge indices and Euler decomposition of their axes (1 or 2 hinges)
        self.ankle = {}
        for s in SIDES:
            names = [x for x in (f"{s}_ankle", f"{s}_ankle_y", f"{s}_ankle_x") if x in self.hinges.names]
            idx = np.array([self.hinges.index(x) for x in names])
            axes = [np.asarray(jplan[x].axis) for x in names]
            self.ankle[s] = (idx, axes)
        self.shin_body = {s: model.body(f"{s}_shin").id for s in SIDES}
        # two-link legs for the swing foot's IK: thigh and shin lengths (m), the knee hinge
        self.leg_len = {s: (float(np.linalg.norm(model.body_pos[self.shin_body[s]])),
                            float(np.linalg.norm(model.body_pos[model.body(f"{s}_foot").id]))) for s in SIDES}
        self.knee = {s: self.hinges.index(f"{s}_knee") for s in SIDES}
        self._foot_pts = {s: foot_points(model, s) for s in SIDES}

    def _model_tables(self) -> None:
        """What the controller changes in the model (damping, actuator fields), saved to restore."""
        model, cfg, n = self.model, self.cfg, len(self.hinges.names)
        # implicit damping: MuJoCo's joint damping carries kd
        self.implicit = cfg.pd.implicit_damping
        self.base_damping = model.dof_damping.copy()
        # the configuration's torque limits replace the model's actuator ranges while it runs
        self._saved = {k: getattr(model, k).copy() for k in _ACTUATOR_FIELDS}
        self.servo = cfg.pd.servo & (self.kp > 0)
        self.servo_gain = np.ones(n)
        self.pelvis = self.root_body = model.body("pelvis").id
        self.control_dt = cfg.control_dt
        self.starts_moving = isinstance(self.source, ClipSource)

    def _foot_tables(self) -> None:
        """Feet, stance-leg chains, body weight and the touch sensors of each side."""
        model = self.model
        self.foot_body = {s: model.body(f"{s}_foot").id for s in SIDES}
        # stance-leg joints below the hip (knee, ankle, toe) per side, for weight support
        self.leg_low = {s: np.array([i for i, n in enumerate(self.hinges.names)
                                     if n.startswith(f"{s}_") and n.split("_", 1)[1] in ("knee", "ankle", "ankle_y",
                                                                                         "ankle_x", "toe")])
                        for s in SIDES}
        self.weight = float(np.sum(model.body_mass) * -model.opt.gravity[2])
        self.jacp = np.zeros((3, model.nv))
        self.touch = {s: [model.sensor_adr[model.sensor(f"touch_{b}_touch").id]
                          for b in (f"{s}_foot", f"{s}_toe") if _has_sensor(model, f"touch_{b}_touch")]
                      for s in SIDES}

    def _gait_state(self) -> None:
        """The FSM, the reference's playback and the per-run state (reset by :meth:`reset`)."""
        model, cfg, source, n = self.model, self.cfg, self.source, len(self.hinges.names)
        self.fsm = GaitFSM(state1_time=cfg.fsm.state1_time or source.state1_time(),
                           min_swing_time=cfg.fsm.min_swing_time, contact_force=cfg.fsm.contact_force)
        self.state = ControllerState()
        self.frame = source.loop_start
        self.heading_target = 0.0
        self.fade = 1.0
        self.force_active = False
        self.force_ended_at: float | None = None
        self.last_strike_time = self.last_strike_clock = 0.0
        self.last_strike_frame = source.loop_start
        self.wait_time = 0.0
        self.pending_shift = 0.0
        self._shift_spread = cfg.resync.spread
        self.resyncs: list[ResyncEvent] = []
        self.ctrl = np.zeros(model.nu)
        self.torque = np.zeros(n)  #: the torques (N*m) of the last control step
        self.tracking_error = np.zeros(n)
        self._qpos_now = np.zeros(model.nq)

    def _hot_path_tables(self) -> None:
        """Constants of the control step in the forms it reads fastest (slices, lists, floats)."""
        model, cfg, source = self.model, self.cfg, self.source
        # hot-path constants (see __call__)
        self._qsel, self._dsel, self._asel = (_as_slice(self.hinges.qadr), _as_slice(self.hinges.dadr),
                                              _as_slice(self.hinges.actuator))
        self._leg_dofs = {s: _as_slice(self.hinges.dadr[self.leg_low[s]]) for s in SIDES}
        self._leg_low = {s: _as_slice(self.leg_low[s]) for s in SIDES}
        self._neg_limit = -self.limit
        #: pd.net_limit: which hinges' limits bound actuator and damping together (None: every hinge;
        #: per side, the swing leg's hinges for "swing" and "swing_hip")
        self._net_limit = cfg.pd.net_limit != "off" and self.implicit
        self._net_joints: dict[str, list[int]] | None = (
            {sd: [int(i) for i in self.hip[sd][0]] for sd in SIDES} if cfg.pd.net_limit == "swing_hip"
            else {sd: [*(int(i) for i in self.hip[sd][0]), int(self.knee[sd])] for sd in SIDES}
            if cfg.pd.net_limit == "swing" else None)
        self._all_servo = bool(np.all(self.servo))
        self._ref_vel = cfg.pd.mode == "pd_ref_velocity"
        self._fade_on = cfg.fade.enabled
        self._roll_kp = cfg.balance.torso_kp if cfg.balance.roll_kp is None else cfg.balance.roll_kp
        self._speed = float(source.speed())
        # the sagittal c_v and c_d scheduled by the walk's Froude number (legs: hip to ankle, both sides' mean)
        leg, g = leg_length(model), -float(model.opt.gravity[2])
        self._cv_sagittal = cfg.balance.sagittal.cv
        self._cd_sagittal = sagittal_cd(cfg.balance, self._speed, leg, g)
        self._tempo_on = cfg.fsm.tempo.gain > 0.0
        self._v_sag = self._speed  #: the last control step's sagittal COM velocity (heading frame)
        self.clock = 0.0  #: the gait clock (s): real time run at the tempo rate
        self._kp_l, self._kd_l = self.kp.tolist(), self.kd.tolist()
        self._tlo_l, self._thi_l = self.tlo.tolist(), self.thi.tolist()
        self._r_heading = np.eye(3)
        self._r_torso = np.eye(3)  #: scratch: the torso law's heading when the stance foot's yaw limits it
        self._stance_yaw_limit = cfg.balance.stance_yaw_limit
        self.course = CourseTracker(source.course())
        self._course_from: tuple[float, float] | None = None  #: the COM's place on the course at reset
        self._course_on = cfg.balance.enabled and cfg.balance.course.enabled
        self._rate_f = 0.0  #: the course offset's rate, low-passed (m/s)
        cc = cfg.balance.course
        self._course_gains = (cc.deadband, cc.rate_filter, cc.steer_gain, cc.steer_damping, cc.max_turn)
        self._dt = model.opt.timestep  #: the last control step's length (s)
        # scratch 3x3s refilled on every step (building a fresh array costs more than the product)
        self._ry = np.eye(3)
        self._r_fb = np.eye(3)
        self._touch_idx = np.array(self.touch["right"] + self.touch["left"], dtype=np.int64)
        self._n_touch_right = len(self.touch["right"])
        # per side: swing-hip hinge indices as (slice, list), their joint ids as a slice (the hinges'
        # world axes), Euler order and signs; ankle hinges with unit axes
        self._hip_fast = {s: (_as_slice(self.hip[s][0]), self.hip[s][0].tolist(), _as_slice(self.hip[s][1]),
                              self.hip[s][2], self.hip[s][3].tolist(), self.hinges.dadr[self.hip[s][0]].tolist())
                          for s in SIDES}
        self._ankle_fast = {s: (self.ankle[s][0].tolist(), [tuple((a / np.linalg.norm(a)).tolist())
                                                             for a in self.ankle[s][1]],
                                None if len(self.ankle[s][1]) < 2 else hinge_basis(self.ankle[s][1])[2])
                            for s in SIDES}
        mod = cfg.modulation
        # "auto" is resolved for the reference when a scenario is loaded (control.config.for_reference);
        # left unresolved, it is off
        self._ik_on = mod.swing_foot.enabled is True and source.swing_leg(source.loop_start, "left") is not None
        self._ankle_fb_on = mod.stance_ankle.enabled is True
        self._com_hf = (0.0, 0.0, 0.0, 0.0)  #: the last step's COM offset from the stance ankle and velocity
        vel = cfg.balance.velocity
        # the sagittal target is the source's walking speed: a source without one (key poses) has none
        self._kv_sag = vel.kv_sagittal if self._speed > 0.0 else 0.0
        self._vel_on = cfg.balance.enabled and self._kv_sag > 0
        #: per side: (hinge index, joint id) of the knee and ankle hinges, the stance leg's chain below
        #: the hip (which belongs to the torso law) for velocity tuning
        self._vf_joints = {s: [(int(i), int(self.hinges.jid[i])) for i in self.leg_low[s]
                               if not self.hinges.names[i].endswith("toe")] for s in SIDES}

    # ------------------------------------------------------------------ setup
    def _configure_actuators(self) -> None:
        """Put this controller's actuator settings into the model (on reset; ``restore_model`` undoes
        them): constructing a controller leaves the model as it was, so several may be made for one model."""
        model, acts = self.model, self.hinges.actuator
        # the net-limited hinges: the controller clamps their torques (see __call__), and the actuator's own
        # range leaves room for the damping's share at up to NET_LIMIT_SPEED rad/s
        room = np.zeros(len(self.limit))
        if self._net_limit:
            net = range(len(room)) if self._net_joints is None else [i for js in self._net_joints.values() for i in js]
            for i in net:
                room[i] = self.kd[i] * NET_LIMIT_SPEED
        if self.cfg.pd.servo:
            # force = gain ctrl - gain q for servo joints (ctrl is a target angle), = ctrl for motors;
            # the torque limit clamps the actuator force on every physics step
            model.actuator_gaintype[acts] = mujoco.mjtGain.mjGAIN_FIXED
            model.actuator_biastype[acts] = mujoco.mjtBias.mjBIAS_AFFINE
            model.actuator_biasprm[acts] = 0.0
            model.actuator_ctrllimited[acts] = 0
            model.actuator_forcelimited[acts] = 1
            model.actuator_forcerange[acts, 0] = -self.limit - room
            model.actuator_forcerange[acts, 1] = self.limit + room
        else:
            model.actuator_ctrlrange[acts, 0] = -self.limit - room
            model.actuator_ctrlrange[acts, 1] = self.limit + room

    def _apply_damping(self, scale: float) -> None:
        """Gains scaled by the fade factor: MuJoCo joint damping (implicit kd) and servo stiffness."""
        d = self.base_damping.copy()
        if self.implicit:
            d[self.hinges.dadr] += scale * self.kd
        self.model.dof_damping[:] = d
        if self.cfg.pd.servo:
            acts = self.hinges.actuator
            self.servo_gain = np.where(self.servo, max(scale, 1e-6) * self.kp, 1.0)
            self.model.actuator_gainprm[acts, 0] = self.servo_gain
            self.model.actuator_biasprm[acts, 1] = np.where(self.servo, -self.servo_gain, 0.0)
        self._akp, self._akd = scale * self.kp, scale * self.kd
        self._inv_gain = np.where(self.servo, 1.0 / self.servo_gain, 0.0)

    def restore_model(self) -> None:
        """Undo the damping, gains and torque ranges this controller put into the model."""
        self.model.dof_damping[:] = self.base_damping
        for k, v in self._saved.items():
            getattr(self.model, k)[:] = v

    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        """Start: reference at ``frame`` (default: the loop start, a right-foot strike), state 1."""
        self.frame = self.source.loop_start if frame is None else frame
        left = self.source.nearest_strike(self.frame, "left")
        right = self.source.nearest_strike(self.frame, "right")
        start_left = left is not None and right is not None and abs(left - self.frame) < abs(right - self.frame)
        self.fsm.state, self.fsm.time_in_state, self.fsm.step_time = (3 if start_left else 1), 0.0, 0.0
        self.fsm.strikes.clear()
        self.resyncs.clear()
        self.pending_shift = 0.0
        self.heading_target = heading_of(data.xmat[self.pelvis].reshape(3, 3))
        self._r_heading = yaw_matrix(self.heading_target)
        self.state.heading_target = self.heading_target
        ref_pose, seg = self.source.course_start(self.frame)
        self.course.reset(ref_pose, (float(data.qpos[0]), float(data.qpos[1]), self.heading_target), seg)
        cx, cy, _ = data.subtree_com[self.pelvis].tolist()
        self._course_from = self.course.locate(cx, cy)
        self._rate_f = 0.0
        self.last_strike_time, self.last_strike_frame = t, self.frame
        self.clock = self.last_strike_clock = t
        self._v_sag = self._vf_v = self._speed
        self.fade = 1.0
        self._configure_actuators()
        self._apply_damping(1.0)

    def start_frame(self) -> int:
        """A clip starts at its loop start (a foot strike); key poses at frame 0, at rest."""
        return int(round(self.source.start_frame())) if self.starts_moving else 0

    # ------------------------------------------------------------------ read-outs (the interface)
    def reference_qpos(self) -> FloatArray:
        """The reference pose now, as a full qpos (root where the reference has it)."""
        return self.source.reference_qpos(self.frame, self.fsm.state, self._qpos_now)

    def reference_speed(self) -> float:
        return float(self.source.speed())

    def course_progress(self, data: mujoco.MjData) -> tuple[float, float] | None:
        """The centre of mass's progress (m) along the reference's course since :meth:`reset` (arc
        length between the nearest course points, whole loops counted) and its lateral offset (m,
        positive left) from the course now; None for a walk in place."""
        cx, cy, _ = data.subtree_com[self.pelvis].tolist()
        now = self.course.locate(cx, cy)
        if now is None or self._course_from is None:
            return None
        return now[0] - self._course_from[0], now[1]

    def actuator_torques(self) -> FloatArray:
        """Torques per actuator (``data.ctrl`` holds servo targets for servo joints, not torques)."""
        out = np.zeros(self.model.nu)
        out[self.hinges.actuator] = self.torque
        return out

    def foot_names(self) -> tuple[str, ...]:
        return FOOT_ORDER

    def foot_forces(self, data: mujoco.MjData) -> list[float]:
        return [sum(float(data.sensordata[a]) for a in self.touch[s]) for s in FOOT_ORDER]

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

    def tracked_joints(self) -> tuple[list[str], list[int]]:
        """Names and qpos addresses of the hinges tracked (for joint-angle plots and CSV)."""
        return list(self.hinges.names), [int(a) for a in self.hinges.qadr]

    # ------------------------------------------------------------------ external force and fade
    def set_external_force(self, active: bool, t: float) -> None:
        """Tell the controller whether an external force (a push) acts now (sec. 4.4)."""
        if self.force_active and not active:
            self.force_ended_at = t
        self.force_active = active

    def _update_fade(self, t: float) -> None:
        f = self.cfg.fade
        if not f.enabled:
            scale = 1.0
        elif self.force_active:
            scale = f.min_scale
        elif self.force_ended_at is not None:
            u = (t - self.force_ended_at) / f.fade_in
            scale = 1.0 if u >= 1.0 else f.min_scale + (1.0 - f.min_scale) * u
        else:
            scale = 1.0
        if scale != self.fade:
            self.fade = scale
            self._apply_damping(scale)

    # ------------------------------------------------------------------ resync
    def _resync(self, foot: str, t: float) -> None:
        src = self.source
        # the reference strike this one matches: that foot's next strike after the last matched one
        target = src.next_strike(self.last_strike_frame + 1e-3, foot)
        p_c = self.clock - self.last_strike_clock  # on the gait clock, as the reference's P_r
        before = self.frame
        ratio = 1.0
        if target is not None:
            p_r = max((target - self.last_strike_frame) * src.frame_time, 1e-6)
            ratio = p_c / p_r
            if self.cfg.resync.enabled:
                delta = np.clip(self.cfg.resync.gain * (target - self.frame), -self.cfg.resync.max_frames,
                                self.cfg.resync.max_frames)
                if self.cfg.resync.spread > 0:
                    self.pending_shift, self._shift_spread = float(delta), self.cfg.resync.spread
                else:
                    self.frame += float(delta)
            self.last_strike_frame = target
        self.last_strike_time, self.last_strike_clock = t, self.clock
        self.resyncs.append(ResyncEvent(t, foot, before, self.frame, ratio))

    # ------------------------------------------------------------------ the control law
    # This runs on every control step, so it is written for speed: slices instead of index arrays
    # where the hinges are contiguous, the balance maths on plain floats (numpy's per-call overhead
    # dominates on 3-vectors), numpy only for whole-body vectors and 3x3 products.
    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        cfg = self.cfg
        src = self.source
        if self._fade_on:
            self._update_fade(t)
        fsm = self.fsm
        sd = data.sensordata
        touch = sd[self._touch_idx].tolist()
        forces = {"right": sum(touch[:self._n_touch_right]), "left": sum(touch[self._n_touch_right:])}
        # a strike is the swing foot's sole landing; its toe brushing the floor at lift-off is not
        # the gait clock: real time, faster while the body outruns the reference (fsm.tempo)
        rate = 1.0
        if self._tempo_on:
            tc = cfg.fsm.tempo
            e = self._v_sag - self._speed
            e = e - tc.deadband if e > tc.deadband else (e + tc.deadband if e < -tc.deadband else 0.0)
            rate = min(max(1.0 + tc.gain * e, tc.min), tc.max)
        dt_ref = dt * rate
        self.clock += dt_ref
        swing_force = float(sd[self.touch[fsm.swing][0]])
        struck = fsm.update(dt_ref, t, swing_force)
        if struck is not None:
            self._resync(struck, t)
            self.wait_time = 0.0
        # advance the reference, holding at the swing foot's strike frame while it has not landed
        nxt = self.frame + dt_ref / src.frame_time
        if self.pending_shift:
            step = self.pending_shift * (min(1.0, dt / self._shift_spread) if self._shift_spread > 0 else 1.0)
            if abs(self.pending_shift - step) < 1e-9 or abs(step) >= abs(self.pending_shift):
                step = self.pending_shift
            nxt += step
            self.pending_shift -= step
        holding = False
        if cfg.resync.hold and fsm.state in (2, 4):
            exp = src.next_strike(self.frame, fsm.swing)
            if exp is not None and nxt >= exp and self.wait_time < cfg.fsm.max_wait:
                nxt = exp - 1e-6
                holding = True
                self.wait_time += dt
        self.frame = nxt
        q_d, qd_d = src.hinge_targets(self.frame, fsm.state)
        self._qpos_now = data.qpos
        q = data.qpos[self._qsel]
        qd = data.qvel[self._dsel]
        self.tracking_error = q - q_d  # against the reference itself, before limits and balance
        np.minimum(np.maximum(q_d, self.tlo, out=q_d), self.thi, out=q_d)
        a = self.fade
        ref_vel = self._ref_vel
        if self.implicit:
            # the -kd qdot part is MuJoCo joint damping (implicit); only the rest is computed here
            tau = self._akp * (q_d - q)
            if ref_vel:
                tau += self._akd * qd_d
        else:
            tau = self._akp * (q_d - q) - self._akd * (qd - qd_d if ref_vel else qd)
        if cfg.pd.gravity_compensation:
            self._ff = self._gravity(data, forces)
            tau += self._ff
        st = self.state
        st.frame, st.fsm_state, st.fade, st.holding, st.tempo = self.frame, fsm.state, a, holding, rate
        if cfg.balance.enabled:
            self._dt = dt
            self._balance(data, q, qd, q_d, qd_d, tau, forces)
        self.torque = np.minimum(np.maximum(tau, self._neg_limit), self.limit)
        if self._net_limit:
            # the limit bounds actuator and damping together while the joint is driven the way it moves
            if self._net_joints is None:
                damp = self._akd * qd
                self.torque = np.minimum(np.maximum(tau, self._neg_limit + np.minimum(damp, 0.0)),
                                         self.limit + np.maximum(damp, 0.0))
            else:
                for i in self._net_joints[fsm.swing]:
                    d, lim, t = float(self._akd[i] * qd[i]), float(self.limit[i]), float(tau[i])
                    self.torque[i] = min(max(t, -lim + (d if d < 0.0 else 0.0)), lim + (d if d > 0.0 else 0.0))
            tau = self.torque
        if self.cfg.pd.servo:
            # servo joints: the target that gives this torque now, tau = gain (ctrl - q), and the
            # actuator keeps applying gain (ctrl - q), clamped to the limit, as q moves
            if self._all_servo:
                u = q + tau * self._inv_gain
            else:
                u = np.where(self.servo, q + tau * self._inv_gain, self.torque)
            self.ctrl[self._asel] = u
        else:
            self.ctrl[self._asel] = self.torque
        return self.ctrl

    def _gravity(self, data: mujoco.MjData, forces: dict[str, float]) -> FloatArray:
        """Feedforward torques: MuJoCo's bias forces hold each distal subtree against gravity (right for
        swinging limbs, the spine, arms); the legs in contact instead carry their share of the body
        weight, tau = -J^T f with f = share x weight up at the ankle (knee, ankle, toe only: the hips
        belong to the balance law)."""
        ff = data.qfrc_bias[self._dsel].copy()
        total = forces["left"] + forces["right"]
        for s in SIDES:
            share = forces[s] / total if total > 1e-6 else (1.0 if s == self.fsm.stance else 0.0)
            if share <= 0.0:
                continue
            body = self.foot_body[s]
            mujoco.mj_jac(self.model, data, self.jacp, None, data.xpos[body], body)
            # f = (0, 0, share W): J^T f is the Jacobian's vertical row times share W
            ff[self._leg_low[s]] = (-share * self.weight) * self.jacp[2, self._leg_dofs[s]]
        return ff

    def _balance(self, data: mujoco.MjData, q: FloatArray, qd: FloatArray, q_d: FloatArray, qd_d: FloatArray,
                 tau: FloatArray, forces: dict[str, float]) -> None:
        """The balance terms of one control step, in order: course steering, the torso law, swing-hip
        feedback (eq. 6), the feet's world targets, the hips' torque split (eq. 2-5), velocity tuning."""
        b, fsm = self.cfg.balance, self.fsm
        stance, swing = fsm.stance, fsm.swing
        r_p = data.xmat[self.pelvis].reshape(3, 3)
        pm = data.xmat[self.pelvis].tolist()
        mujoco.mj_subtreeVel(self.model, data)
        cx, cy, _ = data.subtree_com[self.pelvis].tolist()
        vx, vy, _ = data.subtree_linvel[self.pelvis].tolist()
        heading = math.atan2(pm[3], pm[0])
        c, s = math.cos(heading), math.sin(heading)
        if self._course_on:
            self._steer(cx, cy, vx, vy)
        ry = self._ry
        ry[0, 0], ry[0, 1], ry[1, 0], ry[1, 1] = c, -s, s, c
        tau_torso = self._torso_torque(r_p, pm, data.qvel[3:6].tolist(), c, s, self._torso_heading(data, forces))
        ax, ay, _ = data.xpos[self.foot_body[stance]].tolist()
        fs, fc, vh0, vh1 = self._feedback(cx - ax, cy - ay, vx, vy, c, s)
        if self._ik_on:
            fs += self._swing_foot_ik(data, q_d, tau)
        if b.swing_hip_world:
            tb = self._swing_hip(data, r_p, q, qd, q_d, qd_d, fs, fc)
        else:
            sl_b, idx_b = self._hip_fast[swing][:2]
            tb = tau[sl_b].tolist() if isinstance(sl_b, slice) else [float(tau[i]) for i in idx_b]
        if b.feet_world:
            self._feet_world(data, q, qd, q_d, qd_d, tau)
        self._hips(data, tau, tau_torso, tb, forces)
        if self._vel_on:  # last: the feet's world targets above set the ankle torques outright
            self._virtual_force(data, tau, forces, c, s, vh0)

    def _torso_heading(self, data: mujoco.MjData, forces: dict[str, float]) -> FloatArray:
        """The torso law's heading rotation: the heading target's (``_r_heading``), its yaw kept within
        ``balance.stance_yaw_limit`` of the loaded stance foot's yaw less the reference foot's own yaw
        from its pelvis (the pelvis's yaw over that foot as the reference has it)."""
        lim, stance = self._stance_yaw_limit, self.fsm.stance
        rh = self._r_heading
        if lim is None or forces[stance] <= 0.0:
            return rh
        f_ref = self.source.foot_target(self.frame, self.fsm.state, stance)
        if f_ref is None:
            return rh
        fm = data.xmat[self.foot_body[stance]]
        h = math.atan2(float(rh[1, 0]), float(rh[0, 0]))
        anchor = math.atan2(float(fm[3]), float(fm[0])) - math.atan2(float(f_ref[1, 0]), float(f_ref[0, 0]))
        h_t = yaw_within(h, anchor, lim)
        if h_t == h:
            return rh
        r, ch, sh = self._r_torso, math.cos(h_t), math.sin(h_t)
        r[0, 0], r[0, 1], r[1, 0], r[1, 1] = ch, -sh, sh, ch
        return r

    def _torso_torque(self, r_p: FloatArray, pm: list[float], omega_body: list[float], c: float, s: float,
                      r_heading: FloatArray | None = None) -> tuple[float, float, float]:
        """The torso law: world torque (N*m) turning the pelvis (rotation ``r_p``, ``pm`` its 9 entries
        row by row, angular velocity ``omega_body`` rad/s in its own frame) toward the reference's pitch
        and roll under the heading rotation ``r_heading`` (:meth:`_torso_heading`; None: the heading
        target's); PD per heading-frame axis (roll about forward x with
        ``roll_kp``, pitch about lateral y with ``torso_kp``, yaw with ``heading_kp``); ``c``, ``s``:
        cos and sin of the pelvis's heading. (ndarray.dot, not @: on 3x3s the matmul ufunc's dispatch
        costs twice the product.)"""
        b = self.cfg.balance
        if r_heading is None:
            r_heading = self._r_heading
        w0, w1, w2 = _rotvec3(r_heading.dot(self.source.pelvis_target(self.frame, self.fsm.state)).dot(r_p.T))
        e0, e1 = c * w0 + s * w1, -s * w0 + c * w1
        p00, p01, p02, p10, p11, p12, p20, p21, p22 = pm
        x, y, z = omega_body
        ow0, ow1, ow2 = p00 * x + p01 * y + p02 * z, p10 * x + p11 * y + p12 * z, p20 * x + p21 * y + p22 * z
        o0, o1 = c * ow0 + s * ow1, -s * ow0 + c * ow1
        h0 = self._roll_kp * e0 - b.torso_kd * o0
        h1 = b.torso_kp * e1 - b.torso_kd * o1
        return (c * h0 - s * h1, s * h0 + c * h1, b.heading_kp * w2 - b.torso_kd * ow2)

    def _feedback(self, dx: float, dy: float, vx: float, vy: float, c: float, s: float
                  ) -> tuple[float, float, float, float]:
        """Eq. 6's feedback angles (rad) c_d d + c_v v, sagittal and coronal, from the COM's offset
        (dx, dy) m from the stance ankle and velocity (vx, vy) m/s (world), measured against the walk's
        own as ``balance.relative`` says. Also returns the COM velocity in the heading frame (for
        velocity tuning)."""
        b, src, stance, frame = self.cfg.balance, self.source, self.fsm.stance, self.frame
        d0, d1 = c * dx + s * dy, -s * dx + c * dy
        v0, v1 = c * vx + s * vy, -s * vx + c * vy
        self._com_hf = (d0, d1, v0, v1)
        vh0, vh1 = v0, v1
        self._v_sag = v0
        if b.relative == "full":
            d_ref, v_ref = src.com_reference(frame, stance)
            d0, d1, v0, v1 = d0 - float(d_ref[0]), d1 - float(d_ref[1]), v0 - float(v_ref[0]), v1 - float(v_ref[1])
        elif b.relative == "mean_velocity":
            v0 -= self._speed
        elif b.relative == "lateral_reference":
            d1 -= src.lateral_reference(frame, stance)
            v0 -= self._speed
        if b.feedback:
            fs = feedback_angle(0.0, self._cd_sagittal, self._cv_sagittal, d0, v0, b.max_feedback)
            fc = feedback_angle(0.0, b.coronal.cd, b.coronal.cv, d1, v1, b.max_feedback)
        else:
            fs = fc = 0.0
        self.state.feedback_sagittal, self.state.feedback_coronal = fs, fc
        return fs, fc, vh0, vh1

    def _swing_hip(self, data: mujoco.MjData, r_p: FloatArray, q: FloatArray, qd: FloatArray, q_d: FloatArray,
                   qd_d: FloatArray, fs: float, fc: float) -> list[float]:
        """The swing hip's hinge torques (N*m) toward the world-frame thigh target turned by the
        feedback angles ``fs`` (sagittal) and ``fc`` (coronal) about the heading frame's axes."""
        src, swing, state, frame = self.source, self.fsm.swing, self.fsm.state, self.frame
        sl_b, idx_b, _jid_b, order_b, sign_b, dadr_b = self._hip_fast[swing]
        fade, kp, kd, tlo, thi = self.fade, self._kp_l, self._kd_l, self._tlo_l, self._thi_l
        ref_vel, implicit = self._ref_vel, self.implicit
        # r_fb = ry R_y(-fs) R_x(fc) ry^T (feedback about the heading frame's axes), so
        # pelvis^T r_fb ry thigh_ref = pelvis^T ry R_y(-fs) R_x(fc) thigh_ref
        cs, ss, cc, sc = math.cos(fs), math.sin(fs), math.cos(fc), math.sin(fc)
        r_fb = self._r_fb
        r_fb[0, 0], r_fb[0, 1], r_fb[0, 2] = cs, -ss * sc, -ss * cc
        r_fb[1, 1], r_fb[1, 2] = cc, -sc
        r_fb[2, 0], r_fb[2, 1], r_fb[2, 2] = ss, cs * sc, cs * cc
        ang = euler_from_matrix(r_p.T.dot(self._ry).dot(r_fb.dot(src.thigh_target(frame, state, swing))), order_b)
        # the world target sets where the thigh points; its twist about its own axis (the last
        # hinge, applied after flexion and abduction) stays the reference's: turning the leg
        # about itself does not place the foot, it only yaws the body
        i0, i1, i2 = idx_b
        v0 = min(max(ang[0] * sign_b[0], tlo[i0]), thi[i0])
        v1 = min(max(ang[1] * sign_b[1], tlo[i1]), thi[i1])
        q_d[i0], q_d[i1] = v0, v1
        qb = q[sl_b].tolist() if isinstance(sl_b, slice) else [float(q[i]) for i in idx_b]
        tb = [kp[i0] * (v0 - qb[0]), kp[i1] * (v1 - qb[1]), kp[i2] * (float(q_d[i2]) - qb[2])]
        if not implicit or ref_vel:
            for k, i in enumerate(idx_b):
                vel = (0.0 if implicit else float(qd[i])) - (float(qd_d[i]) if ref_vel else 0.0)
                tb[k] -= kd[i] * vel
        tb = [fade * x for x in tb]
        if self.cfg.pd.gravity_compensation:
            bias = data.qfrc_bias
            tb = [x + float(bias[d]) for x, d in zip(tb, dadr_b)]
        return tb

    def _swing_foot_ik(self, data: mujoco.MjData, q_d: FloatArray, tau: FloatArray) -> float:
        """Swing-foot height by two-link IK (``modulation.swing_foot``): the reference's hip-to-ankle
        vector raised by dz (see :class:`~bipedsim.control.config.SwingFootConfig`); the knee target
        (and its torque in ``tau``) changes by the knee angle that shortens the leg so, and the returned
        angle (rad, forward) turns the swing thigh's world target to keep the ankle on the raised point."""
        sf, src, swing, stance = self.cfg.modulation.swing_foot, self.source, self.fsm.swing, self.fsm.stance
        leg = src.swing_leg(self.frame, swing)
        ph = src.swing_phase(self.frame, swing)
        if leg is None or ph is None:
            return 0.0
        x, z, h_ref = leg
        zs = data.xpos[:, 2]
        h = min(float(zs[b]) for b in self._foot_pts[swing]) - min(float(zs[b]) for b in self._foot_pts[stance])
        ph = min(max(ph, 0.0), 1.0)
        err = h_ref - h
        if sf.deadband > 0.0:
            # only a foot lower than its reference by more than the band is raised (the lift phased in
            # over one more band), so a swing that clears the floor as its reference does is left alone
            w = min(max((err - sf.deadband) / sf.deadband, 0.0), 1.0)
            if w == 0.0:
                return 0.0
            err -= sf.deadband
            lift = w * sf.lift
        else:
            lift = sf.lift
        dz = min(max(sf.height_gain * err + lift * math.sin(math.pi * ph), -sf.max_drop), sf.max_raise)
        l1, l2 = self.leg_len[swing]
        k0, b0 = _two_link(l1, l2, math.hypot(x, z))
        k1, b1 = _two_link(l1, l2, math.hypot(x, z + dz))
        i = self.knee[swing]
        new = min(max(float(q_d[i]) + k1 - k0, self._tlo_l[i]), self._thi_l[i])
        tau[i] += self._akp[i] * (new - float(q_d[i]))
        q_d[i] = new
        return math.atan2(x, -(z + dz)) - math.atan2(x, -z) + b1 - b0

    def _feet_world(self, data: mujoco.MjData, q: FloatArray, qd: FloatArray, q_d: FloatArray, qd_d: FloatArray,
                    tau: FloatArray) -> None:
        """Ankle torques (into ``tau``) aiming each foot at the reference's heading-frame orientation."""
        src, state, frame, ry = self.source, self.fsm.state, self.frame, self._ry
        fade, kp, kd, tlo, thi = self.fade, self._kp_l, self._kd_l, self._tlo_l, self._thi_l
        ref_vel, implicit, grav = self._ref_vel, self.implicit, self.cfg.pd.gravity_compensation
        tilt = self._stance_tilt() if self._ankle_fb_on else None
        for side in SIDES:
            r_f = src.foot_target(frame, state, side)
            if r_f is None:
                continue
            if tilt is not None and side == self.fsm.stance:
                r_f = tilt.dot(r_f)
            idx, axes, basis = self._ankle_fast[side]
            local = data.xmat[self.shin_body[side]].reshape(3, 3).T.dot(ry.dot(r_f))
            ang = _hinge_angles_small(local, axes, basis)
            for k, i in enumerate(idx):
                v = min(max(ang[k], tlo[i]), thi[i])
                q_d[i] = v
                t_i = fade * kp[i] * (v - float(q[i]))
                if ref_vel or not implicit:
                    vel = (0.0 if implicit else float(qd[i])) - (float(qd_d[i]) if ref_vel else 0.0)
                    t_i -= fade * kd[i] * vel
                if grav:
                    t_i += float(self._ff[i])
                tau[i] = t_i

    def _stance_tilt(self) -> FloatArray:
        """Stance-ankle feedback (``modulation.stance_ankle``): the heading-frame rotation applied to
        the stance foot's target, toe down (COP forward) while the COM runs ahead of the reference's,
        the outer edge down while it runs outward."""
        sa = self.cfg.modulation.stance_ankle
        d0, d1, v0, v1 = self._com_hf
        d_ref, v_ref = self.source.com_reference(self.frame, self.fsm.stance)
        lim = sa.max_angle
        a = min(max(sa.kv * (v0 - float(v_ref[0])) + sa.kd * (d0 - float(d_ref[0])), -lim), lim)
        b = min(max(-(sa.kv * (v1 - float(v_ref[1])) + sa.kd * (d1 - float(d_ref[1]))), -lim), lim)
        return axis_rotation(np.array([0.0, 1.0, 0.0]), a).dot(axis_rotation(np.array([1.0, 0.0, 0.0]), b))

    def _hips(self, data: mujoco.MjData, tau: FloatArray, tau_torso: tuple[float, float, float], tb: list[float],
              forces: dict[str, float]) -> None:
        """Eq. 2-5: the swing hip keeps its world torque, the stance hip takes the torso's less the
        swing hip's, redistributed by the feet's loads; both written into ``tau`` as hinge torques."""
        stance, swing = self.fsm.stance, self.fsm.swing
        sl_b, jid_b = self._hip_fast[swing][0], self._hip_fast[swing][2]
        sl_a, jid_a = self._hip_fast[stance][0], self._hip_fast[stance][2]
        axes_b = data.xaxis[jid_b].tolist()
        t_b = hinges_to_world3(axes_b, tb)
        if t_b is None:
            t_b = tuple(hinges_to_world(np.array(axes_b), np.array(tb)).tolist())
        gamma = stance_share(forces[stance], forces[swing])
        t_a, t_b_total = hip_torques3(tau_torso, t_b, gamma, self.cfg.balance.redistribution)
        tau[sl_a] = world_to_hinges3(data.xaxis[jid_a].tolist(), t_a)
        tau[sl_b] = world_to_hinges3(axes_b, t_b_total)
        self.state.gamma = gamma
        self.state.tau_torso = tau_torso

    def _steer(self, cx: float, cy: float, vx: float, vy: float) -> None:
        """Course control (``balance.course``): the COM at (cx, cy) m moving at (vx, vy) m/s (world) is
        placed on the reference's course; the torso law's heading target becomes the course's heading
        turned back toward it, ``h_ref + clamp(-k_y e - k_v e_dot, +-max_turn)``."""
        band, tau, ky, kv, max_turn = self._course_gains
        offset, rate, h_ref = self.course.update(cx, cy, vx, vy)
        self.state.course_offset = offset
        # the rate is low-passed: the walk's own sway swings it by about 0.1 m/s within every cycle
        a = self._dt / tau
        self._rate_f += (a if a < 1.0 else 1.0) * (rate - self._rate_f)
        # inside the band the law is silent (damping included): the balance law keeps the walk's sway
        offset = beyond(offset, band)
        rate = self._rate_f if offset != 0.0 else 0.0
        h_t = h_ref + course_turn(offset, rate, ky, kv, max_turn)
        self.heading_target = self.state.heading_target = h_t
        rh, ch, sh = self._r_heading, math.cos(h_t), math.sin(h_t)
        rh[0, 0], rh[0, 1], rh[1, 0], rh[1, 1] = ch, -sh, sh, ch

    def _virtual_force(self, data: mujoco.MjData, tau: FloatArray, forces: dict[str, float], c: float, s: float,
                       v0: float) -> None:
        """Velocity tuning: a virtual force F = kv (v_target - v) (heading frame, clipped to ``max_force``)
        on the centre of mass, produced by the loaded legs with the foot as the chain's fixed end: each
        knee and ankle hinge adds -share a . ((com - anchor) x F) (Jacobian transpose of the reversed
        chain; a joint's torque acts on its parent, the side toward the body, with the opposite sign)."""
        vc = self.cfg.balance.velocity
        if vc.filter_s > 0.0:
            self._vf_v += (v0 - self._vf_v) * min(1.0, self._dt / vc.filter_s)
            v0 = self._vf_v
        f0 = self._kv_sag * (self._speed - v0)
        if abs(f0) > vc.max_force:
            f0 = f0 * vc.max_force / abs(f0)
        fx, fy = c * f0, s * f0
        self.state.virtual_force = (f0, 0.0)
        total = forces["left"] + forces["right"]
        if total <= 1e-6:
            return
        cx, cy, cz = data.subtree_com[self.pelvis].tolist()
        for side in SIDES:
            share = forces[side] / total
            if share <= 0.0:
                continue
            for i, j in self._vf_joints[side]:
                ax, ay, az = data.xaxis[j].tolist()
                px, py, pz = data.xanchor[j].tolist()
                rx, ry, rz = cx - px, cy - py, cz - pz
                # r x F with F = (fx, fy, 0): (-rz fy, rz fx, rx fy - ry fx)
                tau[i] -= share * (ax * (-rz * fy) + ay * (rz * fx) + az * (rx * fy - ry * fx))


#: Actuator fields the controller changes while it runs (and restores after).
_ACTUATOR_FIELDS = ("actuator_ctrlrange", "actuator_gaintype", "actuator_biastype", "actuator_gainprm",
                    "actuator_biasprm", "actuator_ctrllimited", "actuator_forcelimited", "actuator_forcerange")


def leg_length(model: mujoco.MjModel) -> float:
    """A humanoid's leg length (m): hip to knee plus knee to ankle, the two legs' mean."""
    return sum(float(np.linalg.norm(model.body_pos[model.body(f"{s}_shin").id]))
               + float(np.linalg.norm(model.body_pos[model.body(f"{s}_foot").id])) for s in SIDES) / 2


def body_mass(model: mujoco.MjModel) -> float:
    """A body's total mass (kg)."""
    return float(np.sum(model.body_mass[1:]))


def _hinge_angles_small(local: FloatArray, axes: list[tuple[float, float, float]],
                        basis: FloatArray | None = None) -> tuple[float, ...]:
    """Angles of 1 or 2 hinges (unit axes, applied in order) best reproducing a local rotation matrix.
    Two hinges off x, y and z (a flexion axis along a bone's) take their ``basis``
    (:func:`bipedsim.model.retarget.hinge_basis`: the first axis, the second, their cross product)."""
    if len(axes) == 1:
        x, y, z = axes[0]
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = local.ravel().tolist()
        # twist of the rotation about the axis (swing-twist): sin from the skew part along the axis,
        # cos from the trace less the axis's own component (2 cos(theta) restricted to the plane)
        aw = x * (m21 - m12) + y * (m02 - m20) + z * (m10 - m01)
        ama = x * (m00 * x + m01 * y + m02 * z) + y * (m10 * x + m11 * y + m12 * z) + z * (m20 * x + m21 * y + m22 * z)
        return (math.atan2(aw, m00 + m11 + m22 - ama),)
    if basis is not None:  # the rotation in the hinges' own basis: about its x, then its y
        a, b, _ = euler_from_matrix(basis.T.dot(local).dot(basis), (0, 1, 2))
        return a, b
    order = tuple(int(np.argmax(np.abs(x))) for x in axes)
    signs = [1.0 if x[k] > 0 else -1.0 for x, k in zip(axes, order)]
    third = next(k for k in range(3) if k not in order)
    ang = euler_from_matrix(local, (order[0], order[1], third))
    return ang[0] * signs[0], ang[1] * signs[1]


def _two_link(l1: float, l2: float, reach: float) -> tuple[float, float]:
    """A two-link leg (thigh ``l1``, shin ``l2``, m) reaching ``reach`` m from hip to ankle: the knee's
    flexion and the thigh's angle ahead of the hip-ankle line (rad), the reach clamped to what the
    links can span."""
    r = min(max(reach, abs(l1 - l2) + 1e-3), 0.9999 * (l1 + l2))
    knee = math.pi - math.acos(min(max((l1 * l1 + l2 * l2 - r * r) / (2 * l1 * l2), -1.0), 1.0))
    thigh = math.acos(min(max((l1 * l1 + r * r - l2 * l2) / (2 * l1 * r), -1.0), 1.0))
    return knee, thigh


def _has_sensor(model: mujoco.MjModel, name: str) -> bool:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name) >= 0


def _rotvec3(e: FloatArray) -> tuple[float, float, float]:
    """Rotation vector (rad) of a rotation matrix, as three floats."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = e.ravel().tolist()
    cos = min(max((m00 + m11 + m22 - 1.0) * 0.5, -1.0), 1.0)
    ang = math.acos(cos)
    s = math.sin(ang)
    k = 0.5 if s < 1e-6 else ang / (2.0 * s)
    return (m21 - m12) * k, (m02 - m20) * k, (m10 - m01) * k


def _as_slice(idx: npt.NDArray[np.int64]) -> slice | npt.NDArray[np.int64]:
    """A slice for contiguous ascending indices (a view, no gather), else the indices."""
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


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
    return PoseSource(cfg.pose_gait, h) if cfg.source == "pose" else ClipSource(clip, model, plan, h)
