"""Creature files (a name and one clip per mode) and the clips made ready to chain: a loop cut from each
file, its root put on a local frame moving along the clip's measured travel direction, its foot contacts
and key frames (foot strikes, or wing beats when no foot touches down).

What the world needs of a clip is measured, not assumed: the travel direction and speed from the root's
path over the loop (the root's own axes may point anywhere: the shared dog's root x axis points
backwards), the loop as the pair of frames with the closest poses (any clip, not only a cycle that
already closes), the feet from the creature body plan, contacts from :mod:`bipedsim.reference.clip`.
"""

from __future__ import annotations

import inspect
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.ndimage import uniform_filter1d
from scipy.signal import find_peaks
from scipy.spatial.transform import Rotation

from bipedsim.config import load_yaml
from bipedsim.errors import BipedsimError
from bipedsim.model.creature_builder import creature_plan
from bipedsim.model.profile import load_profile
from bipedsim.model.source import motion_points
from bipedsim.motion.bvh import load_bvh
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.reference.clip import STANCE_LEVEL_PERCENTILE, contact_labels, debounce, foot_speeds, gait_events
from bipedsim.reference.retarget import retarget
from bipedsim.synthesis.world.blend import slerp
from bipedsim.synthesis.world.tiles import TRAVEL_MODES, WorldError

FloatArray = npt.NDArray[np.float64]

#: Modes a creature file may name.
CLIP_MODES = (*TRAVEL_MODES, "idle", "jump")
#: Shortest loop (s) cut from a clip (a clip's whole usable part when that is shorter).
LOOP_MIN_S = 1.0
#: Window (s) over which the root speed is smoothed to tell travelling frames from idle ones.
SPEED_WINDOW_S = 0.5
#: Frames travelling at least this fraction of the clip's brisk speed (90th percentile) are travel frames;
#: those at most IDLE_FRACTION of it idle frames.
TRAVEL_FRACTION = 0.5
IDLE_FRACTION = 0.15
#: A travel clip must cover at least this fraction of the creature's size per second.
MIN_TRAVEL_SIZES_PER_S = 0.05
#: The loop is searched within at most this many frames of the clip's longest travelling (or idle) run --
#: a loop is a few seconds; every pair of frames is compared (17 s at 120 fps, 67 s at 30 fps).
LOOP_SEARCH_MAX_FRAMES = 2000
#: Pose values (frames x frames x joints) compared at once while searching the loop (32 MB of float64).
POSE_BLOCK_VALUES = 4_000_000
#: A creature's name names its output files (``OUT_<name>.bvh``): a letter, digit or ``_`` first, then
#: those, ``.`` or ``-``; no folder separators, no ``..`` first, no control characters.
NAME_PATTERN = re.compile(r"\w[\w.-]{0,63}")


def retarget_default(name: str) -> float:
    """The contact thresholds the project retargets with (reference.retarget's defaults): one source."""
    return float(inspect.signature(retarget).parameters[name].default)


