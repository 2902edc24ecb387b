"""BVH reading in bounded memory and time: a file at the size limit reads within 1 GB of address space,
nothing is allocated from the ``Frames:`` count alone, long lines and hostile sizes give one-line errors,
files over the limit are refused before reading, and a large file shows progress on a terminal.
Fixtures are generated: a 31-joint humanoid walking in place, its frames repeated to the size wanted."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import textwrap
import tracemalloc
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from bipedsim.cli import main
from bipedsim.data import builtin_walk_path
from bipedsim.errors import BVHError
from bipedsim.motion import bvh, bvh_bytes
from bipedsim.motion.bvh import MAX_HEADER_LINE_BYTES, PROGRESS_MIN_BYTES, read_bvh

#: The address space (KiB, ``ulimit -v``) a file at the BVH size limit must read within.
ADDRESS_SPACE_KB = 1_000_000
#: Frames of motion written out before they are repeated to make a large file.
BLOCK_FRAMES = 240

#: A 31-joint humanoid: (name, parent index, OFFSET in cm), Y up; the legs and spine as capture rigs name them.
_SIDE = [("UpLeg", "Hips", (9.0, 0.0, 0.0)), ("Leg", "UpLeg", (0.0, -42.0, 0.0)),
         ("Foot", "Leg", (0.0, -40.0, 0.0)), ("ToeBase", "Foot", (0.0, -8.0, 12.0)),
         ("Shoulder", "Spine2", (3.0, 12.0, 0.0)), ("Arm", "Shoulder", (12.0, 0.0, 0.0)),
         ("ForeArm", "Arm", (27.0, 0.0, 0.0)), ("Hand", "ForeArm", (24.0, 0.0, 0.0)),
         ("HandIndex1", "Hand", (6.0, 0.0, 1.0)), ("HandIndex2", "HandIndex1", (3.0, 0.0, 0.0)),
         ("HandIndex3", "HandIndex2", (2.0, 0.0, 0.0)), ("HandThumb1", "Hand", (2.0, 0.0, 3.0))]
_TRUNK = [("Spine", "Hips", (0.0, 10.0, 0.0)), ("Spine1", "Spine", (0.0, 12.0, 0.0)),
          ("Spine2", "Spine1", (0.0, 12.0, 0.0)), ("Neck", "Spine2", (0.0, 14.0, 0.0)),
          ("Neck1", "Neck", (0.0, 4.0, 0.0)), ("Head", "Neck1", (0.0, 8.0, 0.0))]


def _joints() -> list[tuple[str, str, tuple[float, float, float]]]:
    out = [("Hips", "", (0.0, 0.0, 0.0)), *_TRUNK]
    for side, sign in (("Left", 1.0), ("Right", -1.0)):
        for name, parent, (x, y, z) in _SIDE:
            par = parent if parent in ("Hips", "Spine2") else side + parent
            out.append((side + name, par, (sign * x, y, z)))
    return out


def humanoid_header(joints: list[tuple[str, str, tuple[float, float, float]]] | None = None) -> str:
    """The HIERARCHY of the 31-joint humanoid (cm, Y up), the root with 6 channels, the rest ZXY."""
    joints = joints or _joints()
    kids: dict[str, list[int]] = {}
    for i, (_, parent, _) in enumerate(joints):
        kids.setdefault(parent, []).append(i)
    lines = ["HIERARCHY"]

    def emit(i: int, depth: int) -> None:
        name, _, off = joints[i]
        ind = "  " * depth
        lines.append(f"{ind}{'ROOT' if i == 0 else 'JOINT'} {name}")
        lines.append(f"{ind}{{")
        lines.append(f"{ind}  OFFSET {off[0]:g} {off[1]:g} {off[2]:g}")
        pos = "Xposition Yposition Zposition " if i == 0 else ""
        lines.append(f"{ind}  CHANNELS {6 if i == 0 else 3} {pos}Zrotation Xrotation Yrotation")
        for k in kids.get(name, []):
            emit(k, depth + 1)
        if name not in kids:
            lines.extend([f"{ind}  End Site", f"{ind}  {{", f"{ind}    OFFSET 0 2 0", f"{ind}  }}"])
        lines.append(f"{ind}}}")

    emit(0, 0)
    return "\n".join(lines) + "\n"


def humanoid_bvh(path: Path, size_bytes: int, frames: int | None = None) -> int:
    """Write the humanoid walking in place (legs swinging, root bobbing) at 120 fps, its
    :data:`BLOCK_FRAMES` frames repeated until the file is about ``size_bytes``; ``frames``: the count
    written in the header (default: the frames written). Returns the frames written."""
    n_joints = len(_joints())
    t = np.arange(BLOCK_FRAMES) / 120.0
    phase = 2 * np.pi * t / 1.0  # one stride a second
    data = np.zeros((BLOCK_FRAMES, 3 + 3 * n_joints))
    data[:, 1] = 92.0 + 1.5 * np.cos(2 * phase)  # the hip's height (cm)
    rng = np.random.default_rng(0)
    data[:, 6:] = 3.0 * np.sin(phase[:, None] + rng.uniform(0, 6.3, 3 * n_joints - 3))
    names = [j[0] for j in _joints()]
    for side, sign in (("Left", 1.0), ("Right", -1.0)):
        up, knee = names.index(side + "UpLeg"), names.index(side + "Leg")
        data[:, 3 + 3 * up + 1] = sign * 25.0 * np.sin(phase)  # hip flexion (X, the second of ZXY)
        data[:, 3 + 3 * knee + 1] = 30.0 * (1 + np.sin(phase + sign * np.pi / 2))
    buf = io.StringIO()
    np.savetxt(buf, data, fmt="%.6f")
    block = buf.getvalue()
    head = humanoid_header()
    repeats = max(1, (size_bytes - len(head)) // len(block))
    written = repeats * BLOCK_FRAMES
    with open(path, "w", newline="\n") as f:
        f.write(f"{head}MOTION\nFrames: {written if frames is None else frames}\nFrame Time: 0.0083333\n")
        for _ in range(repeats):
            f.write(block)
    return written


@contextmanager
def traced(monkeypatch: pytest.MonkeyPatch, path: Path) -> Iterator[list[int]]:
    """Measure the most memory Python and numpy hold at once (bytes, as tracemalloc counts; appended to the
    list yielded) while the BVH file ``path`` is read: its bytes are read before, so this is the reader's
    own memory."""
    data = bvh.read_input_bytes(path, "bvh")
    monkeypatch.setattr(bvh, "read_input_bytes", lambda p, kind: data)
    peak: list[int] = []
    tracemalloc.start()
    try:
        yield peak
    finally:
        peak.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()


def test_generated_humanoid_reads_as_a_walk(tmp_path: Path) -> None:
    path = tmp_path / "h.bvh"
    n = humanoid_bvh(path, 200_000)
    m, info = read_bvh(path)
    assert info.num_joints == 31 and m.num_frames == n
    assert info.unit_name == "cm" and info.up == "y"


def test_memory_is_a_small_multiple_of_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Reading holds the values (about the file's size in float64) and the rotations, not a list of the
    file's words (more than ten times the file): at most twice the file, plus the windows and blocks it
    parses and converts a piece at a time."""
    path = tmp_path / "big.bvh"
    humanoid_bvh(path, 6 << 20)
    size = path.stat().st_size
    with traced(monkeypatch, path) as peak:
        read_bvh(path)
    assert peak[0] < 2 * size + (16 << 20), f"reading a {size / 2**20:.1f} MiB file held {peak[0] / 2**20:.1f} MiB"


