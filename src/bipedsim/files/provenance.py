"""What made an output: the versions of bipedsim and of the libraries that shape its results (imported
when asked: the command line imports this package at start-up and ``--help`` stays quick)."""

from __future__ import annotations

import platform

import bipedsim


def versions() -> dict[str, str]:
    """Versions of bipedsim and the libraries that shape its results."""
    import mujoco
    import numpy
    import scipy

    return {"bipedsim": bipedsim.__version__, "mujoco": mujoco.__version__, "numpy": numpy.__version__,
            "scipy": scipy.__version__, "python": platform.python_version()}
