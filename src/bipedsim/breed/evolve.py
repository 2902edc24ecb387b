"""Hierarchical evolution: breed two parent motions into a child motion.

The four steps are separate functions:

0. Correspondence -- a static root at the floor with the body's translation on its child is folded
   away (:mod:`bipedsim.motion.reroot`); without a user mapping the joints are paired by role
   (:func:`bipedsim.motion.correspondence.correspondence`: names in the usual conventions, else structure and
   geometry). The pairs and why each was made go to the report and can be saved as a ``--map`` file.
1. :func:`crossover` -- a meta-skeleton holding every joint of both parents: joints that correspond
   (the pairs above, same names, or -- for the roots -- the structural rule that both roots are the
   bodies' roots) are kept once; the others are appended under the joint their parent maps to.
2. :func:`mutate` -- each joint's activity is the standard deviation over time of the angle its bone
   turns between consecutive frames (cos theta = X(t).X(t-1) / |X(t)||X(t-1)|). The parents' activity
   vectors are standardised and combined by PCA over the pair (the first principal component's
   weights); a joint then scores as its liveliest descendant (removing it removes them all), user
   weights are added (negative: more likely to go), and the N lowest-scored joints are removed with
   their subtrees.
3. :func:`survivor` -- parent A is sampled every ``sample_every`` frames; for each sample the window of
   parent B with the smallest motion difference (least "energy loss") is found; the correction d is
   the rotation from A to that B window on the joints both have (rotation vectors, interpolated between
   samples); the child is C(t) = C1(t) + x d(t), i.e. A's rotation turned by x of the correction.
   Joints only one parent has take that parent's motion (B's at the matched time).
4. :func:`floor_constraint` -- no joint below the floor: offending joints are lifted by the smallest
   rotation of the bone above them (a one-joint IK step, parents first); joints above stay unchanged.

All motions here are in the project frame (metres, Z up).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim import config
from bipedsim.config import limit_from_env
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.motion.correspondence import correspondence
from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.motion.reroot import fold_static_root
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]

#: Range of the spacetime parameter x (0 = parent A's motion, 1 = the matched motion of parent B).
X_RANGE = (0.0, 1.0)
SAMPLE_EVERY = 5
#: Half-width (frames) of the windows compared in the survivor step.
WINDOW_HALF = 5
#: Most frames of each parent (B at A's frame rate): the survivor step compares every frame of A with
#: every frame of B (20 000 frames: about 3 min at 120 fps, 11 min at 30 fps; tens of seconds). Raised
#: with ``BIPEDSIM_MAX_BREED_FRAMES``.
MAX_BREED_FRAMES = 20_000
#: Frame pairs (A x B) whose motion differences are held at once in the survivor step (32 MB of float64);
#: longer parents are compared a block of A's frames at a time.
PAIR_BLOCK = 4_000_000


def max_breed_frames() -> int:
    """:data:`MAX_BREED_FRAMES`, or ``BIPEDSIM_MAX_BREED_FRAMES`` where set."""
    return limit_from_env("breed_frames", MAX_BREED_FRAMES)


class BreedError(BipedsimError):
    """Parents that cannot be bred, or a bad breeding parameter."""


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


def mutate(meta: MetaSkeleton, act_a: FloatArray, act_b: FloatArray, count: int = 5,
           weights: dict[str, float] | None = None) -> MutationResult:
    """Choose the ``count`` lowest-scored joints (root never) and remove them with their subtrees."""
    sk = meta.skeleton
    score, w = activity_scores(meta, act_a, act_b, weights)
    if count < 0:
        raise BreedError(f"mutation count must be >= 0, got {count}")
    removable = sk.num_joints - 1
    if count > removable:
        raise BreedError(f"{count} mutations asked, but only {removable} joints can be removed (the root stays)")
    order = sorted(range(1, sk.num_joints), key=lambda j: (score[j], j))
    gone: set[int] = set()
    chosen: list[int] = []
    for j in order:
        if len(chosen) == count:
            break
        if j in gone:
            continue
        chosen.append(j)
        gone.update(sk.subtree(j))
    if len(chosen) < count:
        raise BreedError(f"{count} mutations asked, but removing subtrees left only {len(chosen)} joints to choose")
    return MutationResult(removed=[sk.names[j] for j in chosen], removed_all=[sk.names[j] for j in sorted(gone)],
                          scores={sk.names[j]: float(score[j]) for j in range(sk.num_joints)}, pca_weights=w)


# ---------------------------------------------------------------------- 3. survivor
@dataclass
class SurvivorResult:
    rotations: FloatArray  #: (T, J_meta, 4) child rotations
    matched: npt.NDArray[np.int64]  #: per frame of A, the matched frame of B
    correction: FloatArray  #: (T, n_common, 3) d(t), rotation vectors (rad)


def survivor(meta: MetaSkeleton, a: Motion, b: Motion, x: float = 0.5, sample_every: int = SAMPLE_EVERY,
             correction: FloatArray | None = None) -> SurvivorResult:
    """Motion transfer (see module docstring). ``b`` must have ``a``'s frame time. ``correction``:
    a known d (T, n_common, 3) to use instead of the matched one (tests)."""
    if not X_RANGE[0] <= x <= X_RANGE[1]:
        raise BreedError(f"x must be in [{X_RANGE[0]}, {X_RANGE[1]}] (0: parent A's motion, 1: B's matched "
                         f"motion), got {x}")
    if sample_every < 1:
        raise BreedError("sample_every must be >= 1")
    common = meta.common
    ja = [meta.from_a[i] for i in common]
    jb = [meta.from_b[i] for i in common]
    t_a, t_b = a.num_frames, b.num_frames
    qa = Rotation.from_quat(a.rotations[:, ja].reshape(-1, 4)).as_matrix().reshape(t_a, len(common), 3, 3)
    qb = Rotation.from_quat(b.rotations[:, jb].reshape(-1, 4)).as_matrix().reshape(t_b, len(common), 3, 3)
    samples = np.arange(0, t_a, sample_every)
    if samples[-1] != t_a - 1:
        samples = np.append(samples, t_a - 1)
    # motion difference of windows: sum over joints and window frames of |R_a - R_b|_F^2 (= 4(1 - cos))
    fa = qa.reshape(t_a, -1)
    fb = qb.reshape(t_b, -1)
    sq_a, sq_b = np.sum(fa * fa, axis=1), np.sum(fb * fb, axis=1)
    offs = np.arange(-WINDOW_HALF, WINDOW_HALF + 1)
    matched_s = np.zeros(len(samples), dtype=np.int64)
    # the (Ta, Tb) differences at once when they are small, else a block of A's frames at a time (each
    # block with the window's margin), so memory stays bounded whatever the parents' length
    step = t_a if t_a * t_b <= PAIR_BLOCK else max(1, PAIR_BLOCK // t_b - 2 * WINDOW_HALF)
    k = 0
    for b0 in range(0, t_a, step):
        lo, hi = max(0, b0 - WINDOW_HALF), min(t_a, b0 + step + WINDOW_HALF)
        d2 = sq_a[lo:hi, None] + sq_b[None, :] - 2.0 * fa[lo:hi] @ fb.T  # (rows, Tb)
        while k < len(samples) and samples[k] < b0 + step:
            ia = np.clip(samples[k] + offs, 0, t_a - 1)
            cost = np.zeros(t_b)
            for o, i in zip(offs, ia):
                ib = np.clip(np.arange(t_b) + o, 0, t_b - 1)
                cost += d2[i - lo, ib]
            matched_s[k] = int(np.argmin(cost))
            k += 1
    matched = np.interp(np.arange(t_a), samples, matched_s).round().astype(np.int64)
    if correction is None:
        corr_s = np.zeros((len(samples), len(common), 3))
        for k, (s, m) in enumerate(zip(samples, matched_s)):
            corr_s[k] = Rotation.from_matrix(np.transpose(qa[s], (0, 2, 1)) @ qb[m]).as_rotvec()
        flat = corr_s.reshape(len(samples), -1)
        corr = np.stack([np.interp(np.arange(t_a), samples, flat[:, c]) for c in range(flat.shape[1])],
                        axis=1).reshape(t_a, len(common), 3)
    else:
        corr = np.asarray(correction, dtype=float).reshape(t_a, len(common), 3)
    n = meta.skeleton.num_joints
    out = np.zeros((t_a, n, 4))
    out[..., 3] = 1.0
    for i in range(n):
        if meta.from_a[i] is not None and meta.from_b[i] is None:
            out[:, i] = a.rotations[:, meta.from_a[i]]
        elif meta.from_a[i] is None:
            out[:, i] = b.rotations[matched, meta.from_b[i]]
    for k, i in enumerate(common):
        ra = Rotation.from_quat(a.rotations[:, meta.from_a[i]])
        out[:, i] = (ra * Rotation.from_rotvec(x * corr[:, k])).as_quat()
    for i in _between_paired(meta, a.skeleton):  # A's joints B's chain does not have: toward identity
        ra = Rotation.from_quat(a.rotations[:, i])
        out[:, i] = (ra * Rotation.from_rotvec(-x * ra.as_rotvec())).as_quat()
    return SurvivorResult(rotations=canonical_quat(out), matched=matched, correction=corr)


# ---------------------------------------------------------------------- 3a. rest-pose alignment
def _rest_positions(sk: Skeleton) -> FloatArray:
    """Joint positions of the rest pose (every rotation identity), root at the origin."""
    pos = np.zeros((sk.num_joints, 3))
    for j in range(1, sk.num_joints):
        pos[j] = pos[int(sk.parents[j])] + sk.offsets[j]
    return pos


def _best_rotation(src: list[FloatArray], dst: list[FloatArray]) -> FloatArray:
    """The rotation taking the unit directions ``src`` onto ``dst`` best (least squares, Kabsch); one
    pair, or pairs along one line: the smallest rotation of the first onto the first."""
    u = np.array([v / np.linalg.norm(v) for v in src])
    w = np.array([v / np.linalg.norm(v) for v in dst])
    if len(u) > 1 and np.linalg.matrix_rank(u, tol=1e-3) >= 2 and np.linalg.matrix_rank(w, tol=1e-3) >= 2:
        m = w.T @ u
        uu, _, vt = np.linalg.svd(m)
        d = np.sign(np.linalg.det(uu @ vt))
        return uu @ np.diag([1.0, 1.0, d]) @ vt
    return _min_rot(u[0], w[0])


def rest_alignment(a: Skeleton, b: Skeleton, mapping: dict[int, int]) -> FloatArray:
    """Per joint of B, the rotation C (3, 3) that takes A's rest bone directions at the corresponding
    joint onto B's: C maps the direction from A's joint to its nearest paired descendants (in each
    child branch, the first at a distance, else its End Site) onto the direction between B's
    counterparts. ``mapping``: B joint -> A joint. Joints of B without a counterpart (or with no
    direction to compare) take their parent's C.

    Parents' local rotations are rotations from their own rest pose: a file whose rest pose lies
    along X (bone-aligned joint frames, the pose made by the rotations) and one whose rest pose
    stands have local rotations that mean different poses; they can be blended only in one rest."""
    pa, pb = _rest_positions(a), _rest_positions(b)
    size = max(float(np.ptp(pa, axis=0).max()), float(np.ptp(pb, axis=0).max()), 1e-9)
    near = 1e-3 * size
    out = np.tile(np.eye(3), (b.num_joints, 1, 1))
    for jb in range(b.num_joints):
        c = out[int(b.parents[jb])] if jb else np.eye(3)
        ja = mapping.get(jb)
        if ja is not None:
            src, dst = [], []
            b_sub = set(b.subtree(jb))
            stack = list(a.children(ja))
            while stack:
                k = stack.pop()
                kb = next((q for q, r in mapping.items() if r == k), None)
                va = pa[k] - pa[ja]
                if kb is not None and kb in b_sub and np.linalg.norm(va) > near and np.linalg.norm(
                        pb[kb] - pb[jb]) > near:
                    src.append(va)
                    dst.append(pb[kb] - pb[jb])
                else:
                    stack.extend(a.children(k))
            if not src:
                ea = [a.end_site_offsets[e] for e, q in enumerate(a.end_site_parents) if int(q) == ja]
                eb = [b.end_site_offsets[e] for e, q in enumerate(b.end_site_parents) if int(q) == jb]
                if len(ea) == 1 and len(eb) == 1 and min(np.linalg.norm(ea[0]), np.linalg.norm(eb[0])) > near:
                    src, dst = ea, eb
            if src:
                c = _best_rotation(src, dst)
        out[jb] = c
    return out


def in_rest_of(a: Skeleton, b: Motion, mapping: dict[int, int]) -> Motion:
    """``b`` with its joint frames turned (:func:`rest_alignment`) so that its rest pose is A's at the
    paired joints: local rotations C_p^T L C, offsets C_p^T o, End Sites C^T e (p the parent). Every
    joint and End Site stays where it was in every frame."""
    sk = b.skeleton
    c = rest_alignment(a, sk, mapping)
    par = np.maximum(sk.parents, 0)
    cp = c[par]
    cp[0] = np.eye(3)
    offsets = np.einsum("jki,jk->ji", cp, sk.offsets)
    offsets[0] = sk.offsets[0]
    es = np.einsum("jki,jk->ji", c[sk.end_site_parents], sk.end_site_offsets) if len(sk.end_site_parents) else \
        sk.end_site_offsets
    t, n = b.num_frames, sk.num_joints
    loc = Rotation.from_quat(b.rotations.reshape(-1, 4)).as_matrix().reshape(t, n, 3, 3)
    loc = np.einsum("jki,tjkl,jlm->tjim", cp, loc, c)
    rot = canonical_quat(Rotation.from_matrix(loc.reshape(-1, 3, 3)).as_quat().reshape(t, n, 4))
    trans = None
    if b.translations is not None:
        trans = np.einsum("jki,tjk->tji", cp, b.translations)
        trans[:, 0] = b.translations[:, 0]
    return b.copy(skeleton=sk.replace(offsets=offsets, end_site_offsets=es.reshape(-1, 3)), rotations=rot,
                  translations=trans)


def across_unpaired(meta: MetaSkeleton, a: Skeleton, b: Motion) -> Motion:
    """``b`` with each paired joint's local rotation taken from its nearest paired ancestor (B's joints
    between them, which A does not have, folded in: G_anc^T G_j), so that blended into A's chain --
    where A's own unpaired joints in between turn toward identity as x goes to B
    (:func:`survivor`) -- it gives B's pose of the joint. B-only joints keep their own rotations."""
    _, g = b.fk()
    rot = b.rotations.copy()
    for i in meta.common:
        jb = meta.from_b[i]
        anc = _paired_ancestor(meta, a, i)
        if anc is None or jb is None:
            continue
        ab = meta.from_b[anc]
        assert ab is not None
        if int(b.skeleton.parents[jb]) == ab:
            continue
        rel = np.einsum("tki,tkl->til", g[:, ab], g[:, jb])
        rot[:, jb] = Rotation.from_matrix(rel).as_quat()
    return b.copy(rotations=canonical_quat(rot))


