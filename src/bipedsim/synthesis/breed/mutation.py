"""2. Mutation: each joint's activity (the standard deviation over time of the angle its bone turns
between frames), the parents' activities combined by PCA into one score per meta joint (a joint as lively
as the liveliest part it carries, plus user weights), and the lowest-scored joints removed with their
subtrees. A mutation never removes what the creature stands on: the joints that carry a parent's feet
(measured from its clip, :func:`support_joints`) and every joint above them are kept."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from bipedsim.model.creature_kind import detect_body_kind
from bipedsim.motion.motion import Motion
from bipedsim.synthesis.breed.limits import BreedError
from bipedsim.synthesis.breed.meta_skeleton import MetaSkeleton

FloatArray = npt.NDArray[np.float64]


# ---------------------------------------------------------------------- 2. mutation
def joint_activity(motion: Motion) -> FloatArray:
    """(J,) standard deviation over time of each joint's bone-turning angle between frames (rad).

    A joint's bone X runs from it to its first child (or End Site); joints with no bone score 0."""
    sk = motion.skeleton
    pos = motion.fk()[0]
    if motion.num_frames < 3:
        return np.zeros(sk.num_joints)
    ends = motion.end_site_positions() if len(sk.end_site_parents) else np.zeros((motion.num_frames, 0, 3))
    act = np.zeros(sk.num_joints)
    for j in range(sk.num_joints):
        kids = sk.children(j)
        if kids:
            x = pos[:, kids[0]] - pos[:, j]
        else:
            es = [e for e, p in enumerate(sk.end_site_parents) if p == j]
            if not es:
                continue
            x = ends[:, es[0]] - pos[:, j]
        n = np.linalg.norm(x, axis=1)
        if np.all(n < 1e-9):
            continue
        c = np.sum(x[1:] * x[:-1], axis=1) / np.maximum(n[1:] * n[:-1], 1e-12)
        theta = np.arccos(np.clip(c, -1.0, 1.0))
        act[j] = float(np.std(theta))
    return act


@dataclass
class MutationResult:
    removed: list[str]  #: joints chosen (lowest scores), each removed with its subtree
    removed_all: list[str]  #: every joint removed (subtrees included)
    scores: dict[str, float]
    pca_weights: tuple[float, float]


def _standardise(v: FloatArray) -> FloatArray:
    s = v.std()
    return (v - v.mean()) / s if s > 1e-12 else v - v.mean()


def activity_scores(meta: MetaSkeleton, act_a: FloatArray, act_b: FloatArray,
                    weights: dict[str, float] | None = None) -> tuple[FloatArray, tuple[float, float]]:
    """Combined activity per meta joint (PCA over the parents' standardised activities) plus weights."""
    za, zb = _standardise(act_a), _standardise(act_b)
    common = meta.common
    wa, wb = 0.5 ** 0.5, 0.5 ** 0.5
    if len(common) >= 2:
        m = np.stack([[za[meta.from_a[i]], zb[meta.from_b[i]]] for i in common])
        m = m - m.mean(axis=0)
        _, _, vt = np.linalg.svd(m, full_matrices=False)
        pc = vt[0] * (1.0 if vt[0].sum() >= 0 else -1.0)
        wa, wb = float(abs(pc[0])), float(abs(pc[1]))
    n = meta.skeleton.num_joints
    score = np.zeros(n)
    for i in range(n):
        a, b = meta.from_a[i], meta.from_b[i]
        if a is not None and b is not None:
            score[i] = (wa * za[a] + wb * zb[b]) / max(wa + wb, 1e-12)
        elif a is not None:
            score[i] = za[a]
        else:
            score[i] = zb[b]  # type: ignore[index]
    # a joint is as lively as the liveliest part it carries: removing it removes its subtree
    sk = meta.skeleton
    carried = score.copy()
    for i in range(n - 1, 0, -1):
        p = int(sk.parents[i])
        carried[p] = max(carried[p], carried[i])
    for name, w in (weights or {}).items():
        if not (isinstance(w, int | float) and math.isfinite(w)):
            raise BreedError(f"weight for joint {name!r} must be a finite number, got {w!r}")
        if name not in sk.names:
            raise BreedError(f"weight for unknown joint {name!r}; joints are {', '.join(sk.names)}")
        carried[sk.index(name)] += w
    return carried, (wa, wb)


def support_joints(motion: Motion) -> set[str]:
    """Names of the joints that carry ``motion``'s feet: each foot's joint (the joint of a low tip,
    :func:`~bipedsim.model.creature_kind.detect_body_kind`, measured from the clip, not from names).
    A mutation keeps them and every joint above them."""
    sk = motion.skeleton
    out: set[str] = set()
    for _, feet in detect_body_kind(motion).legs:
        for f in feet:
            out.add(f.split("/")[0])  # "Joint/End Site" -> the joint the End Site hangs from
    return {n for n in out if n in sk.names}


def leg_roots(motion: Motion) -> set[str]:
    """Names of the roots of ``motion``'s legs (the legs
    :func:`~bipedsim.model.creature_kind.detect_body_kind` measures from the clip: chains ending in tips
    that stay low). A limb the clip holds up (a bird's wing, a human's arm) is no leg."""
    return {root for root, _ in detect_body_kind(motion).legs if root in motion.skeleton.names}


def mutate(meta: MetaSkeleton, act_a: FloatArray, act_b: FloatArray, count: int = 5,
           weights: dict[str, float] | None = None, keep: set[int] | None = None) -> MutationResult:
    """Choose the ``count`` lowest-scored joints (root never) and remove them with their subtrees.

    ``keep``: meta joints never removed, nor any joint whose subtree holds one (a creature's feet: a
    mutation never removes what it stands on); when fewer than ``count`` joints remain removable, the
    removable ones go."""
    sk = meta.skeleton
    score, w = activity_scores(meta, act_a, act_b, weights)
    if count < 0:
        raise BreedError(f"mutation count must be >= 0, got {count}")
    removable = sk.num_joints - 1
    if count > removable:
        raise BreedError(f"{count} mutations asked, but only {removable} joints can be removed (the root stays)")
    order = sorted(range(1, sk.num_joints), key=lambda j: (score[j], j))
    kept = set(keep or ())
    carries = {j for j in range(sk.num_joints) if kept.intersection(sk.subtree(j))}
    gone: set[int] = set()
    chosen: list[int] = []
    for j in order:
        if len(chosen) == count:
            break
        if j in gone or j in carries:
            continue
        chosen.append(j)
        gone.update(sk.subtree(j))
    if len(chosen) < count and not carries:
        raise BreedError(f"{count} mutations asked, but removing subtrees left only {len(chosen)} joints to choose")
    return MutationResult(removed=[sk.names[j] for j in chosen], removed_all=[sk.names[j] for j in sorted(gone)],
                          scores={sk.names[j]: float(score[j]) for j in range(sk.num_joints)}, pca_weights=w)
