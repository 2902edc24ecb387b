"""Motion graphs over real clips from another source: what the user tagged is kept (or the build says
why not), no reachable dead end (a property over random graphs and the shared clips), static roots,
mirroring and part layers on a skeleton whose root is not the hips, lost-tag errors with the fix."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from fixture_clips import walk_wave

from bipedsim.cli import main
from bipedsim.errors import BipedsimError
from bipedsim.motion import load_bvh, write_bvh
from bipedsim.motion.reroot import add_static_root
from bipedsim.synthesis.graph import FULL, MotionGraph, Player, build_graph, load_graph_config, parse
from bipedsim.synthesis.graph.commands import build_graph_file, play_script
from bipedsim.synthesis.graph.player import PlayError
from bipedsim.synthesis.graph.prune import DEFAULT_QUANTILE, Transition, choose_threshold, prune

#: Bandai-style names for the Holden skeleton's joints (the rest keep theirs)
BANDAI_NAMES = {"LeftUpLeg": "UpperLeg_L", "LeftLeg": "LowerLeg_L", "LeftFoot": "Foot_L", "LeftToeBase": "Toes_L",
                "RightUpLeg": "UpperLeg_R", "RightLeg": "LowerLeg_R", "RightFoot": "Foot_R",
                "RightToeBase": "Toes_R", "LeftArm": "UpperArm_L", "LeftForeArm": "LowerArm_L", "LeftHand": "Hand_L",
                "LeftShoulder": "Shoulder_L", "RightArm": "UpperArm_R", "RightForeArm": "LowerArm_R",
                "RightHand": "Hand_R", "RightShoulder": "Shoulder_R", "Spine1": "Chest"}
SHOW_YAML = """name: show
clips:
  - {name: walk, file: walk.bvh, tags: [WALK]}
  - {name: walk_mirror, file: walk.bvh, mirror: true, tags: [WALK]}
  - {name: wave, file: wave.bvh, tags: [WAVE_HAND]}
  - {name: call, file: wave.bvh, mirror: true, tags: [CALL]}
parts:
  Upper-Body: {root: Chest}
