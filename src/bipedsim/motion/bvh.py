"""Read and write BVH motion capture files.

Handles the files people actually have: every rotation order and mixed orders in one file, joints
with 6 channels (position channels detected as absolute -- ``replace`` -- or added to the OFFSET --
``add``), End Sites and leaf joints without them, CRLF / LF / CR / mixed line endings, tabs, numbers
like ``.0083333`` and ``1e-05``, no final newline, 1-frame files, a UTF-8 byte-order mark. Anything
malformed raises :class:`~bipedsim.errors.BVHError` naming the file, the line and what was expected.

Files up to the BVH input limit (:data:`bipedsim.files.INPUT_LIMITS_MB`, raised with ``BIPEDSIM_MAX_BVH_MB``)
are read in a few times their size in memory: the frame lines go straight from the file's bytes into one
float array, a window at a time, and a file over :data:`PROGRESS_MIN_BYTES` shows a progress bar on a
terminal.

:func:`read_bvh` returns the motion in the file's own units and axes, with the guessed (or given)
metres-per-unit and up axis recorded on the :class:`Motion`; :func:`load_bvh` converts it to the
project frame (metres, Z up). :func:`write_bvh` writes a motion exactly as it is.
"""

from __future__ import annotations

import codecs
import math
import os
import re
import warnings
from collections import Counter
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.errors import BVHError, InputError
from bipedsim.files import atomic_write_text, progress_bar, read_input_bytes
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
#: Bytes of the motion section parsed at a time: the temporary arrays of one window are a few times
#: its size, so reading stays within a small multiple of the file's own size whatever its length.
WINDOW_BYTES = 1 << 20
#: A BVH larger than this (bytes) shows a progress bar while its frames are read, on a terminal.
PROGRESS_MIN_BYTES = 5 << 20
#: The longest header line (bytes) read: a joint name or keyword line is a few dozen bytes; a longer
#: line is not a BVH header, and splitting it into words could take many times its size.
MAX_HEADER_LINE_BYTES = 1 << 20

#: The bytes frame values are separated by (ASCII whitespace, as ``bytes.split()`` has it).
_SEPARATORS = b" \t\n\r\x0b\x0c"
_IS_SEPARATOR = np.zeros(256, dtype=bool)
_IS_SEPARATOR[list(_SEPARATORS)] = True
#: Bytes the fast path reads: printable ASCII and separators. A window with any other byte is read
#: value by value with ``float`` (the reference behaviour), so both paths accept the same files.
_IS_PLAIN = _IS_SEPARATOR.copy()
_IS_PLAIN[33:127] = True
_NOT_SPACE = re.compile(rb"[^ \t\n\r\x0b\x0c]")
_WORD = re.compile(r"\S+")
#: Lines longer than this (characters) have their words counted without splitting them into a list.
_SPLIT_MAX_CHARS = 1 << 16
_CONTROL = re.compile(rb"[\x00-\x08\x0e-\x1f]")


class _Lines:
    """The file's lines from ``start`` on, decoded one at a time as they are asked for (the header is
    small; the motion section is read by :class:`_FrameReader` from the bytes), with 1-based line
    numbers. A line ends at LF, CRLF or a lone CR."""

    def __init__(self, raw: bytes, start: int, path: str, encoding: str, has_cr: bool, total: int) -> None:
        self.raw = raw
        self.pos = start  # byte offset of the next line; len(raw) + 1 once the last line is read
        self.path = path
        self.encoding = encoding
        self.total = total  # lines in the file, as splitting its text at every line break counts them
        self.i = 0  # lines read
        # the next LF and CR at or after pos, found once and reused (-1: none left): looking for a CR
        # from every line of an LF file would scan the rest of the file each time
        self._lf = -2
        self._cr = -2 if has_cr else -1

    def _read_line(self) -> str | None:
        raw, pos = self.raw, self.pos
        if pos > len(raw):
            return None
        if -1 < self._lf < pos or self._lf == -2:
            self._lf = raw.find(b"\n", pos)
        if -1 < self._cr < pos or self._cr == -2:
            self._cr = raw.find(b"\r", pos)
        ends = [p for p in (self._lf, self._cr) if p >= 0]
        end = min(ends) if ends else len(raw)
        self.i += 1
        if end - pos > MAX_HEADER_LINE_BYTES:
            raise BVHError(f"line is {end - pos} bytes long, more than any BVH header line "
                           f"({MAX_HEADER_LINE_BYTES} at most)", self.path, self.i)
        self.pos = end + 2 if raw[end:end + 2] == b"\r\n" else end + 1
        return raw[pos:end].decode(self.encoding)

    def next(self, expected: str) -> tuple[list[str], int]:
        while (line := self._read_line()) is not None:
            toks = line.split()
            if toks:
                return toks, self.i
        raise BVHError(f"unexpected end of file: expected {expected}", self.path, self.total)


