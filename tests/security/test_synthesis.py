"""The synthesis commands (``graph build``, ``graph play``, ``world``, ``breed``) on hostile or absurd
inputs: each is one line naming the file and key (or line), exit 2, no traceback -- within 1 GiB of
address space where a size is what is hostile -- or the right result. Fixtures are generated: a tiny
graph from the shipped built-in walk, worlds on the shipped sample horse."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

from bipedsim.cli import main
from bipedsim.data import builtin_walk_path
from bipedsim.motion import Motion
from bipedsim.synthesis.breed import breed, horse_walk, pterosaur_flight
from bipedsim.synthesis.breed.evolve import BreedError
from bipedsim.synthesis.graph import read_graph
from bipedsim.synthesis.graph.build import MAX_GRAPH_FPS, MAX_GRAPH_FRAMES
from bipedsim.synthesis.graph.player import MAX_PLAY_FRAMES
from bipedsim.synthesis.graph.script import MAX_SCRIPT_COMMANDS
from bipedsim.synthesis.world.creature_file import LOOP_SEARCH_MAX_FRAMES, find_loop
from bipedsim.synthesis.world.synth import MAX_WORLD_FRAMES
from bipedsim.synthesis.world.tiles import MAX_WORLD_CELLS

REPO = Path(__file__).resolve().parents[2]
HORSE_BVH = REPO / "src" / "bipedsim" / "data" / "horse_walk.bvh"
#: 1 GiB of address space, in KiB (ulimit -v)
ONE_GIB_KB = 1 << 20
GRAPH_YAML = """\
name: tiny
fps: {fps}
k: 10
clips:
  - {{name: walk, file: {walk}, tags: [WALK]}}
  - {{name: walk_m, file: {walk}, mirror: true, tags: [WALK]}}
  - {{name: slow, file: {walk}, speed: {speed}, tags: [SLOW]}}
"""


def graph_yaml(folder: Path, name: str = "g.yaml", fps: float = 30, speed: float = 0.5, extra: str = "") -> Path:
    p = folder / name
    p.write_text(GRAPH_YAML.format(fps=fps, walk=builtin_walk_path(), speed=speed) + extra)
    return p


def horse_yaml(folder: Path, name: str = "horse", file: str = "horse.yaml") -> Path:
    p = folder / file
    p.write_text(f"name: {json.dumps(name)}\nclips:\n  walk: {HORSE_BVH}\n")
    return p


def world_yaml(folder: Path, text: str, file: str = "w.yaml") -> Path:
    p = folder / file
    p.write_text(textwrap.dedent(text))
    return p


def one_line(capsys: pytest.CaptureFixture[str], command: str) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"bipedsim {command}: error: "), lines[0]
    return lines[0]


#: the module's fixtures build a graph and run every limited case in one process: one worker runs them all
pytestmark = pytest.mark.xdist_group("security_synthesis")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with a tiny graph (three clips of the built-in walk, 448 frames at 30 fps) built as
    ``g.npz``."""
    d = tmp_path_factory.mktemp("tiny")
    assert main(["graph", "build", str(graph_yaml(d)), "-o", str(d / "g.npz")]) == 0
    return d


# ---------------------------------------------------------------------- within 1 GiB, one process
#: name -> (argv with {d} for the case folder, environment changes): each made in `limited`'s folder
LIMITED: dict[str, tuple[list[str], dict[str, str]]] = {
    "world_cells": (["world", "{d}/big.yaml", "{d}/horse.yaml", "-o", "{d}/o.bvh"], {}),
    "world_map_issue": (["world", "{d}/issue.yaml", "{d}/horse.yaml", "-o", "{d}/o.bvh"], {}),
    "world_frames": (["world", "{d}/long.yaml", "{d}/horse.yaml", "-o", "{d}/o.bvh"], {}),
    "graph_fps": (["graph", "build", "{d}/fps.yaml", "-o", "{d}/g.npz"], {}),
    "graph_frames": (["graph", "build", "{d}/frames.yaml", "-o", "{d}/g.npz"], {}),
    "graph_declared": (["graph", "play", "{d}/declared.npz", "{d}/walk.txt", "-o", "{d}/o.bvh"], {}),
    "script_seconds": (["graph", "play", "{d}/tiny.npz", "{d}/forever.txt", "-o", "{d}/o.bvh"], {}),
    "script_lines": (["graph", "play", "{d}/tiny.npz", "{d}/lines.txt", "-o", "{d}/o.bvh"], {}),
    "script_frames": (["graph", "play", "{d}/tiny.npz", "{d}/day.txt", "-o", "{d}/o.bvh"], {}),
}
DRIVER = """
import os, sys, traceback
from bipedsim.cli import main
for name, argv, env in CASES:
    os.environ.update(env)
    print("=== " + name, file=sys.stderr, flush=True)
    try:
        rc = main(argv)
    except BaseException:
        traceback.print_exc()
        rc = "traceback"
    print("=== rc " + str(rc), file=sys.stderr, flush=True)
"""


