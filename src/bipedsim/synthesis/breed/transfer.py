"""3. Survivor (motion transfer): parent A sampled every few frames, each sample matched to the window of
parent B with the smallest motion difference, and the child's rotations A's turned by x of the correction
toward the matched B (rotation vectors, interpolated between samples)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.motion.motion import Motion, canonical_quat
from bipedsim.synthesis.breed.alignment import (
    _between_paired,
)
from bipedsim.synthesis.breed.limits import X_RANGE, BreedError
from bipedsim.synthesis.breed.meta_skeleton import MetaSkeleton

FloatArray = npt.NDArray[np.float64]


SAMPLE_EVERY = 5
#: Half-width (frames) of the windows compared in the survivor step.
WINDOW_HALF = 5


#: Frame pairs (A x B) whose motion differences are held at once in the survivor step (32 MB of float64);
#: longer parents are compared a block of A's frames at a time.
PAIR_BLOCK = 4_000_000


# ---------------------------------------------------------------------- 3. survivor
@dataclass
class SurvivorResult:
    rotations: FloatArray  #: (T, J_meta, 4) child rotations
    matched: npt.NDArray[np.int64]  #: per frame of A, the matched frame of B
    correction: FloatArray  #: (T, n_common, 3) d(t), rotation vectors (rad)


def survivor(meta: MetaSkeleton, a: Motion, b: Motion, x: float = 0.5, sample_every: int = SAMPLE_EVERY,
             correction: FloatArray | None = None, x_joints: dict[int, float] | None = None) -> SurvivorResult:
    """Motion transfer (see module docstring). ``b`` must have ``a``'s frame time. ``correction``:
    a known d (T, n_common, 3) to use instead of the matched one (tests). ``x_joints``: meta joint ->
    its own x in [0, 1] (a limb taken whole from one parent), the others blend at ``x``."""
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
    out = blend(meta, a, b, x, corr, matched, x_joints)
    return SurvivorResult(rotations=out, matched=matched, correction=corr)


def blend(meta: MetaSkeleton, a: Motion, b: Motion, x: float, corr: FloatArray, matched: npt.NDArray[np.int64],
          x_joints: dict[int, float] | None = None) -> FloatArray:
    """(T, J_meta, 4) the child's rotations from the survivor step's correction ``corr`` and ``matched``
    frames: A's rotations turned by x of the correction (``x_joints``: a joint's own x), joints of one
    parent only taking that parent's."""
    t_a, n = a.num_frames, meta.skeleton.num_joints
    out = np.zeros((t_a, n, 4))
    out[..., 3] = 1.0
    for i in range(n):
        if meta.from_a[i] is not None and meta.from_b[i] is None:
            out[:, i] = a.rotations[:, meta.from_a[i]]
        elif meta.from_a[i] is None:
            out[:, i] = b.rotations[matched, meta.from_b[i]]
    for k, i in enumerate(meta.common):
        ra = Rotation.from_quat(a.rotations[:, meta.from_a[i]])
        out[:, i] = (ra * Rotation.from_rotvec((x_joints or {}).get(i, x) * corr[:, k])).as_quat()
    for i in _between_paired(meta, a.skeleton):  # A's joints B's chain does not have: toward identity
        ra = Rotation.from_quat(a.rotations[:, i])
        out[:, i] = (ra * Rotation.from_rotvec(-x * ra.as_rotvec())).as_quat()
    return canonical_quat(out)
