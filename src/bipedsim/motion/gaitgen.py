"""A procedural walking-clip generator: the project's own reference walk.

The walk is built from footprints, not from joint-angle curves: the stance foot stays planted, the
swing foot travels on a smooth arc to the next footprint, the pelvis moves forward at the walking speed
with a small vertical bob and lateral sway over the stance foot, and the legs follow by analytic
two-link inverse kinematics (hip roll + pitch, knee, ankle keeping the foot level). Arms swing against
the legs. So the clip has exact foot contacts, which makes it a clean reference to track in physics.

Bone lengths follow the paper's table (upper leg 0.458 m, lower leg 0.475 m, torso 0.458 m, upper arm
0.261 m, lower arm 0.309 m). Frame: metres, Z up, walking along +X, +Y to the character's left.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import ModelError
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]

UPPER_LEG_M = 0.458
LOWER_LEG_M = 0.475
ANKLE_HEIGHT_M = 0.07  # ankle joint above the sole
HIP_HALF_WIDTH_M = 0.09
HIP_DROP_M = 0.08  # hip joints below the pelvis (root) joint
FOOT_FORWARD_M = 0.12  # ankle to toe joint, forward
UPPER_ARM_M = 0.261
LOWER_ARM_M = 0.309
#: Stance-leg extension at its longest (fraction of the full leg length); < 1 keeps the knee off its
#: singularity so the physics can track it.
MAX_LEG_EXTENSION = 0.985
#: Torso yaw against the arm swing (rad of twist per rad of swing).
TORSO_TWIST = 0.12


@dataclass(frozen=True)
class WalkParams:
    """Walk parameters. Give any two of ``speed`` (m/s), ``step_length`` (m) and ``cadence``
    (steps/min); the third follows from ``speed = step_length * cadence / 60``."""

    speed: float | None = None
    step_length: float | None = 0.44
    cadence: float | None = 129.0
    frames_per_cycle: int = 50  #: frames per gait cycle (two steps), as in the paper
    cycles: int = 4
    foot_clearance: float = 0.1  #: swing-foot peak height above the ground (m)
    double_support: float = 0.1  #: fraction of each step with both feet down
    pelvis_bob: float = 0.0  #: vertical pelvis motion, peak to mean (m), on top of the pendulum
    pelvis_sway: float = 0.02  #: lateral sway (m) for ``pelvis_profile: "sine"``
    #: "lipm": the pelvis moves as a linear inverted pendulum over the stance foot (the centre of
    #: pressure rolling from ``zmp_start`` to ``zmp_end`` m ahead of the ankle), so the walk is one
    #: a physical body can follow with flat feet; "sine": constant speed with a sine sway
    pelvis_profile: str = "lipm"
    zmp_start: float = 0.0
    zmp_end: float = 0.09
    arm_swing: float = 0.25  #: shoulder pitch amplitude (rad)
    elbow_bend: float = 0.35  #: mean elbow flexion (rad)
    step_width: float = 0.2  #: lateral distance between the footprints (m)

    def resolved(self) -> tuple[float, float, float]:
        """(speed m/s, step length m, cadence steps/min)."""
        given = [x is not None for x in (self.speed, self.step_length, self.cadence)]
        if sum(given) < 2:
            raise ModelError("WalkParams: give two of speed, step_length, cadence")
        v, length, c = self.speed, self.step_length, self.cadence
        if (v is not None and length is not None and c is not None
                and not np.isclose(v, length * c / 60.0, rtol=1e-6)):
            raise ModelError("WalkParams: speed, step_length and cadence disagree "
                                 "(speed must be step_length * cadence / 60); give only two")
        if v is None:
            v = length * c / 60.0  # type: ignore[operator]
        elif length is None:
            length = v * 60.0 / c  # type: ignore[operator]
        elif c is None:
            c = v * 60.0 / length
        for name, x in (("speed", v), ("step_length", length), ("cadence", c)):
            if not (x is not None and x > 0 and np.isfinite(x)):
                raise ModelError(f"WalkParams: {name} must be positive, got {x}")
        return float(v), float(length), float(c)  # type: ignore[arg-type]


def walk_skeleton() -> Skeleton:
    """The built-in humanoid skeleton (CMU-style names), Z up, metres, rest pose standing with arms
    hanging."""
    j: list[tuple[str, str | None, tuple[float, float, float]]] = [
        ("Hips", None, (0.0, 0.0, 0.0)),
        ("Spine", "Hips", (0.0, 0.0, 0.10)),
        ("Spine1", "Spine", (0.0, 0.0, 0.23)),
        ("Neck", "Spine1", (0.0, 0.0, 0.228)),
        ("Head", "Neck", (0.0, 0.0, 0.08)),
    ]
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        j += [
            (f"{side}Shoulder", "Spine1", (0.0, s * 0.04, 0.20)),
            (f"{side}Arm", f"{side}Shoulder", (0.0, s * 0.15, 0.0)),
            (f"{side}ForeArm", f"{side}Arm", (0.0, 0.0, -UPPER_ARM_M)),
            (f"{side}Hand", f"{side}ForeArm", (0.0, 0.0, -LOWER_ARM_M + 0.06)),
        ]
    for side, s in (("Left", 1.0), ("Right", -1.0)):
        j += [
            (f"{side}UpLeg", "Hips", (0.0, s * HIP_HALF_WIDTH_M, -HIP_DROP_M)),
            (f"{side}Leg", f"{side}UpLeg", (0.0, 0.0, -UPPER_LEG_M)),
            (f"{side}Foot", f"{side}Leg", (0.0, 0.0, -LOWER_LEG_M)),
            (f"{side}ToeBase", f"{side}Foot", (FOOT_FORWARD_M, 0.0, -(ANKLE_HEIGHT_M - 0.02))),
        ]
    names = tuple(n for n, _, _ in j)
    parents = [-1 if p is None else names.index(p) for _, p, _ in j]
    offsets = np.array([o for _, _, o in j])
    channels = tuple(
        ("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation") if p is None
        else ("Zrotation", "Yrotation", "Xrotation") for _, p, _ in j)
    ends = [("Head", (0.0, 0.0, 0.20)), ("LeftHand", (0.0, 0.0, -0.08)), ("RightHand", (0.0, 0.0, -0.08)),
            ("LeftToeBase", (0.05, 0.0, 0.0)), ("RightToeBase", (0.05, 0.0, 0.0))]
    return Skeleton(names=names, parents=np.array(parents), offsets=offsets, channels=channels,
                    end_site_parents=np.array([names.index(n) for n, _ in ends]),
                    end_site_offsets=np.array([o for _, o in ends]))


def _smooth(s: FloatArray) -> FloatArray:
    """Minimum-jerk blend 0 -> 1 on s in [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def _foot_track(t: FloatArray, t_step: float, length: float, lateral: float, clearance: float,
                ds: float, first_strike: float) -> tuple[FloatArray, FloatArray]:
    """Ankle path (T, 3) and stance flag (T,) of one foot.

    The foot strikes at ``first_strike + 2 k t_step`` at ``x = 2 k L + x0``; it lifts off ``ds`` of a
    step after the other foot strikes, and swings until its next strike.
    """
    cycle = 2 * t_step
    tau = (t - first_strike) % cycle  # time since this foot's last strike
    k = np.floor((t - first_strike) / cycle)  # index of that strike
    x_strike = first_strike / t_step * length + 2 * k * length
    lift = t_step + ds * t_step  # the other foot strikes at t_step; this one lifts ds later
    stance = tau < lift
    s = np.clip((tau - lift) / (cycle - lift), 0.0, 1.0)
    x = np.where(stance, x_strike, x_strike + 2 * length * _smooth(s))
    z = np.where(stance, 0.0, clearance * np.sin(np.pi * s) ** 2)
    pos = np.stack([x, np.full_like(x, lateral), z + ANKLE_HEIGHT_M], axis=1)
    return pos, stance


GRAVITY = 9.81


def _lipm_pelvis(t: FloatArray, t_step: float, length: float, half_w: float, height: float,
                 zmp_start: float, zmp_end: float) -> tuple[FloatArray, FloatArray]:
    """Periodic linear-inverted-pendulum pelvis path (x, y) over alternating stance feet.

    Step j (t in [j T, (j+1) T)) stands on foot x = j L, y = -w/2 (j even, right) or +w/2 (odd,
    left). Sagittal: x'' = w^2 (x - p(t)), the centre of pressure p rolling linearly from
    ``zmp_start`` to ``zmp_end`` ahead of the ankle; periodic: x(T) = x(0) + L, x'(T) = x'(0).
    Lateral: y'' = w^2 (y - q) with q the stance foot; y(T) = -y(0), y'(T) = -y'(0).
    """
    w = np.sqrt(GRAVITY / height)
    big_t = t_step
    c, s = np.cosh(w * big_t), np.sinh(w * big_t)
    r = (zmp_end - zmp_start) / big_t
    p0 = zmp_start
    b1 = p0 + r * big_t - p0 * c - (r / w) * s
    b2 = r - p0 * w * s - r * c
    x0, v0 = np.linalg.solve([[c - 1.0, s / w], [w * s, c - 1.0]], [length - b1, -b2])
    q = -half_w  # right stance first
    y0, vy0 = np.linalg.solve([[c + 1.0, s / w], [w * s, c + 1.0]], [-q * (1.0 - c), q * w * s])
    j = np.floor(t / big_t + 1e-9)
    tau = t - j * big_t
    ch, sh = np.cosh(w * tau), np.sinh(w * tau)
    x = j * length + p0 + r * tau + (x0 - p0) * ch + ((v0 - r) / w) * sh
    sign = np.where(j % 2 == 0, 1.0, -1.0)  # left steps are the mirror image of right ones
    y = sign * (q + (y0 - q) * ch + (vy0 / w) * sh)
    return x, y


def _leg_ik(d: FloatArray, l1: float, l2: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Hip (roll, pitch) and knee angles putting the ankle at ``d`` (T, 3) from the hip, pelvis frame.

    Hip rotation = Rx(roll) Ry(pitch); knee = Ry(knee) with knee >= 0 (flexion). Ry(a) maps the
    downward bone (0, 0, -1) to (-sin a, 0, -cos a), so forward flexion is a negative pitch.
    """
    roll = np.arctan2(d[:, 1], -d[:, 2])
    r = np.hypot(d[:, 1], d[:, 2])
    dist = np.linalg.norm(d, axis=1)
    if np.any(dist > l1 + l2 - 1e-9):
        raise ModelError("walk generator: a footprint is out of the leg's reach; shorten the step")
    knee = np.pi - np.arccos(np.clip((l1 * l1 + l2 * l2 - dist * dist) / (2 * l1 * l2), -1.0, 1.0))
    beta = np.arccos(np.clip((l1 * l1 + dist * dist - l2 * l2) / (2 * l1 * dist), -1.0, 1.0))
    theta = np.arctan2(-d[:, 0], r)
    return roll, theta - beta, knee


def generate_walk(params: WalkParams | None = None) -> Motion:
    """A straight walk in the project frame (metres, Z up, along +X), ``params.cycles`` gait cycles
    long and periodic: frame ``k * frames_per_cycle`` is frame 0 moved forward by ``k`` strides.

    Phase 0 is a right-foot strike (start of the right stance).
    """
    p = params or WalkParams()
    speed, length, cadence = p.resolved()
    if p.frames_per_cycle < 8 or p.cycles < 1:
        raise ModelError("WalkParams: frames_per_cycle must be >= 8 and cycles >= 1")
    if not 0.0 <= p.double_support < 0.5:
        raise ModelError("WalkParams: double_support must be in [0, 0.5)")
    t_step = 60.0 / cadence
    cycle = 2 * t_step
    dt = cycle / p.frames_per_cycle
    n = p.frames_per_cycle * p.cycles + 1
    t = np.arange(n) * dt
    sk = walk_skeleton()
    idx = {name: i for i, name in enumerate(sk.names)}
    half_w = p.step_width / 2.0

    right, r_stance = _foot_track(t, t_step, length, -half_w, p.foot_clearance, p.double_support, 0.0)
    left, l_stance = _foot_track(t, t_step, length, +half_w, p.foot_clearance, p.double_support, t_step)
    # the right foot struck at t=0 at x=0; the left at t=-t_step at x=-L (before the clip started)

    leg = UPPER_LEG_M + LOWER_LEG_M
    reach = MAX_LEG_EXTENSION * leg
    lat = HIP_HALF_WIDTH_M - half_w
    phase = 2 * np.pi * t / t_step  # one bob per step, highest at mid-stance
    if p.pelvis_profile == "lipm":
        # first guess of the height, then the pendulum, then the highest pelvis from which both
        # ankles stay within reach on every frame (hip = pelvis - HIP_DROP_M)
        h = np.sqrt(reach ** 2 - (length / 2) ** 2) + ANKLE_HEIGHT_M + HIP_DROP_M
        for _ in range(3):
            px, py = _lipm_pelvis(t, t_step, length, half_w, h - ANKLE_HEIGHT_M, p.zmp_start, p.zmp_end)
            limits = []
            for foot in (left, right):
                horiz2 = (px - foot[:, 0]) ** 2 + (HIP_HALF_WIDTH_M - abs(half_w)) ** 2
                if np.any(horiz2 >= reach ** 2):
                    raise ModelError("walk generator: a footprint is out of the leg's reach; shorten the step")
                limits.append(foot[:, 2] + HIP_DROP_M + np.sqrt(reach ** 2 - horiz2))
            h = float(np.min(limits)) - p.pelvis_bob
        root = np.stack([px, py, h - p.pelvis_bob * np.cos(phase)], axis=1)
    elif p.pelvis_profile == "sine":
        h_mean = np.sqrt(reach ** 2 - (length / 2) ** 2 - lat ** 2) + ANKLE_HEIGHT_M + HIP_DROP_M - p.pelvis_bob
        # At a right strike (t = 2k t_step) the feet are at x = 2kL (right, front) and 2kL - L (left,
        # back): the pelvis sits halfway between them and leans toward the stance foot mid-stance.
        root = np.stack([
            speed * t - length / 2,
            -p.pelvis_sway * np.sin(np.pi * t / t_step),
            h_mean - p.pelvis_bob * np.cos(phase),
        ], axis=1)
    else:
        raise ModelError(f"WalkParams: pelvis_profile must be 'lipm' or 'sine', got {p.pelvis_profile!r}")

    rot = np.zeros((n, sk.num_joints, 4))
    rot[..., 3] = 1.0
    for side, ankle in (("Left", left), ("Right", right)):
        s = 1.0 if side == "Left" else -1.0
        hip = root + np.array([0.0, s * HIP_HALF_WIDTH_M, -HIP_DROP_M])
        roll, pitch, knee = _leg_ik(ankle - hip, UPPER_LEG_M, LOWER_LEG_M)
        r_hip = Rotation.from_euler("XY", np.stack([roll, pitch], axis=1))
        r_knee = Rotation.from_euler("Y", knee[:, None])
        r_ankle = (r_hip * r_knee).inv()  # keep the foot level and pointing forward
        rot[:, idx[f"{side}UpLeg"]] = r_hip.as_quat()
        rot[:, idx[f"{side}Leg"]] = r_knee.as_quat()
        rot[:, idx[f"{side}Foot"]] = r_ankle.as_quat()
    # arms swing against the legs: the right arm comes forward with the left leg (strike at t_step)
    swing = p.arm_swing * np.sin(np.pi * (t - t_step / 2) / t_step)
    for side, sign in (("Left", 1.0), ("Right", -1.0)):
        a = sign * swing  # negative pitch = forward: the left arm swings back as the left leg comes forward
        rot[:, idx[f"{side}Arm"]] = Rotation.from_euler("XY", np.stack(
            [np.full(n, sign * 0.08), a], axis=1)).as_quat()
        rot[:, idx[f"{side}ForeArm"]] = Rotation.from_euler(
            "Y", -(p.elbow_bend + 0.5 * np.maximum(-a, 0.0))[:, None]).as_quat()
    # a little torso counter-rotation
    rot[:, idx["Spine1"]] = Rotation.from_euler("Z", TORSO_TWIST * swing[:, None]).as_quat()
    return Motion(skeleton=sk, frame_time=dt, root_translation=root, rotations=canonical_quat(rot),
                  unit=1.0, up="z")


#: Unit the built-in clip's BVH file is written in (metres per unit): centimetres, Y up, as most
#: BVH files are.
BUILTIN_BVH_UNIT = 0.01


def walk_bvh_motion(params: WalkParams | None = None) -> Motion:
    """The generated walk converted to the usual BVH frame: Y up, centimetres."""
    m = generate_walk(params).with_up("y")
    return m.scaled(1.0 / BUILTIN_BVH_UNIT)
