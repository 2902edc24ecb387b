"""Motion made from motion: creature breeding (:mod:`.breed`), motion graphs and Motion Script
(:mod:`.graph`) and motion-tile worlds (:mod:`.world`)."""

from __future__ import annotations
