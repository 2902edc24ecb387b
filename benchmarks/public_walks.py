"""Public walks the project does not ship: `bipedsim run` judged on captures from sources beside the shared
sample (other Bandai-Namco styles, GAMES-105's turning walks, Xia's style clips on Holden's CMU skeleton,
an Emilya figure-eight walk, a deep-motion-editing example; ActorCore, LaFAN1,
Perception Neuron, OptiTrack-style, MotionBuilder, SNU, SFU, Mixamo, Rokoko and HumanIK exports), so that
what works is not fitted to the files we develop on.

The files stay where they are published; this script says where each one is, copies them out of clones of
their repositories and runs ``benchmarks/real_walks.py`` on the ones found:

    python benchmarks/public_walks.py list                      # each file's repository, commit and path
    git clone --depth 1 https://github.com/GAMES-105/GAMES-105 CLONES/GAMES-105    # (each repository listed)
    python benchmarks/public_walks.py collect CLONES DIR        # copy them into DIR under the names below
    python benchmarks/public_walks.py run DIR --seeds 2 --csv F  # real_walks.py on those in DIR

``run`` names the files missing from DIR and runs the rest (the table is real_walks.py's: outcome, fall
time, speed against the clip's own, ...). Licences are the repositories' own (Bandai-Namco's data CC BY-NC
4.0); nothing here is redistributed.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

import real_walks  # benchmarks/real_walks.py

#: (local name, repository, commit the table in docs/controller.md was measured at, path in it, what it is)
WALKS: tuple[tuple[str, str, str, str, str], ...] = tuple(
    [(f"bn1_walk_{s}.bvh", "BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset",
      "74ead3ba1ae4696404e6086233779f60de8bf9ef",
      f"dataset/Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk_{s}.bvh",
      f"Bandai-Namco set 1, '{s.split('_')[0]}' walk, 30 fps, cm, 6-channel joints under a static root")
     for s in ("normal_001", "active_001", "giant_001", "happy_001", "old_001", "proud_001", "sad_001",
               "tired_001")]
    + [("bn2_walk_normal_001.bvh", "BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset",
        "74ead3ba1ae4696404e6086233779f60de8bf9ef",
        "dataset/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk_normal_001.bvh",
        "Bandai-Namco set 2 (the shared exhausted walk's set), normal walk")]
    # an out-of-sample check of the real-length toes
    + [(f"bn2_walk_{s}.bvh", "BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset",
        "74ead3ba1ae4696404e6086233779f60de8bf9ef",
        f"dataset/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk_{s}.bvh",
        f"Bandai-Namco set 2, '{s[:-4]}' walk (take {s[-3:]}), toes without tips")
       for s in ("active_001", "active_002", "elderly_001", "elderly_002", "exhausted_002", "feminine_001",
                 "feminine_002", "masculine_001", "masculine_002", "normal_002", "youthful_001", "youthful_002")]
    + [(f"g105_{n}.bvh", "GAMES-105/GAMES-105", "442b13ad9c50544889236d6541358c9c752f8458",
        f"lab2/motion_material/{n}.bvh", what)
       for n, what in (("walk_forward", "1 s of a straight walk at 100 fps, metres"),
                       ("walk_and_turn_left", "a walk turning left, 100 fps"),
                       ("walk_and_ture_right", "a walk turning right, 60 fps (the file's own spelling)"))]
    + [(f"xia_{n}.bvh", "PeizhuoLi/deep-motion-editing", "a9d7f6ad06542ba8f6870717f16156808a6f6d28",
        f"style_transfer/data/xia_test/{n}.bvh", what)
       for n, what in (("neutral_01_000", "Xia style walk on Holden's CMU skeleton, 2.7 s at 120 fps"),
                       ("old_13_000", "Xia 'old' walk, one cycle from a left strike (1.6 s)"),
                       ("angry_13_000", "Xia 'angry' walk, one fast cycle from a left strike (1.2 s)"),
                       ("neutral_16_000", "Xia clip of a jump in place (no walk: refused)"))]
    + [("dme_example.bvh", "PeizhuoLi/deep-motion-editing", "a9d7f6ad06542ba8f6870717f16156808a6f6d28",
        "blender_rendering/example.bvh", "a 2.3 s walk, Holden's CMU skeleton")]
    + [("emilya_8walk_meredith.bvh", "omimo/PyMO", "ba24f5f8d8911173f41e2ea1a367fa7955a6da9f",
        "demos/data/AV_8Walk_Meredith_HVHA_Rep1.bvh",
        "Emilya figure-eight walk, 8.9 s at 120 fps, inches: 15 m of path, 0.35 m net")]
    # thirteen more repositories and their rigs (docs/controller.md, *Walks from
    # thirteen more repositories*); some files were deleted after the commit named, which collect reads
    # them from
    + [(n, r, c, p, w) for n, r, c, p, w in (
        ("ksim_actorcore_walk_normal.bvh", "kscalelabs/ksim", "ca9ddb768643f89472ecfda3db63a0e675832e2b",
         "examples/data/walk_normal_dh.bvh", "ActorCore (Reallusion CC_Base_ rig, 101 joints, twist and share "
         "bones), Z up, 60 fps, a 2.3 s straight walk"),
        ("ksim_actorcore_walk_relaxed_inplace.bvh", "kscalelabs/ksim", "c580ee93a3880cadfc4a8476d20641693e85ccad",
         "examples/default_humanoid/data/walk-relaxed_actorcore.bvh", "ActorCore relaxed walk in place, 30 fps"),
        ("lafan1_bvhutils_walking.bvh", "eggfryonrice/bvhUtils", "6f9a1cac97f969a76b4dc7868872dd03648b41c2",
         "walking.bvh", "a LaFAN1 (Ubisoft) walk, 17 s of turns at 30 fps"),
        ("neuron_addradar_walk.bvh", "chenzunh23/add_radar", "8f425125670f675096949744f9699504bfe324ec",
         "walk.bvh", "Perception Neuron naming, 59 joints, feet without toes or foot length, 90 fps, start-stop"),
        ("neuron_ezgitek_walk1.bvh", "ezgitek/bvh-parser", "fa0878723dc5f9791ff5f2575f99f0d46bd85ab7",
         "walk1.bvh", "Perception Neuron Studio naming, every joint with 6 channels, 58.8 fps, from standing"),
        ("optitrackstyle_motionviewer_walk.bvh", "kevinxie4c/motion-viewer", "5205a8df11a4302837f026e039fbb9752643a89a",
         "walk.bvh", "Hip/Knee/Ankle naming, mixed rotation orders, 120 fps, a brisk 2.5 s walk"),
        ("mass_walk_cycle.bvh", "lsw9021/MASS", "e79a338e97878ea4acbf98f8d456d7a4154c74b6", "data/motion/walk.bvh",
         "MotionBuilder Character1_ rig with *_RIGMESH helpers, one 1.1 s cycle at 120 fps"),
        ("snu_helloavatar_walk_attitude.bvh", "y0ngw00/HelloAvatar", "6ab37417ea45112c687d2557ed01b25f9d9a54ea",
         "data/bvh/walk_attitude.bvh", "SNU 15-joint sim* rig (no neck, a head End Site of no length), start-stop"),
        ("snu_car_walk_long.bvh", "syleemrl/CAR", "e7cfc8d9d5d38727a8c30309b2a2484d455091c2", "motion/walk_long.bvh",
         "SNU 18-joint rig (no Foot joint, a toe joint on the ankle), 42 s back and forth"),
        ("sfu_0005_walking001.bvh", "yiyezhiqiu2077/BVHskinning", "95f36906ba3d24c7eddb50df7aad10d2964b6486",
         "assets/motions/0005_Walking001.bvh", "SFU walk in circles, inches, 39 s at 120 fps"),
        ("mixamo_bvhskin_walking.bvh", "yiyezhiqiu2077/BVHskinning", "95f36906ba3d24c7eddb50df7aad10d2964b6486",
         "assets/motions/walking.bvh", "Mixamo (mixamorig:, 65 joints), 1 s of walking then a held pose"),
        ("mixamo_bvhskin_start_walking.bvh", "yiyezhiqiu2077/BVHskinning", "95f36906ba3d24c7eddb50df7aad10d2964b6486",
         "assets/motions/start walking.bvh", "Mixamo start walking from idle, 3 s, then a held pose"),
        ("mixamo_haze_walk_inplace.bvh", "jerech33/haze", "0417d922cfe2049481d8b60fb319a880f0c9a276", "bvh/walk.bvh",
         "Mixamo walk cycle in place, 1.3 s"),
        ("mixamo_qvb_walking_inplace.bvh", "frankpyf/QueryVectorBuilder", "c61e750d24b411354f46c05352f9dde57924f154",
         "data/walking.bvh", "Mixamo names without prefix, Z up, 53 joints with 6 channels, in place"),
        ("mixamo_s2d_walk_inplace.bvh", "Shinhyoung/2DtoAnimated3D", "25e3e0262d2794ee4fa426af2aa8a33d6244ed1f",
         "motions/walk.bvh", "Mixamo names, Z up, metres, a 1 m character, in place"),
        ("rokoko_anais_walk_turn_30fps.bvh", "codespace-antwerp/anais-dance-tool",
         "7ea63c438da41405ac5405da8072f8af277ed65b", "public/walk.bvh", "Rokoko naming (spine OFFSETs pointing "
         "down), 'Frames:' one short, a walk, a turn and a walk back at 30 fps"),
        ("hik_anais_walk_turn_100fps.bvh", "codespace-antwerp/anais-dance-tool",
         "31d4a025113624d49515754634145c6a815006d2", "public/walk.bvh", "the same take, HumanIK naming with Roll "
         "bones, 100 fps, 'Frames:' one short"))])


#: one file to copy: (its name under the output folder, repository, commit, path in it, what it is)
Source = tuple[str, str, str, str, str]


def list_sources(sources: Sequence[Source]) -> int:
    """Print where each file comes from and the clones ``collect`` reads them out of."""
    width = max([28, *(len(n) for n, *_ in sources)])  # the name column (characters)
    for name, repo, commit, path, what in sources:
        print(f"{name:{width}s} {repo} @ {commit[:12]} : {path}\n{'':{width}s} {what}")
    repos = sorted({r for _, r, _, _, _ in sources})
    print("\nclone each into CLONES/<name>: " + "; ".join(
        f"git clone --depth 1 https://github.com/{r} CLONES/{r.split('/')[1]}" for r in repos))
    return 0


def collect_sources(clones: Path, out: Path, sources: Sequence[Source]) -> int:
    """Copy each file out of ``clones/<repository name>`` (a clone or a bare git directory) into
    ``out/<name>``: the file at the commit named, else the clone's working copy."""
    out.mkdir(parents=True, exist_ok=True)
    missing = 0
    for name, repo, commit, path, _ in sources:
        clone = clones / repo.split("/")[1]
        dest = out / name
        dest.parent.mkdir(parents=True, exist_ok=True)
        # the file at the commit named (some were deleted or changed since), else the clone's copy
        shown = subprocess.run(["git", "-C", str(clone), "show", f"{commit}:{path}"], capture_output=True)
        if shown.returncode == 0:
            dest.write_bytes(shown.stdout)
        elif (clone / path).is_file():
            shutil.copyfile(clone / path, dest)
        else:
            missing += 1
            print(f"missing: {clone / path} (at {commit[:12]}: clone without --depth 1 to read it)")
    print(f"copied {len(sources) - missing} of {len(sources)} files into {out}")
    return 0 if missing < len(sources) else 1


