"""Breeding across naming conventions, in one run: every pair of the shared animal and human clips and
the shipped horse and pterosaur, bred without a map, against the baseline of pairing joints by equal
names only (what breeding did before roles: refused when the roots' names differ). Then the same
skeletons with every joint renamed J00, J01...: how many of the limb joints (thigh, knee, ankle, upper
arm, elbow, wrist) the geometry alone gives the role their names give; and with their side words exchanged
(``LeftUpLeg`` on the right, as a mirrored export names them): how many keep their true side.

    python benchmarks/breed_correspondence.py
"""

from __future__ import annotations

import itertools
import sys
import time
from pathlib import Path

from bipedsim.data import HORSE_WALK, PTEROSAUR_FLIGHT
from bipedsim.motion import load_bvh
from bipedsim.motion.correspondence import correspondence
from bipedsim.motion.reroot import fold_static_root
from bipedsim.motion.roles import find_roles
from bipedsim.synthesis.breed.evolve import BreedError, crossover

sys.path.insert(0, str(Path(__file__).resolve().parent))

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "bvh"
CORE = ("thigh", "knee", "ankle", "upper_arm", "elbow", "wrist")


def limb_roles(m) -> dict[int, str]:  # type: ignore[no-untyped-def]
    return {j: f"{limb.side} {limb.kind} {role}" for limb in find_roles(m).limbs
            for role, j in limb.roles.items() if role in CORE}


def main() -> int:
    files = sorted(SHARED.glob("animal/*.bvh")) + sorted(SHARED.glob("human/*.bvh")) if SHARED.is_dir() else []
    files += [HORSE_WALK, PTEROSAUR_FLIGHT]
    motions = {f.name: fold_static_root(load_bvh(f))[0] for f in files}
    pairs = list(itertools.combinations(motions, 2))
    by_name = by_role = 0
    joints_name = joints_role = 0
    t_role = 0.0
    for a, b in pairs:
        ma, mb = motions[a], motions[b]
        try:
            joints_name += len(crossover(ma.skeleton, mb.skeleton, {}).common)
            by_name += 1
        except BreedError:
            pass
        t0 = time.perf_counter()
        corr = correspondence(ma, mb)
        t_role += time.perf_counter() - t0
        joints_role += len(found := corr.pairs)
        by_role += bool(found) and crossover(ma.skeleton, mb.skeleton, corr.pairs) is not None
    print(f"{len(files)} parents, {len(pairs)} pairs")
    print(f"pairs that breed without a map: by role {by_role}/{len(pairs)}, by equal names (baseline) "
          f"{by_name}/{len(pairs)} -> {by_role / max(by_name, 1):.1f}x")
    print(f"joints paired over all pairs: by role {joints_role}, by equal names {joints_name} -> "
          f"{joints_role / max(joints_name, 1):.1f}x; correspondence {t_role / len(pairs) * 1000:.1f} ms per pair")
    agree = total = 0
    for m in motions.values():
        named = limb_roles(m)
        renamed = m.copy(skeleton=m.skeleton.replace(names=tuple(f"J{i:02d}" for i in range(m.num_joints))))
        blind = limb_roles(renamed)
        total += len(named)
        agree += sum(blind.get(j) == r for j, r in named.items())
    print(f"names scrambled: {agree}/{total} limb joints get the role their names give "
          f"({agree / max(total, 1):.0%}; a name-only matcher: 0%)")
    # the side words exchanged (a mirrored export): the side the true names give, or the names' (wrong) one
    from layout_variants import _side_names

    agree = total = flipped = 0
    for m in motions.values():
        named = limb_roles(m)
        swapped = limb_roles(_side_names(m))
        total += len(named)
        agree += sum(swapped.get(j) == r for j, r in named.items())
        flipped += sum(swapped.get(j, "").split(" ")[0] not in ("", r.split(" ")[0]) for j, r in named.items())
    print(f"side words exchanged: {agree}/{total} limb joints keep the side their true names give "
          f"({agree / max(total, 1):.0%}; {flipped} take the exchanged names' side; a name-only matcher: 0%)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
