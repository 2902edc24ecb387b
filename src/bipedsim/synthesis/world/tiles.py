"""World files: a 2D tile map (first row north), what each tile allows, terrain heights and events.

Tile ``(r, c)`` has its centre at ``x = (c + 0.5) * tile``, ``y = -(r + 0.5) * tile`` (metres, Z up).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.config import limit_from_env, load_yaml
from bipedsim.errors import ConfigError

FloatArray = npt.NDArray[np.float64]

#: Modes a creature travels in (a tile allows some of them); ``idle`` and ``jump`` are clips, not travel.
TRAVEL_MODES = ("walk", "fly", "swim")
#: Height (m) of a mountain tile's top and of a wall; depth (m) of water below its surface (z = 0).
MOUNTAIN_HEIGHT_M = 2.0
WALL_HEIGHT_M = 1.5
WATER_DEPTH_M = 1.0
#: Depth (m) of a gap cut for a jump event.
GAP_DEPTH_M = 1.0
#: Event kinds a world file may place.
EVENT_KINDS = ("jump",)

# ---------------------------------------------------------------------- limits
#: Tile side (m): from a tenth of a metre (smaller than any creature's foot) to 100 m (a crossing of a
#: few such tiles already takes minutes of motion). A creature also needs tiles of at least
#: :data:`MIN_TILE_BODY_FRACTION` of its body (checked when it crosses).
TILE_MIN_M, TILE_MAX_M = 0.1, 100.0
#: A tile kind's cost factor per step: from a hundredth to a hundred ordinary steps.
COST_MIN, COST_MAX = 0.01, 100.0
#: Terrain height (m) of a tile kind, above or below the ground: higher than any creature climbs or flies
#: in a clip.
HEIGHT_LIMIT_M = 100.0
#: Most tiles (rows x columns) a world may have: path finding takes about 3 s and 400 MB for 200 x 200
#: tiles (400 m a side at 2 m). Raised with ``BIPEDSIM_MAX_WORLD_CELLS``.
MAX_WORLD_CELLS = 40_000
#: A tile must be at least this fraction of a creature's body (its size, m) for the creature to cross it:
#: smaller tiles make a path shorter than a step and a motion of a few frames.
MIN_TILE_BODY_FRACTION = 0.25
#: Most events a world may place (at most one per tile; each is searched when the terrain is sampled).
MAX_EVENTS = 1000
#: Longest tile kind name (characters).
MAX_NAME_CHARS = 64


def max_world_cells() -> int:
    """:data:`MAX_WORLD_CELLS`, or ``BIPEDSIM_MAX_WORLD_CELLS`` where set."""
    return limit_from_env("world_cells", MAX_WORLD_CELLS)


class WorldError(ConfigError):
    """A world or creature file that cannot be used, or a world a creature cannot cross."""


@dataclass(frozen=True)
class TileKind:
    """What a tile character means: its name, the travel modes it allows, a cost factor per step and the
    terrain height (m) of its top (water: the bottom; its surface is z = 0)."""

    name: str
    modes: tuple[str, ...]
    cost: float = field(default=1.0, metadata={"min": COST_MIN, "max": COST_MAX, "unit": "x a step"})
    height: float = field(default=0.0, metadata={"min": -HEIGHT_LIMIT_M, "max": HEIGHT_LIMIT_M, "unit": "m"})
    water: bool = False


DEFAULT_LEGEND: dict[str, TileKind] = {
    ".": TileKind("ground", ("walk", "fly")),
    "S": TileKind("start", ("walk", "fly")),
    "G": TileKind("goal", ("walk", "fly")),
    "M": TileKind("mountain", ("fly",), height=MOUNTAIN_HEIGHT_M),
    "~": TileKind("water", ("swim", "fly"), height=-WATER_DEPTH_M, water=True),
    "#": TileKind("wall", (), height=WALL_HEIGHT_M),
}


@dataclass(frozen=True)
class Event:
    """A terrain event on one tile: ``kind`` (``jump``: a gap across the tile), ``at`` (row, column) and
    the gap's ``width`` (m) along ``axis`` (0: x, the gap runs north-south; 1: y, it runs east-west)."""

    kind: str
    at: tuple[int, int]
    width: float
    axis: int


