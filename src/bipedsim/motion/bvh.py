"""Read and write BVH motion capture files.

Handles the files people actually have: every rotation order and mixed orders in one file, joints
with 6 channels (position channels detected as absolute -- ``replace`` -- or added to the OFFSET --
``add``), End Sites and leaf joints without them, CRLF / LF / CR / mixed line endings, tabs, numbers
like ``.0083333`` and ``1e-05``, no final newline, 1-frame files. Anything malformed raises
:class:`~bipedsim.errors.BVHError` naming the file, the line and what was expected.

:func:`read_bvh` returns the motion in the file's own units and axes, with the guessed (or given)
metres-per-unit and up axis recorded on the :class:`Motion`; :func:`load_bvh` converts it to the
project frame (metres, Z up). :func:`write_bvh` writes a motion exactly as it is.
"""

from __future__ import annotations

import math
import os
import warnings
from collections import Counter
from dataclasses import asdict, dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import BVHError, InputError
from bipedsim.io import read_input_bytes
from bipedsim.motion.conventions import (
    AMBIGUOUS_SCORE_MARGIN,
    UNIT_SCALES,
    ReadingScore,
    guess_unit,
    guess_up_axis,
    leg_stature,
    score_reading,
)
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton

#: A UTF-8 byte-order mark, which some editors write at the start of a text file: dropped before parsing.
UTF8_BOM = b"\xef\xbb\xbf"

FloatArray = npt.NDArray[np.float64]

#: Frames sampled over a clip to guess its up axis and unit.
SIZE_SAMPLE_FRAMES = 50
#: Plausible frame times (s): motion is captured and animated at 1 to 10,000 frames per second. A
#: frame time outside this range is a broken header (``Frame Time: 1e30``), not a motion.
FRAME_TIME_RANGE_S = (1e-4, 1.0)
#: Plausible size (m) of any body -- its height if upright, else its largest extent -- once a scale
#: the caller gave is applied: from an insect to a dinosaur. Outside it, the scale is wrong (``--scale
#: 1`` on a centimetre file makes a 183 m person); the guessed ranges in ``conventions`` are narrower.
GIVEN_SCALE_SIZE_RANGE_M = (0.02, 30.0)


@dataclass
class BVHInfo:
    """What reading a file found out, for reports and ``bipedsim info``."""

    path: str
    num_joints: int
    num_frames: int
    frame_time: float
    rotation_orders: dict[str, int]
    unit_name: str
    unit_scale: float  # metres per file unit
    unit_source: str  # "guessed" or "given"
    unit_reason: str
    height_m: float
    upright: bool
    up: str
    up_source: str
    up_reason: str
    line_endings: str
    final_newline: bool
    frame_time_source: str = "file"  # "file" (its Frame Time) or "given" (the caller's frame rate)
    file_frame_time: float = 0.0  # the file's own Frame Time (s), whichever was used
    position_channels: dict[str, str] = field(default_factory=dict)  # joint -> "replace" | "add"
    position_mode_reasons: dict[str, str] = field(default_factory=dict)
    end_sites: int = 0
    standing_height_m: float = 0.0  # from the hip's height (conventions.leg_stature); 0: no named feet
    reading_note: str = ""  # when another reading (up axis, position modes) was nearly as plausible
    notes: list[str] = field(default_factory=list)  # what preparing the motion did (model.gait.humanoid_motion)

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["fps"] = self.fps
        return d


# ---------------------------------------------------------------------- reading
class _Lines:
    """The header's non-empty lines as token lists, with 1-based line numbers."""

    def __init__(self, lines: list[str], path: str) -> None:
        self.lines = lines
        self.path = path
        self.i = 0

    def next(self, expected: str) -> tuple[list[str], int]:
        while self.i < len(self.lines):
            toks = self.lines[self.i].split()
            self.i += 1
            if toks:
                return toks, self.i
        raise BVHError(f"unexpected end of file: expected {expected}", self.path, len(self.lines))


def _decode(raw: bytes, path: str) -> str:
    if not raw.strip():
        raise BVHError("file is empty: expected 'HIERARCHY'", path, 1)
    nul = raw.find(b"\x00")
    if nul >= 0:
        line = raw.count(b"\n", 0, nul) + 1
        raise BVHError(f"binary data (NUL byte at offset {nul}): not a text BVH file", path, line)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        bad = raw[exc.start:exc.start + 1]
        # latin-1 names occur in old files; anything with control bytes is garbage
        text = raw.decode("latin-1")
        if any(ord(c) < 32 and c not in "\t\r\n\f\v" for c in text):
            raise BVHError(f"binary data (byte {bad!r} at offset {exc.start}): not a text BVH file",
                           path, line) from None
        return text


