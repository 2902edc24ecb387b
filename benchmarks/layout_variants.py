"""The same clips in other file layouts: a probe for the files users bring that we do not have.

Each BVH file given is read as bipedsim reads it and written again in every layout below, into ``OUT``
(``<name>__<variant>.bvh``); run those through a benchmark to see whether a capability depends on how a
file is written rather than on the motion in it:

    python benchmarks/layout_variants.py /tmp/variants ../shared/data/bvh/human/cmu_02_01_walk__holden31_crlf.bvh
    python benchmarks/real_walks.py --files /tmp/variants/*.bvh        # humans
    python benchmarks/creatures.py --animals /tmp/variants             # creatures (every BVH in the folder)
    python benchmarks/layout_variants.py /tmp/variants --run           # the tracked shared walks: each variant's
                                                                       # speed ratio against its original's (~4 min;
                                                                       # --csv F [--resume] keeps the rows)

Variants (each one change from the file as read):
- ``30fps``, ``60fps``, ``120fps``: resampled (slerp / linear), skipped at the file's own rate;
- ``up``: the other up axis (Y up <-> Z up);
- ``metres``, ``cm``, ``inch``: the lengths in another unit, skipped for the file's own one (a creature
  file in inches reads as a smaller animal: nothing in it tells its unit);
- ``static_root``: under a new static root joint at the floor, the old root a 6-channel child (the layout
  of many game exports);
- ``in_place``: the travelling joint's horizontal translation held at its first frame (a walk in place,
  as game-animation exports often are);
- ``mirrored``: left and right exchanged;
- ``side_names``: the joints' side names exchanged (``Left``/``Right``, ``L``/``R`` prefixes, ``_L``/``.R``
  suffixes), the geometry kept: a skeleton named from the viewer's side, or a mirrored capture;
- ``turning``: bent into a steady 15 deg/s turn (the root's heading and its steps turned with time);
- ``six_channels``: every joint with 3 position channels (holding its OFFSET) before its rotations;
- ``cycle``: one gait cycle (the loop ``bipedsim run`` plays, both strikes' frames kept) in place, as a
  game animation's walk cycle is exported;
- ``rig_prefix``: every joint name behind a rig's prefix (``CC_Base_``, as ActorCore's; MotionBuilder's
  ``Character1_``, 3ds Max's ``Bip01 ``);
- ``helpers``: twist and share bones on the limbs (a twist chain along each shin and forearm from its
  joint, a share bone at each knee, a twist bone half-way down each thigh: ActorCore, HumanIK and
  Unreal rigs), each turning with its parent;
- ``fingers``: five three-joint fingers on each hand (Mixamo and Perception Neuron rigs: 40 of their
  ~60 joints);
- ``no_tips``: a foot without a toe joint and the head without a neck, their End Sites of no length (a
  Perception Neuron foot, SNU's 15-joint head), for the files that have no toe joint;
- ``spine_down``: the spine's joint frames turned half a turn about the forward axis, so the identity
  pose stands on its head (a Rokoko export's spine OFFSETs all point down); the motion is unchanged;
- ``held_tail``: the last frame repeated for 3 s (an export padded to a fixed length: four Mixamo files
  of 250 frames walk 30-90).
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from bipedsim.errors import BipedsimError
from bipedsim.motion.bvh import read_bvh, write_bvh
from bipedsim.motion.motion import Motion
from bipedsim.motion.reroot import add_static_root

UNITS = {"metres": 1.0, "cm": 0.01, "inch": 0.0254}
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"
#: the shared walks the default controller tracks (tests/reference/test_gait.py's TRACKED, with CMU 02_01)
TRACKED = ("cmu_02_01_walk__holden31_crlf", "cmu_02_02_walk__19joint_Hip_Abdomen", "cmu_02_02_walk__daz43",
           "games105_walk60__metres_crlf")


def _in_place(m: Motion) -> Motion:
    h = [i for i in range(3) if "xyz"[i] != m.up]
    out = m.copy()
    tj = m.travel_joint()
    if tj == 0:
        out.root_translation[:, h] = m.root_translation[0, h]
        if out.translations is not None:
            out.translations[:, 0, h] = m.root_translation[0, h]
    else:
        assert out.translations is not None
        out.translations[:, tj, h] = m.translations[0, tj, h]  # type: ignore[index]
    return out


def _turning(m: Motion, deg_per_s: float = 15.0) -> Motion:
    """The walk bent into a steady turn: every frame's root turned about the up axis by ``deg_per_s`` x
    its time, the root's horizontal steps turned alike (the stance feet slip a little: the capture's own
    step, turned)."""
    if m.travel_joint() != 0:
        raise BipedsimError("a turn is made on a root that carries the travel")
    u = "xyz".index(m.up)
    h = [i for i in range(3) if i != u]
    ang = np.radians(deg_per_s) * np.arange(m.num_frames) * m.frame_time
    axis = np.zeros(3)
    axis[u] = 1.0
    turn = Rotation.from_rotvec(ang[:, None] * axis)
    step = np.diff(m.root_translation, axis=0)
    step = turn[1:].apply(step)
    root = m.root_translation.copy()
    root[1:, h] = m.root_translation[0, h] + np.cumsum(step[:, h], axis=0)
    rots = m.rotations.copy()
    rots[:, 0] = (turn * Rotation.from_quat(m.rotations[:, 0])).as_quat()
    tr = None
    if m.translations is not None:
        tr = m.translations.copy()
        tr[:, 0] = root
    return m.copy(root_translation=root, rotations=rots, translations=tr)


def _cycle(path: str, m: Motion) -> Motion:
    """One gait cycle of the walk (the loop ``bipedsim run`` plays, right strike to right strike, both
    frames kept), in place: a game animation's walk cycle."""
    from bipedsim.control.humanoid.sources import clip_cycle
    from bipedsim.sim.runner import load_scenario

    sc = load_scenario(None, path)
    c = clip_cycle(sc.clip, sc.built.model, sc.built.plan)
    if c is None:
        raise BipedsimError("no gait cycle to cut")
    t = sc.clip.trimmed_frames
    return _in_place(m[c.a + t:c.b + t + 1])


