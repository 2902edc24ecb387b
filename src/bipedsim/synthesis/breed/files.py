"""Breeding two BVH files into a child BVH file, as ``bipedsim breed`` does it, callable from a notebook."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

from bipedsim.errors import ConfigError, ModelError
from bipedsim.files import atomic_write_json, atomic_write_text, check_output_file
from bipedsim.model.build import build_model
from bipedsim.model.creature_kind import detect_body_kind, read_source
from bipedsim.motion.bvh import load_bvh, write_bvh
from bipedsim.motion.motion import Motion
from bipedsim.synthesis.breed.evolve import X_RANGE, BreedReport, breed, load_joint_map

PathLike = str | os.PathLike[str]
#: Metres -> centimetres: the child is written as most BVH files are, Y up, in centimetres.
CHILD_UNITS_PER_M = 100.0  # the child BVH is written in cm (run it with --scale cm)


def breed_files(a: PathLike, b: PathLike, output: PathLike, *, x: float = 0.5, mutations: int = 5,
                weights: Mapping[str, float] | None = None, map: PathLike | None = None,
                report: PathLike | None = None, save_map: PathLike | None = None) -> BreedReport:
    """Breed the motions of the BVH files ``a`` and ``b`` and write the child to ``output`` (BVH, Y up,
    centimetres). ``x``: the spacetime parameter in [0, 1] (0: A's motion, 1: B's); ``mutations``:
    joints removed with their subtrees; ``weights``: shifts of joints' activity scores (negative: more
    likely to go); ``map``: a YAML mapping joints of A to joints of B (the whole correspondence;
    without it the joints are paired by role); ``report``: also write the report as JSON there;
    ``save_map``: write the correspondence used as a mapping YAML that ``map`` accepts back (edit it
    and breed again). Output locations are checked (errors name ``-o``, ``--report`` and
    ``--save-map``) before the breeding, and ``x`` (errors name ``--x``) before reading. Returns the
    report."""
    if not X_RANGE[0] <= x <= X_RANGE[1]:  # also NaN
        raise ConfigError(f"must be in [{X_RANGE[0]:g}, {X_RANGE[1]:g}] (0: parent A's motion, 1: B's), got {x}",
                          key="--x")
    ma, mb = read_parent(a), read_parent(b)
    check_output_file(output, "-o", (".bvh",))
    if report:
        check_output_file(report, "--report")
    if save_map:
        check_output_file(save_map, "--save-map")
    mapping = load_joint_map(map, ma.skeleton, mb.skeleton) if map else None
    child, rep = breed(ma, mb, x=x, mutations=mutations, weights=dict(weights or {}), mapping=mapping,
                       names=(str(a), str(b)))
    write_bvh(child.with_up("y").scaled(CHILD_UNITS_PER_M), output, precision=6)
    rep.body, rep.body_detected = body_kind(child)
    if report:
        atomic_write_json(Path(report), rep.to_dict())
    if save_map:
        atomic_write_text(save_map, map_text(rep))
    return rep


def read_parent(path: PathLike) -> Motion:
    """A parent BVH file in the project frame (metres, Z up), read as ``bipedsim run`` reads it: its rig's
    helper bones left out and, for a creature, its unit guessed from its largest extent (the shared
    flamingo is 0.72 m tall in centimetres; as a standing human's height it read 1.84 m, in inches,
    and its children came out 2.5 x their size). A file whose body kind cannot be measured (fewer than
    two legs: a flying creature) is read as it is."""
    try:
        return read_source(path, fold_root=False)[2]  # breeding folds a static root itself, and says so
    except ModelError:
        return load_bvh(path)


def body_kind(child: Motion) -> tuple[str, bool]:
    """The body kind ``bipedsim run --bvh CHILD`` builds (``"humanoid"``/``"creature"``) and whether
    ``bipedsim run`` detects it by itself (False: it must be given with ``--profile``).

    The kind is the one ``bipedsim run`` measures (:func:`~bipedsim.model.creature_kind.detect_body_kind`);
    a child measured as a humanoid whose humanoid body does not build (a mutation took a foot), or in
    which fewer than two legs are found, runs as a creature, given with ``--profile creature``."""
    kind = detect_body_kind(child)
    if len(kind.legs) < 2:
        return "creature", False
    if kind.kind == "creature":
        return "creature", True
    try:
        build_model(child, "humanoid")
    except ModelError:
        return "creature", False
    return "humanoid", True


def map_text(rep: BreedReport) -> str:
    """The correspondence of a breeding as a mapping YAML (``joint of A: joint of B``, the reason as a
    comment) that ``--map`` reads back."""
    lines = [f"# joints of {rep.parents[0]} (left) paired with joints of {rep.parents[1]} (right);",
             "# found by " + ("role" if rep.map_source == "roles" else rep.map_source)
             + ". Edit and pass back with --map: pairs left out stay unpaired unless their names are equal."]
    for ja, jb in rep.correspondence.items():
        lines.append(f"{json.dumps(ja)}: {json.dumps(jb)}  # {rep.correspondence_reasons.get(ja, '')}")
    return "\n".join(lines) + "\n"


def format_breed_summary(rep: BreedReport, output: PathLike, report: PathLike | None = None,
                         save_map: PathLike | None = None) -> str:
    """The lines ``bipedsim breed`` prints: the child written to ``output`` (joints, frames, where they
    came from, what was removed, the time taken in ms), the correspondence used (static roots folded,
    the pairs ``A=B``), and the ``report`` and ``save_map`` files when written."""
    lines = [f"wrote {output}: {rep.child_joints} joints, {rep.child_frames} frames; common "
             f"{len(rep.kept_common)}, from A only {len(rep.only_a)}, from B only {len(rep.only_b)}; "
             f"removed {', '.join(rep.removed) or 'none'}; x={rep.x}; "
             f"{sum(rep.timings_s.values()) * 1000:.0f} ms"]
    for parent, f in rep.folded_roots.items():
        lines.append(f"  parent {parent}: static root {f['root']!r} folded into {f['into']!r} (it carries the motion)")
    for parent, ev in rep.role_evidence.items():
        if "sides" in ev:  # the names' sides contradicted by the walk (motion.roles): said, with how to overrule
            lines.append(f"  parent {parent}: {ev['sides']} (a --map names the pairs yourself)")
    how = "by role" if rep.map_source == "roles" else f"from {rep.map_source}"
    pairs = ", ".join(f"{a}={b}" for a, b in rep.correspondence.items())
    lines.append(f"  correspondence {how}, {len(rep.correspondence)} pairs (A=B): {pairs}")
    if rep.body:
        # the child's unit is known (cm): said, not left to the reader's guess, which takes a small
        # upright child for a human in inches
        flag = " --scale cm" + ("" if rep.body_detected else f" --profile {rep.body}")
        lines.append(f"  a {rep.body}: bipedsim run --bvh {output}{flag}")
    for path in (report, save_map):
        if path:
            lines.append(f"wrote {path}")
    return "\n".join(lines)