@pytest.fixture(scope="module")
def limited(tiny: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[str, list[str]]]:
    """Every case of :data:`LIMITED` run in one Python process limited to 1 GiB of address space (ulimit
    -v): per case its exit status and its stderr lines."""
    d = tmp_path_factory.mktemp("limited")
    horse_yaml(d)
    side = 250  # 62 500 tiles, more than the limit in a file of 63 KB
    rows = ["S" + "." * (side - 1)] + ["." * side] * (side - 2) + ["." * (side - 1) + "G"]
    (d / "big.yaml").write_text("tile: 2\nrows:\n" + "".join(f"  - '{r}'\n" for r in rows))
    rows = ["S" + "." * 2999] + ["." * 3000] * 2998 + ["." * 2999 + "G"]  # the issue's map: 9 MB
    (d / "issue.yaml").write_text("tile: 2\nrows:\n" + "".join(f"  - '{r}'\n" for r in rows))
    (d / "long.yaml").write_text("tile: 100\nrows: ['S" + "." * 400 + "G']\n")  # 40 km: a day of walking
    graph_yaml(d, "fps.yaml", fps=100_000)
    graph_yaml(d, "frames.yaml", fps=MAX_GRAPH_FPS, speed=0.1)  # the slow clip alone: 8900 frames
    (d / "tiny.npz").write_bytes((tiny / "g.npz").read_bytes())
    arrays = dict(np.load(tiny / "g.npz"))
    arrays["clip0_rot"] = np.zeros((1_000_000, 21, 4))  # 670 MB declared, a few KB compressed
    np.savez_compressed(d / "declared.npz", **arrays)
    (d / "walk.txt").write_text("WALK for 1 sec\n")
    (d / "forever.txt").write_text("WALK for 1000000000 sec\n")
    (d / "lines.txt").write_text("WALK\n" * 100_000)
    (d / "day.txt").write_text("WALK for 80000 sec\n")
    cases = [(name, [a.format(d=d) for a in argv], env) for name, (argv, env) in LIMITED.items()]
    code = f"CASES = {cases!r}\n{DRIVER}"
    proc = subprocess.run(["bash", "-c", f'ulimit -v {ONE_GIB_KB}; exec "{sys.executable}" -c "$0"', code],
                          capture_output=True, text=True, timeout=600, check=False)
    out: dict[str, tuple[str, list[str]]] = {}
    name, lines = None, []
    for line in proc.stderr.splitlines():
        if line.startswith("=== rc "):
            out[name] = (line[7:], lines)  # type: ignore[index]
        elif line.startswith("=== "):
            name, lines = line[4:], []
        else:
            lines.append(line)
    assert set(out) == set(LIMITED), proc.stderr[-3000:]
    return out


def limited_line(limited: dict[str, tuple[str, list[str]]], case: str, command: str) -> str:
    rc, lines = limited[case]
    assert rc == "2" and len(lines) == 1, (rc, lines)
    assert lines[0].startswith(f"bipedsim {command}: error: "), lines[0]
    return lines[0]


def test_a_world_map_past_the_tile_limit_is_refused_within_1_gib(limited) -> None:
    """A 250 x 250 map: one line naming rows, the limit and how to raise it (a 3000 x 3000 map took 7.6 GB
    then a traceback)."""
    line = limited_line(limited, "world_cells", "world")
    assert "big.yaml: rows: 250 rows x 250 columns = 62500 tiles" in line
    assert f"at most {MAX_WORLD_CELLS}" in line and "BIPEDSIM_MAX_WORLD_CELLS" in line


