"""BVH reading and writing: FK against independent references, exact round trips, unit and axis
conventions, and clear errors for malformed input."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_params
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bipedsim.cli import main
from bipedsim.errors import BVHError
from bipedsim.motion import bvh_text, load_bvh, read_bvh, write_bvh

FK_TOL = 1e-6  # of the body's height, per the issue


@pytest.mark.parametrize("path", shared_params())
def test_fk_matches_independent_implementations(path: Path) -> None:
    from bvh_reference import bvhio_positions, naive_positions

    motion, info = read_bvh(path, lead_in=False)  # every frame of the file, as the other readers read it
    pos = motion.fk()[0]
    height_units = info.height_m / info.unit_scale
    frames = list(range(motion.num_frames))
    names, ref = naive_positions(str(path), info.position_channels, frames)
    idx = [motion.skeleton.index(n) for n in names]
    assert np.abs(pos[:, idx] - ref).max() <= FK_TOL * height_units
    if set(info.position_channels.values()) <= {"replace"}:
        # bvhio reads every position channel as absolute; compare where that reading is ours too
        names, ref = bvhio_positions(str(path))
        idx = [motion.skeleton.index(n) for n in names]
        # bvhio computes in float32 (PyGLM): its rounding grows with the coordinates (a 9 m walk in cm)
        f32 = 8 * np.finfo(np.float32).eps * np.abs(ref).max()
        assert np.abs(pos[:, idx] - ref).max() <= FK_TOL * height_units + f32


@pytest.mark.parametrize("path", shared_params())
def test_round_trip_is_exact(path: Path, tmp_path: Path) -> None:
    a, _ = read_bvh(path)
    out = tmp_path / "rt.bvh"
    write_bvh(a, out)
    b, _ = read_bvh(out)
    sa, sb = a.skeleton, b.skeleton
    assert sa.names == sb.names and sa.channels == sb.channels
    # a translating root is written with a zero OFFSET and absolute channels (both readings of the
    # position channels then agree); every other OFFSET and mode is kept exactly
    root_free = 1 if sa.has_positions(0) else 0
    assert np.array_equal(sa.parents, sb.parents)
    assert np.array_equal(sa.offsets[root_free:], sb.offsets[root_free:])
    assert not root_free or (not np.any(sb.offsets[0]) and sb.position_modes[0] == "replace")
    assert np.array_equal(sa.end_site_offsets, sb.end_site_offsets)
    assert sa.position_modes[root_free:] == sb.position_modes[root_free:]
    assert a.frame_time == b.frame_time
    assert np.array_equal(a.root_translation, b.root_translation)
    assert np.array_equal(a.local_translations(), b.local_translations())
    # same rotation: |<qa, qb>| = 1 to float precision
    dots = np.abs(np.sum(a.rotations * b.rotations, axis=-1))
    assert np.all(1.0 - dots < 1e-12)
    pa, pb = a.fk()[0], b.fk()[0]
    assert np.abs(pa - pb).max() <= 1e-9 * max(1.0, np.abs(pa).max())
    # and the channel layout of the text is the original's, line for line
    assert bvh_text(b).split("MOTION")[0] == out.read_text().split("MOTION")[0]


def test_two_units_same_take_agree(shared_dir: Path) -> None:
    a = load_bvh(shared_dir / "human/cmu_131_01_start_walk_stop__max31_mixedEOL.bvh")
    b = load_bvh(shared_dir / "odd/cmu_131_01_start_walk_stop__metres.bvh")
    pa, pb = a.fk()[0], b.fk()[0]
    n = min(len(pa), len(pb))
    assert np.abs(pa[:n] - pb[:n]).max() < 1e-3


def test_line_endings_do_not_matter(shared_dir: Path) -> None:
    a, ia = read_bvh(shared_dir / "odd/mocapbank_crouch__crlf.bvh")
    b, ib = read_bvh(shared_dir / "odd/mocapbank_crouch__lf.bvh")
    assert ia.line_endings == "CRLF" and ib.line_endings == "LF"
    assert np.array_equal(a.rotations, b.rotations)
    assert np.array_equal(a.root_translation, b.root_translation)


@pytest.mark.parametrize("name,unit,up", [
    ("human/cmu_02_01_walk__holden31_crlf.bvh", "cmu", "y"),
    ("human/cmu_02_02_walk__daz43.bvh", "cm", "y"),
    ("odd/cmu_131_01_start_walk_stop__metres.bvh", "m", "y"),
    ("odd/makehuman_walk1__zup_decimetre.bvh", "dm", "z"),
    ("odd/bvh_spec_sample__2frames.bvh", "inch", "y"),
    ("animal/mann_dog_D1_007_KAN01_001_locomotion.bvh", "cm", "y"),
])
def test_unit_and_up_guesses(shared_dir: Path, name: str, unit: str, up: str) -> None:
    _, info = read_bvh(shared_dir / name)
    assert (info.unit_name, info.up) == (unit, up)


def test_project_frame_is_z_up_metres(shared_dir: Path) -> None:
    for name in ("human/cmu_02_01_walk__holden31_crlf.bvh", "odd/makehuman_walk1__zup_decimetre.bvh"):
        m = load_bvh(shared_dir / name)
        pos = m.fk()[0]
        head = next(i for i, n in enumerate(m.skeleton.names) if n.lower() == "head")
        feet = [i for i, n in enumerate(m.skeleton.names) if "foot" in n.lower()]
        rise = pos[:, head, 2] - pos[:, feet, 2].mean(axis=1)
        assert 1.0 < np.median(rise) < 2.0, name  # head 1-2 m above the feet along +Z


def test_explicit_scale_overrides_guess(shared_dir: Path) -> None:
    path = shared_dir / "human/cmu_02_01_walk__holden31_crlf.bvh"
    _m1, i1 = read_bvh(path, scale="cm")
    assert i1.unit_source == "given" and i1.unit_scale == 0.01
    m2, i2 = read_bvh(path, scale=0.01)
    assert i2.unit_name == "cm" and m2.unit == 0.01
    with pytest.raises(BVHError, match="unknown unit 'furlong'"):
        read_bvh(path, scale="furlong")
    with pytest.raises(BVHError, match="scale must be a positive"):
        read_bvh(path, scale=-1.0)


def test_six_channel_modes_detected(shared_dir: Path) -> None:
    _, info = read_bvh(shared_dir / "odd/makehuman_tpose__173j_144six-channel.bvh")
    non_root = {k: v for k, v in info.position_channels.items() if k != "root"}
    assert len(non_root) == 143 and set(non_root.values()) == {"add"}
    _, info = read_bvh(shared_dir / "odd/bvhtools_test3__YXZ_XYZ_metres_first600f__DERIVED.bvh")
    non_root = {k: v for k, v in info.position_channels.items() if k != "pelvis"}
    assert len(non_root) == 17 and set(non_root.values()) == {"replace"}


# ---------------------------------------------------------------------- synthetic files
SIMPLE = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Leg
\t{
\t\tOFFSET 0 -10 0
\t\tCHANNELS 3 Xrotation Yrotation Zrotation
\t\tJOINT Foot
\t\t{
\t\t\tOFFSET 0 -10 0
\t\t\tCHANNELS 6 Xposition Yposition Zposition Yrotation Zrotation Xrotation
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: .0083333
0 20 0 0 0 0 10 20 30 0.5 -10 1e-05 0 0 0
1 20 0 90 0 0 -10 5 30 0.5 -10 0 0 0 45
"""


