"""The project's exception types.

Every error a user can cause (a malformed file, a bad configuration key, an impossible value) is raised
as a subclass of :class:`BipedsimError` with a message that says where (file, line, key) and what was
expected. The command line prints the message and exits with status 2, without a traceback.
"""

from __future__ import annotations

import os


class BipedsimError(Exception):
    """Base class of every error a user can cause."""


class BVHError(BipedsimError):
    """A BVH file that cannot be read: names the file, the line (1-based) and what was expected."""

    def __init__(self, message: str, path: str | os.PathLike[str] | None = None,
                 line: int | None = None) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        self.reason = message
        where = self.path or "<bvh>"
        if line is not None:
            where = f"{where}:{line}"
        super().__init__(f"{where}: {message}")


class ConfigError(BipedsimError):
    """A configuration file (YAML) with an unknown key, a wrong type or an impossible value."""

    def __init__(self, message: str, path: str | os.PathLike[str] | None = None,
                 key: str | None = None) -> None:
        self.path = None if path is None else str(path)
        self.key = key
        self.reason = message
        parts = [p for p in (self.path, key) if p]
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)


class ModelError(BipedsimError):
    """A skeleton or motion that cannot become a simulated body (no legs, zero-length bones...)."""


class OutputError(BipedsimError):
    """An output location that cannot be written: a folder where a file is wanted (or the reverse), a
    path under a file, no permission, a read-only or full disk. Names the flag or file and the cause."""


class InputError(BipedsimError):
    """An input that is refused before it is read: missing, a folder, a device, pipe or socket, or larger
    than the limit for its kind. Names the file, what was found and how to raise a limit."""

    def __init__(self, message: str, path: str | os.PathLike[str] | None = None) -> None:
        self.path = None if path is None else str(path)
        self.reason = message
        super().__init__(f"{self.path}: {message}" if self.path else message)