def _float(tok: str, path: str, line: int, what: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise BVHError(f"expected a number for {what}, got {tok!r}", path, line) from None
    if not np.isfinite(v):
        raise BVHError(f"{what} must be finite, got {tok!r}", path, line)
    return v


def _parse_hierarchy(lines: _Lines) -> tuple[list[str], list[int], list[list[float]], list[tuple[str, ...]],
                                             list[int], list[list[float]]]:
    path = lines.path
    toks, ln = lines.next("'HIERARCHY'")
    if toks != ["HIERARCHY"]:
        raise BVHError(f"expected 'HIERARCHY' as the first line, got {' '.join(toks)[:40]!r}", path, ln)
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[tuple[str, ...]] = []
    es_par: list[int] = []
    es_off: list[list[float]] = []

    toks, ln = lines.next("'ROOT'")
    if toks[0] != "ROOT":
        raise BVHError(f"expected 'ROOT <name>', got {' '.join(toks)[:40]!r}", path, ln)

    def name_of(toks: list[str], ln: int) -> tuple[str, bool]:
        rest = toks[1:]
        brace = bool(rest) and rest[-1] == "{"
        if brace:
            rest = rest[:-1]
        if not rest:
            raise BVHError(f"{toks[0]} needs a name", path, ln)
        return " ".join(rest), brace

    def open_brace(already: bool, what: str) -> None:
        if already:
            return
        t, ln2 = lines.next(f"'{{' opening {what}")
        if t != ["{"]:
            raise BVHError(f"expected '{{' opening {what}, got {' '.join(t)[:40]!r}", path, ln2)

    def offset(what: str) -> list[float]:
        t, ln2 = lines.next(f"OFFSET of {what}")
        if t[0] != "OFFSET":
            raise BVHError(f"expected 'OFFSET x y z' for {what}, got {' '.join(t)[:40]!r}", path, ln2)
        if len(t) != 4:
            raise BVHError(f"OFFSET of {what} needs 3 numbers, got {len(t) - 1}", path, ln2)
        return [_float(x, path, ln2, f"OFFSET of {what}") for x in t[1:]]

    def joint_header(toks: list[str], ln: int, parent: int) -> tuple[int, list[str], int]:
        """Name, OFFSET and CHANNELS of a joint: its index and the first line after them."""
        name, brace = name_of(toks, ln)
        if name in names:
            raise BVHError(f"joint name {name!r} is used twice", path, ln)
        open_brace(brace, f"joint {name!r}")
        idx = len(names)
        names.append(name)
        parents.append(parent)
        offsets.append(offset(f"joint {name!r}"))
        t, ln2 = lines.next(f"CHANNELS of joint {name!r}")
        chans: tuple[str, ...] = ()
        if t[0] == "CHANNELS":
            if len(t) < 2:
                raise BVHError("CHANNELS needs a count", path, ln2)
            try:
                n = int(t[1])
            except ValueError:
                raise BVHError(f"CHANNELS count must be an integer, got {t[1]!r}", path, ln2) from None
            chans = tuple(t[2:])
            if n != len(chans):
                raise BVHError(f"CHANNELS says {n} but lists {len(chans)} names", path, ln2)
            for c in chans:
                if c not in POSITION_CHANNELS + ROTATION_CHANNELS:
                    raise BVHError(f"unknown channel {c!r}; allowed: "
                                   f"{', '.join(POSITION_CHANNELS + ROTATION_CHANNELS)}", path, ln2)
            if len(set(chans)) != len(chans):
                raise BVHError(f"repeated channel in {list(chans)}", path, ln2)
            t, ln2 = lines.next(f"JOINT, End Site or '}}' in joint {name!r}")
        elif idx == 0:
            raise BVHError(f"expected 'CHANNELS' for the root {name!r}, got {t[0]!r}", path, ln2)
        channels.append(chans)
        return idx, t, ln2

    # the joints still open, innermost last: an explicit stack, not recursion, so a chain of
    # thousands of nested joints (a rope, a generated tail) reads like any other file
    idx, t, ln2 = joint_header(toks, ln, -1)
    stack = [idx]
    while True:
        name = names[stack[-1]]
        if t[0] == "JOINT":
            idx, t, ln2 = joint_header(t, ln2, stack[-1])
            stack.append(idx)
            continue
        if t[0] == "End" and len(t) >= 2 and t[1] == "Site":
            open_brace(len(t) == 3 and t[2] == "{", f"End Site of {name!r}")
            es_par.append(stack[-1])
            es_off.append(offset(f"End Site of {name!r}"))
            t2, ln3 = lines.next(f"'}}' closing End Site of {name!r}")
            if t2 != ["}"]:
                raise BVHError(f"expected '}}' closing End Site of {name!r}, got "
                               f"{' '.join(t2)[:40]!r}", path, ln3)
        elif t == ["}"]:
            stack.pop()
            if not stack:
                break
            name = names[stack[-1]]
        else:
            raise BVHError(f"unexpected {' '.join(t)[:40]!r} in joint {name!r}: expected one of "
                           f"JOINT, End Site, '}}' (unbalanced braces?)", path, ln2)
        t, ln2 = lines.next(f"JOINT, End Site or '}}' closing joint {name!r}")
    return names, parents, offsets, channels, es_par, es_off


def _split_text(raw_text: str) -> tuple[list[str], str]:
    crlf = raw_text.count("\r\n")
    cr = raw_text.count("\r") - crlf
    lf = raw_text.count("\n") - crlf
    kinds = [k for k, n in (("CRLF", crlf), ("LF", lf), ("CR", cr)) if n]
    endings = "+".join(kinds) if len(kinds) > 1 else (kinds[0] if kinds else "none")
    if len(kinds) > 1:
        endings = "mixed (" + endings + ")"
    text = raw_text.replace("\r\n", "\n").replace("\r", "\n")
    return text.split("\n"), endings


def _parse(path: str, raw: bytes) -> tuple[Skeleton, float, FloatArray, BVHInfo, list[tuple[str, int]]]:
    text = _decode(raw, path)
    lines, endings = _split_text(text)
    final_newline = text.endswith("\n")
    hl = _Lines(lines, path)
    names, parents, offsets, channels, es_par, es_off = _parse_hierarchy(hl)

    toks, ln = hl.next("'MOTION'")
    if toks != ["MOTION"]:
        raise BVHError(f"expected 'MOTION' after the hierarchy, got {' '.join(toks)[:40]!r} "
                       f"(unknown keyword or unbalanced braces)", path, ln)
    toks, ln = hl.next("'Frames: N'")
    if toks[0] != "Frames:" or len(toks) != 2:
        raise BVHError(f"expected 'Frames: N', got {' '.join(toks)[:40]!r}", path, ln)
    try:
        n_frames = int(toks[1])
    except ValueError:
        raise BVHError(f"Frames: must be an integer, got {toks[1]!r}", path, ln) from None
    if n_frames < 1:
        raise BVHError(f"Frames: must be at least 1, got {n_frames}", path, ln)
    toks, ln = hl.next("'Frame Time: seconds'")
    if toks[:2] != ["Frame", "Time:"] or len(toks) != 3:
        raise BVHError(f"expected 'Frame Time: seconds', got {' '.join(toks)[:40]!r}", path, ln)
    frame_time = _float(toks[2], path, ln, "Frame Time")
    lo, hi = FRAME_TIME_RANGE_S
    if not lo <= frame_time <= hi:
        raise BVHError(f"Frame Time {toks[2]} s is not plausible: expected {lo:g} to {hi:g} s "
                       f"({1 / hi:g} to {1 / lo:g} frames per second)", path, ln)

    n_ch = sum(len(c) for c in channels)
    start = hl.i  # index of the first data line
    data_lines: list[int] = [i for i in range(start, len(lines)) if lines[i].strip()]
    if len(data_lines) < n_frames:
        last = data_lines[-1] + 1 if data_lines else ln
        raise BVHError(f"truncated motion: 'Frames: {n_frames}' but only {len(data_lines)} frame lines "
                       f"follow", path, last)
    rows = [lines[i].split() for i in data_lines]
    for r, i in zip(rows, data_lines):
        if len(r) != n_ch:
            raise BVHError(f"expected {n_ch} values on a frame line (the hierarchy's channel count), "
                           f"got {len(r)}", path, i + 1)
    notes = []
    if len(data_lines) > n_frames:
        # every extra line is a whole frame (checked above): an exporter's count off by a frame or a few
        # (one take exported twice, 418 and 1392 declared, one more row each); the rows are the motion
        notes.append(f"'Frames: {n_frames}' but {len(data_lines)} whole frame lines follow (line "
                     f"{data_lines[n_frames] + 1} on): all {len(data_lines)} read")
        n_frames = len(data_lines)
    flat = [x for r in rows for x in r]
    try:
        data = np.array(flat, dtype=np.float64).reshape(n_frames, max(n_ch, 0))
    except ValueError:
        for r, i in zip(rows, data_lines):
            for x in r:
                _float(x, path, i + 1, "a frame value")
        raise  # pragma: no cover - every bad token is found above
    if not np.all(np.isfinite(data)):
        bad_row = int(np.flatnonzero(~np.all(np.isfinite(data), axis=1))[0])
        bad_tok = next(x for x in rows[bad_row] if not np.isfinite(float(x)))
        raise BVHError(f"frame values must be finite, got {bad_tok!r}", path, data_lines[bad_row] + 1)

    sk0 = Skeleton(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets),
                   channels=tuple(channels), end_site_parents=np.array(es_par, dtype=np.int64),
                   end_site_offsets=np.array(es_off).reshape(-1, 3))
    info = BVHInfo(path=path, num_joints=len(names), num_frames=n_frames, frame_time=frame_time,
                   rotation_orders=dict(Counter(sk0.rotation_order(j) or "-" for j in range(len(names)))),
                   unit_name="", unit_scale=1.0, unit_source="", unit_reason="", height_m=0.0,
                   upright=True, up="y", up_source="", up_reason="", line_endings=endings,
                   final_newline=final_newline, end_sites=len(es_par), notes=notes)
    return sk0, frame_time, data, info, []


