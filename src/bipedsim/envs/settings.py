"""The settings of :class:`~bipedsim.envs.track.TrackEnv`, the one home of its defaults: the reward's
terms and weights, the random pushes an episode draws, the action's scale and the episode length.

Each type takes a plain dict too (the environment's keyword arguments), validated by
:func:`bipedsim.config.from_dict` with errors naming the key.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

from bipedsim.config import from_dict
from bipedsim.errors import ConfigError


@dataclass(frozen=True)
class RewardWeights:
    """The reward of one environment step, a weighted sum of terms each in [0, 1] (penalties below 0):

    ``tracking * exp(-(e / tracking_scale)^2)``, ``e`` the RMS of the controller's tracking error (rad)
    on that step; ``+ upright * max(0, z)``, ``z`` the torso's (a creature: the root's) up axis's
    vertical component; ``- action * mean(a^2)`` over the action (rad^2); ``+ fall`` on the step the
    body falls or the simulation diverges."""

    #: weight of the tracking term: following the reference is the task
    tracking: float = field(default=1.0, metadata={"min": 0.0})
    #: rad; the RMS tracking error at which the tracking term is exp(-1) of its best
    tracking_scale: float = field(default=0.2, metadata={"gt": 0.0})
    #: weight of the upright term: staying up is what the balance controller is for
    upright: float = field(default=0.5, metadata={"min": 0.0})
    #: weight of the action penalty (per rad^2 of mean square residual): keeps a residual small
    action: float = field(default=0.01, metadata={"min": 0.0})
    #: reward on the step of a fall (a negative number: a penalty)
    fall: float = field(default=-10.0, metadata={"max": 0.0})


@dataclass(frozen=True)
class PushRanges:
    """Random pushes an episode draws on reset from the environment's generator: ``count`` pushes on the
    torso (a creature: its root), each with a uniform magnitude (N, horizontal), direction (degrees
    from the heading, 0 forward, 90 left), duration (s) and start (s); a start is moved earlier where
    the push would end after the episode."""

    magnitude: tuple[float, float] = (100.0, 300.0)  #: N
    direction: tuple[float, float] = (0.0, 360.0)  #: degrees from the heading
    duration: tuple[float, float] = (0.1, 0.2)  #: s
    start: tuple[float, float] = (1.0, 3.0)  #: s
    count: int = field(default=1, metadata={"min": 0, "max": 100})

    def check(self) -> None:
        for name in ("magnitude", "direction", "duration", "start"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ConfigError(f"needs low <= high, both finite; got ({lo:g}, {hi:g})", key=f"pushes.{name}")
        if self.magnitude[0] < 0 or self.duration[0] <= 0 or self.start[0] < 0:
            raise ConfigError("magnitudes and starts must be >= 0 and durations > 0", key="pushes")


@dataclass(frozen=True)
class TrackSettings:
    """What an episode of :class:`~bipedsim.envs.track.TrackEnv` is."""

    #: simulated seconds of an episode (then it is truncated)
    seconds: float = field(default=10.0, metadata={"gt": 0.0})
    #: rad; the residual action's bound per PD target (the action space is [-limit, limit])
    action_limit: float = field(default=0.3, metadata={"gt": 0.0, "max": math.pi})
    #: whether actions are absolute PD targets (rad) instead of residuals on the controller's
    absolute: bool = False
    #: standard deviation (rad/s, m/s) of the initial velocity noise an episode draws (0: none)
    init_noise: float = field(default=0.0, metadata={"min": 0.0})
    reward: RewardWeights = field(default_factory=RewardWeights)
    #: random pushes per episode; None: none
    pushes: PushRanges | None = None


def track_settings(seconds: float | None = None, *, action_limit: float | None = None, absolute: bool | None = None,
                   init_noise: float | None = None, reward: RewardWeights | dict[str, Any] | None = None,
                   pushes: PushRanges | dict[str, Any] | None = None) -> TrackSettings:
    """:class:`TrackSettings` from the environment's keyword arguments (None: the default), dicts
    validated into their types (errors name the key, e.g. ``reward.tracking``)."""
    given: dict[str, Any] = {k: v for k, v in (("seconds", seconds), ("action_limit", action_limit),
                                                ("absolute", absolute), ("init_noise", init_noise)) if v is not None}
    base = from_dict(TrackSettings, given)
    if isinstance(reward, dict):
        reward = from_dict(RewardWeights, reward, prefix="reward")
    if isinstance(pushes, dict):
        pushes = from_dict(PushRanges, pushes, prefix="pushes")
    if pushes is not None:
        pushes.check()
    return replace(base, reward=reward or RewardWeights(), pushes=pushes)