def test_the_issues_3000_by_3000_map_is_refused_within_1_gib(limited) -> None:
    line = limited_line(limited, "world_map_issue", "world")
    assert "issue.yaml" in line and ("limit" in line or "at most" in line)


def test_a_world_whose_crossing_passes_the_frame_limit_is_refused_before_synthesis(limited) -> None:
    line = limited_line(limited, "world_frames", "world")
    assert "long.yaml: rows: horse would need about" in line
    assert f"at most {MAX_WORLD_FRAMES} frames" in line and "BIPEDSIM_MAX_WORLD_FRAMES" in line


def test_graph_fps_100000_is_refused_within_1_gib(limited) -> None:
    """It took 3 GB then a traceback."""
    assert limited_line(limited, "graph_fps", "graph").endswith(
        f"fps.yaml: fps: must be <= {MAX_GRAPH_FPS}, got 100000.0")


def test_a_graph_past_the_frame_limit_is_refused_before_resampling(limited) -> None:
    line = limited_line(limited, "graph_frames", "graph")
    assert "frames.yaml: clips.slow: the clips up to this one hold" in line
    assert f"at most {MAX_GRAPH_FRAMES}" in line and "BIPEDSIM_MAX_GRAPH_FRAMES" in line


def test_a_graph_file_declaring_a_huge_array_is_refused_unread(limited) -> None:
    line = limited_line(limited, "graph_declared", "graph")
    assert "declared.npz: not a bipedsim motion graph (array 'clip0_rot' has shape (1000000, 21, 4)" in line


def test_walk_for_a_billion_seconds_is_refused_at_its_line(limited) -> None:
    """It ran with no limit and no output."""
    assert "forever.txt:1:10: duration 1000000000 s is longer than" in limited_line(limited, "script_seconds",
                                                                                    "graph")


def test_a_100000_line_script_is_refused_at_the_first_line_past_the_limit(limited) -> None:
    line = limited_line(limited, "script_lines", "graph")
    assert f"lines.txt:{MAX_SCRIPT_COMMANDS + 1}:1: more than {MAX_SCRIPT_COMMANDS} commands" in line


def test_a_script_asking_for_more_frames_than_one_play_writes_is_refused_before_playing(limited) -> None:
    line = limited_line(limited, "script_frames", "graph")
    assert f"day.txt:1: the motion passes {MAX_PLAY_FRAMES} frames" in line and "BIPEDSIM_MAX_PLAY_FRAMES" in line


# ---------------------------------------------------------------------- worlds
@pytest.mark.parametrize("tile", ["1e-9", "0", "-2", ".nan", ".inf", "1e9", "'two'", "true"])
def test_an_implausible_tile_is_refused_and_nothing_written(tmp_path: Path, capsys, tile: str) -> None:
    """``tile: 1e-9`` wrote a 1-frame BVH with exit 0."""
    w = world_yaml(tmp_path, f"tile: {tile}\nrows: ['S..G']\n")
    out = tmp_path / "o.bvh"
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(out)]) == 2
    line = one_line(capsys, "world")
    assert f"{w}: tile: must be" in line and " m" in line, line
    assert not out.exists()


def test_a_tile_too_small_for_the_creature_is_refused(tmp_path: Path, capsys) -> None:
    w = world_yaml(tmp_path, "tile: 0.3\nrows: ['S..G']\n")
    out = tmp_path / "o.bvh"
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(out)]) == 2
    line = one_line(capsys, "world")
    assert f"{w}: tile: 0.3 m is too small for horse, whose body is" in line
    assert not out.exists()


@pytest.mark.parametrize("legend, key, says", [
    ("{M: {height: 1.0e300}}", "legend.M.height", "must be between -100 and 100 m"),
    ("{'=': {modes: [walk], cost: .nan}}", "legend.=.cost", "must be between 0.01 and 100"),
    ("{'=': {modes: [walk], cost: 0}}", "legend.=.cost", "must be between 0.01 and 100"),
    ("{'=': {modes: walk}}", "legend.=.modes", "must be a list of travel modes"),
    ("{'=': {modes: 5}}", "legend.=.modes", "must be a list of travel modes"),
    ("{'=': {modes: [walk], water: 'yes'}}", "legend.=.water", "must be true or false"),
    ("{'=': {modes: [walk], name: \"\\e[31m\"}}", "legend.=.name", "must be printable text"),
])
def test_other_world_numbers_that_make_degenerate_output_are_refused(tmp_path: Path, capsys, legend: str,
                                                                     key: str, says: str) -> None:
    w = world_yaml(tmp_path, f"tile: 2\nrows: ['S.=MG']\nlegend: {legend}\n")
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(tmp_path / "o.bvh")]) == 2
    line = one_line(capsys, "world")
    assert f"{w}: {key}: {says}" in line, line
    assert "\x1b" not in line


