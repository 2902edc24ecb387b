"""Recognising humanoid skeletons from their joint names.

Handles the usual conventions -- CMU (``Hips/LeftUpLeg/LeftLeg/LeftFoot``), Daz/Poser
(``hip/lThigh/lShin/lFoot``), 3ds-Max style (``LeftHip/LeftKnee/LeftAnkle``), Mixamo
(``mixamorig:LeftUpLeg``), Bandai-style (``joint_*``, ``*_L``), MakeHuman (``upperleg01.L``), Blender
(``thigh.L``) -- and anything else through a user mapping YAML.

A name is split into a side (left/right/none) and a base word with digits and separators removed;
the base is matched against role synonyms. Structure settles the rest: the upper arm is the topmost
arm-like ancestor of the elbow, the chest is where both arms meet, the pelvis is where both legs meet.
"""

from __future__ import annotations

import dataclasses
import os
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from bipedsim import config
from bipedsim.errors import ConfigError, ModelError
from bipedsim.motion.roles import find_roles
from bipedsim.motion.skeleton import Skeleton

if TYPE_CHECKING:
    from bipedsim.motion.motion import Motion

SIDES = ("left", "right")

#: Role synonyms, tried in order: an earlier group wins over a later one on the same side.
LEG_ROLES: dict[str, list[list[str]]] = {
    "thigh": [["upleg", "upperleg", "thigh", "uleg"], ["hip"]],
    "knee": [["leg", "knee", "shin", "lowleg", "loleg", "lowerleg", "calf", "lleg"]],
    "ankle": [["foot", "ankle"]],
    "toe": [["toe", "toebase", "toes", "ball"]],
}
ARM_ROLES: dict[str, list[list[str]]] = {
    "upper_arm": [["arm", "uparm", "upperarm", "shldr", "uarm"], ["shoulder"]],
    "elbow": [["forearm", "elbow", "lowarm", "loarm", "lowerarm", "larm"]],
    "wrist": [["hand", "wrist"]],
}
#: a joint below the ankle whose base begins with this is a toe when no name is a toe word exactly
TOE_STEM = "toe"
HEAD_WORDS = ["head"]
NECK_WORDS = ["neck"]
_ROLE_WORDS = {w for groups in (*LEG_ROLES.values(), *ARM_ROLES.values()) for g in groups for w in g} | {
    "head", "neck", "hips", "hip", "spine", "pelvis", "root"}

_SIDE_RULES = [
    (re.compile(r"^(left|right)[_\-. ]?(.*)$", re.IGNORECASE), lambda m: (m.group(1).lower(), m.group(2))),
    (re.compile(r"^(.*?)[_\-. ]?(left|right)$", re.IGNORECASE), lambda m: (m.group(2).lower(), m.group(1))),
    (re.compile(r"^(.*?)[_.\-]([LR])$"), lambda m: ("left" if m.group(2) == "L" else "right", m.group(1))),
    (re.compile(r"^(.*?)[_.\-]([lr])$"), lambda m: ("left" if m.group(2) == "l" else "right", m.group(1))),
    (re.compile(r"^(.*?)(LT|RT)$"), lambda m: ("left" if m.group(2) == "LT" else "right", m.group(1))),
    (re.compile(r"^([lL])([A-Z].*)$"), lambda m: ("left", m.group(2))),
    (re.compile(r"^([rR])([A-Z].*)$"), lambda m: ("right", m.group(2))),
    (re.compile(r"^([LRlr])[_\-. ](.+)$"), lambda m: ("left" if m.group(1) in "Ll" else "right", m.group(2))),
]

#: a name prefix shared by at least this share of a skeleton's joints is a rig's, no part of any joint's
#: role (ActorCore's ``CC_Base_``, MotionBuilder's ``Character1_``, 3ds Max's ``Bip01 ``, ``sim``)
RIG_PREFIX_SHARE = 0.5


