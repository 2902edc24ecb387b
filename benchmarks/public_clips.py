"""Public clips of the kinds whole-clip tracking must handle, from sources the project does not develop on:
long walks with many turns, slow, sad, angry, fast and very fast walks, walks out and back, clips that are
one walk cycle (in place and travelling), a game rig whose first frame is a rest pose, and a file whose
channel keywords are upper case.

The files stay where they are published; this script says where each one is, copies them out of clones of
their repositories into ``DIR/<kind>/<name>`` and runs ``benchmarks/real_walks.py`` on the ones found:

    python benchmarks/public_clips.py list                        # each file's kind, repository, commit, path
    git clone https://github.com/snumrl/ys2010 CLONES/ys2010      # (each repository listed)
    python benchmarks/public_clips.py collect CLONES DIR          # copy them into DIR/<kind>/<name>
    python benchmarks/public_clips.py run DIR --seconds 20        # real_walks.py on those in DIR
    python benchmarks/public_clips.py run DIR --kind sad --kind slow   # only these kinds

A few files are read at a commit older than their repository's head (clone without ``--depth 1``). Several
clips are long (up to 51 s): ``--seconds`` at or above a clip's duration tracks all of it; reading and
preparing a long or 240 fps clip takes minutes before its run starts. Licences are the
repositories' own (Bandai-Namco's data CC BY-NC 4.0; CMU's free with acknowledgement; the SNU, Xsens
(AnyBody AMMR), MakeHuman, Mixamo, ActorCore and Rokoko files as their repositories state); nothing here is
redistributed.
"""

from __future__ import annotations

import argparse
import sys

import public_walks  # benchmarks/public_walks.py: the list / collect / run commands

#: the kinds, in the order the table lists them (DIR/<kind>/ holds each kind's files)
KINDS = ("long_turns", "slow", "sad", "angry", "fast", "very_fast", "out_and_back", "one_cycle", "tpose_rig",
         "upper_case")

_DDBC = ("snumrl/DataDrivenBipedController", "68ecaa17790ebf3039ae8c0b91d21fab4829bb8c")
_YS = ("snumrl/ys2010", "02ae02acb4064a56a8c6ca13dbdee1f70096c443")
_IA = ("snumrl/InteractiveAnimation", "0027fca40e3617b22357e3fb4430a2a8ee78ff50")
_TCR = ("snumrl/TimeCriticalResponse", "11f859239551e10ecec604e1fdd7c49d56349d8c")
_BN = ("BandaiNamcoResearchInc/Bandai-Namco-Research-Motiondataset", "74ead3ba1ae4696404e6086233779f60de8bf9ef")
_DME = ("PeizhuoLi/deep-motion-editing", "a9d7f6ad06542ba8f6870717f16156808a6f6d28")
_BN1 = "dataset/Bandai-Namco-Research-Motiondataset-1/data/dataset-1_"
_IA_CMU = "mrl.motion.neural/walkTest/motion/"
_XIA = "style_transfer/data/xia_test/"