@dataclass
class ModeClip:
    """One mode's loop, ready to chain (project frame: m, Z up).

    ``rots`` (n, J, 4): joint rotations, the root's relative to the travel frame (yaw of the travel
    direction removed); ``off`` (n, 3): the root in the travel frame (x forward beyond steady progress,
    y left, z height above the clip's floor; a flying clip keeps its altitude); ``speed``: steady progress
    (m/s); ``keys``: key frames (loop indices, ascending); ``contacts`` (n, F) of the ``feet`` (point
    indices of :func:`~bipedsim.model.source.motion_points`); ``below_root``: the most any point of the
    body hangs below the root (m); ``frames``: the source frames [a, b) the loop was cut from.
    """

    mode: str
    source: str
    frame_time: float
    rots: FloatArray
    off: FloatArray
    speed: float
    keys: npt.NDArray[np.int64]
    contacts: npt.NDArray[np.bool_]
    feet: list[int]
    below_root: float
    frames: tuple[int, int]
    key_kind: str = "strike"
    loop_error: float = 0.0
    yaw_offset: float = 0.0  #: travel direction minus the root's mean yaw (rad)

    @property
    def n(self) -> int:
        return int(self.rots.shape[0])

    def next_key(self, phase: float) -> tuple[int, int]:
        """The first key frame at or after ``phase`` (loop frames, may exceed n: unwrapped) and the interval
        to the key after it (frames)."""
        cyc, p = divmod(phase, self.n)
        ks = self.keys
        i = int(np.searchsorted(ks, p - 1e-9))
        k = int(ks[i]) + int(cyc) * self.n if i < len(ks) else int(ks[0]) + (int(cyc) + 1) * self.n
        nxt = np.append(ks, ks[0] + self.n)
        j = int(np.searchsorted(nxt, (k % self.n) + 1e-9, side="right"))
        return k, int(nxt[j] - (k % self.n)) if j < len(nxt) else self.n

    def sample(self, phase: float) -> tuple[FloatArray, FloatArray]:
        """Rotations (J, 4) and root offset (3,) at fractional loop frame ``phase`` (wraps)."""
        i0 = int(np.floor(phase))
        f = phase - i0
        a, b = i0 % self.n, (i0 + 1) % self.n
        return slerp(self.rots[a], self.rots[b], f), (1 - f) * self.off[a] + f * self.off[b]


@dataclass
class Creature:
    """A creature file: its name, its skeleton's template motion and one :class:`ModeClip` per mode."""

    name: str
    path: str
    template: Motion
    clips: dict[str, ModeClip]
    feet: list[str] = field(default_factory=list)
    mass: float = 0.0
    size: float = 0.0
    clips_source: dict[str, Motion] = field(default_factory=dict)  #: each mode's whole source motion

    @property
    def travel_modes(self) -> list[str]:
        return [m for m in TRAVEL_MODES if m in self.clips]

    @property
    def frame_time(self) -> float:
        return min(c.frame_time for c in self.clips.values())


# ---------------------------------------------------------------------- reading
def load_creature(path: str | os.PathLike[str]) -> Creature:
    """Read a creature YAML: ``name:``, ``clips: {mode: BVH path relative to the file}``, optional
    ``scale:``/``up:`` for the BVH reader."""
    p = Path(path)
    data = load_yaml(p)
    allowed = ("name", "clips", "scale", "up")
    if not isinstance(data, dict):
        raise WorldError(f"a creature file is a mapping with keys {', '.join(allowed)} (clips: mode -> BVH file)",
                         path=p)
    unknown = [k for k in data if k not in allowed]
    if unknown:
        raise WorldError(f"unknown key; allowed keys here: {', '.join(allowed)}", path=p, key=str(unknown[0]))
    clips = data.get("clips")
    if not isinstance(clips, dict) or not clips:
        raise WorldError(f"must map modes ({', '.join(CLIP_MODES)}) to BVH files", path=p, key="clips")
    bad = [m for m in clips if m not in CLIP_MODES]
    if bad:
        raise WorldError(f"unknown mode {bad[0]!r}; allowed: {', '.join(CLIP_MODES)}", path=p, key="clips")
    if not any(m in clips for m in TRAVEL_MODES):
        raise WorldError(f"needs at least one travel mode ({', '.join(TRAVEL_MODES)})", path=p, key="clips")
    scale, up = data.get("scale"), data.get("up")
    if scale is not None and (isinstance(scale, bool) or not isinstance(scale, int | float | str)):
        raise WorldError(f"must be a number of metres per unit or a unit name (cm, inch...), got {scale!r}",
                         path=p, key="scale")
    if up is not None and not (isinstance(up, str) and up.lower() in ("y", "z")):
        raise WorldError(f"must be y or z, got {up!r}", path=p, key="up")
    name = creature_name(data.get("name"), p)  # before the clips are read
    motions = {}
    for mode, f in clips.items():
        if not isinstance(f, str) or not f:
            raise WorldError(f"must be a BVH file name, got {f!r}", path=p, key=f"clips.{mode}")
        fp = (p.parent / f).resolve() if not Path(f).is_absolute() else Path(f)
        if not fp.is_file():
            raise WorldError(f"no BVH file {fp}", path=p, key=f"clips.{mode}")
        motions[mode] = (str(fp), load_bvh(fp, scale=scale, up=up).to_project_frame())
    return creature_from_motions(name, {m: mo for m, (_, mo) in motions.items()},
                                 {m: s for m, (s, _) in motions.items()}, path=str(p))