def rig_prefix(names: tuple[str, ...] | list[str]) -> str:
    """The longest name prefix shared by at least :data:`RIG_PREFIX_SHARE` of ``names`` (after any
    namespace, ``ns:``) that ends at a word boundary -- a separator (``_ - . `` space) or a change to
    upper case (``simLeftUpLeg``) -- and is no side or role word itself; ``""`` when none is."""
    bare = [_bare(n) for n in names]
    if len(bare) < 2:
        return ""
    cands: set[str] = set()
    for b in bare:
        for k in range(1, len(b)):
            if b[k - 1] in "_-. " or (b[k].isupper() and b[k - 1].islower()):
                cands.add(b[:k])
    for c in sorted(cands, key=len, reverse=True):
        word = re.sub(r"[^a-z]", "", c.lower())
        if word in ("left", "right", "l", "r", "") or word in _ROLE_WORDS:
            continue
        if sum(b.startswith(c) for b in bare) >= RIG_PREFIX_SHARE * len(bare):
            return c
    return ""


def _bare(name: str) -> str:
    """``name`` without its namespace (``mixamorig:``, ``a|b|``)."""
    return name.split(":")[-1].split("|")[-1]


def _strip(name: str, prefix: str) -> str:
    """``name`` without the rig ``prefix`` after its namespace (the namespace kept)."""
    n = _bare(name)
    head = name[:len(name) - len(n)]
    return head + (n[len(prefix):] if prefix and n.startswith(prefix) and len(n) > len(prefix) else n)


def split_name(name: str, prefix: str = "") -> tuple[str, str]:
    """(side, base): side is ``left``/``right``/``""``; base lower-case with namespace, the rig's
    ``prefix`` (:func:`rig_prefix`), ``joint`` prefix, digits and separators removed
    (``mixamorig:LeftUpLeg`` -> ``("left", "upleg")``; ``CC_Base_L_Thigh`` with ``CC_Base_`` ->
    ``("left", "thigh")``)."""
    n = _bare(_strip(name, prefix))
    n = re.sub(r"^joint[_\-. ]?", "", n, flags=re.IGNORECASE)
    side = ""
    for pat, fn in _SIDE_RULES:
        m = pat.match(n)
        if m:
            side, n = fn(m)
            break
    base = re.sub(r"[^a-z]", "", n.lower())
    return side, base


@dataclass
class HumanoidMap:
    """Which source joints play which role. Sides are ``left``/``right``; arms may be absent."""

    pelvis: str
    torso_base: str
    chest: str
    neck: str
    head: str
    legs: dict[str, dict[str, str | None]] = field(default_factory=dict)  # side -> role -> joint
    arms: dict[str, dict[str, str]] = field(default_factory=dict)


@dataclass(frozen=True)
class MapFile:
    """User mapping YAML: any role may be given; the rest is recognised from names."""

    pelvis: str | None = None
    torso_base: str | None = None
    chest: str | None = None
    neck: str | None = None
    head: str | None = None
    left: dict[str, str] = field(default_factory=dict)
    right: dict[str, str] = field(default_factory=dict)

    def validate(self) -> None:
        allowed = set(LEG_ROLES) | set(ARM_ROLES)
        for side in SIDES:
            for role in getattr(self, side):
                if role not in allowed:
                    raise ValueError(f"{side}.{role}: unknown role; allowed: {', '.join(sorted(allowed))}")


def load_map(path: str | os.PathLike[str], skeleton: Skeleton) -> MapFile:
    """Load a mapping YAML and check every joint it names exists in ``skeleton``."""
    m = config.load(MapFile, path)
    names = set(skeleton.names)
    named = [(k, v) for k in ("pelvis", "torso_base", "chest", "neck", "head") if (v := getattr(m, k))]
    named += [(f"{s}.{r}", v) for s in SIDES for r, v in getattr(m, s).items()]
    for key, joint in named:
        if joint not in names:
            close = sorted(n for n in names if n.lower()[:3] == str(joint).lower()[:3])[:5]
            hint = f"; similar: {', '.join(close)}" if close else ""
            raise ConfigError(f"names joint {joint!r}, which the skeleton does not have{hint}",
                              path=path, key=key)
    return m


