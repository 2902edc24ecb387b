"""Soles for a creature that stands on two legs: a flat box under each foot, spanning its toes.

A creature's feet are capsules along its toe bones (a bird's three toes, a dog's paw): on four legs
the support polygon spans the feet, but on two legs the body stands on its feet alone, and capsules
touch the floor along lines -- a biped on line feet tips over even standing still. So each leg of a
two-legged creature gets a **sole**, measured from the skeleton:

- the **foot segment**: the body its toes spread from (the lowest body common to the leg's feet; a
  single foot body is its own segment);
- the **sole's plane**: level where the motion has the segment flat on the floor (the frames on which
  every toe tip is within ``FLAT_HEIGHT_M`` of its lowest level and the segment still, as the humanoid's
  feet are levelled): the world's up direction averaged over those frames in the segment's frame;
- its **outline**: the box in that plane spanning the ankle (the segment's origin) and every joint and
  End Site below it -- a bird's toes spread forward and sideways -- its bottom at the lowest of them less
  the toe capsules' radius, its thickness that radius twice;
- **paired legs** (two legs: left and right) stand on soles of one size, the larger of the two
  measured: a skeleton whose End Sites stop at the toe joints on one side (the shared flamingo's right
  toes end 4 cm from the ankle, its left ones 13 cm) would otherwise stand on one short foot.

The sole is a massless collision box on the segment, with a site ``<segment>_sole`` at the middle of
its bottom face whose z axis is the sole's normal (the planned gait aims it flat on the floor). The
plan records each leg's sole site in ``extra["soles"]`` (leg root -> site name).

Units: m; body coordinates (parallel to the world in the rest pose, Z up).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from bipedsim.model.flat_foot import _flat_frames
from bipedsim.model.humanoid_geoms import _quat
from bipedsim.model.plan import BodyPlan, GeomPlan, SitePlan
from bipedsim.model.source import SourcePoints

FloatArray = npt.NDArray[np.float64]

#: bodies on at most this many legs stand on soles (on more legs the support spans the feet)
SOLE_MAX_LEGS = 2
#: a two-legged creature's legs weigh at most this share of its mass together (a human's two legs: 32 %
#: of the body, the paper's mass table 2 x 10.8 of 67 kg; a bird's thin legs less)
BIPED_LEG_SHARE = 0.32
#: a two-legged creature's leg joints turn this much (rad) further than the clip shows plus the profile's
#: margin: a step that catches the body sideways needs the hip and knee out of the clip's plane
BIPED_RANGE_EXTRA = 0.5


def lighten_legs(bodies: list[BodyPlan], legs: list) -> float:
    """Scale the masses of a two-legged creature's leg bodies so its legs weigh at most BIPED_LEG_SHARE
    of the whole; returns the factor (1: unchanged, or more than SOLE_MAX_LEGS legs).

    Capsules sized from bone lengths (radius 0.18 x length) make a bird's long, thin legs the heaviest
    part of it: a flamingo's would come to 60 % of its mass, its 55 cm tarsus alone 19 kg, and swinging
    one leg (30 % of the body) would push the body off its foot."""
    if not legs or len(legs) > SOLE_MAX_LEGS:
        return 1.0
    leg_bodies = {b for leg in legs for b in leg.bodies}
    on_legs = sum(g.mass for b in bodies if b.name in leg_bodies for g in b.geoms)
    rest = sum(g.mass for b in bodies if b.name not in leg_bodies for g in b.geoms)
    if on_legs <= 0:
        return 1.0
    f = min(1.0, BIPED_LEG_SHARE * rest / ((1.0 - BIPED_LEG_SHARE) * on_legs))
    for b in bodies:
        if b.name in leg_bodies:
            for g in b.geoms:
                g.mass *= f
            for j in b.joints:  # a biped catches itself sideways: room beyond what the clip shows
                j.range = [j.range[0], float(min(np.pi, j.range[1] + BIPED_RANGE_EXTRA))]
    return f


def foot_segment(bodies: list[BodyPlan], feet: tuple[str, ...]) -> str:
    """The lowest body common to every foot in ``feet`` (a single foot is its own segment)."""
    parent = {b.name: b.parent for b in bodies}

    def chain(b: str | None) -> list[str]:
        out = []
        while b is not None:
            out.append(b)
            b = parent[b]
        return out

    common = set(chain(feet[0]))
    for f in feet[1:]:
        common &= set(chain(f))
    return next(b for b in chain(feet[0]) if b in common)


def _subtree(bodies: list[BodyPlan], root: str) -> set[str]:
    out = {root}
    for b in bodies:  # parents come first
        if b.parent in out:
            out.add(b.name)
    return out


def _points(moving: SourcePoints, sources: set[str]) -> list[str]:
    """Names of the joints and End Sites (``joint/end<k>``) on the bodies whose source joints are
    ``sources`` (merged joints included through their body's source set)."""
    return [n for n in moving.names if n.split("/")[0] in sources]


def _sole_frame(moving: SourcePoints, seg_source: str, tips: list[str], rel: FloatArray) -> FloatArray:
    """Axes (columns, segment body coordinates) of the sole: z its normal (world up on the frames where
    the segment is flat on the floor; the rest pose's up when the motion never shows it flat), x the
    direction of the toes from the ankle in that plane."""
    assert moving.rotations is not None
    j = moving.index[seg_source]
    flat = _flat_frames(moving, seg_source, tips)
    rots = moving.rotations[:, j] if flat is None else moving.rotations[flat, j]
    z = np.einsum("fji,j->i", rots, np.array([0.0, 0.0, 1.0]))  # sum of R^T up
    z = z / max(float(np.linalg.norm(z)), 1e-12)
    toes = rel.mean(axis=0)
    x = toes - (toes @ z) * z
    if np.linalg.norm(x) < 1e-9:
        x = np.cross([0.0, 1.0, 0.0], z)
    x = x / float(np.linalg.norm(x))
    return np.column_stack([x, np.cross(z, x), z])


def _outline(rel: FloatArray, frame: FloatArray, radius: float, ankle: float) -> tuple[FloatArray, FloatArray]:
    """(lo, hi) corners (sole frame, m) of the box spanning the points ``rel`` (segment body
    coordinates, the ankle at 0 included), ``radius`` below the lowest and 2 x ``radius`` thick; its
    bottom at least ``ankle`` (m) below the ankle (the round end of the bone above it, which would
    otherwise be what the body stands on)."""
    p = np.vstack([np.zeros(3), rel]) @ frame
    lo, hi = p.min(axis=0), p.max(axis=0)
    lo[0:2] -= radius
    hi[0:2] += radius
    lo[2] = min(lo[2] - radius, -ankle)
    hi[2] = lo[2] + 2.0 * radius
    return lo, hi


def add_soles(bodies: list[BodyPlan], legs: list, moving: SourcePoints, rest: SourcePoints,
              body_source: dict[str, set[str]]) -> dict[str, str]:
    """Give each leg of a creature on at most SOLE_MAX_LEGS legs a sole on its foot segment (see the
    module text); returns leg root -> sole site name ({} for more legs). ``legs``: the body's
    :class:`~bipedsim.model.creature_builder.Leg` list; ``body_source``: each body's source joints (its own and
    the ones merged into it); ``rest``/``moving``: the skeleton's rest-pose and per-frame points."""
    if not legs or len(legs) > SOLE_MAX_LEGS:
        return {}
    by_name = {b.name: b for b in bodies}
    made = []
    for leg in legs:
        seg = by_name[foot_segment(bodies, leg.feet)]
        sources = set().union(*(body_source[b] for b in _subtree(bodies, seg.name)))
        names = [n for n in _points(moving, sources) if n != seg.source]
        origin = rest.positions[rest.index[seg.source]]
        rel = np.array([rest.positions[rest.index[n]] for n in names]) - origin
        tips = [n for n in names if "/" in n] or names
        radius = min(g.size[0] for b in _subtree(bodies, seg.name) for g in by_name[b].geoms)
        # the capsule of the bone down to the ankle ends in a ball around it
        above = by_name[seg.parent] if seg.parent else seg
        ankle = max([g.size[0] for g in above.geoms if g.kind == "capsule" and g.fromto is not None and np.allclose(
            np.asarray(above.pos) + g.fromto[3:6], seg.pos, atol=1e-6)] + [0.0])
        frame = _sole_frame(moving, seg.source, tips, rel)
        made.append((leg, seg, frame, *_outline(rel, frame, radius, ankle)))
    # paired legs stand on soles of one size: the larger measured length and width
    size = np.max([hi[0:2] - lo[0:2] for *_, lo, hi in made], axis=0)
    soles = {}
    for leg, seg, frame, lo, hi in made:
        grow = size - (hi[0:2] - lo[0:2])
        hi[0] += grow[0]  # longer toward the toes: the ankle is the heel
        lo[1] -= grow[1] / 2
        hi[1] += grow[1] / 2
        centre = (lo + hi) / 2
        half = (hi - lo) / 2
        name = f"{seg.name}_sole"
        seg.geoms.append(GeomPlan(kind="box", size=[float(v) for v in half], pos=[float(v) for v in frame @ centre],
                                  mass=0.0, name=f"{name}_geom", quat=_quat(frame), sole=True))
        bottom = np.array([centre[0], centre[1], lo[2]])
        seg.sites.append(SitePlan(name=name, pos=[float(v) for v in frame @ bottom], quat=_quat(frame)))
        soles[leg.root] = name
    return soles


__all__ = ["BIPED_LEG_SHARE", "SOLE_MAX_LEGS", "add_soles", "foot_segment", "lighten_legs"]
