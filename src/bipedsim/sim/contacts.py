"""How well a creature's planned stance feet really touch the floor: a rollout hook.

:class:`StanceContacts` is passed to :func:`~bipedsim.sim.runner.run_scenario` (``hooks=[...]``) with
a controller that has ``contact_state(data, t)`` (a creature's planned gait,
:class:`~bipedsim.control.creature.gait.PlannedGait`). From ``after_s`` on it counts, per
leg and control step, whether the leg is planned in stance and whether it touches the floor, and
reports:

- ``stance_share``: the share of a leg's planned stance time its foot is on the floor (1: no chatter);
- ``swing_share``: the share of its swing time it is on the floor (scuffing);
- ``by_decile``: the stance share in each tenth of the stance (late landings show as a low start);
- ``switches``: contact changes per stance (a foot bouncing on and off the floor);
- ``legs_down``: the share of the counted steps with 0, 1, ..., n legs on the floor (a body that
  bounces shows time with no leg down, a rocking one long spells on one leg).
"""

from __future__ import annotations

import mujoco
import numpy as np

from bipedsim.control.base import Controller


class StanceContacts:
    """A hook ``(t, data, ctrl)`` that tallies planned stance against real floor contact per leg."""

    def __init__(self, after_s: float = 1.0) -> None:
        self.after_s = after_s
        self.planned: list[list[bool]] = []
        self.down: list[list[bool]] = []
        self.progress: list[list[float]] = []

    def __call__(self, t: float, data: mujoco.MjData, ctrl: Controller) -> None:
        if t < self.after_s or not hasattr(ctrl, "contact_state"):
            return
        planned, down, prog = ctrl.contact_state(data, t)
        self.planned.append(planned)
        self.down.append(down)
        self.progress.append(prog)

    def summary(self) -> dict[str, list[float] | list[list[float]]]:
        """Per leg: ``stance_share``, ``swing_share``, ``switches`` (per stance) and ``by_decile``
        (10 shares per leg); ``legs_down`` (n + 1 shares); empty lists before any step was counted."""
        if not self.planned:
            return {"stance_share": [], "swing_share": [], "switches": [], "by_decile": [], "legs_down": []}
        st, dn = np.array(self.planned), np.array(self.down)
        prog = np.array(self.progress)
        n_st = np.maximum(st.sum(axis=0), 1)
        stance = ((st & dn).sum(axis=0) / n_st).tolist()
        swing = ((~st & dn).sum(axis=0) / np.maximum((~st).sum(axis=0), 1)).tolist()
        changes = (np.diff(dn.astype(int), axis=0) != 0) & st[1:] & st[:-1]
        starts = np.maximum((np.diff(st.astype(int), axis=0) == 1).sum(axis=0), 1)
        switches = (changes.sum(axis=0) / starts).tolist()
        deciles = []
        for i in range(st.shape[1]):
            m = st[:, i] & (prog[:, i] >= 0)
            b = np.minimum((prog[m, i] * 10).astype(int), 9)
            deciles.append([float(dn[m, i][b == k].mean()) if np.any(b == k) else float("nan") for k in range(10)])
        counts = np.bincount(dn.sum(axis=1), minlength=st.shape[1] + 1) / len(dn)
        return {"stance_share": stance, "swing_share": swing, "switches": switches, "by_decile": deciles,
                "legs_down": counts.tolist()}


__all__ = ["StanceContacts"]
