"""Which joints of a humanoid skeleton are which limb and side: the roles from the names (or, where
they say nothing, from the geometry), the named sides checked against where the legs face over the motion
(exchanged when mirrored), and the way the rest pose faces."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.errors import ModelError
from bipedsim.model.naming import HumanoidMap, MapFile, map_from_roles, recognise_humanoid
from bipedsim.model.source import SourcePoints
from bipedsim.motion.motion import Motion

FloatArray = npt.NDArray[np.float64]


#: The named sides are taken as mirrored when the knees (and the feet, where measured) face the other
#: way from the hips' named sides by more than this (a cosine; real skeletons measure +0.39 to +1.00 for
#: the knees and +0.61 to +1.00 for the feet, a skeleton with its side names swapped -0.92 to -0.99).
MIRRORED_SIDES_COS = -0.5
#: The knees' bend is evidence when they leave the hip-ankle line by at least this much on average (m):
#: a motion with straight legs (a T-pose, a stand) says nothing about where its knees point.
MIN_KNEE_BEND_M = 0.03


def side_evidence(moving: SourcePoints, hm: HumanoidMap) -> dict[str, float]:
    """How well the legs agree with the hips' named sides, over the motion ``moving`` (project frame, Z
    up): with forward the named left hip minus the right, crossed with up, ``knee`` is the mean cosine
    between forward and where the knees leave the hip-ankle line (weighted by how far), ``foot`` the
    same for the feet (ankle to toe, or to the ankle's end site), both horizontal; +1: the names' forward,
    -1: the opposite. A value is left out when the motion cannot tell (straight knees, no foot point);
    ``knee_bend_m`` is the knees' mean distance from the hip-ankle line."""
    legs = hm.legs
    left = moving[legs["left"]["thigh"]] - moving[legs["right"]["thigh"]]  # type: ignore[index]
    fwd = np.cross(left, [0.0, 0.0, 1.0])
    fwd[..., 2] = 0.0
    fwd /= np.linalg.norm(fwd, axis=-1, keepdims=True) + 1e-12
    knee = [0.0, 0.0]
    foot = [0.0, 0.0]
    for leg in legs.values():
        h, k, a = moving[leg["thigh"]], moving[leg["knee"]], moving[leg["ankle"]]  # type: ignore[index]
        u = (a - h) / (np.linalg.norm(a - h, axis=-1, keepdims=True) + 1e-12)
        e = (k - h) - np.sum((k - h) * u, axis=-1, keepdims=True) * u
        e[..., 2] = 0.0
        knee[0] += float(np.sum(e * fwd))
        knee[1] += float(np.sum(np.linalg.norm(e, axis=-1)))
        ends = [n for n in moving.names if n.startswith(f"{leg['ankle']}/end")]
        tip = leg["toe"] or (ends[0] if ends else None)
        if tip is not None:
            d = moving[tip] - a
            d[..., 2] = 0.0
            foot[0] += float(np.sum(d * fwd))
            foot[1] += float(np.sum(np.linalg.norm(d, axis=-1)))
    frames = max(1, int(np.prod(fwd.shape[:-1])))
    out = {"knee_bend_m": knee[1] / (2 * frames)}
    if out["knee_bend_m"] >= MIN_KNEE_BEND_M:
        out["knee"] = knee[0] / knee[1]
    if foot[1] > 1e-9:
        out["foot"] = foot[0] / foot[1]
    return out


def mirrored_sides(evidence: dict[str, float]) -> bool:
    """Whether the legs face away from the hips' named sides (:func:`side_evidence`): the knees bend
    backward of the named forward (below :data:`MIRRORED_SIDES_COS`) and the feet, where measured, point
    backward too. Without bent knees nothing is exchanged: a foot's end site alone can point back (the BVH
    specification's sample), and a body left as named is no worse than the file says."""
    if evidence.get("knee", 1.0) >= MIRRORED_SIDES_COS:
        return False
    return evidence.get("foot", -1.0) < MIRRORED_SIDES_COS


def check_sides(moving: SourcePoints, hm: HumanoidMap) -> tuple[HumanoidMap, dict[str, Any] | None]:
    """The roles ``hm`` found from names, with left and right exchanged when the legs face away from the
    named sides over the motion ``moving`` (:func:`mirrored_sides`), and the evidence for
    :func:`sides_note` (None when the names' sides were kept)."""
    ev = side_evidence(moving, hm)
    if not mirrored_sides(ev):
        return hm, None
    note = {"named_left": hm.legs["left"]["thigh"], "named_right": hm.legs["right"]["thigh"],
            **{k: round(v, 2) for k, v in ev.items()}}
    return _swap_sides(hm), note


def _swap_sides(hm: HumanoidMap) -> HumanoidMap:
    """The same roles with left and right exchanged (legs, and arms where there are both)."""
    legs = {"left": hm.legs["right"], "right": hm.legs["left"]}
    arms = {"left": hm.arms["right"], "right": hm.arms["left"]} if len(hm.arms) == 2 else hm.arms
    return HumanoidMap(pelvis=hm.pelvis, torso_base=hm.torso_base, chest=hm.chest, neck=hm.neck, head=hm.head,
                       legs=legs, arms=arms)


def _facing_yaw(pts: SourcePoints, hm: HumanoidMap) -> float:
    """Yaw (rad) about +z that turns the rest pose to face +x (from the hips: forward = left x up)."""
    left = pts[hm.legs["left"]["thigh"]] - pts[hm.legs["right"]["thigh"]]  # type: ignore[index]
    fwd = np.cross(left, [0.0, 0.0, 1.0])
    if np.hypot(fwd[0], fwd[1]) < 1e-9:
        raise ModelError("cannot tell which way the rest pose faces: the hip joints coincide")
    return float(-np.arctan2(fwd[1], fwd[0]))


def sides_note(extra: dict[str, Any]) -> str | None:
    """The line saying a body's left and right were taken from where its legs face, not from its joint
    names (a body plan's ``extra``, or a build summary); None when the names' sides were kept."""
    s = extra.get("sides_from_geometry")
    if not s:
        return None
    parts = [(w, s[k]) for k, w in (("knee", "knees bend"), ("foot", "feet point")) if k in s]
    how = " and ".join(w for w, _ in parts)
    cos = " and ".join(f"{c:+.2f}" for _, c in parts)
    return (f"the skeleton's side names are mirrored: with its named left hip on its left, its {how} backward "
            f"(cosine {cos} with that forward); {s['named_left']!r} is built as the right leg and "
            f"{s['named_right']!r} as the left (give a mapping YAML with --map to name the sides yourself)")


def humanoid_roles(motion: Motion, mapping: MapFile | None = None) -> tuple[HumanoidMap, bool]:
    """The humanoid roles of ``motion``'s skeleton: from its names (and ``mapping``), else -- the names
    say nothing (anonymous or foreign joint names) and no mapping is given -- the limbs found from its
    geometry (:func:`~bipedsim.model.naming.map_from_roles`). Returns them and whether the names gave
    them; a :class:`ModelError` saying what is missing when neither does."""
    try:
        return recognise_humanoid(motion.skeleton, mapping), True
    except ModelError:
        derived = map_from_roles(motion) if mapping is None else None
        if derived is None:
            raise
        return recognise_humanoid(motion.skeleton, derived), False
