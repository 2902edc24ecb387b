"""The one controller interface every body uses.

The rollout loop (``sim/rollout.py``), pushes, the recorder and fall detection see a controller only
through :class:`Controller`: they never reach into a particular controller's FSM, hinge tables or
sensors. A new body kind or control law is one new file that subclasses it and registers itself in
:data:`CONTROLLERS` (a name -> factory table, no if/elif).

Units: times in s, angles in rad, torques in N*m, forces in N; positions in the world frame, Z up.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from bipedsim.control.humanoid.balance import heading_of

FloatArray = npt.NDArray[np.float64]


class Controller(ABC):
    """Maps the simulation state to actuator controls for one body, and reports what the loop,
    pushes and the recorder need to know about it."""

    #: the model this controller drives (it may change damping or gains in it; see ``restore_model``)
    model: mujoco.MjModel
    #: the reference frame now (a float: playback between frames)
    frame: float = 0.0
    #: per tracked degree of freedom, the last control step's error against the reference (rad)
    tracking_error: FloatArray
    #: seconds between control steps; ``None``: every physics step
    control_dt: float | None = None
    #: the body pushes act on and fall detection watches (a body id: the pelvis, a creature's root)
    root_body: int = 1
    #: added to the PD targets (rad) on every control step, in :meth:`target_names` order, before the
    #: targets are held to their limits: a learned policy's residual (:mod:`bipedsim.envs`); None: none
    #: (today's controller, bit for bit)
    target_offset: FloatArray | None = None
    #: whether :attr:`target_offset` replaces the PD targets (absolute targets) instead of adding to them
    target_absolute: bool = False

    # ------------------------------------------------------------------ the control step
    def start_frame(self) -> int:
        """The clip frame a rollout starts from (its pose, and its velocity when :attr:`starts_moving`)."""
        return 0

    #: whether a rollout starts with the clip's velocity at :meth:`start_frame` (else at rest)
    starts_moving: bool = True

    @abstractmethod
    def reset(self, data: mujoco.MjData, frame: float | None = None, t: float = 0.0) -> None:
        """Start a rollout at reference ``frame`` (default: the controller's own start) at time ``t``."""

    @abstractmethod
    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, t: float, dt: float) -> FloatArray:
        """The controls (``data.ctrl`` values) for the next ``dt`` s from the state in ``data`` at ``t``."""

    @abstractmethod
    def restore_model(self) -> None:
        """Undo every change this controller made to the model (damping, gains, ranges)."""

    # ------------------------------------------------------------------ read-outs
    @abstractmethod
    def reference_qpos(self) -> FloatArray:
        """The reference pose now, as a full qpos."""

    @abstractmethod
    def reference_speed(self) -> float:
        """The reference's mean horizontal speed (m/s)."""

    @abstractmethod
    def actuator_torques(self) -> FloatArray:
        """The torque (N*m) each actuator was asked for on the last control step, shape (nu,)."""

    @abstractmethod
    def foot_names(self) -> tuple[str, ...]:
        """The feet whose contact forces :meth:`foot_forces` reports, in that order."""

    @abstractmethod
    def foot_forces(self, data: mujoco.MjData) -> list[float]:
        """Each foot's vertical contact force now (N), in :meth:`foot_names` order."""

    def target_names(self) -> tuple[str, ...]:
        """What each entry of :attr:`target_offset` offsets (a hinge's name; a ball joint's ``name:x``,
        ``:y``, ``:z`` rotation-vector components); () for a controller that takes no offset."""
        return ()

    def gait_state(self) -> int:
        """The gait machine's state (1-4 for the SIMBICON FSM); 0 for a controller without one."""
        return 0

    def time_in_state(self) -> float:
        """Seconds spent in the current gait state (0 without a gait machine)."""
        return 0.0

    def state_duration(self, state: int) -> float | None:
        """The nominal length (s) of gait ``state``, for pushes timed by phase; ``None``: no such state."""
        return None

    def foot_strikes(self) -> list[tuple[float, str]]:
        """(time s, foot) of every foot strike so far."""
        return []

    def heading(self, data: mujoco.MjData) -> float:
        """The root body's heading: its yaw about world Z (rad)."""
        return heading_of(data.xmat[self.root_body].reshape(3, 3))

    def course_progress(self, data: mujoco.MjData) -> tuple[float, float] | None:
        """(progress m along the reference's own course since reset, lateral offset m from it now,
        positive left), or None where the controller has no course (a walk in place, key poses)."""
        return None

    def set_external_force(self, active: bool, t: float) -> None:  # noqa: B027 - optional hook
        """Told whether an external force (a push) acts now; a controller may react (fade, sec. 4.4)."""

    def metrics(self) -> dict[str, Any]:
        """Controller-specific figures for the outcome (resynchronisations, support forces...)."""
        return {}


#: controller factories by body profile: ``(built model, clip, config) -> Controller``
CONTROLLERS: dict[str, Callable[..., Controller]] = {}


def register(profile: str) -> Callable[[Callable[..., Controller]], Callable[..., Controller]]:
    """Class decorator: the controller for bodies of ``profile`` ("humanoid", "creature")."""
    def deco(factory: Callable[..., Controller]) -> Callable[..., Controller]:
        CONTROLLERS[profile] = factory
        return factory
    return deco
