"""Ground given as a sampled height grid (a tile world's terrain, a scanned patch): one MuJoCo height
field in place of a built model's flat floor, and height and normal queries of it.

A :class:`HeightGrid` holds heights (m) on a regular grid in the world frame (Z up): row ``i`` at
``y = y0 + i * dy``, column ``j`` at ``x = x0 + j * dx`` (row 0 is the grid's lowest y, as MuJoCo lays
a height field's first row). :func:`with_height_grid` turns the body's floor into that height field
(the floor's contact settings, friction and material kept) and records the grid's placement in the
model (custom text :data:`GRID_TEXT`; the heights are the height field's own data), so a saved
``model.xml`` draws it and :func:`grid_terrain_of` answers queries for any model built with it --
:func:`bipedsim.model.ground.terrain_of` returns it like the terms' terrain. Between samples the
height is interpolated on the two triangles of each cell MuJoCo's height-field collision uses.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.errors import ConfigError
from bipedsim.model.build import BuiltModel
from bipedsim.model.plan import FLOOR_NAME

FloatArray = npt.NDArray[np.float64]

#: the model's custom text holding a height grid's placement (JSON: hfield name, origin, spacing)
GRID_TEXT = "bipedsim.ground_grid"
#: the height field's name in the model
GRID_HFIELD = "ground_grid"
#: thickness (m) of the height field's solid base below its lowest sample
GRID_BASE_M = 0.5
#: least height span (m) of a grid (a flat grid is a height field of this span, all at its lowest level)
MIN_SPAN_M = 1e-4
#: most samples a grid may have (the MJCF lists every sample as text)
MAX_GRID_SAMPLES = 4_000_000


@dataclass(frozen=True)
class HeightGrid:
    """Ground heights (m, world Z) sampled on a regular grid: ``heights[i, j]`` at
    ``(x0 + j * dx, y0 + i * dy)`` (m, world frame)."""

    heights: FloatArray  #: (rows, cols) m; row 0 at the lowest y
    x0: float  #: m, world x of column 0
    y0: float  #: m, world y of row 0
    dx: float  #: m between columns (> 0)
    dy: float  #: m between rows (> 0)

    def __post_init__(self) -> None:
        h = np.asarray(self.heights, dtype=float)
        if h.ndim != 2 or min(h.shape) < 2:
            raise ConfigError(f"a height grid needs at least 2 x 2 samples, got shape {h.shape}", key="ground")
        if h.size > MAX_GRID_SAMPLES:
            raise ConfigError(f"a height grid has at most {MAX_GRID_SAMPLES} samples, got {h.size}", key="ground")
        if not np.all(np.isfinite(h)):
            raise ConfigError("a height grid's heights must be finite numbers", key="ground")
        if not (self.dx > 0 and self.dy > 0 and math.isfinite(self.dx) and math.isfinite(self.dy)):
            raise ConfigError(f"a height grid's spacing must be positive, got dx={self.dx!r}, dy={self.dy!r}",
                              key="ground")
        object.__setattr__(self, "heights", h)

    @property
    def size(self) -> tuple[float, float]:
        """The grid's extent (m) along x and y."""
        rows, cols = self.heights.shape
        return (cols - 1) * self.dx, (rows - 1) * self.dy

    @property
    def centre(self) -> tuple[float, float]:
        """The grid's centre (m, world x and y)."""
        w, d = self.size
        return self.x0 + w / 2, self.y0 + d / 2


@dataclass
class GridTerrain:
    """Height and normal queries of a :class:`HeightGrid` (world frame, m, Z up), the surface MuJoCo's
    height field has: each cell split into two triangles along its diagonal from (i, j) to (i+1, j+1).
    Outside the grid, the nearest edge's height."""

    grid: HeightGrid

    def _cell(self, x: float, y: float) -> tuple[int, int, float, float]:
        g = self.grid
        rows, cols = g.heights.shape
        u = min(max((x - g.x0) / g.dx, 0.0), cols - 1.0)
        v = min(max((y - g.y0) / g.dy, 0.0), rows - 1.0)
        j, i = min(int(u), cols - 2), min(int(v), rows - 2)
        return i, j, u - j, v - i

    def height(self, x: float, y: float) -> float:
        """The ground's height (m) at world (x, y)."""
        i, j, fu, fv = self._cell(x, y)
        h = self.grid.heights
        h00, h11 = h[i, j], h[i + 1, j + 1]
        if fu >= fv:  # the triangle (i, j), (i, j+1), (i+1, j+1)
            return float(h00 + fu * (h[i, j + 1] - h00) + fv * (h11 - h[i, j + 1]))
        return float(h00 + fv * (h[i + 1, j] - h00) + fu * (h11 - h[i + 1, j]))

    def heights(self, xy: FloatArray) -> FloatArray:
        """:meth:`height` at points ``xy`` (..., 2) (m)."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        return np.array([self.height(float(a), float(b)) for a, b in pts]).reshape(np.shape(xy)[:-1])

    def normal(self, x: float, y: float) -> tuple[float, float, float]:
        """The ground's unit normal at world (x, y) (the triangle's under it)."""
        i, j, fu, fv = self._cell(x, y)
        h, g = self.grid.heights, self.grid
        if fu >= fv:
            gx, gy = (h[i, j + 1] - h[i, j]) / g.dx, (h[i + 1, j + 1] - h[i, j + 1]) / g.dy
        else:
            gx, gy = (h[i + 1, j + 1] - h[i + 1, j]) / g.dx, (h[i + 1, j] - h[i, j]) / g.dy
        n = math.sqrt(gx * gx + gy * gy + 1.0)
        return float(-gx / n), float(-gy / n), float(1.0 / n)

    def pitch(self, x: float, y: float, heading: float) -> float:
        """The ground's rise (rad, positive uphill) along ``heading`` (rad, world yaw) at (x, y)."""
        nx, ny, nz = self.normal(x, y)
        return math.atan2(-(nx * math.cos(heading) + ny * math.sin(heading)), nz)