def _paired_ancestor(meta: MetaSkeleton, a: Skeleton, i: int) -> int | None:
    """The nearest ancestor of A's joint ``i`` that is paired with a joint of B (None at the root)."""
    common = set(meta.common)
    k = int(a.parents[i])
    while k >= 0 and k not in common:
        k = int(a.parents[k])
    return k if k >= 0 else None


def _between_paired(meta: MetaSkeleton, a: Skeleton) -> list[int]:
    """A's unpaired joints with a paired ancestor and a paired descendant (a clavicle A has and B has
    not): their rotation is no part of B's chain."""
    common = set(meta.common)
    return [j for j in range(a.num_joints) if j not in common and _paired_ancestor(meta, a, j) is not None
            and any(k in common for k in a.subtree(j) if k != j)]


def typical_frame(motion: Motion) -> int:
    """The frame whose pose (every joint's local rotation matrix) is closest to the clip's mean pose."""
    t, n = motion.num_frames, motion.num_joints
    r = Rotation.from_quat(motion.rotations.reshape(-1, 4)).as_matrix().reshape(t, n * 9)
    return int(np.argmin(np.sum((r - r.mean(axis=0)) ** 2, axis=1)))


def on_typical_rest(motion: Motion) -> Motion:
    """``motion`` rebased (:meth:`Motion.rebased`) on its :func:`typical_frame`: its rest pose is a
    pose of its own motion, with world-parallel joint frames, and its rotations measure how far each
    frame is from it. Two files' local rotations mean the same pose only from such a rest."""
    return motion.rebased(typical_frame(motion))


