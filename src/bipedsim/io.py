"""Small file helpers: inputs checked and read within a size limit, output locations checked before long
work, atomic writes that respect the umask, stale-output clean-up, terminal progress bars, and provenance
(what made an output)."""

from __future__ import annotations

import contextlib
import errno
import functools
import json
import os
import platform
import shutil
import stat
import sys
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any

from bipedsim.errors import InputError, OutputError

#: Permissions a new file gets before the umask, as ``open(path, "w")`` would give it.
NEW_FILE_MODE = 0o666
#: Terminal size (columns, rows) used where the terminal reports none (0 x 0: some pseudo-terminals,
#: CI consoles, containers started without a size), where tqdm would otherwise draw nothing.
FALLBACK_SIZE = (80, 24)

_umask_lock = threading.Lock()


def os_reason(exc: OSError) -> str:
    """The human part of an OSError ("Permission denied", "Read-only file system"), without the path."""
    return exc.strerror or str(exc) or type(exc).__name__


#: errno values that only a write raises: for these the message says "cannot write".
WRITE_ERRNOS = {errno.ENOSPC, errno.EROFS, errno.EDQUOT, errno.EFBIG, errno.EISDIR}


def describe_os_error(exc: OSError) -> str:
    """One line for an OSError that reached the command line: what, where and why (cannot write / cannot
    access, the file or files, the reason)."""
    where = exc.filename if exc.filename is not None else "a file"
    target = f" -> {exc.filename2}" if exc.filename2 is not None else ""
    verb = "cannot write" if exc.errno in WRITE_ERRNOS else "cannot access"
    return f"{verb} {where}{target}: {os_reason(exc)}"


@functools.cache
def process_umask() -> int:
    """The process's umask, read once. Linux reports it in /proc/self/status without changing it;
    elsewhere it is read by setting and restoring it, under a lock, once per process."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    with _umask_lock:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


# ---------------------------------------------------------------------- reading inputs
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


def read_input_bytes(path: str | os.PathLike[str], kind: str) -> bytes:
    """The bytes of the input file ``path`` of ``kind`` (see :func:`check_input_file`), never more than
    its limit: a file that grows while it is read, or reports a size of 0 (``/proc``), is cut off at the
    limit and refused."""
    p = check_input_file(path, kind)
    limit = input_limit_bytes(kind)
    try:
        with open(p, "rb") as f:
            data = f.read(limit + 1)
    except OSError as exc:
        raise InputError(f"cannot read: {os_reason(exc)}", p) from None
    if len(data) > limit:
        raise _too_large(p, kind, None)
    return data


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


# ---------------------------------------------------------------------- checking output locations
def _make_folder(folder: Path, what: str) -> None:
    """Create ``folder`` (and its parents) or raise :class:`OutputError` saying why not."""
    if folder.is_dir():
        return
    if folder.exists() or folder.is_symlink():
        raise OutputError(f"{what}: {folder} exists and is not a folder")
    for anc in folder.parents:
        if anc.exists():
            if not anc.is_dir():
                raise OutputError(f"{what}: cannot create folder {folder}: {anc} is a file, not a folder")
            break
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{what}: cannot create folder {folder}: {os_reason(exc)}") from None


def _probe_writable(folder: Path, what: str) -> None:
    """Create and remove a file in ``folder``: the only check that sees permissions, read-only mounts
    and access control alike (``os.access`` says yes to root on a read-only mount)."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".bipedsim-probe-", dir=folder)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise OutputError(f"{what}: cannot write in {folder}: {os_reason(exc)}") from None


def prepare_output_dir(path: str | os.PathLike[str], flag: str) -> Path:
    """Make sure ``path`` is a folder this process can write in, creating it (and its parents) when it
    is missing. Raises :class:`OutputError` naming ``flag`` (e.g. ``"--out"``), the path and the cause
    when it is a file, lies under a file, or cannot be created or written in."""
    p = Path(path)
    what = f"{flag} {p}"
    if p.exists() and not p.is_dir():
        raise OutputError(f"{what}: is an existing file; give a folder")
    _make_folder(p, what)
    _probe_writable(p, what)
    return p


