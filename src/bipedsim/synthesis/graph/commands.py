"""File to file: building a motion graph from its YAML and playing a Motion Script on a graph file into
a BVH file, as ``bipedsim graph build`` and ``bipedsim graph play`` do it, callable from a notebook."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from bipedsim.errors import ConfigError
from bipedsim.files import atomic_write_json, check_distinct_paths, check_output_file, read_input_text
from bipedsim.motion.bvh import write_bvh
from bipedsim.synthesis.graph.build import FULL, MotionGraph, build_graph, load_graph_config
from bipedsim.synthesis.graph.player import Player
from bipedsim.synthesis.graph.script import parse
from bipedsim.synthesis.graph.store import read_graph

PathLike = str | os.PathLike[str]
#: Metres -> centimetres: the played motion is written as most BVH files are, Y up, in centimetres.
BVH_UNITS_PER_M = 100.0


def build_graph_file(config: PathLike, output: PathLike, report: PathLike | None = None) -> MotionGraph:
    """Build the motion graph the YAML ``config`` describes (its clip files relative to its folder) and
    save it to ``output`` (``.npz``; checked, naming ``-o``, before the build; neither it nor ``report``
    may be an input). ``report``: also write the build report as JSON there (:func:`build_report`).
    Returns the graph."""
    path = Path(config)
    check_distinct_paths([("-o", output), ("--report", report)], [("the graph YAML", config)])
    cfg = load_graph_config(path)
    base = path.resolve().parent
    check_distinct_paths([("-o", output), ("--report", report)],
                         [(f"clip {c.name}'s file", base / c.file) for c in cfg.clips])
    check_output_file(output, "-o", (".npz",))
    if report:
        check_output_file(report, "--report")
    try:
        g = build_graph(cfg, path.resolve().parent)
    except ConfigError as exc:  # a clip's key (a missing file, the frame limit): named in the graph YAML
        if exc.path is not None:
            raise
        raise ConfigError(exc.reason, path=path, key=exc.key) from None
    full = g.layers[FULL]
    if full.scc_nodes == 0:  # nothing to play: refuse rather than write an empty graph
        given = "threshold" if cfg.threshold is not None else "threshold_quantile"
        raise ConfigError(f"pruning at threshold {full.threshold:.4g} left no frame in the full-body graph "
                          "(every tag lost); remove threshold/threshold_quantile (the builder then chooses one "
                          "that keeps every tag) or raise it", path=path, key=given)
    g.save(output)
    if report:
        atomic_write_json(report, build_report(g))
    return g


def build_report(g: MotionGraph) -> dict[str, Any]:
    """What a build kept: static roots folded per clip and, per layer, the threshold and how it was
    chosen, warnings, and per clip and tag the frames kept and dropped (with why)."""
    return {"folded_roots": g.folded_roots, "timings": g.timings,
            "layers": {name: {"parent": ly.parent, "transitions": len(ly.transitions), "nodes": ly.scc_nodes,
                              **ly.report} for name, ly in g.layers.items()}}


def format_graph_summary(g: MotionGraph, output: PathLike, report: PathLike | None = None) -> str:
    """The lines ``bipedsim graph build`` prints: the file written (clips, frames, build time in s),
    static roots folded, one line per layer (its parent, transitions, nodes in the strongly connected
    graph, motions kept, the threshold and how it was chosen), the frames each tag kept of its total,
    the build's warnings, and the ``report`` file when written."""
    lines = [f"wrote {output}: {len(g.clips)} clips, {g.timings['frames']} frames, built in "
             f"{g.timings['total_s']:.2f} s"]
    for clip, f in g.folded_roots.items():
        lines.append(f"  clip {clip}: static root {f['root']!r} folded into {f['into']!r} (it carries the motion)")
    warnings = []
    for name, ly in g.layers.items():
        rep = ly.report
        q = "" if rep.get("quantile") is None else f" {rep['quantile']:g}"
        if q and rep.get("chosen", "").startswith("raised"):  # "raised from the default quantile to 0.35"
            q = f" to{q}"
        lines.append(f"  {name:12s} parent {ly.parent or '-':10s} {len(ly.transitions):4d} transitions, "
                     f"{ly.scc_nodes} nodes in the strongly connected graph, "
                     f"motions {len(ly.kept_clips)}/{len(g.clips)}, threshold {ly.threshold:.4g} "
                     f"({rep.get('chosen', '')}{q})")
        tags = rep.get("tags", {})
        if tags:
            lines.append("    frames kept per tag: " + ", ".join(
                f"{t} {e['kept_frames']}/{e['kept_frames'] + e['dropped_frames']}" for t, e in sorted(tags.items())))
        warnings += rep.get("warnings", [])
    lines += [f"warning: {w}" for w in warnings]
    if report:
        lines.append(f"wrote {report}")
    return "\n".join(lines)


def play_script(graph: PathLike, script: PathLike, output: PathLike, *, start: str | None = None,
                report: PathLike | None = None) -> dict[str, Any]:
    """Play the Motion Script file ``script`` on the graph file ``graph`` (from :func:`build_graph_file`)
    and write the motion to ``output`` (BVH, Y up, centimetres). ``start``: the motion (name or tag)
    to start from; ``report``: also write the report as JSON there. Output locations are checked
    (errors name ``-o`` and ``--report``; outputs that would overwrite each other or an input are
    refused) before playing. Returns the report: ``frames``, ``seconds``
    (s) and the ``events`` of the path taken (time in s, layer, kind, detail, transition cost), with
    the graph's ``fps`` (frames/s) added (not in the JSON file)."""
    check_distinct_paths([("-o", output), ("--report", report)], [("the graph", graph), ("the script", script)])
    g = read_graph(graph)
    cmds = parse(read_input_text(script, "script"), source=str(script), layers=tuple(g.layers))
    check_output_file(output, "-o", (".bvh",))
    if report:
        check_output_file(report, "--report")
    player = Player(g, start=start, source=str(script))
    motion = player.run(cmds)
    write_bvh(motion.with_up("y").scaled(BVH_UNITS_PER_M), output, precision=6)
    rep = player.report()
    if report:
        atomic_write_json(report, rep)
    return {**rep, "fps": g.config.fps}


def format_play_summary(rep: dict[str, Any], output: PathLike) -> str:
    """The lines ``bipedsim graph play`` prints for a :func:`play_script` report: the file written
    (frames, seconds, fps) and one line per event."""
    lines = [f"wrote {output}: {rep['frames']} frames ({rep['seconds']:.1f} s) at {rep['fps']:g} fps"]
    for e in rep["events"]:
        cost = "" if e["cost"] is None else f" (cost {e['cost']:.3f})"
        lines.append(f"  {e['time_s']:6.2f} s  {e['layer']:12s} {e['kind']:12s} {e['detail']}{cost}")
    return "\n".join(lines)
