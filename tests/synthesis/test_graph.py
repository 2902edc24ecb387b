"""Motion graphs: the closed-form alignment, distances, pruning, layers, Motion Script, playback."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_BVH
from fixture_clips import graph_config
from scipy.optimize import minimize

from bipedsim.cli import main
from bipedsim.synthesis.graph import (
    FULL,
    MotionGraph,
    Player,
    ScriptError,
    build_graph,
    load_graph_config,
    parse,
    read_graph,
)
from bipedsim.synthesis.graph.build import summed_part_distance
from bipedsim.synthesis.graph.distance import align_2d, apply_2d, distance_matrix, windows
from bipedsim.synthesis.graph.prune import prune

REPO = Path(__file__).resolve().parents[2]
#: Documented bound: no output frame moves any joint more than this factor times the largest
#: per-frame joint displacement found in the source clips.
JUMP_FACTOR = 1.5


@pytest.mark.parametrize("seed", range(5))
def test_closed_form_alignment_matches_optimiser(seed: int) -> None:
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(40, 3))
    q = apply_2d(p, rng.uniform(-3, 3), *rng.normal(size=2)) + rng.normal(scale=0.3, size=(40, 3))
    w = rng.uniform(0.2, 2.0, 40)
    theta, x0, y0, d = align_2d(p, q, w)

    def f(v: np.ndarray) -> float:
        return float(w @ np.sum((p - apply_2d(q, *v)) ** 2, axis=1))

    best = min((minimize(f, x0=[t, 0, 0], method="BFGS", options={"gtol": 1e-13}) for t in np.linspace(-3, 3, 7)),
               key=lambda r: r.fun)
    assert abs(d - best.fun) < 1e-9
    assert abs(d - f(np.array([theta, x0, y0]))) < 1e-9


def test_distance_matrix_is_all_pairs_of_alignments() -> None:
    rng = np.random.default_rng(1)
    pa, pb = rng.normal(size=(15, 6, 3)), rng.normal(size=(12, 6, 3))
    w = rng.uniform(0.5, 2, 6)
    d = distance_matrix(pa, pb, 4, weights=w)
    wa, wb = windows(pa, 4), windows(pb, 4)
    ww = np.tile(w, 4)
    ref = np.array([[align_2d(wa[i], wb[j], ww)[3] for j in range(len(wb))] for i in range(len(wa))])
    assert np.allclose(d, ref, atol=1e-9)
    # a cloud and its turned, shifted copy are at distance zero
    assert distance_matrix(pa, np.stack([apply_2d(f, 0.7, 1.0, -2.0) for f in pa]), 4).diagonal().max() < 1e-9


def test_script_parser_and_errors() -> None:
    cmds = parse("WALK\nWALK with Upper-Body TALK for 10 sec  # comment\nwalk and wave_hand for 2.5 s\n",
                 layers=("Upper-Body",))
    assert cmds[0].main.tag == "WALK" and cmds[0].seconds is None
    assert cmds[1].mode == "with" and cmds[1].extra.layer == "Upper-Body" and cmds[1].extra.tag == "TALK"
    assert cmds[1].seconds == 10.0 and cmds[2].mode == "and" and cmds[2].seconds == 2.5
    for text, line, col, msg in (("WALK\nWALK for ten sec", 2, 10, "expected a number"),
                                 ("WALK with", 1, 10, "expected a motion name or tag"),
                                 ("WALK for 3 sex", 1, 12, "expected 'sec'"),
                                 ("WALK $", 1, 6, "unexpected character"),
                                 ("WALK TALK", 1, 6, "unexpected 'TALK'"),
                                 ("", 1, 1, "no commands")):
        with pytest.raises(ScriptError) as exc:
            parse(text, source="s.txt")
        assert (exc.value.line, exc.value.column) == (line, col) and msg in str(exc.value)
        assert str(exc.value).startswith(f"s.txt:{line}:{col}: ")


@pytest.mark.parametrize("text, col", [("WALK with Lower-Body WAVE_HAND", 11),
                                       ("WALK and lower-body WAVE_HAND for 2 sec", 10)])
def test_a_part_the_graph_lacks_is_named_with_the_graphs_parts(text: str, col: int) -> None:
    """`WALK with Lower-Body WAVE_HAND` on a graph whose only part is Upper-Body: 'no part', the parts
    listed, at the part's column -- it said "unexpected 'WAVE_HAND'"."""
    with pytest.raises(ScriptError) as exc:
        parse(text, source="s.txt", layers=(FULL, "Upper-Body"))
    assert str(exc.value).startswith(f"s.txt:1:{col}: no part ")
    assert "the graph's parts: Upper-Body" in str(exc.value) and FULL not in str(exc.value)
    with pytest.raises(ScriptError, match="no part 'Lower-Body'; the graph's parts: Upper-Body"):
        parse("Lower-Body WAVE_HAND", source="s.txt", layers=(FULL, "Upper-Body"))


