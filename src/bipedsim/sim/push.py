"""Pushes: external forces of chosen size, direction and timing, applied through ``xfrc_applied``.

Direction is in degrees in the character's heading frame at the moment the push starts (0 forward,
90 to the left), plus an optional vertical component (N). A push starts at a time (s) or at a gait
phase: the first moment after ``after`` seconds when the FSM is in ``state`` and has spent
``fraction`` of that state's nominal duration in it. ``xfrc_applied`` is cleared when it ends (MuJoCo
never clears it).

A push must lie inside the run it is given to (:func:`check_pushes`, called by every rollout: ``bipedsim
run``, sweeps and regression suites): a timed push must start and end by the end of the run, a
phase-timed one must be able to (``after`` + ``duration`` within the run). A push that starts after
the run has ended would leave a rollout that reports ``no_fall`` for a push it never received. A
phase-timed push can still miss (the gait never reaches its state in time); the rollout then reports
the outcome ``push_not_applied``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import mujoco
import numpy as np

from bipedsim.control.base import Controller
from bipedsim.errors import ConfigError
from bipedsim.sim.limits import MAX_ROLLOUT_S

#: Seconds of walking before a phase-timed push may start (the gait settles first).
DEFAULT_AFTER_S = 2.0
#: The body a push acts on unless it names another: the humanoid's torso; a body without a torso
#: (a creature) is pushed at its root body, where its trunk is.
DEFAULT_PUSH_BODY = "torso"
#: Largest push force (N, horizontal or vertical) accepted: 100 kN is ~170 g on a 60 kg body, far past
#: any fall (the 2000 N of the push grid's top already topples it); beyond it a value is a typo.
MAX_PUSH_N = 100_000.0
#: A push may end this much (s) after the run's end and still count as within it (float rounding of
#: start + duration against the run length).
_END_SLACK_S = 1e-9


@dataclass(frozen=True)
class Push:
    magnitude: float  #: N, horizontal
    direction: float = 0.0  #: degrees from the heading, 0 forward, 90 left
    duration: float = 0.2  #: s
    start: float | None = None  #: s; or give ``state`` (+ ``fraction``)
    state: int | None = None  #: FSM state 1-4
    fraction: float = 0.5  #: of the state's nominal duration
    after: float = DEFAULT_AFTER_S  #: earliest time (s) for a phase-timed push
    vertical: float = 0.0  #: N, up positive
    #: the body pushed; the default, the torso, is the root body on a body without one (a creature)
    body: str = DEFAULT_PUSH_BODY

    def validate(self) -> None:
        """Each value on its own (the run length is :func:`check_pushes`'s); ``ValueError`` naming the key."""
        if not (0 <= self.magnitude <= MAX_PUSH_N):  # also NaN
            raise ValueError(f"magnitude: must be 0-{MAX_PUSH_N:g} N, got {self.magnitude}")
        if not abs(self.vertical) <= MAX_PUSH_N:
            raise ValueError(f"vertical: must be within +-{MAX_PUSH_N:g} N, got {self.vertical}")
        if not math.isfinite(self.direction):
            raise ValueError(f"direction: must be a finite number of degrees, got {self.direction}")
        if not (self.duration > 0 and math.isfinite(self.duration)):
            raise ValueError(f"duration: must be > 0 s, got {self.duration}")
        if self.start is None and self.state is None:
            raise ValueError("start: give a start time (s) or a gait phase (state and fraction)")
        if self.start is not None and self.state is not None:
            raise ValueError("start: give a start time or a gait phase, not both")
        if self.start is not None and not (self.start >= 0 and math.isfinite(self.start)):
            raise ValueError(f"start: must be >= 0 s, got {self.start}")
        if self.state is not None and self.state not in (1, 2, 3, 4):
            raise ValueError(f"state: FSM states are 1-4, got {self.state}")
        if not 0.0 <= self.fraction <= 1.0:
            raise ValueError(f"fraction: must be in [0, 1], got {self.fraction}")
        if not (self.after >= 0 and math.isfinite(self.after)):
            raise ValueError(f"after: must be >= 0 s, got {self.after}")

    def describe(self) -> str:
        """The push in the command line's ``MAG:DIR:DUR:START`` notation (START ``sSTATE.FRACTION``
        for a phase-timed push), for messages."""
        if self.start is not None:
            when = f"{self.start:g}"
        elif self.fraction < 1.0:
            when = f"s{self.state}." + (f"{self.fraction:.6f}".rstrip("0")[2:] or "0")
        else:  # the notation's digits after the dot cannot say 1
            when = f"state {self.state} at fraction 1"
        return f"{self.magnitude:g}:{self.direction:g}:{self.duration:g}:{when}"

    def earliest_end(self) -> float:
        """The earliest time (s) this push can be over: a timed one's end, a phase-timed one's if its
        state came right at ``after``."""
        return (self.start if self.start is not None else self.after) + self.duration

    def outside(self, seconds: float) -> str | None:
        """Why this push cannot lie inside a run of ``seconds`` s, or None."""
        if self.start is not None and self.start >= seconds:
            return f"starts at {self.start:g} s, after the run ends at {seconds:g} s"
        if self.start is None and self.after >= seconds:
            return (f"waits until {self.after:g} s of walking (after) for its gait phase, but the run ends at "
                    f"{seconds:g} s")
        if self.earliest_end() > seconds + _END_SLACK_S:
            start = f"starts at {self.start:g} s" if self.start is not None else \
                f"cannot start before {self.after:g} s (after)"
            return (f"{start} and lasts {self.duration:g} s: it would still act at the end of the run "
                    f"({seconds:g} s); a push must end within the run")
        return None

    @property
    def impulse(self) -> float:
        return self.magnitude * self.duration

    @staticmethod
    def parse(text: str) -> Push:
        """``MAG:DIR:DUR:START`` (N, degrees from heading, s, s) as on the command line; START may
        be ``sS.F`` for FSM state S at fraction F (e.g. ``s2.5`` = state 2, half way)."""
        parts = text.split(":")
        if len(parts) != 4:
            raise ConfigError(f"push {text!r}: expected MAG:DIR:DUR:START (N, degrees, s, s or sSTATE.FRACTION)",
                              key="--push")
        try:
            mag, direction, dur = (float(x) for x in parts[:3])
            start_txt = parts[3].strip()
            if start_txt.lower().startswith("s"):
                st, _, frac = start_txt[1:].partition(".")
                p = Push(magnitude=mag, direction=direction, duration=dur, state=int(st),
                         fraction=float("0." + frac) if frac else 0.5)
            else:
                p = Push(magnitude=mag, direction=direction, duration=dur, start=float(start_txt))
        except ValueError:
            raise ConfigError(f"push {text!r}: MAG, DIR, DUR and START must be numbers (START may be "
                              f"sSTATE.FRACTION)", key="--push") from None
        try:
            p.validate()
        except ValueError as exc:
            raise ConfigError(f"push {text!r}: {exc}", key="--push") from None
        return p


def check_pushes(pushes: list[Push], seconds: float, *, path: str | os.PathLike[str] | None = None,
                 key: str = "--push", seconds_key: str = "--seconds") -> None:
    """Raise :class:`ConfigError` unless ``seconds`` is a plausible run length (0 < s <=
    :data:`MAX_ROLLOUT_S`) and every push is valid and lies inside the run (see the module's text).

    ``path``, ``key`` and ``seconds_key`` say where the values came from (the command line's flags by
    default; experiment and suite loaders pass their file and keys)."""
    if not 0 < seconds <= MAX_ROLLOUT_S:  # also NaN
        raise ConfigError(f"must be a run length in (0, {MAX_ROLLOUT_S:g}] s, got {seconds}", path=path,
                          key=seconds_key)
    for p in pushes:
        try:
            p.validate()
        except ValueError as exc:
            raise ConfigError(f"push {p.describe()}: {exc}", path=path, key=key) from None
        why = p.outside(seconds)
        if why:
            raise ConfigError(f"push {p.describe()} {why}", path=path, key=key)


def random_pushes(seed: int, count: int, magnitude: tuple[float, float] = (100.0, 300.0),
                  duration: float = 0.2, window: tuple[float, float] = (2.0, 8.0), body: str = "torso",
                  direction: tuple[float, float] = (0.0, 360.0)) -> list[Push]:
    """``count`` pushes with uniform random magnitude (N), direction (degrees) and start time (s, in
    ``window``, in increasing order), from ``seed``."""
    rng = np.random.default_rng(seed)
    starts = np.sort(rng.uniform(*window, size=count))
    return [Push(magnitude=float(rng.uniform(*magnitude)), direction=float(rng.uniform(*direction)) % 360.0,
                 duration=duration, start=float(s), body=body) for s in starts]


@dataclass
class _Active:
    push: Push
    body: int
    force: np.ndarray
    start: float
    end: float


@dataclass
class PushSchedule:
    """Applies pushes during a rollout (a ``before_step`` hook) and tells the controller."""

    model: mujoco.MjModel
    pushes: list[Push]
    fired: list[_Active] = field(default_factory=list)
    pending: list[Push] = field(default_factory=list)

    def __post_init__(self) -> None:
        names = {self.model.body(i).name for i in range(self.model.nbody)}
        for p in self.pushes:
            if p.body not in names and p.body != DEFAULT_PUSH_BODY:
                raise ConfigError(f"unknown body {p.body!r}; bodies are {', '.join(sorted(names - {'world'}))}",
                                  key="push.body")
        self.pending = list(self.pushes)

    def check_controller(self, ctrl: Controller) -> None:
        """Every phase-timed push names a gait state this body's controller has."""
        for p in self.pushes:
            if p.state is not None and ctrl.state_duration(p.state) is None:
                raise ConfigError(f"push {p.describe()} is timed by gait state {p.state}, but this body's controller "
                                  "has no gait states; give a start time in seconds", key="push.state")

    def _due(self, p: Push, t: float, ctrl: Controller) -> bool:
        if p.start is not None:
            return t >= p.start
        if t < p.after or ctrl.gait_state() != p.state:
            return False
        return ctrl.time_in_state() >= p.fraction * (ctrl.state_duration(p.state) or 0.0)

    def _body(self, p: Push, ctrl: Controller) -> int:
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, p.body)
        return i if i >= 0 else ctrl.root_body

    def __call__(self, t: float, data: mujoco.MjData, ctrl: Controller) -> None:
        for p in list(self.pending):
            if self._due(p, t, ctrl):
                a = ctrl.heading(data) + math.radians(p.direction)
                force = np.array([p.magnitude * math.cos(a), p.magnitude * math.sin(a), p.vertical])
                self.fired.append(_Active(p, self._body(p, ctrl), force, t, t + p.duration))
                self.pending.remove(p)
        data.xfrc_applied[:] = 0.0
        active = False
        for a in self.fired:
            if a.start <= t < a.end:
                data.xfrc_applied[a.body, :3] += a.force
                active = True
        ctrl.set_external_force(active, t)

    @property
    def first_start(self) -> float | None:
        return min((a.start for a in self.fired), default=None)

    @property
    def last_end(self) -> float | None:
        return max((a.end for a in self.fired), default=None)