def _folded_b_joints(meta: MetaSkeleton, b: Skeleton) -> list[str]:
    """B's unpaired joints between paired ones that keep nothing under them in the meta-skeleton (their
    rotation is folded into the paired joint below, :func:`across_unpaired`): left in, each would be
    a stray bone."""
    sk = meta.skeleton
    paired_b = {jb for jb in meta.from_b if jb is not None and meta.from_a[meta.from_b.index(jb)] is not None}
    return [sk.names[i] for i in range(sk.num_joints)
            if meta.from_a[i] is None and meta.from_b[i] is not None and not sk.children(i)
            and not any(e == i for e in sk.end_site_parents)
            and any(k in paired_b for k in b.subtree(meta.from_b[i]) if k != meta.from_b[i])]


# ---------------------------------------------------------------------- 4. floor constraint
#: Passes of the one-bone IK per frame before the rest of a frame's penetration is taken out by
#: lifting the whole body (turning one bone can push a sibling under the floor).
FLOOR_PASSES = 3


def floor_constraint(motion: Motion, floor: float = 0.0) -> tuple[Motion, int]:
    """Lift joints and End Sites below ``floor`` by turning the bone above each one (parents first,
    up to :data:`FLOOR_PASSES` passes); what is still below afterwards is lifted with the whole body.
    Returns the corrected motion and how many (frame, point) corrections were made. Frames already
    above the floor are unchanged."""
    m = motion.copy()
    fixes = 0
    low = _lowest(m)
    for t in np.flatnonzero(low < floor - 1e-9):
        frame = m[t:t + 1]
        for _ in range(FLOOR_PASSES):
            moved = _lift_pass(frame, floor)
            fixes += moved
            if not moved:
                break
        rest = floor - float(_lowest(frame)[0])
        if rest > 1e-9:
            frame.root_translation[0, 2] += rest
            fixes += 1
        m.rotations[t] = frame.rotations[0]
        m.root_translation[t] = frame.root_translation[0]
    return m, fixes


