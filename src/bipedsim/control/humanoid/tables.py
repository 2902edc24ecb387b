"""The humanoid controller's constant tables, built once per controller into one frozen object.

:func:`build_tables` reads a model, its body plan, a gait source and a controller config (already scaled
to the body) and fixes everything the control step looks up: per-hinge gains, torque limits and target
ranges, the hips' and ankles' hinges, the legs' lengths, the feet's bodies and touch sensors, and the
switches and gains the config implies. Indices are into the model's hinge list
(:class:`~bipedsim.control.humanoid.sources.Hinges`); where the hinges a step reads are contiguous they are
slices (a view, no gather). The gains and target ranges are held as arrays for the whole-body vector
maths and as plain-float lists for the few hinges the balance laws read one at a time (a numpy element
costs more to read than the arithmetic on it).

Units: gains kp N*m/rad, kd N*m*s/rad; torques N*m; angles rad; lengths m; forces N.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import sagittal_cd
from bipedsim.control.humanoid.settings import DEFAULT_GAINS
from bipedsim.control.humanoid.sources import SIDES, GaitSource, Hinges, foot_points
from bipedsim.control.settings import ControllerConfig
from bipedsim.errors import ConfigError
from bipedsim.model.plan import BodyPlanSet, JointPlan
from bipedsim.reference.retarget import hinge_basis

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
Selection = slice | IntArray
#: the hinges below the hip that carry a loaded leg's share of the body weight (name after the side)
LOWER_LEG = ("knee", "ankle", "ankle_y", "ankle_x", "toe")


@dataclass(frozen=True)
class HipTable:
    """One hip's three hinges (flexion, abduction, twist), as the swing-hip law reads them."""

    idx: IntArray  #: hinge indices
    sel: Selection  #: the same, as a slice where contiguous
    idx_l: list[int]  #: the same, as plain ints
    jid: IntArray  #: MuJoCo joint ids (for the hinges' world axes)
    jid_sel: Selection  #: the same, as a slice where contiguous
    order: tuple[int, int, int]  #: the Euler order of the hinges' axes (0 x, 1 y, 2 z)
    signs: list[float]  #: each axis's sign along its Euler axis
    dadr: list[int]  #: dof addresses


@dataclass(frozen=True)
class AnkleTable:
    """One ankle's one or two hinges."""

    idx: list[int]  #: hinge indices
    axes: list[tuple[float, float, float]]  #: unit hinge axes in the shin's frame
    #: two hinges off x, y and z: their basis (:func:`~bipedsim.reference.retarget.hinge_basis`)
    basis: FloatArray | None


@dataclass(frozen=True)
class HumanoidTables:
    """What the humanoid's control step looks up: fixed by the model, the plan, the source and the config."""

    # ---- every hinge
    kp: FloatArray  #: N*m/rad per hinge
    kd: FloatArray  #: N*m*s/rad per hinge
    limit: FloatArray  #: torque limit (N*m) per hinge
    neg_limit: FloatArray  #: -limit
    tlo: FloatArray  #: lowest target (rad) per hinge
    thi: FloatArray  #: highest target (rad) per hinge
    kp_l: list[float]  #: kp as plain floats
    kd_l: list[float]  #: kd as plain floats
    tlo_l: list[float]  #: tlo as plain floats
    thi_l: list[float]  #: thi as plain floats
    qsel: Selection  #: the hinges' qpos addresses
    dsel: Selection  #: the hinges' dof addresses
    asel: Selection  #: the hinges' actuators
    servo: npt.NDArray[np.bool_]  #: per hinge: driven by a position servo (``pd.servo`` and kp > 0)
    all_servo: bool  #: every hinge is
    # ---- legs and feet, per side
    hip: dict[str, HipTable]
    ankle: dict[str, AnkleTable]
    knee: dict[str, int]  #: the knee's hinge index
    leg_len: dict[str, tuple[float, float]]  #: thigh and shin lengths (m), for the swing foot's IK
    foot_pts: dict[str, list[int]]  #: the bodies standing for a foot's lowest point
    shin_body: dict[str, int]
    foot_body: dict[str, int]
    leg_low: dict[str, IntArray]  #: the hinges below the hip (:data:`LOWER_LEG`)
    leg_low_sel: dict[str, Selection]  #: the same, as a slice where contiguous
    leg_dofs: dict[str, Selection]  #: their dof addresses
    vf_joints: dict[str, list[tuple[int, int]]]  #: (hinge index, joint id) of the knee and ankle hinges
    touch: dict[str, list[int]]  #: sensordata addresses of the sole's touch sensors (foot, toe)
    touch_idx: IntArray  #: the right foot's, then the left's
    n_touch_right: int  #: how many of ``touch_idx`` are the right foot's
    pelvis: int  #: the pelvis's body id
    weight: float  #: the body's weight (N)
    omega: float  #: the linear inverted pendulum's sqrt(g / L) (1/s), L the body's leg length (hip to ankle)
    # ---- switches and gains of the step
    implicit: bool  #: kd is MuJoCo joint damping (``pd.implicit_damping``)
    ref_vel: bool  #: damping against the reference's velocity (``pd.mode: pd_ref_velocity``)
    net_limit: bool  #: some hinges' limits bound actuator and damping together (``pd.net_limit``)
    net_joints: dict[str, list[int]] | None  #: those hinges per swing side (None: every hinge)
    speed: float  #: the source's mean walking speed (m/s; 0 for key poses)
    cd_sagittal: float  #: the sagittal c_d (rad/m) scheduled by the walk's Froude number
    kv_sagittal: float  #: velocity tuning's gain (N per m/s; 0 without a walking speed)
    velocity_on: bool  #: velocity tuning acts
    roll_kp: float  #: the torso law's roll stiffness (N*m/rad)
    course_on: bool  #: course control steers the heading target
    ik_on: bool  #: swing-foot height by leg IK (``modulation.swing_foot``)
    ankle_feedback_on: bool  #: stance-ankle feedback (``modulation.stance_ankle``)


