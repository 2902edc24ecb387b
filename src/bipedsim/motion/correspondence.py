"""The correspondence of two skeletons through their joint roles (:func:`correspondence`): root with
root, the trunk between its anchors by position along it, each limb with the limb of the same kind and
side, tails from their base, and same-named joints no role paired."""

from __future__ import annotations

from dataclasses import dataclass

from bipedsim.motion.motion import Motion
from bipedsim.motion.roles import Roles, _path, find_roles


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