def _six_channels(m: Motion) -> Motion:
    """Every joint with position channels (absolute: the channels hold the OFFSET), as some game and
    Bandai-Namco exports write every joint."""
    sk = m.skeleton
    pos = ("Xposition", "Yposition", "Zposition")
    channels = tuple(ch if any(c in pos for c in ch) else pos + tuple(ch) for ch in sk.channels)
    modes = tuple(md or "replace" for md in sk.position_modes) or ("replace",) * len(channels)
    new_sk = dataclasses.replace(sk, channels=channels, position_modes=modes)
    return m.copy(skeleton=new_sk, translations=m.local_translations())


_SIDE_WORDS = re.compile(r"Left|Right|left|right|LEFT|RIGHT|(?<![A-Za-z])[LRlr](?=[A-Z])|(?<=[_.])[LRlr](?![A-Za-z])")
_OTHER_SIDE = {"Left": "Right", "Right": "Left", "left": "right", "right": "left", "LEFT": "RIGHT", "RIGHT": "LEFT",
               "L": "R", "R": "L", "l": "r", "r": "l"}


def _side_names(m: Motion) -> Motion:
    """The same motion with each joint name's side word exchanged (the skeleton's geometry kept)."""
    names = tuple(_SIDE_WORDS.sub(lambda x: _OTHER_SIDE[x.group(0)], n) for n in m.skeleton.names)
    return m.copy(skeleton=m.skeleton.replace(names=names))


def _rig_prefix(m: Motion, prefix: str = "CC_Base_") -> Motion:
    """Every joint name behind a rig's ``prefix``."""
    return m.copy(skeleton=m.skeleton.replace(names=tuple(prefix + n for n in m.skeleton.names)))


def _with_leaves(m: Motion, leaves: list[tuple[str, str, np.ndarray, np.ndarray | None]]) -> Motion:
    """``m`` with joints added: (parent, name, offset, End Site offset or None), in the motion's units,
    each with 3 rotation channels held at identity (it turns with its parent)."""
    sk = m.skeleton
    names, parents, offsets = list(sk.names), list(sk.parents), [np.asarray(o) for o in sk.offsets]
    channels, modes = list(sk.channels), list(sk.position_modes)
    es_p, es_o = list(sk.end_site_parents), [np.asarray(o) for o in sk.end_site_offsets]
    for parent, name, off, end in leaves:
        names.append(name)
        parents.append(names.index(parent))
        offsets.append(np.asarray(off, dtype=float))
        channels.append(("Zrotation", "Xrotation", "Yrotation"))
        modes.append("")
        if end is not None:
            es_p.append(len(names) - 1)
            es_o.append(np.asarray(end, dtype=float))
    k, t = len(leaves), m.num_frames
    rot = np.concatenate([m.rotations, np.tile([0.0, 0.0, 0.0, 1.0], (t, k, 1))], axis=1)
    trans = None if m.translations is None else np.concatenate(
        [m.translations, np.tile(np.array(offsets[-k:]), (t, 1, 1))], axis=1)
    new_sk = sk.replace(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets),
                        channels=tuple(channels), position_modes=tuple(modes),
                        end_site_parents=np.array(es_p, dtype=np.int64), end_site_offsets=np.array(es_o).reshape(-1, 3))
    return m.copy(skeleton=new_sk, rotations=rot, translations=trans)