def _lowest(m: Motion) -> FloatArray:
    """(T,) height of the lowest joint or End Site per frame."""
    z = m.fk()[0][..., 2].min(axis=1)
    if len(m.skeleton.end_site_parents):
        z = np.minimum(z, m.end_site_positions()[..., 2].min(axis=1))
    return z


def _lift_pass(frame: Motion, floor: float) -> int:
    """One pass over a one-frame motion's joints, then End Sites: each one below the floor is lifted
    (the root by moving it, others by turning the bone above them). Returns how many were lifted."""
    sk = frame.skeleton
    moved = 0
    points = [(j, -1) for j in range(sk.num_joints)] + [(int(p), e) for e, p in enumerate(sk.end_site_parents)]
    p, g = frame.fk()
    for j, e in points:
        point = p[0, j] if e < 0 else p[0, j] + g[0, j] @ sk.end_site_offsets[e]
        if point[2] >= floor - 1e-9:
            continue
        if e < 0 and j == 0:
            frame.root_translation[0, 2] += floor - point[2]
            moved += 1
        else:
            moved += _turn_bone(frame, int(sk.parents[j]) if e < 0 else j, point, p, g, floor)
        p, g = frame.fk()  # only after a change: the checks use the current pose
    return moved


def _turn_bone(frame: Motion, par: int, point: FloatArray, p: FloatArray, g: FloatArray, floor: float) -> int:
    """Turn joint ``par`` by the smallest rotation that brings ``point`` (below the floor, carried by
    ``par``) up to the floor; when the bone is too short to reach, lift the whole frame instead."""
    sk = frame.skeleton
    v = point - p[0, par]
    length = float(np.linalg.norm(v))
    if length < 1e-12:
        return 0
    need = floor - p[0, par, 2]  # target vertical component of the bone
    if abs(need) > length:  # the joint itself is too low to reach: lift the whole frame
        frame.root_translation[0, 2] += floor - point[2]
        return 1
    horiz = np.hypot(v[0], v[1])
    new_h = np.sqrt(max(length ** 2 - need ** 2, 0.0))
    d = np.array([v[0], v[1]]) / horiz if horiz > 1e-12 else np.array([1.0, 0.0])
    r = _min_rot(v, np.array([d[0] * new_h, d[1] * new_h, need]))
    gp = g[0, par]
    new_local = r @ gp if sk.parents[par] < 0 else g[0, int(sk.parents[par])].T @ r @ gp
    frame.rotations[0, par] = canonical_quat(Rotation.from_matrix(new_local).as_quat())
    return 1