def _text_encoding(raw: bytes, start: int, path: str) -> str:
    """How to decode the file's text from ``start`` on: ``"utf-8"``, or ``"latin-1"`` for the old files
    with latin-1 names. Empty files and binary data (NUL or control bytes in text that is not UTF-8)
    raise :class:`BVHError`; offsets in the messages count from ``start``. Nothing is copied: UTF-8 is
    checked a window at a time."""
    if _NOT_SPACE.search(raw, start) is None:
        raise BVHError("file is empty: expected 'HIERARCHY'", path, 1)
    nul = raw.find(b"\x00", start)
    if nul >= 0:
        line = raw.count(b"\n", start, nul) + 1
        raise BVHError(f"binary data (NUL byte at offset {nul - start}): not a text BVH file", path, line)
    if np.frombuffer(raw, dtype=np.uint8, offset=start).max() < 0x80:  # ASCII: UTF-8 (and faster than a regex)
        return "utf-8"
    decoder = codecs.getincrementaldecoder("utf-8")()
    view = memoryview(raw)
    for a in range(start, len(raw), WINDOW_BYTES):
        pending = len(decoder.getstate()[0])  # bytes of a character split at the last window's end
        try:
            decoder.decode(view[a:a + WINDOW_BYTES], final=a + WINDOW_BYTES >= len(raw))
        except UnicodeDecodeError as exc:
            bad_at = a - pending + exc.start
            break
    else:
        return "utf-8"
    # latin-1 names occur in old files; anything with control bytes is garbage
    if _CONTROL.search(raw, start) is not None:
        line = raw.count(b"\n", start, bad_at) + 1
        raise BVHError(f"binary data (byte {raw[bad_at:bad_at + 1]!r} at offset {bad_at - start}): not a text "
                       "BVH file", path, line)
    return "latin-1"


def _line_endings(raw: bytes, start: int) -> tuple[str, int, bool]:
    """The file's line endings ("LF", "CRLF", "CR", "mixed (...)" or "none"), the number of lines (as
    splitting at every line break counts them) and whether any line ends in a CR."""
    crlf = raw.count(b"\r\n", start)
    cr = raw.count(b"\r", start) - crlf
    lf = raw.count(b"\n", start) - crlf
    kinds = [k for k, n in (("CRLF", crlf), ("LF", lf), ("CR", cr)) if n]
    endings = "+".join(kinds) if len(kinds) > 1 else (kinds[0] if kinds else "none")
    if len(kinds) > 1:
        endings = "mixed (" + endings + ")"
    return endings, crlf + cr + lf + 1, crlf + cr > 0


def _plain(raw: bytes, start: int) -> bool:
    """Whether ``raw[start:]`` is only printable ASCII and separators, checked a window at a time."""
    for a in range(start, len(raw), WINDOW_BYTES):
        if not _IS_PLAIN[np.frombuffer(raw, dtype=np.uint8, count=min(WINDOW_BYTES, len(raw) - a), offset=a)].all():
            return False
    return True


