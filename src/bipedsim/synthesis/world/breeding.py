"""Environment-weighted breeding: two creature files and a world give a child creature file.

The world's environment weights E = (MT_F, MT_W, MT_S) / MT_ALL (tile shares allowing flying, walking,
swimming) weight each creature's abilities: w = E on the modes it has, 0 elsewhere. The child has the modes
of both parents. Its Bray-Curtis dissimilarity to each parent,
D(C, P) = sum |w_C - w_P| / (sum w_C + sum w_P), sets the parents' transfer weights: parent P gets
(1 - D(C, P)) / sum over parents of (1 - D). Each mode's clip is bred by hierarchical evolution
(:func:`bipedsim.synthesis.breed.breed`) from the parents' clips for that mode (a parent without it gives its first
clip) with the spacetime parameter x = B's transfer weight, moved half-way toward the parent that has the
mode when only one has it (x + (h_B - h_A) / 2, clipped to [0, 1]): a walk comes mostly from the walker.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from bipedsim.files import atomic_write_json, atomic_write_text, check_distinct_paths, check_output_file
from bipedsim.motion.bvh import load_bvh, write_bvh
from bipedsim.synthesis.breed import breed
from bipedsim.synthesis.breed.files import CHILD_UNITS_PER_M
from bipedsim.synthesis.world.creature_file import load_creature
from bipedsim.synthesis.world.tiles import TRAVEL_MODES, World, WorldError, load_world

PathLike = str | os.PathLike[str]
#: How far (of the way from the Bray-Curtis x) a mode only one parent has moves toward that parent.
OWNER_SHIFT = 0.5
#: Joints removed by mutation unless asked otherwise: none, since each limb may carry one of the modes
#: (a flying horse keeps its legs and its wings).
WORLD_MUTATIONS = 0
#: Weight that forces a joint's removal, so every mode's child has the first mode's skeleton.
FORCE_REMOVE = -1e6


def ability_weights(modes: list[str], env: dict[str, float]) -> dict[str, float]:
    """(w_F, w_W, w_S): the environment weight of each travel mode the creature has, 0 for the others."""
    return {m: (env[m] if m in modes else 0.0) for m in TRAVEL_MODES}


def bray_curtis(wc: dict[str, float], wp: dict[str, float]) -> float:
    """D(C, P) = (|w_CF - w_PF| + |w_CW - w_PW| + |w_CS - w_PS|) / (sum_C + sum_P); 0 when both are empty."""
    den = sum(wc.values()) + sum(wp.values())
    return sum(abs(wc[m] - wp[m]) for m in TRAVEL_MODES) / den if den > 0 else 0.0


def parent_weights(world: World, modes_a: list[str], modes_b: list[str]) -> dict[str, Any]:
    """Environment weights, each creature's ability weights, the Bray-Curtis dissimilarities and the
    parents' transfer weights (summing to 1)."""
    env = world.environment_weights()
    child = sorted(set(modes_a) | set(modes_b), key=TRAVEL_MODES.index)
    wa, wb, wc = (ability_weights(m, env) for m in (modes_a, modes_b, child))
    da, db = bray_curtis(wc, wa), bray_curtis(wc, wb)
    sa, sb = 1.0 - da, 1.0 - db
    ta = sa / (sa + sb) if sa + sb > 0 else 0.5
    return {"environment": env, "ability": {"A": wa, "B": wb, "child": wc}, "bray_curtis": {"A": da, "B": db},
            "transfer": {"A": ta, "B": 1.0 - ta}, "child_modes": child}


def mode_x(mode: str, has_a: bool, has_b: bool, x_b: float) -> float:
    """The spacetime parameter for ``mode``'s clip: B's transfer weight, moved :data:`OWNER_SHIFT` toward
    the parent that has the mode when only one has it."""
    return min(1.0, max(0.0, x_b + OWNER_SHIFT * (int(has_b) - int(has_a))))


def _creature_clips(path: PathLike) -> tuple[str, dict[str, Path]]:
    """A creature file's name and its clip files per mode (checked by :func:`load_creature`)."""
    c = load_creature(path)
    return c.name, {m: Path(k.source) for m, k in c.clips.items()}


def _printable(text: str) -> str:
    """``text`` with every character that is not printable (a newline, a control code) made ``?``: safe
    in a YAML comment and on a terminal."""
    return "".join(ch if ch.isprintable() else "?" for ch in text)


