"""The ground a body walks on: flat (the default), a slope, steps, rough ground, a friction.

A :class:`Ground` is parsed from terms (``bipedsim run --ground TERM``, repeatable; a ``ground:`` key
in run, sweep and suite files takes the same terms as a list):

- ``slope:DEG``: the ground rises DEG degrees along the walking direction (negative: falls);
- ``step:HEIGHT_M:DISTANCE_M``: the ground rises HEIGHT_M (negative: drops) DISTANCE_M ahead of the
  start along the walking direction (repeatable: a flight of steps);
- ``rough:AMPLITUDE_M:WAVELENGTH_M[:SEED]``: uneven ground, heights within +-AMPLITUDE_M made of waves
  about WAVELENGTH_M long (a MuJoCo height field), drawn from SEED (default 0);
- ``friction:MU``: the sliding friction coefficient of every contact with the ground.

The ground is laid out in a :class:`GroundFrame`: its origin is the body's start (x, y; the height
there is 0) and its axis the walking direction (yaw). Without rough ground it is exact: a plane
(tilted by the slope) at its lowest level and one box (tilted alike) per higher level, so a step's
edge is sharp; with rough ground, one height field per level, the slope in its heights. Every
ground geom is a world-body geom that collides with the body (:func:`ground_geoms`), and the ground
is stored in the model itself (a custom text, as the body plan), so a saved ``model.xml`` draws it
and :func:`terrain_of` answers height queries for any model built with it.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.errors import ConfigError
from bipedsim.model.build import BuiltModel
from bipedsim.model.ground_grid import GridTerrain, grid_terrain_of, model_text
from bipedsim.model.ground_terms import (
    AHEAD_M,
    BEHIND_M,
    HALF_WIDTH_M,
    MIN_STEP_DISTANCE_M,
    PLANE_AHEAD_M,
    PLANE_BEHIND_M,
    PLANE_HALF_WIDTH_M,
    ROUGH_MAX_SAMPLES,
    SYNTAX,
    Rough,
    Step,
    _friction,
    _rough,
    _slope,
    _split,
    _step,
)
from bipedsim.model.plan import BODY_CONTYPE, FLOOR_NAME

FloatArray = npt.NDArray[np.float64]

#: the model's custom text holding the ground (terms and frame) as JSON
GROUND_TEXT = "bipedsim.ground"
#: rough ground's height-field sample spacing (m): at most this, and at least this many samples
#: per wavelength (linear triangles between samples)
ROUGH_SPACING_M = 0.1
ROUGH_SAMPLES_PER_WAVELENGTH = 8
#: plane waves summed into rough ground, and the spread of their wavelengths (times the given one)
ROUGH_WAVES = 8
ROUGH_WAVELENGTH_SPREAD = (0.75, 1.5)
#: rough ground is flat within this distance (m) of the start and reaches its full height this far on
#: (a linear ramp between): the body starts standing on level ground
ROUGH_FLAT_M, ROUGH_RAMP_M = 0.3, 1.0
#: how far (m) a box or height field reaches below its level's surface (a step's box below the base)
BASE_DEPTH_M = 0.5


@dataclass(frozen=True)
class Ground:
    """The ground's shape and friction (the default: flat, the profile's friction)."""

    slope_deg: float = 0.0  #: degrees, positive: uphill along the walking direction
    steps: tuple[Step, ...] = ()  #: in order of distance
    rough: Rough | None = None
    friction: float | None = None  #: sliding friction coefficient; None: the body profile's

    @property
    def flat(self) -> bool:
        """Level, even ground with the profile's friction (what a run has without ``--ground``)."""
        return self == Ground()

    @property
    def shaped(self) -> bool:
        """Whether the ground's surface is other than the plane z = 0."""
        return bool(self.slope_deg or self.steps or self.rough)

    def terms(self) -> list[str]:
        """The terms that parse back into this ground (``flat``: none)."""
        out = [f"slope:{self.slope_deg:g}"] if self.slope_deg else []
        out += [f"step:{s.height_m:g}:{s.distance_m:g}" for s in self.steps]
        if self.rough is not None:
            r = self.rough
            out.append(f"rough:{r.amplitude_m:g}:{r.wavelength_m:g}:{r.seed}")
        if self.friction is not None:
            out.append(f"friction:{self.friction:g}")
        return out

    def label(self) -> str:
        """One word for tables: the terms joined by ``+``, or ``flat``."""
        return "+".join(self.terms()) or "flat"

    def extent(self) -> tuple[float, float]:
        """How far (m) the ground's boxes or height fields reach behind and ahead of the start along the
        walking direction: a plane-based ground's boxes :data:`PLANE_BEHIND_M` and
        :data:`PLANE_AHEAD_M`; rough ground's height fields :data:`BEHIND_M` and as far ahead as
        :data:`ROUGH_MAX_SAMPLES` samples reach at their spacing (at least :data:`AHEAD_M`)."""
        if self.rough is None:
            return PLANE_BEHIND_M, PLANE_AHEAD_M
        dx = _rough_spacing(self.rough)
        rows = int(math.ceil(2 * HALF_WIDTH_M / dx)) + 1
        cols = ROUGH_MAX_SAMPLES // rows - 1 - len(self.steps)  # a column more per level
        return BEHIND_M, min(PLANE_AHEAD_M, max(AHEAD_M, math.floor(cols * dx - BEHIND_M)))

    def levels(self) -> list[tuple[float, float, float]]:
        """The ground's levels as (from, to, height): distances along the walking direction (m, the
        first from :meth:`extent`'s behind the start, the last to its ahead) and the level's height (m)
        above the start's before slope and roughness."""
        behind, ahead = self.extent()
        cuts = [-behind] + [s.distance_m for s in self.steps] + [ahead]
        heights = np.concatenate([[0.0], np.cumsum([s.height_m for s in self.steps])]).tolist()
        return [(cuts[i], cuts[i + 1], heights[i]) for i in range(len(heights))]

    @staticmethod
    def parse(terms: str | Sequence[str] | None, key: str = "--ground",
              path: str | os.PathLike[str] | None = None) -> Ground:
        """A ground from its terms (one string or a list; ``flat`` or nothing: flat). A term that does
        not parse, a value out of range or a term given twice that cannot be (slope, rough, friction)
        is a :class:`ConfigError` naming ``key`` (and the file at ``path``) and the term."""
        items = [terms] if isinstance(terms, str) else list(terms or [])
        slope, rough, friction, steps = None, None, None, []
        for i, raw in enumerate(items):
            where = key if isinstance(terms, str) or len(items) == 1 else f"{key}[{i}]"
            if not isinstance(raw, str):
                raise ConfigError(f"expected a term ({SYNTAX}), got {raw!r}", path=path, key=where)
            kind, values = _split(raw, where, path)
            if kind == "flat":
                continue
            if kind in ("slope", "rough", "friction") and {"slope": slope, "rough": rough,
                                                            "friction": friction}[kind] is not None:
                raise ConfigError(f"{raw!r}: a ground has one {kind}; give it once", path=path, key=where)
            try:
                if kind == "slope":
                    slope = _slope(values)
                elif kind == "step":
                    steps.append(_step(values))
                elif kind == "rough":
                    rough = _rough(values)
                else:
                    friction = _friction(values)
            except ValueError as exc:
                raise ConfigError(f"{raw!r}: {exc}", path=path, key=where) from None
        steps.sort(key=lambda s: s.distance_m)
        for a, b in zip(steps, steps[1:]):
            if b.distance_m - a.distance_m < MIN_STEP_DISTANCE_M:
                raise ConfigError(f"steps at {a.distance_m:g} m and {b.distance_m:g} m: steps lie at least "
                                  f"{MIN_STEP_DISTANCE_M:g} m apart", path=path, key=key)
        return Ground(slope_deg=slope or 0.0, steps=tuple(steps), rough=rough, friction=friction)