class _FrameReader:
    """The motion section's frame lines read straight from the file's bytes into one float array.

    The bytes are read a window (:data:`WINDOW_BYTES`) at a time: separators and line breaks found with
    numpy, the values of the window's complete lines parsed by ``np.fromstring``; a window that is not
    plain ASCII numbers (or holds a value that is not finite) is read again value by value with ``float``
    to find what is wrong and where. The rows are allocated from what the file holds (its lines, and
    the values its bytes can hold), never from the ``Frames:`` count alone. Errors keep the order a
    reader going through the whole file would report: too few frame lines, then the first line with
    the wrong count of values, then the first value that is not a number (or not finite).
    """

    def __init__(self, raw: bytes, lines: _Lines, n_frames: int, n_ch: int, frames_line: int) -> None:
        self.raw, self.path, self.encoding = raw, lines.path, lines.encoding
        self.start = min(lines.pos, len(raw))
        self.first_line = lines.i + 1  # the line number of the first line after the header
        self.n_frames, self.n_ch, self.frames_line = n_frames, n_ch, frames_line
        size = len(raw) - self.start
        # each row holds n_ch values, each followed by a separator but the file's last
        self.max_rows = (size + 1) // (2 * n_ch) if n_ch else 0
        self.rows = np.empty((min(n_frames, lines.total, self.max_rows), n_ch))
        self.n_rows = 0  # frame (non-blank) lines so far
        self.last_line = 0  # line number of the last frame line
        self.extra_line = 0  # line number of the first frame line past the Frames: count
        self.bad_count: tuple[int, int] | None = None  # (line, values) of the first line with a wrong count
        self.bad_value: tuple[int, int, str] | None = None  # (line, index, token): the first non-number
        self.not_finite: tuple[int, int, str] | None = None  # (line, index, token): the first inf or nan
        self.plain = False  # whether the motion section is all printable ASCII and separators

    def read(self, bar: Any = None) -> tuple[FloatArray, list[str]]:
        """The (frames, channels) values and the notes on them; raises :class:`BVHError`. ``bar``: a
        progress bar counting the file's bytes, or None."""
        if bar is not None:
            bar.update(self.start)  # the header
        self.plain = _plain(self.raw, self.start)
        if not self.plain:
            return self._read_text(bar)
        raw, end = self.raw, len(self.raw)
        line_start, line_no = self.start, self.first_line  # the line the next window continues
        carry_count, carry_sep = 0, True  # values so far on that line; whether the byte before is a separator
        for a in range(self.start, end, WINDOW_BYTES):
            b = min(a + WINDOW_BYTES, end)
            arr = np.frombuffer(raw, dtype=np.uint8, count=b - a, offset=a)
            sep = _IS_SEPARATOR[arr]
            starts = ~sep
            starts[1:] &= sep[:-1]
            starts[0] &= carry_sep
            breaks = arr == 10
            lone_cr = arr == 13
            lone_cr[:-1] &= arr[1:] != 10
            if b < end and raw[b] == 10:
                lone_cr[-1] = False  # the LF of this CRLF begins the next window
            breaks |= lone_cr
            at = np.flatnonzero(breaks)
            counts = np.bincount(np.searchsorted(at, np.flatnonzero(starts)), minlength=len(at) + 1)
            counts[0] += carry_count
            carry_sep = bool(sep[-1])
            carry_count = int(counts[-1])
            if len(at):
                span_end = a + int(at[-1]) + 1
                self._take(counts[:-1], line_start, span_end, line_no)
                line_no += len(at)
                line_start = span_end
            if bar is not None:
                bar.update(b - a)
        if line_start < end:  # a last line without a line break
            self._take(np.array([carry_count]), line_start, end, line_no)
        return self._result()

    def _read_text(self, bar: Any) -> tuple[FloatArray, list[str]]:
        """:meth:`read` for a motion section that is not plain ASCII (other whitespace, other letters):
        a window of whole lines at a time is decoded and its words counted as ``str.split`` finds them."""
        raw, end = self.raw, len(self.raw)
        a, line_no = self.start, self.first_line
        has_cr = raw.find(b"\r", a) >= 0
        while a < end:
            q = min(a + WINDOW_BYTES, end)
            found = [i for i in (raw.find(b"\n", q), raw.find(b"\r", q) if has_cr else -1) if i >= 0]
            b = min(found) + 1 if found else end
            if raw[b - 1:b + 1] == b"\r\n":
                b += 1
            lines = raw[a:b].decode(self.encoding).replace("\r\n", "\n").replace("\r", "\n").split("\n")
            if b < end or raw[b - 1] in b"\r\n":
                lines.pop()  # what follows the window's last line break: the next window's first line
            counts = np.array([len(x.split()) if len(x) <= _SPLIT_MAX_CHARS else sum(1 for _ in _WORD.finditer(x))
                               for x in lines], dtype=np.int64)
            del lines
            self._take(counts, a, b, line_no)
            line_no += len(counts)
            if bar is not None:
                bar.update(b - a)
            a = b
        return self._result()

    def _take(self, counts: npt.NDArray[np.int64], start: int, end: int, first: int) -> None:
        """Take the complete lines in bytes ``start:end``, with ``counts`` values each, the first
        numbered ``first``."""
        idx = np.flatnonzero(counts)
        m = len(idx)
        if not m:
            return
        if not self.extra_line and self.n_rows + m > self.n_frames:
            self.extra_line = first + int(idx[max(self.n_frames - self.n_rows, 0)])
        self.last_line = first + int(idx[-1])
        if self.bad_count is None:
            wrong = np.flatnonzero(counts[idx] != self.n_ch)
            if len(wrong):
                k = int(idx[wrong[0]])
                self.bad_count = (first + k, int(counts[k]))
        if self.bad_count is None and self.bad_value is None:
            self._grow(self.n_rows + m)
            self._values(start, end, first, m)
        self.n_rows += m

    def _grow(self, rows: int) -> None:
        if rows <= len(self.rows):
            return
        bigger = np.empty((min(max(rows, 2 * len(self.rows)), max(rows, self.max_rows)), self.n_ch))
        bigger[:self.n_rows] = self.rows[:self.n_rows]
        self.rows = bigger

    def _values(self, start: int, end: int, first: int, m: int) -> None:
        """Parse the values of the m frame lines in bytes ``start:end`` into the next m rows."""
        chunk = self.raw[start:end]
        out = self.rows[self.n_rows:self.n_rows + m]
        if self.plain or _IS_PLAIN[np.frombuffer(chunk, dtype=np.uint8)].all():
            try:
                with warnings.catch_warnings():
                    # numpy < 2.3 warns, and returns what it read, where it meets a word that is no number
                    warnings.simplefilter("ignore", DeprecationWarning)
                    values = np.fromstring(chunk, sep=" ")
            except ValueError:
                values = None
            if values is not None and values.size == out.size and np.isfinite(values).all():
                out[:] = values.reshape(out.shape)
                return
        # not plain numbers: value by value, as float() reads them, to find the first that is wrong
        r = 0
        text = chunk.decode(self.encoding).replace("\r\n", "\n").replace("\r", "\n")
        del chunk
        for k, line in enumerate(text.split("\n")):
            toks = line.split()
            if not toks:
                continue
            for c, word in enumerate(toks):
                try:
                    out[r, c] = v = float(word)
                except ValueError:
                    self.bad_value = (first + k, c, word)
                    return
                if self.not_finite is None and not math.isfinite(v):
                    self.not_finite = (first + k, c, word)
            r += 1

    def _result(self) -> tuple[FloatArray, list[str]]:
        path, n_frames, n_rows = self.path, self.n_frames, self.n_rows
        if n_rows < n_frames:
            raise BVHError(f"truncated motion: 'Frames: {n_frames}' but only {n_rows} frame lines follow", path,
                           self.last_line or self.frames_line)
        if self.bad_count is not None:
            line, got = self.bad_count
            raise BVHError(f"expected {self.n_ch} values on a frame line (the hierarchy's channel count), got {got}",
                           path, line)
        notes = []
        if n_rows > n_frames:
            # every extra line is a whole frame (checked above): an exporter's count off by a frame or a few
            # (one take exported twice, 418 and 1392 declared, one more row each); the rows are the motion
            notes.append(f"'Frames: {n_frames}' but {n_rows} whole frame lines follow (line {self.extra_line} on): "
                         f"all {n_rows} read")
        bad, inf = self.bad_value, self.not_finite
        if bad is not None and inf is not None and inf[:2] < bad[:2]:
            raise BVHError(f"a frame value must be finite, got {inf[2]!r}", path, inf[0])
        if bad is not None:
            raise BVHError(f"expected a number for a frame value, got {bad[2]!r}", path, bad[0])
        if inf is not None:
            raise BVHError(f"frame values must be finite, got {inf[2]!r}", path, inf[0])
        return (self.rows if len(self.rows) == n_rows else self.rows[:n_rows].copy()), notes


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


