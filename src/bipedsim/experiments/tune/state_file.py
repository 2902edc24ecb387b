"""``state.json``, a tune's optimiser state on disk: its file names and format (JSON of numbers and names
only: CMA-ES's construction arguments and every candidate evaluated, with its score), and the check of
every value before a resumed tune uses it; an earlier version's pickle is refused unread."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bipedsim.errors import InputError
from bipedsim.experiments.tune.spec import MAX_POPSIZE
from bipedsim.files import json_kind

STATE_FILE, HISTORY_FILE = "state.json", "history.csv"
#: The state file of earlier versions: a Python pickle, refused without being read (unpickling a file
#: runs whatever code it names, and a tune folder may come from anyone).
OLD_STATE_FILE = "state.pkl"


#: state.json's "format" and "version": a file without them, or of another version, is refused, not misread
STATE_FORMAT, STATE_VERSION = "bipedsim tune state", 3
#: state.json's keys, and those of its "strategy" (CMA-ES's construction arguments) and of a generation
STATE_KEYS = ("format", "version", "fingerprint", "parameters", "strategy", "generations")
STRATEGY_KEYS = ("x0", "sigma0", "popsize", "seed", "cma")
GENERATION_KEYS = ("candidates", "scores")


@dataclass
class Generation:
    """One generation as far as it was evaluated: its candidates in CMA-ES's coordinates (each
    parameter's range scaled to [0, 1]), in the order CMA-ES asked them, and their scores. All
    ``popsize`` of them unless the budget cut it short; only a whole generation is told to CMA-ES."""

    candidates: list[list[float]]
    scores: list[float]


class _Malformed(ValueError):
    """Where a state file departs from the format, and how (becomes one line naming the file)."""


def parse_state(text: str, path: Path, dims: int) -> tuple[str, list[str], dict[str, Any], list[Generation]]:
    """A state file's (fingerprint, parameter names, strategy, generations), every value checked: the
    format and version, each key and its kind, vectors of ``dims`` numbers in [0, 1], finite numbers, at
    most a generation's ``popsize`` candidates each with one score; an :class:`InputError` naming the
    file and the first departure otherwise. Nothing in the file is run or looked up, whatever it holds."""
    try:
        data = json.loads(text)
    except (ValueError, RecursionError) as exc:  # RecursionError: nesting deeper than json's parser goes
        raise _bad_state(path, f"not JSON: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    try:
        if not isinstance(data, dict) or data.get("format") != STATE_FORMAT:
            raise _Malformed(f"no \"format\": \"{STATE_FORMAT}\"")
        if data.get("version") != STATE_VERSION:
            raise _Malformed(f"format version {data.get('version')!r}; this bipedsim reads version {STATE_VERSION}")
        _keys(data, STATE_KEYS, "the file")
        fingerprint = data["fingerprint"]
        if not isinstance(fingerprint, str):
            raise _Malformed(f"fingerprint: expected a string, got a JSON {json_kind(fingerprint)}")
        keys = data["parameters"]
        if not isinstance(keys, list) or len(keys) != dims or not all(isinstance(k, str) for k in keys):
            raise _Malformed(f"parameters: expected the names of {dims} parameters")
        strategy = _strategy(data["strategy"], dims)
        generations = _generations(data["generations"], dims, strategy["popsize"])
    except _Malformed as exc:
        raise _bad_state(path, str(exc)) from None
    return fingerprint, keys, strategy, generations


def _bad_state(path: Path, why: str) -> InputError:
    return InputError(f"not a state file of this version of bipedsim tune ({why}); give another --out, or remove "
                      f"{STATE_FILE} and {HISTORY_FILE} to start again", path)


def _keys(data: Any, keys: tuple[str, ...], where: str) -> None:
    if not isinstance(data, dict):
        raise _Malformed(f"{where}: expected an object, got a JSON {json_kind(data)}")
    if set(data) != set(keys):
        odd = sorted(set(data) ^ set(keys))[0]
        raise _Malformed(f"{where}: {'unknown' if odd in data else 'missing'} key {odd!r}; expected "
                         f"{', '.join(keys)}")


def _number(v: Any, where: str, low: float = -math.inf, high: float = math.inf) -> float:
    """``v`` as a float when it is a finite JSON number within [low, high]."""
    try:
        ok = not isinstance(v, bool) and isinstance(v, int | float) and low <= float(v) <= high
    except OverflowError:  # an integer beyond any float
        ok = False
    if not ok or not math.isfinite(float(v)):
        limits = "" if math.isinf(low) and math.isinf(high) else f" in [{low:g}, {high:g}]"
        raise _Malformed(f"{where}: expected a finite number{limits}, got {str(v)[:40]}")
    return float(v)


def _vector(v: Any, dims: int, where: str) -> list[float]:
    """A candidate: ``dims`` numbers in [0, 1] (CMA-ES's coordinates)."""
    if not isinstance(v, list) or len(v) != dims:
        raise _Malformed(f"{where}: expected a list of {dims} numbers in [0, 1]")
    return [_number(x, f"{where}[{i}]", 0.0, 1.0) for i, x in enumerate(v)]


def _integer(v: Any, where: str, low: int, high: int) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
        raise _Malformed(f"{where}: expected an integer in [{low}, {high}], got {str(v)[:40]}")
    return v


def _strategy(v: Any, dims: int) -> dict[str, Any]:
    _keys(v, STRATEGY_KEYS, "strategy")
    if not isinstance(v["cma"], str):
        raise _Malformed(f"strategy.cma: expected a version string, got a JSON {json_kind(v['cma'])}")
    return {"x0": _vector(v["x0"], dims, "strategy.x0"), "sigma0": _number(v["sigma0"], "strategy.sigma0", 0.0, 1.0),
            "popsize": _integer(v["popsize"], "strategy.popsize", 1, MAX_POPSIZE),
            "seed": _integer(v["seed"], "strategy.seed", 0, 2**63), "cma": v["cma"]}


def _generations(v: Any, dims: int, popsize: int) -> list[Generation]:
    if not isinstance(v, list):
        raise _Malformed(f"generations: expected a list, got a JSON {json_kind(v)}")
    out = []
    for i, g in enumerate(v):
        where = f"generations[{i}]"
        _keys(g, GENERATION_KEYS, where)
        xs, scores = g["candidates"], g["scores"]
        if not isinstance(xs, list) or not 1 <= len(xs) <= popsize:
            raise _Malformed(f"{where}.candidates: expected a list of 1 to {popsize} (popsize) candidates")
        if not isinstance(scores, list) or len(scores) != len(xs):
            raise _Malformed(f"{where}.scores: expected a list of {len(xs)} scores, one per candidate")
        out.append(Generation([_vector(x, dims, f"{where}.candidates[{j}]") for j, x in enumerate(xs)],
                              [_number(f, f"{where}.scores[{j}]") for j, f in enumerate(scores)]))
    return out