# ---------------------------------------------------------------------- where the ground lies
@dataclass(frozen=True)
class GroundFrame:
    """Where a ground is laid: its origin (m, world x and y: the body's start) and the walking
    direction (rad, yaw about +z from +x)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


@dataclass
class Terrain:
    """Height and normal queries of a ground laid in a frame (world frame, m, Z up). The controller
    and the fall rule ask this object; nothing reads the ground's geoms."""

    ground: Ground
    frame: GroundFrame = field(default_factory=GroundFrame)

    def __post_init__(self) -> None:
        g, f = self.ground, self.frame
        self._c, self._s = math.cos(f.yaw), math.sin(f.yaw)
        self._tan = math.tan(math.radians(g.slope_deg))
        self._cuts = [s.distance_m for s in g.steps]
        self._levels = [lv for _, _, lv in g.levels()]
        self._waves = _waves(g.rough) if g.rough is not None else None

    def local(self, x: float, y: float) -> tuple[float, float]:
        """World (x, y) as (along, left) of the walking direction from the origin (m)."""
        dx, dy = x - self.frame.x, y - self.frame.y
        return dx * self._c + dy * self._s, -dx * self._s + dy * self._c

    def level(self, s: float) -> float:
        """The step level (m) at ``s`` m along the walking direction."""
        k = 0
        for cut in self._cuts:
            if s >= cut:
                k += 1
        return self._levels[k]

    def height(self, x: float, y: float) -> float:
        """The ground's height (m) at world (x, y)."""
        s, lat = self.local(x, y)
        h = self._tan * s + self.level(s)
        if self._waves is not None:
            h += self._waves.at(s, lat)
        return h

    def normal(self, x: float, y: float) -> tuple[float, float, float]:
        """The ground's unit normal at world (x, y) (a step's edge: the level's)."""
        s, lat = self.local(x, y)
        ds, dl = self._tan, 0.0
        if self._waves is not None:
            gs, gl = self._waves.gradient(s, lat)
            ds, dl = ds + gs, gl
        gx, gy = ds * self._c - dl * self._s, ds * self._s + dl * self._c  # the gradient in world axes
        n = math.sqrt(gx * gx + gy * gy + 1.0)
        return -gx / n, -gy / n, 1.0 / n

    def pitch(self, x: float, y: float, heading: float) -> float:
        """The ground's rise (rad, positive uphill) along ``heading`` (rad, world yaw) at (x, y)."""
        nx, ny, nz = self.normal(x, y)
        return math.atan2(-(nx * math.cos(heading) + ny * math.sin(heading)), nz)


