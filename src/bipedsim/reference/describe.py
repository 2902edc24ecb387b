"""What a BVH file holds, as ``bipedsim info`` reports it: joints, frames, timing, rotation orders, the
unit and up axis (with where each came from), the root's travel and speed."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from bipedsim.errors import BipedsimError, ModelError
from bipedsim.model.creature_kind import read_source
from bipedsim.model.humanoid import check_sides, sides_note
from bipedsim.model.naming import recognise_humanoid
from bipedsim.model.source import motion_points
from bipedsim.motion.bvh import BVHInfo, read_bvh
from bipedsim.motion.conventions import HIP_PER_STATURE, horizontal_axes
from bipedsim.motion.motion import check_extent
from bipedsim.reference.prepare import motion_for_body

#: The Froude number v^2 / (g h) (v the speed, h the hip's height standing) above which people run rather
#: than walk: the walk-run transition lies near 0.5 across body sizes (Alexander 1989, "Optimization and
#: gaits in the locomotion of vertebrates"); ordinary walks lie well below it.
WALK_FROUDE_MAX = 0.5
GRAVITY = 9.81


def pace_note(speed_mps: float, info: BVHInfo, step_s: float | None = None) -> str | None:
    """A line saying the clip moves faster than people walk, or None: its speed ``speed_mps`` (m/s) on its
    hip's height (``info.standing_height_m`` x :data:`HIP_PER_STATURE`) is above Froude
    :data:`WALK_FROUDE_MAX`. A walk read that fast most often has a Frame Time that is not its capture's
    rate; the line gives the flag that sets the rate, and what half the rate would give. ``step_s``: the
    clip's step time (s), for its cadence; None where unknown. None also for a body without named feet."""
    hip = info.standing_height_m * HIP_PER_STATURE
    if not (hip > 0 and speed_mps > 0):
        return None
    fr = speed_mps ** 2 / (GRAVITY * hip)
    if fr <= WALK_FROUDE_MAX:
        return None
    cadence = f", {60.0 / step_s:.0f} steps/min" if step_s else ""
    rate = (f"{info.fps:.4g} fps, given" if info.frame_time_source == "given"
            else f"{info.fps:.4g} fps, the file's Frame Time {info.file_frame_time:.6g} s")
    return (f"the clip moves at {speed_mps:.2f} m/s on a {hip:.2f} m hip height: Froude {fr:.2f} (v^2 / g h)"
            f"{cadence}; people walk below about Froude {WALK_FROUDE_MAX:g} and run above it. If this is a walk, "
            f"its frame rate ({rate}) is likely not the capture's: give the capture's rate with --clip-fps FPS "
            f"(at {info.fps / 2:.4g} fps it moves at {speed_mps / 2:.2f} m/s, Froude {fr / 4:.2f})")


def describe_bvh(path: str | os.PathLike[str], scale: float | str | None = None,
                 up: str | None = None, positions: str | None = None, fps: float | None = None) -> dict[str, Any]:
    """Facts about the BVH file at ``path``: what reading it found (:meth:`BVHInfo.to_dict`: joints,
    frames, fps, rotation orders, position channels, unit, height, up axis, line endings) plus
    ``duration_s`` (s), ``joint_names``, and the root's horizontal travel in the project frame:
    ``root_path_m`` (m, along the path), ``root_displacement_m`` (m, first frame to last) and
    ``root_speed_mps`` (m/s, path over duration). ``scale`` (metres per file unit or a unit name) and
    ``up`` (``"y"`` or ``"z"``) override the guesses, ``fps`` the file's frame rate. It is read as
    ``bipedsim run`` reads it for the body it builds (``body``: the kind measured from the skeleton, None
    where none can be told); a walk in place or a short walk cycle also gets ``walked_speed_mps`` (its
    travel rebuilt from its feet) and ``walked_note`` (what was done); a humanoid clip faster than people
    walk gets ``pace_note`` (:func:`pace_note`). A T-pose or rest pose before the take is dropped at
    reading (``lead_in_frames``, a line in ``notes``): the frames, duration and speeds are the take's."""
    built = None
    try:
        raw, info, m, body = read_source(path, scale=scale, up=up, positions=positions, fps=fps)
    except ModelError:  # no body kind can be told: the file as read, its body unknown
        motion, info = read_bvh(path, scale=scale, up=up, positions=positions, fps=fps)
        check_extent(motion, path)
        m, body = motion.to_project_frame(), None
    try:  # as `bipedsim run` prepares it: a loop repeated, a walk in place given its travel back
        built = motion_for_body(raw, m, body, info.notes) if body is not None else None
    except BipedsimError:  # what run would refuse, run says; the file's own facts stand
        built = None

    def travel(motion: Any) -> tuple[float, float]:  # (path length m, displacement m)
        root = motion.travel()[:, list(horizontal_axes(motion.up))]
        length = float(np.linalg.norm(np.diff(root, axis=0), axis=1).sum()) if motion.num_frames > 1 else 0.0
        return length, float(np.linalg.norm(root[-1] - root[0]))

    path_len, net = travel(m)
    d = info.to_dict()
    d.update({
        "body": body,
        "duration_s": m.duration,
        "joint_names": list(m.skeleton.names),
        "root_path_m": path_len,
        "root_displacement_m": net,
        "root_speed_mps": path_len / m.duration if m.duration > 0 else 0.0,
    })
    # a walk cycle repeated, a walk in place given its travel back (reference.prepare): the speed it walks at
    made = [n for n in info.notes if n.startswith(("a loop:", "walks in place:"))]
    if built is not None and made and built.duration > 0:
        d["walked_speed_mps"] = travel(built)[0] / built.duration
        d["walked_note"] = "; ".join(made)
    pace = pace_note(d.get("walked_speed_mps", d["root_speed_mps"]), info) if body == "humanoid" else None
    if pace:
        d["pace_note"] = pace
    sides = _sides_note(m) if body == "humanoid" else None
    if sides:
        d["sides_note"] = sides
    return d


