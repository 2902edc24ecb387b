"""What a BVH file holds, as ``bipedsim info`` reports it: joints, frames, timing, rotation orders, the
unit and up axis (with where each came from), the root's travel and speed."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from bipedsim.motion.bvh import read_bvh
from bipedsim.motion.conventions import horizontal_axes


def describe_bvh(path: str | os.PathLike[str], scale: float | str | None = None,
                 up: str | None = None, positions: str | None = None) -> dict[str, Any]:
    """Facts about the BVH file at ``path``: what reading it found (:meth:`BVHInfo.to_dict`: joints,
    frames, fps, rotation orders, position channels, unit, height, up axis, line endings) plus
    ``duration_s`` (s), ``joint_names``, and the root's horizontal travel in the project frame:
    ``root_path_m`` (m, along the path), ``root_displacement_m`` (m, first frame to last) and
    ``root_speed_mps`` (m/s, path over duration). ``scale`` (metres per file unit or a unit name) and
    ``up`` (``"y"`` or ``"z"``) override the guesses. It is read as ``bipedsim run`` reads it for the
    body it builds (``body``: the kind measured from the skeleton, None where none can be told); a walk
    in place or a short walk cycle also gets ``walked_speed_mps`` (its travel rebuilt from its feet) and
    ``walked_note`` (what was done)."""
    from bipedsim.errors import BipedsimError, ModelError
    from bipedsim.model.creature_kind import read_for_body
    from bipedsim.model.gait import motion_for_body

    built = None
    try:
        raw, info, m, body = read_for_body(path, scale=scale, up=up, positions=positions)
    except ModelError:  # no body kind can be told: the file as read, its body unknown
        motion, info = read_bvh(path, scale=scale, up=up, positions=positions)
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
    # a walk cycle repeated, a walk in place given its travel back (model.gait): the speed it walks at
    made = [n for n in info.notes if n.startswith(("a loop:", "walks in place:"))]
    if built is not None and made and built.duration > 0:
        d["walked_speed_mps"] = travel(built)[0] / built.duration
        d["walked_note"] = "; ".join(made)
    return d


def format_description(d: dict[str, Any]) -> str:
    """The text form of :func:`describe_bvh`'s dict: one labelled line per fact, no final newline."""
    orders = ", ".join(f"{k} x{v}" for k, v in d["rotation_orders"].items())
    six = d["position_channels"]
    lines = [
        f"file        {d['path']}",
        f"joints      {d['num_joints']}  (end sites: {d['end_sites']})",
        f"frames      {d['num_frames']} at {d['fps']:.4g} fps (frame time {d['frame_time']:.6g} s), "
        f"duration {d['duration_s']:.3f} s",
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
        f"text        line endings {d['line_endings']}, final newline {'yes' if d['final_newline'] else 'no'}",
    ]
    return "\n".join(lines)
