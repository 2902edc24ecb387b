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

:func:`~bipedsim.motion.correspondence.correspondence` pairs the joints of two skeletons role by role
(trunk and limb chains of different lengths by their position along the chain). Everything here works on
a :class:`~bipedsim.motion.motion.Motion` in the project frame (metres, Z up). Names are read in
:mod:`~bipedsim.motion.role_names`, limbs found in :mod:`~bipedsim.motion.limbs`; this module puts the
whole skeleton together (:func:`find_roles`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from bipedsim.motion.limbs import (
    Limb,
    _forward,
    _heights,
    _limb_kind,
    _limb_roles,
    _main_chain,
    _names_mirrored,
    _pairs_under,
    _reach,
    _rest_pose,
    _side_of,
    rotation_activity,
)
from bipedsim.motion.motion import Motion
from bipedsim.motion.role_names import (
    TRUNK_WORDS,
    has_word,
    name_side,
)
from bipedsim.motion.skeleton import Skeleton

FloatArray = npt.NDArray[np.float64]


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


#: Pairs whose mean end height is within this fraction of the body size of the lowest pair's are
#: also low (a quadruped's forelegs next to its hind legs).
LOW_FRACTION = 0.12


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
