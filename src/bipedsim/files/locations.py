"""Output locations checked before long work: an output folder created and probed for writing, an output
file's folder and suffix checked, and outputs that would overwrite each other or one of the command's
inputs refused (paths compared as the files they name: links resolved, hard links by inode)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from pathlib import Path

from bipedsim.errors import OutputError
from bipedsim.files.os_errors import os_reason
from bipedsim.files.writing import _unlink_quietly


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
    except OSError as exc:
        raise OutputError(f"{what}: cannot write in {folder}: {os_reason(exc)}") from None
    try:
        os.close(fd)
    finally:  # a signal between the two leaves no probe behind
        _unlink_quietly(tmp)


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
    (lower case, with the dot), ending in one of them. Raises :class:`OutputError` naming ``flag``.

    An existing regular file at ``path`` is no obstacle: a path given on the command line is the
    user's request to write there (as with any Unix tool); only files a command would replace or
    delete without being asked must be its own (:class:`OutputFolder`)."""
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


# ---------------------------------------------------------------------- outputs that collide
#: One path a command names, with how the message calls it: ``("--csv", "a.csv")``,
#: ``("the --out file", "run/outcome.json")``; a path of None is not given and skipped.
NamedPath = tuple[str, str | os.PathLike[str] | None]


def _file_identity(path: str | os.PathLike[str]) -> tuple[str, tuple[int, int] | None]:
    """The file ``path`` names: its absolute path with every link resolved (the file need not exist)
    and, when it exists, its device and inode (a hard link, or a case-insensitive file system)."""
    real = os.path.normcase(os.path.realpath(os.path.abspath(os.fspath(path))))
    try:
        st = os.stat(real)
    except OSError:
        return real, None
    return real, (st.st_dev, st.st_ino)


def _same(a: tuple[str, tuple[int, int] | None], b: tuple[str, tuple[int, int] | None]) -> bool:
    return a[0] == b[0] or (a[1] is not None and a[1] == b[1])


def check_distinct_paths(outputs: Iterable[NamedPath], inputs: Iterable[NamedPath] = ()) -> None:
    """Refuse, before any work, a command whose outputs would overwrite each other or one of its inputs:
    every pair of ``outputs`` and every output against every one of ``inputs`` are compared as the
    files they name (links resolved, relative paths against the working folder). Raises
    :class:`OutputError`, one line naming both (their labels and paths); writes and creates nothing."""
    outs = [(label, p, _file_identity(p)) for label, p in outputs if p is not None and os.fspath(p) != ""]
    ins = [(label, p, _file_identity(p)) for label, p in inputs if p is not None and os.fspath(p) != ""]
    for i, (la, pa, ia) in enumerate(outs):
        for lb, pb, ib in outs[:i]:
            if _same(ia, ib):
                raise OutputError(f"{lb} {pb} and {la} {pa} are the same file: one output would overwrite the "
                                  "other; give each its own path")
        for lb, pb, ib in ins:
            if _same(ia, ib):
                raise OutputError(f"{la} {pa} would overwrite {lb} {pb}, an input of this command; give the "
                                  "output another path")


def folder_files(label: str, folder: str | os.PathLike[str], names: Iterable[str]) -> list[NamedPath]:
    """``(label, folder/name)`` for each of ``names``: the files a command writes into a folder, for
    :func:`check_distinct_paths`."""
    return [(label, Path(folder) / n) for n in names]
