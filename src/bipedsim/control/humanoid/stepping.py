"""The reference's playback: the gait clock, the frame's advance and the resynchronisation at strikes.

The reference frame F (a float, unwrapped: it only grows) advances by ``dt_gait / frame_time`` per
control step, where the gait clock runs at the step tempo's rate (``fsm.tempo``). At every foot strike the
controller matches the reference's strike of that foot and records M = P_c / P_r, the simulated step time
over the reference's (eq. 7-8); with ``resync.enabled`` it moves the reference toward that strike, spread
over ``resync.spread`` s, and with ``resync.hold`` it holds the reference at the strike frame while the
swing foot is late (up to ``fsm.max_wait``). Times in s, frames in clip frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bipedsim.control.humanoid.feedback import ComState, capture_deviation, capture_excess, capture_rate
from bipedsim.control.humanoid.fsm import GaitFSM
from bipedsim.control.humanoid.settings import ResyncConfig, TempoConfig
from bipedsim.control.humanoid.sources import GaitSource
from bipedsim.control.settings import ControllerConfig


@dataclass
class ResyncEvent:
    """One foot strike as resynchronisation saw it."""

    time: float  #: s
    foot: str
    frame_before: float
    frame_after: float
    ratio: float  #: M = P_c / P_r


@dataclass
class Playback:
    """The gait clock and the bookkeeping of the strikes, reset with each rollout."""

    clock: float = 0.0  #: the gait clock (s): real time run at the tempo rate
    last_strike_time: float = 0.0  #: s, real time
    last_strike_clock: float = 0.0  #: s, on the gait clock
    last_strike_frame: float = 0.0  #: the reference strike frame last matched
    wait_time: float = 0.0  #: s the reference has been held at a strike frame
    pending_shift: float = 0.0  #: frames of resynchronisation still to apply
    resyncs: list[ResyncEvent] = field(default_factory=list)
    #: capture-point step timing: the deviation's running mean (m, sagittal, coronal; None until measured)
    capture_bias: tuple[float, float] | None = None
    #: the capture point's excess (m, sagittal, coronal) the last control step measured
    capture_excess: tuple[float, float] = (0.0, 0.0)

    def reset(self, frame: float, t: float) -> None:
        """A rollout starting at reference ``frame`` at time ``t``."""
        self.resyncs.clear()
        self.capture_bias, self.capture_excess = None, (0.0, 0.0)
        self.pending_shift = 0.0
        self.last_strike_time, self.last_strike_frame = t, frame
        self.clock = self.last_strike_clock = t


def tempo_rate(tc: TempoConfig, v_sagittal: float, speed: float) -> float:
    """The gait clock's rate (x real time): ``clamp(1 + gain e, min, max)``, ``e`` the sagittal COM
    velocity ``v_sagittal``'s excess over the walk's ``speed`` (m/s) beyond the deadband."""
    e = v_sagittal - speed
    e = e - tc.deadband if e > tc.deadband else (e + tc.deadband if e < -tc.deadband else 0.0)
    return min(max(1.0 + tc.gain * e, tc.min), tc.max)


def hurry(pb: Playback, cfg: ControllerConfig, src: GaitSource, frame: float, stance: str, com: ComState,
          omega: float, dt: float, rate: float) -> float:
    """Capture-point step timing (``balance.capture``) for one control step of ``dt`` s: the capture point's
    excess (:func:`~bipedsim.control.humanoid.feedback.capture_excess`) of the COM state ``com`` against
    ``stance``'s ankle at reference ``frame``, kept in ``pb`` with the deviation's running mean, and the
    gait clock's rate (x real time): ``rate`` (the step tempo's), raised to what the excess asks for while
    it is not 0, so a pushed body's swing ends early and its next step comes sooner. ``rate`` when off."""
    cc = cfg.balance.capture
    if not cc.enabled or omega <= 0.0:
        return rate
    dev = capture_deviation(com, src.com_reference(frame, stance), omega)
    bias = pb.capture_bias or dev
    a = min(1.0, dt / cc.bias_s)
    pb.capture_bias = (bias[0] + a * (dev[0] - bias[0]), bias[1] + a * (dev[1] - bias[1]))
    pb.capture_excess = capture_excess(cc, dev, bias)
    return max(rate, capture_rate(cc, pb.capture_excess)) if pb.capture_excess != (0.0, 0.0) else rate


def resync(pb: Playback, src: GaitSource, rc: ResyncConfig, frame: float, foot: str, t: float) -> float:
    """A strike of ``foot`` at time ``t`` with the reference at ``frame``: match it to that foot's next
    reference strike after the last matched one, record M, and return the frame (moved at once by
    ``resync.enabled`` with no spread; else the shift is left pending)."""
    target = src.next_strike(pb.last_strike_frame + 1e-3, foot)
    p_c = pb.clock - pb.last_strike_clock  # on the gait clock, as the reference's P_r
    before = frame
    ratio = 1.0
    if target is not None:
        p_r = max((target - pb.last_strike_frame) * src.frame_time, 1e-6)
        ratio = p_c / p_r
        if rc.enabled:
            delta = np.clip(rc.gain * (target - frame), -rc.max_frames, rc.max_frames)
            if rc.spread > 0:
                pb.pending_shift = float(delta)
            else:
                frame += float(delta)
        pb.last_strike_frame = target
    pb.last_strike_time, pb.last_strike_clock = t, pb.clock
    pb.resyncs.append(ResyncEvent(t, foot, before, frame, ratio))
    return frame


def advance(pb: Playback, src: GaitSource, cfg: ControllerConfig, fsm: GaitFSM, frame: float, dt: float,
            dt_gait: float) -> tuple[float, bool]:
    """The reference frame after a control step of ``dt`` s real time, ``dt_gait`` s on the gait clock:
    moved on by the clock and by the pending resynchronisation, and held just before the swing foot's
    strike frame while that foot is late (``resync.hold``). Also whether it is held."""
    nxt = frame + dt_gait / src.frame_time
    if pb.pending_shift:
        spread = cfg.resync.spread
        step = pb.pending_shift * (min(1.0, dt / spread) if spread > 0 else 1.0)
        if abs(pb.pending_shift - step) < 1e-9 or abs(step) >= abs(pb.pending_shift):
            step = pb.pending_shift
        nxt += step
        pb.pending_shift -= step
    if cfg.resync.hold and fsm.state in (2, 4):
        exp = src.next_strike(frame, fsm.swing)
        if exp is not None and nxt >= exp and pb.wait_time < cfg.fsm.max_wait:
            pb.wait_time += dt
            return exp - 1e-6, True
    return nxt, False