#: (local name, repository, commit, path in it, kind, what it is: measured with `bipedsim info`; speeds are
#: the root's mean horizontal speed over the whole clip, "1-s speed" its 90th percentile over 1 s windows)
CLIPS: tuple[tuple[str, str, str, str, str, str], ...] = (
    # -- long walks with many turns (30 s and more)
    ("snu_cmu69_06_turns.bvh", *_IA, _IA_CMU + "69_06_1.bvh", "long_turns",
     "CMU 69_06 retargeted by SNU (22 joints, cm, 30 fps): 43.4 s walking in a 2.4 m area, 29 m of path, "
     "about 2300 deg of turning, 0.67 m/s"),
    ("snu_cmu69_11_turns.bvh", *_IA, _IA_CMU + "69_11_1.bvh", "long_turns",
     "CMU 69_11 retargeted by SNU: 41.3 s, 25 m of path with about 1100 deg of turns, 0.61 m/s, pauses"),
    ("snu_woody_freewalk_01.bvh", *_YS, "Data/woody2/Motion/VideoMotion/wd2_freeWalk_01.bvh", "long_turns",
     "SNU 'woody2' free walk (26 joints with zero-length dummy joints, inches, 30 fps): 51.5 s, 33 m of path "
     "in a 2.2 m area, about 1800 deg of turns, 0.63 m/s"),
    ("snu_woody_walk_stop_walk.bvh", *_DDBC, "Walking/rawmotion/woddy2_walk_stop_walk.bvh", "long_turns",
     "SNU 'woody2' raw take (20 joints, cm, 24 fps, CRLF): 47.2 s of walks, stops and turns back and forth "
     "over 4 m, 26 m of path, 0.55 m/s"),
    # -- slow walks
    ("snu_woody_walk_very_slow.bvh", *_DDBC, "Walking/rawmotion/woddy2_walk_straight_very_slow.bvh", "slow",
     "SNU 'woody2' raw take, 24 fps: 45.7 s of very slow walking back and forth over 3.5 m with turns, "
     "0.37 m/s (1-s speed 0.64)"),
    ("snu_woody_walkforwardslow05.bvh", *_YS, "Data/woody2/Motion/Physics2/wd2_WalkForwardSlow05.bvh", "slow",
     "SNU 'woody2' (20 joints, cm, 30 fps): 6.7 s slow straight walk, 3.3 m, 0.51 m/s"),
    ("bn1_walk_not-confident_001.bvh", *_BN, _BN1 + "walk_not-confident_001.bvh", "slow",
     "Bandai-Namco set 1 'not-confident' walk (22 joints, cm, 30 fps): 16 s, hesitant, 7.6 m, 0.48 m/s"),
    # -- sad walks
    ("bn1_walk_sad_002.bvh", *_BN, _BN1 + "walk_sad_002.bvh", "sad",
     "Bandai-Namco set 1 'sad' walk, take 2: 13.7 s, slumped and slow, 5.4 m, 0.39 m/s"),
    ("bn1_walk_sad_001.bvh", *_BN, _BN1 + "walk_sad_001.bvh", "sad",
     "Bandai-Namco set 1 'sad' walk, take 1: 11.5 s, 7 m, 0.60 m/s"),
    ("xia_depressed_13_000.bvh", *_DME, _XIA + "depressed_13_000.bvh", "sad",
     "Xia 'depressed' walk on Holden's CMU skeleton (31 joints, 120 fps): 1.6 s, one cycle travelling, "
     "read as 1.46 m/s in CMU units"),
    # -- angry walks
    ("bn1_walk_angry_002.bvh", *_BN, _BN1 + "walk_angry_002.bvh", "angry",
     "Bandai-Namco set 1 'angry' walk, take 2: 8 s, 8.3 m, 1.03 m/s"),
    ("xia_angry_13_000.bvh", *_DME, _XIA + "angry_13_000.bvh", "angry",
     "Xia 'angry' walk, 120 fps: 1.2 s, one fast cycle travelling"),
    # -- fast walks
    ("bn1_walk_active_002.bvh", *_BN, _BN1 + "walk_active_002.bvh", "fast",
     "Bandai-Namco set 1 'active' walk, take 2: 4.8 s straight, 7.6 m, 1.59 m/s"),
    ("snu_woody_walk_fast.bvh", *_DDBC, "Walking/rawmotion/woddy2_walk_straight_fast.bvh", "fast",
     "SNU 'woody2' raw take, 24 fps: 42.7 s of fast walks back and forth over 4 m (1-s speed 1.12 m/s) with "
     "turns and pauses, 0.58 m/s overall"),
    ("snu_cmu16_24_fast.bvh", *_TCR, "mrl.motion.critical/data/martial_arts_compact/motion/16_24_1.bvh", "fast",
     "CMU 16_24 retargeted by SNU (22 joints, cm, 30 fps): 2.5 s fast walk veering 35 deg, 1.66 m/s"),
    # -- very fast walks
    ("bn1_walk_angry_001.bvh", *_BN, _BN1 + "walk_angry_001.bvh", "very_fast",
     "Bandai-Namco set 1 'angry' walk, take 1: 4.7 s, 9 m at 1.89 m/s, no flight phase (a walk)"),
    ("snu_cmu16_21_very_fast.bvh", *_TCR, "mrl.motion.critical/data/martial_arts_compact/motion/16_21_1.bvh",
     "very_fast", "CMU 16_21 retargeted by SNU: 2.6 s straight, 4.5 m at 1.77 m/s, no flight phase"),
    ("snu_woody_walk_very_fast.bvh", *_DDBC, "Walking/rawmotion/woddy2_walk_straight_very_fast.bvh",
     "very_fast", "SNU 'woody2' raw take, 24 fps: 43.8 s of very fast walks back and forth over 4 m "
     "(1-s speed 1.58 m/s) with turns, 0.76 m/s overall"),
    # -- walks out and back (turning 180 deg)
    ("xsens_ammr_s01_trial01.bvh", "AnyBody/ammr", "ef387217a8c69ed97b237d6cd6eec92c77049b9f",
     "Application/MocapExamples/BVH_Xsens/BVH-files/S01_Trial01.bvh", "out_and_back",
     "Xsens MVN export (23 joints, cm, 240 fps): 15.4 s, out 9.6 m, a 180 deg turn and back, 1.24 m/s"),
    ("xsens_ammr_walk_metres.bvh", "AnyBody/ammr", "a527660d4eee2fc77f94f48122f0c8cc81aba50e",
     "Application/MocapExamples/BVH/Trials/Walk/Walk.bvh", "out_and_back",
     "Xsens MVN export in metres (23 joints, 240 fps): 19.7 s, out 6.9 m and back, 0.69 m/s"),
    ("snu_woody_walk_turn_180.bvh", *_DDBC, "Walking/rawmotion/woddy2_walk_turn_180.bvh", "out_and_back",
     "SNU 'woody2' raw take, 24 fps: 33.8 s of walking out about 3 m, turning 180 deg and back, repeated; "
     "0.69 m/s"),
    # -- one walk cycle (in place and travelling)
    ("makehuman_zombiewalk1_inplace_24fps.bvh", "makehumancommunity/makehuman",
     "a8bc2d54ff0ac92e78ff71431b1023eda42bf482", "makehuman/data/animations/zombie/zombieWalk1.bvh",
     "one_cycle", "MakeHuman game rig (75 joints, Z up, decimetres): one 31-frame walk cycle at 24 fps, in place"),
    ("mixamo_haze_walk_inplace_30fps.bvh", "jerech33/haze", "0417d922cfe2049481d8b60fb319a880f0c9a276",
     "bvh/walk.bvh", "one_cycle", "Mixamo rig (55 joints, cm): one 40-frame walk cycle at 30 fps, in place"),
    ("actorcore_walk_cycle_travelling_60fps.bvh", "kscalelabs/ksim-kbot", "d71da26dd56448c6e09ec054c07fc1ce4706a69c",
     "ksim_kbot/reference_motions/walk_normal_actorcore_male.bvh", "one_cycle",
     "ActorCore / Character Creator rig (CC_Base_, 101 joints, Z up, cm): one 141-frame cycle at 60 fps "
     "travelling 3.1 m at 1.34 m/s"),
    # -- a game rig whose first frame is a rest pose far from the take
    ("rokoko_anais_walk_turn_tpose0.bvh", "codespace-antwerp/anais-dance-tool",
     "7ea63c438da41405ac5405da8072f8af277ed65b", "public/walk.bvh", "tpose_rig",
     "Rokoko rig (74 joints, cm, 30 fps; 'Frames:' one short): frame 0 a pose 31 deg (RMS) from every later "
     "frame, then 13.9 s of a walk, a turn and a walk back, 0.39 m/s"),
    # -- upper-case channel keywords (XPOSITION ... ZROTATION)
    ("snu_upper_u_turn.bvh", *_DDBC, "Walking/ppmotion/wd2_u-turn.bvh", "upper_case",
     "SNU 'woody2' processed (13 joints, metres, 30 fps), channels XPOSITION/ZROTATION...: 25.9 s, 17 m of "
     "path with a U-turn, 0.66 m/s"),
    ("snu_upper_walk_vfast.bvh", *_DDBC, "Walking/ppmotion/wd2_WalkForwardVFast00.bvh", "upper_case",
     "SNU 'woody2' processed, upper-case channels: 4 s straight 'very fast' walk, 3.5 m, 0.89 m/s"),
    ("snu_upper_walk_slow.bvh", *_DDBC, "Walking/ppmotion/wd2_WalkForwardSlow01.bvh", "upper_case",
     "SNU 'woody2' processed, upper-case channels: 6.4 s straight slow walk, 3 m, 0.48 m/s"),
)

#: the table as public_walks' sources, each file under its kind's folder
SOURCES: tuple[public_walks.Source, ...] = tuple(
    (f"{kind}/{name}", repo, commit, path, what) for name, repo, commit, path, kind, what in CLIPS)


def main(argv: list[str] | None = None) -> int:
    pre = argparse.ArgumentParser(add_help=False)
    pre.add_argument("--kind", action="append", choices=KINDS, help="only the clips of this kind (repeatable)")
    known, rest = pre.parse_known_args(argv)
    sources = [s for s in SOURCES if known.kind is None or s[0].split("/")[0] in known.kind]
    return public_walks.command_line(sources, __doc__ or "", "public_clips.py", rest)


if __name__ == "__main__":
    sys.exit(main())
