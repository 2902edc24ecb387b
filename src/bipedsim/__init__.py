"""bipedsim: physics-based character simulation on MuJoCo.

BVH motion capture -> :mod:`bipedsim.motion` (reading) -> :mod:`bipedsim.model` (MJCF bodies) ->
:mod:`bipedsim.reference` (the clip made a reference for one body) -> :mod:`bipedsim.control` (PD +
SIMBICON balance, creature balance) -> :mod:`bipedsim.sim` (rollouts, pushes) ->
:mod:`bipedsim.experiments` (sweeps, tuning, regression suites); :mod:`bipedsim.synthesis` (breeding,
motion graphs, tile worlds) and :mod:`bipedsim.render` (videos, plots). Units are SI everywhere inside
the package; the world is Z-up.
"""

from __future__ import annotations

import importlib as _importlib
import os as _os

__version__ = "0.1.0"

# MuJoCo refuses to import at all when MUJOCO_GL names an unknown backend. Keep the user's value for
# the renderer (which reports it clearly) and let everything else -- simulation needs no GL -- run.
_VALID_GL = ("glfw", "egl", "osmesa", "glx", "cgl", "wgl")
if _os.environ.get("MUJOCO_GL", "").lower() not in ("", *_VALID_GL):
    _os.environ["BIPEDSIM_MUJOCO_GL"] = _os.environ.pop("MUJOCO_GL")

from bipedsim.errors import (  # noqa: E402
    BipedsimError,
    BVHError,
    ConfigError,
    InputError,
    ModelError,
    OutputError,
)

#: the Python API (:mod:`bipedsim.api`), loaded on first use so ``import bipedsim`` stays light
_API = ("run", "run_folder", "sweep", "tune", "SweepResult")


def __getattr__(name: str) -> object:
    # reached by name (PEP 562), not imported at the top: the API sits above every layer of the package,
    # and the modules below read this package's __version__
    if name in _API:
        return getattr(_importlib.import_module("bipedsim.api"), name)
    raise AttributeError(f"module 'bipedsim' has no attribute {name!r}")


__all__ = ["BVHError", "BipedsimError", "ConfigError", "InputError", "ModelError", "OutputError", "SweepResult",
           "__version__", "run", "run_folder", "sweep", "tune"]