def build_tables(model: mujoco.MjModel, plan: BodyPlanSet, source: GaitSource, cfg: ControllerConfig,
                 hinges: Hinges, leg: float) -> HumanoidTables:
    """The tables of a controller driving ``model`` (built from ``plan``) along ``source`` with ``cfg``
    (already scaled to the body); ``leg``: the body's leg length (m, hip to ankle)."""
    jplan = {j.name: j for b in plan.bodies for j in b.joints}
    kp, kd, limit = _gains(model, cfg, hinges, jplan)
    tlo, thi = _target_ranges(model, cfg, hinges)
    hip = {s: _hip(s, hinges, jplan) for s in SIDES}
    knee = {s: hinges.index(f"{s}_knee") for s in SIDES}
    leg_low = {s: np.array([i for i, n in enumerate(hinges.names)
                            if n.startswith(f"{s}_") and n.split("_", 1)[1] in LOWER_LEG]) for s in SIDES}
    touch = {s: [model.sensor_adr[model.sensor(f"touch_{b}_touch").id]
                 for b in (f"{s}_foot", f"{s}_toe") if _has_sensor(model, f"touch_{b}_touch")] for s in SIDES}
    servo = cfg.pd.servo & (kp > 0)
    speed = float(source.speed())
    kv_sagittal = cfg.balance.velocity.kv_sagittal if speed > 0.0 else 0.0
    shin_body = {s: model.body(f"{s}_shin").id for s in SIDES}
    foot_body = {s: model.body(f"{s}_foot").id for s in SIDES}
    b = cfg.balance
    for a in (kp, kd, limit, tlo, thi, servo):
        a.setflags(write=False)
    return HumanoidTables(
        kp=kp, kd=kd, limit=limit, neg_limit=-limit, tlo=tlo, thi=thi, kp_l=kp.tolist(), kd_l=kd.tolist(),
        tlo_l=tlo.tolist(), thi_l=thi.tolist(), qsel=as_slice(hinges.qadr), dsel=as_slice(hinges.dadr),
        asel=as_slice(hinges.actuator), servo=servo, all_servo=bool(np.all(servo)),
        hip=hip, ankle={s: _ankle(s, hinges, jplan) for s in SIDES}, knee=knee,
        leg_len={s: (float(np.linalg.norm(model.body_pos[shin_body[s]])),
                     float(np.linalg.norm(model.body_pos[foot_body[s]]))) for s in SIDES},
        foot_pts={s: foot_points(model, s) for s in SIDES}, shin_body=shin_body, foot_body=foot_body,
        leg_low=leg_low, leg_low_sel={s: as_slice(leg_low[s]) for s in SIDES},
        leg_dofs={s: as_slice(hinges.dadr[leg_low[s]]) for s in SIDES},
        vf_joints={s: [(int(i), int(hinges.jid[i])) for i in leg_low[s] if not hinges.names[i].endswith("toe")]
                   for s in SIDES},
        touch=touch, touch_idx=np.array(touch["right"] + touch["left"], dtype=np.int64),
        n_touch_right=len(touch["right"]), pelvis=model.body("pelvis").id,
        weight=float(np.sum(model.body_mass) * -model.opt.gravity[2]),
        omega=math.sqrt(-float(model.opt.gravity[2]) / leg) if leg > 0 else 0.0,
        implicit=cfg.pd.implicit_damping, ref_vel=cfg.pd.mode == "pd_ref_velocity",
        net_limit=cfg.pd.net_limit != "off" and cfg.pd.implicit_damping,
        net_joints=_net_joints(cfg.pd.net_limit, hip, knee), speed=speed,
        cd_sagittal=sagittal_cd(b, speed, leg, -float(model.opt.gravity[2])), kv_sagittal=kv_sagittal,
        velocity_on=b.enabled and kv_sagittal > 0, roll_kp=b.torso_kp if b.roll_kp is None else b.roll_kp,
        course_on=b.enabled and b.course.enabled,
        # "auto" is resolved for the reference when a scenario is loaded (control.settings.for_reference);
        # left unresolved, it is off
        ik_on=cfg.modulation.swing_foot.enabled is True and source.swing_leg(source.loop_start, "left") is not None,
        ankle_feedback_on=cfg.modulation.stance_ankle.enabled is True)


