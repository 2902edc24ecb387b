"""PD tracking of the humanoid's hinges (eq. 1), its gravity feedforward, torque limits and actuation.

Torques are N*m per hinge, in the order of :class:`~bipedsim.control.humanoid.sources.Hinges`. The kp
(theta_d - theta) term runs in MuJoCo's position servos (``pd.servo``): each control step sets the servo
target u = theta + tau / kp that gives the controller's torque tau now, and the servo keeps acting as a
spring between control steps. With implicit damping (``pd.implicit_damping``) the -kd theta_dot term is
MuJoCo joint damping. :class:`Drive` owns what the controller changes in the model to do this, and puts
it back.
"""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.settings import FadeConfig
from bipedsim.control.humanoid.sources import SIDES
from bipedsim.control.humanoid.tables import HumanoidTables
from bipedsim.control.settings import ControllerConfig

FloatArray = npt.NDArray[np.float64]
#: With ``pd.net_limit``: the joint speed (rad/s) up to which a servo's force range leaves room for the
#: damping's share beside the torque limit.
NET_LIMIT_SPEED = 20.0
#: Actuator fields the controller changes while it runs (and restores after).
ACTUATOR_FIELDS = ("actuator_ctrlrange", "actuator_gaintype", "actuator_biastype", "actuator_gainprm",
                   "actuator_biasprm", "actuator_ctrllimited", "actuator_forcelimited", "actuator_forcerange")


class Drive:
    """The hinges' actuators and damping as the controller sets them, at the gains scaled by the fade.

    Constructing one leaves the model as it was (several controllers may be made for one model);
    :meth:`configure` and :meth:`scale_gains` change it, :meth:`restore` puts it back."""

    def __init__(self, model: mujoco.MjModel, tables: HumanoidTables, actuators: npt.NDArray[np.int64],
                 dofs: npt.NDArray[np.int64], cfg: ControllerConfig) -> None:
        self.model, self.t, self.acts, self.dofs = model, tables, actuators, dofs
        self.servo_on = cfg.pd.servo
        self.base_damping = model.dof_damping.copy()
        self.saved = {k: getattr(model, k).copy() for k in ACTUATOR_FIELDS}
        self.servo_gain = np.ones(len(tables.kp))
        #: kp and kd (N*m/rad, N*m*s/rad) scaled by the fade now, and 1 / the servo gain (0: a motor)
        self.akp, self.akd, self.inv_gain = tables.kp, tables.kd, np.zeros(len(tables.kp))

    def configure(self) -> None:
        """Put the controller's actuator settings into the model: servos (or motors) whose force range is
        the torque limit, with room for the damping's share on the net-limited hinges."""
        model, acts, t = self.model, self.acts, self.t
        # the net-limited hinges: the controller clamps their torques (see limit_torques), and the
        # actuator's own range leaves room for the damping's share at up to NET_LIMIT_SPEED rad/s
        room = np.zeros(len(t.limit))
        if t.net_limit:
            net = range(len(room)) if t.net_joints is None else [i for js in t.net_joints.values() for i in js]
            for i in net:
                room[i] = t.kd[i] * NET_LIMIT_SPEED
        if self.servo_on:
            # force = gain ctrl - gain q for servo joints (ctrl is a target angle), = ctrl for motors;
            # the torque limit clamps the actuator force on every physics step
            model.actuator_gaintype[acts] = mujoco.mjtGain.mjGAIN_FIXED
            model.actuator_biastype[acts] = mujoco.mjtBias.mjBIAS_AFFINE
            model.actuator_biasprm[acts] = 0.0
            model.actuator_ctrllimited[acts] = 0
            model.actuator_forcelimited[acts] = 1
            model.actuator_forcerange[acts, 0] = -t.limit - room
            model.actuator_forcerange[acts, 1] = t.limit + room
        else:
            model.actuator_ctrlrange[acts, 0] = -t.limit - room
            model.actuator_ctrlrange[acts, 1] = t.limit + room

    def scale_gains(self, scale: float) -> None:
        """The gains times ``scale`` (the fade factor): MuJoCo joint damping (implicit kd) and servo stiffness."""
        t = self.t
        d = self.base_damping.copy()
        if t.implicit:
            d[self.dofs] += scale * t.kd
        self.model.dof_damping[:] = d
        if self.servo_on:
            self.servo_gain = np.where(t.servo, max(scale, 1e-6) * t.kp, 1.0)
            self.model.actuator_gainprm[self.acts, 0] = self.servo_gain
            self.model.actuator_biasprm[self.acts, 1] = np.where(t.servo, -self.servo_gain, 0.0)
        self.akp, self.akd = scale * t.kp, scale * t.kd
        self.inv_gain = np.where(t.servo, 1.0 / self.servo_gain, 0.0)

    def restore(self) -> None:
        """Undo the damping, gains and torque ranges put into the model."""
        self.model.dof_damping[:] = self.base_damping
        for k, v in self.saved.items():
            getattr(self.model, k)[:] = v


