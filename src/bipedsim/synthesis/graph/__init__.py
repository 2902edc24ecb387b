"""Multi-layered motion graphs and Motion Script, producing reference clips."""

from __future__ import annotations

from bipedsim.synthesis.graph.build import FULL, GraphConfig, MotionGraph, build_graph, load_graph_config
from bipedsim.synthesis.graph.commands import build_graph_file, format_graph_summary, format_play_summary, play_script
from bipedsim.synthesis.graph.distance import align_2d, distance_matrix
from bipedsim.synthesis.graph.player import Player, PlayError
from bipedsim.synthesis.graph.script import ScriptError, parse
from bipedsim.synthesis.graph.store import read_graph

__all__ = ["FULL", "GraphConfig", "MotionGraph", "PlayError", "Player", "ScriptError", "align_2d", "build_graph",
           "build_graph_file", "distance_matrix", "format_graph_summary", "format_play_summary",
           "load_graph_config", "parse", "play_script", "read_graph"]
