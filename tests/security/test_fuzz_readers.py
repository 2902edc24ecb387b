"""Property-based fuzzing of every reader of user files: small valid files, mutated (bytes flipped, cut
short, words inserted or deleted, huge numbers, other encodings, a byte-order mark, CR / LF mixes, YAML
nesting and alias bombs), each either loads or raises a :class:`~bipedsim.errors.BipedsimError` -- no
other exception -- within a deadline and a memory budget.

The default run is derandomized and bounded (a few dozen examples per reader); ``-m slow`` runs many
more, randomized. A reader's failing input is printed by hypothesis as the ``blob`` to reproduce it with.
"""

from __future__ import annotations

import contextlib
import functools
import os
import tempfile
import tracemalloc
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bipedsim.errors import BipedsimError
from bipedsim.files import INPUT_LIMITS_MB

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "src" / "bipedsim" / "data"
WALK_BVH = DATA / "walk.bvh"
HORSE_BVH = DATA / "horse_walk.bvh"
DEFAULT_CONTROLLER = REPO / "controllers" / "default.yaml"

#: Most memory (bytes, as tracemalloc counts Python's and numpy's) one reader may hold at once on an input
#: of a few KiB: anything near it is an allocation sized from a number in the file, not from the file.
MEMORY_BUDGET = 96 << 20
#: The input limit (MiB) every kind gets while fuzzing: the inputs are a few KiB, and the reader's
#: buffer for the whole limit (64 MiB for a BVH) would otherwise count against the memory budget.
FUZZ_LIMIT_MB = "1"
#: The longest one example may take: a reader that loops or grows with a number in the file runs past it,
#: while the slowest example here takes a few tenths of a second (the margin is for a busy machine).
DEADLINE = timedelta(seconds=10)

