"""The limbs of any legged skeleton: sibling subtrees of similar reach paired as left and right limbs, their
kind (leg, arm, wing) from names, their thigh/knee/ankle (upper arm/elbow/wrist) from names or the two
longest, most turning bones, their sides from names or from where they lie of the facing direction, and
whether the named sides are mirrored. Positions in m, project frame (Z up)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.motion.motion import Motion
from bipedsim.motion.role_names import (
    KIND_WORDS,
    LIMB_ANCHORS,
    LIMB_WORDS,
    SIDES,
    _first_word,
    has_word,
    name_side,
)
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]


#: A sibling pair is a limb pair when its shorter chain is at least this fraction of the longer, and
#: at least :data:`LIMB_MIN_FRACTION` of the body's size long (smaller pairs: eyes, fingers, helpers).
PAIR_LENGTH_RATIO = 0.7
LIMB_MIN_FRACTION = 0.12
#: ... and when the smaller subtree has at least this fraction of the larger one's joints.
PAIR_COUNT_RATIO = 0.5
#: A clip travels when its root ends this many body sizes from where it started.
TRAVEL_FRACTION = 0.3
#: The names' sides are exchanged when their left leg lies on the right this consistently (-1: on every
#: frame, :func:`_left_consistency`), both of the direction of travel and of the direction the feet
#: point: a mirrored export, or a skeleton named from the viewer's side (:func:`_names_mirrored`)
MIRRORED_SIDES = -0.5
#: Sibling limbs pair up better the closer their ends' mean heights: the score falls by e per this
#: fraction of the body size (legs end at the floor, wings and arms higher).
PAIR_HEIGHT_SCALE = 0.1


@dataclass
class Limb:
    kind: str  #: "leg", "arm", "wing"
    side: str  #: "left"/"right"
    chain: list[int]  #: main chain from the limb's first joint to its tip
    roles: dict[str, int] = field(default_factory=dict)  #: role -> joint (anchors, above<k>, below<k>)
    evidence: str = "names"  #: what found the limb's joints' roles
    side_from: str = "names"  #: what gave its side


# ---------------------------------------------------------------------- geometry
def _tip(sk: Skeleton, j: int, rest: FloatArray, ends: FloatArray) -> FloatArray:
    es = [e for e, p in enumerate(sk.end_site_parents) if p == j]
    if es:
        return ends[es[0]]
    return rest[j]


def _main_chain(sk: Skeleton, start: int, reach: FloatArray) -> list[int]:
    """From ``start``, follow the child whose subtree reaches farthest."""
    chain = [start]
    while kids := sk.children(chain[-1]):
        chain.append(max(kids, key=lambda c: (reach[c], -c)))
    return chain


def _reach(sk: Skeleton, pos: FloatArray, ends: FloatArray) -> FloatArray:
    """Per joint, the path length (m) from it to the farthest point of its subtree (End Sites included)."""
    r = np.zeros(sk.num_joints)
    for e, p in enumerate(sk.end_site_parents):
        r[p] = max(r[p], float(np.linalg.norm(ends[e] - pos[p])))
    for j in range(sk.num_joints - 1, 0, -1):
        p = int(sk.parents[j])
        r[p] = max(r[p], r[j] + float(np.linalg.norm(pos[j] - pos[p])))
    return r


def _rest_pose(motion: Motion) -> tuple[FloatArray, FloatArray]:
    """Joint and End Site positions (m) with every rotation at identity: bone lengths that do not
    depend on how the body turns (joints with position channels at their median translation)."""
    sk = motion.skeleton
    off = sk.offsets if motion.translations is None else np.median(motion.translations, axis=0)
    rest = Motion(skeleton=sk.replace(offsets=off), frame_time=1.0, root_translation=np.zeros((1, 3)),
                  rotations=np.tile([0.0, 0.0, 0.0, 1.0], (1, sk.num_joints, 1)))
    ends = rest.end_site_positions()[0] if len(sk.end_site_parents) else np.zeros((0, 3))
    return rest.fk()[0][0], ends


def _heights(motion: Motion, pos: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Mean height (m) of each joint and End Site above the frame's lowest point."""
    ends = motion.end_site_positions() if len(motion.skeleton.end_site_parents) else np.zeros(
        (motion.num_frames, 0, 3))
    floor = pos[..., 2].min(axis=1)
    if ends.shape[1]:
        floor = np.minimum(floor, ends[..., 2].min(axis=1))
    return (pos[..., 2] - floor[:, None]).mean(axis=0), (ends[..., 2] - floor[:, None]).mean(axis=0)