def _write(tmp_path: Path, text: str | bytes, name: str = "x.bvh") -> Path:
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    return p


def test_synthetic_quirks(tmp_path: Path) -> None:
    m, info = read_bvh(_write(tmp_path, SIMPLE))
    assert info.num_frames == 2 and np.isclose(info.frame_time, 0.0083333)
    assert info.rotation_orders == {"ZXY": 1, "XYZ": 1, "YZX": 1}
    assert info.position_channels["Foot"] == "replace"  # values sit at the OFFSET (0.5, -10, 0)
    assert np.allclose(m.translations[0, 2], [0.5, -10, 1e-5])
    # no final newline, CR-only line endings, tabs
    m2, info2 = read_bvh(_write(tmp_path, SIMPLE.rstrip("\n").replace("\n", "\r"), "cr.bvh"))
    assert info2.line_endings == "CR" and not info2.final_newline
    assert np.array_equal(m.rotations, m2.rotations)


def test_six_channel_add_mode(tmp_path: Path) -> None:
    text = SIMPLE.replace("0.5 -10 1e-05", "0.5 0.1 0").replace("0.5 -10 0", "0.5 0.2 0")
    m, info = read_bvh(_write(tmp_path, text))
    assert info.position_channels["Foot"] == "add"
    assert np.allclose(m.translations[:, 2], [[0.5, -9.9, 0], [0.5, -9.8, 0]])
    # and it is written back as offsets-relative values
    out = tmp_path / "o.bvh"
    write_bvh(m, out)
    assert "0.5 0.1" in out.read_text().replace("0.09999999999999964", "0.1")


