"""Simulated bodies from skeletons (MJCF via MuJoCo's MjSpec).

``build_model(motion, profile="humanoid"|"creature")`` -> :class:`BuiltModel` (MJCF text, compiled
model, body plan). A motion made into a reference clip for the body is :mod:`bipedsim.reference`.
"""

from __future__ import annotations

from bipedsim.model.build import BuiltModel, build_model, load_model
from bipedsim.model.plan import BodyPlanSet, ModelBuilder, model_hash, plan_from_model
from bipedsim.model.profile import CreatureProfile, HumanoidProfile, load_profile

__all__ = [
    "BodyPlanSet",
    "BuiltModel",
    "CreatureProfile",
    "HumanoidProfile",
    "ModelBuilder",
    "build_model",
    "load_model",
    "load_profile",
    "model_hash",
    "plan_from_model",
]