def _ancestors(sk: Skeleton, j: int) -> list[int]:
    out = []
    while j >= 0:
        out.append(j)
        j = int(sk.parents[j])
    return out  # j, parent, ..., root


def _lca(sk: Skeleton, a: int, b: int) -> int:
    anc = set(_ancestors(sk, a))
    for j in _ancestors(sk, b):
        if j in anc:
            return j
    return 0


def _topmost_on_chain(sk: Skeleton, start: int, words_groups: list[list[str]], side: str,
                      stop: int | None = None) -> int | None:
    """Walk from ``start`` up to the root; among ancestors matching the first group with hits, the
    topmost of the contiguous run nearest ``start``."""
    chain = _ancestors(sk, start)[1:]
    if stop is not None and stop in chain:
        chain = chain[:chain.index(stop)]
    for words in words_groups:
        hits = [j for j in chain if split_name(sk.names[j]) == (side, _one(words, sk.names[j], side))]
        if hits:
            # contiguous run nearest start: lowerarm02 -> lowerarm01 -> ... pick the topmost of it
            first = hits[0]
            run = [first]
            for j in chain[chain.index(first) + 1:]:
                s, b = split_name(sk.names[j])
                if s == side and b in words:
                    run.append(j)
                else:
                    break
            return run[-1]
    return None


def _one(words: list[str], name: str, side: str) -> str | None:
    s, b = split_name(name)
    return b if (s == side and b in words) else None


def _find_first(sk: Skeleton, side: str, words: list[str], under: int | None = None) -> int | None:
    cands = [j for j in range(sk.num_joints) if _one(words, sk.names[j], side) is not None]
    if under is not None:
        cands = [j for j in cands if under in _ancestors(sk, j)]
    if not cands:
        return None
    depth = sk.depth()
    return min(cands, key=lambda j: (depth[j], j))


def _find_toe(sk: Skeleton, side: str, ankle: int) -> int | None:
    """The toe below ``ankle``: a joint named by a toe word, else the shallowest whose base begins with
    ``toe`` -- the word with a suffix, as in ``lToeJoint`` (games105), ``RightToe_End`` or ``Toe0``."""
    toe = _find_first(sk, side, LEG_ROLES["toe"][0], under=ankle)
    if toe is not None:
        return toe
    cands = [j for j in range(sk.num_joints) if j != ankle and ankle in _ancestors(sk, j)
             and split_name(sk.names[j])[0] in (side, "") and split_name(sk.names[j])[1].startswith(TOE_STEM)]
    depth = sk.depth()
    return min(cands, key=lambda j: (depth[j], j)) if cands else None


def _find_by_last_word(sk: Skeleton, words: list[str]) -> int | None:
    """The shallowest joint whose name's last word (split at separators) is one of ``words``: joints
    named for the bone from their parent (games105's ``torso_head``, ``lowerback_torso``)."""
    cands = [j for j in range(sk.num_joints)
             if re.split(r"[_\-. ]+", sk.names[j].split(":")[-1].lower())[-1] in words]
    if not cands:
        return None
    depth = sk.depth()
    return min(cands, key=lambda j: (depth[j], j))


#: the two thigh joints found by name stand closer than this fraction of the knees' distance in the
#: rest pose: helper bones at the pelvis centre (MakeHuman's __UpLeg_L/__UpLeg_R above UpLeg_L/UpLeg_R)
COINCIDENT_THIGHS = 0.1


def _rest_positions(sk: Skeleton) -> list:
    pos: list = []
    for j in range(sk.num_joints):
        p = int(sk.parents[j])
        pos.append(sk.offsets[j] if p < 0 else pos[p] + sk.offsets[j])
    return pos


