"""3a. Rest-pose alignment: parent B re-expressed in parent A's rest pose at the paired joints (local
rotations are blended, and rotations from rest poses that differ mean different poses), B's joints between
paired ones folded into the paired joint below, a parent rebased on its typical pose, and the child put
on a standing rest with left and right limbs alike."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from bipedsim.model.creature_kind import detect_body_kind
from bipedsim.motion.conventions import axis_index
from bipedsim.motion.motion import Motion, _yaw_between, canonical_quat
from bipedsim.motion.skeleton import Skeleton
from bipedsim.synthesis.breed.meta_skeleton import MetaSkeleton

FloatArray = npt.NDArray[np.float64]


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


def mean_pose_rotations(motion: Motion, g: FloatArray | None = None) -> FloatArray:
    """Each joint's global rotation (J, 3, 3) in ``motion``'s mean pose: per joint the chordal mean over
    the clip of its global rotation with the root's heading (its twist about ``up``) taken off each
    frame, turned back to the heading of the :func:`typical_frame`. ``g``: the global rotations
    (T, J, 3, 3), if known.

    The mean over a walk of a limb's orientation is where it is on average: left and right legs,
    swinging in opposite phases, have mirrored means (a mid-stride frame has one leg forward, the
    other back), and the mean stands as the walk stands on average."""
    g = motion.fk()[1] if g is None else g
    u = axis_index(motion.up)
    root = Rotation.from_matrix(g[:, 0]).as_quat()  # (T, 4): x, y, z, w
    yaw = 2.0 * np.arctan2(root[:, u], root[:, 3])  # (T,) rad: the root's twist about up
    axis = np.eye(3)[u]
    off = Rotation.from_rotvec(-yaw[:, None] * axis).as_matrix()  # (T, 3, 3)
    m = np.einsum("tab,tjbc->jac", off, g) / len(g)  # (J, 3, 3): the chordal (matrix) mean
    uu, _, vt = np.linalg.svd(m)
    d = np.sign(np.linalg.det(uu @ vt))
    uu[:, :, 2] *= d[:, None]
    mean = uu @ vt
    head = Rotation.from_rotvec(yaw[typical_frame(motion)] * axis).as_matrix()
    return np.einsum("ab,jbc->jac", head, mean)


def on_standing_rest(motion: Motion) -> Motion:
    """``motion`` with its joint frames turned (:meth:`Motion.reframed`; forward kinematics unchanged on
    every frame) so that its rest pose (every rotation identity) stands with its left and right limbs
    alike: the trunk and every joint outside a leg in the mean pose (:func:`mean_pose_rotations`), each
    leg (the legs :func:`~bipedsim.model.creature_kind.detect_body_kind` measures from the clip) on the
    frame where it is straightest (:func:`straightest_frame`), turned to the mean pose's heading.

    A bred child's rest is the pose its body is built in, and the body builder centres each ball
    joint's range on it. On a walk's mid-stride frame (:func:`on_typical_rest`) left and right legs
    stand in opposite phases and get ranges of different size (a horse x flamingo child's hind hips:
    0.85 and 0.56 rad); a file's own rest can be no pose the creature walks in (a Biped rig's). Each
    leg at its straightest is the same pose for left and right in a walk, and a range measured from a
    straight leg holds its bends; the mean pose alone (bent legs) gives the tightest ranges, and
    children built on it fell."""
    sk = motion.skeleton
    pos, g = motion.fk()
    rest = mean_pose_rotations(motion, g)
    u = axis_index(motion.up)
    for root, feet in detect_body_kind(motion).legs:
        if root not in sk.names or not feet:
            continue
        top, foot = sk.index(root), sk.index(feet[0].split("/")[0])  # "Joint/End Site" -> its joint
        f = straightest_frame(pos, top, foot)
        par = int(sk.parents[top])
        turn = _yaw_between(rest[par], g[f, par], u)
        for k in sk.subtree(top):
            rest[k] = turn @ g[f, k]
    return motion.reframed(np.transpose(rest, (0, 2, 1)), g)


def straightest_frame(pos: FloatArray, top: int, foot: int) -> int:
    """The frame where the leg from joint ``top`` to joint ``foot`` is straightest: its foot farthest
    from its top (``pos``: global joint positions (T, J, 3), m; the bones between are rigid)."""
    return int(np.argmax(np.linalg.norm(pos[:, foot] - pos[:, top], axis=1)))


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


def _min_rot(a: FloatArray, b: FloatArray) -> FloatArray:
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    axis = np.cross(a, b)
    s = np.linalg.norm(axis)
    c = float(np.dot(a, b))
    if s < 1e-12:
        return np.eye(3)
    return Rotation.from_rotvec(axis / s * np.arctan2(s, c)).as_matrix()
