"""The push threshold protocol: replicated grid cells (seeded noise and phase offsets), the replica rule
of the summary (at least k of n replicas at a magnitude and at every lower one), and the grid's push
dimensions (bodies, durations)."""

from __future__ import annotations

from pathlib import Path

import pytest

from bipedsim.errors import ConfigError
from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import run_row, run_sweep
from bipedsim.experiments.sweep_summary import format_summary, summarise, threshold, threshold_table

REPLICATED = """name: rep
seconds: 3.5
after: 1.0
replicas: {{count: 3, survive: 2, noise: 0.02, phase_offset: 0.1, start_offset: 0.05}}
grid:
  magnitude: [100, 300]
  direction: [0, 180]
  duration: [0.1, 0.3]
  body: [torso, pelvis, left_upper_arm]
  {timing}
"""


def rows_for(ladder: dict[float, list[bool]], direction: float = 0.0, state: int = 2) -> list[dict[str, str]]:
    """Synthetic results rows of one cell: per magnitude (N) one row per replica, True survived."""
    out = []
    for m, oks in ladder.items():
        for rep, ok in enumerate(oks):
            out.append({"controller": "default", "body": "torso", "duration": "0.2", "vertical": "0.0",
                        "direction": str(direction), "state": str(state), "fraction": "0.5", "start": "",
                        "magnitude": str(m), "repeat": str(rep), "outcome": "no_fall" if ok else "fall"})
    return out


def test_threshold_needs_k_of_n_at_the_magnitude_and_every_lower_one() -> None:
    y, n = True, False
    ladder = {200.0: [y, y, y, y, y], 250.0: [y, y, y, y, n], 300.0: [y, y, y, n, n], 350.0: [y, y, y, y, y]}
    # 350 N is survived by 5 of 5, but 300 N only by 3: the threshold stops below 300
    assert threshold(ladder, 4) == 250.0
    assert threshold(ladder, 3) == 350.0
    assert threshold(ladder, None) == 200.0  # every replica
    assert threshold({100.0: [y, n, n, y, y]}, 4) is None  # the lowest magnitude already fails
    # the order the rows come in does not matter
    assert threshold(dict(reversed(list(ladder.items()))), 4) == 250.0


def test_summary_reports_the_rule_per_direction_and_state() -> None:
    y, n = True, False
    rows = (rows_for({200.0: [y] * 5, 300.0: [y, y, y, y, n], 400.0: [y, n, n, n, n], 500.0: [y] * 5}, 0.0, 2)
            + rows_for({200.0: [y] * 5, 300.0: [y] * 5, 400.0: [y] * 5, 500.0: [y] * 5}, 0.0, 4)
            + rows_for({200.0: [y, y, y, n, n], 300.0: [y] * 5}, 180.0, 2))
    s = summarise(rows, survive=4, replicas=5)
    cells = {(g["direction_deg"], g["phase"]): g for g in s["by_direction_and_phase"]}
    assert cells[(0.0, "state 2 at 0.50")]["threshold_n"] == 300.0
    assert cells[(0.0, "state 2 at 0.50")]["largest_survived_n"] == 500.0
    assert cells[(0.0, "state 2 at 0.50")]["survived_all_up_to_n"] == 200.0
    assert cells[(0.0, "state 2 at 0.50")]["survived_of"] == {"200": "5/5", "300": "4/5", "400": "1/5",
                                                               "500": "5/5"}
    assert cells[(0.0, "state 4 at 0.50")]["threshold_n"] == 500.0
    assert cells[(180.0, "state 2 at 0.50")]["threshold_n"] is None
    assert s["largest_survived_per_direction_n"] == {"0": 300.0, "180": None}
    assert s["rule"] == {"survive": 4, "replicas": 5}
    lines = format_summary({**s, "rollouts": len(rows)}, "out").splitlines()
    assert "every phase survived up to 300 N by 4 of 5 replicas" in lines[1]
    assert "no magnitude survived by 4 of 5 replicas in every phase" in lines[2]
    assert lines[-1] == "wrote out/results.csv, summary.json, push_polar.png, thresholds.md"
    table = threshold_table(s).splitlines()
    assert table[0] == ("torso 0.2 s: largest push (N) survived by at least 4 of 5 replicas at it and at every "
                        "lower magnitude")
    assert table[2:6] == ["| direction (deg) | state 2 at 0.50 | state 4 at 0.50 | all |", "|---:|---:|---:|---:|",
                          "| 0 | 300 | 500 | 300 |", "| 180 | - | - | - |"]


