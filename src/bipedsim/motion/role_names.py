"""Joint roles from names: a joint name split into words (namespace, separators, camel case, digits), its
side word (left/l/lt, right/r/rt) and the role words of each limb kind and of the trunk, in the usual
conventions (CMU/Holden, Daz, Mixamo, MotionBuilder, 3ds Max and its Biped, Bandai, Blender)."""

from __future__ import annotations

import re

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
