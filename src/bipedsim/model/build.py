"""One entry point for building bodies: profile dispatch, summary, file output."""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from bipedsim.errors import ConfigError, InputError, ModelError
from bipedsim.files import atomic_write_text, read_input_text
from bipedsim.model.creature_builder import creature_plan
from bipedsim.model.humanoid import humanoid_plan
from bipedsim.model.plan import BodyPlanSet, ModelBuilder, model_hash, plan_from_model
from bipedsim.model.profile import MASS_RANGE_KG, CreatureProfile, HumanoidProfile, load_profile
from bipedsim.motion.motion import Motion


@dataclass
class BuiltModel:
    """A built body: its MJCF text, the compiled model and the plan it came from."""

    xml: str
    model: mujoco.MjModel
    plan: BodyPlanSet

    @property
    def hash(self) -> str:
        return model_hash(self.xml)

    def summary(self) -> dict[str, Any]:
        """Bodies, DOFs, actuators, total mass (kg) and standing height (m)."""
        m = self.model
        data = mujoco.MjData(m)
        mujoco.mj_kinematics(m, data)
        top = max(data.geom_xpos[g][2] + float(np.max(m.geom_size[g])) for g in range(m.ngeom)
                  if m.geom_bodyid[g] > 0)
        return {"name": self.plan.name, "profile": self.plan.profile, "bodies": int(m.nbody - 1),
                "dofs": int(m.nv), "actuated_dofs": int(m.nu), "joints": int(m.njnt),
                "total_mass_kg": float(np.sum(m.body_mass)), "height_m": float(top),
                "mass_from_legs": self.plan.extra.get("mass_from_legs"),
                "toes_without_tip": self.plan.extra.get("toes_without_tip"),
                "sides_from_geometry": self.plan.extra.get("sides_from_geometry"),
                "timestep_s": float(m.opt.timestep), "hash": self.hash}

    def write(self, path: str | os.PathLike[str]) -> None:
        atomic_write_text(path, self.xml)


def total_mass_problem(mass: float) -> str | None:
    """What is wrong with a total body mass (kg), or None: a finite number within
    :data:`~bipedsim.model.profile.MASS_RANGE_KG`."""
    lo, hi = MASS_RANGE_KG
    if isinstance(mass, bool) or not isinstance(mass, int | float) or not (math.isfinite(mass) and mass > 0):
        return f"total mass must be a finite number > 0 kg, got {mass}"
    if not lo <= mass <= hi:
        return f"total mass must be {lo:g} to {hi:g} kg, got {mass:g} kg"
    return None


def check_total_mass(mass: float | None, flag: str = "--mass") -> None:
    """Refuse a total mass (kg) that is not a finite number within
    :data:`~bipedsim.model.profile.MASS_RANGE_KG`, naming the command's ``flag``."""
    why = None if mass is None else total_mass_problem(mass)
    if why:
        raise ConfigError(why, key=flag)


def build_model(motion: Motion, profile: str | os.PathLike[str] | HumanoidProfile | CreatureProfile = "humanoid",
                *, total_mass: float | None = None, mapping: Any = None, name: str | None = None,
                source: str | os.PathLike[str] | None = None) -> BuiltModel:
    """Build a body for a motion's skeleton. ``motion`` in the project frame (metres, Z up).

    ``profile``: ``"humanoid"``, ``"creature"``, a profile YAML path, or a loaded profile.
    ``total_mass`` (kg) scales every segment. ``mapping``: a :class:`~bipedsim.model.naming.MapFile`
    (humanoid only). ``source``: the file the motion came from, named in any error (a sweep or a tune
    reads several).
    """
    try:
        return _build_model(motion, profile, total_mass=total_mass, mapping=mapping, name=name)
    except ModelError as exc:
        if source is None or str(source) in str(exc):
            raise
        raise ModelError(f"{source}: {exc}") from None


