"""Public walks the project does not ship: `bipedsim run` judged on captures from sources beside the shared
sample (other Bandai-Namco styles, GAMES-105's turning walks, Xia's style clips on Holden's CMU skeleton,
an Emilya figure-eight walk, a deep-motion-editing example), so that what works is not fitted to the files
we develop on.

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
import sys
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
    # added in session 13 as an out-of-sample check of the real-length toes (docs/controller.md)
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
        "Emilya figure-eight walk, 8.9 s at 120 fps, inches: 15 m of path, 0.35 m net")])


def _list() -> int:
    for name, repo, commit, path, what in WALKS:
        print(f"{name:28s} {repo} @ {commit[:12]} : {path}\n{'':28s} {what}")
    repos = sorted({r for _, r, _, _, _ in WALKS})
    print("\nclone each into CLONES/<name>: " + "; ".join(
        f"git clone --depth 1 https://github.com/{r} CLONES/{r.split('/')[1]}" for r in repos))
    return 0


def _collect(clones: Path, out: Path) -> int:
    out.mkdir(parents=True, exist_ok=True)
    missing = 0
    for name, repo, _, path, _ in WALKS:
        src = clones / repo.split("/")[1] / path
        if src.is_file():
            shutil.copyfile(src, out / name)
        else:
            missing += 1
            print(f"missing: {src}")
    print(f"copied {len(WALKS) - missing} of {len(WALKS)} files into {out}")
    return 0 if missing < len(WALKS) else 1


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("list", help="where each file comes from")
    c = sub.add_parser("collect", help="copy the files out of clones of their repositories")
    c.add_argument("clones", type=Path, help="folder holding one clone per repository, named as the repository")
    c.add_argument("out", type=Path)
    r = sub.add_parser("run", help="benchmarks/real_walks.py on the files found in DIR")
    r.add_argument("dir", type=Path)
    args, rest = ap.parse_known_args(argv)
    if args.cmd == "list":
        return _list()
    if args.cmd == "collect":
        return _collect(args.clones, args.out)
    found = [args.dir / n for n, *_ in WALKS if (args.dir / n).is_file()]
    for n, *_ in WALKS:
        if not (args.dir / n).is_file():
            print(f"missing: {args.dir / n} (python benchmarks/public_walks.py list)")
    if not found:
        print(f"none of the {len(WALKS)} public walks is in {args.dir}")
        return 1
    return real_walks.main([*rest, "--files", *map(str, found)])


if __name__ == "__main__":
    sys.exit(main())
