"""1. Crossover: the meta-skeleton holding every joint of both parents -- corresponding joints (a mapping,
same names, the roots) kept once, the others appended under the joint their parent maps to -- and the
mapping YAML that gives the correspondence by hand."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from bipedsim import config
from bipedsim.errors import ConfigError
from bipedsim.motion.skeleton import Skeleton
from bipedsim.synthesis.breed.limits import BreedError


# ---------------------------------------------------------------------- 1. crossover
@dataclass
class MetaSkeleton:
    skeleton: Skeleton  #: the union, A's joints first
    from_a: list[int | None]  #: per meta joint, the joint of parent A it is (None: B only)
    from_b: list[int | None]  #: per meta joint, the joint of parent B it is (None: A only)

    @property
    def common(self) -> list[int]:
        return [i for i, (a, b) in enumerate(zip(self.from_a, self.from_b)) if a is not None and b is not None]


def load_joint_map(path: str | os.PathLike[str], a: Skeleton, b: Skeleton) -> dict[str, str]:
    """A mapping YAML ``{joint of A: joint of B}``; every name must exist in its parent."""
    data = config.load_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError("expected a mapping {joint of parent A: joint of parent B}", path=path)
    for ka, kb in data.items():
        if str(ka) not in a.names:
            raise ConfigError(f"parent A has no joint {ka!r}", path=path, key=str(ka))
        if str(kb) not in b.names:
            raise ConfigError(f"parent B has no joint {kb!r}", path=path, key=str(ka))
    return {str(k): str(v) for k, v in data.items()}


def crossover(a: Skeleton, b: Skeleton, mapping: dict[str, str] | None = None) -> MetaSkeleton:
    """The meta-skeleton: every joint of A, then B's joints A does not have, under their mapped parent."""
    mapping = dict(mapping or {})
    for ka, kb in mapping.items():
        if ka not in a.names or kb not in b.names:
            raise BreedError(f"mapping names unknown joints: {ka!r} -> {kb!r}")
    b_to_a: dict[int, int] = {b.index(kb): a.index(ka) for ka, kb in mapping.items()}
    for j, name in enumerate(b.names):
        if j not in b_to_a and name in a.names and a.index(name) not in b_to_a.values():
            b_to_a[j] = a.index(name)
    if 0 not in b_to_a:
        if b_to_a:
            raise BreedError(f"the parents have no common root: A's root is {a.names[0]!r}, B's {b.names[0]!r} "
                             f"(and B's root corresponds to nothing in A); name them alike or map them")
        raise BreedError(f"the parents have no common root and no joint in common: A's root is {a.names[0]!r}, "
                         f"B's {b.names[0]!r}; give a mapping YAML (--map) that pairs at least the roots")
    if b_to_a[0] != 0:
        raise BreedError(f"the parents have no common root: B's root {b.names[0]!r} corresponds to A's "
                         f"{a.names[b_to_a[0]]!r}, not to A's root {a.names[0]!r}")
    names = list(a.names)
    parents = list(a.parents)
    offsets = list(a.offsets)
    channels = list(a.channels)
    from_a: list[int | None] = list(range(a.num_joints))
    from_b: list[int | None] = [None] * a.num_joints
    for jb, ja in b_to_a.items():
        from_b[ja] = jb
    meta_of_b: dict[int, int] = dict(b_to_a)
    for jb in range(b.num_joints):
        if jb in meta_of_b:
            continue
        name = b.names[jb]
        while name in names:
            name += "_b"
        meta_of_b[jb] = len(names)
        names.append(name)
        parents.append(meta_of_b[int(b.parents[jb])])
        offsets.append(b.offsets[jb])
        channels.append(tuple(c for c in b.channels[jb] if c.endswith("rotation")) or ("Zrotation", "Xrotation",
                                                                                        "Yrotation"))
        from_a.append(None)
        from_b.append(jb)
    # reorder so parents come before children (appended joints may hang under later A joints: no,
    # A's joints all come first, and B's appended joints follow their parents in B's order)
    es_par, es_off = [], []
    for e, p in enumerate(a.end_site_parents):
        es_par.append(int(p))
        es_off.append(a.end_site_offsets[e])
    for e, p in enumerate(b.end_site_parents):
        m = meta_of_b[int(p)]
        if from_a[m] is None:  # End Sites of B-only joints
            es_par.append(m)
            es_off.append(b.end_site_offsets[e])
    sk = Skeleton(names=tuple(names), parents=np.array(parents), offsets=np.array(offsets),
                  channels=tuple(channels), end_site_parents=np.array(es_par, dtype=np.int64),
                  end_site_offsets=np.array(es_off).reshape(-1, 3))
    return MetaSkeleton(skeleton=sk, from_a=from_a, from_b=from_b)