def test_two_events_on_one_tile_and_too_many_events_are_refused(tmp_path: Path, capsys) -> None:
    w = world_yaml(tmp_path, "tile: 2\nrows: ['S...G']\nevents: [{at: [0, 2]}, {at: [0, 2]}]\n")
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(tmp_path / "o.bvh")]) == 2
    assert f"{w}: events[1]: at [0, 2]: events[0] is already there" in one_line(capsys, "world")
    w.write_text("tile: 2\nrows: ['S...G']\nevents: [" + ", ".join(["{at: [0, 2]}"] * 1001) + "]\n")
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(tmp_path / "o.bvh")]) == 2
    assert f"{w}: events: 1001 events; a world places at most" in one_line(capsys, "world")


def test_the_world_limits_can_be_raised_from_the_environment(tmp_path: Path, capsys, monkeypatch) -> None:
    monkeypatch.setenv("BIPEDSIM_MAX_WORLD_CELLS", "3")
    w = world_yaml(tmp_path, "tile: 2\nrows: ['S..G']\n")
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(tmp_path / "o.bvh")]) == 2
    assert "4 tiles; a world has at most 3" in one_line(capsys, "world")
    monkeypatch.setenv("BIPEDSIM_MAX_WORLD_CELLS", "many")
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(tmp_path / "o.bvh")]) == 2
    assert "BIPEDSIM_MAX_WORLD_CELLS='many': expected a positive whole number" in one_line(capsys, "world")
    monkeypatch.setenv("BIPEDSIM_MAX_WORLD_CELLS", "4")
    assert main(["world", str(w), str(horse_yaml(tmp_path)), "-o", str(tmp_path / "o.bvh")]) == 0
    assert (tmp_path / "o.bvh").is_file()


@pytest.mark.parametrize("name", ["../evil", "a/b", "..", ".hidden", "x\ny", "\x1b[2J", "a" * 65])
def test_a_creature_name_that_is_no_file_name_is_refused_and_nothing_written_outside(
        tmp_path: Path, capsys, name: str) -> None:
    """Several creatures write ``OUT_<name>.bvh``: a name with ``/`` or ``..`` wrote outside the output
    folder (or ended in a traceback)."""
    d = tmp_path / "in"
    d.mkdir()
    w = world_yaml(d, "tile: 2\nrows: ['S..G']\n")
    evil, good = horse_yaml(d, name, "evil.yaml"), horse_yaml(d)
    out = tmp_path / "out" / "o.bvh"
    before = sorted(tmp_path.rglob("*"))
    assert main(["world", str(w), str(evil), str(good), "-o", str(out)]) == 2
    line = one_line(capsys, "world")
    assert "name" in line and "\x1b" not in line and "\n" not in line
    assert sorted(tmp_path.rglob("*")) == before  # nothing written anywhere
    assert main(["breed", str(evil), str(good), "--world", str(w), "-o", str(tmp_path / "out" / "c.yaml")]) == 2
    assert "name" in one_line(capsys, "breed")
    assert not list(tmp_path.rglob("*.bvh")) and not (tmp_path / "out" / "c.yaml").exists()


@pytest.mark.parametrize("line, key, says", [
    ("scale: [1, 2]", "scale", "must be a number of metres per unit or a unit name"),
    ("up: 5", "up", "must be y or z, got 5"),
    ("up: x", "up", "must be y or z, got 'x'"),
])
def test_creature_file_keys_of_the_wrong_type_are_one_line(tmp_path: Path, capsys, line: str, key: str,
                                                           says: str) -> None:
    """A list as scale or a number as up axis were tracebacks."""
    c = tmp_path / "c.yaml"
    c.write_text(f"name: c\n{line}\nclips:\n  walk: {HORSE_BVH}\n")
    w = world_yaml(tmp_path, "tile: 2\nrows: ['S..G']\n")
    assert main(["world", str(w), str(c), "-o", str(tmp_path / "o.bvh")]) == 2
    assert f"{c}: {key}: {says}" in one_line(capsys, "world")