@pytest.mark.parametrize("frames", [10**6, 10**12, 10**18])
def test_frames_count_allocates_nothing_by_itself(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                  frames: int) -> None:
    """A header claiming a trillion frames over a file that holds a few: one line, and no allocation
    sized from the claim (the rows come from the lines the file holds)."""
    path = tmp_path / "claims.bvh"
    humanoid_bvh(path, 1, frames=frames)
    with traced(monkeypatch, path) as peak, pytest.raises(
            BVHError, match=rf"truncated motion: 'Frames: {frames}' but only {BLOCK_FRAMES} frame lines"):
        read_bvh(path)
    assert peak[0] < 4 << 20, f"{peak[0] / 2**20:.1f} MiB for a {path.stat().st_size} byte file"


def test_one_huge_frame_line_is_counted_not_split(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A frame line of millions of values (a file run together) is refused by its count, without a list of
    its words; so is one with other whitespace (a no-break space), which is counted as str.split counts."""
    head = humanoid_header() + "MOTION\nFrames: 1\nFrame Time: 0.01\n"
    for sep, name in ((" ", "plain"), ("\u00a0", "nbsp")):
        path = tmp_path / f"{name}.bvh"
        path.write_text(head + sep.join(["1.5"] * 1_500_000) + "\n", encoding="utf-8")
        with monkeypatch.context() as mp, traced(mp, path) as peak, pytest.raises(
                BVHError, match="expected 96 values on a frame line .*got 1500000") as exc:
            read_bvh(path)
        assert exc.value.line == head.count("\n") + 1
        assert peak[0] < 4 * path.stat().st_size, f"{name}: {peak[0] / 2**20:.1f} MiB for one line"


def test_header_line_past_the_limit(tmp_path: Path) -> None:
    path = tmp_path / "long.bvh"
    path.write_bytes(b"HIERARCHY\nROOT " + b"x " * (MAX_HEADER_LINE_BYTES // 2 + 1) + b"\n{\n")
    with pytest.raises(BVHError, match="more than any BVH header line") as exc:
        read_bvh(path)
    assert exc.value.line == 2


def test_values_and_errors_do_not_depend_on_the_window(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The frame lines are read a window of bytes at a time: a window ending inside a number, between a
    CR and its LF or inside a UTF-8 character changes nothing -- not the values, not the error's line."""
    head = humanoid_header() + "MOTION\nFrames: 3\nFrame Time: 0.01\n"
    row = " ".join(f"{v:.3f}" for v in np.linspace(-90, 90, 96))
    rows = [row, row.replace("-90.000", "1e-05"), row]
    path_good, path_bad = tmp_path / "good.bvh", tmp_path / "bad.bvh"
    path_good.write_text(head + "\n".join(rows) + "\n", newline="\r\n")
    rows[2] = rows[2].replace("-90.000", "-9é.000")  # a latin letter (two bytes in UTF-8) in the third frame
    path_bad.write_text(head + "\n".join(rows) + "\n", newline="\r\n", encoding="utf-8")
    ref, _ = read_bvh(path_good)
    for window in (1, 2, 3, 7, 64, 1000):
        monkeypatch.setattr(bvh_bytes, "WINDOW_BYTES", window)
        m, info = read_bvh(path_good)
        assert np.array_equal(m.rotations, ref.rotations) and info.line_endings == "CRLF"
        with pytest.raises(BVHError, match="expected a number for a frame value, got '-9é.000'") as exc:
            read_bvh(path_bad)
        assert exc.value.line == head.count("\n") + 3


def test_over_the_limit_refused_before_reading(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "big.bvh"
    humanoid_bvh(path, 2 << 20)
    monkeypatch.setenv("BIPEDSIM_MAX_BVH_MB", "1")
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "above the 1 MiB limit for BVH files (set BIPEDSIM_MAX_BVH_MB" in err and "Traceback" not in err
    monkeypatch.setenv("BIPEDSIM_MAX_BVH_MB", "3")
    assert read_bvh(path)[1].num_joints == 31


def test_progress_shown_for_a_large_file_on_a_terminal(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """On a terminal a file over :data:`PROGRESS_MIN_BYTES` shows a bar named for it; a small one none;
    and nothing reaches a log or a pipe (the bar is only drawn on a terminal)."""
    from bipedsim import files as bio

    big, small = tmp_path / "big.bvh", tmp_path / "small.bvh"
    humanoid_bvh(big, PROGRESS_MIN_BYTES + (1 << 20))
    humanoid_bvh(small, 100_000)
    read_bvh(big)
    assert "reading big.bvh" not in capsys.readouterr().err  # stderr is not a terminal here
    monkeypatch.setattr(bvh, "progress_bar", lambda *a, **k: bio.progress_bar(*a, **k, force=True, leave=True))
    read_bvh(small)
    assert capsys.readouterr().err == ""
    read_bvh(big)
    err = capsys.readouterr().err
    assert "reading big.bvh" in err and "100%" in err and "M/" in err  # sizes in MiB


def test_file_at_the_limit_reads_within_1_gb(tmp_path: Path) -> None:
    """A ~60 MiB file (31 joints, about 9.5 minutes at 120 fps) read in a process limited to
    :data:`ADDRESS_SPACE_KB` of address space."""
    path = tmp_path / "at_limit.bvh"
    frames = humanoid_bvh(path, 60 << 20)
    code = textwrap.dedent(f"""
        from bipedsim.motion import read_bvh
        m, info = read_bvh({str(path)!r})
        print("frames", m.num_frames, info.num_joints)
    """)
    # one BLAS thread: each reserves address space, as many as the machine has cores
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    proc = subprocess.run(["bash", "-c", f'ulimit -v {ADDRESS_SPACE_KB}; exec "{sys.executable}" -c "$0"', code],
                          capture_output=True, text=True, env=env, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert f"frames {frames} 31" in proc.stdout


@pytest.mark.parametrize("value", ["1e300", "-3e10"])
def test_corrupt_magnitudes_are_refused_quietly(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                value: str) -> None:
    lines = builtin_walk_path().read_text().split("\n")
    first = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    values = lines[first].split()
    values[0] = value
    lines[first] = " ".join(values)
    bad = tmp_path / "corrupt.bvh"
    bad.write_text("\n".join(lines))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning on the way to the error
        assert main(["info", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"bipedsim info: error: {bad}: frame 1 holds a value of") and "corrupt" in err, err
