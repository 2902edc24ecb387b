"""The humanoid's controller: :class:`~bipedsim.control.humanoid.simbicon.SimbiconController` (PD tracking,
the four-state gait FSM, SIMBICON balance feedback with contact-weighted redistribution,
resynchronisation, stepping, course control) over a gait source (:mod:`.sources`), with its settings
(:mod:`.settings`) and constant tables (:mod:`.tables`)."""

from __future__ import annotations