@dataclass
class World:
    """A parsed world file."""

    path: str
    tile: float = field(metadata={"min": TILE_MIN_M, "max": TILE_MAX_M, "unit": "m"})
    rows: list[str] = field(default_factory=list)
    legend: dict[str, TileKind] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.rows), len(self.rows[0])

    def kind(self, r: int, c: int) -> TileKind:
        return self.legend[self.rows[r][c]]

    def allows(self, r: int, c: int, mode: str) -> bool:
        return mode in self.kind(r, c).modes

    def find(self, ch: str) -> tuple[int, int]:
        for r, row in enumerate(self.rows):
            if ch in row:
                return r, row.index(ch)
        raise WorldError(f"no {ch!r} tile", path=self.path)

    @property
    def start(self) -> tuple[int, int]:
        return self.find("S")

    @property
    def goal(self) -> tuple[int, int]:
        return self.find("G")

    def centre(self, r: float, c: float) -> FloatArray:
        """Centre (x, y) in metres of tile (r, c)."""
        return np.array([(c + 0.5) * self.tile, -(r + 0.5) * self.tile])

    def tile_of(self, xy: FloatArray) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """(rows, columns) of the tiles under points ``xy`` (..., 2) in metres (clipped to the map)."""
        xy = np.asarray(xy, dtype=float)
        r = np.clip(np.floor(-xy[..., 1] / self.tile), 0, self.shape[0] - 1).astype(np.int64)
        c = np.clip(np.floor(xy[..., 0] / self.tile), 0, self.shape[1] - 1).astype(np.int64)
        return r, c

    def heights(self) -> FloatArray:
        """(rows, cols) terrain height (m) of each tile's top (water: its bottom)."""
        return np.array([[self.legend[ch].height for ch in row] for row in self.rows])

    def terrain(self, xy: FloatArray) -> FloatArray:
        """Terrain height (m) under points ``xy`` (..., 2): the tile's height, a gap's floor inside a gap."""
        xy = np.asarray(xy, dtype=float)
        r, c = self.tile_of(xy)
        h = self.heights()[r, c]
        for ev in self.events:
            inside = self.in_gap(ev, xy) & (r == ev.at[0]) & (c == ev.at[1])
            h = np.where(inside, -GAP_DEPTH_M, h)
        return h

    def in_gap(self, ev: Event, xy: FloatArray) -> npt.NDArray[np.bool_]:
        """Whether points ``xy`` (..., 2) lie in event ``ev``'s gap (the strip of its width across its tile)."""
        centre = self.centre(*ev.at)
        return np.abs(np.asarray(xy)[..., ev.axis] - centre[ev.axis]) < ev.width / 2

    def environment_weights(self) -> dict[str, float]:
        """E = (MT_F, MT_W, MT_S) / MT_ALL: the share of tiles allowing flying, walking and swimming,
        MT_ALL = MT_F + MT_W + MT_S."""
        counts = {m: sum(m in self.legend[ch].modes for row in self.rows for ch in row) for m in TRAVEL_MODES}
        total = sum(counts.values())
        return {m: (counts[m] / total if total else 0.0) for m in TRAVEL_MODES}


# ---------------------------------------------------------------------- parsing
def _bounded(raw: Any, cls: type, name: str, path: str, key: str) -> float:
    """``raw`` as a number within the bounds of field ``name`` of dataclass ``cls`` (its metadata
    ``min``, ``max`` and ``unit``); else a :class:`WorldError` naming ``key``."""
    meta = next(f.metadata for f in fields(cls) if f.name == name)
    unit = meta.get("unit", "")
    try:
        if isinstance(raw, bool):
            raise TypeError
        value = float(raw)
    except (TypeError, ValueError):
        raise WorldError(f"must be a number ({unit}), got {raw!r}", path=path, key=key) from None
    if not (math.isfinite(value) and meta["min"] <= value <= meta["max"]):
        raise WorldError(f"must be between {meta['min']:g} and {meta['max']:g} {unit}, got {raw!r}", path=path,
                         key=key)
    return value


