"""The world in MuJoCo: the terrain as a height field sampled from the map (mountains and walls raised,
water tiles sunk under a translucent surface at z = 0, gaps cut out), the creature's body (the creature
profile) played back on it, rendered by :mod:`bipedsim.render.video` (same GL backend choice, follow
camera and video writer as every other video of the project)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bipedsim.model.build import build_model
from bipedsim.motion.motion import Motion
from bipedsim.reference.retarget import retarget
from bipedsim.render.video import MODEL_FILE, TRAJECTORY_FILE, VideoOptions, render_video
from bipedsim.sim.recorder import SAMPLE_DTYPES, Trajectory
from bipedsim.synthesis.world.creature_file import Creature
from bipedsim.synthesis.world.physics import SimulateSettings, run_crossing
from bipedsim.synthesis.world.synth import Synthesis
from bipedsim.synthesis.world.tiles import World

FloatArray = npt.NDArray[np.float64]

#: Height-field samples per tile side (fine enough for a gap of a tenth of a tile).
SAMPLES_PER_TILE = 20
#: Most height-field samples (1000 x 1000): a large world is sampled more coarsely, never under
#: :data:`MIN_SAMPLES_PER_TILE` per tile side (the MJCF lists every sample as text).
MAX_HFIELD_SAMPLES = 1_000_000
MIN_SAMPLES_PER_TILE = 2
#: Thickness (m) of the height field's base below its lowest point.
HFIELD_BASE_M = 0.2
WATER_RGBA = "0.2 0.45 0.85 0.55"
FLOOR_LINE = '<geom name="floor"'


def samples_per_tile(world: World) -> int:
    """:data:`SAMPLES_PER_TILE`, fewer where the map would pass :data:`MAX_HFIELD_SAMPLES`."""
    rows, cols = world.shape
    fit = int(np.sqrt(MAX_HFIELD_SAMPLES / (rows * cols)))
    return max(MIN_SAMPLES_PER_TILE, min(SAMPLES_PER_TILE, fit))


def height_grid(world: World, samples: int | None = None) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Terrain heights (m) on a grid over the map, first row north (y = 0) as MuJoCo's ``elevation``
    lists them, ``samples`` per tile side (default :func:`samples_per_tile`); returns the grid and its x
    and y sample positions."""
    samples = samples_per_tile(world) if samples is None else samples
    rows, cols = world.shape
    xs = np.linspace(0.0, cols * world.tile, cols * samples + 1)
    ys = -np.linspace(0.0, rows * world.tile, rows * samples + 1)
    gx, gy = np.meshgrid(xs, ys)
    return world.terrain(np.stack([gx, gy], axis=-1)), xs, ys


def terrain_xml(world: World) -> tuple[str, str]:
    """(asset, worldbody) MJCF snippets: the height field and the water surfaces."""
    h, xs, ys = height_grid(world)
    lo, hi = float(h.min()), float(h.max())
    span = max(hi - lo, 1e-3)
    elev = " ".join(f"{v:.4f}" for v in ((h - lo) / span).ravel())
    w, d = float(xs[-1]), float(-ys[-1])
    asset = (f'<hfield name="terrain" nrow="{h.shape[0]}" ncol="{h.shape[1]}" '
             f'size="{w / 2:.4f} {d / 2:.4f} {span:.4f} {HFIELD_BASE_M}" elevation="{elev}"/>')
    body = [f'<geom name="floor" type="hfield" hfield="terrain" pos="{w / 2:.4f} {-d / 2:.4f} {lo:.4f}" '
            'material="grid" conaffinity="2" friction="1.5"/>']
    for r, row in enumerate(world.rows):
        for c, ch in enumerate(row):
            if world.legend[ch].water:
                x, y = world.centre(r, c)
                body.append(f'<geom type="box" pos="{x:.4f} {y:.4f} 0" size="{world.tile / 2:.4f} '
                            f'{world.tile / 2:.4f} 0.005" rgba="{WATER_RGBA}" contype="0" conaffinity="0"/>')
    return asset, "\n    ".join(body)


def scene_xml(body_xml: str, world: World) -> str:
    """The creature body's MJCF with its flat floor replaced by the world's terrain."""
    asset, body = terrain_xml(world)
    lines = body_xml.splitlines()
    out = []
    for ln in lines:
        if ln.strip().startswith(FLOOR_LINE):
            out.append("    " + body)
            continue
        out.append(ln)
        if ln.strip() == "<asset>":
            out.append("    " + asset)
    return "\n".join(out)


def write_scene(folder: str | os.PathLike[str], motion: Motion, world: World) -> None:
    """A folder :func:`bipedsim.render.video.render_video` reads: ``model.xml`` (body + terrain) and
    ``trajectory.npz`` (the motion retargeted onto the body, root kept where the world put it)."""
    built = build_model(motion, "creature")
    clip = retarget(motion, built.model, plan=built.plan, trim_glitches=False)
    qpos = clip.qpos.copy()
    qpos[:, 0:3] = motion.root_translation  # the world's placement, not retarget's floor levelling
    xml = scene_xml(built.xml, world)
    folder = Path(folder)
    (folder / MODEL_FILE).write_text(xml)
    t = motion.num_frames
    m = built.model
    zeros = {k: np.zeros((t,), dtype=v) for k, v in SAMPLE_DTYPES.items()}
    tr = Trajectory(time=np.arange(t) * motion.frame_time, qpos=qpos, qvel=np.zeros((t, m.nv)),
                    ctrl=np.zeros((t, m.nu)), contact_force=np.zeros((t, 1)), fsm_state=zeros["fsm_state"],
                    ref_frame=np.arange(t, dtype=float), ref_qpos=qpos, xfrc=np.zeros((t, m.nbody, 3)),
                    com=motion.root_translation.copy(), meta={"source": "bipedsim world"})
    tr.save(folder / TRAJECTORY_FILE)


def render_world_video(motion: Motion, world: World, out: str | os.PathLike[str], opts: object | None = None,
                       progress: bool = False) -> int:
    """Render ``motion`` on ``world`` to ``out`` (.mp4/.gif); returns the frame count."""
    o = opts if opts is not None else VideoOptions(distance=8.0, elevation=-25.0, label=False)
    with tempfile.TemporaryDirectory(prefix="bipedsim-world-") as tmp:
        write_scene(tmp, motion, world)
        return render_video(tmp, out, o, progress=progress, out_flag="--video")  # type: ignore[arg-type]


def render_simulated_video(world: World, creature: Creature, syn: Synthesis, modes: list[str],
                           out: str | os.PathLike[str], opts: object | None = None, *,
                           settings: SimulateSettings | None = None, progress: bool = False
                           ) -> tuple[dict[str, Any], int]:
    """The crossing in physics (:func:`~bipedsim.synthesis.world.physics.run_crossing`) and a video of it
    (.mp4/.gif: the body on the terrain, follow camera); returns the ``simulated`` block and the frame
    count (0: not simulated, no video)."""
    sim, built, traj = run_crossing(world, creature, syn, modes, settings=settings)
    if built is None or traj is None:
        return sim, 0
    o = opts if opts is not None else VideoOptions(distance=4.0, elevation=-20.0, label=False)
    with tempfile.TemporaryDirectory(prefix="bipedsim-world-sim-") as tmp:
        (Path(tmp) / MODEL_FILE).write_text(built.xml)
        traj.save(Path(tmp) / TRAJECTORY_FILE)
        return sim, render_video(tmp, out, o, progress=progress, out_flag="--video")  # type: ignore[arg-type]
