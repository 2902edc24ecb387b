"""A sweep's output folder read back before it resumes: ``results.csv``'s rows checked against the
experiment (torn, malformed, foreign or edited rows dropped and run again) and rewritten in row order, and
``experiment.json``'s setup (run length, reference, noise, fall criteria) checked against this one."""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

from bipedsim.errors import BipedsimError, InputError
from bipedsim.experiments.experiment import Experiment, Row
from bipedsim.files import (
    atomic_write_text,
    json_kind,
    read_input_bytes,
    read_input_text,
)
from bipedsim.sim.rollout import OUTCOMES

RESULT_COLUMNS = ["index", "key", "controller", "magnitude", "direction", "duration", "state", "fraction", "start",
                  "vertical", "body", "ground", "repeat", "seed", "phase_offset", "outcome", "fall_time_s",
                  "fall_reason", "foot_strikes", "distance_m", "mean_speed_mps", "tracking_rmse_rad", "recovery_time_s",
                  "peak_com_deviation_m", "steps_to_recover", "sim_seconds", "wall_seconds"]
TIMING_COLUMNS = ("wall_seconds",)


#: Columns that always hold a finite number, and those that may be empty (a push at a start time has
#: no state; a survived rollout no fall time).
NUMERIC_COLUMNS = ("index", "magnitude", "direction", "duration", "vertical", "repeat", "seed", "phase_offset",
                   "foot_strikes",
                   "distance_m", "mean_speed_mps", "tracking_rmse_rad", "sim_seconds", "wall_seconds")
OPTIONAL_NUMERIC_COLUMNS = ("state", "fraction", "start", "fall_time_s", "recovery_time_s", "peak_com_deviation_m",
                            "steps_to_recover")
#: Columns that must equal the experiment's row of the same key (else the row is from an edited experiment).
PARAM_COLUMNS = ("index", "magnitude", "direction", "duration", "state", "fraction", "start", "vertical", "body",
                 "ground", "repeat", "seed", "phase_offset")
#: Malformed rows named in the one-line report (the rest are counted).
_REPORT_ROWS = 3


def read_results(path: Path) -> list[dict[str, str]]:
    """The rows of ``path`` that have a key and an outcome, for counting (an interrupted sweep's
    message); [] when there is no readable file. :func:`load_results` checks them properly."""
    if not path.exists():
        return []
    try:
        text = read_input_bytes(path, "csv").decode("utf-8", errors="replace")
        rows = list(csv.DictReader(io.StringIO(text, newline="")))
    except (BipedsimError, csv.Error):
        return []
    return [r for r in rows if r.get("key") and r.get("outcome")]


def _row_problem(rec: dict[str, str], expected: dict[str, Row]) -> str | None:
    """Why a results.csv record cannot stand for a rollout of this experiment, or None."""
    for col in NUMERIC_COLUMNS + OPTIONAL_NUMERIC_COLUMNS:
        v = rec[col]
        if v == "" and col in OPTIONAL_NUMERIC_COLUMNS:
            continue
        try:
            ok = math.isfinite(float(v))
        except ValueError:
            ok = False
        if not ok:
            return f"{col} is not a number: {v!r}"
    if rec["outcome"] not in OUTCOMES:
        return f"unknown outcome {rec['outcome']!r} (outcomes: {', '.join(OUTCOMES)})"
    row = expected.get(rec["key"])
    if row is None:
        return f"key {rec['key']!r} is not a rollout of this experiment"
    want = row.params()
    for col in PARAM_COLUMNS:
        w, v = want[col], rec[col]
        same = v == str(w) if isinstance(w, str) else v != "" and float(v) == float(w)
        if not same:
            return f"{col} {v!r} is not this experiment's {w!r} for key {rec['key']} (the experiment was edited?)"
    return None