def _roles(m: Motion):
    from bipedsim.model.naming import recognise_humanoid

    return recognise_humanoid(m.skeleton)


def _helpers(m: Motion) -> Motion:
    """Twist and share bones on the limbs: a twist chain from each knee and elbow along the bone below,
    a share bone at each knee pointing down the shin, a twist bone half-way down each thigh."""
    hm, sk = _roles(m), m.skeleton
    leaves = []
    for side, leg in hm.legs.items():
        shin = sk.offsets[sk.index(leg["ankle"])]
        leaves += [(leg["knee"], f"{side}_ShinTwist01", 0.0 * shin, None),
                   (f"{side}_ShinTwist01", f"{side}_ShinTwist02", 0.5 * shin, 0.2 * shin),
                   (leg["knee"], f"{side}_KneeShareBone", 0.0 * shin, 0.2 * shin),
                   (leg["thigh"], f"{side}_ThighTwist01", 0.5 * sk.offsets[sk.index(leg["knee"])], None)]
    for side, arm in hm.arms.items():
        fore = sk.offsets[sk.index(arm["wrist"])]
        leaves += [(arm["elbow"], f"{side}_ForearmTwist01", 0.0 * fore, None),
                   (f"{side}_ForearmTwist01", f"{side}_ForearmTwist02", 0.5 * fore, 0.2 * fore)]
    return _with_leaves(m, leaves)


def _fingers(m: Motion) -> Motion:
    """Five fingers of three joints on each hand, fanned ahead of the wrist along the forearm."""
    hm, sk = _roles(m), m.skeleton
    leaves = []
    for side, arm in hm.arms.items():
        fore = sk.offsets[sk.index(arm["wrist"])]
        along = fore / max(float(np.linalg.norm(fore)), 1e-9)
        side_dir = np.cross(along, [0.0, 1.0, 0.0] if abs(along[1]) < 0.9 else [1.0, 0.0, 0.0])
        side_dir /= np.linalg.norm(side_dir)
        seg = 0.1 * float(np.linalg.norm(fore))  # a finger's bone: a tenth of the forearm
        for f in range(5):
            base = f"{side}_Finger{f + 1}"
            leaves.append((arm["wrist"], f"{base}_1", along * seg + side_dir * (f - 2) * 0.3 * seg, None))
            leaves.append((f"{base}_1", f"{base}_2", along * seg, None))
            leaves.append((f"{base}_2", f"{base}_3", along * seg, along * 0.5 * seg))
    return _with_leaves(m, leaves)


def _no_tips(m: Motion) -> Motion:
    """The feet's and head's End Sites of no length, the neck renamed to no neck word (so the head is its
    own neck); for a skeleton without toe joints."""
    hm, sk = _roles(m), m.skeleton
    if any(leg["toe"] for leg in hm.legs.values()):
        raise BipedsimError("no_tips is for a skeleton without toe joints")
    ends = {sk.index(leg["ankle"]) for leg in hm.legs.values()} | {sk.index(hm.head)}
    es = sk.end_site_offsets.copy()
    for e, p in enumerate(sk.end_site_parents):
        if int(p) in ends:
            es[e] = 0.0
    names = tuple("Throat" if n == hm.neck and hm.neck != hm.head else n for n in sk.names)
    return m.copy(skeleton=sk.replace(end_site_offsets=es, names=names))


def _spine_down(m: Motion) -> Motion:
    """The spine's joint frames (the torso's first joint and everything above it) turned half a turn about
    the forward axis: the identity pose stands on its head, the motion is unchanged."""
    hm, sk = _roles(m), m.skeleton
    base = np.tile(np.eye(3), (sk.num_joints, 1, 1))
    forward = np.zeros(3)
    forward[2 if m.up == "y" else 0] = 1.0  # a horizontal axis: any turns the spine over
    half = Rotation.from_rotvec(np.pi * forward).as_matrix()
    for j in sk.subtree(sk.index(hm.torso_base)):
        base[j] = half
    return m.reframed(base)


def _held_tail(m: Motion, seconds: float = 3.0) -> Motion:
    """The last frame repeated for ``seconds`` (an export padded to a fixed length)."""
    k = int(round(seconds / m.frame_time))
    idx = np.concatenate([np.arange(m.num_frames), np.full(k, m.num_frames - 1)])
    return m.copy(root_translation=m.root_translation[idx], rotations=m.rotations[idx],
                  translations=None if m.translations is None else m.translations[idx])