def depth_first(motion: Motion) -> Motion:
    """The motion with its joints in depth-first order (each joint's subtree right after it), the
    order a BVH file lists them in: the crossover appends B's joints after all of A's, and a skeleton
    not in file order would be written with its channel columns out of step with its hierarchy."""
    sk = motion.skeleton
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(sk.children(j)))
    if order == list(range(sk.num_joints)):
        return motion
    new = {j: i for i, j in enumerate(order)}
    es = sorted(range(len(sk.end_site_parents)), key=lambda e: new[int(sk.end_site_parents[e])])
    out = Skeleton(names=tuple(sk.names[j] for j in order),
                   parents=np.array([-1 if sk.parents[j] < 0 else new[int(sk.parents[j])] for j in order]),
                   offsets=sk.offsets[order], channels=tuple(sk.channels[j] for j in order),
                   position_modes=tuple(sk.position_modes[j] for j in order),
                   end_site_parents=np.array([new[int(sk.end_site_parents[e])] for e in es], dtype=np.int64),
                   end_site_offsets=sk.end_site_offsets[es].reshape(-1, 3))
    return motion.copy(skeleton=out, rotations=motion.rotations[:, order],
                       translations=None if motion.translations is None else motion.translations[:, order])


def _min_rot(a: FloatArray, b: FloatArray) -> FloatArray:
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s = np.linalg.norm(axis)
    c = float(np.dot(a, b))
    if s < 1e-12:
        return np.eye(3)
    return Rotation.from_rotvec(axis / s * np.arctan2(s, c)).as_matrix()


