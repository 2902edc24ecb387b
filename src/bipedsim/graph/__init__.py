"""Multi-layered motion graphs and Motion Script, producing reference clips."""

from __future__ import annotations

from bipedsim.graph.build import FULL, GraphConfig, MotionGraph, build_graph, load_graph_config
from bipedsim.graph.distance import align_2d, distance_matrix
from bipedsim.graph.player import Player, PlayError
from bipedsim.graph.script import ScriptError, parse

__all__ = ["FULL", "GraphConfig", "MotionGraph", "PlayError", "Player", "ScriptError", "align_2d", "build_graph",
           "distance_matrix", "load_graph_config", "parse"]
