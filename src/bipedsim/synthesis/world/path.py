"""Path finding over the tile graph with a creature's travel modes, and the motion priority per tile.

Nodes are (tile, mode) pairs a tile allows and the creature has; a step to one of the 8 neighbours (no
corner cut past a tile the mode cannot use) costs distance (tiles) x the tile's cost x the mode's cost;
a mode change, on a tile allowing both modes or at the edge between two tiles, costs
:data:`MODE_CHANGE_COST`. Shortest paths by
:func:`scipy.sparse.csgraph.dijkstra`. The path finder decides where to go; the motion priority then
decides how on each path tile.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from bipedsim.synthesis.world.tiles import TRAVEL_MODES, World, WorldError

#: Cost factor of each travel mode per tile stepped (flying and swimming take more effort than walking).
MODE_COST = {"walk": 1.0, "swim": 1.5, "fly": 2.0}
#: Cost (tile steps) of changing mode on a tile.
MODE_CHANGE_COST = 1.0
#: Motion priority: weight of the hard constraints (what the tile allows) and of the soft preferences.
HARD_WEIGHT, SOFT_WEIGHT = 0.6, 0.4
#: Scores closer than this are a tie (the previous tile's mode is kept).
TIE = 1e-9
NEIGHBOURS = [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)]


@dataclass
class Path:
    """Tiles from start to goal (row, column) and the mode the path finder used on each."""

    tiles: list[tuple[int, int]]
    finder_modes: list[str]
    cost: float

    def length_m(self, tile: float) -> float:
        """Length (m) of the polyline through the tile centres."""
        t = np.array(self.tiles, dtype=float)
        return float(np.sum(np.linalg.norm(np.diff(t, axis=0), axis=1)) * tile)


def _step_ok(world: World, r: int, c: int, dr: int, dc: int, mode: str) -> bool:
    rows, cols = world.shape
    r2, c2 = r + dr, c + dc
    if not (0 <= r2 < rows and 0 <= c2 < cols) or not world.allows(r2, c2, mode):
        return False
    return not (dr and dc) or (world.allows(r + dr, c, mode) and world.allows(r, c + dc, mode))


def find_path(world: World, modes: list[str], creature: str = "creature") -> Path:
    """The cheapest path from S to G using ``modes`` (travel modes). Raises :class:`WorldError` naming the
    creature and the tiles that block it when the goal cannot be reached."""
    modes = [m for m in TRAVEL_MODES if m in modes]
    rows, cols = world.shape
    nm = len(modes)

    def node(r: int, c: int, k: int) -> int:
        return (r * cols + c) * nm + k

    edges: list[tuple[int, int, float]] = []
    for r in range(rows):
        for c in range(cols):
            for k, m in enumerate(modes):
                if not world.allows(r, c, m):
                    continue
                for k2, m2 in enumerate(modes):
                    if k2 != k and world.allows(r, c, m2):
                        edges.append((node(r, c, k), node(r, c, k2), MODE_CHANGE_COST))
                for dr, dc in NEIGHBOURS:
                    for k2, m2 in enumerate(modes):
                        # a step keeps the mode, or changes it at the tile edge (orthogonal steps only)
                        if (k2 == k and _step_ok(world, r, c, dr, dc, m)) or (
                                k2 != k and not (dr and dc) and _step_ok(world, r, c, dr, dc, m2)):
                            cost = float(np.hypot(dr, dc)) * world.kind(r + dr, c + dc).cost * MODE_COST[m2]
                            edges.append((node(r, c, k), node(r + dr, c + dc, k2),
                                          cost + (MODE_CHANGE_COST if k2 != k else 0.0)))
    n = rows * cols * nm
    src, dst, w = (list(v) for v in zip(*edges)) if edges else ([], [], [])
    g = coo_matrix((w, (src, dst)), shape=(n, n)).tocsr()
    (sr, sc), (gr, gc) = world.start, world.goal
    starts = [node(sr, sc, k) for k, m in enumerate(modes) if world.allows(sr, sc, m)]
    if not starts:
        raise WorldError(f"{creature} cannot stand on the start tile ({world.kind(sr, sc).name}) with its modes "
                         f"{', '.join(modes)}", path=world.path)
    dist, pred = dijkstra(g, indices=starts, return_predecessors=True)
    goals = [node(gr, gc, k) for k in range(nm)]
    i, j = np.unravel_index(int(np.argmin(dist[:, goals])), (len(starts), nm))
    best = float(dist[i, goals[j]])
    if not np.isfinite(best):
        raise WorldError(_blocked(world, modes, creature), path=world.path)
    seq = [goals[j]]
    while seq[-1] != starts[i]:
        seq.append(int(pred[i, seq[-1]]))
    seq.reverse()
    tiles, used = [], []
    for v in seq:
        t, k = divmod(v, nm)
        rc = divmod(t, cols)
        if tiles and tiles[-1] == rc:
            used[-1] = modes[k]
            continue
        tiles.append(rc)
        used.append(modes[k])
    return Path(tiles=tiles, finder_modes=used, cost=best)


def _blocked(world: World, modes: list[str], creature: str) -> str:
    """Why the goal is out of reach: the tiles none of the creature's modes can use, by kind."""
    kinds: dict[str, list[str]] = {}
    for r, row in enumerate(world.rows):
        for c, ch in enumerate(row):
            if not any(m in world.legend[ch].modes for m in modes):
                kinds.setdefault(f"{ch!r} {world.legend[ch].name}", []).append(f"[{r}, {c}]")
    what = "; ".join(f"{k} at {', '.join(v[:8])}{' ...' if len(v) > 8 else ''}" for k, v in kinds.items())
    return (f"{creature} cannot reach the goal {list(world.goal)} from the start {list(world.start)} with its modes "
            f"({', '.join(modes)}): blocked by {what or 'nothing?'}; give it a mode those tiles allow or open a way")


# ---------------------------------------------------------------------- motion priority
def preference(modes: list[str]) -> dict[str, float]:
    """What a creature does best: 1 for its cheapest travel mode, cheapest cost / cost for the others."""
    best = min(MODE_COST[m] for m in modes)
    return {m: best / MODE_COST[m] for m in modes}


def priority_scores(allowed: list[str], modes: list[str], previous: str | None) -> dict[str, float]:
    """Score of each of the creature's ``modes`` on a tile allowing ``allowed``: 0.6 x hard (1 when the tile
    allows it) + 0.4 x soft (half what the creature does best, half whether it did it on the previous tile).
    A mode the tile forbids scores nothing (hard constraint)."""
    pref = preference(modes)
    out = {}
    for m in modes:
        if m not in allowed:
            continue
        soft = 0.5 * pref[m] + 0.5 * float(m == previous)
        out[m] = HARD_WEIGHT * 1.0 + SOFT_WEIGHT * soft
    return out


def choose_mode(allowed: list[str], modes: list[str], previous: str | None) -> str | None:
    """The mode with the highest priority score; a tie keeps ``previous`` (no flicker between modes)."""
    scores = priority_scores(allowed, modes, previous)
    if not scores:
        return None
    top = max(scores.values())
    tied = [m for m, s in scores.items() if top - s <= TIE]
    return previous if previous in tied else tied[0]


def path_modes(world: World, path: Path, modes: list[str]) -> list[str]:
    """The motion priority's mode on each path tile."""
    out: list[str] = []
    prev = None
    for (r, c), fm in zip(path.tiles, path.finder_modes):
        m = choose_mode(list(world.kind(r, c).modes), modes, prev) or fm
        out.append(m)
        prev = m
    return out
