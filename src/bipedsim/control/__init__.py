"""PD tracking, the four-state gait FSM, SIMBICON balance, fade and resynchronisation.

``Controller(model, plan, source, config)`` maps (model, data, t) to joint torques. Sources:
:class:`ClipSource` (a reference clip, looped at gait events) and :class:`PoseSource` (SIMBICON key
poses). This package never parses files except through :func:`load_controller`.
"""

from __future__ import annotations

from bipedsim.control.config import ControllerConfig, load_controller
from bipedsim.control.controller import Controller
from bipedsim.control.fsm import GaitFSM
from bipedsim.control.reference import ClipSource, GaitSource, Hinges, PoseSource

__all__ = ["ClipSource", "Controller", "ControllerConfig", "GaitFSM", "GaitSource", "Hinges", "PoseSource",
           "load_controller"]