def pd_torques(drive: Drive, q_d: FloatArray, q: FloatArray, qd: FloatArray, qd_d: FloatArray) -> FloatArray:
    """Eq. 1 per hinge (N*m): kp (theta_d - theta) - kd theta_dot, or - kd (theta_dot - theta_dot_d) with
    ``pd_ref_velocity``; with implicit damping the -kd theta_dot part is left to MuJoCo."""
    if drive.t.implicit:
        # the -kd qdot part is MuJoCo joint damping (implicit); only the rest is computed here
        tau = drive.akp * (q_d - q)
        if drive.t.ref_vel:
            tau += drive.akd * qd_d
        return tau
    return drive.akp * (q_d - q) - drive.akd * (qd - qd_d if drive.t.ref_vel else qd)


def gravity_feedforward(t: HumanoidTables, model: mujoco.MjModel, data: mujoco.MjData, jacp: FloatArray,
                        forces: dict[str, float], stance: str) -> FloatArray:
    """Feedforward torques (N*m): MuJoCo's bias forces hold each distal subtree against gravity (right for
    swinging limbs, the spine, arms); the legs in contact instead carry their share of the body weight,
    tau = -J^T f with f = share x weight up at the ankle (knee, ankle, toe only: the hips belong to the
    balance law). ``forces``: each foot's vertical contact force (N); ``jacp``: a 3 x nv scratch."""
    ff = data.qfrc_bias[t.dsel].copy()
    total = forces["left"] + forces["right"]
    for s in SIDES:
        share = forces[s] / total if total > 1e-6 else (1.0 if s == stance else 0.0)
        if share <= 0.0:
            continue
        body = t.foot_body[s]
        mujoco.mj_jac(model, data, jacp, None, data.xpos[body], body)
        # f = (0, 0, share W): J^T f is the Jacobian's vertical row times share W
        ff[t.leg_low_sel[s]] = (-share * t.weight) * jacp[2, t.leg_dofs[s]]
    return ff


def limit_torques(drive: Drive, tau: FloatArray, qd: FloatArray, swing: str) -> FloatArray:
    """``tau`` clipped to the torque limits; on the net-limited hinges (``pd.net_limit``) the limit bounds
    actuator and damping together while the joint is driven the way it moves."""
    t = drive.t
    torque = np.minimum(np.maximum(tau, t.neg_limit), t.limit)
    if not t.net_limit:
        return torque
    if t.net_joints is None:
        damp = drive.akd * qd
        return np.minimum(np.maximum(tau, t.neg_limit + np.minimum(damp, 0.0)), t.limit + np.maximum(damp, 0.0))
    for i in t.net_joints[swing]:
        d, lim, x = float(drive.akd[i] * qd[i]), float(t.limit[i]), float(tau[i])
        torque[i] = min(max(x, -lim + (d if d < 0.0 else 0.0)), lim + (d if d > 0.0 else 0.0))
    return torque


def set_controls(drive: Drive, ctrl: FloatArray, q: FloatArray, tau: FloatArray, torque: FloatArray) -> None:
    """Write the actuators' controls into ``ctrl``: for a servo the target that gives the torque ``tau`` now
    (tau = gain (ctrl - q); the actuator keeps applying gain (ctrl - q), clamped to the limit, as q moves),
    for a motor the clipped ``torque``."""
    t = drive.t
    if not drive.servo_on:
        ctrl[t.asel] = torque
    elif t.all_servo:
        ctrl[t.asel] = q + tau * drive.inv_gain
    else:
        ctrl[t.asel] = np.where(t.servo, q + tau * drive.inv_gain, torque)


def fade_scale(f: FadeConfig, force_active: bool, force_ended_at: float | None, t: float) -> float:
    """The tracking gains' factor at time ``t`` (sec. 4.4): ``min_scale`` while a push acts, back to 1
    linearly over ``fade_in`` s after it ends; 1 without ``fade.enabled``."""
    if not f.enabled:
        return 1.0
    if force_active:
        return f.min_scale
    if force_ended_at is not None:
        u = (t - force_ended_at) / f.fade_in
        return 1.0 if u >= 1.0 else f.min_scale + (1.0 - f.min_scale) * u
    return 1.0
