"""The creature's controller: :class:`~bipedsim.control.creature.controller.CreatureController` (PD
tracking on ball joints, optional root support) and its legged balance and gait (virtual forces through
stance legs, foot placement), with its settings (:mod:`.settings`)."""

from __future__ import annotations
