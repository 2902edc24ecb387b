"""One line for an operating-system error: its reason without the path, and what a command could not do
where (cannot write / cannot access, the file or files, the reason)."""

from __future__ import annotations

import errno


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