"""
SCRIPT = "WALK for 3 sec\nWALK with Upper-Body WAVE_HAND for 5 sec\nWALK and CALL for 3 sec\n"

#: the module fixtures build the show graph once: one worker runs the module
pytestmark = pytest.mark.xdist_group("graph_keep")


# ---------------------------------------------------------------------- no dead ends, as a property
def _random_candidates(rng: np.random.Generator, k: int) -> tuple[list[Transition], list[int]]:
    lengths = [int(rng.integers(3 * k, 12 * k)) for _ in range(int(rng.integers(1, 6)))]
    trans = []
    for _ in range(int(rng.integers(1, 40))):
        a, b = (int(x) for x in rng.integers(len(lengths), size=2))
        i = int(rng.integers(0, lengths[a] - k + 1))
        j = int(rng.integers(0, lengths[b] - 2 * k + 1))
        trans.append(Transition(a, i, b, j, float(rng.uniform()), 0.0))
    return trans, lengths


def _assert_no_dead_end(keep: list[Transition], k: int, lengths: list[int]) -> None:
    for t in keep:
        arrival = t.dst_frame + k
        assert arrival <= lengths[t.dst]
        assert any(u.src == t.dst and u.src_frame >= arrival for u in keep), (t, keep)


@pytest.mark.parametrize("seed", range(300))
def test_pruned_random_graphs_have_no_reachable_dead_end(seed: int) -> None:
    """Whatever the candidates, every frame play can arrive at after pruning has a way on ahead in its
    clip, pruning again changes nothing (the kept graph is strongly connected), and a long random walk
    through it never gets stuck."""
    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 8))
    trans, lengths = _random_candidates(rng, k)
    keep, clips, _ = prune(trans, lengths, k)
    _assert_no_dead_end(keep, k, lengths)
    assert prune(keep, lengths, k)[0] == keep
    if keep:
        clip, frame = keep[0].dst, keep[0].dst_frame + k
        for _ in range(200):
            ahead = [t for t in keep if t.src == clip and t.src_frame >= frame]
            assert ahead
            t = ahead[int(rng.integers(len(ahead)))]
            clip, frame = t.dst, t.dst_frame + k
        assert set(clips) == {t.src for t in keep} | {t.dst for t in keep}


def test_threshold_is_raised_until_every_tag_keeps_frames_and_refused_when_impossible() -> None:
    k = 2
    lengths = [40, 40, 40]
    # clips 0 and 1 loop cheaply; clip 2 only through dear transitions
    cheap = [Transition(0, 20, 1, 5, 0.1, 0.0), Transition(1, 20, 0, 5, 0.1, 0.0),
             Transition(0, 30, 0, 2, 0.1, 0.0), Transition(1, 30, 1, 2, 0.1, 0.0)]
    dear = [Transition(0, 25, 2, 3, 0.9, 0.0), Transition(2, 30, 1, 4, 0.9, 0.0)]
    names, labels = ["a", "b", "c"], [["WALK"], ["WALK"], ["WAVE"]]
    auto = choose_threshold("L", cheap + dear, names, labels, lengths, k, None, None)
    assert auto.threshold >= 0.9 and auto.how == "raised from the default quantile" and 2 in auto.kept_clips
    assert "WAVE" in auto.warnings[0] and auto.report["tags"]["WAVE"]["kept_frames"] > 0
    given = choose_threshold("L", cheap + dear, names, labels, lengths, k, None, DEFAULT_QUANTILE)
    assert 2 not in given.kept_clips and given.report["tags"]["WAVE"]["kept_frames"] == 0
    assert "c frames 0-39" in given.warnings[0] and "threshold_quantile: 0.8 keeps every tag" in given.warnings[0]
    # a tagged clip nothing leads back from: refused, saying which frames and the fix
    with pytest.raises(BipedsimError, match=r"no threshold keeps every tag .*'WAVE'.*c frames 0-39.*Fix: "):
        choose_threshold("L", cheap + dear[:1], names, labels, lengths, k, None, None)


# ---------------------------------------------------------------------- the shared clips, re-rooted
@pytest.fixture(scope="module")
def show(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The issue's setting from the shared walk and wave (without ``../shared`` the generated walk and
    wave of one walker, ``fixture_clips.py``): with a static ``joint_Root`` at the floor (the translation
    on the hips, Bandai-style names); the graph YAML uses the defaults."""
    d = tmp_path_factory.mktemp("show")
    for src, dst in zip(walk_wave(), ("walk.bvh", "wave.bvh")):
        m = load_bvh(src)
        m = m.copy(skeleton=m.skeleton.replace(names=tuple(BANDAI_NAMES.get(n, n) for n in m.skeleton.names)))
        write_bvh(add_static_root(m).with_up("y").scaled(100.0), d / dst, precision=6)
    (d / "show.yaml").write_text(SHOW_YAML)
    (d / "script.txt").write_text(SCRIPT)
    return d


@pytest.fixture(scope="module")
def show_graph(show: Path) -> MotionGraph:
    return build_graph(load_graph_config(show / "show.yaml"), show)


def test_defaults_keep_every_tag_and_report_it(show_graph: MotionGraph) -> None:
    g = show_graph
    assert g.folded_roots["walk"] == {"root": "joint_Root", "into": "Hips"} and g.skeleton.names[0] == "Hips"
    for ly in g.layers.values():
        rep = ly.report
        assert set(rep["tags"]) == {"WALK", "WAVE_HAND", "CALL"}
        assert all(e["kept_frames"] > 0 for e in rep["tags"].values()), rep["tags"]
        assert sorted(ly.kept_clips) == [0, 1, 2, 3]
        for c in rep["clips"].values():  # kept + dropped = the clip, every drop has a reason
            assert c["kept_frames"] + sum(d["to"] - d["from"] for d in c["dropped"]) == c["frames"]
            assert all(d["why"] for d in c["dropped"])
        if rep["chosen"] == "raised from the default quantile":
            assert rep["warnings"] and rep["quantile"] > DEFAULT_QUANTILE