def load_results(path: Path, rows: list[Row]) -> tuple[list[dict[str, str]], list[tuple[int, str]]]:
    """The rows of ``path`` (a sweep's results.csv) that are whole rollouts of this experiment, and
    (line number, why) for every other record: a torn last line (a crash or a full disk mid-write), a
    wrong column count, an unparsable number, an unknown outcome, a key not in the experiment or
    parameters that differ from it, a second row for one key. Raises :class:`BipedsimError` when the
    file cannot be read (:class:`~bipedsim.errors.InputError`: a folder, a device, above the size limit
    for CSV files), or is not a results file (its header is not :data:`RESULT_COLUMNS`)."""
    if not path.exists():
        return [], []
    raw = read_input_bytes(path, "csv")
    text = raw.decode("utf-8", errors="replace")  # a byte torn in a character shows as a bad value
    records: list[tuple[int, list[str]]] = []
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        for rec in reader:
            records.append((reader.line_num, rec))
    except csv.Error as exc:  # e.g. a NUL byte from a crash: keep what was read, the rest is torn
        records.append((reader.line_num, [f"<{exc}>"]))
    if not records:
        return [], []
    (_, header), body = records[0], records[1:]
    torn_last = bool(text) and not text.endswith(("\n", "\r"))
    if header != RESULT_COLUMNS:
        if not body:  # a header torn while the first row was written: nothing to keep
            return [], [(1, "the header line is incomplete")]
        raise BipedsimError(f"{path}: not a results file of this version of bipedsim sweep: its columns are "
                            f"{', '.join(header[:4])}, ...; expected {', '.join(RESULT_COLUMNS[:4])}, ...; move it "
                            "away or give another --out")
    expected = {r.key: r for r in rows}
    good: list[dict[str, str]] = []
    seen: dict[str, int] = {}
    problems: list[tuple[int, str]] = []
    for i, (line, rec) in enumerate(body):
        if i == len(body) - 1 and torn_last:
            problems.append((line, "the last line is cut short (an interrupted write)"))
            continue
        if len(rec) != len(RESULT_COLUMNS):
            problems.append((line, f"{len(rec)} columns, expected {len(RESULT_COLUMNS)}"))
            continue
        d = dict(zip(RESULT_COLUMNS, rec))
        why = _row_problem(d, expected)
        if why is None and d["key"] in seen:
            why = f"a second row for key {d['key']} (line {seen[d['key']]} has it)"
        if why is not None:
            problems.append((line, why))
            continue
        seen[d["key"]] = line
        good.append(d)
    return good, problems


def _report_dropped(path: Path, problems: list[tuple[int, str]]) -> str:
    shown = "; ".join(f"line {line}: {why}" for line, why in problems[:_REPORT_ROWS])
    more = f"; and {len(problems) - _REPORT_ROWS} more" if len(problems) > _REPORT_ROWS else ""
    return (f"{path}: dropped {len(problems)} malformed row(s), their rollouts run again ({shown}{more})")


def _check_not_foreign(results: Path, exp: Experiment, rows: list[Row]) -> None:
    """Refuse to drop a results file none of whose rows is a rollout of ``exp``: another experiment's
    results, which resuming would delete."""
    keys = {r.key for r in rows}
    theirs = read_results(results)
    if theirs and not any(r["key"] in keys for r in theirs):
        raise BipedsimError(f"--out {results.parent}: {results.name} holds {len(theirs)} row(s), none of them a "
                            f"rollout of experiment {exp.spec.name!r} ({exp.path}): another experiment's results? "
                            "Give another --out, or remove the file to start again")


def _setup(exp: Experiment) -> dict[str, Any]:
    """What every rollout of ``exp`` shares but a row's key does not hold: rows made under another
    setup are not rows of this one."""
    s = exp.spec
    out = {"seconds": s.seconds, "reference": exp.resolve(s.reference), "profile": s.profile, "support": s.support,
           "init_noise": s.init_noise, "replicas": None if s.replicas is None else asdict(s.replicas),
           "fall": None if s.fall is None else asdict(s.fall)}
    if s.ground:  # (a flat ground's setup reads as before)
        out["ground"] = list(s.ground)
    return out


def _read_setup(path: Path) -> dict[str, Any] | None:
    """The setup an ``experiment.json`` records; None when there is none to check against (no file, or
    an older record without one); :class:`InputError` for a file that is not a sweep's record."""
    if not path.exists():
        return None
    try:
        record = json.loads(read_input_text(path, "json"))
    except (ValueError, RecursionError) as exc:  # RecursionError: nesting deeper than json's parser goes
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(_not_a_record(f"not JSON: {why}"), path) from None
    if not isinstance(record, dict):
        raise InputError(_not_a_record(f"a JSON {json_kind(record)}, not an object"), path)
    if "setup" not in record:
        return None
    if not isinstance(record["setup"], dict):
        raise InputError(_not_a_record("its setup is not an object"), path)
    return record["setup"]


def _not_a_record(why: str) -> str:
    return (f"not a sweep's record ({why}), so the results beside it cannot be checked against this "
            "experiment; remove it to resume without that check, or remove results.csv to start again")


def _check_setup(out: Path, exp: Experiment) -> None:
    """Refuse to resume into results made with another run length, reference, noise or fall criteria
    (``experiment.json`` records them; an older record without them is not checked: it is rewritten;
    a file that is not a record at all is refused, as resuming would trust rows it cannot check)."""
    if not read_results(out / "results.csv"):
        return
    old = _read_setup(out / "experiment.json")
    if old is None:
        return
    new = json.loads(json.dumps(_setup(exp)))  # tuples as lists, as the record has them
    diff = [k for k in new if old.get(k) != new[k]]
    if diff:
        k = diff[0]
        raise BipedsimError(f"--out {out}: holds results made with {k} {old.get(k)}, this experiment has {k} "
                            f"{new[k]}; give another --out, or remove {out / 'results.csv'} to start again")


def _rewrite(path: Path, rows: list[dict[str, str]]) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=RESULT_COLUMNS)
    w.writeheader()
    for r in rows:
        w.writerow({k: r.get(k, "") for k in RESULT_COLUMNS})
    atomic_write_text(path, buf.getvalue())
