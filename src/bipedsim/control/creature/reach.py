"""How far the built body's feet reach from the neutral stance, by IK inside the joint ranges: the
planned gait's stride and a capture step are held to it (a clip's joint ranges can leave a leg too
little room for the step the clip itself takes).

Each foot is moved in steps of REACH_STEP x the leg height until the IK misses it by more than
REACH_TOL x the leg height; a leg's reach is its last step reached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.ik import Attitude, LegIK
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.control.creature.stance import Stance

#: a foot the IK brings within this share of the root height of its target is reached
REACH_TOL = 0.04
#: the reach of the legs is measured in steps of this share of the root height
REACH_STEP = 0.025
#: IK iterations per measured target
REACH_IK_ITERS = 30


@dataclass
class Reach:
    """The legs' reach on the floor (m): ``ahead`` / ``behind`` (legs,) of each foot's neutral place,
    ``half`` the stance's half sweep, ``centred`` whether each foot's sweep is centred in its own leg's
    reach, ``out`` (legs,) to each foot's side (the furthest a capture step puts it)."""

    ahead: FloatArray
    behind: FloatArray
    half: float = math.inf
    centred: bool = False
    out: FloatArray = field(default_factory=lambda: np.zeros(0))


def reach_error(ik: LegIK, stance: Stance, pull: float, shift: float, lift: float, out: float = 0.0,
                attitude: Attitude | None = None) -> FloatArray:
    """Each leg's IK miss (m) with every foot ``shift`` (m) ahead of its neutral place (behind when
    negative), ``out`` (m) further out to its side and ``lift`` (m) above the floor, the body in its
    neutral pose (``pull``: the IK's pull toward it; ``attitude``: the feet's orientations it aims at)."""
    q = stance.q.copy()
    root = q[0:3]
    across = stance.side * out if out else 0.0
    feet = np.column_stack([root[0] + stance.feet[:, 0] + shift, root[1] + stance.feet[:, 1] + across,
                            stance.site_ground + lift])
    ik.solve(q, feet, stance.q, pull, iters=REACH_IK_ITERS, attitude=attitude)
    mujoco.mj_kinematics(ik.model, ik.data)
    return np.linalg.norm(ik.site_positions() - feet, axis=1)


def measure_reach(ik: LegIK, stance: Stance, bal: CreatureBalanceConfig, height: float,
                  attitude: Attitude | None = None) -> Reach:
    """The stride the legs reach (``height``: the leg height L, m), measured from the neutral stance:

    - ``ahead`` / ``behind``: how far each foot reaches ahead of and behind its neutral place on the
      floor, each leg measured to its own first miss (at most ``stride_fraction`` L);
    - ``centred``: with ``centre_sweep``, or where centring widens the sweep at least
      ``centre_sweep_gain`` times (legs whose reach ahead and behind are lopsided: a hind leg that
      reaches far back but little ahead);
    - ``half``: the shortest reach of them all (the symmetric sweep), or centred half the narrowest
      leg's interval, each foot's neutral place (``stance.feet``) then moved the least that puts the
      sweep inside its own interval.

    The IK's warm start is left as it was."""
    n = len(stance.feet)
    tol = REACH_TOL * height
    saved = ik.q.copy()
    reach = np.zeros((2, n))  # ahead, behind
    going = np.ones((2, n), dtype=bool)
    for k in range(1, int(bal.stride_fraction / REACH_STEP) + 1):
        s = k * REACH_STEP * height
        for side, sign in enumerate((1.0, -1.0)):
            if going[side].any():
                going[side] &= reach_error(ik, stance, bal.posture_pull, sign * s, 0.0, attitude=attitude) <= tol
                reach[side, going[side]] = s
        if not going.any():
            break
    ik.q[:] = saved
    out = Reach(ahead=reach[0], behind=reach[1], out=np.zeros(n))
    symmetric, centred = float(reach.min()), float((reach[0] + reach[1]).min()) / 2.0
    out.centred = bal.centre_sweep or (bal.centre_sweep_gain > 0 and centred >= bal.centre_sweep_gain * symmetric)
    if out.centred:
        out.half = centred
        stance.feet[:, 0] += np.clip(0.0, out.half - reach[1], reach[0] - out.half)
    else:
        out.half = symmetric
    return out


def measure_reach_out(ik: LegIK, stance: Stance, bal: CreatureBalanceConfig, height: float,
                      attitude: Attitude | None = None) -> FloatArray:
    """(legs,) how far (m) each foot reaches out to its side of its neutral place, at most
    ``max_placement`` x the leg height ``height``; the IK's warm start is left as it was."""
    saved = ik.q.copy()
    reach_out = np.zeros(len(stance.feet))
    going = np.ones(len(stance.feet), dtype=bool)
    for k in range(1, int(bal.max_placement / REACH_STEP) + 1):
        miss = reach_error(ik, stance, bal.posture_pull, 0.0, 0.0, out=k * REACH_STEP * height, attitude=attitude)
        going &= miss <= REACH_TOL * height
        if not going.any():
            break
        reach_out[going] = k * REACH_STEP * height
    ik.q[:] = saved
    return reach_out


__all__ = ["REACH_STEP", "REACH_TOL", "Reach", "measure_reach", "measure_reach_out", "reach_error"]
