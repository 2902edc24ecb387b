"""Resumable result rows for the benchmark scripts: a CSV written row by row, whose rows already there are
kept (and not run again) with ``--resume``."""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any


class Rows:
    """The rows done so far (by key) and a writer appending new ones; no file when ``path`` is None."""

    def __init__(self, path: str | None, fields: list[str], resume: bool, key: Callable[[dict[str, str]], str]):
        self.done: dict[str, dict[str, str]] = {}
        if path and resume and Path(path).exists():
            with open(path, newline="") as fh:
                self.done = {key(r): r for r in csv.DictReader(fh)}
        self._fh: IO[str] | None = None
        self._writer: Any = None
        if path:
            self._fh = open(path, "a" if self.done else "w", newline="")  # noqa: SIM115 - closed by close()
            self._writer = csv.DictWriter(self._fh, fieldnames=fields)
            if not self.done:
                self._writer.writeheader()

    def add(self, row: dict[str, object]) -> None:
        """Append one new row (flushed: an interrupted run keeps it)."""
        if self._writer is not None and self._fh is not None:
            self._writer.writerow(row)
            self._fh.flush()

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
