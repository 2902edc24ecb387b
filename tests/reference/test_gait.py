"""Gait events on real walks: every shared human walk, strikes per foot within one of a count
made by hand from the foot heights; the detector's rule on synthetic signals; events given by hand."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import HAVE_SHARED, SHARED_BVH, need_shared

from bipedsim.errors import ConfigError
from bipedsim.model import build_model
from bipedsim.motion import read_bvh
from bipedsim.motion.rest import standing_rest
from bipedsim.reference import retarget
from bipedsim.reference.gait_events import contacts_from_strikes, load_events, point_contacts
from bipedsim.reference.prepare import humanoid_motion, in_place

#: Strikes per foot counted by hand from each clip's heel/toe heights and speeds (the contact that is
#: under way when a clip starts is no strike). Start-walk-stop: the left foot slides twice (a pivot, a
#: shift: 0.1-0.2 s lifts of 3 cm at 1 m/s) before the walk, then the walking steps and the stop.
HAND_COUNTS = {
    "bandai2_walk_exhausted_001": {"left": 8, "right": 9},
    "cmu_02_01_walk__holden31_crlf": {"left": 2, "right": 3},
    "cmu_02_02_walk__19joint_Hip_Abdomen": {"left": 2, "right": 2},
    "cmu_02_02_walk__daz43": {"left": 2, "right": 2},
    "cmu_12_03_walk__cgspeed_mb31": {"left": 4, "right": 3},
    "cmu_131_01_start_walk_stop__max31_mixedEOL": {"left": 6, "right": 5},
    "games105_walk60__metres_crlf": {"left": 2, "right": 3},
}
#: Strikes per foot of the same walks' stand-ins (bvh_fixtures.py), counted from the generated walk's
#: footprints: the right foot strikes every 0.93 s from 0, the left 0.465 s after it; a stand-in starts
#: 0.09 s in and lasts 3.07 s (CMU 02_01's 2.81 s, Bandai's 7.0 s)
STANDIN_COUNTS = {**{name: {"left": 3, "right": 3} for name in HAND_COUNTS},
                  "bandai2_walk_exhausted_001": {"left": 8, "right": 7}}
#: the counts the shared walks are checked against: the real takes' or their stand-ins'
COUNTS = HAND_COUNTS if HAVE_SHARED else STANDIN_COUNTS


#: controller settings that track a capture's own legs (``reference: {feasible: false}``)
AS_CAPTURED = Path(__file__).resolve().parents[1] / "data" / "reference_as_captured.yaml"


def _clip(name: str):
    m = standing_rest(read_bvh(SHARED_BVH / "human" / f"{name}.bvh")[0].to_project_frame())
    b = build_model(m)
    return m, b, retarget(m, b.model, plan=b.plan, xml=b.xml)


@pytest.mark.parametrize("name", sorted(HAND_COUNTS))
def test_strikes_per_foot_match_the_hand_count(name: str) -> None:
    _, _, clip = _clip(name)
    for foot, n in COUNTS[name].items():
        found = len(clip.events[foot]["strike"])
        assert abs(found - n) <= 1, (foot, found, n)
    if "start_walk_stop" in name:
        return  # its first steps from standing need not alternate (a shuffle before the walk)
    # strikes alternate: between two strikes of one foot the other foot strikes (a walk)
    rs, ls = clip.events["right"]["strike"], clip.events["left"]["strike"]
    for a, b in zip(rs, rs[1:]):
        assert any(a < s < b for s in ls), (a, b, ls)


def _synthetic(dt: float, noise: float, slide: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """One foot point walking 1 m/s: stance 0.6 s (sliding ``slide`` m/s), swing 0.4 s lifting 8 cm."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 6.0, dt)
    phase = (t % 1.0)
    swing = phase >= 0.6
    h = np.where(swing, 0.08 * np.sin(np.pi * (phase - 0.6) / 0.4), 0.0) + 0.03
    v = np.where(swing, 2.5, slide)
    x = np.cumsum(v) * dt
    pos = np.stack([x, np.zeros_like(x), h], axis=1)[:, None] + rng.normal(0, noise, (len(t), 1, 3))
    low = h[:, None] + rng.normal(0, noise, (len(t), 1))
    strikes = [int(round(k / dt)) for k in np.arange(1.0, 6.0, 1.0)]
    return low, pos, strikes


