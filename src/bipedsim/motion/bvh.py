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

The work is done by the modules beside this one: :mod:`~bipedsim.motion.bvh_bytes` (text encoding, line
endings, the frame lines read from the bytes), :mod:`~bipedsim.motion.bvh_parse` (the hierarchy and the
MOTION header; :class:`BVHInfo`), :mod:`~bipedsim.motion.bvh_reading` (position modes and up axis chosen
by scoring), :mod:`~bipedsim.motion.bvh_channels` (channels to motion and back) and
:mod:`~bipedsim.motion.bvh_write`; this module reads a file through them and re-exports their public names.
"""

from __future__ import annotations

import math
import os

import numpy as np

from bipedsim.errors import BVHError, InputError
from bipedsim.files import progress_bar, read_input_bytes
from bipedsim.motion.bvh_bytes import MAX_HEADER_LINE_BYTES
from bipedsim.motion.bvh_channels import FRAME_BLOCK, _column_starts, euler_to_quat, motion_to_channels
from bipedsim.motion.bvh_parse import FRAME_TIME_RANGE_S, BVHInfo, _parse
from bipedsim.motion.bvh_reading import (
    POSITION_MODE_NAMES,
    SIZE_SAMPLE_FRAMES,
    _candidate_modes,
    _choose_reading,
    _forced_modes,
    _position_modes,
    _sample_points,
)
from bipedsim.motion.bvh_write import bvh_text, write_bvh
from bipedsim.motion.conventions import UNIT_SCALES, guess_unit, leg_stature
from bipedsim.motion.lead_in import drop_lead_in
from bipedsim.motion.motion import Motion

__all__ = [
    "FRAME_BLOCK", "FRAME_TIME_RANGE_S", "GIVEN_SCALE_SIZE_RANGE_M", "MAX_HEADER_LINE_BYTES", "POSITION_MODE_NAMES",
    "PROGRESS_MIN_BYTES", "SIZE_SAMPLE_FRAMES", "UTF8_BOM", "BVHInfo", "bvh_text", "euler_to_quat", "load_bvh",
    "motion_to_channels", "read_bvh", "write_bvh",
]

#: A UTF-8 byte-order mark, which some editors write at the start of a text file: dropped before parsing.
UTF8_BOM = b"\xef\xbb\xbf"
#: Plausible size (m) of any body -- its height if upright, else its largest extent -- once a scale
#: the caller gave is applied: from an insect to a dinosaur. Outside it, the scale is wrong (``--scale
#: 1`` on a centimetre file makes a 183 m person); the guessed ranges in ``conventions`` are narrower.
GIVEN_SCALE_SIZE_RANGE_M = (0.02, 30.0)
#: A BVH larger than this (bytes) shows a progress bar while its frames are read, on a terminal.
PROGRESS_MIN_BYTES = 5 << 20


#: The largest value a BVH file may hold (an OFFSET, a position or an angle, in the file's own units): a
#: billion millimetres is 1000 km, a billion degrees nearly 3 million turns. Larger numbers are corrupt, and
#: would overflow the arithmetic that chooses the file's reading.
MAX_FILE_VALUE = 1e9


def _check_magnitudes(offsets: np.ndarray, data: np.ndarray, path: str) -> None:
    """Refuse a file whose OFFSETs or frame values pass :data:`MAX_FILE_VALUE`, naming the first one."""
    if offsets.size and np.abs(offsets).max() > MAX_FILE_VALUE:
        raise BVHError(f"an OFFSET of {np.abs(offsets).max():g} file units: larger than {MAX_FILE_VALUE:g}, "
                       "the file's numbers are corrupt", path)
    if data.size:
        big = np.abs(data).max(axis=1) > MAX_FILE_VALUE
        if big.any():
            row = int(np.flatnonzero(big)[0])
            raise BVHError(f"frame {row + 1} holds a value of {np.abs(data[row]).max():g}: larger than "
                           f"{MAX_FILE_VALUE:g} (file units or degrees), the file's numbers are corrupt", path)


def read_bvh(path: str | os.PathLike[str], *, scale: float | str | None = None,
             up: str | None = None, positions: str | None = None,
             upright: bool | None = None, fps: float | None = None, lead_in: bool = True) -> tuple[Motion, BVHInfo]:
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
        lead_in: drop the leading frames that are no part of the take (a T-pose or rest pose before the
            capture, :func:`~bipedsim.motion.lead_in.lead_in_frames`): ``info.lead_in_frames`` says how
            many, a line in ``info.notes`` why, and ``info.num_frames`` counts the frames kept.

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
    _check_magnitudes(sk.offsets, data, p)
    info.file_frame_time = frame_time
    if fps is not None:
        frame_time = info.frame_time = _given_frame_time(fps, p)
        info.frame_time_source = "given"
    if up is not None and up.lower() not in ("y", "z"):
        raise BVHError(f"up axis must be 'y' or 'z', got {up!r}", p)
    ups = (up.lower(),) if up is not None else ("y", "z")

    def reading(values: np.ndarray) -> tuple[Motion, str, str, str, dict[str, str]]:
        """The most plausible reading of the frame values (motion, up axis, why, note) and why each
        joint's position channels were read as they were."""
        if positions is None:
            modes, reasons, weak = _position_modes(sk, values, _column_starts(sk))
            mode_options = _candidate_modes(sk, modes, weak)
        else:
            mode_options = [_forced_modes(sk, positions, p)]
            reasons = {sk.names[j]: "given by the caller" for j in range(sk.num_joints) if sk.has_positions(j)}
        return (*_choose_reading(sk, frame_time, values, mode_options, ups), reasons)

    motion, info.up, up_reason, note, reasons = reading(data)
    if lead_in:  # a T-pose before the take: the reading is chosen again on the take alone
        _, info.lead_in_frames = drop_lead_in(motion, info.notes)
        if info.lead_in_frames:
            motion, info.up, up_reason, note, reasons = reading(data[info.lead_in_frames:])
            info.num_frames = motion.num_frames
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
