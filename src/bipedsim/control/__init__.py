"""Controllers behind one interface (:class:`~bipedsim.control.base.Controller`), one per body kind,
found by profile in :data:`CONTROLLERS`: the humanoid's :class:`SimbiconController` (PD tracking, the
four-state gait FSM, SIMBICON balance, fade, resynchronisation, course control; gait sources
:class:`ClipSource` and :class:`PoseSource`) and the creature's :class:`CreatureController` (PD
tracking on ball joints, optional root support). This package never parses files except through
:func:`load_controller`.
"""

from __future__ import annotations

from bipedsim.control.base import CONTROLLERS, Controller
from bipedsim.control.config import ControllerConfig, load_controller
from bipedsim.control.creature import CreatureController
from bipedsim.control.creature_config import BipedGaitConfig, CreatureBalanceConfig, CreatureControlConfig
from bipedsim.control.fsm import GaitFSM
from bipedsim.control.reference import ClipSource, GaitSource, Hinges, PoseSource
from bipedsim.control.simbicon import SimbiconController

__all__ = ["CONTROLLERS", "BipedGaitConfig", "ClipSource", "Controller", "ControllerConfig", "CreatureBalanceConfig",
           "CreatureControlConfig", "CreatureController", "GaitFSM", "GaitSource", "Hinges", "PoseSource",
           "SimbiconController", "load_controller"]
