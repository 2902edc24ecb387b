"""A BVH file parsed: the HIERARCHY into a :class:`~bipedsim.motion.skeleton.Skeleton`, the MOTION
header, the frame values (:mod:`bipedsim.motion.bvh_bytes`), and :class:`BVHInfo`, what reading found out.

Anything malformed raises :class:`~bipedsim.errors.BVHError` naming the file, the line and what was expected.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.errors import BVHError
from bipedsim.motion.bvh_bytes import _FrameReader, _line_endings, _Lines, _text_encoding
from bipedsim.motion.skeleton import POSITION_CHANNELS, ROTATION_CHANNELS, Skeleton

FloatArray = npt.NDArray[np.float64]

#: Plausible frame times (s): motion is captured and animated at 1 to 10,000 frames per second. A
#: frame time outside this range is a broken header (``Frame Time: 1e30``), not a motion.
FRAME_TIME_RANGE_S = (1e-4, 1.0)
#: A channel keyword in any case (``XPOSITION``, ``xrotation``) is the standard one it spells: exporters
#: disagree on the case, the meaning is the same.
CHANNEL_KEYWORDS = {c.lower(): c for c in POSITION_CHANNELS + ROTATION_CHANNELS}


@dataclass
class BVHInfo:
    """What reading a file found out, for reports and ``bipedsim info``."""

    path: str
    num_joints: int
    num_frames: int  # the frames read: the file's, less its lead-in (lead_in_frames)
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
    lead_in_frames: int = 0  # the file's first frames dropped as no part of the take (motion.lead_in)
    notes: list[str] = field(default_factory=list)  # what preparing the motion did (reference.prepare.humanoid_motion)

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    def to_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["fps"] = self.fps
        return d


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
    seen: set[str] = set()  # the names so far, to find a repeated one in constant time (files hold 1e5 joints)
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
        if name in seen:
            raise BVHError(f"joint name {name!r} is used twice", path, ln)
        open_brace(brace, f"joint {name!r}")
        idx = len(names)
        names.append(name)
        seen.add(name)
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
            if n != len(t) - 2:
                raise BVHError(f"CHANNELS says {n} but lists {len(t) - 2} names", path, ln2)
            for c in t[2:]:
                if c.lower() not in CHANNEL_KEYWORDS:
                    raise BVHError(f"unknown channel {c!r}; allowed: "
                                   f"{', '.join(POSITION_CHANNELS + ROTATION_CHANNELS)} (in any case)", path, ln2)
            chans = tuple(CHANNEL_KEYWORDS[c.lower()] for c in t[2:])
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


def _parse(path: str, raw: bytes, start: int = 0,
           bar: Any = None) -> tuple[Skeleton, float, FloatArray, BVHInfo, list[tuple[str, int]]]:
    """Read the BVH file whose bytes are ``raw[start:]`` (``start`` skips a byte-order mark without
    copying the file); ``bar``: a progress bar counting the file's bytes, or None."""
    encoding = _text_encoding(raw, start, path)
    endings, n_lines, has_cr = _line_endings(raw, start)
    final_newline = len(raw) > start and raw[-1] in b"\r\n"
    hl = _Lines(raw, start, path, encoding, has_cr, n_lines)
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
    data, notes = _FrameReader(raw, hl, n_frames, n_ch, ln).read(bar)
    n_frames = len(data)

    sk0 = Skeleton(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets),
                   channels=tuple(channels), end_site_parents=np.array(es_par, dtype=np.int64),
                   end_site_offsets=np.array(es_off).reshape(-1, 3))
    info = BVHInfo(path=path, num_joints=len(names), num_frames=n_frames, frame_time=frame_time,
                   rotation_orders=dict(Counter(sk0.rotation_order(j) or "-" for j in range(len(names)))),
                   unit_name="", unit_scale=1.0, unit_source="", unit_reason="", height_m=0.0,
                   upright=True, up="y", up_source="", up_reason="", line_endings=endings,
                   final_newline=final_newline, end_sites=len(es_par), notes=notes)
    return sk0, frame_time, data, info, []