def _separate_thighs(sk: Skeleton, legs: dict[str, dict[str, str | None]], idx: dict[str, int]) -> None:
    """Where the left and right thighs found by name coincide in the rest pose, take the next joints
    down each leg until they part (the hip joints proper), short of the knees."""
    rest = _rest_positions(sk)
    th = {s: idx[legs[s]["thigh"]] for s in SIDES}  # type: ignore[index]
    kn = {s: idx[legs[s]["knee"]] for s in SIDES}  # type: ignore[index]
    width = float(sum((rest[kn["left"]] - rest[kn["right"]]) ** 2) ** 0.5)
    while float(sum((rest[th["left"]] - rest[th["right"]]) ** 2) ** 0.5) < COINCIDENT_THIGHS * width:
        down = {s: next((c for c in _ancestors(sk, kn[s]) if int(sk.parents[c]) == th[s]), None) for s in SIDES}
        if any(d is None or d == kn[s] for s, d in down.items()):
            return
        th = down  # type: ignore[assignment]
    for s in SIDES:
        legs[s]["thigh"] = sk.names[th[s]]


def map_from_roles(motion: Motion) -> MapFile | None:
    """A mapping of the humanoid's limbs and head found from the skeleton's structure and motion
    (:func:`~bipedsim.motion.roles.find_roles`: limbs as pairs of sibling chains, the legs the pair whose
    ends stay lowest, left of the direction of travel), for a skeleton whose names say nothing; None
    when it does not find two legs."""
    try:
        r = find_roles(motion if motion.up == "z" and motion.unit == 1.0 else motion.to_project_frame())
    except (ValueError, IndexError, ModelError):
        return None
    sk = motion.skeleton
    sides: dict[str, dict[str, str]] = {"left": {}, "right": {}}
    for limb in r.limbs:
        if limb.kind not in ("leg", "arm") or limb.side not in sides:
            continue
        wanted = ("thigh", "knee", "ankle", "toe") if limb.kind == "leg" else ("upper_arm", "elbow", "wrist")
        sides[limb.side].update({role: sk.names[j] for role, j in limb.roles.items() if role in wanted})
    if not all({"thigh", "knee", "ankle"} <= set(sides[s]) for s in SIDES):
        return None
    head = r.anchors.get("head")
    chest = r.anchors.get("chest")
    neck = None  # the trunk's joint after the chest, below the head
    if head is not None and chest in r.trunk and head in r.trunk:
        after = r.trunk[r.trunk.index(chest) + 1:r.trunk.index(head)]
        neck = after[0] if after else None
    return MapFile(head=None if head is None else sk.names[head], neck=None if neck is None else sk.names[neck],
                   left=sides["left"], right=sides["right"])