def _position_modes(sk: Skeleton, data: FloatArray, col: list[int]) -> tuple[tuple[str, ...], dict[str, str],
                                                                           list[int]]:
    """Decide per joint whether its position channels replace or add to the OFFSET.

    Absolute channels sit near the OFFSET, additive ones near zero. Per axis, the distance of the
    channel values' median from the OFFSET and from zero is measured in units of that axis's own spread
    (10-90 %): an axis the joint travels along (a walk's forward axis) says little, the axis it holds
    (the hips' height) decides. Returns the modes, a reason per joint, and the joints whose choice is
    weak (the distances within a factor of 3), whose alternative reading is scored as well.
    """
    modes: list[str] = []
    reasons: dict[str, str] = {}
    weak: list[int] = []
    scale = float(np.median(np.linalg.norm(sk.offsets[1:], axis=1))) if sk.num_joints > 1 else 1.0
    floor = 1e-3 * (scale if scale > 0 else 1.0)
    for j, name in enumerate(sk.names):
        if not sk.has_positions(j):
            modes.append("")
            continue
        off = sk.offsets[j]
        if not np.any(off):
            modes.append("replace")
            reasons[name] = "OFFSET is zero: replace and add agree"
            continue
        d_rep = d_add = 0.0
        for k, c in enumerate(sk.channels[j]):
            if c not in POSITION_CHANNELS:
                continue
            v = data[:, col[j] + k]
            a = POSITION_CHANNELS.index(c)
            spread = float(np.percentile(v, 90) - np.percentile(v, 10)) + floor
            med = float(np.median(v))
            d_rep += abs(med - off[a]) / spread
            d_add += abs(med) / spread
        if d_rep <= d_add:
            modes.append("replace")
            reasons[name] = (f"channel values sit near the OFFSET ({d_rep:.3g} vs {d_add:.3g} spreads from "
                             "zero): absolute")
        else:
            modes.append("add")
            reasons[name] = (f"channel values sit near zero ({d_add:.3g} vs {d_rep:.3g} spreads from the "
                             "OFFSET): added to OFFSET")
        if max(d_rep, d_add) < 3.0 * min(d_rep, d_add) + 1.0:
            weak.append(j)
    return tuple(modes), reasons, weak


