"""Writing outputs atomically: a temporary file in the same folder renamed over the output when complete
(a reader never sees half a file; no temporary file is left behind, on errors or signals), with the
permissions the user's umask gives a new file; bytes, text, JSON and matplotlib figures."""

from __future__ import annotations

import contextlib
import functools
import json
import os
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from bipedsim.errors import OutputError
from bipedsim.files.os_errors import os_reason

#: Permissions a new file gets before the umask, as ``open(path, "w")`` would give it.
NEW_FILE_MODE = 0o666


_umask_lock = threading.Lock()


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
    # removed on any way out but the rename: errors, Ctrl-C, and SIGTERM/SIGHUP (which the command line
    # turns into KeyboardInterrupt)
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


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: float = 100) -> None:
    """Write a matplotlib figure as a PNG at ``path`` atomically (see :func:`atomic_writer`): an
    interrupted save leaves neither half a PNG nor a temporary file."""
    with atomic_writer(path) as f:
        fig.savefig(f, format="png", dpi=dpi)


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