@pytest.mark.parametrize("clip", ["[a, b]", "5", "''"])
def test_a_creature_clip_that_is_no_file_name_is_one_line(tmp_path: Path, capsys, clip: str) -> None:
    c = tmp_path / "c.yaml"
    c.write_text(f"name: c\nclips:\n  walk: {clip}\n")
    w = world_yaml(tmp_path, "tile: 2\nrows: ['S..G']\n")
    assert main(["world", str(w), str(c), "-o", str(tmp_path / "o.bvh")]) == 2
    assert f"{c}: clips.walk: must be a BVH file name" in one_line(capsys, "world")


def test_a_creature_file_without_a_name_is_named_by_its_file_made_safe(tmp_path: Path) -> None:
    from bipedsim.synthesis.world import load_creature

    p = tmp_path / "my horse (v2).yaml"
    p.write_text(f"clips:\n  walk: {HORSE_BVH}\n")
    assert load_creature(p).name == "my_horse__v2_"


def test_the_child_creature_file_quotes_its_values(tmp_path: Path) -> None:
    """The child's YAML holds the parents' names and the command as written: quoted, and the comment on
    one line whatever the paths hold."""
    import yaml

    d = tmp_path / "a\nname: injected"
    d.mkdir()
    w = world_yaml(d, "tile: 2\nrows: ['S..G']\n")
    out = tmp_path / "child.yaml"
    assert main(["breed", str(horse_yaml(d, "h.1")), str(horse_yaml(d, "h-2", "h2.yaml")), "--world", str(w),
                 "-o", str(out)]) == 0
    data = yaml.safe_load(out.read_text())
    assert data == {"name": "h.1_h-2", "clips": {"walk": "child_walk.bvh"}}


def test_the_loop_search_of_a_long_clip_stays_within_its_window() -> None:
    """A creature clip of 30 001 frames needed 134 GiB (every pair of frames, per joint)."""
    m = horse_walk(cycles=100)  # 6001 frames, one travelling run
    tracemalloc.start()
    a, b, _ = find_loop(m, "walk")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert 0 <= a < b <= LOOP_SEARCH_MAX_FRAMES + 1
    assert peak < 400 * 2**20, peak / 2**20


# ---------------------------------------------------------------------- graphs
def test_threshold_and_threshold_quantile_together_are_refused_naming_both(tmp_path: Path, capsys) -> None:
    """One silently won."""
    g = graph_yaml(tmp_path, extra="threshold: 1.0\nthreshold_quantile: 0.3\n")
    assert main(["graph", "build", str(g), "-o", str(tmp_path / "g.npz")]) == 2
    line = one_line(capsys, "graph")
    assert f"{g}: threshold and threshold_quantile are both given" in line
    assert not (tmp_path / "g.npz").exists()


@pytest.mark.parametrize("extra, key", [("k: 100000\n", "k"), ("segment: 100000000\n", "segment"),
                                        ("fps: 0.001\n", "fps")])
def test_graph_sizes_are_bounded(tmp_path: Path, capsys, extra: str, key: str) -> None:
    text = GRAPH_YAML.format(fps=30, walk=builtin_walk_path(), speed=0.5)
    g = tmp_path / "g.yaml"
    g.write_text(text.replace("k: 10\n", "").replace("fps: 30\n", "") + extra)
    assert main(["graph", "build", str(g), "-o", str(tmp_path / "g.npz")]) == 2
    assert f"{g}: {key}: must be" in one_line(capsys, "graph")


@pytest.mark.parametrize("part", ["a b", "a/b", "x" * 65, "\x1b[2J"])
def test_a_part_name_no_script_can_write_is_refused(tmp_path: Path, capsys, part: str) -> None:
    """A part's name is a script word and names arrays in the graph file."""
    g = graph_yaml(tmp_path, extra=f"parts:\n  {json.dumps(part)}: {{root: Hips}}\n")
    assert main(["graph", "build", str(g), "-o", str(tmp_path / "g.npz")]) == 2
    line = one_line(capsys, "graph")
    assert f"{g}: parts: " in line and "cannot be named in a Motion Script" in line and "\x1b" not in line


@pytest.mark.parametrize("clip", ['{name: "\\e[2Jwipe", file: W}', '{name: x, file: W, tags: ["\\e]0;title\\a"]}',
                                  '{name: "", file: W}'])
