"""Do a creature's planned stance feet touch the floor? Per leg of the planned gait: the share of its
planned stance time in floor contact (1 = no chatter), by tenth of the stance (late landings start
low), contact switches per stance (bouncing) and the share of its swing time on the floor (scuffing).

    python benchmarks/creature_contacts.py [--seconds 6] [--animals ../shared/data/bvh/animal]
                                           [--config CONTROLLER.yaml]

A second table gives each body's support: the share of the counted time with no leg on the floor
(bouncing) and with exactly one (rocking onto one foot).

Clips: the shared dog, the shipped horse and the child bred from them (as in benchmarks/creatures.py),
each one rollout through the one rollout loop with :class:`bipedsim.sim.contacts.StanceContacts` as a
hook, counted from 1 s on.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from bipedsim.data import HORSE_WALK
from bipedsim.sim.contacts import StanceContacts
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario
from bipedsim.synthesis.breed.files import breed_files

REPO = Path(__file__).resolve().parent.parent
ANIMALS = REPO.parent / "shared" / "data" / "bvh" / "animal"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--animals", type=Path, default=ANIMALS)
    ap.add_argument("--config", type=Path, default=None,
                    help="a controller YAML (its creature: section) instead of the defaults")
    args = ap.parse_args()
    dog = args.animals / "mann_dog_D1_007_KAN01_001_locomotion.bvh"
    clips = [("horse_walk (shipped)", HORSE_WALK)]
    if dog.is_file():
        child = Path(tempfile.mkdtemp(prefix="bipedsim-contacts-")) / "dog_x_horse.bvh"
        breed_files(dog, HORSE_WALK, child, mutations=0)
        clips = [("dog", dog)] + clips + [("child of dog x horse", child)]
    print(f"{args.seconds:g} s per rollout, counted from 1 s\n")
    print("| clip | leg | stance in contact | by tenth of stance | switches / stance | swing on floor |")
    print("|---|---|---|---|---|---|")
    support = []
    for name, path in clips:
        sc = load_scenario(args.config, bvh=path)
        hook = StanceContacts()
        out, ctrl = run_scenario(sc, RolloutSpec(seconds=args.seconds), hooks=[hook])
        s = hook.summary()
        for i, leg in enumerate(getattr(ctrl, "legs", [])):
            dec = " ".join(f"{x:.2f}" for x in s["by_decile"][i])
            print(f"| {name} | {leg.root} | {s['stance_share'][i]:.2f} | {dec} | {s['switches'][i]:.1f} "
                  f"| {s['swing_share'][i]:.2f} |", flush=True)
        if out.fall_time_s is not None:
            print(f"| {name} | falls at {out.fall_time_s:.2f} s | | | | |")
        down = s["legs_down"]
        if down:
            support.append(f"| {name} | {down[0]:.3f} | {down[1]:.2f} |")
    print("\n| clip | no leg down | one leg down |\n|---|---|---|")
    print("\n".join(support))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
