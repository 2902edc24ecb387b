"""bipedsim: physics-based character simulation on MuJoCo.

BVH motion capture -> :mod:`bipedsim.motion` -> :mod:`bipedsim.model` (MJCF bodies and reference
clips) -> :mod:`bipedsim.control` (PD + SIMBICON balance) -> :mod:`bipedsim.sim` (rollouts, pushes,
sweeps). Units are SI everywhere inside the package; the world is Z-up.
"""

from __future__ import annotations

__version__ = "0.1.0"

from bipedsim.errors import BipedsimError, BVHError, ConfigError, ModelError

__all__ = ["BVHError", "BipedsimError", "ConfigError", "ModelError", "__version__"]