def _build_model(motion: Motion, profile: str | os.PathLike[str] | HumanoidProfile | CreatureProfile,
                 *, total_mass: float | None, mapping: Any, name: str | None) -> BuiltModel:
    why = None if total_mass is None else total_mass_problem(total_mass)
    if why:
        raise ModelError(why)
    prof = profile if isinstance(profile, HumanoidProfile | CreatureProfile) else load_profile(profile)
    if motion.up != "z" or motion.unit != 1.0:
        motion = motion.to_project_frame()
    if isinstance(prof, HumanoidProfile):
        plan = humanoid_plan(motion, prof, mapping=mapping, total_mass=total_mass, name=name or "humanoid")
    else:
        if mapping is not None:
            raise ModelError("a joint mapping applies to the humanoid profile only")
        plan = creature_plan(motion, prof, total_mass=total_mass, name=name or "creature")
    _check_depth(plan)
    builder = ModelBuilder(plan)
    try:
        xml = builder.xml()  # MuJoCo compiles the spec to write it
    except ValueError as exc:  # e.g. a body whose segments' masses round to nothing
        raise ModelError(f"MuJoCo cannot build this body: {' '.join(str(exc).split())}") from None
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:  # pragma: no cover - a builder bug, not user input
        raise ModelError(f"the generated MJCF does not compile: {exc}") from None
    built = BuiltModel(xml=xml, model=model, plan=plan)
    if isinstance(prof, HumanoidProfile):
        _check_standing_height(built)
    return built


#: Standing heights (m, top of the head) a built humanoid may have: wide of any adult or child
#: capture. Outside them the motion was misread -- a wrong unit or up axis, a translation channel read
#: the wrong way -- and the body would be simulated at the wrong size: refused, never built.
HUMANOID_BUILT_HEIGHT_M = (0.6, 3.0)


def _check_standing_height(built: BuiltModel) -> None:
    h = built.summary()["height_m"]
    lo, hi = HUMANOID_BUILT_HEIGHT_M
    if not lo <= h <= hi:
        raise ModelError(
            f"the humanoid built from this motion stands {h:.2f} m tall, outside {lo:g}-{hi:g} m: the file was "
            "probably misread (a wrong unit or up axis, or position channels read the wrong way); check the unit, "
            "height and up axis `bipedsim info FILE` finds and give --scale and --up, or use --profile creature "
            "for a body that is not human")


#: the deepest chain of nested bodies MuJoCo's XML reader accepts: tinyxml2 refuses elements nested
#: deeper than 500 levels, and each body is one level (with the worldbody and the mujoco element above)
MAX_BODY_DEPTH = 490


def _check_depth(plan: BodyPlanSet) -> None:
    depth: dict[str, int] = {}
    for b in plan.bodies:  # parents come first
        depth[b.name] = 1 if b.parent is None else depth.get(b.parent, 0) + 1
    deepest = max(depth.values(), default=0)
    if deepest > MAX_BODY_DEPTH:
        leaf = max(depth, key=depth.__getitem__)
        raise ModelError(f"the body chain ending at {leaf!r} nests {deepest} bodies deep; MuJoCo reads at most "
                         f"{MAX_BODY_DEPTH} nested bodies: merge short bones (a creature profile YAML with a larger "
                         "merge_fraction, convert --profile-file)")


#: What makes an MJCF file read other files (meshes, textures, height fields, included XML).
EXTERNAL_FILE = re.compile(r"<\s*include\b|\bfile\s*=", re.IGNORECASE)


def load_model(path: str | os.PathLike[str]) -> BuiltModel:
    """Load an MJCF file written by bipedsim (its body plan travels inside it)."""
    p = Path(path)
    try:
        xml = read_input_text(p, "xml")
    except InputError as exc:
        raise ModelError(str(exc)) from None
    if EXTERNAL_FILE.search(xml):
        # bipedsim writes self-contained models; a file= or <include> would make MuJoCo open other files
        raise ModelError(f"{p}: names other files (file= or <include>): not a model bipedsim wrote")
    try:
        model = mujoco.MjModel.from_xml_string(xml)
    except ValueError as exc:
        raise ModelError(f"{p}: not a valid MJCF model: {exc}") from None
    return BuiltModel(xml=xml, model=model, plan=plan_from_model(model))