#: Examples per reader in the default run: the BVH reader (cheap, and the most varied input) gets more.
EXAMPLES = {"bvh": 30, "info": 12}
DEFAULT_EXAMPLES = 8
#: How many times more examples the ``slow`` run tries, randomized.
SLOW_FACTOR = 40
_SETTINGS = {"deadline": DEADLINE, "database": None,
             "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large]}


# ---------------------------------------------------------------------- valid files to start from
def bvh_names() -> st.SearchStrategy[str]:
    return st.sampled_from(["Hips", "Spine", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg",
                            "RightFoot", "Head", "Left Arm", "Schulter_é", "joint_7", "Tail1"])


@st.composite
def bvh_files(draw: st.DrawFn) -> bytes:
    """A small valid BVH: 1-6 joints in a random tree, every rotation order, position channels on the
    root and sometimes below it, leaves with or without End Sites, 1-5 frames of values written in
    several number formats, LF / CRLF / CR line endings, tabs or spaces, with or without a final
    newline and a byte-order mark."""
    n = draw(st.integers(1, 6))
    parents = [-1] + [draw(st.integers(0, i - 1)) for i in range(1, n)]
    names = draw(st.lists(bvh_names(), min_size=n, max_size=n, unique=True))
    orders = draw(st.lists(st.permutations("XYZ"), min_size=n, max_size=n))
    positions = [draw(st.integers(0, 5)) > 0] + [draw(st.integers(0, 5)) == 0 for _ in range(n - 1)]
    end_sites = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    ind = draw(st.sampled_from(["\t", "  "]))
    kids: dict[int, list[int]] = {}
    for j, p in enumerate(parents):
        kids.setdefault(p, []).append(j)
    lines = ["HIERARCHY"]
    n_ch = 0

    def emit(j: int, depth: int) -> None:
        nonlocal n_ch
        pre = ind * depth
        off = " ".join(f"{draw(st.floats(-20, 20, allow_nan=False)):.4f}" for _ in range(3))
        chans = [f"{a}rotation" for a in orders[j]]
        if positions[j]:
            chans = ["Xposition", "Yposition", "Zposition", *chans]
        n_ch += len(chans)
        lines.extend([f"{pre}{'ROOT' if j == 0 else 'JOINT'} {names[j]}", f"{pre}{{", f"{pre}{ind}OFFSET {off}",
                      f"{pre}{ind}CHANNELS {len(chans)} {' '.join(chans)}"])
        for k in kids.get(j, []):
            emit(k, depth + 1)
        if j not in kids and end_sites[j]:
            lines.extend([f"{pre}{ind}End Site", f"{pre}{ind}{{", f"{pre}{ind * 2}OFFSET 0 5 0", f"{pre}{ind}}}"])
        lines.append(f"{pre}}}")

    emit(0, 0)
    frames = draw(st.integers(1, 5))
    fmt = draw(st.sampled_from(["{:.6f}", "{:g}", "{!r}", "{:e}", "{:.0f}"]))
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {draw(st.sampled_from(['0.0083333', '.033333', '0.01']))}"]
    for _ in range(frames):
        lines.append(" ".join(fmt.format(draw(st.floats(-180, 180, allow_nan=False))) for _ in range(n_ch)))
    eol = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    text = eol.join(lines) + (eol if draw(st.booleans()) else "")
    bom = b"\xef\xbb\xbf" if draw(st.integers(0, 4)) == 0 else b""
    return bom + text.encode("utf-8")


SEEDS: dict[str, list[str]] = {
    "controller": ["name: fuzz\ncontrol_dt: 0.004\npd:\n  gains:\n    hip: {kp: 900.0, kd: 90.0}\n"
                   "fsm:\n  state1_time: 0.3\n", ""],
    "experiment": [f"name: smoke\nseconds: 3\nafter: 1.0\ngrid:\n  controller: [{DEFAULT_CONTROLLER}]\n"
                   "  magnitude: [150, 2000]\n  direction: [90]\n  phase: [[2, 0.5]]\n",
                   f"name: r\nreference: {WALK_BVH}\nseconds: 4\nruns:\n  - {{magnitude: 100, direction: 0, "
                   "duration: 0.2, start: 2.0}\n"],
    "suite": ["name: s\nscenarios:\n  - name: walk\n    seconds: 5\n    expect: no_fall\n  - name: push\n"
              "    seconds: 5\n    pushes: [{magnitude: 60, direction: 90, duration: 0.2, state: 2, fraction: 0.5}]\n"
              "    expect: fall\n"],
    "tune": ["name: t\nparameters:\n  balance.sagittal.cd: [0.0, 1.0]\n  pd.gains.hip.kp: [700.0, 1400.0]\n"
             "evaluations: 8\nseed: 1\nsigma: 0.1\nexperiment:\n  seconds: 4\n"
             "  grid: {magnitude: [150], direction: [0, 90], duration: [0.2], phase: [[1, 0.5]]}\n"],
    "world": ['tile: 2.0\nrows:\n  - "....MM....."\n  - "S...MM....G"\n  - "..........."\n'
              "events:\n  - {kind: jump, at: [1, 2], width: 1.0}\n"],
    "creature": [f"name: horse\nclips:\n  walk: {HORSE_BVH}\n"],
    "graph": [f"name: g\nfps: 30\nk: 10\nsegment: 10\nthreshold_quantile: 0.35\nclips:\n"
              f"  - {{name: walk, file: {WALK_BVH}, tags: [WALK]}}\n"
              f"  - {{name: walk_mirror, file: {WALK_BVH}, mirror: true, end: 0.8, tags: [WALK]}}\n"
              "parts:\n  Upper-Body: {root: Spine1}\n"],
    "events": ["right: [12, 140]\nleft: [76, 1.25s]\n"],
    "breed": ["Hips: Hips\nLeftUpLeg: LeftUpLeg\nRightFoot: RightFoot\n"],
    "script": ["# Motion Script\nWALK for 3 sec\nWALK with Upper-Body WAVE_HAND for 5 sec\n"
               "WALK and WAVE_HAND for 3 sec\nIDLE\n"],
}

# ---------------------------------------------------------------------- mutations
#: Words inserted by the mutations: numbers past every range, YAML structure and tags (a Python tag must
#: be refused, never run), BVH keywords, control and non-ASCII bytes.
TOKENS: list[bytes] = [
    b"nan", b"inf", b"-inf", b"1e308", b"-1e400", b"1e-320", b"99999999999999999999999", b"-0", b"0", b"1e12",
    b"0x1F", b"1_000", b".5", b"5.", b"1.2.3", b"--1", b"true", b"null", b"~", b"''", b'"\\u0000"',
    b"{", b"}", b"[", b"]", b":", b": ", b"- ", b",", b"#", b"&a ", b"*a", b"<<: *a", b"? ", b"|", b">",
    b"!!python/object/apply:os.system ['echo pwned']", b"!!binary aGk=", b"!!set {a}", b"%YAML 1.1\n---\n",
    b"---\n", b"...\n", b"\t", b"\r", b"\r\n", b"\n", b"\x00", b"\x01", b"\x1c", b"\x7f", b"\xff", b"\xc3\xa9",
    b"\xe2\x80\xa8", b"\xc2\xa0", b"\xef\xbb\xbf", b"\xed\xa0\x80",
    b"HIERARCHY", b"ROOT", b"JOINT x", b"End Site", b"MOTION", b"Frames: 1000000000000", b"Frame Time: 1e-30",
    b"CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", b"CHANNELS 100000",
    b"OFFSET 1e300 1e300 1e300", b"Xrotation",
    b"WALK for 1000000000 sec", b"with Upper-Body", b"for", b"sec", b"1e9s",
]
#: Whole hostile files for the YAML readers: deep nesting, an alias bomb, a Python object, a duplicate key.
HOSTILE_YAML: list[bytes] = [
    b"[" * 5000 + b"]" * 5000,
    b"a: " + b"{b: " * 3000 + b"1" + b"}" * 3000,
    b"a: &a [x, x, x, x, x, x, x, x, x, x]\n" + b"".join(
        f"{c}: &{c} [{', '.join(['*' + p] * 10)}]\n".encode() for p, c in zip("abcdefgh", "bcdefghi")),
    b"!!python/object/apply:os.system ['echo pwned']\n",
    b"name: a\nname: b\n",
    b"\xff\xfe" + "name: x\n".encode("utf-16-le"),
]


@dataclass(frozen=True)
class Op:
    kind: str
    pos: int
    token: bytes
    byte: int


OPS = st.builds(Op, st.sampled_from(["flip", "bit", "cut", "insert", "delete", "drop_word", "dup_line",
                                     "swap_lines", "eol", "repeat"]),
                st.integers(0, 1 << 16), st.sampled_from(TOKENS), st.integers(0, 255))
WHOLE = st.sampled_from(["none", "none", "none", "bom", "latin-1", "utf-16", "crlf", "cr", "mixed"])


def mutate(data: bytes, ops: list[Op], whole: str) -> bytes:
    """``data`` changed by each op in turn, then as a whole (an encoding, a byte-order mark, line endings)."""
    b = bytearray(data)
    for op in ops:
        at = op.pos % (len(b) + 1)
        if op.kind == "flip" and b:
            b[min(at, len(b) - 1)] = op.byte
        elif op.kind == "bit" and b:
            b[min(at, len(b) - 1)] ^= 1 << (op.byte % 8)
        elif op.kind == "cut":
            del b[at:]
        elif op.kind == "insert":
            b[at:at] = op.token
        elif op.kind == "delete":
            del b[at:at + 1 + op.byte % 8]
        elif op.kind in ("drop_word", "dup_line", "swap_lines", "repeat"):
            sep = b" " if op.kind == "drop_word" else b"\n"
            parts = bytes(b).split(sep)
            i = op.pos % len(parts)
            if op.kind == "drop_word":
                del parts[i]
            elif op.kind == "dup_line":
                parts.insert(i, parts[i])
            elif op.kind == "swap_lines":
                k = op.byte % len(parts)
                parts[i], parts[k] = parts[k], parts[i]
            else:  # a line many times over: more frames, more joints, more commands than declared
                parts[i:i + 1] = [parts[i]] * (2 + op.byte)
            b = bytearray(sep.join(parts))
        elif op.kind == "eol":
            b = bytearray(bytes(b).replace(b"\n", [b"\r\n", b"\r", b"\n\r", b" \n"][op.byte % 4], 1 + op.byte))
    out = bytes(b)
    if whole == "bom":
        out = b"\xef\xbb\xbf" + out
    elif whole in ("latin-1", "utf-16"):
        text = out.decode("utf-8", "replace")
        out = text.encode("latin-1", "replace") if whole == "latin-1" else text.encode("utf-16")
    elif whole == "crlf":
        out = out.replace(b"\r\n", b"\n").replace(b"\n", b"\r\n")
    elif whole == "cr":
        out = out.replace(b"\r\n", b"\n").replace(b"\n", b"\r")
    elif whole == "mixed":
        out = out.replace(b"\n", b"\r", out.count(b"\n") // 2)
    return out


def mutated(seeds: st.SearchStrategy[bytes], hostile: list[bytes] = ()) -> st.SearchStrategy[bytes]:
    """A seed changed by 1-4 mutations, or (rarely) a hostile file as it is."""
    changed = st.builds(mutate, seeds, st.lists(OPS, min_size=1, max_size=4), WHOLE)
    return st.one_of(changed, st.sampled_from(hostile)) if hostile else changed


# ---------------------------------------------------------------------- the readers
@functools.cache
def walk_skeleton() -> Any:
    from bipedsim.motion import load_bvh

    return load_bvh(WALK_BVH).skeleton


def _read_script(p: Path) -> Any:
    from bipedsim.files import read_input_text
    from bipedsim.synthesis.graph.script import parse

    return parse(read_input_text(p, "script"), str(p), ("Upper-Body",))


def _info(p: Path) -> None:
    """``bipedsim info FILE``: the facts printed, or the error's one line with exit status 2 (the command
    line turns a BipedsimError into that; anything else reaches here)."""
    from bipedsim.cli import main

    status = main(["info", str(p)])
    assert status in (0, 2), f"bipedsim info exited {status}"


def _reader(name: str) -> Callable[[Path], Any]:
    """The function that reads a file of kind ``name``, as the command line calls it."""
    from bipedsim.control.settings import load_controller
    from bipedsim.experiments.experiment import load_experiment, load_suite
    from bipedsim.experiments.tune.spec import load_tune
    from bipedsim.motion.bvh import read_bvh
    from bipedsim.reference.gait_events import load_events
    from bipedsim.synthesis.breed.evolve import load_joint_map
    from bipedsim.synthesis.graph.build import load_graph_config
    from bipedsim.synthesis.world.creature_file import load_creature
    from bipedsim.synthesis.world.tiles import load_world

    return {
        "bvh": read_bvh, "info": _info, "controller": load_controller, "experiment": load_experiment,
        "suite": load_suite, "tune": load_tune, "world": load_world, "creature": load_creature,
        "graph": load_graph_config, "script": _read_script,
        "events": lambda p: load_events(p, ["left", "right"], 300, 1 / 120),
        "breed": lambda p: load_joint_map(p, walk_skeleton(), walk_skeleton()),
    }[name]


def inputs(name: str) -> st.SearchStrategy[bytes]:
    if name in ("bvh", "info"):
        return mutated(bvh_files())
    seeds = st.sampled_from([s.encode() for s in SEEDS[name]])
    return mutated(seeds, HOSTILE_YAML if name != "script" else [])


@contextlib.contextmanager
def small_limits() -> Iterator[None]:
    """Every input kind limited to :data:`FUZZ_LIMIT_MB` while an example runs."""
    names = [f"BIPEDSIM_MAX_{k.upper()}_MB" for k in INPUT_LIMITS_MB]
    old = {n: os.environ.get(n) for n in names}
    os.environ.update(dict.fromkeys(names, FUZZ_LIMIT_MB))
    try:
        yield
    finally:
        for n, v in old.items():
            if v is None:
                os.environ.pop(n, None)
            else:
                os.environ[n] = v


def check_reader(read: Callable[[Path], Any], name: str, blob: bytes) -> None:
    """The property: reading ``blob`` as a ``name`` file loads or raises a BipedsimError, within
    :data:`MEMORY_BUDGET` (the deadline is hypothesis's)."""
    with tempfile.TemporaryDirectory() as d, small_limits():
        p = Path(d) / ("input.bvh" if name in ("bvh", "info") else "input.yaml")
        p.write_bytes(blob)
        tracemalloc.start()
        try:
            read(p)
        except BipedsimError:
            pass
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    assert peak < MEMORY_BUDGET, f"{name}: {peak / 2**20:.0f} MiB held reading a {len(blob)}-byte file"


READERS = ["bvh", "info", "controller", "experiment", "suite", "tune", "world", "creature", "graph", "script",
           "events", "breed"]


@pytest.fixture
def reader(name: str) -> Callable[[Path], Any]:
    """The reader of ``name`` files, called once on a valid file first: its lazy imports and first-call
    caches count neither against the memory budget nor the deadline."""
    read = _reader(name)
    with tempfile.TemporaryDirectory() as d, small_limits():
        p = Path(d) / "seed"
        p.write_bytes(WALK_BVH.read_bytes() if name in ("bvh", "info") else SEEDS[name][0].encode())
        with contextlib.suppress(BipedsimError):
            read(p)
    return read


def fuzz(read: Callable[[Path], Any], name: str, examples: int, derandomize: bool) -> None:
    """Run the property on ``examples`` mutated ``name`` files."""
    @settings(max_examples=examples, derandomize=derandomize, **_SETTINGS)
    @given(blob=inputs(name))
    def loads_or_raises_its_error(blob: bytes) -> None:
        check_reader(read, name, blob)

    loads_or_raises_its_error()


@pytest.mark.parametrize("name", list(SEEDS))
def test_seeds_load(name: str, tmp_path: Path) -> None:
    """The files the mutations start from are valid: the fuzz explores near files that load."""
    read = _reader(name)
    for i, text in enumerate(SEEDS[name]):
        p = tmp_path / f"{name}{i}.yaml"
        p.write_text(text)
        assert read(p) is not None


@settings(max_examples=30, derandomize=True, **_SETTINGS)
@given(blob=bvh_files())
def test_generated_bvh_files_load(blob: bytes) -> None:
    from bipedsim.motion.bvh import read_bvh

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "valid.bvh"
        p.write_bytes(blob)
        m, info = read_bvh(p)
    assert m.num_frames == info.num_frames >= 1


@pytest.mark.parametrize("name", READERS)
def test_reader_loads_or_raises_its_error(reader: Callable[[Path], Any], name: str) -> None:
    fuzz(reader, name, EXAMPLES.get(name, DEFAULT_EXAMPLES), derandomize=True)


@pytest.mark.slow
@pytest.mark.parametrize("name", READERS)
def test_reader_loads_or_raises_its_error_long(reader: Callable[[Path], Any], name: str) -> None:
    fuzz(reader, name, SLOW_FACTOR * EXAMPLES.get(name, DEFAULT_EXAMPLES), derandomize=False)
