"""The humanoid profile: a source skeleton reduced to the paper's physics skeleton.

Bodies: pelvis (free joint), torso (spine, 3 hinges), head (neck, 3 hinges), per side upper arm
(shoulder, 3), lower arm (elbow, 1; the hand is merged into it), thigh (hip, 3), shin (knee, 1), foot
(ankle, 1 or 2), toe (toe, 1; only when the source has a toe joint, else the foot reaches the toe tip).
Every other source joint (fingers, clavicles, extra spine and neck links, helper bones) is dropped:
its rotation is absorbed into the orientation fit of the body it belongs to.

The steps live beside this module: :mod:`~bipedsim.model.humanoid_sides` (which joint is which limb and
side), :mod:`~bipedsim.model.rigid_layout` (the rigid pelvis and torso), :mod:`~bipedsim.model.humanoid_bones`
(hinges), :mod:`~bipedsim.model.humanoid_geoms` (segment shapes), :mod:`~bipedsim.model.flat_foot` (level
soles), :mod:`~bipedsim.model.humanoid_proportions` (mass, missing bone tips) and
:mod:`~bipedsim.model.humanoid_builder` (the builder that puts them together).
"""

from __future__ import annotations

from typing import Any

from bipedsim.model.humanoid_bones import MIN_TOE_M
from bipedsim.model.humanoid_builder import _HumanoidBuilder
from bipedsim.model.humanoid_proportions import mass_from_legs, with_tips
from bipedsim.model.humanoid_sides import MIN_KNEE_BEND_M, check_sides, mirrored_sides, side_evidence, sides_note
from bipedsim.model.naming import MapFile
from bipedsim.model.plan import BodyPlanSet
from bipedsim.model.profile import HumanoidProfile
from bipedsim.motion.motion import Motion

__all__ = ["MIN_KNEE_BEND_M", "MIN_TOE_M", "check_sides", "humanoid_plan", "mass_from_legs", "mirrored_sides",
           "side_evidence", "sides_note", "toes_note", "with_tips"]


def humanoid_plan(motion: Motion, profile: HumanoidProfile, *, mapping: MapFile | None = None,
                  total_mass: float | None = None, name: str = "humanoid") -> BodyPlanSet:
    """The humanoid body plan for a motion's skeleton (motion in the project frame: m, Z up).

    Limb geometry comes from the skeleton's rest pose; the layout of the rigid pelvis (hips, spine
    base) and torso (neck, shoulders) is calibrated on the motion (:func:`calibrate_rigid`).
    """
    b = _HumanoidBuilder(motion, profile, mapping)
    b.fit_pelvis()
    b.fit_torso()
    b.add_pelvis()
    b.add_trunk()
    b.add_head()
    for side in ("left", "right"):
        if side in b.hm.arms:
            b.add_arm(side)
    for side in ("left", "right"):
        b.add_leg(side)
    b.scale_masses(total_mass if total_mass is not None else b.profile_mass())
    return b.plan(name, b.stand_on_floor())


def toes_note(extra: dict[str, Any]) -> str | None:
    """The line saying a body's toes were given a person's foot length (a body plan's ``extra``, where
    :meth:`_HumanoidBuilder.toe_length_without_tip` records it); None when its toes were measured."""
    toes = extra.get("toes_without_tip")
    if not toes:
        return None
    t = next(iter(toes.values()))
    return (f"the skeleton's toes end without a tip ({', '.join(toes)}); the soles reach {t['sole_m']:.2f} m heel "
            f"to toe tip, a {t['height_m']:.2f} m person's foot (profile geometry.foot_length_share "
            f"{t['foot_length_share']:g})")