def test_summary_keeps_bodies_and_durations_apart() -> None:
    a = rows_for({100.0: [True], 200.0: [True]})
    b = [{**r, "duration": "0.4"} for r in rows_for({100.0: [True], 200.0: [False]})]
    s = summarise(a + b)
    assert [g["threshold_n"] for g in s["by_direction_and_phase"]] == [200.0, 100.0]
    assert s["largest_survived_per_setting_n"] == {"torso 0.2 s": {"0": 200.0}, "torso 0.4 s": {"0": 100.0}}
    assert s["largest_survived_per_direction_n"] == {"0": 100.0}
    assert "rule" not in s


@pytest.mark.parametrize("timing", ["phase: [[2, 0.5], [4, 0.9]]", "start: [1.5]"])
def test_replica_rows_are_seeded_and_share_an_offset_per_cell(tmp_path: Path, timing: str) -> None:
    spec = tmp_path / "rep.yaml"
    spec.write_text(REPLICATED.format(timing=timing))
    rows = load_experiment(spec).rows()
    n_cells = 2 * 2 * 2 * 3 * (2 if "phase" in timing else 1)
    assert len(rows) == 3 * n_cells and len({r.key for r in rows}) == len(rows)
    assert rows == load_experiment(spec).rows()  # deterministic
    assert {r.body for r in (row.push for row in rows)} == {"torso", "pelvis", "left_upper_arm"}
    assert {r.push.duration for r in rows} == {0.1, 0.3}
    first = rows[:n_cells]
    assert all(r.repeat == 0 and r.offset == 0.0 and r.init_noise == 0.0 and r.seed == 0 for r in first)
    later = rows[n_cells:]
    assert all(r.init_noise == 0.02 and r.seed == r.repeat for r in later)
    span = 0.1 if "phase" in timing else 0.05
    assert all(0 < abs(r.offset) <= span for r in later)
    assert len({r.offset for r in later}) > n_cells // 2  # drawn per cell and replica, not one for all
    # a cell's magnitudes share one offset: its ladder meets one gait
    by_cell: dict[tuple, set[float]] = {}
    for r in later:
        p = r.push
        by_cell.setdefault((r.repeat, p.body, p.direction, p.duration, p.state, r.params()["fraction"],
                            r.params()["start"]), set()).add(r.offset)
    assert all(len(v) == 1 for v in by_cell.values())
    # the row shows the cell's own timing and the offset beside it; the push holds both
    for r in later:
        par = r.params()
        if r.push.state is not None:
            assert par["fraction"] in (0.5, 0.9) and r.push.fraction == pytest.approx(par["fraction"] + r.offset)
            assert 0.0 <= r.push.fraction <= 1.0
        else:
            assert par["start"] == 1.5 and r.push.start == pytest.approx(1.5 + r.offset)
        assert par["phase_offset"] == pytest.approx(r.offset)
    other = tmp_path / "other.yaml"
    other.write_text(REPLICATED.format(timing=timing).replace("name: rep", "name: rep\nseed: 7"))
    assert [r.offset for r in load_experiment(other).rows()] != [r.offset for r in rows]


def test_a_replica_rollout_is_deterministic_and_perturbed(tmp_path: Path) -> None:
    spec = tmp_path / "rep.yaml"
    spec.write_text("name: rep\nseconds: 2.5\nafter: 1.0\nreplicas: {count: 2, survive: 1}\n"
                    "grid: {magnitude: [150], direction: [90], phase: [[2, 0.5]]}\n")
    exp = load_experiment(spec)
    r0, r1 = exp.rows()
    body = (None, "auto", False)
    a = run_row((r1, body, 2.5, r1.init_noise, None))
    b = run_row((r1, body, 2.5, r1.init_noise, None))
    c = run_row((r0, body, 2.5, r0.init_noise, None))
    same = ("outcome", "distance_m", "tracking_rmse_rad", "peak_com_deviation_m")
    assert [a[k] for k in same] == [b[k] for k in same]
    assert a["distance_m"] != c["distance_m"]  # the replica's noise and offset change the rollout


