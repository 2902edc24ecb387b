"""bipedsim: physics-based character simulation on MuJoCo.

BVH motion capture -> :mod:`bipedsim.motion` -> :mod:`bipedsim.model` (MJCF bodies and reference
clips) -> :mod:`bipedsim.control` (PD + SIMBICON balance) -> :mod:`bipedsim.sim` (rollouts, pushes,
sweeps). Units are SI everywhere inside the package; the world is Z-up.
"""

from __future__ import annotations

import os as _os

__version__ = "0.1.0"

# MuJoCo refuses to import at all when MUJOCO_GL names an unknown backend. Keep the user's value for
# the renderer (which reports it clearly) and let everything else -- simulation needs no GL -- run.
_VALID_GL = ("glfw", "egl", "osmesa", "glx", "cgl", "wgl")
if _os.environ.get("MUJOCO_GL", "").lower() not in ("", *_VALID_GL):
    _os.environ["BIPEDSIM_MUJOCO_GL"] = _os.environ.pop("MUJOCO_GL")

from bipedsim.errors import BipedsimError, BVHError, ConfigError, ModelError  # noqa: E402

__all__ = ["BVHError", "BipedsimError", "ConfigError", "ModelError", "__version__"]