def test_show_scripts_play_and_run(show: Path, show_graph: MotionGraph, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    """WALK / WALK with Upper-Body WAVE_HAND / WALK and CALL on the re-rooted skeleton: the output's
    root travels as the walk does, a hand rises during the gestures, and `bipedsim run` takes it."""
    g, out, rep = tmp_path / "g.npz", tmp_path / "out.bvh", tmp_path / "build.json"
    assert main(["graph", "build", str(show / "show.yaml"), "-o", str(g), "--report", str(rep)]) == 0
    printed = capsys.readouterr().out
    assert "static root 'joint_Root' folded into 'Hips'" in printed and "frames kept per tag" in printed
    assert json.loads(rep.read_text())["layers"][FULL]["tags"]["WALK"]["kept_frames"] > 0
    assert main(["graph", "play", str(g), str(show / "script.txt"), "-o", str(out)]) == 0
    m = load_bvh(out)
    walk = load_bvh(walk_wave()[0])
    src_speed = np.linalg.norm(walk.root_translation[-1, :2] - walk.root_translation[0, :2]) / walk.duration
    speed = np.linalg.norm(m.root_translation[-1, :2] - m.root_translation[0, :2]) / m.duration
    assert abs(m.duration - 11.0) < 1.5 and 0.8 * src_speed < speed < 1.2 * src_speed
    pos = m.fk()[0]
    sk = m.skeleton
    hands = np.maximum(pos[:, sk.index("Hand_R"), 2], pos[:, sk.index("Hand_L"), 2]) - pos[:, 0, 2]
    fps = 1.0 / m.frame_time
    assert hands[: int(2.5 * fps)].max() < 0.15 and hands[int(4 * fps): int(8 * fps)].max() > 0.3
    assert main(["run", "--bvh", str(out), "--seconds", "1", "--out", str(tmp_path / "run")]) == 0


@pytest.mark.parametrize("commands", [pytest.param(12, id="12"), pytest.param(100, id="100", marks=pytest.mark.slow)])
def test_player_never_reaches_a_frame_without_a_way_on(show_graph: MotionGraph, commands: int) -> None:
    """Random commands (plain, with a part, and) on the shared-clip graph: no dead end."""
    rng = np.random.default_rng(commands)
    tags, gestures = ["WALK", "WAVE_HAND", "CALL"], ["WAVE_HAND", "CALL"]
    lines = []
    for _ in range(commands):
        kind = int(rng.integers(3))
        secs = float(rng.uniform(0.5, 4.0))
        if kind == 0:
            lines.append(f"{tags[int(rng.integers(3))]} for {secs:.1f} sec")
        else:
            lines.append(f"WALK {'with Upper-Body' if kind == 1 else 'and'} {gestures[int(rng.integers(2))]} "
                         f"for {secs:.1f} sec")
    pl = Player(show_graph, start="walk")
    m = pl.run(parse("\n".join(lines), layers=tuple(show_graph.layers)))
    assert np.isfinite(m.rotations).all() and m.num_frames > commands * 0.5 * show_graph.config.fps


def test_a_script_naming_a_lost_tag_says_which_frames_and_how_to_keep_them(show: Path, tmp_path: Path) -> None:
    cfg = show / "lossy.yaml"
    cfg.write_text(SHOW_YAML.replace("name: show", "name: lossy\nthreshold_quantile: 0.01"))
    g = build_graph_file(cfg, tmp_path / "g.npz")
    warnings = [w for ly in g.layers.values() for w in ly.report["warnings"]]
    lost = sorted(t for t, e in g.layers[FULL].report["tags"].items() if e["kept_frames"] == 0)
    assert lost and warnings and "remove threshold/threshold_quantile" in warnings[0]
    script = tmp_path / "s.txt"
    script.write_text(f"{lost[0]} for 2 sec\n")
    with pytest.raises(PlayError) as exc:
        play_script(tmp_path / "g.npz", script, tmp_path / "o.bvh")
    msg = str(exc.value)
    assert f"{lost[0]!r}" in msg and "dropped from the Full-Body graph" in msg and "frames 0-" in msg
    assert "rebuild without threshold/threshold_quantile" in msg and "threshold_quantile:" in msg
