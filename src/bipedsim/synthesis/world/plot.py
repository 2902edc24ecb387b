"""The paths plot: the map (tiles coloured by kind, gaps marked) and each creature's root path on it,
coloured by mode, in metres (x east, y north)."""

from __future__ import annotations

import os

import numpy as np

from bipedsim.files import atomic_writer
from bipedsim.synthesis.world.tiles import World

#: Tile colours by kind name (other kinds: grey by height).
TILE_COLOURS = {"ground": "#cfe3b4", "start": "#9fd39b", "goal": "#f2c879", "mountain": "#8c7b6b",
                "water": "#7fb2e5", "wall": "#444444"}
MODE_STYLES = {"walk": "-", "fly": "--", "swim": ":", "idle": "-"}
#: Figure size: a tile's side (inches) on a small map, and the largest side of the figure (inches, at 90
#: dpi 2700 pixels) -- a large map's tiles are drawn smaller.
TILE_INCHES = 0.55
MAX_FIGURE_INCHES = 30.0


def plot_paths(world: World, tracks: dict[str, tuple[np.ndarray, list[str]]],
               out: str | os.PathLike[str]) -> None:
    """Write a PNG of ``world`` with ``tracks``: name -> (root positions (T, 3) m, clip label per frame)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    rows, cols = world.shape
    t = world.tile
    inch = min(TILE_INCHES, MAX_FIGURE_INCHES / max(rows, cols))
    fig, ax = plt.subplots(figsize=(max(4.0, cols * inch), max(3.0, rows * inch + 0.8)), dpi=90)
    for r, row in enumerate(world.rows):
        for c, ch in enumerate(row):
            k = world.legend[ch]
            ax.add_patch(Rectangle((c * t, -(r + 1) * t), t, t, facecolor=TILE_COLOURS.get(k.name, "#bbbbbb"),
                                   edgecolor="white", linewidth=0.5))
            if ch in "SG":
                ax.text((c + 0.5) * t, -(r + 0.5) * t, ch, ha="center", va="center", fontsize=9, weight="bold")
    for ev in world.events:
        x, y = world.centre(*ev.at)
        w, h = (ev.width, t) if ev.axis == 0 else (t, ev.width)
        ax.add_patch(Rectangle((x - w / 2, y - h / 2), w, h, facecolor="black", alpha=0.6))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (name, (root, labels)) in enumerate(tracks.items()):
        col = colours[i % len(colours)]
        modes = [lab.split(">")[-1] for lab in labels]
        start = 0
        for j in range(1, len(modes) + 1):
            if j == len(modes) or modes[j] != modes[start]:
                seg = root[start:j + 1]
                ax.plot(seg[:, 0], seg[:, 1], MODE_STYLES.get(modes[start], "-"), color=col, linewidth=2,
                        label=f"{name}" if start == 0 else None)
                start = j
    ax.set_xlim(0, cols * t)
    ax.set_ylim(-rows * t, 0)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("paths (solid: walk, dashed: fly, dotted: swim)", fontsize=9)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=max(1, len(tracks)), fontsize=8, frameon=False)
    fig.tight_layout()
    with atomic_writer(out) as f:
        fig.savefig(f, format="png")
    plt.close(fig)