def test_whole_frame_lines_past_the_declared_count_are_read_and_said(tmp_path: Path) -> None:
    """An exporter's 'Frames:' one short (a real take, exported at 30 and 100 fps, declares 418 and 1392
    frames over 419 and 1393 rows): every whole frame line is motion, read with a note; an extra line
    that is no whole frame is still refused (``BAD_CASES``)."""
    from bipedsim.reference.describe import describe_bvh, format_description

    path = _write(tmp_path, SIMPLE.replace("Frames: 2", "Frames: 1"))
    m, info = read_bvh(path)
    assert m.num_frames == 2 and info.num_frames == 2
    assert info.notes == ["'Frames: 1' but 2 whole frame lines follow (line 21 on): all 2 read"]
    full, _ = read_bvh(_write(tmp_path, SIMPLE, "full.bvh"))
    assert np.array_equal(m.rotations, full.rotations)
    assert "'Frames: 1' but 2 whole frame lines" in format_description(describe_bvh(path))


def test_one_frame_file_and_leaf_without_end_site(tmp_path: Path) -> None:
    text = SIMPLE.replace("Frames: 2", "Frames: 1").rsplit("\n", 2)[0] + "\n"
    m, info = read_bvh(_write(tmp_path, text))
    assert m.num_frames == 1 and info.end_sites == 0 and m.duration == 0.0


BAD_CASES = [
    ("truncated", lambda s: s.rsplit("\n", 2)[0] + "\n", "truncated motion", 20),
    ("too many values", lambda s: s.replace("0 20 0 0 0 0 10", "0 20 0 0 0 0 0 10"),
     "expected 15 values on a frame line", 20),
    ("frames past the count, not whole", lambda s: s.replace("Frames: 2", "Frames: 1").replace(" 0 0 45\n", " 0 0\n"),
     "expected 15 values on a frame line", 21),
    ("nan", lambda s: s.replace("0.5 -10 1e-05", "0.5 nan 1e-05"), "must be finite, got 'nan'", 20),
    ("inf", lambda s: s.replace("1 20 0 90", "1 20 0 inf"), "must be finite, got 'inf'", 21),
    ("text value", lambda s: s.replace("1 20 0 90", "1 20 0 abc"), "expected a number", 21),
    ("zero frame time", lambda s: s.replace(".0083333", "0"), "is not plausible: expected 0.0001 to 1 s", 19),
    ("negative frame time", lambda s: s.replace(".0083333", "-0.1"), "is not plausible: expected 0.0001 to 1 s", 19),
    ("unknown keyword", lambda s: s.replace("\tJOINT Leg", "\tJIONT Leg"), "unexpected 'JIONT Leg'", 6),
    ("unbalanced close", lambda s: s.replace("\t}\n}\nMOTION", "\t}\nMOTION"), "unexpected 'MOTION'", 16),
    ("extra close", lambda s: s.replace("}\nMOTION", "}\n}\nMOTION"), "expected 'MOTION'", 17),
    ("bad channel", lambda s: s.replace("Xrotation Yrotation Zrotation", "Xrotation Yrotation Wrotation"),
     "unknown channel 'Wrotation'", 9),
    ("channel count", lambda s: s.replace("CHANNELS 3 Xrotation", "CHANNELS 4 Xrotation"),
     "CHANNELS says 4 but lists 3", 9),
    ("bad offset", lambda s: s.replace("OFFSET 0 -10 0\n\t\tCHANNELS", "OFFSET 0 -10\n\t\tCHANNELS"),
     "needs 3 numbers", 8),
    ("no hierarchy", lambda s: s.replace("HIERARCHY", "HIERARCHIES"), "expected 'HIERARCHY'", 1),
    ("no frames line", lambda s: s.replace("Frames: 2", "Frame: 2"), "expected 'Frames: N'", 18),
]


