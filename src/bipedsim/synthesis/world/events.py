"""Terrain events: a gap to jump.

The pushing feet (those on the ground when the push starts) drive the jump: the push lasts
:data:`PUSH_TIME_S`; the force on the body is F = m a, with a the change of velocity over the push plus
gravity held off; the take-off direction is searched in 15-degree steps (15..75 degrees above the path)
for the one needing the smallest force; the root then flies a ballistic arc from take-off to landing
(take-off and landing a body half-length before and beyond the gap). The pushing feet stay where they
stood through the push (CCD inverse kinematics on the three joints above each), the other joints follow
the clip, and the ground is never penetrated (:func:`~bipedsim.synthesis.world.synth.keep_above_terrain`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.synthesis.world.creature_file import foot_tips, tip_joint

FloatArray = npt.NDArray[np.float64]

GRAVITY = 9.81
#: Take-off directions searched: 15-degree steps above the path.
ANGLE_STEP_DEG = 15.0
ANGLES_DEG = tuple(np.arange(ANGLE_STEP_DEG, 90.0, ANGLE_STEP_DEG))
#: Duration (s) of the push before take-off and of the landing's give.
PUSH_TIME_S = 0.25
LAND_TIME_S = 0.2
#: Crouch of the root during the push and the landing, as a fraction of its standing height.
CROUCH_FRACTION = 0.1
#: CCD iterations and joints above each pushing foot.
IK_ITERATIONS = 8
IK_CHAIN = 3


@dataclass
class JumpPlan:
    """One jump over a gap: where (arc lengths, m), how (angle, speeds m/s, force N) and the push."""

    tile: tuple[int, int]
    width: float
    s_push: float
    s_takeoff: float
    s_land: float
    s_settle: float
    angle_deg: float
    speed: float
    vx: float
    vz: float
    force_n: list[float]
    force_mag_n: float
    mass_kg: float
    flight_s: float
    apex_m: float
    crouch_m: float
    g: float = GRAVITY
    searched: dict[str, float] = field(default_factory=dict)
    pushing_feet: list[str] = field(default_factory=list)

    def state(self, s: float, v: float) -> tuple[float, float]:
        """Height added to the root (m) and progress speed (m/s) at arc length ``s`` (walking speed ``v``)."""
        if self.s_push <= s < self.s_takeoff:
            u = (s - self.s_push) / (self.s_takeoff - self.s_push)
            return -self.crouch_m * np.sin(np.pi * u), v
        if self.s_takeoff <= s < self.s_land:
            t = (s - self.s_takeoff) / self.vx
            return self.vz * t - 0.5 * self.g * t * t, self.vx
        if self.s_land <= s < self.s_settle:
            u = (s - self.s_land) / (self.s_settle - self.s_land)
            return -self.crouch_m * np.sin(np.pi * u), v
        return 0.0, v

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        return {k: (round(float(v), 4) if isinstance(v, float) else list(v) if isinstance(v, tuple) else v)
                for k, v in d.items()}


def best_direction(distance: float, v0: float, mass: float, push_s: float = PUSH_TIME_S,
                   angles_deg: tuple[float, ...] = ANGLES_DEG) -> tuple[float, float, FloatArray, dict[str, float]]:
    """The take-off angle (degrees) needing the smallest push force to fly ``distance`` (m) from ground to
    ground level, starting from walking speed ``v0`` (m/s): for each angle the take-off speed
    v = sqrt(g d / sin 2a), the force F = m (v_takeoff - v0) / push_s + m g (up). Returns the angle, v,
    the force (forward, up; N) and |F| per angle searched."""
    best = None
    table = {}
    for a in angles_deg:
        r = np.radians(a)
        v = float(np.sqrt(GRAVITY * distance / np.sin(2 * r)))
        f = mass * (np.array([v * np.cos(r), v * np.sin(r)]) - [v0, 0.0]) / push_s + [0.0, mass * GRAVITY]
        table[f"{a:g}"] = float(np.linalg.norm(f))
        if best is None or table[f"{a:g}"] < best[3]:
            best = (float(a), v, f, table[f"{a:g}"])
    assert best is not None
    return best[0], best[1], best[2], table


def plan_jump(world: Any, event_at: tuple[Any, int], curve: Any, walk: Any, creature: Any) -> JumpPlan | None:
    """The jump over ``event_at`` = (event, path tile index) for a creature walking at ``walk.speed``."""
    ev, i = event_at
    s_gap = float(curve.tile_s[i])
    margin = creature.size / 2
    s_to = s_gap - ev.width / 2 - margin
    s_ld = s_gap + ev.width / 2 + margin
    if s_to <= 0 or s_ld >= curve.length:
        return None
    dist = s_ld - s_to
    angle, v, f, table = best_direction(dist, walk.speed, creature.mass)
    r = np.radians(angle)
    vx, vz = v * np.cos(r), v * np.sin(r)
    crouch = CROUCH_FRACTION * float(np.median(walk.off[:, 2]))
    return JumpPlan(tile=tuple(ev.at), width=ev.width, s_push=max(0.0, s_to - walk.speed * PUSH_TIME_S),
                    s_takeoff=s_to, s_land=s_ld, s_settle=min(curve.length, s_ld + walk.speed * LAND_TIME_S),
                    angle_deg=angle, speed=v, vx=vx, vz=vz, force_n=[float(x) for x in f],
                    force_mag_n=float(np.linalg.norm(f)), mass_kg=creature.mass, flight_s=dist / vx,
                    apex_m=vz * vz / (2 * GRAVITY), crouch_m=crouch, searched=table)


# ---------------------------------------------------------------------- IK for the pushing feet
def _min_rotation(a: FloatArray, b: FloatArray) -> FloatArray:
    a = a / max(np.linalg.norm(a), 1e-12)
    b = b / max(np.linalg.norm(b), 1e-12)
    axis = np.cross(a, b)
    s, c = float(np.linalg.norm(axis)), float(np.dot(a, b))
    if s < 1e-12:
        return np.eye(3)
    return Rotation.from_rotvec(axis / s * np.arctan2(s, c)).as_matrix()


def ccd_frame(frame: Motion, j_tip: int, tip_off: FloatArray, target: FloatArray,
              iterations: int = IK_ITERATIONS, chain: int = IK_CHAIN) -> Motion:
    """One frame with the ``chain`` joints above the tip turned (cyclic coordinate descent) so the tip
    (joint ``j_tip`` + ``tip_off`` in its frame) comes as close as it can to ``target`` (m)."""
    sk = frame.skeleton
    joints, j = [], j_tip
    if np.any(tip_off):
        joints.append(j)
    while len(joints) < chain and sk.parents[j] > 0:
        j = int(sk.parents[j])
        joints.append(j)
    rots = frame.rotations.copy()
    for _ in range(iterations):
        for k in joints:
            m = frame.copy(rotations=rots)
            pos, g = m.fk()
            tip = pos[0, j_tip] + g[0, j_tip] @ tip_off
            rw = _min_rotation(tip - pos[0, k], target - pos[0, k])
            gp = g[0, int(sk.parents[k])]
            local = gp.T @ rw @ g[0, k]
            rots[0, k] = Rotation.from_matrix(local).as_quat()
    return frame.copy(rotations=canonical_quat(rots))


def push_ik(motion: Motion, frames: npt.NDArray[np.int64], feet: list[str], contact_height: float) -> tuple[
        Motion, list[str]]:
    """Lock the feet on the ground at ``frames[0]`` (tip within ``contact_height`` of the floor) at their
    positions there through ``frames``; returns the motion and the feet locked."""
    if len(frames) == 0:
        return motion, []
    m = motion.copy(rotations=motion.rotations.copy(), root_translation=motion.root_translation.copy())
    first = m[int(frames[0]):int(frames[0]) + 1]
    pos, g = first.fk()
    locked = []
    targets = {}
    for f, point in zip(feet, foot_tips(m, feet)):
        j, off = tip_joint(m, point)
        tip = pos[0, j] + g[0, j] @ off
        if tip[2] < contact_height:
            targets[f] = (j, off, np.array([tip[0], tip[1], max(tip[2], 0.0)]))
            locked.append(f)
    for t in frames[1:]:
        fr = m[int(t):int(t) + 1]
        for _f, (j, off, target) in targets.items():
            fr = ccd_frame(fr, j, off, target)
        m.rotations[int(t)] = fr.rotations[0]
    return m, locked