@pytest.mark.parametrize("text,key,msg", [
    ("replicas: {count: 3, survive: 4}\ngrid: {magnitude: [100], phase: [[2, 0.5]]}\n", "replicas",
     "survive: 4 of 3 replicas"),
    ("replicas: {count: 0}\ngrid: {magnitude: [100], phase: [[2, 0.5]]}\n", "replicas.count", "must be >= 1"),
    ("replicas: {phase_offset: 1.5}\ngrid: {magnitude: [100], phase: [[2, 0.5]]}\n", "replicas.phase_offset",
     "1.5"),
    ("replicas: {count: 5}\nruns: [{magnitude: 100, start: 2.5}]\n", "replicas", "only with a grid"),
    ("repeats: 2\nreplicas: {count: 5}\ngrid: {magnitude: [100], phase: [[2, 0.5]]}\n", "replicas",
     "not both"),
    ("init_noise: 0.1\nreplicas: {count: 5}\ngrid: {magnitude: [100], phase: [[2, 0.5]]}\n", "replicas",
     "replicas.noise"),
    ("grid: {magnitude: [100], body: [torso, tail], phase: [[2, 0.5]]}\n", "grid.body", "unknown body 'tail'"),
    ("grid: {magnitude: [100], body: [pelvis, pelvis], phase: [[2, 0.5]]}\n", "grid", "pelvis is listed twice"),
    ("replicas: {start_offset: 0.5}\ngrid: {magnitude: [100], duration: [0.4], start: [3.3]}\n",
     "replicas.start_offset", "must end within the run"),
])
def test_bad_replica_and_dimension_keys_fail_before_running(tmp_path: Path, text: str, key: str, msg: str) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text("name: x\nseconds: 4\n" + text)
    with pytest.raises(ConfigError) as exc:
        load_experiment(p)
    assert str(p) in str(exc.value) and key in str(exc.value) and msg in str(exc.value), str(exc.value)


def test_project_grid_files_load() -> None:
    """The project's replicated threshold grid and its push-dimension grid parse and validate."""
    repo = Path(__file__).resolve().parents[2] / "experiments"
    grid = load_experiment(repo / "push_grid.yaml")
    assert grid.spec.replicas is not None and grid.spec.replicas.survive == 4 and grid.spec.replicas.count == 5
    assert len(grid.rows()) == 8 * 4 * 11 * 5
    dims = load_experiment(repo / "push_dimensions.yaml")
    assert {r.push.body for r in dims.rows()} >= {"torso", "pelvis"}
    assert len({r.push.duration for r in dims.rows()}) >= 3


def test_a_replicated_sweep_writes_its_thresholds(tmp_path: Path) -> None:
    """The sweep of a replicated grid: results in replica-major order, the rule in summary.json, the
    table in thresholds.md, the polar plot."""
    spec = tmp_path / "rep.yaml"
    spec.write_text("name: rep\nseconds: 2.5\nafter: 1.0\nreplicas: {count: 2, survive: 2}\n"
                    "grid: {magnitude: [50, 2000], direction: [90], phase: [[2, 0.5]]}\n")
    summary = run_sweep(load_experiment(spec), tmp_path / "out", workers=1, progress=False)
    assert summary["rule"] == {"survive": 2, "replicas": 2}
    (cell,) = summary["by_direction_and_phase"]
    assert cell["survived_of"]["2000"] == "0/2" and cell["threshold_n"] in (50.0, None)
    table = (tmp_path / "out" / "thresholds.md").read_text()
    assert "| 90 |" in table and "at least 2 of 2 replicas" in table
    assert (tmp_path / "out" / "push_polar.png").read_bytes()[:4] == b"\x89PNG"