def _legend(raw: Any, path: str) -> dict[str, TileKind]:
    legend = dict(DEFAULT_LEGEND)
    if raw is None:
        return legend
    if not isinstance(raw, dict):
        raise WorldError("must map tile characters to {modes, cost, height}", path=path, key="legend")
    for ch, spec in raw.items():
        key = f"legend.{ch}"
        if not isinstance(ch, str) or len(ch) != 1:
            raise WorldError("a tile is one character", path=path, key=key)
        allowed = ("name", "modes", "cost", "height", "water")
        if not isinstance(spec, dict):
            raise WorldError(f"must be a mapping with keys {', '.join(allowed)}", path=path, key=key)
        unknown = [k for k in spec if k not in allowed]
        if unknown:
            raise WorldError(f"unknown key; allowed keys here: {', '.join(allowed)}", path=path,
                             key=f"{key}.{unknown[0]}")
        base = legend.get(ch, TileKind(name=ch, modes=()))
        raw_modes = spec.get("modes", list(base.modes))
        if not isinstance(raw_modes, list) or not all(isinstance(m, str) for m in raw_modes):
            raise WorldError(f"must be a list of travel modes ({', '.join(TRAVEL_MODES)}), got {raw_modes!r}",
                             path=path, key=f"{key}.modes")
        modes = tuple(raw_modes)
        bad = [m for m in modes if m not in TRAVEL_MODES]
        if bad:
            raise WorldError(f"unknown mode {bad[0]!r}; allowed: {', '.join(TRAVEL_MODES)}", path=path, key=key)
        cost = _bounded(spec.get("cost", base.cost), TileKind, "cost", path, f"{key}.cost")
        height = _bounded(spec.get("height", base.height), TileKind, "height", path, f"{key}.height")
        water = spec.get("water", base.water)
        if not isinstance(water, bool):
            raise WorldError(f"must be true or false, got {water!r}", path=path, key=f"{key}.water")
        name = spec.get("name", base.name)
        if not (isinstance(name, str) and 0 < len(name) <= MAX_NAME_CHARS and name.isprintable()):
            raise WorldError(f"must be printable text of 1 to {MAX_NAME_CHARS} characters, got {name!r}",
                             path=path, key=f"{key}.name")
        legend[ch] = TileKind(name, modes, cost, height, water)
    return legend


def _allowed(legend: dict[str, TileKind]) -> str:
    return ", ".join(f"{ch!r} {k.name}" for ch, k in legend.items())


def _rows(raw: Any, legend: dict[str, TileKind], path: str) -> list[str]:
    if not isinstance(raw, list) or not raw or not all(isinstance(r, str) for r in raw):
        raise WorldError("must be a list of strings, one per row of tiles (first row north)", path=path, key="rows")
    width = len(raw[0])
    limit = max_world_cells()
    if len(raw) * width > limit:  # before any per-tile work
        raise WorldError(f"{len(raw)} rows x {width} columns = {len(raw) * width} tiles; a world has at most {limit} "
                         "(path finding takes time and memory with every tile): use larger tiles, or set "
                         "BIPEDSIM_MAX_WORLD_CELLS to allow more", path=path, key="rows")
    for r, row in enumerate(raw):
        if len(row) != width:
            raise WorldError(f"row {r} has {len(row)} tiles, row 0 has {width}: every row must have the same "
                             "number of tiles", path=path, key="rows")
        for c, ch in enumerate(row):
            if ch not in legend:
                raise WorldError(f"row {r}, column {c}: unknown tile {ch!r}; allowed: {_allowed(legend)} "
                                 "(more kinds go in legend:)", path=path, key="rows")
    for ch, what in (("S", "start"), ("G", "goal")):
        n = sum(row.count(ch) for row in raw)
        if n != 1:
            raise WorldError(f"needs exactly one {what} tile {ch!r}, found {n}", path=path, key="rows")
    return list(raw)