def _forward(motion: Motion, pos: FloatArray, size: float, legs: list[Limb]) -> tuple[FloatArray, str]:
    """(T, 2) horizontal direction the body faces on each frame (not normalised: frames weigh by its
    length), and how it was found: the root's velocity when the clip travels, else the direction the
    feet point (ankle to toe), else the root's heading."""
    root = motion.root_translation[:, :2]
    vel = np.gradient(root, axis=0) if motion.num_frames > 1 else np.zeros_like(root)
    if np.linalg.norm(root[-1] - root[0]) >= TRAVEL_FRACTION * size:
        return vel, "the direction of travel"
    feet = np.zeros_like(root)  # a clip in place (sway is no direction): the feet point forward
    for leg in legs:
        a, t = leg.roles.get("ankle"), leg.roles.get("toe")
        if a is not None and t is not None:
            feet += pos[:, t, :2] - pos[:, a, :2]
    if np.linalg.norm(feet, axis=1).sum() > 1e-6:
        return feet, "the direction the feet point"
    h = motion.heading()
    return np.stack([np.cos(h), np.sin(h)], axis=1), "the root's heading"


# ---------------------------------------------------------------------- limbs
def _pairs_under(sk: Skeleton, j: int, reach: FloatArray, size: float, tip_height: FloatArray) -> list[
        tuple[int, int]]:
    """Pairs of ``j``'s children that look like a left and a right limb: similar reach, joint count and
    end height, sides (when named) opposite; best-matching pairs first."""
    kids = [c for c in sk.children(j) if reach[c] >= LIMB_MIN_FRACTION * size]
    cands = []
    for a in range(len(kids)):
        for b in range(a + 1, len(kids)):
            ca, cb = kids[a], kids[b]
            ratio = min(reach[ca], reach[cb]) / max(reach[ca], reach[cb])
            na, nb = len(sk.subtree(ca)), len(sk.subtree(cb))
            count = min(na, nb) / max(na, nb)
            sa, sb = name_side(sk.names[ca]), name_side(sk.names[cb])
            if ratio < PAIR_LENGTH_RATIO or count < PAIR_COUNT_RATIO or (sa and sb and sa == sb) or (
                    bool(sa) != bool(sb)):
                continue
            dh = abs(tip_height[ca] - tip_height[cb]) / (PAIR_HEIGHT_SCALE * size)
            cands.append((ratio * count * float(np.exp(-dh)), ca, cb))
    used: set[int] = set()
    out = []
    for _, ca, cb in sorted(cands, reverse=True):
        if ca not in used and cb not in used:
            used |= {ca, cb}
            out.append((ca, cb))
    return out


def _limb_kind(sk: Skeleton, chain: list[int]) -> str | None:
    votes = {k: sum(has_word(sk.names[j], w) for j in chain) for k, w in KIND_WORDS.items()}
    if votes["wing"]:
        return "wing"
    best = max(votes, key=lambda k: votes[k])
    return best if votes[best] else None


def _anchor_by_names(sk: Skeleton, chain: list[int], kind: str) -> dict[str, int] | None:
    top, mid, end, after = LIMB_ANCHORS[kind]
    words = LIMB_WORDS[kind]
    role_of = [_first_word(sk.names[j], words) for j in chain]
    ends = [i for i, r in enumerate(role_of) if r == end]
    mids = [i for i, r in enumerate(role_of) if r == mid]
    if ends:
        e = ends[0]
        above = [i for i in mids if i < e]
        m = above[-1] if above else e - 1
    elif mids:
        m = mids[0]
        e = m + 1
    else:
        return None
    t = m - 1
    if t < 0 or not t < m < e:
        return None
    out = {top: chain[t], mid: chain[m]}
    if e < len(chain):
        out[end] = chain[e]
    if e + 1 < len(chain):
        out[after] = chain[e + 1]
    return out


def rotation_activity(motion: Motion) -> FloatArray:
    """(J,) how much each joint turns over the clip: the RMS angle (rad) of its local rotation away
    from its mean rotation."""
    q = motion.rotations
    mean = q.mean(axis=0)
    mean /= np.maximum(np.linalg.norm(mean, axis=-1, keepdims=True), 1e-12)
    dots = np.clip(np.abs(np.sum(q * mean[None], axis=-1)), 0.0, 1.0)
    return np.sqrt(np.mean((2.0 * np.arccos(dots)) ** 2, axis=0))


