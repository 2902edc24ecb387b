"""Simulated bodies from skeletons (MJCF via MuJoCo's MjSpec) and reference clips from motions.

``build_model(motion, profile="humanoid"|"creature")`` -> :class:`BuiltModel` (MJCF text, compiled
model, body plan); ``retarget(motion, model)`` -> :class:`ReferenceClip`.
"""

from __future__ import annotations

from bipedsim.model.build import BuiltModel, build_model, load_model
from bipedsim.model.clip import ReferenceClip
from bipedsim.model.convert import convert_bvh, format_convert_summary
from bipedsim.model.describe import describe_bvh, format_description
from bipedsim.model.plan import BodyPlanSet, ModelBuilder, model_hash, plan_from_model
from bipedsim.model.profile import CreatureProfile, HumanoidProfile, load_profile
from bipedsim.model.retarget import retarget

__all__ = [
    "BodyPlanSet",
    "BuiltModel",
    "CreatureProfile",
    "HumanoidProfile",
    "ModelBuilder",
    "ReferenceClip",
    "build_model",
    "convert_bvh",
    "describe_bvh",
    "format_description",
    "format_convert_summary",
    "load_model",
    "load_profile",
    "model_hash",
    "plan_from_model",
    "retarget",
]
