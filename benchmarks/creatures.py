"""Every creature clip walked in physics without support: outcome, fall time and speed against the
clip's own, for the creature balance controller and, as the baseline, PD tracking alone.

    python benchmarks/creatures.py [--seconds 20] [--seeds 3] [--animals ../shared/data/bvh/animal] [--only WORD ...]
                                   [--config CONTROLLER.yaml] [--clips /work/clips/creatures] [--children]

The controller is the registered creature controller (the planned gait, ``gait: planned``); two
baselines from the clip's start frame: the clip-timed balance controller (``gait: clip``, the controller
before the planned gait) and PD tracking alone.

Clips: every ``*.bvh`` in the shared animal folder, the shipped horse walk, a child bred from the
shared dog and the horse (``bipedsim breed``'s package function, no mutations), the public creature
clips of :data:`PUBLIC_CREATURES` found under ``--clips`` (each named by its repository and commit;
absent ones are listed as skipped), and with ``--children`` the children of every ordered pair of the
shared and shipped walkers (dog, horse, flamingo) bred with ``bipedsim breed``'s defaults, and the README's
child of the dog and CMU 02_02. Each row is one
rollout from the controller's start frame through the one rollout loop; the body kind is measured from
the skeleton (no --profile). ``speed %`` is the simulated mean speed (straight-line distance / time)
against the clip's own mean root speed over its looped part; an in-place clip (clip speed under
IN_PLACE_MPS) has no speed requirement and shows ``in place``. The last column is the balance
controller's survival time over the baseline's. ``seeds`` runs the controller again with seeds 1..N-1
(0.05 rad/s of initial velocity noise each) and counts the runs of all N that walk the whole time at
>= 50 % of the clip's speed (the issue's goal), with the lowest speed and the falls.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from bipedsim.control.creature.controller import CreatureController, make_creature_controller
from bipedsim.control.creature.settings import CreatureBalanceConfig
from bipedsim.data import HORSE_WALK
from bipedsim.sim.rollout import RolloutSpec, rollout
from bipedsim.sim.runner import load_scenario, run_scenario, run_seeds
from bipedsim.synthesis.breed.files import breed_files

REPO = Path(__file__).resolve().parent.parent
ANIMALS = REPO.parent / "shared" / "data" / "bvh" / "animal"
#: a clip whose root moves slower than this (m/s) walks in place
IN_PLACE_MPS = 0.1
#: where the public creature clips are collected (never in the repository; /work/clips/MANIFEST.md)
CLIPS = Path("/work/clips/creatures")
#: public creature clips: (file under --clips, repository, commit, path in it, kind)
PUBLIC_CREATURES: tuple[tuple[str, str, str, str, str], ...] = (
    ("monkey/truebones_monkey_walk_inplace.bvh", "LinghaoChan/Motion2Motion_codes",
     "751d114785141491895b88719198128add1e2b61", "data/processed/Monkey/__Walk.bvh", "monkey, walk in place"),
)


def clip_speed(sc, ctrl) -> float:
    """The clip's mean horizontal root speed (m/s) over the part the controller loops."""
    a, b = getattr(ctrl, "loop", (0, sc.clip.num_frames))
    q = sc.clip.qpos
    path = np.linalg.norm(np.diff(q[a:b, :2], axis=0), axis=1).sum()
    return float(path / max((b - a - 1) * sc.clip.frame_time, 1e-9))


def baseline(sc, seconds: float, balance: CreatureBalanceConfig | None = None):
    """PD tracking alone (no balance), or with ``balance`` the clip-timed balance controller (the
    controller before the planned gait), from the clip's start frame."""
    if balance is None:
        ctrl = CreatureController(sc.built.model, sc.built.plan, sc.clip, sc.creature_cfg)
    else:
        ctrl = make_creature_controller(sc.built.model, sc.built.plan, sc.clip, sc.creature_cfg, balance)
    f = ctrl.start_frame() if balance is not None else sc.controller().start_frame()
    out, _ = rollout(sc.built.model, sc.built.plan, ctrl, RolloutSpec(seconds=seconds, start_frame=float(f),
                     fall=sc.fall_criteria()), initial_qpos=sc.clip.qpos[f], initial_qvel=sc.clip.qvel[f])
    return out


def over_seeds(sc, first, v_clip: float, seconds: float, seeds: int) -> str:
    """Of seeds 0..seeds-1 (seed 0 is ``first``), how many walk the whole time at >= 50 % of the clip."""
    outs = [first] + run_seeds(sc, seconds, seeds, start=1)
    ratios = [o.mean_speed_mps / v_clip if v_clip >= IN_PLACE_MPS else 1.0 for o in outs]
    ok = sum(o.fall_time_s is None and r >= 0.5 for o, r in zip(outs, ratios))
    falls = [f"{o.fall_time_s:.1f}" for o in outs if o.fall_time_s is not None]
    return (f"{ok} of {len(outs)}" + (f", min {100 * min(ratios):.0f} %" if v_clip >= IN_PLACE_MPS else "")
            + (f", falls at {', '.join(falls)} s" if falls else ""))


