"""A BVH file's bytes: its text encoding and line endings, its header lines one at a time, and its frame
lines read straight from the bytes into one float array, a window (:data:`WINDOW_BYTES`) at a time.

Every problem raises :class:`~bipedsim.errors.BVHError` naming the file and the line.
"""

from __future__ import annotations

import codecs
import math
import re
import warnings
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.errors import BVHError

FloatArray = npt.NDArray[np.float64]

#: Bytes of the motion section parsed at a time: the temporary arrays of one window are a few times
#: its size, so reading stays within a small multiple of the file's own size whatever its length.
WINDOW_BYTES = 1 << 20
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