# ---------------------------------------------------------------------- the whole breeding
@dataclass
class BreedReport:
    parents: list[str]
    x: float
    mutations: int
    kept_common: list[str] = field(default_factory=list)
    only_a: list[str] = field(default_factory=list)
    only_b: list[str] = field(default_factory=list)
    removed: list[str] = field(default_factory=list)
    removed_with_subtrees: list[str] = field(default_factory=list)
    activity: dict[str, float] = field(default_factory=dict)
    pca_weights: tuple[float, float] = (0.0, 0.0)
    floor_fixes: int = 0
    timings_s: dict[str, float] = field(default_factory=dict)
    child_joints: int = 0
    child_frames: int = 0
    #: joint of A -> joint of B, as a ``--map`` file holds it (the pairs the breeding used)
    correspondence: dict[str, str] = field(default_factory=dict)
    #: joint of A -> why it was paired ("left leg knee", "trunk below chest", "same name", "--map")
    correspondence_reasons: dict[str, str] = field(default_factory=dict)
    map_source: str = "roles"  #: "roles" (found automatically) or the --map file
    #: per parent ("A"/"B"): the static root folded away and the joint that became the root
    folded_roots: dict[str, dict[str, str]] = field(default_factory=dict)
    #: per parent: what decided its roles (names or geometry, and how the facing direction was found)
    role_evidence: dict[str, dict[str, str]] = field(default_factory=dict)
    #: per parent: joint -> the role found for it ("left leg knee", "chest", "trunk"...), paired or not
    roles: dict[str, dict[str, str]] = field(default_factory=dict)
    #: the body kind ``bipedsim run`` builds for the child ("humanoid"/"creature"; "" when not checked)
    body: str = ""
    #: whether ``bipedsim run`` detects that kind by itself (False: give it with --profile)
    body_detected: bool = True

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def prune(meta: MetaSkeleton, rotations: FloatArray, motion_a: Motion, removed: set[str]) -> tuple[Skeleton,
                                                                                                    list[int]]:
    sk = meta.skeleton
    keep = [j for j in range(sk.num_joints) if sk.names[j] not in removed]
    new_index = {j: k for k, j in enumerate(keep)}
    parents = [-1 if sk.parents[j] < 0 else new_index[int(sk.parents[j])] for j in keep]
    es = [(new_index[int(p)], sk.end_site_offsets[e]) for e, p in enumerate(sk.end_site_parents) if int(p) in new_index]
    child = Skeleton(names=tuple(sk.names[j] for j in keep), parents=np.array(parents),
                     offsets=sk.offsets[keep], channels=tuple(
                         tuple(c for c in sk.channels[j] if c.endswith("rotation")) if j else sk.channels[j]
                         for j in keep),
                     end_site_parents=np.array([p for p, _ in es], dtype=np.int64),
                     end_site_offsets=np.array([o for _, o in es]).reshape(-1, 3))
    return child, keep


