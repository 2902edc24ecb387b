"""Ground as a sweep grid dimension (``grid.ground``): rows per ground, their keys, the checks, the
summary per ground."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict
from pathlib import Path

import pytest

from bipedsim.errors import ConfigError
from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import _tasks
from bipedsim.experiments.sweep_summary import summarise, threshold_table

BASE = """name: g
seconds: 4
after: 1.0
grid:
  magnitude: [100, 200]
  direction: [0, 180]
  duration: [0.2]
  phase: [[1, 0.5]]
"""


def _exp(tmp_path: Path, extra: str) -> object:
    p = tmp_path / "e.yaml"
    p.write_text(BASE + extra, encoding="utf-8")
    return load_experiment(p)


def test_each_ground_is_a_row_set_of_its_own(tmp_path: Path) -> None:
    exp = _exp(tmp_path, '  ground: [[], ["slope:8"], ["rough:0.03:1.0", "friction:0.8"]]\n')
    rows = exp.rows()  # type: ignore[attr-defined]
    assert len(rows) == 3 * 4
    assert [r.params()["ground"] for r in rows[::4]] == ["flat", "slope:8", "rough:0.03:1.0+friction:0.8"]
    assert len({r.key for r in rows}) == len(rows)
    # each row's worker builds the scenario of its own ground (flat: none)
    tasks = _tasks(exp, rows)  # type: ignore[arg-type]
    assert len(tasks[0][1]) == 3 and tasks[4][1][3] == ("slope:8",)


def test_a_grid_without_grounds_keeps_its_row_keys(tmp_path: Path) -> None:
    rows = _exp(tmp_path, "").rows()  # type: ignore[attr-defined]
    r = rows[1]
    ident = json.dumps([None, asdict(r.push), 0], sort_keys=True)
    assert r.key == hashlib.sha1(ident.encode()).hexdigest()[:12]
    assert r.params()["ground"] == "flat"


@pytest.mark.parametrize("extra, needle", [
    ('  ground: [["slope:40"]]\n', "slope:40"),
    ('  ground: [["slope:8"], ["slope:8"]]\n', "listed twice"),
    ('ground: ["slope:8"]\n', "give the ground once"),
])
def test_bad_grounds_are_refused_naming_the_key(tmp_path: Path, extra: str, needle: str) -> None:
    text = extra if extra.startswith("  ") else ""
    head = "" if text else extra
    p = tmp_path / "e.yaml"
    p.write_text(head + BASE + (text or '  ground: [["slope:8"]]\n'), encoding="utf-8")
    with pytest.raises(ConfigError, match="ground") as err:
        load_experiment(p)
    assert needle in str(err.value)


def _row(ground: str, mag: float, ok: bool) -> dict[str, str]:
    return {"controller": "default", "body": "torso", "ground": ground, "duration": "0.2", "vertical": "0",
            "direction": "0", "state": "1", "fraction": "0.5", "start": "", "magnitude": f"{mag:g}",
            "outcome": "no_fall" if ok else "fall"}


def test_the_summary_gives_a_threshold_per_ground() -> None:
    rows = [_row("flat", 100, True), _row("flat", 200, True), _row("slope:8", 100, True),
            _row("slope:8", 200, False)]
    s = summarise(rows)
    got = {g["ground"]: g["threshold_n"] for g in s["by_direction_and_phase"]}
    assert got == {"flat": 200.0, "slope:8": 100.0}
    assert set(s["largest_survived_per_setting_n"]) == {"torso 0.2 s on flat", "torso 0.2 s on slope:8"}
    assert "on slope:8" in threshold_table(s)
    # one ground: the labels say nothing of it
    assert "largest_survived_per_setting_n" not in summarise(rows[:2])