def test_clip_names_and_tags_with_control_characters_are_refused(tmp_path: Path, capsys, clip: str) -> None:
    """They are printed in the build summary and in play errors: no control code reaches the terminal."""
    g = graph_yaml(tmp_path, extra="")
    g.write_text(g.read_text() + "  - " + clip.replace("W", str(builtin_walk_path())) + "\n")
    assert main(["graph", "build", str(g), "-o", str(tmp_path / "g.npz")]) == 2
    line = one_line(capsys, "graph")
    assert f"{g}: clips: " in line and "printable text" in line and "\x1b" not in line and "\x07" not in line


@pytest.mark.parametrize("speed, says", [(1e-9, "clips[2].speed: must be >= 0.1"),
                                         (1e9, "clips[2].speed: must be <= 10.0")])
def test_a_derived_clip_speed_is_bounded(tmp_path: Path, capsys, speed: float, says: str) -> None:
    g = graph_yaml(tmp_path, speed=speed)
    assert main(["graph", "build", str(g), "-o", str(tmp_path / "g.npz")]) == 2
    assert f"{g}: {says}" in one_line(capsys, "graph")


def _tampered(tiny: Path, tmp_path: Path, change) -> Path:  # noqa: ANN001
    """``g.npz`` of ``tiny`` with ``change(arrays, meta)`` applied (arrays and the decoded meta edited in
    place), saved as ``t.npz``."""
    z = dict(np.load(tiny / "g.npz"))
    meta = json.loads(str(z["meta"]))
    change(z, meta)
    z["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(tmp_path / "t.npz", **z)
    return tmp_path / "t.npz"


def _set(arr: str, index: tuple, value: float):  # noqa: ANN202
    def change(z, meta) -> None:  # noqa: ANN001
        z[arr] = z[arr].copy()
        z[arr][index] = value
    return change


def _meta(path: list, value: object):  # noqa: ANN202
    def change(z, meta) -> None:  # noqa: ANN001
        d = meta
        for p in path[:-1]:
            d = d[p]
        d[path[-1]] = value
    return change


@pytest.mark.parametrize("change, says", [
    (_set("clip0_root", (5, 0), np.nan), "array 'clip0_root' holds NaN or infinite values"),
    (_set("clip1_rot", (3, 2, 0), np.inf), "array 'clip1_rot' holds NaN or infinite values"),
    (_set("clip0_rot", (3, 2, 0), 5.0), "array 'clip0_rot' holds rotations that are not unit quaternions"),
    (_set("clip0_root", (2, 2), 1e300), "array 'clip0_root' holds values beyond"),
    (_set("Full-Body_predecessors", (0, 1), 7), "array 'Full-Body_predecessors' points outside the clips"),
    (_set("Full-Body_path_cost", (0, 1), np.nan), "array 'Full-Body_path_cost' holds NaN or negative costs"),
    (_set("Full-Body_similarity", (1, 1), -np.inf), "array 'Full-Body_similarity' holds NaN"),
    (lambda z, meta: z.update(clip0_root=z["clip0_root"].astype(np.complex128)), "has dtype complex128"),
    (lambda z, meta: z.update(clip0_root=z["clip0_root"][:, :2]), "array 'clip0_root' has shape"),
    (lambda z, meta: z.pop("clip1_rot"), "array 'clip1_rot' is missing"),
    (_meta(["layers", "Full-Body", "transitions", 0, "src_frame"], 10**9), "transition frame = 1000000000 is out"),
    (_meta(["layers", "Full-Body", "transitions", 0, "dst"], -1), "transition clip = -1 is out of range"),
    (_meta(["layers", "Full-Body", "joints"], [0, 99]), "joint = 99 is out of range"),
    (_meta(["layers", "Full-Body", "threshold"], "NaN"), "threshold is not a finite number"),
    (_meta(["skeleton", "parents"], [99] * 21), "a skeleton parent = 99 is out of range"),
    (_meta(["skeleton", "parents"], [5] * 21), "joint 0 must be the only root"),
    (_meta(["skeleton", "offsets", 0], [0, 0, float("nan")]), "skeleton offsets"),
    (_meta(["skeleton", "names", 3], "\x1b[2J"), "a skeleton name holds control characters"),
    (_meta(["config", "fps"], 1e6), "its config"),
    (_meta(["tags"], [["WALK"]]), "its tags do not match its clips"),
    (_meta(["layers", "Full-Body", "report"], {"tags": {"WALK": {"kept_frames": "x"}}}), "report kept frames"),
])
def test_a_tampered_graph_file_is_refused_naming_the_part(tiny: Path, tmp_path: Path, capsys, change,  # noqa: ANN001
                                                          says: str) -> None:
    """NaN in a graph file gave a BVH rooted at the origin: every array and index is checked first."""
    t = _tampered(tiny, tmp_path, change)
    (tmp_path / "s.txt").write_text("WALK for 2 sec\n")
    out = tmp_path / "o.bvh"
    assert main(["graph", "play", str(t), str(tmp_path / "s.txt"), "-o", str(out)]) == 2
    line = one_line(capsys, "graph")
    assert line.startswith(f"bipedsim graph: error: {t}: not a bipedsim motion graph (") and says in line, line
    assert not out.exists()


def test_deeply_nested_json_in_a_graph_file_is_one_line(tiny: Path, tmp_path: Path, capsys) -> None:
    z = dict(np.load(tiny / "g.npz"))
    z["meta"] = np.array("[" * 100_000 + "]" * 100_000)
    np.savez_compressed(tmp_path / "t.npz", **z)
    (tmp_path / "s.txt").write_text("WALK\n")
    assert main(["graph", "play", str(tmp_path / "t.npz"), str(tmp_path / "s.txt"), "-o", str(tmp_path / "o.bvh")]) == 2
    assert "not a bipedsim motion graph" in one_line(capsys, "graph")


def test_the_untampered_graph_file_loads_and_plays(tiny: Path, tmp_path: Path) -> None:
    """The checks refuse what is wrong, not a graph the builder wrote."""
    g = read_graph(tiny / "g.npz")
    assert [m.num_frames for m in g.clips] == [112, 112, 224]
    (tmp_path / "s.txt").write_text("WALK for 2 sec\nSLOW for 2 sec\n")
    assert main(["graph", "play", str(tiny / "g.npz"), str(tmp_path / "s.txt"), "-o", str(tmp_path / "o.bvh")]) == 0


@pytest.mark.parametrize("data, says", [
    (b"WALK for 2 sec\n\xff\xfe\x00binary\n", "s.txt: line 2: not UTF-8 text"),
    (b"WALK for 2 sec\nWALK\x00\x1b[2J\n", "s.txt:2:5: unexpected character '\\x00'"),
])
def test_binary_bytes_in_a_script_are_one_line(tiny: Path, tmp_path: Path, capsys, data: bytes, says: str) -> None:
    """They gave a traceback."""
    s = tmp_path / "s.txt"
    s.write_bytes(data)
    assert main(["graph", "play", str(tiny / "g.npz"), str(s), "-o", str(tmp_path / "o.bvh")]) == 2
    line = one_line(capsys, "graph")
    assert says in line and "\x1b" not in line and "\x00" not in line


def test_script_errors_count_lines_as_an_editor_does(tiny: Path, tmp_path: Path, capsys) -> None:
    """A form feed or vertical tab inside a line does not start a new one (str.splitlines would)."""
    s = tmp_path / "s.txt"
    s.write_bytes(b"WALK for 1 sec\r\nWALK \x0c for 1 sec\r\nFLY\r\n")
    assert main(["graph", "play", str(tiny / "g.npz"), str(s), "-o", str(tmp_path / "o.bvh")]) == 2
    assert f"{s}:3: no motion named or tagged 'FLY'" in one_line(capsys, "graph")


def test_the_play_frame_limit_is_checked_while_playing(tiny: Path, tmp_path: Path, capsys, monkeypatch) -> None:
    """A script whose commands have no durations (each plays its motion once) is stopped at the limit."""
    monkeypatch.setenv("BIPEDSIM_MAX_PLAY_FRAMES", "300")
    s = tmp_path / "s.txt"
    s.write_text("WALK\n" * 20)
    assert main(["graph", "play", str(tiny / "g.npz"), str(s), "-o", str(tmp_path / "o.bvh")]) == 2
    assert "the motion passes 300 frames here" in one_line(capsys, "graph")
    assert not (tmp_path / "o.bvh").exists()


# ---------------------------------------------------------------------- nested YAML, per reader
def _deep(folder: Path, name: str) -> Path:
    p = folder / name
    p.write_text("a: " + "[" * 1000 + "]" * 1000 + "\n")
    return p


@pytest.mark.parametrize("which", ["world", "creature", "graph build", "breed --map", "breed --world"])
def test_deeply_nested_yaml_is_one_line_in_every_synthesis_reader(tmp_path: Path, capsys, which: str) -> None:
    """It was a RecursionError traceback in world and graph build."""
    deep = _deep(tmp_path, "deep.yaml")
    w = world_yaml(tmp_path, "tile: 2\nrows: ['S..G']\n")
    horse = horse_yaml(tmp_path)
    argv = {"world": ["world", str(deep), str(horse), "-o", str(tmp_path / "o.bvh")],
            "creature": ["world", str(w), str(deep), "-o", str(tmp_path / "o.bvh")],
            "graph build": ["graph", "build", str(deep), "-o", str(tmp_path / "g.npz")],
            "breed --map": ["breed", str(HORSE_BVH), str(HORSE_BVH), "-o", str(tmp_path / "c.bvh"),
                            "--map", str(deep)],
            "breed --world": ["breed", str(horse), str(horse), "--world", str(deep), "-o",
                              str(tmp_path / "c.yaml")]}[which]
    assert main(argv) == 2
    line = one_line(capsys, argv[0])
    assert f"{deep}: line 1, column" in line and "nested more than" in line


# ---------------------------------------------------------------------- breeding
def test_parents_past_the_breed_frame_limit_are_refused_before_the_work(monkeypatch) -> None:
    monkeypatch.setenv("BIPEDSIM_MAX_BREED_FRAMES", "150")
    a, b = horse_walk(), pterosaur_flight(cycles=8)
    with pytest.raises(BreedError, match=r"parent A horse has 181 frames .* at most 150 frames each"):
        breed(a, b, names=("horse", "ptero"))
    with pytest.raises(BreedError, match=r"parent B ptero has \d+ frames at parent A's frame rate"):
        breed(a.slice(0, 100), b, names=("horse", "ptero"))


def test_a_weight_that_is_no_finite_number_is_refused(tmp_path: Path, capsys) -> None:
    assert main(["breed", str(HORSE_BVH), str(HORSE_BVH), "-o", str(tmp_path / "c.bvh"),
                 "--weight", "Neck=nan"]) == 2
    assert "weight for joint 'Neck' must be a finite number, got nan" in one_line(capsys, "breed")
    assert not (tmp_path / "c.bvh").exists()


def test_the_survivor_step_compares_long_parents_in_blocks_with_the_same_child(monkeypatch) -> None:
    from bipedsim.synthesis.breed import transfer as evolve

    a, b = horse_walk(cycles=6), pterosaur_flight(cycles=8)
    whole, _ = breed(a, b, x=0.4)
    monkeypatch.setattr(evolve, "PAIR_BLOCK", 4000)  # blocks of a few of A's frames
    blocks, _ = breed(a, b, x=0.4)
    assert isinstance(whole, Motion) and np.array_equal(whole.rotations, blocks.rotations)


def test_graph_distances_in_blocks_equal_the_whole(monkeypatch) -> None:
    from bipedsim.synthesis.graph import distance

    rng = np.random.default_rng(0)
    pa, pb = rng.normal(size=(90, 5, 3)), rng.normal(size=(70, 5, 3))
    whole = distance.distance_matrix(pa, pb, 4)
    monkeypatch.setattr(distance, "BLOCK_VALUES", 4 * 5 * 13)
    assert np.allclose(distance.distance_matrix(pa, pb, 4), whole, rtol=1e-12, atol=1e-9)


def test_a_graph_archive_member_that_is_no_array_is_refused(tiny: Path, tmp_path: Path, capsys) -> None:
    t = tmp_path / "t.npz"
    t.write_bytes((tiny / "g.npz").read_bytes())
    with zipfile.ZipFile(t, "a") as zf:
        zf.writestr("payload.py", "print('hi')\n")
    (tmp_path / "s.txt").write_text("WALK\n")
    assert main(["graph", "play", str(t), str(tmp_path / "s.txt"), "-o", str(tmp_path / "o.bvh")]) == 2
    assert "member 'payload.py' is not an array" in one_line(capsys, "graph")
