"""Choosing a headless OpenGL backend for MuJoCo: EGL first, then OSMesa.

MuJoCo picks its GL backend from ``MUJOCO_GL`` when it first creates a context, once per process,
so rendering runs in a child process started with the backend that a quick probe (also a child
process) showed to work. If ``MUJOCO_GL`` is already set, only that backend is tried.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys

from bipedsim.errors import BipedsimError

BACKENDS = ("egl", "osmesa")
#: What each backend needs, for the error message (Debian/Ubuntu package names).
PACKAGES = {"egl": "libegl1 and libgl1-mesa-dri (Mesa EGL), or a GPU driver with EGL",
            "osmesa": "libosmesa6 (Mesa off-screen rendering)"}
PROBE = (
    "import mujoco\n"
    "m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><light pos=\"0 0 3\"/>"
    "<geom type=\"sphere\" size=\".2\"/></worldbody></mujoco>')\n"
    "r = mujoco.Renderer(m, 16, 16)\n"
    "d = mujoco.MjData(m)\n"
    "mujoco.mj_forward(m, d)\n"
    "r.update_scene(d)\n"
    "assert r.render().any()\n"
)


class RenderError(BipedsimError):
    """Headless rendering is impossible here (no working GL backend) or failed."""


#: Why each backend probed in this process did not render (backend -> the probe's last error line);
#: error messages say which backends were tried before the one used.
PROBE_FAILURES: dict[str, str] = {}


def backend_env(backend: str) -> dict[str, str]:
    env = dict(os.environ)
    env.pop("BIPEDSIM_MUJOCO_GL", None)
    env["MUJOCO_GL"] = backend
    env["PYOPENGL_PLATFORM"] = backend
    return env


def _probe(backend: str, timeout: float = 60.0) -> str | None:
    """None if ``backend`` renders, else why not (the child's last line of error)."""
    try:
        p = subprocess.run([sys.executable, "-c", PROBE], env=backend_env(backend), capture_output=True,
                           text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return "timed out"
    if p.returncode == 0:
        return None
    lines = [ln for ln in (p.stderr or p.stdout).strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else f"exit status {p.returncode}"


@functools.cache
def choose_backend(requested: str | None = None) -> str:
    """The first backend that renders: ``MUJOCO_GL`` if set, else EGL, else OSMesa."""
    wanted = requested if requested is not None else (os.environ.get("BIPEDSIM_MUJOCO_GL")
                                                      or os.environ.get("MUJOCO_GL"))
    candidates = (wanted,) if wanted else BACKENDS
    failures = []
    for b in candidates:
        why = _probe(b)
        if why is None:
            return b
        PROBE_FAILURES[b] = why
        failures.append(f"{b}: {why}")
    need = "; ".join(f"{b} needs {PACKAGES[b]}" for b in candidates if b in PACKAGES)
    if wanted and wanted not in PACKAGES:
        need = f"MUJOCO_GL={wanted!r} is not a headless backend; use one of {', '.join(BACKENDS)}"
    raise RenderError("no working OpenGL backend for headless rendering (" + "; ".join(failures) + "). "
                      + need + ".")


def backends_tried(used: str) -> str:
    """Which GL backends were tried to get ``used``, for error messages: "egl" or
    "osmesa, after egl failed: REASON"."""
    before = [f"{b} failed: {why}" for b, why in PROBE_FAILURES.items() if b != used]
    return used + (f", after {'; '.join(before)}" if before else "")