@pytest.fixture(scope="module")
def graph_yaml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example graph's YAML on the real walk and wave, or without ``../shared`` on the generated
    walk and wave of one walker, which share poses as the real takes do (``fixture_clips.py``)."""
    return graph_config(tmp_path_factory.mktemp("graph"))


@pytest.fixture(scope="module")
def graph(graph_yaml: Path) -> MotionGraph:
    """The example graph built from :func:`graph_yaml`."""
    return build_graph(load_graph_config(graph_yaml), graph_yaml.parent)


def _strongly_connected(ly, lengths, k) -> bool:
    keep, _, n = prune(ly.transitions, lengths, k)
    return len(keep) == len(ly.transitions) and n > 0


def test_pruned_graphs_are_strongly_connected(graph: MotionGraph) -> None:
    lengths = [c.num_frames for c in graph.clips]
    k = graph.config.k
    for ly in graph.layers.values():
        assert ly.transitions and _strongly_connected(ly, lengths, k)
        # every arrival (a blend into frame f ends at f + k) has an exit ahead of it (no dead end)
        for t in ly.transitions:
            assert any(u.src == t.dst and u.src_frame >= t.dst_frame + k for u in ly.transitions)


def test_random_walk_of_ten_minutes_never_dead_ends(graph: MotionGraph) -> None:
    rng = np.random.default_rng(0)
    ly = graph.layers[FULL]
    clip, frame, played = ly.transitions[0].dst, ly.transitions[0].dst_frame, 0
    k = graph.config.k
    while played < 10 * 60 * graph.config.fps:
        ahead = [t for t in ly.transitions if t.src == clip and t.src_frame >= frame]
        assert ahead, f"dead end in clip {clip} at frame {frame}"
        t = ahead[rng.integers(len(ahead))]
        played += t.src_frame - frame + k
        clip, frame = t.dst, t.dst_frame + k
    assert played >= 18000


def test_layers_and_similarity(graph: MotionGraph) -> None:
    assert set(graph.layers) == {FULL, "Upper-Body"} and graph.layers["Upper-Body"].parent == FULL
    sim = graph.layers["Upper-Body"].similarity
    walk, mirror, wave = (graph.clip_index(n) for n in ("walk", "walk_mirror", "wave"))
    # an upper body is more like the walk's own mirror than like a wave
    assert sim[walk, mirror] < sim[walk, wave]
    assert graph.layers[FULL].path(walk, wave)[0] == walk and graph.layers[FULL].path(walk, wave)[-1] == wave


def test_part_motion_chosen_by_similarity_stays_closer_to_the_replaced_motion(graph: MotionGraph) -> None:
    """The method's check: of the WAVE_HAND upper bodies, the one with the lowest overall motion
    similarity to the walk has the lower summed point-cloud distance to the walk's upper body over
    3, 10 and 20 s (20 random start frames, the same for both candidates)."""
    ub = graph.layers["Upper-Body"]
    walk = graph.clip_index("walk")
    cands = graph.clips_with("WAVE_HAND")
    best = min(cands, key=lambda c: ub.similarity[walk, c])
    other = next(c for c in cands if c != best)
    starts = np.random.default_rng(0).integers(graph.clips[walk].num_frames, size=20)
    for seconds in (3.0, 10.0, 20.0):
        d_best = np.mean([summed_part_distance(graph, walk, int(s), best, seconds, ub.joints) for s in starts])
        d_other = np.mean([summed_part_distance(graph, walk, int(s), other, seconds, ub.joints) for s in starts])
        assert d_best < d_other, (seconds, d_best, d_other)


def _play(graph: MotionGraph, text: str):
    pl = Player(graph, start="walk")
    return pl, pl.run(parse(text, layers=tuple(graph.layers)))


def test_walk_with_upper_body_wave_and_walk_and_wave(graph: MotionGraph, tmp_path: Path) -> None:
    src_step = max(np.linalg.norm(np.diff(c.fk()[0], axis=0), axis=2).max() for c in graph.clips)
    sk = graph.skeleton
    for text in ("WALK with Upper-Body WAVE_HAND for 6 sec", "WALK and WAVE_HAND for 6 sec"):
        pl, m = _play(graph, text)
        pos = m.fk()[0]
        assert np.linalg.norm(np.diff(pos, axis=0), axis=2).max() <= JUMP_FACTOR * src_step
        # the legs walk: the root moves on at walking speed, the feet take turns
        speed = np.linalg.norm(m.root_translation[-1, :2] - m.root_translation[0, :2]) / m.duration
        assert speed > 0.8
        lf, rf = pos[:, sk.index("LeftFoot"), 2], pos[:, sk.index("RightFoot"), 2]
        assert np.corrcoef(lf, rf)[0, 1] < 0.2
        # an arm waves: a hand well above the hips once the layer is in
        hands = np.maximum(pos[:, sk.index("RightHand"), 2], pos[:, sk.index("LeftHand"), 2]) - pos[:, 0, 2]
        assert hands[60:].max() > 0.3 and any(e.layer == "Upper-Body" for e in pl.events)
    # walking alone keeps the hands down
    _, m = _play(graph, "WALK for 4 sec")
    pos = m.fk()[0]
    assert (np.maximum(pos[:, sk.index("RightHand"), 2], pos[:, sk.index("LeftHand"), 2]) - pos[:, 0, 2]).max() < 0.1


def test_cli_build_play_and_run(graph: MotionGraph, graph_yaml: Path, tmp_path: Path) -> None:
    g, out = tmp_path / "g.npz", tmp_path / "out.bvh"
    assert main(["graph", "build", str(graph_yaml), "-o", str(g)]) == 0
    again = read_graph(g)
    assert again.layers[FULL].transitions[0] == graph.layers[FULL].transitions[0]
    script = REPO / "examples" / "graphs" / "walk_and_wave.txt"
    assert main(["graph", "play", str(g), str(script), "-o", str(out), "--start", "walk",
                 "--report", str(tmp_path / "r.json")]) == 0
    # the output runs straight into the physics
    assert main(["run", "--bvh", str(out), "--seconds", "1", "--out", str(tmp_path / "run")]) == 0
    bad = tmp_path / "bad.txt"
    bad.write_text("WALK for 2 sec\nFLY for 2 sec\n")
    assert main(["graph", "play", str(g), str(bad), "-o", str(out)]) == 2


def test_play_errors_from_the_graph_name_the_script_file_and_line(graph: MotionGraph, tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """A tag the graph lacks is reported FILE:LINE: as a syntax error is (it said `line 2:` alone)."""
    from bipedsim.synthesis.graph import PlayError, play_script

    g = tmp_path / "g.npz"
    graph.save(g)
    script = tmp_path / "bad.txt"
    script.write_text("WALK for 1 sec\nFLY for 2 sec\n")
    with pytest.raises(PlayError) as exc:
        play_script(g, script, tmp_path / "o.bvh")
    assert str(exc.value).startswith(f"{script}:2: no motion named or tagged 'FLY'") and exc.value.line == 2
    script.write_text("WALK with NOD for 1 sec\n")
    with pytest.raises(PlayError, match=f"^{re.escape(str(script))}:1: no child layer has a motion tagged 'NOD'"):
        play_script(g, script, tmp_path / "o.bvh")
    assert main(["graph", "play", str(g), str(script), "-o", str(tmp_path / "o.bvh")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.splitlines() == [f"bipedsim graph: error: {script}:1: no child layer has a motion tagged 'NOD'"]
    # without a file name (a script parsed from text): `line N:`
    with pytest.raises(PlayError, match="^line 1: no motion named or tagged 'FLY'"):
        Player(graph, start="walk").run(parse("FLY", layers=tuple(graph.layers)))


def test_graph_config_errors(tmp_path: Path) -> None:
    from bipedsim.errors import ConfigError

    p = tmp_path / "g.yaml"
    p.write_text("name: x\nclips: []\n")
    with pytest.raises(ConfigError, match="at least one clip"):
        load_graph_config(p)
    p.write_text(f"name: x\nclips:\n  - {{name: a, file: {SHARED_BVH}/human/missing.bvh}}\n")
    with pytest.raises(ConfigError, match="no such BVH file"):
        build_graph(load_graph_config(p), tmp_path)


@pytest.mark.parametrize("content", [None, b"", b"# a README\n", "pickled"])
def test_loading_what_is_no_graph_file_says_so_and_how_to_make_one(tmp_path: Path, content: object,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """An absent, empty, text or object-holding file given as a graph: one line naming it and
    `bipedsim graph build`, exit 2 -- never a traceback nor numpy's advice to unpickle it."""
    path = tmp_path / "g.npz"
    if content == "pickled":
        np.savez(path, meta=np.array([{"a": 1}], dtype=object))
    elif content is not None:
        path.write_bytes(content)
    script = tmp_path / "s.txt"
    script.write_text("WALK for 1 sec\n")
    assert main(["graph", "play", str(path), str(script), "-o", str(tmp_path / "o.bvh")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(path) in err and "bipedsim graph build" in err, err
    assert "allow_pickle" not in err and "Traceback" not in err


def test_a_threshold_that_prunes_every_frame_is_refused_and_nothing_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Half a percent of the candidate transitions: only the ones between the stand clip and the wave
    frames it is cut from (the same poses, at distance 0) pass, and they form no loop."""
    text = graph_config(tmp_path).read_text()
    cfg = tmp_path / "g.yaml"
    text = re.sub(r"(?m)^threshold_quantile:.*$", "threshold_quantile: 0.005", text)
    assert "threshold_quantile: 0.005" in text
    cfg.write_text(text)
    out = tmp_path / "g.npz"
    assert main(["graph", "build", str(cfg), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{cfg}: threshold_quantile: pruning" in err and "left no frame" in err and "remove threshold" in err
    assert not out.exists()
