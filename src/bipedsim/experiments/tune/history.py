"""``history.csv``: one row per candidate scored (its number, generation, score and terms, pushes survived,
walk length, parameter values), appended as each finishes and read back whole rows only (a torn last line
is scored again). Floats are written so they read back exactly."""

from __future__ import annotations

import csv
import io
import math
import os
from pathlib import Path
from typing import Any

from bipedsim.errors import BipedsimError, OutputError
from bipedsim.experiments.tune.objective import TERMS
from bipedsim.experiments.tune.spec import Tune
from bipedsim.experiments.tune.state_file import (
    HISTORY_FILE,
    STATE_FILE,
)
from bipedsim.files import (
    atomic_write_text,
    os_reason,
    read_input_bytes,
)

#: history.csv's columns before the parameters' (one column per dotted key) and after them
HEAD_COLUMNS = ["candidate", "generation", "score", *TERMS, "survived", "rollouts", "walk_s"]
TAIL_COLUMNS = ["wall_seconds"]


def history_columns(tune: Tune) -> list[str]:
    return HEAD_COLUMNS + tune.keys + TAIL_COLUMNS


def _load_history(path: Path, columns: list[str]) -> dict[int, dict[str, str]]:
    """The whole rows of history.csv by candidate number (a torn last line is dropped: that candidate
    is scored again); :class:`InputError` for one that cannot be read (a folder, a device, above the size
    limit for CSV files)."""
    if not path.exists():
        return {}
    # a byte torn in a character shows as a bad value in its row, which is dropped
    text = read_input_bytes(path, "csv").decode("utf-8", errors="replace")
    rows = list(csv.reader(io.StringIO(text, newline="")))
    if not rows:
        return {}
    if rows[0] != columns:
        raise BipedsimError(f"{path}: its columns are not this tune's ({', '.join(rows[0][:3])}, ...); give "
                            f"another --out, or remove {HISTORY_FILE} and {STATE_FILE} to start again")
    body = rows[1:]
    if body and not text.endswith(("\n", "\r")):
        body = body[:-1]
    out: dict[int, dict[str, str]] = {}
    for rec in body:
        if len(rec) == len(columns):
            try:
                d = dict(zip(columns, rec))
                if math.isfinite(float(d["score"])):
                    out[int(d["candidate"])] = d
            except ValueError:
                continue
    return out


def _write_history(path: Path, columns: list[str], rows: list[dict[str, Any]], append: bool) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    if not append:
        w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k, "") for k in columns})
    if not append:
        atomic_write_text(path, buf.getvalue())
        return
    try:
        new = not path.exists() or path.stat().st_size == 0
        with open(path, "a", encoding="utf-8", newline="") as f:
            if new:
                f.write(",".join(columns) + "\n")
            f.write(buf.getvalue())
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        raise OutputError(f"{path}: cannot write: {os_reason(exc)}; the rows written before are kept "
                          "(run the same command again to resume)") from None


def _record(result: dict[str, Any], generation: int, values: dict[str, float]) -> dict[str, Any]:
    """A history row: floats written so they read back exactly (the resumed tune tells CMA-ES the same)."""
    row = {k: (repr(float(v)) if isinstance(v, float) else v) for k, v in result.items()}
    row["generation"] = generation
    row.update({k: repr(float(v)) for k, v in values.items()})
    return row