def breed_world_files(a: PathLike, b: PathLike, world: PathLike, output: PathLike, *, mutations: int = WORLD_MUTATIONS,
                      report: PathLike | None = None) -> dict[str, Any]:
    """Breed creature files ``a`` and ``b`` for ``world``; writes the child creature YAML ``output`` and one
    BVH per mode beside it (``<stem>_<mode>.bvh``, Y up, cm like ``bipedsim breed``); returns the report
    (also written to ``report``)."""
    for parent in (a, b):
        if Path(parent).suffix.lower() == ".bvh":
            raise WorldError("with --world the parents are creature files (name, clips: mode -> BVH; see "
                             "examples/worlds/horse.yaml), not BVH files", path=str(parent))
    w = load_world(world)
    (name_a, clips_a), (name_b, clips_b) = _creature_clips(a), _creature_clips(b)
    out = Path(output)
    travel_a = [m for m in TRAVEL_MODES if m in clips_a]
    travel_b = [m for m in TRAVEL_MODES if m in clips_b]
    pw = parent_weights(w, travel_a, travel_b)
    modes = pw["child_modes"]
    # every file written (the child, its clips beside it, the report) checked before any work
    mode_files = {m: out.with_name(f"{out.stem}_{m}.bvh") for m in modes}
    inputs = [("parent A", a), ("parent B", b), ("the world", world)]
    inputs += [(f"parent {who}'s {m} clip", f) for who, clips in (("A", clips_a), ("B", clips_b))
               for m, f in clips.items()]
    check_distinct_paths([("-o", out), ("--report", report)]
                         + [(f"the child's {m} clip", f) for m, f in mode_files.items()], inputs)
    check_output_file(out, "-o", (".yaml", ".yml"))
    for f in mode_files.values():
        check_output_file(f, "-o")
    if report:
        check_output_file(report, "--report")
    first_a, first_b = clips_a[travel_a[0]], clips_b[travel_b[0]]
    files, per_mode, skeleton, forced = {}, {}, None, None
    for m in modes:
        fa, fb = clips_a.get(m, first_a), clips_b.get(m, first_b)
        x = mode_x(m, m in clips_a, m in clips_b, pw["transfer"]["B"])
        kw = ({"mutations": mutations} if forced is None else
              {"mutations": len(forced), "weights": {j: FORCE_REMOVE for j in forced}})
        child, rep = breed(load_bvh(fa), load_bvh(fb), x=x, names=(str(fa), str(fb)), **kw)
        if skeleton is None:
            skeleton, forced = child.skeleton, rep.removed
        elif not child.skeleton.same_structure(skeleton):
            raise WorldError(f"the {m} child has another skeleton than the {modes[0]} child", path=str(out))
        f = mode_files[m]
        write_bvh(child.with_up("y").scaled(CHILD_UNITS_PER_M), f, precision=6)
        files[m] = f.name
        per_mode[m] = {"x": x, "parents": [str(fa), str(fb)], "removed": rep.removed, "joints": rep.child_joints,
                       "frames": rep.child_frames}
    child_name = f"{name_a}_{name_b}"[:64]  # a creature name (creature.NAME_PATTERN), as the parents' are
    # values quoted as JSON strings (valid YAML); the comment made printable: a path cannot start a new line
    text = (f"# bred by `bipedsim breed {_printable(f'{a} {b} --world {world}')}`\n"
            f"name: {json.dumps(child_name)}\nclips:\n"
            + "".join(f"  {m}: {json.dumps(f)}\n" for m, f in files.items()))
    atomic_write_text(out, text)
    result = {"child": str(out), "name": child_name, "parents": {"A": str(a), "B": str(b)}, "world": str(world),
              **pw, "modes": per_mode, "files": files}
    if report:
        atomic_write_json(Path(report), result)
    return result


def format_world_breed_summary(rep: dict[str, Any], report: PathLike | None = None) -> str:
    """The lines ``bipedsim breed --world`` prints."""
    bc, tr = rep["bray_curtis"], rep["transfer"]
    lines = [f"wrote {rep['child']}: {rep['name']} with modes {', '.join(rep['child_modes'])} "
             f"({', '.join(rep['files'].values())}); Bray-Curtis D(C,A)={bc['A']:.3f} D(C,B)={bc['B']:.3f}; "
             f"transfer weights A={tr['A']:.3f} B={tr['B']:.3f}; "
             + ", ".join(f"{m} x={v['x']:.3f}" for m, v in rep["modes"].items())]
    if report:
        lines.append(f"wrote {report}")
    return "\n".join(lines)