def add_height_grid(spec: mujoco.MjSpec, grid: HeightGrid) -> None:
    """Turn the flat floor of a bipedsim model's ``spec`` into ``grid``'s height field (the floor
    geom keeps its name, contact settings, friction and material) and record the grid's placement
    as the custom text :data:`GRID_TEXT`."""
    floor = spec.geom(FLOOR_NAME)
    if floor is None:
        raise ConfigError("this model has no floor geom to replace", key="ground")
    h = grid.heights
    lo, hi = float(h.min()), float(h.max())
    span = max(hi - lo, MIN_SPAN_M)
    w, d = grid.size
    hf = spec.add_hfield(name=GRID_HFIELD, nrow=h.shape[0], ncol=h.shape[1],
                         size=[w / 2, d / 2, span, GRID_BASE_M])
    hf.userdata = ((h - lo) / span).ravel().tolist()
    cx, cy = grid.centre
    floor.type = mujoco.mjtGeom.mjGEOM_HFIELD
    floor.pos = [cx, cy, lo]
    floor.quat = [1.0, 0.0, 0.0, 0.0]
    floor.size = [1.0, 1.0, 1.0]
    floor.hfieldname = GRID_HFIELD
    spec.add_text(name=GRID_TEXT, data=json.dumps({"hfield": GRID_HFIELD, "x0": grid.x0, "y0": grid.y0,
                                                   "dx": grid.dx, "dy": grid.dy, "lo": lo, "span": span},
                                                  sort_keys=True))


def with_height_grid(built: BuiltModel, grid: HeightGrid) -> BuiltModel:
    """``built`` with its flat floor replaced by ``grid``'s height field."""
    spec = mujoco.MjSpec.from_string(built.xml)
    add_height_grid(spec, grid)
    model = spec.compile()
    return BuiltModel(xml=spec.to_xml(), model=model, plan=built.plan)


def model_text(model: mujoco.MjModel, name: str) -> str | None:
    """The model's custom text ``name`` (how a ground is kept in ``model.xml``), or None."""
    tid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, name)
    if tid < 0:
        return None
    adr, size = model.text_adr[tid], model.text_size[tid]
    return bytes(model.text_data[adr:adr + size - 1]).decode("utf-8")


def _grid_text(model: mujoco.MjModel) -> str | None:
    return model_text(model, GRID_TEXT)


def height_grid_of(model: mujoco.MjModel) -> HeightGrid | None:
    """The height grid a model was built with (None: none), its heights read from the height field."""
    text = _grid_text(model)
    if text is None:
        return None
    d = json.loads(text)
    hid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_HFIELD, d["hfield"])
    if hid < 0:
        raise ConfigError(f"the model's {GRID_TEXT} names height field {d['hfield']!r}, which it lacks", key="ground")
    rows, cols = int(model.hfield_nrow[hid]), int(model.hfield_ncol[hid])
    adr = int(model.hfield_adr[hid])
    data = np.asarray(model.hfield_data[adr:adr + rows * cols], dtype=float).reshape(rows, cols)
    return HeightGrid(heights=d["lo"] + d["span"] * data, x0=d["x0"], y0=d["y0"], dx=d["dx"], dy=d["dy"])


#: terrains already made, by their model text and height field (a sweep's rollouts share one)
_GRID_TERRAINS: dict[tuple[str, bytes], GridTerrain] = {}


def grid_terrain_of(model: mujoco.MjModel) -> GridTerrain | None:
    """Height queries of the height grid a model was built with; None where it has none."""
    text = _grid_text(model)
    if text is None:
        return None
    grid = height_grid_of(model)
    assert grid is not None
    key = (text, grid.heights.tobytes())
    if key not in _GRID_TERRAINS:
        _GRID_TERRAINS[key] = GridTerrain(grid)
    return _GRID_TERRAINS[key]


__all__ = ["GRID_TEXT", "GridTerrain", "HeightGrid", "add_height_grid", "grid_terrain_of", "height_grid_of",
           "with_height_grid"]