@pytest.mark.parametrize("name,mutate,message,line", BAD_CASES, ids=[c[0] for c in BAD_CASES])
def test_malformed_input_names_file_and_line(tmp_path: Path, name: str, mutate, message: str,
                                            line: int) -> None:
    path = _write(tmp_path, mutate(SIMPLE))
    with pytest.raises(BVHError) as exc:
        read_bvh(path)
    assert message in str(exc.value)
    assert exc.value.line == line
    assert str(exc.value).startswith(f"{path}:{line}: ")


@pytest.mark.parametrize("content,message", [
    (b"", "file is empty"), (b"   \n\n", "file is empty"),
    (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR", "binary data"),
    (bytes(range(256)) * 4, "binary data"),
])
def test_empty_and_binary(tmp_path: Path, content: bytes, message: str) -> None:
    with pytest.raises(BVHError, match=message):
        read_bvh(_write(tmp_path, content))


def test_missing_file_is_bvh_error(tmp_path: Path) -> None:
    with pytest.raises(BVHError, match="no such file"):
        read_bvh(tmp_path / "nope.bvh")


def test_cli_exits_2_without_traceback(tmp_path: Path, capsys) -> None:
    path = _write(tmp_path, SIMPLE.replace("Frames: 2", "Frames: 3"))
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "truncated motion" in err and f"{path}:21" in err
    proc = subprocess.run([sys.executable, "-m", "bipedsim.cli", "info", str(path)],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and "truncated motion" in proc.stderr


_MUTATIONS = st.lists(st.tuples(st.sampled_from(["delete", "insert", "replace", "dup_line", "drop_line"]),
                                st.integers(0, 10_000), st.text(
                                    alphabet=st.sampled_from(list("{}0123456789.-e \t\nXYZ#naifJOINT\r\x00")),
                                    min_size=1, max_size=8)), min_size=1, max_size=4)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(muts=_MUTATIONS)
def test_fuzz_only_bvh_errors(tmp_path: Path, muts) -> None:
    text = SIMPLE
    for kind, pos, s in muts:
        pos = pos % (len(text) + 1)
        lines = text.split("\n")
        li = pos % len(lines)
        if kind == "delete":
            text = text[:pos] + text[pos + len(s):]
        elif kind == "insert":
            text = text[:pos] + s + text[pos:]
        elif kind == "replace":
            text = text[:pos] + s + text[pos + len(s):]
        elif kind == "dup_line":
            text = "\n".join(lines[:li + 1] + lines[li:])
        else:
            text = "\n".join(lines[:li] + lines[li + 1:])
    path = tmp_path / "fuzz.bvh"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    try:
        m, _ = read_bvh(path)
    except BVHError:
        return
    assert np.all(np.isfinite(m.fk()[0]))


@pytest.mark.parametrize("order", ["XYZ", "ZXY", "YZX", "ZYX", "XZY", "YXZ", "Z", "XY", "ZX"])
def test_euler_to_quat_matches_scipy(order: str) -> None:
    from scipy.spatial.transform import Rotation

    from bipedsim.motion.bvh import euler_to_quat

    ang = np.random.default_rng(1).uniform(-360, 360, size=(50, len(order)))
    q = euler_to_quat(order, ang)
    ref = Rotation.from_euler(order, ang, degrees=True).as_quat()
    assert np.allclose(np.abs(np.sum(q * ref, axis=-1)), 1.0, atol=1e-12)
