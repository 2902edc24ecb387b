"""Terminal progress bars on stderr (tqdm, imported when a bar is drawn), sized to the terminal with a
fallback where it reports no size; none when stderr is not a terminal, so logs and pipes get nothing
extra."""

from __future__ import annotations

import os
import shutil
import sys
from typing import Any

#: Terminal size (columns, rows) used where the terminal reports none (0 x 0: some pseudo-terminals,
#: CI consoles, containers started without a size), where tqdm would otherwise draw nothing.
FALLBACK_SIZE = (80, 24)


def stderr_size() -> tuple[int, int]:
    """Columns and rows of the terminal on stderr, each from :data:`FALLBACK_SIZE` where it reports 0
    (tqdm draws nothing on a terminal of 0 columns or 0 rows)."""
    try:
        cols, rows = os.get_terminal_size(sys.stderr.fileno())
    except (OSError, ValueError, AttributeError):
        cols, rows = 0, 0
    if not (cols and rows):
        fb_cols, fb_rows = shutil.get_terminal_size(FALLBACK_SIZE)
        cols, rows = cols or fb_cols or FALLBACK_SIZE[0], rows or fb_rows or FALLBACK_SIZE[1]
    return cols, rows


def progress_bar(total: float, desc: str, unit: str, *, force: bool = False, leave: bool = False) -> Any:
    """A tqdm bar on stderr when stderr is a terminal (or ``force``), else None: nothing extra goes to a
    log file or a pipe. Sized to the terminal, with a fallback size where it reports none."""
    if not (force or sys.stderr.isatty()):
        return None
    from tqdm import tqdm

    cols, rows = stderr_size()
    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, ncols=cols, nrows=rows, leave=leave)