def _anchor_by_geometry(sk: Skeleton, chain: list[int], kind: str, rest: FloatArray, ends: FloatArray,
                        activity: FloatArray) -> dict[str, int]:
    """The limb's two long bones: the consecutive pair whose summed length, weighted by how much the
    joints at their tops turn (a thigh and knee swing, a hip socket or clavicle hardly), is largest."""
    top, mid, end, after = LIMB_ANCHORS[kind]
    pts = [rest[j] for j in chain] + [_tip(sk, chain[-1], rest, ends)]
    bones = [float(np.linalg.norm(b - a)) for a, b in zip(pts, pts[1:])]
    if len(chain) < 3:
        return {role: j for role, j in zip((top, mid, end), chain)}
    t = max(range(len(chain) - 2), key=lambda i: (bones[i] * activity[chain[i]] + bones[i + 1] * activity[
        chain[i + 1]], -i))
    out = {top: chain[t], mid: chain[t + 1], end: chain[t + 2]}
    if t + 3 < len(chain):
        out[after] = chain[t + 3]
    return out


def _limb_roles(sk: Skeleton, limb: Limb, rest: FloatArray, ends: FloatArray, activity: FloatArray) -> None:
    chain = limb.chain
    if limb.kind == "wing":
        limb.roles = {f"segment{i + 1}": j for i, j in enumerate(chain)}
        return
    anchors = _anchor_by_names(sk, chain, limb.kind)
    if anchors is None:
        anchors = _anchor_by_geometry(sk, chain, limb.kind, rest, ends, activity)
        limb.evidence = "geometry"
    first = min(chain.index(j) for j in anchors.values())
    last = max(chain.index(j) for j in anchors.values())
    roles = dict(anchors)
    for k, i in enumerate(range(first - 1, -1, -1)):
        roles[f"above{k + 1}"] = chain[i]
    for k, i in enumerate(range(last + 1, len(chain))):
        roles[f"below{k + 1}"] = chain[i]
    limb.roles = roles


def _side_of(sk: Skeleton, a: list[int], b: list[int], pos: FloatArray, forward: FloatArray) -> tuple[str, str]:
    """Sides of two paired limbs: from their names when they say, else which one lies to the left of
    the facing direction (Z up: left = up x forward), summed over the frames."""
    sa, sb = name_side(sk.names[a[0]]), name_side(sk.names[b[0]])
    if sa and sb and sa != sb:
        return sa, sb
    left = np.stack([-forward[:, 1], forward[:, 0]], axis=1)
    d = pos[:, a, :2].mean(axis=1) - pos[:, b, :2].mean(axis=1)
    return ("left", "right") if float(np.sum(d * left)) >= 0 else ("right", "left")


def _left_consistency(a: list[int], b: list[int], pos: FloatArray, forward: FloatArray) -> float | None:
    """How consistently limb ``a`` lies left of limb ``b`` (horizontal, the left of ``forward`` (T, 2),
    frames weighted by its length: a body standing still says little about where it goes): the
    weighted sum of ``a``'s offsets to the left over that of their sizes, +1 always left, -1 always
    right; None where nothing can be measured."""
    left = np.stack([-forward[:, 1], forward[:, 0]], axis=1)
    d = pos[:, a, :2].mean(axis=1) - pos[:, b, :2].mean(axis=1)
    lat = np.sum(d * left, axis=1)
    tot = float(np.sum(np.abs(lat)))
    return float(np.sum(lat)) / tot if tot > 1e-12 else None


def _names_mirrored(motion: Motion, pos: FloatArray, size: float, legs: list[Limb]) -> dict[str, float] | None:
    """Whether the legs' named sides are the wrong way round: the named left leg lies on the body's
    right of both the direction of travel and the direction the feet point (ankle to toe), more
    consistently than :data:`MIRRORED_SIDES`; returns those two consistencies when so, None otherwise
    (names kept whenever either cannot be measured: a clip in place, feet without toes)."""
    named = {leg.side: leg for leg in legs[:2] if leg.side_from == "names"}
    if set(named) != set(SIDES):
        return None
    a, b = named["left"].chain, named["right"].chain
    hips = 0.5 * (pos[:, a[0], :2] + pos[:, b[0], :2])  # where the legs join: travels with a static root too
    if motion.num_frames < 2 or np.linalg.norm(hips[-1] - hips[0]) < TRAVEL_FRACTION * size:
        return None
    feet = np.zeros_like(hips)
    for leg in legs[:2]:
        ankle, toe = leg.roles.get("ankle"), leg.roles.get("toe")
        if ankle is None or toe is None:
            return None
        feet += pos[:, toe, :2] - pos[:, ankle, :2]
    travel, point = _left_consistency(a, b, pos, np.gradient(hips, axis=0)), _left_consistency(a, b, pos, feet)
    if travel is None or point is None or max(travel, point) >= MIRRORED_SIDES:
        return None
    return {"travel": round(travel, 2), "feet": round(point, 2)}
