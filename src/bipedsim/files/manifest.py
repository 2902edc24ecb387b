"""What bipedsim wrote in an output folder: the manifest (``.bipedsim-manifest.json``) of each file's
SHA-256 and size, by which a command proves a file is its own before it replaces or deletes it unasked
(:class:`OutputFolder`); anything else in the folder is left alone."""

from __future__ import annotations

import hashlib
import json
import os
import stat
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from bipedsim.errors import OutputError
from bipedsim.files.os_errors import os_reason
from bipedsim.files.writing import atomic_write_json

#: The manifest in each output folder: the files bipedsim wrote there, with their SHA-256 and size.
MANIFEST_FILE = ".bipedsim-manifest.json"
MANIFEST_FORMAT = "bipedsim output manifest"
MANIFEST_VERSION = 1
#: The largest manifest read (bytes): an entry is about 120 bytes, a run folder holds about ten.
MANIFEST_LIMIT_BYTES = 1 << 20
_HASH_CHUNK = 1 << 20


def file_digest(path: str | os.PathLike[str]) -> tuple[str, int]:
    """The SHA-256 (hex) and size (bytes) of the file ``path``, read in chunks."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        while chunk := f.read(_HASH_CHUNK):
            h.update(chunk)
            size += len(chunk)
    return h.hexdigest(), size


def _plain_name(name: object) -> bool:
    return (isinstance(name, str) and name not in ("", ".", "..", MANIFEST_FILE) and "/" not in name
            and "\\" not in name and "\0" not in name)


def _valid_entry(entry: object) -> bool:
    if not isinstance(entry, dict):
        return False
    digest, size = entry.get("sha256"), entry.get("size")
    return (isinstance(digest, str) and len(digest) == 64 and all(c in "0123456789abcdef" for c in digest)
            and isinstance(size, int) and not isinstance(size, bool) and size >= 0)


class OutputFolder:
    """A folder a command writes files of fixed names into (``bipedsim run --out``, ``bipedsim render
    RUN_DIR``), with its manifest (:data:`MANIFEST_FILE`): each file bipedsim wrote there, by name,
    with its SHA-256 and size, recorded by the command that wrote it (the manifest is replaced
    atomically).

    A command replaces or deletes a file it was not asked for by name only when the manifest proves it
    is bipedsim's: listed, a regular file, and the same bytes (the user has not replaced or edited it).
    Anything else in the folder is left alone."""

    def __init__(self, folder: str | os.PathLike[str], flag: str = "--out") -> None:
        self.path = Path(folder)
        self.flag = flag
        self.files: dict[str, dict[str, Any]] = self._read()

    @property
    def manifest_path(self) -> Path:
        return self.path / MANIFEST_FILE

    def _refuse(self, why: str) -> OutputError:
        return OutputError(f"{self.flag} {self.path}: {MANIFEST_FILE} {why}; move it away or choose another "
                           f"{self.flag}")

    def _read(self) -> dict[str, dict[str, Any]]:
        """The manifest's entries (plain names only; an entry that is not a name, a SHA-256 and a size
        proves nothing and is dropped). No manifest: none. A manifest that bipedsim did not write (a
        link, a folder, other JSON) or a newer one is refused: replacing it would lose it."""
        p = self.manifest_path
        try:
            st = os.lstat(p)
        except (FileNotFoundError, NotADirectoryError):  # no folder yet, or not a folder: its own check says so
            return {}
        except OSError as exc:
            raise self._refuse(f"cannot be read ({os_reason(exc)})") from None
        if not stat.S_ISREG(st.st_mode):
            raise self._refuse("is not a regular file")
        if st.st_size > MANIFEST_LIMIT_BYTES:
            raise self._refuse(f"is {st.st_size} bytes, more than a manifest holds")
        try:
            with open(p, "rb") as f:
                data = json.loads(f.read(MANIFEST_LIMIT_BYTES + 1).decode("utf-8"))
        except OSError as exc:
            raise self._refuse(f"cannot be read ({os_reason(exc)})") from None
        except (UnicodeDecodeError, ValueError, RecursionError):
            raise self._refuse("is not a bipedsim manifest (not JSON)") from None
        if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT:
            raise self._refuse("is not a bipedsim manifest")
        version = data.get("version")
        if not isinstance(version, int) or version > MANIFEST_VERSION:
            raise self._refuse(f"is of a newer bipedsim (version {version!r}; this one reads {MANIFEST_VERSION})")
        files = data.get("files")
        if not isinstance(files, dict):
            return {}
        return {n: {"sha256": e["sha256"], "size": e["size"]} for n, e in files.items()
                if _plain_name(n) and _valid_entry(e)}

    def proves(self, name: str) -> bool:
        """Whether the file ``name`` in the folder is one bipedsim wrote, unchanged since (a regular
        file, not a link, whose size and SHA-256 are the manifest's)."""
        entry = self.files.get(name)
        if entry is None:
            return False
        p = self.path / name
        try:
            st = os.lstat(p)
            if not stat.S_ISREG(st.st_mode) or st.st_size != entry["size"]:
                return False
            return file_digest(p)[0] == entry["sha256"]
        except OSError:
            return False

    def check_replaceable(self, names: Iterable[str], *, hint: str = "") -> None:
        """Refuse, before any work, to replace a file of ``names`` (plain names of files the command
        writes into the folder without being asked by name) that bipedsim cannot prove it wrote:
        :class:`OutputError` naming the folder's flag and the files. ``hint``: what else the user
        can do, added to the message."""
        foreign = [n for n in dict.fromkeys(names) if os.path.lexists(self.path / n) and not self.proves(n)]
        if foreign:
            them = "it" if len(foreign) == 1 else "them"
            raise OutputError(f"{self.flag} {self.path}: would replace {', '.join(foreign)}, which bipedsim cannot "
                              f"prove it wrote (not in {MANIFEST_FILE}, or changed since); move {them} away or "
                              f"choose another {self.flag}{hint}")

    def sort_stale(self, known: Iterable[str], keep: Iterable[str]) -> tuple[list[str], list[str]]:
        """Of the files named in ``known`` (what a run writes into such a folder) that are present and
        not in ``keep`` (what this run writes again): those bipedsim proves it wrote (stale: another
        run's) and the others (left alone), each in ``known``'s order."""
        keep_set = set(keep)
        stale, foreign = [], []
        for name in dict.fromkeys(known):
            if name in keep_set or not os.path.lexists(self.path / name):
                continue
            (stale if self.proves(name) else foreign).append(name)
        return stale, foreign

    def remove_stale(self, known: Iterable[str], keep: Iterable[str]) -> tuple[list[str], list[str]]:
        """Delete what an earlier run wrote here (named in ``known``, not in ``keep``) and the manifest
        proves unchanged, so that the folder does not mix two runs' outputs; everything else is left
        alone. Returns (names removed, names left alone), in ``known``'s order."""
        stale, foreign = self.sort_stale(known, keep)
        removed = []
        for name in stale:
            try:
                (self.path / name).unlink()
            except FileNotFoundError:
                pass
            except OSError as exc:
                raise OutputError(f"cannot remove stale {self.path / name} from an earlier run: "
                                  f"{os_reason(exc)}") from None
            self.files.pop(name, None)
            removed.append(name)
        if removed:
            self.save()
        return removed, foreign

    def record(self, *paths: str | os.PathLike[str]) -> None:
        """Add the files ``paths`` (just written by this command) to the manifest, with their SHA-256 and
        size, and save it; paths outside the folder are not its business and are skipped."""
        here = os.path.realpath(self.path)
        changed = False
        for path in paths:
            p = Path(path)
            if os.path.realpath(p.parent) != here or not _plain_name(p.name):
                continue
            try:
                if not stat.S_ISREG(os.lstat(p).st_mode):
                    continue
                digest, size = file_digest(p)
            except OSError:
                continue
            self.files[p.name] = {"sha256": digest, "size": size}
            changed = True
        if changed:
            self.save()

    def save(self) -> None:
        """Write the manifest (atomically: a reader sees the old one or the new one)."""
        atomic_write_json(self.manifest_path, {"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION,
                                               "files": dict(sorted(self.files.items()))})