@dataclass(frozen=True)
class _Waves:
    """Rough ground's plane waves in the ground frame, scaled to +-amplitude over the ground's extent,
    flat at the start (:data:`ROUGH_FLAT_M`, :data:`ROUGH_RAMP_M`)."""

    k: FloatArray  #: (N, 2) wave vectors (rad/m) along (along, left)
    phase: FloatArray  #: (N,) rad
    scale: float  #: m per unit of the summed waves
    _rows: tuple[tuple[float, float, float], ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        rows = tuple((float(a), float(b), float(c)) for (a, b), c in zip(self.k, self.phase))
        object.__setattr__(self, "_rows", rows)

    def _ramp(self, s: FloatArray) -> FloatArray:
        return np.clip((np.abs(s) - ROUGH_FLAT_M) / (ROUGH_RAMP_M - ROUGH_FLAT_M), 0.0, 1.0)

    def raw(self, s: FloatArray, lat: FloatArray) -> FloatArray:
        return np.sin(np.multiply.outer(s, self.k[:, 0]) + np.multiply.outer(lat, self.k[:, 1]) + self.phase).sum(-1)

    def height(self, s: FloatArray, lat: FloatArray) -> FloatArray:
        return self.scale * self.raw(s, lat) * self._ramp(s)

    def at(self, s: float, lat: float) -> float:
        """:meth:`height` at one point (plain floats: the controller asks a few dozen times a step)."""
        ramp = min(max((abs(s) - ROUGH_FLAT_M) / (ROUGH_RAMP_M - ROUGH_FLAT_M), 0.0), 1.0)
        if ramp == 0.0:
            return 0.0
        total = 0.0
        for kx, ky, ph in self._rows:
            total += math.sin(kx * s + ky * lat + ph)
        return self.scale * total * ramp

    def gradient(self, s: float, lat: float) -> tuple[float, float]:
        arg = self.k[:, 0] * s + self.k[:, 1] * lat + self.phase
        cos, raw = np.cos(arg), float(np.sin(arg).sum())
        ramp = float(self._ramp(np.array(s)))
        dramp = (math.copysign(1.0, s) / (ROUGH_RAMP_M - ROUGH_FLAT_M)
                 if ROUGH_FLAT_M < abs(s) < ROUGH_RAMP_M else 0.0)
        gs = self.scale * (float(cos @ self.k[:, 0]) * ramp + raw * dramp)
        return gs, self.scale * float(cos @ self.k[:, 1]) * ramp


def _waves(r: Rough) -> _Waves:
    rng = np.random.default_rng(r.seed)
    lam = r.wavelength_m * rng.uniform(*ROUGH_WAVELENGTH_SPREAD, size=ROUGH_WAVES)
    ang = rng.uniform(0.0, math.pi, size=ROUGH_WAVES)
    k = (2 * math.pi / lam)[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    phase = rng.uniform(0.0, 2 * math.pi, size=ROUGH_WAVES)
    w = _Waves(k=k, phase=phase, scale=1.0)
    s, lat = _rough_grid(r, -BEHIND_M, AHEAD_M)
    peak = float(np.max(np.abs(w.raw(*np.meshgrid(s, lat)))))
    return _Waves(k=k, phase=phase, scale=r.amplitude_m / peak)


def _rough_spacing(r: Rough) -> float:
    """The spacing (m) of rough ground's height samples."""
    return min(ROUGH_SPACING_M, r.wavelength_m / ROUGH_SAMPLES_PER_WAVELENGTH)


def _rough_grid(r: Rough, a: float, b: float) -> tuple[FloatArray, FloatArray]:
    """Sample positions (m, along and left) of rough ground from ``a`` to ``b`` along."""
    dx = _rough_spacing(r)
    ncol = max(2, int(math.ceil((b - a) / dx)) + 1)
    nrow = max(2, int(math.ceil(2 * HALF_WIDTH_M / dx)) + 1)
    return np.linspace(a, b, ncol), np.linspace(-HALF_WIDTH_M, HALF_WIDTH_M, nrow)


# ---------------------------------------------------------------------- the ground in the model
def _quat(yaw: float, pitch: float) -> list[float]:
    """(w, x, y, z) of a turn ``yaw`` about +z after tilting +x up by ``pitch`` (rad)."""
    qz = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    qy = [math.cos(-pitch / 2), 0.0, math.sin(-pitch / 2), 0.0]
    out = np.zeros(4)
    mujoco.mju_mulQuat(out, np.array(qz), np.array(qy))
    return out.tolist()


def add_ground(spec: mujoco.MjSpec, ground: Ground, frame: GroundFrame) -> None:
    """Replace the flat floor of a bipedsim model's ``spec`` with ``ground`` laid in ``frame``: geoms
    named ``floor`` (the lowest level), ``floor_1``, ... with the floor's contact parameters and
    material; the friction of every geom set to the ground's; the ground recorded as the custom text
    :data:`GROUND_TEXT`."""
    floor = spec.geom(FLOOR_NAME)
    if floor is None:
        raise ConfigError("this model has no floor geom to replace", key="ground")
    if ground.friction is not None:
        # a contact takes the larger friction of its two geoms, or a sole's (priority): every geom's
        for g in spec.geoms:
            g.friction = [ground.friction, *list(g.friction)[1:]]
    if ground.shaped:
        terrain = Terrain(ground, frame)
        parts = _rough_parts(spec, terrain) if ground.rough is not None else _plane_parts(terrain)
        _place(spec, floor, parts)
    spec.add_text(name=GROUND_TEXT, data=json.dumps({"terms": ground.terms(), "frame": asdict(frame)},
                                                    sort_keys=True))


#: one ground geom: kind ("plane" | "box" | "hfield"), pos, quat, size, hfield name
_Part = tuple[str, list[float], list[float], list[float], str]


def _plane_parts(t: Terrain) -> list[_Part]:
    """The lowest level as a plane, each higher one as a box whose top is the level (tilted by the slope)."""
    g, f = t.ground, t.frame
    theta = math.atan(t._tan)
    quat = _quat(f.yaw, theta)
    normal = np.array([-math.sin(theta) * t._c, -math.sin(theta) * t._s, math.cos(theta)])
    base = min(lv for _, _, lv in g.levels())
    parts: list[_Part] = [("plane", [f.x, f.y, base], quat, [0.0, 0.0, 0.05], "")]
    for a, b, lv in g.levels():
        if lv <= base:
            continue
        mid = (a + b) / 2
        half_t = (lv - base + BASE_DEPTH_M) / 2 * math.cos(theta)
        top = np.array([f.x + mid * t._c, f.y + mid * t._s, lv + t._tan * mid])
        centre = top - half_t * normal
        parts.append(("box", centre.tolist(), quat, [(b - a) / 2 / math.cos(theta), PLANE_HALF_WIDTH_M, half_t],
                      ""))
    return parts


def _rough_parts(spec: mujoco.MjSpec, t: Terrain) -> list[_Part]:
    """One height field per level: the slope, the level and the waves in its heights."""
    g, f = t.ground, t.frame
    assert g.rough is not None and t._waves is not None
    parts: list[_Part] = []
    for i, (a, b, lv) in enumerate(g.levels()):
        s, lat = _rough_grid(g.rough, a, b)
        ss, ll = np.meshgrid(s, lat)  # rows along +left (row 0 at the right edge), columns along s
        h = t._tan * ss + lv + t._waves.height(ss, ll)
        lo, hi = float(h.min()), float(h.max())
        span = max(hi - lo, 1e-4)
        name = f"ground_{i}"
        hf = spec.add_hfield(name=name, nrow=h.shape[0], ncol=h.shape[1],
                             size=[(b - a) / 2, HALF_WIDTH_M, span, BASE_DEPTH_M])
        hf.userdata = np.round((h - lo) / span, 5).ravel().tolist()
        mid = (a + b) / 2
        parts.append(("hfield", [f.x + mid * t._c, f.y + mid * t._s, lo], _quat(f.yaw, 0.0), [1.0, 1.0, 1.0], name))
    return parts


def _place(spec: mujoco.MjSpec, floor: mujoco.MjsGeom, parts: list[_Part]) -> None:
    """Turn the floor into the first part and add the rest as copies of its contact settings."""
    types = {"plane": mujoco.mjtGeom.mjGEOM_PLANE, "box": mujoco.mjtGeom.mjGEOM_BOX,
             "hfield": mujoco.mjtGeom.mjGEOM_HFIELD}
    for i, (kind, pos, quat, size, hname) in enumerate(parts):
        g = floor if i == 0 else spec.worldbody.add_geom(
            name=f"{FLOOR_NAME}_{i}", contype=floor.contype, conaffinity=floor.conaffinity,
            friction=list(floor.friction), solref=list(floor.solref), solimp=list(floor.solimp),
            condim=floor.condim, material=floor.material)
        g.type, g.pos, g.quat, g.size = types[kind], pos, quat, size
        if hname:
            g.hfieldname = hname


def ground_geoms(model: mujoco.MjModel) -> frozenset[int]:
    """The ids of the ground's geoms: world-body geoms that collide with the body's."""
    return frozenset(g for g in range(model.ngeom) if model.geom_bodyid[g] == 0
                     and (int(model.geom_conaffinity[g]) & BODY_CONTYPE or int(model.geom_contype[g]) & 1))


def _ground_text(model: mujoco.MjModel) -> str | None:
    return model_text(model, GROUND_TEXT)


def ground_of(model: mujoco.MjModel) -> tuple[Ground, GroundFrame] | None:
    """The ground a model was built with (None: the flat floor)."""
    text = _ground_text(model)
    if text is None:
        return None
    d = json.loads(text)
    return Ground.parse(d["terms"], key=GROUND_TEXT), GroundFrame(**d["frame"])



def check_ground(terms: Sequence[str], key: str = "ground") -> Ground:
    """The ground of a file's ``ground:`` terms (an experiment's, a suite scenario's); a bad term raises
    ``ValueError("KEY[i]: ...")`` (the file's loader adds the file)."""
    try:
        return Ground.parse(list(terms), key=key)
    except ConfigError as exc:
        raise ValueError(f"{exc.key}: {exc.reason}") from None

#: terrains already made, by their model text (a sweep's rollouts share one)
_TERRAINS: dict[str, Terrain | None] = {}


def terrain_of(model: mujoco.MjModel) -> Terrain | GridTerrain | None:
    """Height queries of the ground a model was built with (its terms', or a height grid's:
    :mod:`bipedsim.model.ground_grid`); None for a flat floor at z = 0."""
    grid = grid_terrain_of(model)
    if grid is not None:
        return grid
    text = _ground_text(model)
    if text is None:
        return None
    if text not in _TERRAINS:
        got = ground_of(model)
        _TERRAINS[text] = Terrain(*got) if got is not None and got[0].shaped else None
    return _TERRAINS[text]


def with_ground(built: BuiltModel, ground: Ground, frame: GroundFrame) -> BuiltModel:
    """``built`` with its flat floor replaced by ``ground`` laid in ``frame`` (flat: ``built`` itself)."""
    if ground.flat:
        return built
    spec = mujoco.MjSpec.from_string(built.xml)
    add_ground(spec, ground, frame)
    model = spec.compile()
    return BuiltModel(xml=spec.to_xml(), model=model, plan=built.plan)


def start_frame_of(qpos: FloatArray, start: int, frame_time: float) -> GroundFrame:
    """A ground frame at a clip's root at frame ``start`` (``qpos`` (T, nq), free root first), its
    axis the root's course over the next :data:`HEADING_WINDOW_S` s (the root's yaw where the clip
    walks in place)."""
    end = min(len(qpos) - 1, start + max(1, int(round(HEADING_WINDOW_S / frame_time))))
    x, y = float(qpos[start, 0]), float(qpos[start, 1])
    dx, dy = float(qpos[end, 0]) - x, float(qpos[end, 1]) - y
    if math.hypot(dx, dy) >= MIN_COURSE_M:
        return GroundFrame(x=x, y=y, yaw=math.atan2(dy, dx))
    w, qx, qy, qz = (float(v) for v in qpos[start, 3:7])
    return GroundFrame(x=x, y=y, yaw=math.atan2(2 * (w * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz)))


#: the stretch of a clip (s) whose root course gives the walking direction, and the least travel (m)
#: over it that counts as walking somewhere
HEADING_WINDOW_S, MIN_COURSE_M = 2.0, 0.2


__all__ = ["GROUND_TEXT", "Ground", "GroundFrame", "Rough", "Step", "Terrain", "add_ground", "ground_geoms",
           "ground_of", "start_frame_of", "terrain_of", "with_ground"]
