"""A creature's legs as its balance uses them: found from the body
(:func:`~bipedsim.model.creature_builder.creature_legs`: foot end effectors walked up to where they leave the
trunk), any number; per leg its degrees of freedom and actuators, its feet and their touch sites, the
geoms of its lower end that meet the floor; which legs touch the floor now, and the joint torques that
make a foot push the ground with a given force (Jacobian transpose).

The height the balance works at (L, m) and its pendulum frequency sqrt(g/L) (rad/s) are measured here
too: every gain of the creature balance is scaled by them.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import mujoco
import numpy as np

from bipedsim.control.base import FloatArray
from bipedsim.control.creature.forces import distribute_wrench, in_cone
from bipedsim.control.creature.tracking import CreatureBody, ball_joints
from bipedsim.model.creature_builder import Leg, creature_legs
from bipedsim.model.ground import ground_geoms
from bipedsim.model.plan import BodyPlanSet
from bipedsim.reference.clip import ReferenceClip

#: frames sampled (at most) to measure the legs' roots' height above the feet
HEIGHT_SAMPLES = 40


def geom_bottom(model: mujoco.MjModel, data: mujoco.MjData, g: int) -> float:
    """The lowest point (m, world z) of geom ``g`` as posed in ``data`` (spheres, capsules and boxes exactly,
    other shapes by their bounding sphere)."""
    z = float(data.geom_xpos[g][2])
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return z - float(model.geom_size[g][0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:  # axis along the geom's local z, half-length size[1]
        return z - float(model.geom_size[g][0]) - abs(float(data.geom_xmat[g][8])) * float(model.geom_size[g][1])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:  # its lowest corner: half sizes along the axes' vertical parts
        return z - float(np.abs(data.geom_xmat[g][6:9]) @ model.geom_size[g])
    return z - float(model.geom_rbound[g])


def leg_height(model: mujoco.MjModel, clip: ReferenceClip, legs: list[Leg]) -> float:
    """The height (m) the balance works at: the root body's median height, or -- where the root is not
    where the body is (a root joint at the floor carrying the travel, as ActorCore's ``BoneRoot``) --
    the legs' roots' median height above the lowest foot."""
    h = float(np.median(clip.qpos[:, 2]))
    if not legs:
        return h
    d = mujoco.MjData(model)
    roots = [model.body(leg.root).id for leg in legs]
    feet = [model.body(f).id for leg in legs for f in leg.feet]
    hips = []
    for f in np.unique(np.linspace(0, clip.num_frames - 1, min(clip.num_frames, HEIGHT_SAMPLES)).astype(int)):
        d.qpos[:] = clip.qpos[f]
        mujoco.mj_kinematics(model, d)
        hips.append(float(np.mean(d.xpos[roots, 2]) - np.min(d.xpos[feet, 2])))
    legs_h = float(np.median(hips))
    return legs_h if h < 0.5 * legs_h else h


class LegSet:
    """The legs of a creature body and their tables (see the module text). ``clip``: the clip as read
    (its foot contact labels, and the height the balance works at)."""

    def __init__(self, model: mujoco.MjModel, plan: BodyPlanSet, body: CreatureBody, clip: ReferenceClip) -> None:
        self.model = model
        self.legs = creature_legs(plan)
        #: the height the balance works at (m) and its pendulum frequency sqrt(g/L) (rad/s)
        self.height = leg_height(model, clip, self.legs)
        self.omega0 = math.sqrt(-float(model.opt.gravity[2]) / max(self.height, 1e-3))
        ball_of = {model.jnt_bodyid[j]: k for k, j in enumerate(ball_joints(model))}
        #: per leg: its dof columns, its actuators (same order), its feet's body ids and touch sites, its
        #: leg-root ball joint (index into the body's balls), and which clip contact columns are its feet
        self.dofs: list[np.ndarray] = []
        self.acts: list[np.ndarray] = []
        self.feet: list[list[int]] = []
        self.sites: list[list[int]] = []
        self.root_ball: list[int] = []
        self.clip_cols: list[list[int]] = []
        for leg in self.legs:
            ks = [ball_of[model.body(b).id] for b in leg.bodies if model.body(b).id in ball_of]
            self.dofs.append(np.concatenate([body.dadr[k] + np.arange(3) for k in ks]))
            self.acts.append(np.concatenate([body.acts[k] for k in ks]))
            self.feet.append([model.body(f).id for f in leg.feet])
            self.sites.append([model.site(f"{f}_touch").id for f in leg.feet])
            self.root_ball.append(ball_of[model.body(leg.root).id])
            self.clip_cols.append([clip.foot_names.index(f) for f in leg.feet if f in clip.foot_names])
        #: floor-contact geoms of each leg: its feet and the bodies they hang from (a foot's own
        #: geom may be a tiny sphere while the bone to it, on the parent body, meets the ground)
        self.geom_leg: dict[int, int] = {}
        for i, feet in enumerate(self.feet):
            lower = set(feet) | {int(model.body_parentid[f]) for f in feet}
            for g in range(model.ngeom):
                if model.geom_bodyid[g] in lower:
                    self.geom_leg[g] = i
        self.floor = ground_geoms(model)  #: the ground's geoms
        #: each leg root's parent body (the trunk body it hangs from)
        self.root_parent = [model.body_parentid[model.body(leg.root).id] for leg in self.legs]
        self.jacp = np.zeros((3, model.nv))
        #: each leg's mean floor contact point (m, world) at the last :meth:`feet_down`, or its first
        #: foot's touch site where it has none
        self.contact_points: list[FloatArray] = []

    def __len__(self) -> int:
        return len(self.legs)

    def __iter__(self) -> Iterator[Leg]:
        return iter(self.legs)

    def lower_geoms(self, i: int) -> list[int]:
        """The floor-contact geoms of leg ``i``."""
        return [g for g, leg in self.geom_leg.items() if leg == i]

    def feet_down(self, data: mujoco.MjData) -> list[bool]:
        """Per leg: does its lower end (feet and the bones to them) touch the floor now? Also keeps
        each touching leg's mean contact point (m, world) in ``contact_points``."""
        n = len(self.legs)
        pts = [np.zeros(3) for _ in range(n)]
        counts = [0] * n
        floor, gl = self.floor, self.geom_leg
        for c in range(data.ncon):
            g1, g2 = data.contact.geom[c]
            other = g2 if g1 in floor else g1 if g2 in floor else -1
            leg = gl.get(int(other), -1)
            if leg >= 0:
                pts[leg] += data.contact.pos[c]
                counts[leg] += 1
        self.contact_points = [p / k if k else data.site_xpos[self.sites[i][0]].copy()
                               for i, (p, k) in enumerate(zip(pts, counts))]
        return [k > 0 for k in counts]

    def clip_down(self, clip: ReferenceClip, f: int, leg: int) -> bool:
        """Whether ``clip`` has a foot of leg ``leg`` on the ground at frame ``f``."""
        cols = self.clip_cols[leg]
        return bool(cols) and bool(clip.contacts[f, cols].any())

    def torques(self, data: mujoco.MjData, leg: int, point: FloatArray, force: FloatArray) -> FloatArray:
        """Joint torques (N*m, the leg's actuators in ``acts[leg]`` order) that make leg ``leg``'s foot,
        held at ``point`` (m, world), be pushed by the ground with ``force`` (N, world): -J^T f, J the
        point's Jacobian over the leg's degrees of freedom."""
        mujoco.mj_jac(self.model, data, self.jacp, None, point, self.feet[leg][0])
        return -self.jacp[:, self.dofs[leg]].T @ force

    def stance_torques(self, data: mujoco.MjData, force: FloatArray, torque: FloatArray, stance: list[int],
                       com: FloatArray, friction: float) -> FloatArray:
        """Joint torques (N*m, by actuator) through the ``stance`` legs that make their feet push the
        wrench ``force`` (N), ``torque`` (N*m about ``com``) on the body: shared among the legs' contact
        points by :func:`distribute_wrench`, each share held in its friction cone."""
        pts = np.array([self.contact_points[i] for i in stance])
        fs = distribute_wrench(force, torque, pts, com)
        out = np.zeros(self.model.nu)
        for k, i in enumerate(stance):
            out[self.acts[i]] += self.torques(data, i, pts[k], in_cone(fs[k], friction))
        return out


__all__ = ["LegSet", "geom_bottom", "leg_height"]
