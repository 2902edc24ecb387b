"""Controllers behind one interface (:class:`~bipedsim.control.base.Controller`), one per body kind,
found by profile in :data:`CONTROLLERS`: the humanoid's :class:`SimbiconController` (PD tracking, the
four-state gait FSM, SIMBICON balance, fade, resynchronisation, course control; gait sources
:class:`ClipSource` and :class:`PoseSource`) and the creature's :class:`CreatureController` (PD
tracking on ball joints, optional root support), in the packages :mod:`.humanoid` and :mod:`.creature`;
the controller file's settings in :mod:`.settings`. This package never parses files except through
:func:`load_controller`.
"""

from __future__ import annotations

from bipedsim.control.base import CONTROLLERS, Controller
from bipedsim.control.creature.controller import CreatureController
from bipedsim.control.creature.settings import BipedGaitConfig, CreatureBalanceConfig, CreatureControlConfig
from bipedsim.control.humanoid.fsm import GaitFSM
from bipedsim.control.humanoid.simbicon import SimbiconController
from bipedsim.control.humanoid.sources import ClipSource, GaitSource, Hinges, PoseSource
from bipedsim.control.settings import ControllerConfig, load_controller

__all__ = ["CONTROLLERS", "BipedGaitConfig", "ClipSource", "Controller", "ControllerConfig", "CreatureBalanceConfig",
           "CreatureControlConfig", "CreatureController", "GaitFSM", "GaitSource", "Hinges", "PoseSource",
           "SimbiconController", "load_controller"]
