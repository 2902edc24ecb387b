"""Motion-tile worlds: a creature crosses a 2D tile map by walking, flying or swimming.

World files (:mod:`.tiles`), creature files and their clips cut into loops (:mod:`.creature_file`), path
finding with the creature's modes and the motion priority per tile (:mod:`.path`), time warp + P(n)
blending (:mod:`.blend`), synthesis along the path (:mod:`.synth`), terrain events (:mod:`.events`),
environment-weighted breeding (:mod:`.breeding`), the paths plot (:mod:`.plot`), the MuJoCo scene and
video (:mod:`.scene`), the crossing in physics (:mod:`.physics`) and the ``bipedsim world`` command's work
(:mod:`.run`).
"""

from __future__ import annotations

from bipedsim.synthesis.world.blend import linear_weights, quadratic_weights, slerp, smoothstep_weights, warp_times
from bipedsim.synthesis.world.breeding import (
    ability_weights,
    bray_curtis,
    breed_world_files,
    format_world_breed_summary,
    mode_x,
    parent_weights,
)
from bipedsim.synthesis.world.creature_file import Creature, ModeClip, load_creature
from bipedsim.synthesis.world.events import best_direction
from bipedsim.synthesis.world.path import Path, choose_mode, find_path, path_modes, priority_scores
from bipedsim.synthesis.world.physics import SimulateSettings, simulate_crossing, world_grid
from bipedsim.synthesis.world.run import cross_world, format_creature_line, run_world
from bipedsim.synthesis.world.synth import Synthesis, synthesize
from bipedsim.synthesis.world.tiles import World, WorldError, load_world, parse_world

__all__ = ["Creature", "ModeClip", "Path", "SimulateSettings", "Synthesis", "World", "WorldError", "ability_weights",
           "best_direction", "bray_curtis", "breed_world_files", "choose_mode", "cross_world", "find_path",
           "format_creature_line", "format_world_breed_summary", "linear_weights", "load_creature", "load_world",
           "mode_x", "parent_weights", "parse_world", "path_modes", "priority_scores", "quadratic_weights",
           "run_world", "simulate_crossing", "slerp", "smoothstep_weights", "synthesize", "warp_times", "world_grid"]