def row(name: str, path: Path, seconds: float, seeds: int = 1, config: Path | None = None) -> str:
    try:
        sc = load_scenario(config, bvh=path)
        out, ctrl = run_scenario(sc, RolloutSpec(seconds=seconds))
    except Exception as exc:  # noqa: BLE001 - a benchmark reports and goes on
        return f"| {name} | refused: {exc} | | | | | | | | |"
    base = baseline(sc, seconds)
    timed = baseline(sc, seconds, CreatureBalanceConfig(gait="clip"))
    t_timed = timed.fall_time_s or timed.sim_seconds
    v_clip = clip_speed(sc, ctrl)
    speed = "in place" if v_clip < IN_PLACE_MPS else f"{100 * out.mean_speed_mps / v_clip:.0f} %"
    t_bal = out.fall_time_s or out.sim_seconds
    t_base = base.fall_time_s or base.sim_seconds
    fall = f"{out.fall_time_s:.2f} s ({out.fall_reason})" if out.fall_time_s is not None else "-"
    return (f"| {name} | {sc.profile}, {len(getattr(ctrl, 'legs', []))} legs | {out.outcome} | {fall} | "
            f"{out.mean_speed_mps:.2f} / {v_clip:.2f} m/s ({speed}) | {out.tracking_rmse_rad:.3f} rad | "
            f"{timed.outcome} at {t_timed:.2f} s | "
            f"{base.outcome} at {t_base:.2f} s | {t_bal / max(t_base, 1e-9):.2f} | "
            f"{over_seeds(sc, out, v_clip, seconds, seeds)} |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--seeds", type=int, default=3, help="seeds per clip for the goal count (default 3)")
    ap.add_argument("--animals", type=Path, default=ANIMALS)
    ap.add_argument("--only", nargs="+", metavar="WORD",
                    help="only the clips whose row name contains one of these words (e.g. child horse)")
    ap.add_argument("--config", type=Path, default=None,
                    help="a controller YAML (its creature: section) instead of the defaults")
    ap.add_argument("--clips", type=Path, default=CLIPS, help="folder of the public creature clips")
    ap.add_argument("--children", action="store_true",
                    help="also the children (breed defaults) of every ordered pair of dog, horse, flamingo")
    args = ap.parse_args()
    clips = [(p.stem, p) for p in sorted(args.animals.glob("*.bvh"))] + [("horse_walk (shipped)", HORSE_WALK)]
    dog = args.animals / "mann_dog_D1_007_KAN01_001_locomotion.bvh"
    tmp = Path(tempfile.mkdtemp(prefix="bipedsim-creatures-"))
    if dog.is_file():
        child = tmp / "dog_x_horse.bvh"
        breed_files(dog, HORSE_WALK, child, mutations=0)
        clips.append(("child of dog x horse (bred)", child))
    for rel, repo, commit, src, kind in PUBLIC_CREATURES:
        f = args.clips / rel
        if f.is_file():
            clips.append((f"{kind} ({repo}@{commit[:7]}:{src})", f))
        else:
            print(f"skipped (absent): {f} ({repo}@{commit[:7]}:{src})")
    if args.children:
        walkers = [("dog", dog), ("horse", HORSE_WALK),
                   ("flamingo", args.animals / "truebones_flamingo_walk_inplace.bvh")]
        walkers = [(n, f) for n, f in walkers if Path(f).is_file()]
        for na, fa in walkers:
            for nb, fb in walkers:
                if na != nb:
                    child = tmp / f"{na}_x_{nb}_defaults.bvh"
                    breed_files(fa, fb, child)  # bipedsim breed's defaults (5 mutations)
                    clips.append((f"child of {na} x {nb} (breed defaults)", child))
        human = args.animals.parent / "human" / "cmu_02_02_walk__19joint_Hip_Abdomen.bvh"
        if dog.is_file() and human.is_file():  # the README's example: a dog bred with a human walk
            child = tmp / "dog_x_cmu_02_02_defaults.bvh"
            breed_files(dog, human, child)
            clips.append(("child of dog x CMU 02_02 (breed defaults, the README's)", child))
    print(f"{args.seconds:g} s per rollout, no support, no flags\n")
    print("| clip | body | outcome | fall | speed sim / clip | tracking RMSE | clip-timed balance (gait: clip) "
          f"| baseline (PD only) | survival ratio | seeds at goal (of {args.seeds}) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    if args.only:
        clips = [(name, path) for name, path in clips if any(w.lower() in name.lower() for w in args.only)]
    for name, path in clips:
        print(row(name, path, args.seconds, max(1, args.seeds), args.config), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