def _quat_mul(a: FloatArray, b: FloatArray) -> FloatArray:
    """Hamilton product of scalar-last quaternions, broadcasting."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def euler_to_quat(order: str, degrees: FloatArray) -> FloatArray:
    """Intrinsic Euler angles (degrees, last axis in ``order``) to scalar-last quaternions.

    Same result as ``Rotation.from_euler(order.upper(), ..., degrees=True)`` (tested), composed from
    elementary half-angle quaternions because scipy's general path is ~40x slower on the
    tens of thousands of rotations a mocap file holds.
    """
    half = np.radians(degrees) * 0.5
    out = None
    for k, axis in enumerate(order.upper()):
        q = np.zeros(half.shape[:-1] + (4,))
        q[..., "XYZ".index(axis)] = np.sin(half[..., k])
        q[..., 3] = np.cos(half[..., k])
        out = q if out is None else _quat_mul(out, q)
    assert out is not None
    return out


def _column_starts(sk: Skeleton) -> list[int]:
    col, c = [], 0
    for ch in sk.channels:
        col.append(c)
        c += len(ch)
    return col


def _channels_to_motion(sk: Skeleton, frame_time: float, data: FloatArray) -> Motion:
    t, j = data.shape[0], sk.num_joints
    col = _column_starts(sk)
    quats = np.zeros((t, j, 4))
    quats[..., 3] = 1.0
    by_order: dict[str, list[int]] = {}
    for i in range(j):
        order = sk.rotation_order(i)
        if order:
            by_order.setdefault(order, []).append(i)
    for order, joints in by_order.items():
        idx = np.array([[col[i] + k for k, c in enumerate(sk.channels[i]) if c in ROTATION_CHANNELS]
                        for i in joints])  # (n, len(order))
        ang = data[:, idx]  # (t, n, k)
        quats[:, joints] = euler_to_quat(order, ang)
    quats = canonical_quat(quats)
    trans = np.broadcast_to(sk.offsets, (t, j, 3)).copy()
    moving = False
    for i in range(j):
        if not sk.has_positions(i):
            continue
        base = np.zeros(3) if sk.position_modes[i] == "replace" else sk.offsets[i]
        vals = np.tile(base, (t, 1))
        if sk.position_modes[i] == "replace":
            vals[:] = sk.offsets[i]  # an axis without a channel keeps the OFFSET component
        for k, c in enumerate(sk.channels[i]):
            if c in POSITION_CHANNELS:
                a = POSITION_CHANNELS.index(c)
                vals[:, a] = data[:, col[i] + k] + (sk.offsets[i][a] if sk.position_modes[i] == "add" else 0.0)
        trans[:, i] = vals
        if i > 0:
            moving = True
    return Motion(skeleton=sk, frame_time=frame_time, root_translation=trans[:, 0].copy(),
                  rotations=quats, translations=trans if moving else None, unit=1.0, up="y")


#: Position-channel modes a caller may force (``--positions``): every joint's channels are absolute
#: (``replace`` the OFFSET) or added to the OFFSET.
POSITION_MODE_NAMES = {"absolute": "replace", "offset": "add"}


def _forced_modes(sk: Skeleton, positions: str, path: str) -> tuple[str, ...]:
    if positions not in POSITION_MODE_NAMES:
        raise BVHError(f"position mode must be one of {', '.join(POSITION_MODE_NAMES)}, got {positions!r}", path)
    m = POSITION_MODE_NAMES[positions]
    return tuple(m if sk.has_positions(j) else "" for j in range(sk.num_joints))


def _candidate_modes(sk: Skeleton, modes: tuple[str, ...], weak: list[int]) -> list[tuple[str, ...]]:
    """The position-mode readings worth scoring: the per-joint choice, and with its weak choices flipped."""
    out = [modes]
    weak = [j for j in weak if j != 0]  # the root's mode only moves the whole body: nothing to score
    if weak:
        flip = {"replace": "add", "add": "replace"}
        out.append(tuple(flip[m] if j in weak else m for j, m in enumerate(modes)))
    return out


def _sample_points(motion: Motion) -> tuple[FloatArray, FloatArray]:
    """Joint positions and joints + End Sites of a few frames spread over the clip (frame 0 alone may
    be a T-pose, a sitting dog...)."""
    sample = motion[::max(1, motion.num_frames // SIZE_SAMPLE_FRAMES)]
    pos_s = sample.fk()[0]
    pts = np.concatenate([pos_s, sample.end_site_positions()], axis=1)
    tj = motion.travel_joint()
    if tj:  # a static root (at the floor, or anywhere) is no part of the body's extent
        sk = motion.skeleton
        above = [j for j in range(sk.num_joints) if tj in sk.subtree(j) and j != tj]
        keep = np.ones(pts.shape[1], dtype=bool)
        keep[above] = False
        pts = pts[:, keep]
    return pos_s, pts


def _choose_reading(sk: Skeleton, frame_time: float, data: FloatArray, mode_options: list[tuple[str, ...]],
                    ups: tuple[str, ...]) -> tuple[Motion, str, str, str]:
    """Score every (position modes, up axis) reading of the file (:func:`score_reading`) and keep the
    most plausible body. Returns the motion, the up axis, why, and a note on the alternatives ("" when
    the choice is clear)."""
    scored = []
    for modes in mode_options:
        motion = _channels_to_motion(sk.replace(position_modes=modes), frame_time, data)
        pos_s, pts = _sample_points(motion)
        for up in ups:
            sc = score_reading(sk.names, sk.parents, pos_s, up)
            if sc is not None and not guess_unit(pts, up).fits:
                sc = ReadingScore(sc.score + 1.0, sc.hip_ratio, sc.floor_spread, sc.vertical_travel, sc.floor_offset)
            scored.append((sc, modes, up, motion, pos_s))
    if any(s[0] is None for s in scored):
        # no feet to measure: one reading by the root-above-feet rule
        motion, pos_s = scored[0][3], scored[0][4]
        if len(ups) == 1:
            return motion, ups[0], "given by the caller", ""
        g = guess_up_axis(sk.names, pos_s, sk.parents)
        return motion, g.axis, g.reason, ""
    scored.sort(key=lambda s: s[0].score)
    best = scored[0]

    differ = [j for j in range(sk.num_joints) if len({m[j] for m in mode_options}) > 1]

    def label(s: tuple) -> str:
        modes = "".join(f", {sk.names[j]} {'absolute' if s[1][j] == 'replace' else 'added to OFFSET'}"
                        for j in differ)
        return f"{s[2].upper()} up{modes}"

    reason = f"most plausible reading ({label(best)}): {best[0].text()}"
    note = ""
    if len(scored) > 1 and scored[1][0].score - best[0].score < AMBIGUOUS_SCORE_MARGIN:
        note = (f"ambiguous: {label(scored[1])} scores {scored[1][0].score:.2f} against {best[0].score:.2f}; "
                "force a reading with --up y|z" + (" and --positions absolute|offset" if len(mode_options) > 1 else ""))
    return best[3], best[2], reason, note


def read_bvh(path: str | os.PathLike[str], *, scale: float | str | None = None,
             up: str | None = None, positions: str | None = None,
             upright: bool | None = None, fps: float | None = None) -> tuple[Motion, BVHInfo]:
    """Read a BVH file in its own units and axes.

    Args:
        path: the file.
        scale: metres per file unit, or a unit name from :data:`UNIT_SCALES` (``"cm"``, ``"inch"``,
            ``"cmu"``...); guessed from the body's size when omitted (see :class:`BVHInfo`).
        up: the file's up axis, ``"y"`` or ``"z"``; guessed when omitted.
        positions: ``"absolute"`` (position channels replace the OFFSET) or ``"offset"`` (added to it)
            for every joint with position channels; decided per joint when omitted.
        upright: whether the body is a human-like upright one for the unit guess (its height in a
            human's range) or not (its largest extent in a creature's); measured from the body's
            extents when omitted (:func:`~bipedsim.motion.conventions.guess_unit`).
        fps: the capture's frame rate (frames per second), replacing the file's ``Frame Time`` for a file
            whose header does not give the rate it was captured at (``info.frame_time_source`` says which
            was used, ``info.file_frame_time`` keeps the file's).

    The up axis and the position-channel modes are chosen together: every combination is read and
    scored for a plausible body (:func:`~bipedsim.motion.conventions.score_reading`: the hip at about a
    leg length above the feet, the feet meeting one floor, the travel horizontal); the unit is then
    guessed from the chosen body's size. ``info.up_reason`` says what was chosen and, when another
    reading scored nearly as well, how to force one.

    Returns:
        The motion (``unit`` and ``up`` set to the guess or the given values) and what was found.

    Raises:
        BVHError: the file is malformed; the message names the file, the line and what was expected.
    """
    p = str(path)
    try:
        raw = read_input_bytes(p, "bvh").removeprefix(UTF8_BOM)
    except InputError as exc:
        raise BVHError(exc.reason, p) from None
    sk, frame_time, data, info, _ = _parse(p, raw)
    info.file_frame_time = frame_time
    if fps is not None:
        frame_time = info.frame_time = _given_frame_time(fps, p)
        info.frame_time_source = "given"
    if up is not None and up.lower() not in ("y", "z"):
        raise BVHError(f"up axis must be 'y' or 'z', got {up!r}", p)
    if positions is None:
        modes, reasons, weak = _position_modes(sk, data, _column_starts(sk))
        mode_options = _candidate_modes(sk, modes, weak)
    else:
        mode_options = [_forced_modes(sk, positions, p)]
        reasons = {sk.names[j]: "given by the caller" for j in range(sk.num_joints) if sk.has_positions(j)}
    ups = (up.lower(),) if up is not None else ("y", "z")
    motion, info.up, up_reason, note = _choose_reading(sk, frame_time, data, mode_options, ups)
    sk = motion.skeleton
    modes = sk.position_modes
    info.position_channels = {sk.names[j]: modes[j] for j in range(sk.num_joints) if modes[j]}
    info.position_mode_reasons = reasons
    info.up_source = "given" if up is not None else "guessed"
    info.up_reason = up_reason if up is None else "given by the caller"
    info.reading_note = note
    pos_s, pts = _sample_points(motion)
    ug = guess_unit(pts, info.up, upright)
    info.upright = ug.upright
    if scale is None:
        info.unit_name, info.unit_scale, info.unit_source, info.unit_reason = ug.name, ug.scale, "guessed", ug.reason
        info.height_m = ug.height_m
    else:
        if isinstance(scale, str):
            if scale not in UNIT_SCALES:
                raise BVHError(f"unknown unit {scale!r}; allowed: {', '.join(UNIT_SCALES)} or a number", p)
            name, s = scale, UNIT_SCALES[scale]
        else:
            s = float(scale)
            if not (s > 0 and np.isfinite(s)):
                raise BVHError(f"scale must be a positive number of metres per unit, got {scale}", p)
            name = next((k for k, v in UNIT_SCALES.items() if np.isclose(v, s)), f"{s:g} m/unit")
        info.unit_name, info.unit_scale, info.unit_source = name, s, "given"
        info.unit_reason = "given by the caller"
        info.height_m = ug.height_m / ug.scale * s
        lo, hi = GIVEN_SCALE_SIZE_RANGE_M
        if not lo <= info.height_m <= hi:
            what = "height" if ug.upright else "largest extent"
            raise BVHError(f"with scale {scale} ({s:g} m per unit) the body's {what} is {info.height_m:.4g} m, outside "
                           f"{lo:g}-{hi:g} m; the body's size suggests {ug.name} ({ug.scale:g} m per unit): "
                           "give that scale or omit it to use the guess", p)
    if ug.upright:
        info.standing_height_m = leg_stature(sk.names, sk.parents, pos_s, info.up) * info.unit_scale
    motion.unit = info.unit_scale
    motion.up = info.up
    return motion, info


def _given_frame_time(fps: float, path: str) -> float:
    """The frame time (s) of a frame rate given by the caller, within :data:`FRAME_TIME_RANGE_S`."""
    lo, hi = FRAME_TIME_RANGE_S
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 1.0 / hi <= fps <= 1.0 / lo):
        raise BVHError(f"frame rate {fps!r} is not plausible: give {1 / hi:g} to {1 / lo:g} frames per second", path)
    return 1.0 / float(fps)


def load_bvh(path: str | os.PathLike[str], *, scale: float | str | None = None,
             up: str | None = None, positions: str | None = None, fps: float | None = None) -> Motion:
    """Read a BVH file and convert it to the project frame: metres, Z up."""
    motion, _ = read_bvh(path, scale=scale, up=up, positions=positions, fps=fps)
    return motion.to_project_frame()


# ---------------------------------------------------------------------- writing
def _euler(q: FloatArray, order: str) -> FloatArray:
    """Euler angles (degrees) for intrinsic ``order`` of 1-3 axes; (N, len(order))."""
    r = Rotation.from_quat(q)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # gimbal lock: angles stay valid
        if len(order) == 3:
            return r.as_euler(order.upper(), degrees=True)
        if len(order) == 2:
            rest = next(a for a in "XYZ" if a not in order.upper())
            return r.as_euler(order.upper() + rest, degrees=True)[:, :2]
    axis = "XYZ".index(order.upper())
    ang = 2.0 * np.arctan2(q[:, axis], q[:, 3])
    return np.degrees((ang + np.pi) % (2 * np.pi) - np.pi)[:, None]


def motion_to_channels(motion: Motion) -> FloatArray:
    """(T, C) channel values of a motion, in the skeleton's channel order and the motion's units."""
    sk = motion.skeleton
    col = _column_starts(sk)
    n_ch = sum(len(c) for c in sk.channels)
    out = np.zeros((motion.num_frames, n_ch))
    trans = motion.local_translations()
    for j in range(sk.num_joints):
        order = sk.rotation_order(j)
        if order:
            ang = _euler(motion.rotations[:, j], order)
            rk = [k for k, c in enumerate(sk.channels[j]) if c in ROTATION_CHANNELS]
            out[:, [col[j] + k for k in rk]] = ang
        for k, c in enumerate(sk.channels[j]):
            if c in POSITION_CHANNELS:
                a = POSITION_CHANNELS.index(c)
                v = trans[:, j, a]
                if sk.position_modes[j] == "add":
                    v = v - sk.offsets[j, a]
                out[:, col[j] + k] = v
    return out


def _fmt(values: FloatArray, precision: int | None) -> list[str]:
    if precision is None:
        return [repr(float(v)) for v in values]  # shortest text that reads back exactly
    # + 0.0 turns -0.0 into 0.0, and a value that rounds to zero is written "0.000000", never
    # "-0.000000": float noise around zero (1e-15 on one machine, -1e-15 on another) must not change the text
    zero = 0.5 * 10.0 ** -precision
    return [f"{(v if abs(v) >= zero else 0.0) + 0.0:.{precision}f}" for v in values]


def _depth_first(motion: Motion) -> Motion:
    """The motion with its joints in depth-first order, the order a BVH hierarchy lists them (and its
    channel columns follow): a skeleton built otherwise (joints appended under earlier parents, as a
    bred meta-skeleton is) would otherwise be written with its columns under the wrong joints."""
    sk = motion.skeleton
    kids: dict[int, list[int]] = {j: [] for j in range(sk.num_joints)}
    for j in range(1, sk.num_joints):
        kids[int(sk.parents[j])].append(j)
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(kids[j]))
    if order == list(range(sk.num_joints)):
        return motion
    new = {j: k for k, j in enumerate(order)}
    skel = sk.replace(names=tuple(sk.names[j] for j in order),
                      parents=np.array([-1 if sk.parents[j] < 0 else new[int(sk.parents[j])] for j in order]),
                      offsets=sk.offsets[order], channels=tuple(sk.channels[j] for j in order),
                      position_modes=tuple(sk.position_modes[j] for j in order) if sk.position_modes else (),
                      end_site_parents=np.array([new[int(p)] for p in sk.end_site_parents], dtype=np.int64))
    return motion.copy(skeleton=skel, rotations=motion.rotations[:, order],
                       translations=None if motion.translations is None else motion.translations[:, order])


def _unambiguous_root(motion: Motion) -> Motion:
    """The motion with a translating root's OFFSET written as zero and its channels absolute.

    Readers disagree on whether position channels replace the OFFSET or add to it (``load_bvh``
    guesses per file). With a zero root OFFSET both readings give the same root path, so a file this
    project writes never depends on the guess (a world output whose root OFFSET was the source clip's
    4.7 m read back 4.7 m off). The root's OFFSET has no bone behind it, so nothing else changes."""
    sk = motion.skeleton
    if not sk.has_positions(0) or not np.any(sk.offsets[0]):
        return motion
    root = motion.root_translation.copy()
    offsets = sk.offsets.copy()
    offsets[0] = 0.0
    modes = ("replace", *sk.position_modes[1:]) if sk.position_modes else ()
    return motion.copy(skeleton=sk.replace(offsets=offsets, position_modes=modes), root_translation=root)


def bvh_text(motion: Motion, *, precision: int | None = None) -> str:
    """The BVH text of a motion (LF line endings, tab indentation).

    ``precision``: decimals per value; ``None`` writes the shortest exact representation so the file
    reads back to the same numbers.
    """
    motion = _unambiguous_root(_depth_first(motion))
    sk = motion.skeleton
    out: list[str] = ["HIERARCHY"]
    children: dict[int, list[int]] = {j: [] for j in range(sk.num_joints)}
    for j in range(1, sk.num_joints):
        children[int(sk.parents[j])].append(j)
    ends: dict[int, list[int]] = {}
    for e, p in enumerate(sk.end_site_parents):
        ends.setdefault(int(p), []).append(e)

    def off(v: FloatArray) -> str:
        return " ".join(_fmt(v, precision))

    def emit(j: int, depth: int) -> None:
        ind = "\t" * depth
        out.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET {off(sk.offsets[j])}")
        if sk.channels[j] or j == 0:
            out.append(f"{ind}\tCHANNELS {len(sk.channels[j])}" +
                       "".join(" " + c for c in sk.channels[j]))
        for c in children[j]:
            emit(c, depth + 1)
        for e in ends.get(j, []):
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET {off(sk.end_site_offsets[e])}")
            out.append(f"{ind}\t}}")
        out.append(f"{ind}}}")

    emit(0, 0)
    out.append("MOTION")
    out.append(f"Frames: {motion.num_frames}")
    out.append(f"Frame Time: {motion.frame_time!r}")
    data = motion_to_channels(motion)
    for row in data:
        out.append(" ".join(_fmt(row, precision)))
    return "\n".join(out) + "\n"


def write_bvh(motion: Motion, path: str | os.PathLike[str], *, precision: int | None = None) -> None:
    """Write a motion as BVH, atomically (temporary file + rename), in the motion's own units and
    axes, with each joint's channel order preserved."""
    from bipedsim.io import atomic_write_text

    atomic_write_text(path, bvh_text(motion, precision=precision))
