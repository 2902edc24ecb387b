"""A BVH file to an MJCF body file (and optionally its retargeted reference clip), as ``bipedsim
convert`` does it, callable from a notebook."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from bipedsim.files import check_distinct_paths, check_output_file
from bipedsim.model.build import build_model, check_total_mass
from bipedsim.model.creature_kind import AUTO
from bipedsim.model.humanoid import sides_note, toes_note
from bipedsim.model.naming import load_map
from bipedsim.model.profile import HumanoidProfile, load_profile
from bipedsim.reference.prepare import load_source
from bipedsim.reference.retarget import retarget

PathLike = str | os.PathLike[str]


def convert_bvh(input: PathLike, output: PathLike, *, profile: str = AUTO, profile_file: PathLike | None = None,
                mass: float | None = None, map: PathLike | None = None, clip: PathLike | None = None,
                scale: float | str | None = None, up: str | None = None,
                positions: str | None = None, fps: float | None = None) -> dict[str, Any]:
    """Build an MJCF body from the skeleton of the BVH file ``input`` and write it to ``output``.

    ``profile``: ``"humanoid"``, ``"creature"`` or ``"auto"`` (measured from the skeleton; a ``map`` means
    a humanoid), or ``profile_file`` (a profile YAML, which wins);
    ``mass``: total body mass (kg; scales every segment); ``map``: a mapping YAML naming the humanoid
    roles' joints; ``clip``: also retarget the motion and write this ``.npz`` reference clip;
    ``scale``: metres per file unit or a unit name, ``up``: the file's up axis (``"y"``/``"z"``), both
    guessed when None; ``positions``: ``"absolute"``/``"offset"`` position channels (decided per
    joint when None); ``fps``: the capture's frame rate, replacing the file's Frame Time (None: the
    file's). Output locations are checked (errors name ``-o`` and ``--clip``; outputs that would
    overwrite each other or an input are refused) before anything is built. Returns the body's
    summary (bodies, DOFs, mass in kg, height in m, timestep in s, ...) with ``source``, ``output``,
    ``unit``, ``up`` and, with ``clip``, the clip's frames, trimmed frames and foot strikes."""
    # outputs that would overwrite each other or an input: refused before anything is read or written
    check_distinct_paths([("-o", output), ("--clip", clip)],
                         [("the input BVH", input), ("--profile-file", profile_file), ("--map", map)])
    check_total_mass(mass)
    if profile_file is not None:  # the profile file says which kind it builds
        kind = "humanoid" if isinstance(load_profile(profile_file), HumanoidProfile) else "creature"
    else:
        kind = "humanoid" if map and profile == AUTO else profile
    # read as `bipedsim run` reads it (reference.prepare.load_source): unit, static root, rest pose, in place
    _, info, motion, profile = load_source(input, scale=scale, up=up, positions=positions, profile=kind, fps=fps)
    check_output_file(output, "-o")
    if clip:
        check_output_file(clip, "--clip")
    mapping = load_map(map, motion.skeleton) if map else None
    built = build_model(motion, profile_file or profile, total_mass=mass, mapping=mapping, name=Path(output).stem,
                        source=input)
    built.write(output)
    summary = built.summary()
    summary.update({"source": str(input), "output": str(output),
                    "unit": f"{info.unit_name} ({info.unit_source})", "up": f"{info.up} ({info.up_source})",
                    "notes": list(info.notes)})
    if clip:
        ref = retarget(motion, built.model, plan=built.plan, xml=built.xml, source=str(input))
        ref.save(clip)
        summary["clip"] = {"path": str(clip), "frames": ref.num_frames, "trimmed_frames": ref.trimmed_frames,
                           "strikes": {f: len(e["strike"]) for f, e in ref.events.items()}}
    return summary


def format_convert_summary(summary: dict[str, Any]) -> str:
    """The lines ``bipedsim convert`` prints for a :func:`convert_bvh` summary: the body written and,
    when a clip was written, the clip."""
    s = summary
    note = s.get("mass_from_legs")
    mass = f"{s['total_mass_kg']:.1f} kg" + (
        f" (a {note['height_m']:.2f} m person's at BMI {note['bmi']:g}, from its {note['legs_m']:.2f} m legs)"
        if note else "")
    lines = [f"wrote {s['output']}: {s['bodies']} bodies, {s['dofs']} DOFs ({s['actuated_dofs']} actuated), "
             f"{mass}, {s['height_m']:.2f} m tall in its rest pose, profile {s['profile']}, "
             f"timestep {s['timestep_s']} s"]
    if "clip" in s:
        c = s["clip"]
        lines.append(f"wrote {c['path']}: {c['frames']} frames, foot strikes {c['strikes']}"
                     + (f", dropped {c['trimmed_frames']} leading glitch frame(s)" if c["trimmed_frames"] else ""))
    body = [n for n in (sides_note(s), toes_note(s)) if n]
    lines += [f"note: {n}" for n in [*s.get("notes", []), *body]]
    return "\n".join(lines)
