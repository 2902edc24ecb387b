"""Body profiles: the typed form of ``profiles/humanoid.yaml`` and ``profiles/creature.yaml``."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from bipedsim import config

PROFILE_DIR = Path(__file__).resolve().parent.parent / "profiles"

SEGMENTS = ("pelvis", "torso", "head", "upper_arm", "lower_arm", "thigh", "shin", "foot", "toe")
JOINT_GROUPS = ("spine", "neck", "hip", "knee", "ankle", "toe", "shoulder", "elbow")
AXIS_NAMES = ("x", "y", "z", "-x", "-y", "-z", "flex")
#: Total body masses (kg) a body may be given (``--mass``, a profile's ``total_mass``): from a small
#: animal to past the heaviest land animal. Each segment's share is written to the model rounded to a
#: milligram (MJCF ``mass``), so far below the range a small segment rounds to nothing and MuJoCo
#: refuses the body (``--mass 1e-6``); far above it, nothing built here was measured.
MASS_RANGE_KG = (0.1, 100_000.0)


@dataclass(frozen=True)
class SimOptions:
    timestep: float = field(default=0.002, metadata={"gt": 0.0, "max": 0.05})
    integrator: str = field(default="implicitfast",
                            metadata={"choices": ("Euler", "implicit", "implicitfast", "RK4")})
    gravity: float = -9.8
    friction: tuple[float, float, float] = (1.5, 0.005, 0.0001)
    #: contact dimensionality: 3 = sliding friction only; 4 adds torsional friction (friction[1], m)
    condim: int = field(default=3, metadata={"choices": (1, 3, 4, 6)})
    solref: tuple[float, float] = (0.01, 1.0)
    solimp: tuple[float, float, float, float, float] = (0.9, 0.95, 0.001, 0.5, 2.0)
    joint_damping: float = field(default=0.5, metadata={"min": 0.0})
    armature: float = field(default=0.01, metadata={"min": 0.0})
    #: the soles' own contact with the ground (foot and toe boxes; MuJoCo geom priority 1, so these are the
    #: contact's parameters whatever the ground's); null: ``solref`` / ``solimp`` as every other geom
    sole_solref: tuple[float, float] | None = None
    sole_solimp: tuple[float, float, float, float, float] | None = None

    def validate(self) -> None:
        if any(f < 0 for f in self.friction):
            raise ValueError("friction: coefficients must be >= 0")
        for key, ref in (("solref", self.solref), ("sole_solref", self.sole_solref)):
            if ref is not None and ref[0] < 2 * self.timestep:
                raise ValueError(f"{key}: time constant {ref[0]} s must be at least 2 timesteps "
                                 f"({2 * self.timestep} s) for a stable contact")
        for key, imp in (("solimp", self.solimp), ("sole_solimp", self.sole_solimp)):
            if imp is not None and not (0.0 <= imp[0] <= imp[1] < 1.0 and imp[2] > 0.0):
                raise ValueError(f"{key}: need 0 <= dmin <= dmax < 1 and width > 0 (m), got {list(imp)}")


@dataclass(frozen=True)
class JointSpec:
    """One joint group: hinge axes (or ``"auto"``), a range per axis, a torque limit."""

    axes: Any = ("y",)  # list of axis names, or "auto"
    range: Any = ((-1.0, 1.0),)  # list of [lo, hi] per axis, or {x: [lo, hi], ...} for "auto"
    torque: float = field(default=100.0, metadata={"gt": 0.0})

    def validate(self) -> None:
        if self.axes == "auto":
            if not isinstance(self.range, dict) or set(self.range) != {"x", "y", "z"}:
                raise ValueError("range: with axes 'auto', give a range for each of x, y, z")
            ranges = list(self.range.values())
        else:
            if not isinstance(self.axes, list | tuple) or not self.axes:
                raise ValueError("axes: a list of axis names or 'auto'")
            bad = [a for a in self.axes if a not in AXIS_NAMES]
            if bad:
                raise ValueError(f"axes: unknown axis {bad[0]!r}; allowed: {', '.join(AXIS_NAMES)}, auto")
            if not isinstance(self.range, list | tuple) or len(self.range) != len(self.axes):
                raise ValueError(f"range: one [lo, hi] per axis ({len(self.axes)} axes)")
            ranges = list(self.range)
        for r in ranges:
            if (not isinstance(r, list | tuple) or len(r) != 2
                    or not all(isinstance(v, int | float) for v in r)):
                raise ValueError(f"range: each range is [lo, hi] in rad, got {r!r}")
            if r[0] >= r[1]:
                raise ValueError(f"range: limits reversed or empty: [{r[0]}, {r[1]}] (need lo < hi)")


@dataclass(frozen=True)
class Geometry:
    pelvis_radius: float = field(default=0.10, metadata={"gt": 0.0})
    torso_radius: float = field(default=0.11, metadata={"gt": 0.0})
    head_radius: float = field(default=0.10, metadata={"gt": 0.0})
    upper_arm_radius: float = field(default=0.045, metadata={"gt": 0.0})
    lower_arm_radius: float = field(default=0.04, metadata={"gt": 0.0})
    thigh_radius: float = field(default=0.07, metadata={"gt": 0.0})
    shin_radius: float = field(default=0.05, metadata={"gt": 0.0})
    foot_width: float = field(default=0.09, metadata={"gt": 0.0})
    heel_length: float = field(default=0.05, metadata={"min": 0.0})
    foot_top: float = field(default=0.02, metadata={"min": 0.0})
    #: the sole's length, heel to toe tip, as a share of the height, where a skeleton's toe has no
    #: tip to measure (:meth:`~bipedsim.model.humanoid_builder._HumanoidBuilder.toe_length_without_tip`)
    foot_length_share: float = field(default=0.152, metadata={"gt": 0.0, "max": 0.5})


@dataclass(frozen=True)
class HumanoidProfile:
    masses: dict[str, float] = field(default_factory=dict)
    #: total mass (kg): a number; "auto", from the legs (:func:`~bipedsim.model.humanoid_proportions.mass_from_legs`: a
    #: person whose hip-to-ankle legs are ``leg_share`` of the height, at body-mass index ``mass_bmi``);
    #: null, the segments' masses as written
    total_mass: float | Literal["auto"] | None = field(default="auto", metadata={"min": MASS_RANGE_KG[0],
                                                                                 "max": MASS_RANGE_KG[1]})
    mass_bmi: float = field(default=22.0, metadata={"gt": 0.0})
    leg_share: float = field(default=0.491, metadata={"gt": 0.0, "max": 1.0})
    joints: dict[str, JointSpec] = field(default_factory=dict)
    ankle_2dof: bool = False
    ankle_x_range: tuple[float, float] = (-0.4, 0.4)
    #: torso as 1 rigid segment (the paper), 2 (abdomen + chest, each with the spine's 3 hinges), or
    #: "auto": 2 only where the source's spine bends so much that one rigid torso would misplace the
    #: shoulders by more than ``spine_split_tol`` (m) on some frame
    spine_segments: Any = field(default="auto", metadata={"choices": ("auto", 1, 2)})
    spine_split_tol: float = field(default=0.015, metadata={"gt": 0.0})
    geometry: Geometry = field(default_factory=Geometry)
    sim: SimOptions = field(default_factory=SimOptions)

    def validate(self) -> None:
        missing = [s for s in SEGMENTS if s not in self.masses]
        if missing:
            raise ValueError(f"masses: missing segment(s) {missing}; needed: {', '.join(SEGMENTS)}")
        extra = [s for s in self.masses if s not in SEGMENTS]
        if extra:
            raise ValueError(f"masses: unknown segment {extra[0]!r}; allowed: {', '.join(SEGMENTS)}")
        for s, m in self.masses.items():
            if not m > 0:
                raise ValueError(f"masses.{s}: must be > 0 kg, got {m}")
        missing = [g for g in JOINT_GROUPS if g not in self.joints]
        extra = [g for g in self.joints if g not in JOINT_GROUPS]
        if missing or extra:
            what = f"missing {missing}" if missing else f"unknown {extra}"
            raise ValueError(f"joints: {what}; joint groups are {', '.join(JOINT_GROUPS)}")
        if self.ankle_x_range[0] >= self.ankle_x_range[1]:
            raise ValueError("ankle_x_range: limits reversed (need lo < hi)")


@dataclass(frozen=True)
class CreatureProfile:
    merge_fraction: float = field(default=0.04, metadata={"min": 0.0, "max": 0.5})
    radius_fraction: float = field(default=0.18, metadata={"gt": 0.0})
    radius_min: float = field(default=0.012, metadata={"gt": 0.0})
    radius_max: float = field(default=0.06, metadata={"gt": 0.0})
    density: float = field(default=1000.0, metadata={"gt": 0.0})
    total_mass: float | None = field(default=None, metadata={"min": MASS_RANGE_KG[0], "max": MASS_RANGE_KG[1]})
    range_margin: float = field(default=0.35, metadata={"min": 0.0})
    range_min: float = field(default=0.5, metadata={"gt": 0.0})
    torque_scale: float = field(default=3.0, metadata={"gt": 0.0})
    gains: tuple[float, float] = (200.0, 20.0)
    sim: SimOptions = field(default_factory=SimOptions)

    def validate(self) -> None:
        if self.radius_min > self.radius_max:
            raise ValueError("radius_min: must not exceed radius_max")
        if min(self.gains) < 0:
            raise ValueError("gains: kp and kd must be >= 0")


PROFILES: dict[str, type] = {"humanoid": HumanoidProfile, "creature": CreatureProfile}


def load_profile(name_or_path: str | os.PathLike[str]) -> HumanoidProfile | CreatureProfile:
    """A shipped profile by name (``"humanoid"``, ``"creature"``) or a profile YAML file.

    A file's kind is taken from its name containing ``creature``, else from its keys.
    """
    s = str(name_or_path)
    if s in PROFILES:
        return config.load(PROFILES[s], PROFILE_DIR / f"{s}.yaml")
    data = config.load_yaml(s)
    kind = "creature" if isinstance(data, dict) and "density" in data else "humanoid"
    return config.from_dict(PROFILES[kind], data, path=s)