def breed(a: Motion, b: Motion, *, x: float = 0.5, mutations: int = 5, weights: dict[str, float] | None = None,
          mapping: dict[str, str] | None = None, names: tuple[str, str] = ("A", "B")) -> tuple[Motion, BreedReport]:
    """Breed two motions (project frame) into a child motion on the pruned meta-skeleton.

    ``mapping``: joint of A -> joint of B, the whole correspondence (joints it leaves out are paired
    only when their names are equal); None: found by role. A static root at the floor is folded into
    the joint that carries the translation first (a mapping may name either)."""
    if not X_RANGE[0] <= x <= X_RANGE[1]:
        raise BreedError(f"x must be in [{X_RANGE[0]}, {X_RANGE[1]}] (0: parent A's motion, 1: B's), got {x}")
    most = max_breed_frames()
    for who, n in ((f"parent A {names[0]}", a.num_frames),
                   (f"parent B {names[1]}", int(b.duration / a.frame_time) + 1)):  # B is played at A's rate
        if n > most:
            raise BreedError(f"{who} has {n} frames at parent A's frame rate ({1 / a.frame_time:g} fps); breeding "
                             f"compares every frame of A with every frame of B, at most {most} frames each: cut "
                             "the file, or set BIPEDSIM_MAX_BREED_FRAMES to allow more")
    tm: dict[str, float] = {}
    t0 = time.perf_counter()
    a, fold_a = fold_static_root(a.to_project_frame())
    b, fold_b = fold_static_root(b.to_project_frame())
    # local rotations are blended: both parents rebased on their own typical pose (FK unchanged), so
    # that similar poses are similar rotations, small ones from the rest, whatever rest pose (along X,
    # standing) and twist of joint frames a file has
    folded = {p: {"root": f.root, "into": f.into} for p, f in (("A", fold_a), ("B", fold_b)) if f is not None}
    evidence: dict[str, dict[str, str]] = {}
    roles: dict[str, dict[str, str]] = {}
    if mapping is None:
        corr = correspondence(a, b)
        mapping, reasons, source = corr.pairs, corr.reasons, "roles"
        evidence = {"A": corr.roles_a.evidence, "B": corr.roles_b.evidence}
        roles = {"A": corr.roles_a.joint_roles(), "B": corr.roles_b.joint_roles()}
    else:
        alias_a = {fold_a.root: fold_a.into} if fold_a else {}
        alias_b = {fold_b.root: fold_b.into} if fold_b else {}
        mapping = {alias_a.get(k, k): alias_b.get(v, v) for k, v in mapping.items()}
        reasons, source = {k: "--map" for k in mapping}, "--map"
    tm["correspondence"] = time.perf_counter() - t0
    if not np.isclose(a.frame_time, b.frame_time):
        b = b.resample(a.fps)
    a, b = on_typical_rest(a), on_typical_rest(b)
    t0 = time.perf_counter()
    meta = crossover(a.skeleton, b.skeleton, mapping)
    # B's rotations re-expressed in A's rest pose: local rotations are blended, and rotations from
    # rest poses that differ (one along X, one standing) mean different poses
    b = in_rest_of(a.skeleton, b, {int(jb): i for i, jb in enumerate(meta.from_b[:a.num_joints]) if jb is not None})
    meta = crossover(a.skeleton, b.skeleton, mapping)
    act_a, act_b = joint_activity(a), joint_activity(b)  # from B's own FK, before the folding below
    b = across_unpaired(meta, a.skeleton, b)
    tm["crossover"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    mut = mutate(meta, act_a, act_b, mutations, weights)
    tm["mutation"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    surv = survivor(meta, a, b, x=x)
    tm["survivor"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    child_sk, keep = prune(meta, surv.rotations, a, set(mut.removed_all) | set(_folded_b_joints(meta, b.skeleton)))
    child = Motion(skeleton=child_sk, frame_time=a.frame_time, root_translation=a.root_translation.copy(),
                   rotations=surv.rotations[:, keep], unit=1.0, up="z")
    child, fixes = floor_constraint(depth_first(child))
    tm["constraint"] = time.perf_counter() - t0
    sk = meta.skeleton
    rep = BreedReport(parents=list(names), x=x, mutations=mutations,
                      kept_common=[sk.names[i] for i in meta.common],
                      only_a=[sk.names[i] for i in range(sk.num_joints) if meta.from_b[i] is None],
                      only_b=[sk.names[i] for i in range(sk.num_joints) if meta.from_a[i] is None],
                      removed=mut.removed, removed_with_subtrees=mut.removed_all, activity=mut.scores,
                      pca_weights=mut.pca_weights, floor_fixes=fixes, timings_s=tm,
                      child_joints=child_sk.num_joints, child_frames=child.num_frames,
                      correspondence=_pairs_used(meta, b.skeleton), correspondence_reasons=_reasons_used(meta, reasons),
                      map_source=source, folded_roots=folded, role_evidence=evidence, roles=roles)
    return child, rep


def _pairs_used(meta: MetaSkeleton, b: Skeleton) -> dict[str, str]:
    return {meta.skeleton.names[i]: b.names[meta.from_b[i]] for i in meta.common}  # type: ignore[index]


def _reasons_used(meta: MetaSkeleton, reasons: dict[str, str]) -> dict[str, str]:
    return {meta.skeleton.names[i]: reasons.get(meta.skeleton.names[i], "same name") for i in meta.common}