def _gains(model: mujoco.MjModel, cfg: ControllerConfig, hinges: Hinges, jplan: dict[str, JointPlan]
           ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """kp, kd (N*m/rad, N*m*s/rad) and torque limits (N*m) per hinge: the joint's own entry in
    ``pd.joint_gains``, else its group's in ``pd.gains`` (or :data:`DEFAULT_GAINS`, for a config built in
    Python without it), else the joint plan's."""
    n = len(hinges.names)
    kp, kd = np.zeros(n), np.zeros(n)
    # the model's limits are the profile's, for any body: scaled to this one (``body.torque_scale``)
    limit = np.abs(model.actuator_ctrlrange[hinges.actuator, 1]) * cfg.body.torque_scale
    for i, name in enumerate(hinges.names):
        g = cfg.pd.gains.get(hinges.groups[i]) or DEFAULT_GAINS.get(hinges.groups[i])
        k_p, k_d = (g.kp, g.kd) if g else (jplan[name].kp, jplan[name].kd)
        lim = g.torque_limit if g and g.torque_limit else None
        jg = cfg.pd.joint_gains.get(name)
        if jg:
            k_p, k_d = jg.kp, jg.kd
            lim = jg.torque_limit or lim
        kp[i], kd[i] = k_p, k_d
        if lim:
            limit[i] = lim
    unknown = [j for j in (*cfg.pd.joint_gains, *cfg.pd.target_limits) if j not in hinges.names]
    if unknown:
        raise ConfigError(f"names joint {unknown[0]!r}, which the model does not have; hinges are "
                          f"{', '.join(hinges.names)}", key="pd.joint_gains")
    return kp, kd, limit


def _target_ranges(model: mujoco.MjModel, cfg: ControllerConfig, hinges: Hinges) -> tuple[FloatArray, FloatArray]:
    """Per hinge, the range (rad) its target is clipped to: the joint's own (a retargeted clip may reach
    past it), or ``pd.target_limits``."""
    tlo = model.jnt_range[hinges.jid, 0].copy()
    thi = model.jnt_range[hinges.jid, 1].copy()
    for j, (lo, hi) in cfg.pd.target_limits.items():
        tlo[hinges.index(j)], thi[hinges.index(j)] = lo, hi
    return tlo, thi


def _hip(side: str, hinges: Hinges, jplan: dict[str, JointPlan]) -> HipTable:
    names = [f"{side}_hip_y", f"{side}_hip_x", f"{side}_hip_z"]
    idx = np.array([hinges.index(x) for x in names])
    axes = [np.asarray(jplan[x].axis) for x in names]
    order = tuple(int(np.argmax(np.abs(a))) for a in axes)
    signs = np.array([np.sign(a[k]) for a, k in zip(axes, order)])
    jid = hinges.jid[idx]
    return HipTable(idx=idx, sel=as_slice(idx), idx_l=idx.tolist(), jid=jid, jid_sel=as_slice(jid),
                    order=order, signs=signs.tolist(), dadr=hinges.dadr[idx].tolist())  # type: ignore[arg-type]


def _ankle(side: str, hinges: Hinges, jplan: dict[str, JointPlan]) -> AnkleTable:
    names = [x for x in (f"{side}_ankle", f"{side}_ankle_y", f"{side}_ankle_x") if x in hinges.names]
    axes = [np.asarray(jplan[x].axis) for x in names]
    return AnkleTable(idx=[hinges.index(x) for x in names],
                      axes=[tuple((a / np.linalg.norm(a)).tolist()) for a in axes],  # type: ignore[misc]
                      basis=None if len(axes) < 2 else hinge_basis(axes)[2])


def _net_joints(net_limit: str, hip: dict[str, HipTable], knee: dict[str, int]) -> dict[str, list[int]] | None:
    """The hinges whose limits bound actuator and damping together, per swing side: the swing hip's
    (``swing_hip``), with the swing knee (``swing``); None: every hinge (``all``, or no net limit)."""
    if net_limit == "swing_hip":
        return {s: list(hip[s].idx_l) for s in SIDES}
    if net_limit == "swing":
        return {s: [*hip[s].idx_l, int(knee[s])] for s in SIDES}
    return None


def as_slice(idx: IntArray) -> Selection:
    """A slice for contiguous ascending indices (a view, no gather), else the indices."""
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


def _has_sensor(model: mujoco.MjModel, name: str) -> bool:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name) >= 0
