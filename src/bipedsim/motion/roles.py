"""Joint roles of any legged skeleton, and the correspondence of two skeletons through them.

A role says what a joint is for -- ``root``, the trunk (``spine``, ``chest``, ``neck``, ``head``),
``tail``, and per side the limbs: ``leg`` (``thigh``, ``knee``, ``ankle``, ``toe``), ``arm``
(``upper_arm``, ``elbow``, ``wrist``) and ``wing``. Roles come from two kinds of evidence:

- **names**, in the usual conventions (CMU/Holden ``LeftUpLeg``, Daz ``lThigh``, Mixamo
  ``mixamorig:LeftUpLeg``, MotionBuilder, 3ds Max ``LeftHip/LeftKnee``, Bandai ``UpperLeg_L``, 3ds-Max
  Biped ``Bip01_L_Thigh``, the 19-joint ``Hip/Abdomen`` layout, Blender ``thigh.L``): a name is split
  into words (namespace, separators, camel case, digits), a side word (left/l/lt, right/r/rt) and role
  words are looked up;
- **structure and geometry**, used wherever the names say nothing: limbs are pairs of sibling
  subtrees of similar length; the leg pair is the one whose ends are lowest over the clip, the other
  pairs are arms (a quadruped's forelegs) or wings; the head is the highest end of the rest; within a
  limb the thigh/knee/ankle (upper arm/elbow/wrist) are the two longest consecutive bones; left is
  the side to the left of the direction of travel (or of the feet when the clip stays in place);
- **the names' sides checked against the motion**: a walk whose named left leg lies on its right, of
  where it goes and of where its feet point, has every named side exchanged (a mirrored export).

:func:`correspondence` pairs the joints of two skeletons role by role (trunk and limb chains of
different lengths by their position along the chain). Everything here works on a
:class:`~bipedsim.motion.motion.Motion` in the project frame (metres, Z up).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.motion.motion import Motion
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]
SIDES = ("left", "right")
_SIDE_WORDS = {"left": "left", "l": "left", "lt": "left", "right": "right", "r": "right", "rt": "right"}
#: Role words per limb kind, in chain order: (role, words); a name matches a word when one of its
#: words or two adjacent words joined equals it. The first role is found first; the others lean on it.
LIMB_WORDS: dict[str, dict[str, tuple[str, ...]]] = {
    "leg": {"ankle": ("foot", "ankle"), "knee": ("loleg", "lowleg", "lowerleg", "shin", "calf", "knee", "leg"),
            "thigh": ("upleg", "upperleg", "thigh", "uleg"), "toe": ("toe", "toes", "toebase", "ball")},
    "arm": {"wrist": ("hand", "wrist"), "elbow": ("forearm", "elbow", "lowarm", "loarm", "lowerarm", "larm"),
            "upper_arm": ("uparm", "upperarm", "shldr", "arm"), "clavicle": ("collar", "clavicle")},
}
#: per limb kind: the three joints the two long bones join (top, middle, end) and the one after.
LIMB_ANCHORS = {"leg": ("thigh", "knee", "ankle", "toe"), "arm": ("upper_arm", "elbow", "wrist", "hand")}
KIND_WORDS = {"leg": ("upleg", "upperleg", "thigh", "leg", "knee", "shin", "calf", "foot", "ankle", "toe", "hip",
                      "loleg", "lowleg", "lowerleg", "buttock"),
              "arm": ("arm", "forearm", "uparm", "upperarm", "shoulder", "shldr", "elbow", "hand", "wrist",
                      "collar", "clavicle", "lowarm", "loarm", "lowerarm"),
              "wing": ("wing",)}
TRUNK_WORDS = {"head": ("head",), "neck": ("neck",), "tail": ("tail",)}
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
#: Pairs whose mean end height is within this fraction of the body size of the lowest pair's are
#: also low (a quadruped's forelegs next to its hind legs).
LOW_FRACTION = 0.12


def name_words(name: str) -> list[str]:
    """Lower-case words of a joint name: namespace dropped (``mixamorig:``), split at separators,
    digits and camel case (``LHipJoint`` -> ``l hip joint``, ``Bip01_R_Thigh`` -> ``bip r thigh``)."""
    n = re.split(r"[:|]", name)[-1]
    n = re.sub(r"([a-z])([A-Z])", r"\1 \2", n)
    n = re.sub(r"([A-Z])([A-Z][a-z])", r"\1 \2", n)
    return [w.lower() for w in re.split(r"[^A-Za-z]+", n) if w]


def name_side(name: str) -> str:
    """``left``/``right`` from a side word in the name, ``""`` when it has none."""
    for w in name_words(name):
        if w in _SIDE_WORDS:
            return _SIDE_WORDS[w]
    return ""


def _terms(name: str) -> list[str]:
    w = [x for x in name_words(name) if x not in _SIDE_WORDS and x != "joint"]
    return [a + b for a, b in zip(w, w[1:])] + w


def has_word(name: str, words: tuple[str, ...]) -> bool:
    """Whether a word of ``name`` (or two adjacent words joined) is one of ``words``."""
    return any(t in words for t in _terms(name))


def _first_word(name: str, groups: dict[str, tuple[str, ...]]) -> str | None:
    """The role whose words the name matches, compound words first (``forearm`` before ``arm``)."""
    terms = _terms(name)
    for t in terms:
        for role, words in groups.items():
            if t in words:
                return role
    return None


@dataclass
class Limb:
    kind: str  #: "leg", "arm", "wing"
    side: str  #: "left"/"right"
    chain: list[int]  #: main chain from the limb's first joint to its tip
    roles: dict[str, int] = field(default_factory=dict)  #: role -> joint (anchors, above<k>, below<k>)
    evidence: str = "names"  #: what found the limb's joints' roles
    side_from: str = "names"  #: what gave its side


@dataclass
class Roles:
    """The roles found in one skeleton."""

    skeleton: Skeleton
    root: int
    trunk: list[int]  #: root ... head
    anchors: dict[str, int]  #: pelvis, chest, head (those found)
    limbs: list[Limb]
    tail: list[int]
    forward: str  #: how the direction the body faces was found
    evidence: dict[str, str] = field(default_factory=dict)  #: what decided each part

    def joint_roles(self) -> dict[str, str]:
        """joint name -> role, e.g. ``{"LeftUpLeg": "left leg thigh", "Spine1": "chest"}``."""
        sk = self.skeleton
        out: dict[str, str] = {sk.names[self.root]: "root"}
        for j in self.trunk[1:]:
            out.setdefault(sk.names[j], "trunk")
        for name, j in self.anchors.items():
            out[sk.names[j]] = name if j != self.root else out[sk.names[j]]
        for k, j in enumerate(self.tail):
            out[sk.names[j]] = f"tail {k + 1}"
        for limb in self.limbs:
            for role, j in limb.roles.items():
                out[sk.names[j]] = f"{limb.side} {limb.kind} {role}"
        return out


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


# ---------------------------------------------------------------------- the whole skeleton
def find_roles(motion: Motion) -> Roles:
    """The roles of ``motion``'s skeleton (project frame), names first, structure and geometry where
    the names say nothing."""
    sk = motion.skeleton
    rest, ends = _rest_pose(motion)
    pos = motion.fk()[0]
    height, end_height_of = _heights(motion, pos)
    size = float(np.ptp(np.concatenate([rest, ends]), axis=0).max()) or 1.0
    reach = _reach(sk, rest, ends)

    def tip_height(j: int) -> float:
        es = [e for e, p in enumerate(sk.end_site_parents) if p == j]
        return float(end_height_of[es[0]]) if es else float(height[j])

    # per joint, the mean height of the lowest end of its main chain
    chain_tip = np.array([tip_height(_main_chain(sk, j, reach)[-1]) for j in range(sk.num_joints)])

    evidence: dict[str, str] = {}
    # limb pairs: sibling subtrees of similar reach, searched from the root down, not inside limbs
    depth = sk.depth()
    named_head = [j for j in range(sk.num_joints) if has_word(sk.names[j], TRUNK_WORDS["head"])]
    head_by_name = min(named_head, key=lambda j: (depth[j], j)) if named_head else None
    pairs: list[tuple[int, int]] = []
    inside: set[int] = set() if head_by_name is None else set(sk.subtree(head_by_name))  # eyes, jaw
    for j in range(sk.num_joints):
        if j in inside:
            continue
        for ca, cb in _pairs_under(sk, j, reach, size, chain_tip):
            pairs.append((ca, cb))
            inside |= set(sk.subtree(ca)) | set(sk.subtree(cb))
    chains = [(_main_chain(sk, a, reach), _main_chain(sk, b, reach)) for a, b in pairs]
    kinds: list[str | None] = [_limb_kind(sk, ca + cb) for ca, cb in chains]
    tails = [i for i, (ca, cb) in enumerate(chains) if has_word(sk.names[ca[0]], TRUNK_WORDS["tail"])]
    tail_joints = set().union(*(set(sk.subtree(c[0])) for i in tails for c in chains[i])) if tails else set()

    def end_height(i: int) -> float:
        ca, cb = chains[i]
        return float(np.mean([tip_height(c[-1]) for c in (ca, cb)]))

    limb_ids = [i for i in range(len(pairs)) if i not in tails]
    if limb_ids and "leg" not in kinds:
        low = min(limb_ids, key=lambda i: (end_height(i), depth[pairs[i][0]]))
        lows = [i for i in limb_ids if end_height(i) <= end_height(low) + LOW_FRACTION * size]
        hind = min(lows, key=lambda i: (depth[pairs[i][0]], end_height(i)))
        for i in limb_ids:
            if kinds[i] is None:
                kinds[i] = "leg" if i == hind else "arm"
        evidence["legs"] = "geometry: the limb pair whose ends stay lowest"
    else:
        evidence["legs"] = "names" if "leg" in kinds else "none found"
    for i in limb_ids:
        kinds[i] = kinds[i] or "arm"
    limb_ids.sort(key=lambda i: -reach[pairs[i][0]])  # the main pair of each kind first
    limbs = [Limb(kind=str(kinds[i]), side="", chain=c) for i in limb_ids for c in chains[i]]
    activity = rotation_activity(motion)
    for limb in limbs:
        _limb_roles(sk, limb, rest, ends, activity)
    legs = [limb for limb in limbs if limb.kind == "leg"]
    forward, how = _forward(motion, pos, size, legs)
    evidence["forward"] = how
    for i in range(len(limb_ids)):
        a, b = limbs[2 * i], limbs[2 * i + 1]
        a.side, b.side = _side_of(sk, a.chain, b.chain, pos, forward)
        sa, sb = name_side(sk.names[a.chain[0]]), name_side(sk.names[b.chain[0]])
        a.side_from = b.side_from = "names" if sa and sb and sa != sb else "geometry: left of " + how
        evidence[f"sides of {sk.names[a.chain[0]]}/{sk.names[b.chain[0]]}"] = a.side_from
    mirrored = _names_mirrored(motion, pos, size, legs)
    if mirrored is not None:
        # a mirrored export names every limb the wrong way round: the named sides are exchanged
        for limb in limbs:
            if limb.side_from == "names":
                limb.side = "left" if limb.side == "right" else "right"
                limb.side_from = "names, exchanged"
        for key in [k for k, v in evidence.items() if k.startswith("sides of ") and v == "names"]:
            evidence[key] = "names, exchanged"
        evidence["sides"] = ("geometry: the named left leg lies on the right of the direction of travel and of "
                             f"the direction the feet point (consistency {mirrored['travel']:+.2f}, "
                             f"{mirrored['feet']:+.2f}); the named sides are exchanged")
    limb_joints = set().union(*(set(sk.subtree(limb.chain[0])) for limb in limbs)) if limbs else set()
    # the head: named, else the highest end outside the limbs and tails
    free = [j for j in range(sk.num_joints) if j not in limb_joints and j not in tail_joints]
    if head_by_name is not None and head_by_name in free:
        head = head_by_name
        evidence["head"] = "names"
    else:
        leaves = [j for j in free if not [c for c in sk.children(j) if c in free]]
        head = max(leaves, key=lambda j: (tip_height(j), -j))
        par = int(sk.parents[head])
        if par > 0 and len(sk.children(par)) > 1 and all(not sk.children(c) for c in sk.children(par)):
            head = par  # the highest end is one of a few small ends (eyes): the head carries them
        evidence["head"] = "geometry: the highest end outside the limbs"
    trunk = _path(sk, 0, head)
    anchors = _trunk_anchors(sk, limbs, trunk, head)
    # a tail: the shallowest joint named so outside the limbs and the trunk
    named_tail = [j for j in range(sk.num_joints) if j not in limb_joints and j not in trunk
                  and has_word(sk.names[j], TRUNK_WORDS["tail"])]
    tail = _main_chain(sk, min(named_tail, key=lambda j: (depth[j], j)), reach) if named_tail else []
    return Roles(skeleton=sk, root=0, trunk=trunk, anchors=anchors, limbs=limbs, tail=tail, forward=how,
                 evidence=evidence)


def _trunk_anchors(sk: Skeleton, limbs: list[Limb], trunk: list[int], head: int) -> dict[str, int]:
    """head; pelvis: where the legs meet; chest: where the arms (else the wings) meet, on the trunk."""
    anchors: dict[str, int] = {"head": head} if head != 0 else {}
    legs = [limb.chain[0] for limb in limbs if limb.kind == "leg"]
    if len(legs) >= 2:
        anchors["pelvis"] = _lca(sk, legs[0], legs[1])
    arms = [limb.chain[0] for limb in limbs if limb.kind == "arm"]
    wings = [limb.chain[0] for limb in limbs if limb.kind == "wing"]
    chest = _lca(sk, arms[0], arms[1]) if len(arms) >= 2 else (int(sk.parents[wings[0]]) if wings else None)
    if chest is not None and chest in trunk:
        anchors["chest"] = chest
    return anchors


def _path(sk: Skeleton, a: int, b: int) -> list[int]:
    """Joints from ancestor ``a`` down to ``b`` (both included)."""
    out = [b]
    while out[-1] != a and out[-1] >= 0:
        out.append(int(sk.parents[out[-1]]))
    return out[::-1]


def _lca(sk: Skeleton, a: int, b: int) -> int:
    anc = set(_path(sk, 0, a))
    for j in _path(sk, 0, b)[::-1]:
        if j in anc:
            return j
    return 0


# ---------------------------------------------------------------------- correspondence
def _match_by_fraction(a: list[int], b: list[int]) -> list[tuple[int, int]]:
    """Pair the joints of two chains by their position along the chain (each joint at most once,
    order kept)."""
    if not a or not b:
        return []
    short, long_, swap = (a, b, False) if len(a) <= len(b) else (b, a, True)
    out = []
    last = -1
    for i, j in enumerate(short):
        f = (i + 1) / (len(short) + 1)
        k = int(round(f * (len(long_) + 1))) - 1
        k = min(max(k, last + 1), len(long_) - 1 - (len(short) - 1 - i))
        last = k
        out.append((long_[k], j) if swap else (j, long_[k]))
    return out


def _segments(r: Roles, names: list[str]) -> list[list[int]]:
    cuts = [r.anchors[n] for n in names]
    out, prev = [], r.root
    for c in cuts:
        seg = _path(r.skeleton, prev, c)[1:]
        out.append(seg)
        prev = c
    return out


@dataclass
class Correspondence:
    """Joints of skeleton A paired with joints of skeleton B, and why."""

    pairs: dict[str, str]  #: joint of A -> joint of B
    reasons: dict[str, str]  #: joint of A -> the role that paired it
    roles_a: Roles
    roles_b: Roles


def correspondence(a: Motion, b: Motion) -> Correspondence:
    """Pair the joints of two motions' skeletons (project frame) by role: root with root, the trunk
    between its anchors (pelvis, chest, head) by position along it, each limb with the limb of the
    same kind and side (its thigh/knee/ankle/toe or upper arm/elbow/wrist/hand named alike, the joints
    above and below them in order), tails from their base. Joints with the same name that no role
    paired are paired too."""
    ra, rb = find_roles(a), find_roles(b)
    ska, skb = a.skeleton, b.skeleton
    pairs: dict[int, int] = {0: 0}
    reasons: dict[int, str] = {0: "root"}

    def add(ja: int, jb: int, why: str) -> None:
        if ja not in pairs and jb not in pairs.values():
            pairs[ja] = jb
            reasons[ja] = why

    on_trunk = [n for n in ("pelvis", "chest", "head") if n in ra.anchors and n in rb.anchors
                and ra.anchors[n] in ra.trunk and rb.anchors[n] in rb.trunk
                and ra.anchors[n] != ra.root and rb.anchors[n] != rb.root]
    order_a = sorted(on_trunk, key=lambda n: ra.trunk.index(ra.anchors[n]))
    order_b = sorted(on_trunk, key=lambda n: rb.trunk.index(rb.anchors[n]))
    if order_a != order_b:  # the anchors lie in another order on the two trunks: keep the head only
        order_a = [n for n in order_a if n == "head"]
    for n in order_a:
        add(ra.anchors[n], rb.anchors[n], n)
    for name, sa, sb in zip(order_a, _segments(ra, order_a), _segments(rb, order_a)):
        for ja, jb in _match_by_fraction(sa[:-1], sb[:-1]):
            add(ja, jb, f"trunk below {name}")
    if "pelvis" in ra.anchors and "pelvis" in rb.anchors and "pelvis" not in order_a:
        add(ra.anchors["pelvis"], rb.anchors["pelvis"], "pelvis")
    for la in ra.limbs:
        lb = next((x for x in rb.limbs if x.kind == la.kind and x.side == la.side), None)
        if lb is None:
            continue
        for role, ja in la.roles.items():
            if role in lb.roles:
                add(ja, lb.roles[role], f"{la.side} {la.kind} {role}")
    for ja, jb in zip(ra.tail, rb.tail):
        add(ja, jb, "tail")
    for j, name in enumerate(ska.names):
        if j not in pairs and name in skb.names and skb.index(name) not in pairs.values():
            add(j, skb.index(name), "same name")
    return Correspondence(pairs={ska.names[x]: skb.names[y] for x, y in sorted(pairs.items())},
                          reasons={ska.names[x]: reasons[x] for x in sorted(pairs)}, roles_a=ra, roles_b=rb)