def _gap_axis(rows: list[str], legend: dict[str, TileKind], r: int, c: int) -> int:
    """The axis the path crosses a gap along: x when the tile's walkable neighbours lie east/west (the gap
    then runs north-south), y when they lie north/south; x on a tie."""
    def walk(rr: int, cc: int) -> int:
        return int(0 <= rr < len(rows) and 0 <= cc < len(rows[0]) and "walk" in legend[rows[rr][cc]].modes)
    ew = walk(r, c - 1) + walk(r, c + 1)
    ns = walk(r - 1, c) + walk(r + 1, c)
    return 1 if ns > ew else 0


def _events(raw: Any, rows: list[str], legend: dict[str, TileKind], tile: float, path: str) -> list[Event]:
    if raw is None:
        return []
    if not isinstance(raw, list):
        raise WorldError("must be a list of {kind, at: [row, column], width}", path=path, key="events")
    if len(raw) > MAX_EVENTS:
        raise WorldError(f"{len(raw)} events; a world places at most {MAX_EVENTS}", path=path, key="events")
    out: list[Event] = []
    placed: dict[tuple[int, int], int] = {}
    n_rows, n_cols = len(rows), len(rows[0])
    for i, ev in enumerate(raw):
        key = f"events[{i}]"
        if not isinstance(ev, dict) or "at" not in ev:
            raise WorldError("must be a mapping {kind, at: [row, column], width}", path=path, key=key)
        unknown = [k for k in ev if k not in ("kind", "at", "width")]
        if unknown:
            raise WorldError("unknown key; allowed keys here: kind, at, width", path=path, key=f"{key}.{unknown[0]}")
        kind = ev.get("kind", "jump")
        if kind not in EVENT_KINDS:
            raise WorldError(f"unknown kind {kind!r}; allowed: {', '.join(EVENT_KINDS)}", path=path, key=key)
        at = ev["at"]
        if not (isinstance(at, list) and len(at) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                                              for v in at)):
            raise WorldError(f"at must be [row, column] (integers), got {at!r}", path=path, key=key)
        r, c = at
        if (r, c) in placed:
            raise WorldError(f"at [{r}, {c}]: events[{placed[r, c]}] is already there; one event per tile",
                             path=path, key=key)
        placed[r, c] = i
        if not (0 <= r < n_rows and 0 <= c < n_cols):
            raise WorldError(f"at [{r}, {c}] is off the map: rows 0..{n_rows - 1}, columns 0..{n_cols - 1}",
                             path=path, key=key)
        if "walk" not in legend[rows[r][c]].modes:
            raise WorldError(f"row {r}, column {c}: a jump needs a walkable tile, found {rows[r][c]!r} "
                             f"({legend[rows[r][c]].name})", path=path, key=key)
        try:
            if isinstance(ev.get("width"), bool):
                raise TypeError
            width = float(ev.get("width", tile / 2))
        except (TypeError, ValueError):
            raise WorldError("width must be a number (m)", path=path, key=key) from None
        if not 0 < width < tile:
            raise WorldError(f"width must be > 0 and < the tile ({tile:g} m), got {width:g}", path=path, key=key)
        out.append(Event(kind=kind, at=(r, c), width=width, axis=_gap_axis(rows, legend, r, c)))
    return out


def parse_world(data: Any, path: str = "<world>") -> World:
    """A :class:`World` from a parsed YAML mapping; every error names ``path``, the key, the row/column
    and what is allowed."""
    if not isinstance(data, dict):
        raise WorldError("a world file is a mapping with tile, rows, legend, events", path=path)
    unknown = set(data) - {"tile", "rows", "legend", "events"}
    if unknown:
        raise WorldError(f"unknown key {sorted(unknown)[0]!r}; allowed: tile, rows, legend, events", path=path)
    tile = _bounded(data.get("tile", 2.0), World, "tile", path, "tile")
    legend = _legend(data.get("legend"), path)
    rows = _rows(data.get("rows"), legend, path)
    return World(path=path, tile=tile, rows=rows, legend=legend,
                 events=_events(data.get("events"), rows, legend, tile, path))


def load_world(path: str | os.PathLike[str]) -> World:
    """Read and validate a world YAML file."""
    return parse_world(load_yaml(path), str(Path(path)))