@pytest.mark.parametrize("fps", [30, 60, 120, 240])
@pytest.mark.parametrize("noise,slide", [(0.0, 0.0), (0.003, 0.15)])
def test_contact_rule_is_robust_to_frame_rate_noise_and_sliding(fps: int, noise: float, slide: float) -> None:
    dt = 1.0 / fps
    low, pos, strikes = _synthetic(dt, noise, slide)
    c = point_contacts(low, pos, dt)[:, 0]
    onsets = np.flatnonzero(np.diff(c.astype(int)) == 1) + 1
    assert len(onsets) == len(strikes)
    assert np.abs(onsets - strikes).max() * dt <= 0.06


def test_contact_rule_holds_its_units_in_centimetres_scale() -> None:
    """Thresholds scale with the clip: the same walk ten times bigger gives the same contacts."""
    dt = 1 / 60
    low, pos, _ = _synthetic(dt, 0.0, 0.0)
    assert np.array_equal(point_contacts(low, pos, dt), point_contacts(10 * low, 10 * pos, dt))


def test_events_by_hand(tmp_path: Path) -> None:
    f = tmp_path / "events.yaml"
    f.write_text("right: [10, '1.0s']\nleft: [40]\n")
    ev = load_events(f, ["left", "right"], num_frames=200, frame_time=0.01)
    assert ev == {"left": [40], "right": [10, 100]}
    c = contacts_from_strikes(ev, ["left", "right"], 200)
    assert c[10:40, 1].all() and c[40:100, 0].all() and not c[60:100, 1].any()
    f.write_text("rihgt: [10]\n")
    with pytest.raises(ConfigError, match="unknown foot 'rihgt'; feet: left, right"):
        load_events(f, ["left", "right"], 200, 0.01)
    f.write_text("right: [500]\n")
    with pytest.raises(ConfigError, match="not a frame in 0..199"):
        load_events(f, ["left", "right"], 200, 0.01)


