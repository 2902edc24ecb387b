"""A feasible lower-body reference built from a real walk: what the controller is asked to
track made physically possible for the built body.

A capture's legs cannot be replayed as they are by a box-footed body: its stance feet roll from heel
to toe, float or sink by centimetres and slide; its stance knees straighten to the singularity; its
swing toes drag (docs/controller.md, *Feasible reference*). From the clip's own gait events (the
contacts :mod:`bipedsim.reference.gait_events` measured) and footprints, every frame gets:

- **stance feet** planted at the clip's footprint: per stance, the ankle's median position and the
  foot's median heading over the stance's flattest frames (the sole's tilt in its lowest third), where
  the sole lies level on z = 0; where the clip's sole pitches more than :data:`FLAT_BAND`, the foot
  rolls by the excess over its heel edge (toes up) or its ball (heel up: the toe joint, the toe box
  kept level), that pivot held in place -- no sliding, float or sink;
- **swing feet** on the clip's path, moved smoothly (smoothstep over the swing) from the footprint
  they leave to the one they reach, the heading turned from one footprint's to the next, the clip's
  pitch, the box's lowest corner at least ``clearance`` x the leg length x sin(pi u) above the floor
  (u: the swing's progress) and never lower than the clip's own foot;
- **the pelvis** where the clip has it (or, with ``pendulum`` > 0, moved so its centre of mass moves
  as a linear inverted pendulum over the stance feet, :func:`pendulum_shift`), lowered wherever a leg
  would be straighter than ``max_extension`` of its length (hip joint to ankle over thigh + shin), the
  lowering spread over ``smooth_s`` so it does not jerk;
- **leg hinges** by inverse kinematics on the built MuJoCo body: per leg and frame a projected
  Levenberg-Marquardt on the foot's position and sole orientation (and the toe's, when the body has
  one), within the joints' ranges, warm-started from the previous frame, lightly pulled toward the
  clip's own angles (the redundancy a 3-DOF hip leaves);

and the upper body stays the clip's. ``blend`` mixes the clip's legs (0) and the feasible ones (1).
Step timing, lengths, widths and turns are the clip's, so its speed is too.

The steps: :mod:`~bipedsim.reference.feasible_legs` (the legs on the body and their kinematics),
:mod:`~bipedsim.reference.feasible_feet` (footprints and swing paths), :mod:`~bipedsim.reference.feasible_pelvis`
(pendulum shift, pelvis lowering), :mod:`~bipedsim.reference.feasible_ik` (leg IK); how feasible a clip is:
:mod:`~bipedsim.reference.feasible_measure`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.reference.clip import ReferenceClip
from bipedsim.reference.feasible_feet import plan_feet
from bipedsim.reference.feasible_ik import solve_reaching
from bipedsim.reference.feasible_legs import SIDES, _com_path, _kinematics, _Leg
from bipedsim.reference.feasible_pelvis import pelvis_drop, pendulum_shift
from bipedsim.reference.retarget import velocities

FloatArray = npt.NDArray[np.float64]


#: Longest spread (s) of the pelvis lowering: past a few strides it is the whole clip's mean, and the
#: window is counted in frames (1e300 s overflowed).
MAX_SMOOTH_S = 10.0
#: Largest weight of the pendulum term: far past the point where the least squares follow the pendulum's
#: ZMP alone (1e4 and 1e6 walk the built-in walk alike); 1e300 overflowed the solve.
MAX_PENDULUM_WEIGHT = 1e6


@dataclass(frozen=True)
class FeasibleConfig:
    """The controller YAML's ``reference:`` block: whether a real clip's legs are made feasible for the
    built body before tracking (:func:`feasible_clip`), and how."""

    #: build the feasible lower-body reference (stance feet planted flat, swing clearance, pelvis
    #: lowered off a straight knee, legs by IK on the body): true, false, or "auto" -- every capture,
    #: and a clip generated for the body (the built-in walk) only where its legs measure infeasible
    #: (:func:`resolve_because`, :func:`infeasible_because`: hinges out of range, a leg straighter than
    #: ``max_extension``, stance feet floating)
    feasible: bool | Literal["auto"] = "auto"
    #: 0: the clip's legs, 1: the feasible ones (hinge angles and pelvis height mixed linearly)
    blend: float = field(default=1.0, metadata={"min": 0.0, "max": 1.0})
    #: longest leg (hip joint to ankle) as a fraction of thigh + shin (gaitgen's 0.985)
    max_extension: float = field(default=0.985, metadata={"gt": 0.5, "max": 1.0})
    #: the swing sole's least peak height above the floor as a fraction of the leg length
    clearance: float = field(default=0.11, metadata={"min": 0.0, "max": 0.5})
    #: seconds over which the pelvis lowering is spread
    smooth_s: float = field(default=0.15, metadata={"min": 0.0, "max": MAX_SMOOTH_S})
    #: weight of the linear inverted pendulum on the pelvis's horizontal path (0: the clip's path): the
    #: centre of mass moved so that its pendulum ZMP, c - c''/w^2, stays near the stance feet's centre of
    #: pressure (least squares against staying on the clip's path)
    pendulum: float = field(default=0.0, metadata={"min": 0.0, "max": MAX_PENDULUM_WEIGHT})


def feasible_clip(clip: ReferenceClip, model: mujoco.MjModel, cfg: FeasibleConfig | None = None) -> ReferenceClip:
    """The clip with its lower body made feasible for ``model`` (module docstring); the upper body,
    contacts, events and timing are kept. ``cfg.blend`` mixes the clip's legs (0) and the feasible ones."""
    cfg = cfg or FeasibleConfig(feasible=True)
    if set(SIDES) - set(clip.foot_names):
        raise ModelError(f"the feasible reference needs left and right feet, the clip has {clip.foot_names}")
    legs = {s: _Leg.of(model, s) for s in SIDES}
    kin = _kinematics(model, clip.qpos, legs)
    feet = plan_feet(model, clip, legs, kin, cfg.clearance)
    base = clip.qpos.copy()
    if cfg.pendulum > 0:
        base[:, :2] += pendulum_shift(_com_path(model, clip.qpos), feet, clip.frame_time, cfg.pendulum)
        kin = _kinematics(model, base, legs)
    drop = pelvis_drop(kin, feet, legs, cfg.max_extension, clip.frame_time, cfg.smooth_s)
    qpos = base.copy()
    qpos[:, 2] -= drop
    data = mujoco.MjData(model)
    solved = {s: np.zeros((clip.num_frames, len(leg.qadr))) for s, leg in legs.items()}
    prev = {s: clip.qpos[0, leg.qadr].copy() for s, leg in legs.items()}
    for t in range(clip.num_frames):
        data.qpos[:] = qpos[t]
        for s, leg in legs.items():
            f = feet[s]
            q = solve_reaching(model, data, leg, prev[s], clip.qpos[t, leg.qadr], f.ankle[t], f.sole[t], f.toe[t])
            solved[s][t] = prev[s] = q
    w = cfg.blend
    out = clip.qpos.copy()
    out[:, :3] += w * (qpos[:, :3] - clip.qpos[:, :3])
    for s, leg in legs.items():
        out[:, leg.qadr] = (1.0 - w) * clip.qpos[:, leg.qadr] + w * solved[s]
    qvel = velocities(model, out, clip.frame_time)
    return replace(clip, qpos=out, qvel=qvel)