def run_sources(folder: Path, sources: Sequence[Source], rest: list[str], script: str) -> int:
    """``benchmarks/real_walks.py`` (its options in ``rest``) on the files of ``sources`` found in ``folder``."""
    found = [folder / n for n, *_ in sources if (folder / n).is_file()]
    for n, *_ in sources:
        if not (folder / n).is_file():
            print(f"missing: {folder / n} (python benchmarks/{script} list)")
    if not found:
        print(f"none of the {len(sources)} files is in {folder}")
        return 1
    return real_walks.main([*rest, "--files", *map(str, found)])


def command_line(sources: Sequence[Source], doc: str, script: str, argv: list[str] | None = None) -> int:
    """The ``list`` / ``collect CLONES DIR`` / ``run DIR [real_walks.py options]`` commands on ``sources``."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("list", help="where each file comes from")
    c = sub.add_parser("collect", help="copy the files out of clones of their repositories")
    c.add_argument("clones", type=Path, help="folder holding one clone per repository, named as the repository")
    c.add_argument("out", type=Path)
    r = sub.add_parser("run", help="benchmarks/real_walks.py on the files found in DIR")
    r.add_argument("dir", type=Path)
    args, rest = ap.parse_known_args(argv)
    if args.cmd == "list":
        return list_sources(sources)
    if args.cmd == "collect":
        return collect_sources(args.clones, args.out, sources)
    return run_sources(args.dir, sources, rest, script)


def main(argv: list[str] | None = None) -> int:
    return command_line(WALKS, __doc__ or "", "public_walks.py", argv)


if __name__ == "__main__":
    sys.exit(main())