def test_events_by_hand_replace_detection_and_a_failure_says_how(tmp_path: Path, capsys) -> None:
    from bipedsim.cli import main

    m, b, _ = _clip("cmu_02_01_walk__holden31_crlf")
    f = tmp_path / "ev.yaml"
    f.write_text("right: [80, 210]\nleft: [141]\n")
    clip = retarget(m, b.model, plan=b.plan, xml=b.xml, events=f)
    assert clip.events["right"]["strike"] == [80, 210] and clip.events["left"]["strike"] == [141]
    assert clip.events != retarget(m, b.model, plan=b.plan, xml=b.xml).events  # not what is detected
    f.write_text("right: [80]\n")
    bvh = SHARED_BVH / "human" / "cmu_02_01_walk__holden31_crlf.bvh"
    # too few strikes for a gait cycle: a looped cycle is refused, saying how to give them (the clip's own
    # legs: the failure is the events', and the re-solve of the legs is not waited for)
    cyc = tmp_path / "cycle.yaml"
    cyc.write_text("source: cycle\n" + AS_CAPTURED.read_text())
    args = ["run", "--bvh", str(bvh), "--events", str(f), "--seconds", "0.1"]
    assert main([*args[:1], str(cyc), *args[1:], "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert "1 right and 0 left foot strikes (right at frames [80], left at []" in err
    assert "--events FILE" in err
    # the whole clip plays, and the run says it holds the clip's last frame after it
    assert main([*args, "--out", str(tmp_path / "o")]) == 0
    assert "cycle: no gait cycle in this clip" in capsys.readouterr().out


@pytest.mark.parametrize("name", ["cmu_02_01_walk__holden31_crlf", "bandai2_walk_exhausted_001"])
def test_root_rebuilt_for_a_walk_with_its_translation_removed(name: str) -> None:
    """A shared walk made in place (its travelling joint's horizontal translation held at the first
    frame) is recognised and its root travel rebuilt from the stance feet, close to the original."""
    m = humanoid_motion(read_bvh(SHARED_BVH / "human" / f"{name}.bvh")[0])
    assert not in_place(m)
    tj = m.travel_joint()
    flat = m.copy()
    if tj == 0:
        flat.root_translation[:, :2] = m.root_translation[0, :2]
    else:
        flat.translations[:, tj, :2] = m.translations[0, tj, :2]
    assert in_place(flat)
    notes: list[str] = []
    rebuilt = humanoid_motion(flat, notes)
    assert any("walks in place" in n for n in notes)
    a = m.travel()[:, :2] - m.travel()[0, :2]
    b = rebuilt.travel()[:, :2] - rebuilt.travel()[0, :2]
    assert 0.85 < np.linalg.norm(b[-1]) / np.linalg.norm(a[-1]) < 1.1
    assert np.linalg.norm(a - b, axis=1).max() < 0.08 * np.linalg.norm(a[-1]) + 0.05


def test_run_prints_what_it_found_and_the_clip_speed(tmp_path: Path, capsys) -> None:
    import json
    import re

    from bipedsim.cli import main

    name = "bandai2_walk_exhausted_001"
    bvh = SHARED_BVH / "human" / f"{name}.bvh"
    assert main(["run", "--bvh", str(bvh), "--seconds", "0.2", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "note: rest pose: the file's identity pose is no standing body" in out
    found = re.search(r"reference: (\d+) frames at 30 fps, feet left \((\d+) strikes.*right \((\d+) strikes", out)
    assert found, out
    assert int(found[1]) == read_bvh(bvh)[1].num_frames
    assert abs(int(found[2]) - COUNTS[name]["left"]) <= 1 and abs(int(found[3]) - COUNTS[name]["right"]) <= 1
    if HAVE_SHARED:
        assert "reference: 289 frames at 30 fps, feet left (8 strikes" in out and "right (9 strikes" in out
    assert "cycle: frames " in out and "the whole clip 0.9" in out
    assert "whole clip 0.9" in next(line for line in out.splitlines() if line.startswith(("no_fall", "fall at")))
    o = json.loads((tmp_path / "o" / "outcome.json").read_text())
    assert 0.9 < o["extra"]["clip_speed_mps"] < 1.1 and o["reference_speed_mps"] > 0.5


#: The walks the default controller tracks 20 s at >= 70 % of their speed with the search off, as the
#: test suite runs (conftest.py; docs/results.md, *whole clip, feedback alone*); the others are strict
#: expected failures, so a walk that starts to pass flags its marker.
TRACKED = {"bandai2_walk_exhausted_001", "cmu_02_01_walk__holden31_crlf", "cmu_02_02_walk__19joint_Hip_Abdomen",
           "cmu_02_02_walk__daz43", "games105_walk60__metres_crlf"}
_NOT_YET = pytest.mark.xfail(strict=True, reason="not tracked at 70 % of its speed yet (docs/results.md); "
                             "strict: passing flags the marker for removal")
_MARKS: dict[str, pytest.MarkDecorator] = {
    "cmu_12_03_walk__cgspeed_mb31": pytest.mark.xfail(
        strict=True, reason="its whole clip falls within 2 s by the feedback alone; with the search on (the "
        "default of bipedsim run) its looped cycle is chosen and walks 20 s (docs/results.md)"),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", [n if n in TRACKED else pytest.param(n, marks=_MARKS.get(n, _NOT_YET))
                                  for n in sorted(HAND_COUNTS)])
def test_shared_walk_tracked_20s_at_70_percent_of_its_speed(name: str) -> None:
    """Seeds 0, 1 and 2 (0.02 rad/s of initial velocity noise on 1 and 2): every run walks the 20 s and
    the median speed is >= 70 % of the clip's (single runs vary; docs/controller.md, *Speed deficit*,
    *Soft soles*: CMU 02_01 0.84-0.88 then, 0.93 now; CMU 12_03 1.45-1.46 then, 1.28-1.32 now, overshooting)."""
    import numpy as np

    from bipedsim.control.humanoid.sources import clip_speed
    from bipedsim.sim.runner import load_scenario, run_seeds

    need_shared()
    sc = load_scenario(None, SHARED_BVH / "human" / f"{name}.bvh")
    outs = run_seeds(sc, 20.0, 3)
    assert all(o.outcome == "no_fall" for o in outs), [(o.fall_time_s, o.fall_reason) for o in outs]
    assert float(np.median([o.mean_speed_mps for o in outs])) >= 0.7 * clip_speed(sc.clip)
