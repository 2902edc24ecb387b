"""Small file helpers: inputs checked and read within a size limit, output locations checked before long
work (outputs that would overwrite each other or an input refused), the manifest of what bipedsim wrote
in an output folder (the only files it replaces or deletes unasked), atomic writes that respect the
umask and leave no temporary file behind, terminal progress bars, and provenance (what made an
output)."""

from __future__ import annotations

import contextlib
import errno
import functools
import hashlib
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

import bipedsim
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


# ---------------------------------------------------------------------- what bipedsim wrote in a folder
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

    return {"bipedsim": bipedsim.__version__, "mujoco": mujoco.__version__, "numpy": numpy.__version__,
            "scipy": scipy.__version__, "python": platform.python_version()}