def _sides_note(m: Any) -> str | None:
    """What the humanoid builder will say of a skeleton whose side names contradict its legs
    (:func:`~bipedsim.model.humanoid.check_sides`), for ``info``; None when they agree or no roles are
    found by name."""
    try:
        hm = recognise_humanoid(m.skeleton)
    except ModelError:
        return None
    _, note = check_sides(motion_points(m), hm)
    return sides_note({"sides_from_geometry": note}) if note else None


def format_description(d: dict[str, Any]) -> str:
    """The text form of :func:`describe_bvh`'s dict: one labelled line per fact, no final newline."""
    orders = ", ".join(f"{k} x{v}" for k, v in d["rotation_orders"].items())
    six = d["position_channels"]
    lines = [
        f"file        {d['path']}",
        f"joints      {d['num_joints']}  (end sites: {d['end_sites']})",
        f"frames      {d['num_frames']} at {d['fps']:.4g} fps (frame time {d['frame_time']:.6g} s"
        + (f", given; the file's {d['file_frame_time']:.6g} s" if d.get("frame_time_source") == "given" else "")
        + f"), duration {d['duration_s']:.3f} s",
        *[f"            {n}" for n in d.get("notes", []) if n.startswith(("'Frames:", "lead-in:"))],
        f"rotations   {orders}",
    ]
    if six:
        modes = ", ".join(f"{k}: {v}" for k, v in six.items())
        lines.append(f"positions   {len(six)} joint(s) with position channels -- {modes}")
    lines += [
        f"unit        {d['unit_name']} = {d['unit_scale']:.6g} m/unit ({d['unit_source']}: {d['unit_reason']})",
        (f"height      {max(d['height_m'], d['standing_height_m']):.3f} m standing (upright; this clip's "
         f"floor-to-top extent {d['height_m']:.3f} m, the hip's height says {d['standing_height_m']:.3f} m)"
         if d.get("standing_height_m") else
         f"height      {d['height_m']:.3f} m ({'upright' if d['upright'] else 'not upright: largest extent'})"),
        f"up axis     {str(d['up']).upper()} ({d['up_source']}: {d['up_reason']})",
        f"body        {d.get('body') or 'unknown (fewer than two legs found: give --profile to run it)'}",
        *([f"reading     {d['reading_note']}"] if d.get("reading_note") else []),
        f"root        path {d['root_path_m']:.3f} m, net {d['root_displacement_m']:.3f} m, "
        f"speed {d['root_speed_mps']:.3f} m/s",
        *([f"walks       {d['walked_speed_mps']:.3f} m/s ({d['walked_note']})"] if "walked_speed_mps" in d else []),
        *([f"pace        {d['pace_note']}"] if d.get("pace_note") else []),
        *([f"sides       {d['sides_note']}"] if d.get("sides_note") else []),
        f"text        line endings {d['line_endings']}, final newline {'yes' if d['final_newline'] else 'no'}",
    ]
    return "\n".join(lines)
