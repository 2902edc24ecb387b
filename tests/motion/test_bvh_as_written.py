"""Files read as they were written: channel keywords in any case are the standard ones, and where
nothing in a clip tells the up axis it is Y, the BVH convention -- a body the project writes Y up (a
world's flying creature) reads back where it was written."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bipedsim.errors import BVHError
from bipedsim.motion import bvh_text, read_bvh, write_bvh
from bipedsim.motion.gaitgen import WalkParams, generate_walk
from bipedsim.motion.motion import Motion, canonical_quat

CHANNEL = re.compile(r"\b([XYZ])(position|rotation)\b")


def _walk() -> Motion:
    return generate_walk(WalkParams(cycles=2))


@pytest.mark.parametrize("spell", [str.upper, str.lower, lambda s: s[0].lower() + s[1:].upper()],
                         ids=["XPOSITION", "xposition", "xPOSITION"])
def test_channel_keywords_in_any_case_read_as_the_standard_ones(tmp_path: Path, spell) -> None:  # noqa: ANN001
    text = bvh_text(_walk().with_up("y").scaled(100.0), precision=6)
    odd = CHANNEL.sub(lambda mt: spell(mt.group(0)), text)
    assert odd != text
    (tmp_path / "std.bvh").write_text(text)
    (tmp_path / "odd.bvh").write_text(odd)
    m0, _ = read_bvh(tmp_path / "std.bvh")
    m1, _ = read_bvh(tmp_path / "odd.bvh")
    assert m1.skeleton.channels == m0.skeleton.channels
    np.testing.assert_array_equal(m1.rotations, m0.rotations)
    np.testing.assert_array_equal(m1.root_translation, m0.root_translation)


def test_a_channel_named_twice_in_two_cases_is_refused(tmp_path: Path) -> None:
    text = bvh_text(_walk().with_up("y").scaled(100.0), precision=6)
    bad = text.replace("Zrotation Yrotation Xrotation", "ZROTATION Yrotation zrotation", 1)
    assert bad != text
    (tmp_path / "bad.bvh").write_text(bad)
    with pytest.raises(BVHError, match="repeated channel"):
        read_bvh(tmp_path / "bad.bvh")


def flier() -> Motion:
    """A body flying level over a ridge (m, Z up): the generated walker's first pose held face down, head
    forward, its legs trailing behind, its arms beating, rising 2 m and coming down over 4 m. Read with
    the wrong axis up, its feet line up along a horizontal axis as along a floor."""
    m = generate_walk(WalkParams(cycles=2))
    n, sk = m.num_frames, m.skeleton
    rots = np.repeat(m.rotations[:1], n, axis=0)
    rots[:, 0] = (Rotation.from_euler("y", 90, degrees=True) * Rotation.from_quat(rots[:, 0])).as_quat()
    beat = 0.8 * np.sin(np.linspace(0.0, 8 * np.pi, n))[:, None]
    for side, sign in (("LeftArm", 1.0), ("RightArm", -1.0)):
        j = sk.names.index(side)
        rots[:, j] = (Rotation.from_euler("x", sign * beat) * Rotation.from_quat(rots[:, j])).as_quat()
    root = np.zeros((n, 3))
    root[:, 0] = np.linspace(0.0, 4.0, n)
    root[:, 2] = 3.0 + 2.0 * np.sin(np.linspace(0.0, np.pi, n))
    return m.copy(root_translation=root, rotations=canonical_quat(rots))


def test_a_flying_body_written_y_up_reads_back_where_it_was_written(tmp_path: Path) -> None:
    """No reading stands the flier on its legs (its hip is no leg length above its feet along either
    axis): the file is read Y up, as written, and every joint is back where it was (it had been read Z
    up, metres away)."""
    fly = flier()
    path = tmp_path / "flier.bvh"
    write_bvh(fly.with_up("y").scaled(100.0), path)
    back, info = read_bvh(path)
    assert info.up == "y" and info.unit_name == "cm"
    assert "BVH convention" in info.up_reason and "--up" in info.reading_note
    np.testing.assert_allclose(back.to_project_frame().fk()[0], fly.fk()[0], atol=1e-9)


@pytest.mark.parametrize("up", ["y", "z"])
def test_a_walk_reads_back_with_the_axis_it_was_written_with(tmp_path: Path, up: str) -> None:
    """A body on its legs tells its up axis: a walk written Z up is still read Z up."""
    w = _walk()
    path = tmp_path / f"walk_{up}.bvh"
    write_bvh(w.with_up(up).scaled(100.0), path)
    back, info = read_bvh(path)
    assert info.up == up and "most plausible reading" in info.up_reason
    np.testing.assert_allclose(back.to_project_frame().fk()[0], w.fk()[0], atol=1e-9)
