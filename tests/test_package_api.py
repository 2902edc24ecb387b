"""The package functions the command line calls, called directly with explicit arguments (as from a
notebook): each does the command's work and returns what the command prints."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from types import SimpleNamespace

import pytest
from conftest import HAVE_SHARED, REPO, example_graph_config

from bipedsim import cli
from bipedsim.data import builtin_walk_path
from bipedsim.errors import ConfigError, OutputError
from bipedsim.experiments.sweep import format_summary, interrupted_message
from bipedsim.reference import convert_bvh, describe_bvh, format_convert_summary, format_description
from bipedsim.render.gl import RenderError, choose_backend
from bipedsim.render.video import VideoOptions
from bipedsim.sim import outputs
from bipedsim.sim.outputs import check_run_options, render_folder, run_to_folder, written_line
from bipedsim.synthesis.breed import breed_files, format_breed_summary
from bipedsim.synthesis.graph import build_graph_file, format_graph_summary, format_play_summary, play_script

DATA = REPO / "src" / "bipedsim" / "data"


def test_describe_bvh_is_exported_from_model() -> None:
    d = describe_bvh(str(builtin_walk_path()))
    assert d["num_frames"] == 201 and "joints      21" in format_description(d)


def test_convert_bvh_writes_body_and_clip(tmp_path: Path) -> None:
    xml, clip = tmp_path / "walk.xml", tmp_path / "walk.npz"
    s = convert_bvh(builtin_walk_path(), xml, mass=70.0, clip=clip)
    assert xml.is_file() and clip.is_file()
    assert s["output"] == str(xml) and s["profile"] == "humanoid" and abs(s["total_mass_kg"] - 70.0) < 1e-3
    assert s["clip"]["frames"] == 201 and s["clip"]["strikes"] == {"left": 4, "right": 4}
    text = format_convert_summary(s).splitlines()
    assert text[0].startswith(f"wrote {xml}: 15 bodies, 32 DOFs (26 actuated), 70.0 kg")
    assert text[1] == f"wrote {clip}: 201 frames, foot strikes {{'left': 4, 'right': 4}}"
    json.dumps(s)  # the --json form


def test_convert_bvh_checks_outputs_before_building(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=f"^--clip {tmp_path}: is a folder"):
        convert_bvh(builtin_walk_path(), tmp_path / "a.xml", clip=tmp_path)
    assert not (tmp_path / "a.xml").exists()


def test_breed_files_writes_child_and_report(tmp_path: Path) -> None:
    child, report = tmp_path / "child.bvh", tmp_path / "r.json"
    rep = breed_files(DATA / "horse_walk.bvh", DATA / "pterosaur_flight.bvh", child, mutations=3, report=report)
    assert child.read_text().startswith("HIERARCHY") and json.loads(report.read_text())["mutations"] == 3
    assert len(rep.removed) == 3 and rep.child_frames > 0
    lines = format_breed_summary(rep, child, report).splitlines()
    assert lines[0].startswith(f"wrote {child}: {rep.child_joints} joints") and lines[-1] == f"wrote {report}"
    assert lines[1].startswith("  correspondence by role") and "LeftUpLeg=LeftUpLeg" in lines[1]
    # the kind bipedsim run detects for the child file, so the printed command needs no --profile
    from bipedsim.model.creature_kind import resolve_profile
    from bipedsim.motion import load_bvh

    assert resolve_profile(load_bvh(child)) == rep.body == "creature" and rep.body_detected
    assert lines[2] == f"  a creature: bipedsim run --bvh {child} --scale cm"
    assert len(format_breed_summary(rep, child).splitlines()) == 3


def test_graph_build_and_play_files(tmp_path: Path) -> None:
    """The example graph built and played from its files. Its clips are the shared walk and wave, or
    without ``../shared`` their stand-ins, which share no pose (a walk, and a wave standing still): pruned
    as the example is, the walk would be a dead end and dropped, so they are built unpruned."""
    import re

    cfg = example_graph_config(tmp_path)
    if not HAVE_SHARED:
        cfg.write_text(re.sub(r"(?m)^threshold_quantile:.*\n", "", cfg.read_text()))
    g = build_graph_file(cfg, tmp_path / "g.npz")
    lines = format_graph_summary(g, tmp_path / "g.npz").splitlines()
    warnings = sum(len(ly.report["warnings"]) for ly in g.layers.values())
    assert lines[0].startswith(f"wrote {tmp_path / 'g.npz'}: 5 clips")
    assert len(lines) == 1 + 2 * len(g.layers) + warnings  # a layer's line and its tags' frames
    script = tmp_path / "s.txt"
    script.write_text("WALK for 2 sec\n")
    rep = play_script(tmp_path / "g.npz", script, tmp_path / "o.bvh", report=tmp_path / "r.json")
    assert rep["fps"] == 30 and rep["frames"] == 60 and (tmp_path / "o.bvh").is_file()
    assert "fps" not in json.loads((tmp_path / "r.json").read_text())  # the file is the player's report
    assert format_play_summary(rep, "o.bvh").splitlines()[0] == "wrote o.bvh: 60 frames (2.0 s) at 30 fps"


def test_sweep_summary_text_and_interrupted_message(tmp_path: Path) -> None:
    summary = {"rollouts": 4, "outcomes": {"survived": 3, "fell": 1},
               "largest_survived_per_direction_n": {"0": 200.0, "90": None},
               "survived_per_direction": {"0": {"survived": 2, "rollouts": 2}, "90": {"survived": 1, "rollouts": 2}}}
    assert format_summary(summary, "out").splitlines() == [
        "4 rollouts: fell 1, survived 3",
        "  direction     0 deg: 2/2 survived; every phase survived up to 200 N",
        "  direction    90 deg: 1/2 survived; no magnitude survived in every phase",
        "wrote out/results.csv, summary.json, push_polar.png"]
    (tmp_path / "results.csv").write_text("key,outcome\na,survived\nb,\n")
    exp = SimpleNamespace(rows=lambda: [1, 2, 3])
    assert interrupted_message(exp, tmp_path) == (f"interrupted; {tmp_path}/results.csv holds 1 of 3 rollouts; "
                                                  "run the same command again to finish the rest")


@pytest.mark.parametrize(("kwargs", "flag"), [
    ({"support": True}, "--support"), ({"scale": "cm"}, "--scale"), ({"up": "z"}, "--up"),
    ({"init_noise": -1.0}, "--init-noise"), ({"seed": -1}, "--seed")])
def test_check_run_options_names_the_flag(kwargs: dict, flag: str) -> None:
    with pytest.raises(ConfigError, match=f"^{flag}: "):
        check_run_options(**kwargs)


def test_convert_says_where_the_mass_came_from(tmp_path: Path) -> None:
    """Without --mass the summary names the person the legs make (legs 0.933 m -> 1.90 m at BMI 22)."""
    s = convert_bvh(builtin_walk_path(), tmp_path / "walk.xml")
    assert s["mass_from_legs"] == {"legs_m": 0.933, "height_m": 1.9, "bmi": 22.0}
    assert "79.4 kg (a 1.90 m person's at BMI 22, from its 0.93 m legs)" in format_convert_summary(s)
    from bipedsim.model import load_model

    assert load_model(tmp_path / "walk.xml").summary()["mass_from_legs"] == s["mass_from_legs"]  # kept in the file
    assert convert_bvh(builtin_walk_path(), tmp_path / "w70.xml", mass=70.0)["mass_from_legs"] is None


def test_run_to_folder_writes_the_run_and_says_each_line(tmp_path: Path) -> None:
    run_to_folder(tmp_path, seconds=0.3, plots=True)  # an earlier run's plots, recorded in the manifest
    (tmp_path / "rollout.mp4").write_text("the user's own")
    lines: list[str] = []
    res = run_to_folder(tmp_path, seconds=0.3, csv=tmp_path / "j.csv", say=lines.append)
    assert res.outcome.sim_seconds == pytest.approx(0.3) and res.folder == tmp_path
    # the built-in body (legs 0.93 m) weighs 79.4 kg from its legs: the settings' forces follow
    assert lines[0].startswith("controller: settings scaled to the body (legs 0.93 m, 79.4 kg;"), lines[0]
    assert lines[1] == (f"removed from an earlier run in {tmp_path}: joint_angles.png, tracking_error.png, "
                        "com_top_view.png, contacts.png")
    assert lines[2] == f"left alone in {tmp_path}: rollout.mp4 (not written there by bipedsim, or changed since)"
    assert (tmp_path / "rollout.mp4").read_text() == "the user's own"
    assert lines[3] == outputs.outcome_line(res.outcome, res.scenario)
    assert lines[-1] == f"wrote {tmp_path / 'j.csv'}"
    assert [p.name for p in res.written] == ["outcome.json", "trajectory.npz", "model.xml", "j.csv"]
    assert all(p.is_file() for p in res.written)


def test_render_folder_writes_the_video(tmp_path: Path) -> None:
    try:
        choose_backend()
    except RenderError as exc:
        pytest.skip(f"no headless GL here: {exc}")
    run_to_folder(tmp_path, seconds=0.3)
    seen: list[str] = []
    written = render_folder(tmp_path, video_options=VideoOptions(width=160, height=120, fps=10),
                            on_write=lambda p, n: seen.append(written_line(p, n)))
    assert written == [tmp_path / "rollout.mp4"] and seen[0].startswith(f"wrote {tmp_path / 'rollout.mp4'} (")


def test_cli_restates_the_package_defaults() -> None:
    assert cli.DEFAULT_RECORD_HZ == outputs.DEFAULT_RECORD_HZ
    defaults = {f.name: f.default for f in dataclasses.fields(VideoOptions)}
    names = {"--cam-distance": "distance", "--cam-elevation": "elevation", "--cam-azimuth": "azimuth"}
    for flag, _, default, _ in cli.VIDEO_FLAGS:
        assert defaults[names.get(flag, flag[2:])] == default, flag