def creature_name(raw: Any, path: Path) -> str:
    """The creature's name: ``raw`` (the file's ``name:``), which must match :data:`NAME_PATTERN` since it
    names output files, or else the file's stem with every other character made ``_``."""
    if raw is None or raw == "":
        stem = re.sub(r"[^\w.-]", "_", path.stem).lstrip(".-")[:64]
        return stem or "creature"
    if not (isinstance(raw, str) and NAME_PATTERN.fullmatch(raw)):
        raise WorldError(f"must be 1 to 64 letters, digits, '_', '.' or '-' (starting with a letter, digit or "
                         f"'_'), got {raw!r}: it names the output files", path=path, key="name")
    return raw


def creature_from_motions(name: str, motions: dict[str, Motion], sources: dict[str, str] | None = None,
                          path: str = "<creature>") -> Creature:
    """A :class:`Creature` from one motion per mode (project frame, one skeleton)."""
    sources = sources or {m: m for m in motions}
    first_mode = next(m for m in (*TRAVEL_MODES, "idle", "jump") if m in motions)
    template = motions[first_mode]
    for m, mo in motions.items():
        if not mo.skeleton.same_structure(template.skeleton):
            raise WorldError(f"the {m} clip {sources[m]} has another skeleton than the {first_mode} clip "
                             f"{sources[first_mode]}: a creature's clips must share one skeleton", path=path)
    plan = creature_plan(template, load_profile("creature"))
    feet = [b.source for b in plan.bodies if b.is_foot]
    mass = float(sum(g.mass for b in plan.bodies for g in b.geoms))
    size = float(plan.extra["size_m"])
    clips: dict[str, ModeClip] = {}
    for m in sorted(motions, key=lambda k: k in ("idle", "jump")):  # travel clips first: idle uses their heading
        try:
            clips[m] = cut_clip(m, motions[m], feet, size, sources[m], heading_offset=_heading_offset(clips))
        except BipedsimError as exc:
            raise WorldError(str(exc), path=path, key=f"clips.{m}") from None
    return Creature(name=name, path=path, template=template, clips=clips, feet=feet, mass=mass, size=size,
                    clips_source=dict(motions))


def _heading_offset(clips: dict[str, ModeClip]) -> float:
    """Travel direction minus root yaw (rad) of the creature's travel clips (for clips that do not travel)."""
    offs = [c.yaw_offset for c in clips.values() if c.mode in TRAVEL_MODES]
    return float(offs[0]) if offs else 0.0


# ---------------------------------------------------------------------- cutting a loop
def foot_tips(motion: Motion, feet: list[str]) -> list[int]:
    """Per foot, the point (index into :func:`~bipedsim.model.source.motion_points`: joints, then End
    Sites) of its subtree that is lowest over the motion (median height): the sole (a merged hand's hoof,
    not its wrist)."""
    sk = motion.skeleton
    med = np.median(motion_points(motion).positions[..., 2], axis=0)
    idx = []
    for f in feet:
        sub = sk.subtree(sk.index(f))
        cand = list(sub) + [sk.num_joints + e for e, p in enumerate(sk.end_site_parents) if int(p) in sub]
        idx.append(int(min(cand, key=lambda i: med[i])))
    return idx


def tip_joint(motion: Motion, point: int) -> tuple[int, FloatArray]:
    """The joint carrying point ``point`` (a joint, or an End Site) and the point's offset in its frame."""
    sk = motion.skeleton
    if point < sk.num_joints:
        return point, np.zeros(3)
    e = point - sk.num_joints
    return int(sk.end_site_parents[e]), np.asarray(sk.end_site_offsets[e], dtype=float)


def _foot_points(motion: Motion, feet: list[str]) -> tuple[FloatArray, list[int]]:
    """All points (joints and End Sites) per frame, and each foot's tip (:func:`foot_tips`)."""
    return motion_points(motion).positions, foot_tips(motion, feet)