def check_output_file(path: str | os.PathLike[str], flag: str, suffixes: tuple[str, ...] = ()) -> Path:
    """Make sure a file can be written at ``path``: not a folder, its folder creatable (created now, as
    every command creates missing output folders) and writable, and, when ``suffixes`` are given
    (lower case, with the dot), ending in one of them. Raises :class:`OutputError` naming ``flag``."""
    p = Path(path)
    what = f"{flag} {p}"
    if p.is_dir():  # before the suffix: a folder named x.bvh is still a folder
        raise OutputError(f"{what}: is a folder; give a file name")
    if suffixes and p.suffix.lower() not in suffixes:
        raise OutputError(f"{what}: must end in {' or '.join(suffixes)}")
    if p.exists() and not p.is_file():
        # outputs are written beside and renamed over: that would replace a device such as /dev/null
        raise OutputError(f"{what}: is not a regular file (a device, pipe or socket); give a file name")
    _make_folder(p.parent, what)
    _probe_writable(p.parent, what)
    return p


def remove_stale(folder: str | os.PathLike[str], known: Iterable[str], keep: Iterable[str]) -> list[str]:
    """Delete the files named in ``known`` (plain names inside ``folder``) that are not in ``keep``:
    what an earlier job wrote there and this one will not rewrite. Nothing else is touched. Returns the
    names removed, in ``known``'s order."""
    keep_set = set(keep)
    removed = []
    for name in known:
        p = Path(folder) / name
        if name in keep_set or not p.is_file():
            continue
        try:
            p.unlink()
        except OSError as exc:
            raise OutputError(f"cannot remove stale {p} from an earlier run: {os_reason(exc)}") from None
        removed.append(name)
    return removed


# ---------------------------------------------------------------------- atomic writes
@contextlib.contextmanager
def atomic_writer(path: str | os.PathLike[str]) -> Iterator[IO[bytes]]:
    """A binary file to write ``path`` through: a temporary file in the same folder, renamed over
    ``path`` when the block ends without an error (a reader never sees half a file), removed otherwise.
    The file gets ``0666 & ~umask`` like any file the user's programs create (``mkstemp`` makes
    ``0600``). Errors from the file system raise :class:`OutputError` naming the path."""
    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    except OSError as exc:
        raise OutputError(f"cannot write {p}: {os_reason(exc)}") from None
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
            os.fchmod(f.fileno(), NEW_FILE_MODE & ~process_umask())
        os.replace(tmp, p)
    except OSError as exc:
        _unlink_quietly(tmp)
        raise OutputError(f"cannot write {p}: {os_reason(exc)}") from None
    except BaseException:
        _unlink_quietly(tmp)
        raise


def _unlink_quietly(path: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_writer`)."""
    with atomic_writer(path) as f:
        f.write(data)


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike[str], obj: Any) -> None:
    atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=False, default=_json_default) + "\n")


def _json_default(o: Any) -> Any:
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


# ---------------------------------------------------------------------- progress
def stderr_size() -> tuple[int, int]:
    """Columns and rows of the terminal on stderr, each from :data:`FALLBACK_SIZE` where it reports 0
    (tqdm draws nothing on a terminal of 0 columns or 0 rows)."""
    try:
        cols, rows = os.get_terminal_size(sys.stderr.fileno())
    except (OSError, ValueError, AttributeError):
        cols, rows = 0, 0
    if not (cols and rows):
        fb_cols, fb_rows = shutil.get_terminal_size(FALLBACK_SIZE)
        cols, rows = cols or fb_cols or FALLBACK_SIZE[0], rows or fb_rows or FALLBACK_SIZE[1]
    return cols, rows


def progress_bar(total: float, desc: str, unit: str, *, force: bool = False, leave: bool = False) -> Any:
    """A tqdm bar on stderr when stderr is a terminal (or ``force``), else None: nothing extra goes to a
    log file or a pipe. Sized to the terminal, with a fallback size where it reports none."""
    if not (force or sys.stderr.isatty()):
        return None
    from tqdm import tqdm

    cols, rows = stderr_size()
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, ncols=cols, nrows=rows, leave=leave)


def versions() -> dict[str, str]:
    """Versions of bipedsim and the libraries that shape its results."""
    import mujoco
    import numpy
    import scipy

    import bipedsim

    return {"bipedsim": bipedsim.__version__, "mujoco": mujoco.__version__, "numpy": numpy.__version__,
            "scipy": scipy.__version__, "python": platform.python_version()}
