"""A body plan -- the physics skeleton in plain data -- and its compilation to MJCF.

Both profiles (humanoid, creature) produce a :class:`BodyPlan`; :class:`ModelBuilder` turns it into
an MJCF model with MuJoCo's native ``MjSpec``. Every body frame is parallel to the world frame in the
rest pose (the source skeleton's rest pose, turned to face +x, in metres, Z up), so a body's
orientation in the world is the rotation that carries its rest-pose points to where the motion puts
them; :mod:`bipedsim.reference.retarget` relies on that.

The plan is stored in the MJCF file itself (``<custom><text name="bipedsim.plan">`` as JSON), so a
model file alone is enough to retarget motions onto it.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any

import mujoco
import numpy as np

from bipedsim.errors import ModelError
from bipedsim.model.profile import SimOptions

PLAN_TEXT = "bipedsim.plan"
FLOOR_NAME = "floor"
#: Collision filtering: body geoms touch the floor but not each other.
BODY_CONTYPE, BODY_CONAFFINITY = 2, 1
FLOOR_CONTYPE, FLOOR_CONAFFINITY = 1, 2
SITE_SIZE = 0.01


@dataclass
class JointPlan:
    """A hinge (``axis``, ``range`` in rad) or a ball joint (``range`` = (0, max angle))."""

    name: str
    kind: str  # "hinge" | "ball"
    axis: list[float] = field(default_factory=lambda: [0.0, 1.0, 0.0])
    range: list[float] = field(default_factory=lambda: [-1.0, 1.0])
    torque: float = 100.0  # N*m, actuator limit
    kp: float = 300.0
    kd: float = 30.0
    group: str = ""  # joint group in the profile (hip, knee...), for gains tables


@dataclass
class GeomPlan:
    """``capsule``/``box``/``sphere`` in body coordinates. ``fromto`` for capsules; ``pos`` + ``size``
    (half-sizes for boxes, radius for spheres) otherwise. ``mass`` in kg (0: massless)."""

    kind: str
    size: list[float]
    fromto: list[float] | None = None
    pos: list[float] | None = None
    mass: float = 0.0
    name: str | None = None
    quat: list[float] | None = None  #: orientation in the body (w, x, y, z); None: the body's axes
    sole: bool = False  #: a foot's or toe's sole: its ground contact is the profile's ``sim.sole_solref/solimp``


@dataclass
class SitePlan:
    name: str
    pos: list[float]  # body coordinates
    size: list[float] = field(default_factory=lambda: [SITE_SIZE])
    kind: str = "sphere"
    touch: bool = False  # add a touch sensor on this site
    quat: list[float] | None = None  #: orientation in the body (w, x, y, z); None: the body's axes


@dataclass
class FitPlan:
    """How the body's world orientation follows the source motion (see retarget).

    ``method``: ``"kabsch"`` (best rotation carrying ``points`` about ``origin``), ``"aim"`` (turn the
    reference rotation ``ref`` minimally so the bone ``origin -> points[0]`` points where the motion
    does), ``"twobone"`` (aim at ``points[0]`` with the twist that puts ``points[1]`` in the plane of the
    child's hinge ``hinge_axis``). Points are source joint names or ``"<joint>/end<k>"`` End Sites.
    ``ref``: ``"bvh:<joint>"`` (that joint's global rotation) or ``"parent"`` (the parent body's).
    """

    method: str
    origin: str
    points: list[str] = field(default_factory=list)
    ref: str = ""
    hinge_axis: list[float] | None = None
    #: the points' positions relative to ``origin`` in the model's zero pose (m, world axes); for
    #: ``twobone`` a second entry is ``points[1] - points[0]``
    rest_vectors: list[list[float]] = field(default_factory=list)
    weights: list[float] | None = None
    #: ``twobone``: the child hinge's range (rad); of the two twists that reach the end point, the
    #: one bending the child hinge inside this range wins (a knee bends forward, not backward)
    hinge_range: list[float] | None = None


@dataclass
class BodyPlan:
    name: str
    parent: str | None  # None: the root, which gets a free joint
    pos: list[float]  # world position of the body origin in the rest pose (m)
    source: str  # source-skeleton joint at the body origin
    joints: list[JointPlan] = field(default_factory=list)
    geoms: list[GeomPlan] = field(default_factory=list)
    sites: list[SitePlan] = field(default_factory=list)
    fit: FitPlan | None = None
    segment: str = ""  # humanoid segment name (thigh, shin...) or "" for creatures
    is_foot: bool = False  # counts as a foot for contact labels and fall detection


@dataclass
class BodyPlanSet:
    """The whole plan: bodies in tree order plus what the retargeter needs about the source."""

    name: str
    profile: str  # "humanoid" | "creature"
    bodies: list[BodyPlan]
    heading_yaw: float  # rad turned about +z so the rest pose faces +x
    source_names: list[str]  # source skeleton joint names
    sim: dict[str, Any]
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        return json.dumps(asdict(self), sort_keys=True, separators=(",", ":"))

    @staticmethod
    def from_json(text: str) -> BodyPlanSet:
        d = json.loads(text)
        bodies = []
        for b in d.pop("bodies"):
            b["joints"] = [JointPlan(**j) for j in b["joints"]]
            b["geoms"] = [GeomPlan(**g) for g in b["geoms"]]
            b["sites"] = [SitePlan(**s) for s in b["sites"]]
            b["fit"] = None if b["fit"] is None else FitPlan(**b["fit"])
            bodies.append(BodyPlan(**b))
        return BodyPlanSet(bodies=bodies, **d)

    def body(self, name: str) -> BodyPlan:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    @property
    def foot_bodies(self) -> list[str]:
        return [b.name for b in self.bodies if b.is_foot]


def _r(x: Any, nd: int = 6) -> list[float]:
    """Round for a stable, readable file (1 micrometre / 1 microradian)."""
    return [float(round(float(v), nd)) + 0.0 for v in np.atleast_1d(x)]


class ModelBuilder:
    """Owns one MJCF model built from a :class:`BodyPlanSet` (MuJoCo ``MjSpec``).

    ``build()`` returns the spec; ``xml()`` its text; ``compile()`` the ``MjModel``.
    """

    def __init__(self, plan: BodyPlanSet) -> None:
        self.plan = plan
        self.spec = mujoco.MjSpec()
        self._built = False

    def _options(self, sim: SimOptions) -> None:
        s = self.spec
        s.modelname = self.plan.name
        s.compiler.degree = False
        s.option.timestep = sim.timestep
        s.option.gravity = [0.0, 0.0, sim.gravity]
        s.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{sim.integrator.upper()}")

    def _floor(self, sim: SimOptions) -> None:
        w = self.spec.worldbody
        w.add_light(name="sun", pos=[0, 0, 6], dir=[0, -0.3, -1],
                    type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, castshadow=True,
                    diffuse=[0.8, 0.8, 0.8])
        self.spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                              builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.35, 0.4, 0.45],
                              rgb2=[0.25, 0.3, 0.35], width=512, height=512)
        mat = self.spec.add_material(name="grid", texrepeat=[1, 1], texuniform=True, reflectance=0.1)
        mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
        w.add_geom(name=FLOOR_NAME, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                   material="grid", contype=FLOOR_CONTYPE, conaffinity=FLOOR_CONAFFINITY,
                   friction=list(sim.friction), solref=list(sim.solref), solimp=list(sim.solimp),
                   condim=sim.condim)

    def build(self) -> mujoco.MjSpec:
        if self._built:
            return self.spec
        plan = self.plan
        sim = SimOptions(**{k: (tuple(v) if isinstance(v, list) else v) for k, v in plan.sim.items()})
        self._options(sim)
        self._floor(sim)
        handles: dict[str, Any] = {}
        pos = {b.name: np.asarray(b.pos) for b in plan.bodies}
        for b in plan.bodies:
            if b.parent is None:
                body = self.spec.worldbody.add_body(name=b.name, pos=_r(b.pos))
                body.add_freejoint(name="root")
            else:
                if b.parent not in handles:
                    raise ModelError(f"body {b.name!r}: parent {b.parent!r} comes later or is missing")
                body = handles[b.parent].add_body(name=b.name, pos=_r(pos[b.name] - pos[b.parent]))
            handles[b.name] = body
            self.attach_joints(body, b.joints, sim)
            self.attach_geoms(body, b.geoms, sim)
            for s in b.sites:
                skw = {} if s.quat is None else {"quat": _r(s.quat)}
                body.add_site(name=s.name, pos=_r(s.pos), size=_r(s.size + [0, 0])[:3],
                              type=getattr(mujoco.mjtGeom, f"mjGEOM_{s.kind.upper()}"),
                              rgba=[0.9, 0.5, 0.1, 0.0 if s.touch else 0.6], **skw)
                if s.touch:
                    self.spec.add_sensor(name=f"touch_{s.name}", type=mujoco.mjtSensor.mjSENS_TOUCH,
                                         objtype=mujoco.mjtObj.mjOBJ_SITE, objname=s.name)
        self.spec.add_text(name=PLAN_TEXT, data=plan.to_json())
        self._built = True
        return self.spec

    def attach_joints(self, body: Any, joints: list[JointPlan], sim: SimOptions) -> None:
        for j in joints:
            if j.kind == "hinge":
                body.add_joint(name=j.name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=_r(j.axis),
                               range=_r(j.range), limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                               damping=sim.joint_damping, armature=sim.armature)
                self.spec.add_actuator(name=j.name, target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                                       ctrlrange=[-j.torque, j.torque],
                                       ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE)
            elif j.kind == "ball":
                body.add_joint(name=j.name, type=mujoco.mjtJoint.mjJNT_BALL, range=_r(j.range),
                               limited=mujoco.mjtLimited.mjLIMITED_TRUE, damping=sim.joint_damping,
                               armature=sim.armature)
                for k, ax in enumerate(("x", "y", "z")):
                    gear = [0.0] * 6
                    gear[k] = 1.0
                    self.spec.add_actuator(name=f"{j.name}_{ax}", target=j.name, gear=gear,
                                           trntype=mujoco.mjtTrn.mjTRN_JOINT,
                                           ctrlrange=[-j.torque, j.torque],
                                           ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE)
            else:
                raise ModelError(f"joint {j.name!r}: kind must be hinge or ball, got {j.kind!r}")

    def attach_geoms(self, body: Any, geoms: list[GeomPlan], sim: SimOptions) -> None:
        for g in geoms:
            kw: dict[str, Any] = {"contype": BODY_CONTYPE, "conaffinity": BODY_CONAFFINITY,
                                      "friction": list(sim.friction), "solref": list(sim.solref),
                                      "solimp": list(sim.solimp), "condim": 3, "rgba": [0.75, 0.62, 0.5, 1.0]}
            if g.sole and (sim.sole_solref is not None or sim.sole_solimp is not None):
                # the contact takes the sole's parameters, not a mix with the ground's: its solref and solimp,
                # and also its friction and condim (the profile's, as the floor's; a ground with its own
                # friction is overruled at the soles)
                kw["priority"] = 1
                kw["solref"] = list(sim.sole_solref if sim.sole_solref is not None else sim.solref)
                kw["solimp"] = list(sim.sole_solimp if sim.sole_solimp is not None else sim.solimp)
                kw["condim"] = sim.condim  # with priority the sole's condim is the contact's: the profile's
            if g.name:
                kw["name"] = g.name
            if g.quat is not None:
                kw["quat"] = _r(g.quat)
            if g.mass > 0:
                kw["mass"] = round(g.mass, 6)
            else:
                kw["density"] = 0.0
            if g.kind == "capsule":
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=_r(g.fromto),
                              size=_r(g.size + [0, 0])[:3], **kw)
            elif g.kind == "box":
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, pos=_r(g.pos), size=_r(g.size), **kw)
            elif g.kind == "sphere":
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=_r(g.pos),
                              size=_r(g.size + [0, 0])[:3], **kw)
            else:
                raise ModelError(f"geom kind must be capsule, box or sphere, got {g.kind!r}")

    def xml(self) -> str:
        self.build()
        return self.spec.to_xml()

    def compile(self) -> mujoco.MjModel:
        self.build()
        return self.spec.compile()


def model_hash(xml: str) -> str:
    """A short content hash of an MJCF text (identifies the model a clip was made for)."""
    return hashlib.sha256(xml.encode("utf-8")).hexdigest()[:16]


def plan_from_model(model: mujoco.MjModel) -> BodyPlanSet:
    """The body plan stored in a model built by bipedsim."""
    tid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, PLAN_TEXT)
    if tid < 0:
        raise ModelError("this MJCF model was not built by bipedsim (no 'bipedsim.plan' text); "
                         "build it with `bipedsim convert`")
    adr, size = model.text_adr[tid], model.text_size[tid]
    raw = bytes(model.text_data[adr:adr + size - 1]).decode("utf-8")
    return BodyPlanSet.from_json(raw)