#: Frames converted to rotations at a time: the temporaries of the Euler-to-quaternion products stay a
#: few MiB however long the clip (a whole clip at once would need several times the rotations' size).
FRAME_BLOCK = 1024


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
    columns = {order: np.array([[col[i] + k for k, c in enumerate(sk.channels[i]) if c in ROTATION_CHANNELS]
                                for i in joints]) for order, joints in by_order.items()}  # (n, len(order))
    for s in range(0, t, FRAME_BLOCK):
        block = quats[s:s + FRAME_BLOCK]
        for order, joints in by_order.items():
            block[:, joints] = euler_to_quat(order, data[s:s + FRAME_BLOCK][:, columns[order]])
        block[:] = canonical_quat(block)
    moving = [i for i in range(1, j) if sk.has_positions(i)]
    # local translations of every joint only where a joint below the root moves: else the root's alone
    trans = np.broadcast_to(sk.offsets, (t, j, 3)).copy() if moving else np.tile(sk.offsets[0], (t, 1))[:, None]
    for i in range(j):
        if not sk.has_positions(i):
            continue
        vals = trans[:, i]  # a view: written in place
        vals[:] = sk.offsets[i]  # in either mode an axis without a channel keeps the OFFSET component
        for k, c in enumerate(sk.channels[i]):
            if c in POSITION_CHANNELS:
                a = POSITION_CHANNELS.index(c)
                vals[:, a] = data[:, col[i] + k] + (sk.offsets[i][a] if sk.position_modes[i] == "add" else 0.0)
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
    reading scored nearly as well, how to force one. A file over :data:`PROGRESS_MIN_BYTES` shows a
    progress bar while it is read, when stderr is a terminal.

    Returns:
        The motion (``unit`` and ``up`` set to the guess or the given values) and what was found.

    Raises:
        BVHError: the file is malformed; the message names the file, the line and what was expected.
    """
    p = str(path)
    try:
        raw = read_input_bytes(p, "bvh")
    except InputError as exc:
        raise BVHError(exc.reason, p) from None
    bar = progress_bar(len(raw), f"reading {os.path.basename(p)}", "B") if len(raw) > PROGRESS_MIN_BYTES else None
    if bar is not None:  # bytes shown as KiB, MiB
        bar.unit_scale, bar.unit_divisor = True, 1024
        bar.refresh()
    try:
        sk, frame_time, data, info, _ = _parse(p, raw, len(UTF8_BOM) if raw.startswith(UTF8_BOM) else 0, bar)
    finally:
        if bar is not None:
            bar.close()
    del raw  # the values are read: the file's bytes need not stay while the readings are compared
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
    atomic_write_text(path, bvh_text(motion, precision=precision))
