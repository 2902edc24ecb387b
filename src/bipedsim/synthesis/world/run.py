"""``bipedsim world``: creatures cross a world; their motions written as BVH, with a report, a paths plot
and a video, callable from a notebook."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from bipedsim.files import atomic_write_json, check_distinct_paths, check_output_file, versions
from bipedsim.motion.bvh import write_bvh
from bipedsim.reference.clip import STANCE_LEVEL_PERCENTILE
from bipedsim.synthesis.world.creature_file import NAME_PATTERN, Creature, _foot_points, creature_summary, load_creature
from bipedsim.synthesis.world.path import find_path, path_modes
from bipedsim.synthesis.world.physics import SimulateSettings, simulate_crossing
from bipedsim.synthesis.world.synth import Synthesis, body_points, synthesize
from bipedsim.synthesis.world.tiles import MIN_TILE_BODY_FRACTION, World, WorldError, load_world

PathLike = str | os.PathLike[str]
#: Up axis of the BVH files written (metres).
BVH_UP = "y"


def output_paths(output: PathLike, names: list[str]) -> list[Path]:
    """One BVH per creature: ``output`` itself for one, ``<stem>_<name>.bvh`` beside it for several (the
    names are checked file-name parts, :data:`~bipedsim.synthesis.world.creature_file.NAME_PATTERN`: nothing is written
    outside ``output``'s folder)."""
    out = Path(output)
    if len(names) == 1:
        return [out]
    for n in names:
        if not NAME_PATTERN.fullmatch(n):
            raise WorldError(f"creature name {n!r} cannot be part of a file name: a name is letters, digits, "
                             "'_', '.' or '-', starting with a letter, digit or '_'", path=str(output))
    return [out.with_name(f"{out.stem}_{n}{out.suffix or '.bvh'}") for n in names]


#: Feet within this height (m) of their resting level count as planted when skating is measured.
SKATE_HEIGHT_M = 0.02


def foot_skate(tips: np.ndarray, ground: np.ndarray | float, dt: float, frames: np.ndarray | None = None,
               height: float = SKATE_HEIGHT_M) -> float:
    """Mean horizontal speed (m/s) of foot tips (T, F, 3) on the frames where a tip is within ``height``
    of its resting level (its 5th-percentile height above ``ground``, as contact labels measure it);
    ``frames``: a (T,) mask of the frames to measure (speeds come from the whole sequence)."""
    keep = np.ones(len(tips), bool) if frames is None else np.asarray(frames, bool)
    if keep.sum() < 1 or len(tips) < 2:
        return 0.0
    h = tips[..., 2] - ground
    down = (h < np.percentile(h[keep], STANCE_LEVEL_PERCENTILE, axis=0) + height) & keep[:, None]
    sp = np.linalg.norm(np.gradient(tips[..., :2], dt, axis=0), axis=-1)
    return float(sp[down].mean()) if down.any() else 0.0


def motion_metrics(syn: Synthesis, creature: Creature, world: World) -> dict[str, Any]:
    """Foot skating of the output and, measured alike, of the source walk loop (m/s); the lowest clearance
    of any point above the terrain (m; negative = penetration); how close the root passes each path tile's
    centre (m)."""
    m = syn.motion
    pts = body_points(m)
    clearance = pts[..., 2] - world.terrain(pts[..., :2])
    _, idx = _foot_points(m, creature.feet)
    feet = pts[:, idx]
    on_ground = np.array([not lab.startswith("fly") and lab != "swim" for lab in syn.mode])
    skate = foot_skate(feet, world.terrain(feet[..., :2]), m.frame_time, on_ground)
    src = 0.0
    if "walk" in creature.clips:
        k = creature.clips["walk"]
        clip = creature.clips_source["walk"].slice(k.frames[0], k.frames[1])
        pos, cidx = _foot_points(clip, creature.feet)
        src = foot_skate(pos[:, cidx], 0.0, clip.frame_time)
    root = m.root_translation[:, :2]
    centre_dist = [float(np.min(np.linalg.norm(root - world.centre(r, c), axis=1))) for r, c in syn.tiles]
    return {"foot_skate_m_s": skate, "source_foot_skate_m_s": src, "min_clearance_m": float(clearance.min()),
            "root_to_tile_centre_m": {"max": max(centre_dist), "mean": float(np.mean(centre_dist))},
            "lifted_frames": syn.lifted_frames, "max_lift_m": syn.max_lift_m}


def cross_world(world: World, creature: Creature, weights: str = "quadratic") -> tuple[Synthesis, dict[str, Any]]:
    """Find the creature's path and synthesise its motion; returns the synthesis and its report entry."""
    t0 = time.perf_counter()
    if world.tile < MIN_TILE_BODY_FRACTION * creature.size:
        raise WorldError(f"{world.tile:g} m is too small for {creature.name}, whose body is {creature.size:.3g} m: "
                         f"a tile must be at least {MIN_TILE_BODY_FRACTION:g} of the body "
                         f"({MIN_TILE_BODY_FRACTION * creature.size:.3g} m) for a step to fit", path=world.path,
                         key="tile")
    path = find_path(world, creature.travel_modes, creature.name)
    modes = path_modes(world, path, creature.travel_modes)
    t1 = time.perf_counter()
    syn = synthesize(world, creature, path, modes, weights=weights)
    t2 = time.perf_counter()
    m = syn.motion
    (sr, sc), (gr, gc) = world.start, world.goal
    rep = {"name": creature.name, "creature_file": creature.path, "path": [list(t) for t in path.tiles],
           "modes": modes, "finder_modes": path.finder_modes, "length_m": path.length_m(world.tile),
           "curve_length_m": syn.curve.length,
           "straight_m": float(np.hypot(gr - sr, gc - sc) * world.tile), "frames": m.num_frames,
           "frame_time_s": m.frame_time, "duration_s": m.duration,
           "end_to_goal_m": float(np.linalg.norm(m.root_translation[-1, :2] - world.centre(gr, gc))),
           "events": [j.to_dict() for j in syn.jumps],
           "transitions": [{"frame": t.frame, "from": t.src, "to": t.dst, "m": t.m} for t in syn.transitions],
           "clips": creature_summary(creature), "blend": weights}
    rep["metrics"] = motion_metrics(syn, creature, world)
    rep["timings_s"] = {"path": t1 - t0, "synthesis": t2 - t1}
    rep["motion_s_per_compute_s"] = m.duration / max(t2 - t1, 1e-9)
    return syn, rep


def run_world(world: PathLike, creatures: list[PathLike], output: PathLike, *, report: PathLike | None = None,
              video: PathLike | None = None, plot: PathLike | None = None, weights: str = "quadratic",
              video_options: Any = None, progress: bool = False, say: Any = None,
              simulate: bool | SimulateSettings = False) -> dict[str, Any]:
    """Every creature crosses ``world``; writes the BVHs (metres, Y up in the file: ``load_bvh`` reads them
    back into the project frame, Z up, with the root over the tile centres), and optionally the
    report (JSON), the paths plot (PNG) and a video (the first creature, or each as ``<stem>_<name>``).
    ``simulate`` (True or its settings): each walking creature's crossing is also run in physics on the
    world's terrain (:func:`~bipedsim.synthesis.world.physics.simulate_crossing`; the report's
    ``simulated`` block), and its video shows the physical body."""
    sim_settings = simulate if isinstance(simulate, SimulateSettings) else SimulateSettings() if simulate else None
    if sim_settings is not None:
        sim_settings.validate()
    w = load_world(world)
    cs = [load_creature(c) for c in creatures]
    names = [c.name for c in cs]
    if len(set(names)) != len(names):
        names = [f"{n}{i}" for i, n in enumerate(names)]
    outs = output_paths(output, names)
    videos = output_paths(video, names) if video else []
    inputs = [("the world", world)] + [(f"creature file {c}", c) for c in creatures]
    inputs += [(f"{c.name}'s {m} clip", k.source) for c in cs for m, k in c.clips.items()]
    check_distinct_paths([("-o", o) for o in outs] + [("--report", report), ("--plot", plot)]
                         + [("--video", v) for v in videos], inputs)
    for o in outs:
        check_output_file(o, "-o", (".bvh",))
    if report:
        check_output_file(report, "--report")
    if plot:
        check_output_file(plot, "--plot", (".png",))
    for v in videos:
        check_output_file(v, "--video", (".mp4", ".gif"))
    entries, tracks = [], {}
    for c, name, out in zip(cs, names, outs):
        syn, rep = cross_world(w, c, weights)
        t0 = time.perf_counter()
        # Y up in the file (BVH's own convention): load_bvh reads it back into the project frame for any
        # creature; a Z-up file of a creature whose feet trail behind its root (flying) is guessed Y up
        write_bvh(syn.motion.with_up(BVH_UP), out, precision=6)
        rep["output"] = str(out)
        rep["timings_s"]["write"] = time.perf_counter() - t0
        entries.append(rep)
        tracks[name] = (syn.motion.root_translation, syn.mode)
        if say:
            say(format_creature_line(rep))
        n = 0
        if sim_settings is not None:
            if videos:
                from bipedsim.synthesis.world.scene import render_simulated_video

                rep["simulated"], n = render_simulated_video(w, c, syn, rep["modes"], videos[len(entries) - 1],
                                                             video_options, settings=sim_settings, progress=progress)
            else:
                rep["simulated"] = simulate_crossing(w, c, syn, rep["modes"], settings=sim_settings)
            if say:
                say(format_simulated_line(rep["name"], rep["simulated"]))
        if videos:
            from bipedsim.synthesis.world.scene import render_world_video

            v = videos[len(entries) - 1]
            if not n:  # not simulated (or skipped): the synthesised motion played back
                n = render_world_video(syn.motion, w, v, video_options, progress=progress)
            rep["video"] = {"file": str(v), "frames": n}
            if say:
                say(f"wrote {v}: {n} frames")
    if plot:
        from bipedsim.synthesis.world.plot import plot_paths

        plot_paths(w, tracks, plot)
        if say:
            say(f"wrote {plot}")
    result: dict[str, Any] = {"world": str(world), "tile_m": w.tile, "environment_weights": w.environment_weights(),
                              "creatures": entries, "versions": versions()}
    if len(entries) == 1:
        result = {**entries[0], **result}
    if report:
        atomic_write_json(Path(report), result)
        if say:
            say(f"wrote {report}")
    return result


def format_simulated_line(name: str, sim: dict[str, Any]) -> str:
    """One line for a simulated crossing: how it ended, how far from the goal and from the path."""
    if sim["outcome"] == "skipped":
        return f"{name} in physics: not simulated ({sim['why']})"
    left = sim["left_path"]
    where = (f"left the path (> {sim['settings']['off_path_m']:g} m) at {left['t_s']:.1f} s on tile "
             f"{tuple(left['tile'])}" if left else "kept to the path")
    why = f" ({sim['fall_reason']})" if sim.get("fall_reason") else ""
    fell = sim.get("fell_at")
    if fell:
        why += f" on tile {tuple(fell['tile'])}"
        if fell["to_gap_m"] is not None and fell["to_gap_m"] < sim["body_size_m"]:
            why += f", its root {fell['to_gap_m']:.2f} m from a gap"
    return (f"{name} in physics: {sim['outcome']}{why} after {sim['sim_s']:.1f} s, {sim['progress_m']:.1f} of "
            f"{sim['path_length_m']:.1f} m at {sim['speed_m_s']:.2f} m/s, ends {sim['end_to_goal_m']:.2f} m from the "
            f"goal; {where}, at most {sim['max_off_path_m']:.2f} m off it")


def format_creature_line(rep: dict[str, Any]) -> str:
    """One line per creature: output, tiles, modes used, length, frames, events, skating, clearance."""
    used = sorted(set(rep["modes"]), key=rep["modes"].index)
    met = rep["metrics"]
    return (f"wrote {rep['output']}: {rep['name']} crosses {len(rep['path'])} tiles ({', '.join(used)}), "
            f"{rep['length_m']:.1f} m (straight {rep['straight_m']:.1f} m), {rep['frames']} frames "
            f"({rep['duration_s']:.1f} s), {len(rep['events'])} jump(s), {len(rep['transitions'])} transition(s), "
            f"foot skate {met['foot_skate_m_s']:.3f} m/s (source {met['source_foot_skate_m_s']:.3f}), "
            f"lowest clearance {round(met['min_clearance_m'], 3) + 0.0:.3f} m, "
            f"ends {rep['end_to_goal_m']:.2f} m from the goal")
