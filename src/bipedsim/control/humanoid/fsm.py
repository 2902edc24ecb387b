"""The four-state gait machine (SIMBICON form).

States 1 and 2: right stance, left swing; 3 and 4: left stance, right swing. State 1 (3) lasts a
fixed time; state 2 (4) ends when the swing foot touches the ground (after a minimum time), which
starts state 3 (1) with the feet's roles swapped.
"""

from __future__ import annotations

from dataclasses import dataclass, field

RIGHT, LEFT = "right", "left"


@dataclass
class GaitFSM:
    state1_time: float
    min_swing_time: float = 0.1
    contact_force: float = 30.0
    state: int = 1
    time_in_state: float = 0.0
    step_time: float = 0.0  #: time since the current stance began (states 1+2 or 3+4)
    strikes: list[tuple[float, str]] = field(default_factory=list)

    @property
    def stance(self) -> str:
        return RIGHT if self.state in (1, 2) else LEFT

    @property
    def swing(self) -> str:
        return LEFT if self.state in (1, 2) else RIGHT

    def update(self, dt: float, t: float, swing_force: float) -> str | None:
        """Advance by ``dt`` s. Returns the foot that just struck (starting a new stance), else None."""
        self.time_in_state += dt
        self.step_time += dt
        if self.state in (1, 3):
            if self.time_in_state >= self.state1_time:
                self.state += 1
                self.time_in_state = 0.0
            return None
        if self.step_time >= self.min_swing_time and swing_force > self.contact_force:
            foot = self.swing
            self.state = 3 if self.state == 2 else 1
            self.time_in_state = 0.0
            self.step_time = 0.0
            self.strikes.append((t, foot))
            return foot
        return None