def recognise_humanoid(sk: Skeleton, mapping: MapFile | None = None) -> HumanoidMap:
    """Find the humanoid roles in a skeleton; raise :class:`ModelError` saying what is missing. Names
    are matched without the rig's prefix (:func:`rig_prefix`); the map holds the skeleton's own names."""
    mp = mapping or MapFile()
    orig = sk
    idx = {n: i for i, n in enumerate(sk.names)}
    prefix = rig_prefix(sk.names)
    if prefix:
        bare = tuple(_strip(n, prefix) for n in sk.names)
        if len(set(bare)) == len(bare):
            sk = dataclasses.replace(sk, names=bare)  # for matching only
    legs: dict[str, dict[str, str | None]] = {}
    arms: dict[str, dict[str, str]] = {}
    for side in SIDES:
        given = getattr(mp, side)
        # legs: ankle first, then walk up
        ankle = idx[given["ankle"]] if "ankle" in given else _find_first(sk, side, LEG_ROLES["ankle"][0])
        knee = thigh = None
        if ankle is not None:
            knee = idx[given["knee"]] if "knee" in given else _topmost_on_chain(sk, ankle, LEG_ROLES["knee"], side)
            if knee is not None:
                thigh = (idx[given["thigh"]] if "thigh" in given
                         else _topmost_on_chain(sk, knee, LEG_ROLES["thigh"], side))
        if ankle is None or knee is None or thigh is None:
            missing = [r for r, v in (("thigh", thigh), ("knee", knee), ("ankle", ankle)) if v is None]
            raise ModelError(
                f"no {side} leg: could not find the {side} {', '.join(missing)} joint(s) by name "
                f"(looked for names like {side.capitalize()}UpLeg/{side.capitalize()}Leg/"
                f"{side.capitalize()}Foot, {side[0]}Thigh/{side[0]}Shin, thigh.{side[0].upper()}); "
                f"the humanoid profile needs two legs -- give a mapping YAML with --map, or use the "
                f"creature profile")
        toe = idx[given["toe"]] if "toe" in given else _find_toe(sk, side, ankle)
        legs[side] = {"thigh": orig.names[thigh], "knee": orig.names[knee], "ankle": orig.names[ankle],
                      "toe": None if toe is None else orig.names[toe]}
        wrist = idx[given["wrist"]] if "wrist" in given else _find_first(sk, side, ARM_ROLES["wrist"][0])
        if wrist is None:
            continue
        elbow = idx[given["elbow"]] if "elbow" in given else _topmost_on_chain(sk, wrist, ARM_ROLES["elbow"], side)
        if elbow is None:
            continue
        upper = (idx[given["upper_arm"]] if "upper_arm" in given
                 else _topmost_on_chain(sk, elbow, ARM_ROLES["upper_arm"], side))
        if upper is None:
            upper = int(sk.parents[elbow])
        arms[side] = {"upper_arm": orig.names[upper], "elbow": orig.names[elbow], "wrist": orig.names[wrist]}
    if len(arms) == 1:
        arms = {}  # one arm only: drop both, the body stays symmetric

    if "thigh" not in mp.left and "thigh" not in mp.right:
        _separate_thighs(orig, legs, idx)
    th_l, th_r = idx[legs["left"]["thigh"]], idx[legs["right"]["thigh"]]  # type: ignore[index]
    pelvis = idx[mp.pelvis] if mp.pelvis else _lca(sk, th_l, th_r)
    head = idx[mp.head] if mp.head else _find_first(sk, "", HEAD_WORDS)
    if head is None and not mp.head:
        head = _find_by_last_word(sk, HEAD_WORDS)
    if arms:
        ua_l, ua_r = idx[arms["left"]["upper_arm"]], idx[arms["right"]["upper_arm"]]
        chest = idx[mp.chest] if mp.chest else _lca(sk, ua_l, ua_r)
    elif head is not None:
        chest = idx[mp.chest] if mp.chest else int(sk.parents[head])
    else:
        raise ModelError("found legs but neither arms nor a head: cannot tell where the torso is; "
                         "give chest: in a mapping YAML (--map)")
    if chest == pelvis or pelvis in _ancestors(sk, chest)[1:] and chest in (th_l, th_r):
        raise ModelError(f"torso not found: the arms meet at {orig.names[chest]!r}, which is the pelvis; "
                         f"give chest: in a mapping YAML (--map)")
    if head is None:
        head = chest
    if mp.neck:
        neck = idx[mp.neck]
    else:
        neck = _topmost_on_chain(sk, head, [NECK_WORDS], "", stop=chest)
        if neck is None:
            neck = head
    if mp.torso_base:
        torso_base = idx[mp.torso_base]
    else:
        a = _lca(sk, pelvis, chest)
        path = _ancestors(sk, chest)
        path = path[:path.index(a)]  # chest ... child of a
        torso_base = path[-1] if path else chest
    return HumanoidMap(pelvis=orig.names[pelvis], torso_base=orig.names[torso_base], chest=orig.names[chest],
                       neck=orig.names[neck], head=orig.names[head], legs=legs, arms=arms)
