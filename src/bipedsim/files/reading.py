"""Reading inputs safely: every input file checked to be a regular file within the size limit for its
kind (raised with ``BIPEDSIM_MAX_<KIND>_MB``) and read a chunk at a time up to that limit, text decoded as
UTF-8 with the line of the first bad byte, and what a parsed JSON value is, for messages."""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

from bipedsim.errors import InputError
from bipedsim.files.os_errors import os_reason

#: The largest input file read, per kind (MiB). Each can be raised for one command with the environment
#: variable ``BIPEDSIM_MAX_<KIND>_MB`` (e.g. ``BIPEDSIM_MAX_BVH_MB=500``). A BVH of 64 MiB is about
#: 4 hours of a 31-joint skeleton at 120 fps; a controller, experiment or world file is a few KiB.
INPUT_LIMITS_MB: dict[str, float] = {
    "bvh": 64.0,      # motion capture
    "yaml": 4.0,      # controllers, experiments, suites, tunes, worlds, creatures, maps
    "script": 1.0,    # Motion Scripts
    "json": 64.0,     # outcome.json, experiment.json, tune state
    "csv": 256.0,     # results.csv, history.csv
    "npz": 1024.0,    # clips, graphs, trajectories (checked again by what the arrays declare)
    "xml": 64.0,      # MJCF models
    "text": 4.0,      # any other text input
}

_KIND_NAMES = {"bvh": "BVH", "yaml": "YAML", "script": "script", "json": "JSON", "csv": "CSV", "npz": "npz",
               "xml": "MJCF", "text": "text"}


def input_limit_bytes(kind: str) -> int:
    """The size limit (bytes) for inputs of ``kind`` (a key of :data:`INPUT_LIMITS_MB`), raised or
    lowered by ``BIPEDSIM_MAX_<KIND>_MB`` when that is set to a positive number."""
    env = f"BIPEDSIM_MAX_{kind.upper()}_MB"
    mb = INPUT_LIMITS_MB[kind]
    text = os.environ.get(env)
    if text:
        try:
            mb = float(text)
        except ValueError:
            raise InputError(f"{env}={text!r}: expected a number of MiB") from None
        if not (mb > 0 and mb < float("inf")):
            raise InputError(f"{env}={text!r}: expected a positive number of MiB")
    return int(mb * 1024 * 1024)


def _limit_hint(kind: str) -> str:
    return f"set BIPEDSIM_MAX_{kind.upper()}_MB to read larger {_KIND_NAMES[kind]} files"


def _too_large(path: Path, kind: str, size: int | None) -> InputError:
    limit = input_limit_bytes(kind)
    found = f"is {size / 2**20:.1f} MiB" if size is not None else "is larger than that"
    return InputError(f"{found}, above the {limit / 2**20:g} MiB limit for {_KIND_NAMES[kind]} "
                      f"files ({_limit_hint(kind)})", path)


def check_input_file(path: str | os.PathLike[str], kind: str) -> Path:
    """Make sure ``path`` is a regular file this process may read and within the size limit for
    ``kind``, without opening it: missing files, folders, devices (``/dev/zero``), pipes and sockets are
    refused with :class:`~bipedsim.errors.InputError` naming the file and what it is."""
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError("no such file", p) from None
    except OSError as exc:
        raise InputError(f"cannot read: {os_reason(exc)}", p) from None
    mode = st.st_mode
    if stat.S_ISDIR(mode):
        raise InputError(f"is a folder, not a {_KIND_NAMES[kind]} file", p)
    if not stat.S_ISREG(mode):
        what = ("a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "a pipe" if stat.S_ISFIFO(mode)
                else "a socket" if stat.S_ISSOCK(mode) else "not a regular file")
        raise InputError(f"is {what}, not a {_KIND_NAMES[kind]} file; give a regular file", p)
    if st.st_size > input_limit_bytes(kind):
        raise _too_large(p, kind, st.st_size)
    return p


#: Bytes read at a time from an input file.
READ_CHUNK_BYTES = 1 << 20


def read_input_bytes(path: str | os.PathLike[str], kind: str) -> bytes:
    """The bytes of the input file ``path`` of ``kind`` (see :func:`check_input_file`), never more than
    its limit: a file that grows while it is read, or reports a size of 0 (``/proc``), is cut off at the
    limit and refused."""
    p = check_input_file(path, kind)
    limit = input_limit_bytes(kind)
    chunks, total = [], 0
    try:
        with open(p, "rb") as f:  # in chunks: f.read(limit + 1) would allocate the whole limit up front
            while chunk := f.read(READ_CHUNK_BYTES):
                total += len(chunk)
                if total > limit:
                    raise _too_large(p, kind, None)
                chunks.append(chunk)
    except OSError as exc:
        raise InputError(f"cannot read: {os_reason(exc)}", p) from None
    return b"".join(chunks)


def decode_text(data: bytes, path: str | os.PathLike[str]) -> str:
    """``data`` as UTF-8 text (a leading byte-order mark dropped); bytes that are not UTF-8 raise
    :class:`~bipedsim.errors.InputError` with the line and offset of the first one."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise InputError(f"line {line}: not UTF-8 text (byte {data[exc.start:exc.start + 1]!r} at offset "
                         f"{exc.start})", path) from None


def read_input_text(path: str | os.PathLike[str], kind: str = "text") -> str:
    """The UTF-8 text of the input file ``path`` of ``kind``, read within its limit (see
    :func:`read_input_bytes` and :func:`decode_text`)."""
    return decode_text(read_input_bytes(path, kind), path)


def json_kind(value: Any) -> str:
    """What a parsed JSON value is, in JSON's words (for a message about a file holding the wrong kind)."""
    if value is None or isinstance(value, bool):
        return {None: "null", True: "true", False: "false"}[value]
    kinds = {dict: "object", list: "array", str: "string", int: "number", float: "number"}
    return kinds.get(type(value), type(value).__name__)
