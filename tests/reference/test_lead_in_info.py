"""A T-pose first frame dropped at reading reaches what the user sees: ``bipedsim info`` says so and
measures the clip's speed without it, and a run's preparation notes it (the run prints its notes)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from bipedsim.cli import main
from bipedsim.reference import describe_bvh
from bipedsim.reference.describe import format_description
from bipedsim.reference.prepare import load_source

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "motion"))
from test_lead_in import walk, with_lead_in, written  # noqa: E402 (the fixtures of the reading tests)


def _path_length(xy: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(xy, axis=0), axis=1).sum())


def test_info_says_the_lead_in_was_dropped_and_its_speed_leaves_it_out(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    """The T-pose stands at the world origin, metres from where the walk starts: kept, it would add that
    jump to the root's path."""
    w = walk()
    path = written(with_lead_in(w), tmp_path / "tpose.bvh")
    d = describe_bvh(path)
    assert d["lead_in_frames"] == 1 and d["num_frames"] == w.num_frames
    assert np.isclose(d["duration_s"], w.duration)
    assert np.isclose(d["root_path_m"], _path_length(w.root_translation[:, :2]), rtol=1e-6)
    assert np.isclose(d["root_speed_mps"], d["root_path_m"] / w.duration)
    text = format_description(d)
    assert f"frames      {w.num_frames} at" in text
    assert "lead-in: frame 0 of" in text.splitlines()[3]
    assert main(["info", str(path)]) == 0
    assert "lead-in: frame 0 of" in capsys.readouterr().out


def test_a_run_builds_from_the_take_and_notes_the_lead_in(tmp_path: Path) -> None:
    w = walk()
    path = written(with_lead_in(w), tmp_path / "tpose.bvh")
    raw, info, motion, kind = load_source(path)
    assert kind == "humanoid" and raw.num_frames == motion.num_frames == w.num_frames
    assert any(n.startswith("lead-in: frame 0 of") for n in info.notes)