def variants(m: Motion, path: str | None = None) -> dict[str, Callable[[], Motion]]:
    """The layouts of ``m`` (as read), by name; each made only when called."""
    out: dict[str, Callable[[], Motion]] = {}
    fps = 1.0 / m.frame_time
    for f in (30, 60, 120):
        if abs(fps - f) > 1.0:
            out[f"{f}fps"] = lambda f=f: m.resample(f)
    out["up"] = lambda: m.with_up("z" if m.up == "y" else "y")
    for name, unit in UNITS.items():
        if not np.isclose(m.unit, unit, rtol=0.02):
            out[name] = lambda unit=unit: m.in_metres().scaled(1.0 / unit)
    out["static_root"] = lambda: add_static_root(m)
    out["in_place"] = lambda: _in_place(m)
    out["mirrored"] = lambda: m.mirrored()
    out["side_names"] = lambda: _side_names(m)
    out["turning"] = lambda: _turning(m)
    out["six_channels"] = lambda: _six_channels(m)
    if path is not None:
        out["cycle"] = lambda: _cycle(path, m)
    out["rig_prefix"] = lambda: _rig_prefix(m)
    out["held_tail"] = lambda: _held_tail(m)
    try:
        hm = _roles(m)
    except BipedsimError:  # no humanoid found by name (a creature): the human rigs' variants do not apply
        return out
    out["helpers"] = lambda: _helpers(m)
    out["fingers"] = lambda: _fingers(m)
    if not any(leg["toe"] for leg in hm.legs.values()):
        out["no_tips"] = lambda: _no_tips(m)
    out["spine_down"] = lambda: _spine_down(m)
    return out


def write_variants(out: Path, files: list[str], only: list[str] | None = None) -> list[tuple[str, str, Path]]:
    """Every variant of every file written into ``out``: (source file, variant, path) per file written."""
    out.mkdir(parents=True, exist_ok=True)
    done = []
    for f in files:
        m, info = read_bvh(f)
        for name, make in variants(m, f).items():
            if only and name not in only:
                continue
            p = out / f"{Path(f).stem}__{name}.bvh"
            try:
                write_bvh(make(), p)
            except BipedsimError as exc:  # e.g. no left/right pairs to mirror
                print(f"{p}  skipped: {exc}")
                continue
            print(f"{p}  ({info.unit_scale:g} m per unit, {m.up} up, {1 / m.frame_time:.0f} fps as read)")
            done.append((f, name, p))
    return done


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="folder for the variant files (made if missing)")
    ap.add_argument("files", nargs="*", help="BVH files (default with --run: the shared human walks the default "
                    "controller tracks)")
    ap.add_argument("--only", nargs="*", default=None, help="only these variants (default: all)")
    ap.add_argument("--run", action="store_true",
                    help="also walk every variant and its original (benchmarks/real_walks.py) and print each "
                         "variant's speed against the original's")
    ap.add_argument("--seeds", type=int, default=3, help="with --run: seeds per file (medians; default 3)")
    ap.add_argument("--seconds", type=float, default=20.0, help="with --run: simulated seconds (default 20)")
    ap.add_argument("--csv", default=None, help="with --run: also write the rows to this CSV, one at a time")
    ap.add_argument("--resume", action="store_true", help="with --run and --csv: keep the CSV's rows, run the rest")
    args = ap.parse_args(argv)
    files = args.files or ([str(SHARED / "human" / f"{n}.bvh") for n in TRACKED] if args.run else [])
    if not files:
        ap.error("give BVH files (or --run for the shared walks)")
    done = write_variants(Path(args.out), files, args.only)
    if not args.run:
        return 0
    from real_walks import FIELDS, run_one  # benchmarks/real_walks.py
    from rows import Rows  # benchmarks/rows.py

    rows = Rows(args.csv, ["variant", *FIELDS], args.resume, key=lambda r: f"{r['file']}|{r['variant']}")
    print(f"\n{'file':40s} {'variant':12s} {'outcome':8s} {'ratio':>5s} {'runs':>5s} {'vs original':>11s}")
    base: dict[str, dict[str, object]] = {}
    for f, name, p in [(f, "(original)", Path(f)) for f in files] + done:
        key = f"{p.name}|{name}"
        row: dict[str, object] = dict(rows.done[key]) if key in rows.done else run_one(p, args.seconds, None,
                                                                                         seeds=args.seeds)
        if key not in rows.done:
            rows.add({"variant": name, **row})
        if name == "(original)":
            base[f] = row
        b = base[f].get("speed_ratio")
        r = row.get("speed_ratio")
        vs = f"{float(r) / float(b):.2f}" if r not in ("", None) and b not in ("", None) else ""  # type: ignore[arg-type]
        out = row["outcome"] if row["outcome"] == "no_fall" else f"{row['outcome']} {row.get('fall_time_s')}"
        print(f"{Path(f).stem[:40]:40s} {name:12s} {out!s:8s} {r!s:>5s} {row.get('runs_ok', '')!s:>5s} {vs:>11s}")
    rows.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
