"""How feasible a clip's legs are for a body (:func:`measure`: hinges out of range, a leg's extension,
stance feet off the floor, flat feet sliding or tilting), and why ``reference: {feasible: auto}``
re-solves them (:func:`resolve_because`, :func:`infeasible_because`)."""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.reference.clip import ReferenceClip
from bipedsim.reference.feasible import FeasibleConfig
from bipedsim.reference.feasible_feet import FLAT_BAND, _runs, _tilt
from bipedsim.reference.feasible_legs import SIDES, _kinematics, _Leg

FloatArray = npt.NDArray[np.float64]


#: What :func:`infeasible_because` allows: share of frames with a leg hinge more than 0.05 rad out of
#: its range, the leg's extension beyond ``max_extension``, and the stance feet's lowest point above or
#: below the floor (m). The built-in walk measures 0 %, +0.000 and 2.2 cm; every shared capture leaves at
#: least one (docs/controller.md, *Feasible reference*).
TOLERANCE_OUT_OF_RANGE = 0.05
TOLERANCE_EXTENSION = 0.005
TOLERANCE_FLOAT_M = 0.03


def resolve_because(measured: dict[str, float], cfg: FeasibleConfig, generated: bool) -> list[str]:
    """Why ``feasible: auto`` re-solves a clip's legs (empty: it tracks them as they are). A clip
    ``generated`` for the body (the built-in walk) is re-solved only where it measures infeasible
    (:func:`infeasible_because`); a capture always is, since the body was built from its skeleton, not
    posed by it: a capture within the tolerances can still be untrackable as it is."""
    why = infeasible_because(measured, cfg)
    if why or generated:
        return why
    return [f"a capture, re-solved though within the tolerances: legs out of range on "
            f"{measured['legs_out_of_range']:.0%} of frames, a leg {measured['max_extension']:.3f} of its "
            f"length straight, stance feet {measured['stance_low_min'] * 100:.1f} to "
            f"{measured['stance_low_max'] * 100:.1f} cm from the floor"]


def infeasible_because(measured: dict[str, float], cfg: FeasibleConfig) -> list[str]:
    """Why a clip's legs, as :func:`measure` found them, are not feasible for the body (empty: they are)."""
    why = []
    if measured["legs_out_of_range"] > TOLERANCE_OUT_OF_RANGE:
        why.append(f"leg hinges out of range on {measured['legs_out_of_range']:.0%} of frames")
    if measured["max_extension"] > cfg.max_extension + TOLERANCE_EXTENSION:
        why.append(f"a leg {measured['max_extension']:.3f} of its length straight (at most {cfg.max_extension})")
    if max(measured["stance_low_max"], -measured["stance_low_min"]) > TOLERANCE_FLOAT_M:
        why.append(f"stance feet {measured['stance_low_min'] * 100:.1f} to {measured['stance_low_max'] * 100:.1f} cm "
                   "from the floor")
    return why


def sole_heights(model: mujoco.MjModel, qpos: FloatArray) -> dict[str, FloatArray]:
    """Per side, the lowest point (m; 0 = on the floor) of the foot's sole and toe boxes on each frame
    of ``qpos`` (T, nq): what :func:`measure` reads for the stance feet's distance from the floor."""
    legs = {s: _Leg.of(model, s) for s in SIDES}
    kin = _kinematics(model, qpos, legs)
    return {s: kin[s]["low"] for s in SIDES}


def measure(clip: ReferenceClip, model: mujoco.MjModel) -> dict[str, float]:
    """How feasible a clip's legs are for ``model`` (the properties :func:`feasible_clip` builds):

    - ``out_of_range``: share of frames with any hinge more than 0.05 rad outside its range;
      ``legs_out_of_range``: the same over the legs' hinges;
    - ``max_extension``: the longest hip-joint-to-ankle distance over the leg's length (thigh + shin);
    - ``stance_low_min`` / ``stance_low_max``: the stance feet's lowest point (m; 0 = on the floor);
    - ``flat_slide``: the largest horizontal travel (m) of a stance ankle over the frames of one stance
      where its sole lies flat (tilt below :data:`FLAT_BAND`), from their median;
    - ``flat_tilt``: the largest sole tilt (rad) on the frames of a stance flatter than the band."""
    legs = {s: _Leg.of(model, s) for s in SIDES}
    kin = _kinematics(model, clip.qpos, legs)
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    q = clip.qpos[:, model.jnt_qposadr[hinges]]
    out = np.maximum(model.jnt_range[hinges, 0] - q, 0) + np.maximum(q - model.jnt_range[hinges, 1], 0)
    leg_cols = np.isin(model.jnt_qposadr[hinges], np.concatenate([leg.qadr for leg in legs.values()]))
    res = {"out_of_range": float(np.mean((out > 0.05).any(axis=1))),
           "legs_out_of_range": float(np.mean((out[:, leg_cols] > 0.05).any(axis=1))),
           "max_extension": 0.0, "stance_low_min": np.inf, "stance_low_max": -np.inf, "flat_slide": 0.0,
           "flat_tilt": 0.0}
    for s, leg in legs.items():
        k = kin[s]
        ext = np.linalg.norm(k["hip"] - k["ankle"], axis=1) / leg.length
        res["max_extension"] = max(res["max_extension"], float(ext.max()))
        stance = clip.contacts[:, clip.foot_names.index(s)].astype(bool)
        if stance.any():
            res["stance_low_min"] = min(res["stance_low_min"], float(k["low"][stance].min()))
            res["stance_low_max"] = max(res["stance_low_max"], float(k["low"][stance].max()))
        tilt = _tilt(k["sole"])
        for a, b in _runs(stance):
            flat = np.arange(a, b)[tilt[a:b] < FLAT_BAND]
            if len(flat) < 2:
                continue
            xy = k["ankle"][flat, :2]
            res["flat_slide"] = max(res["flat_slide"],
                                    float(np.linalg.norm(xy - np.median(xy, axis=0), axis=1).max()))
            res["flat_tilt"] = max(res["flat_tilt"], float(tilt[flat].max()))
    return res