def _speed(motion: Motion) -> FloatArray:
    v = np.gradient(motion.root_translation[:, :2], motion.frame_time, axis=0) if motion.num_frames > 1 else \
        np.zeros((1, 2))
    w = max(1, int(round(SPEED_WINDOW_S / motion.frame_time)))
    return uniform_filter1d(np.linalg.norm(v, axis=1), w, mode="nearest")


def _longest_run(mask: npt.NDArray[np.bool_]) -> tuple[int, int]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    runs = list(zip(edges[::2], edges[1::2]))
    if not runs:
        return 0, 0
    return max(runs, key=lambda r: r[1] - r[0])


def _pose_distance(motion: Motion, lo: int, hi: int) -> FloatArray:
    """(k, k) pose distance of frames lo..hi-1: sum over joints of 1 - (q_i . q_j)^2 (the root's tilt only,
    its yaw removed) plus the squared root-height change in body sizes."""
    q = motion.rotations[lo:hi].copy()
    yaw = motion.heading()[lo:hi]
    q[:, 0] = (Rotation.from_euler("z", -yaw[:, None]) * Rotation.from_quat(q[:, 0])).as_quat()
    k = hi - lo
    d = np.empty((k, k))
    rows = max(1, POSE_BLOCK_VALUES // (k * q.shape[1]))
    for i in range(0, k, rows):  # a block of rows at a time: (rows, k, J) values, not (k, k, J)
        d[i:i + rows] = (1.0 - np.einsum("ijq,kjq->ikj", q[i:i + rows], q) ** 2).sum(axis=2)
    z = motion.root_translation[lo:hi, 2]
    size = max(float(np.ptp(motion.fk()[0][lo:hi].reshape(-1, 3), axis=0).max()), 1e-6)
    return d + ((z[:, None] - z[None, :]) / size) ** 2


def find_loop(motion: Motion, mode: str) -> tuple[int, int, float]:
    """The loop [a, b) cut from ``motion`` for ``mode``: within the longest run of travelling frames (idle
    frames for ``idle``; its first :data:`LOOP_SEARCH_MAX_FRAMES`), the pair of frames at least
    :data:`LOOP_MIN_S` apart whose poses are closest (ties: the longer loop). Returns a, b and the pose
    distance of frames a and b."""
    sp = _speed(motion)
    brisk = float(np.percentile(sp, 90))
    if mode == "idle":
        mask = sp <= IDLE_FRACTION * brisk if brisk > 1e-6 else np.ones(len(sp), bool)
    else:
        mask = sp >= TRAVEL_FRACTION * brisk
    lo, hi = _longest_run(mask)
    if hi - lo < 3:
        raise WorldError(f"no {'idle' if mode == 'idle' else 'travelling'} part of at least 3 frames "
                         f"(root speed 90th percentile {brisk:.3g} m/s)")
    hi = min(hi, lo + LOOP_SEARCH_MAX_FRAMES)
    d = _pose_distance(motion, lo, hi)
    k = hi - lo
    min_len = min(k - 1, max(2, int(round(LOOP_MIN_S / motion.frame_time))))
    gap = np.arange(k)[None, :] - np.arange(k)[:, None]  # j - i
    cost = np.where(gap >= min_len, d + 1e-3 * (1.0 - gap / k), np.inf)
    a, b = np.unravel_index(int(np.argmin(cost)), cost.shape)
    return lo + int(a), lo + int(b), float(d[a, b])


def cut_clip(mode: str, motion: Motion, feet: list[str], size: float, source: str = "",
             heading_offset: float = 0.0) -> ModeClip:
    """Cut ``mode``'s loop from ``motion`` (project frame) and put it on its travel frame."""
    a, b, err = find_loop(motion, mode)
    n = b - a
    dt = motion.frame_time
    root = motion.root_translation
    travel = root[b, :2] - root[a, :2]
    speed = float(np.linalg.norm(travel) / (n * dt))
    yaw = motion.heading()
    if mode == "idle":
        speed = 0.0
        psi = float(np.angle(np.mean(np.exp(1j * yaw[a:b])))) + heading_offset
    else:
        if speed < MIN_TRAVEL_SIZES_PER_S * size:
            raise WorldError(f"the {mode} clip {source} does not travel: its root moves {speed:.3g} m/s over its "
                             f"loop (frames {a}-{b}); the world needs a clip that moves along its heading, "
                             "not one in place")
        psi = float(np.arctan2(travel[1], travel[0]))
    rz = Rotation.from_euler("z", -psi)
    rots = motion.rotations[a:b + 1].copy()
    rots[:, 0] = (rz * Rotation.from_quat(rots[:, 0])).as_quat()
    steady = root[a] + np.outer(np.arange(n + 1) * dt * speed, [np.cos(psi), np.sin(psi), 0.0])
    off = rz.apply(root[a:b + 1] - steady)
    pos, idx = _foot_points(motion, feet)
    low_all = pos[a:b + 1, :, 2].min(axis=1)
    fly = mode == "fly"
    floor = 0.0 if fly else float(np.percentile(pos[a:b + 1][:, idx, 2].min(axis=1), STANCE_LEVEL_PERCENTILE))
    off[:, 2] = root[a:b + 1, 2] - floor
    # close the loop: the difference between frame b and frame a spread evenly over the loop
    u = np.arange(n + 1) / n
    for j in range(rots.shape[1]):
        fix = (Rotation.from_quat(rots[n, j]).inv() * Rotation.from_quat(rots[0, j])).as_rotvec()
        rots[:, j] = (Rotation.from_quat(rots[:, j]) * Rotation.from_rotvec(np.outer(u, fix))).as_quat()
    off += np.outer(u, off[0] - off[n])
    feet_pos = pos[a:b, idx]
    sp = foot_speeds(feet_pos, dt)
    contacts = debounce(contact_labels(feet_pos[..., 2], sp, retarget_default("contact_height"),
                                       retarget_default("contact_speed")), dt) if not fly else \
        np.zeros((n, len(idx)), bool)
    keys, kind = _key_frames(contacts, pos[a:b], root[a:b, 2], n)
    clip = ModeClip(mode=mode, source=source, frame_time=dt, rots=canonical_quat(rots[:n]), off=off[:n],
                    speed=speed, keys=keys, contacts=contacts, feet=idx,
                    below_root=float(np.max(root[a:b, 2] - low_all[:n])), frames=(a, b), key_kind=kind,
                    loop_error=err, yaw_offset=psi - float(np.angle(np.mean(np.exp(1j * yaw[a:b])))))
    return clip


def _key_frames(contacts: npt.NDArray[np.bool_], pos: FloatArray, root_z: FloatArray,
                n: int) -> tuple[npt.NDArray[np.int64], str]:
    """Key frames of a loop: strikes of the foot that strikes most (one per gait cycle); else wing beats,
    the lowest points (relative to the root) of the point that swings most vertically; else frame 0."""
    if contacts.shape[1]:
        ev = gait_events(contacts, [str(k) for k in range(contacts.shape[1])])
        best = max(ev.values(), key=lambda e: len(e["strike"]))
        if best["strike"]:
            return np.array(sorted(best["strike"]), dtype=np.int64), "strike"
    rel = pos[..., 2] - root_z[:, None]
    k = int(np.argmax(np.ptp(rel, axis=0)))
    if np.ptp(rel[:, k]) > 1e-6:
        peaks, _ = find_peaks(np.concatenate([-rel[:, k], -rel[:, k]]), distance=max(1, n // 16))
        peaks = np.unique(peaks % n)
        if len(peaks):
            return peaks.astype(np.int64), "beat"
    return np.array([0], dtype=np.int64), "loop"


def creature_summary(c: Creature) -> dict[str, Any]:
    """What was measured of each clip (for the report)."""
    return {m: {"source": k.source, "frames": [int(v) for v in k.frames], "speed_m_s": round(k.speed, 4),
                "loop_s": round(k.n * k.frame_time, 4), "loop_error": round(k.loop_error, 5),
                "key_frames": k.keys.tolist(), "key_kind": k.key_kind} for m, k in c.clips.items()}
