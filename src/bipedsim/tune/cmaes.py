"""``bipedsim tune``: CMA-ES (pycma's ask/tell) over a controller's values, scored by rollouts.

The parameters are scaled to [0, 1] (``low`` .. ``high``) and CMA-ES keeps its samples there (pycma's
``bounds``, its default boundary transform); the start controller's values (clipped into the ranges)
are the initial mean. Candidates of a generation are scored in parallel (local processes or Ray, the
sweep's backends) and each is appended to ``history.csv`` as it finishes. The optimiser's state is
written to ``state.json`` (atomically) after each generation: CMA-ES's construction arguments (start,
step, population, seed) and every candidate it asked that was evaluated, with its score. JSON of
numbers only, so a state file from anywhere can be read without running anything; it is checked
(format, version, shapes, finite numbers, this tune's configuration) before use. Rerunning the same
command resumes: pycma's object is rebuilt by replaying those asks and tells from the same seed (each
replayed ask must give the recorded candidates exactly), CMA-ES asks the interrupted generation again
(the same candidates), the candidates already in ``history.csv`` are not scored again, and the run ends
with what an uninterrupted one would have found. ``best.yaml``, ``convergence.png`` and ``summary.json``
are rewritten after every generation.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import cma
import numpy as np
import yaml

from bipedsim import config
from bipedsim.errors import BipedsimError, ConfigError, InputError, OutputError
from bipedsim.io import (
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    os_reason,
    prepare_output_dir,
    progress_bar,
    read_input_bytes,
    read_input_text,
    versions,
)
from bipedsim.sim.sweep import backend_session, check_backend, json_kind, worker_count
from bipedsim.tune.evaluate import Setup, evaluate
from bipedsim.tune.objective import TERMS
from bipedsim.tune.spec import CONFIG_CLASSES, MAX_POPSIZE, Tune

STATE_FILE, HISTORY_FILE = "state.json", "history.csv"
#: The state file of earlier versions: a Python pickle, refused without being read (unpickling a file
#: runs whatever code it names, and a tune folder may come from anyone).
OLD_STATE_FILE = "state.pkl"
#: history.csv's columns before the parameters' (one column per dotted key) and after them
HEAD_COLUMNS = ["candidate", "generation", "score", *TERMS, "survived", "rollouts", "walk_s"]
TAIL_COLUMNS = ["wall_seconds"]
#: state.json's "format" and "version": a file without them, or of another version, is refused, not misread
STATE_FORMAT, STATE_VERSION = "bipedsim tune state", 3
#: state.json's keys, and those of its "strategy" (CMA-ES's construction arguments) and of a generation
STATE_KEYS = ("format", "version", "fingerprint", "parameters", "strategy", "generations")
STRATEGY_KEYS = ("x0", "sigma0", "popsize", "seed", "cma")
GENERATION_KEYS = ("candidates", "scores")


class Randn:
    """CMA-ES's normal samples from its own generator, seeded by the tune (pycma's ``randn`` option
    would take NumPy's global one, which other code in the process may draw from between generations)."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


def history_columns(tune: Tune) -> list[str]:
    return HEAD_COLUMNS + tune.keys + TAIL_COLUMNS


def _fingerprint(tune: Tune) -> str:
    """What a resumed tune must share with the one that wrote the folder (all but the budget: a tune
    may be continued with more ``evaluations``)."""
    spec = config.to_dict(tune.spec)
    spec.pop("evaluations")
    spec.pop("name")
    spec["controller"] = tune.controller_path  # resolved: the same file named from another folder is the same
    spec.pop("reference")  # resolved below
    ident = json.dumps({"spec": spec, "references": tune.references, "start": tune.start}, sort_keys=True,
                       default=str)
    return hashlib.sha1(ident.encode()).hexdigest()


@dataclass
class Generation:
    """One generation as far as it was evaluated: its candidates in CMA-ES's coordinates (each
    parameter's range scaled to [0, 1]), in the order CMA-ES asked them, and their scores. All
    ``popsize`` of them unless the budget cut it short; only a whole generation is told to CMA-ES."""

    candidates: list[list[float]]
    scores: list[float]


@dataclass
class TuneState:
    """A tune's optimiser: pycma's object (``es``), made from ``strategy`` (its construction arguments)
    and moved on by ``generations`` (asked, evaluated and, when whole, told)."""

    fingerprint: str
    strategy: dict[str, Any]
    es: Any
    generations: list[Generation] = field(default_factory=list)

    @property
    def generation(self) -> int:
        return len(self.generations)

    @property
    def evaluated(self) -> int:
        return sum(len(g.candidates) for g in self.generations)

    def candidates(self) -> list[tuple[int, list[float]]]:
        """(generation, CMA-ES coordinates) of every candidate evaluated, in candidate order (1, 2, ...)."""
        return [(n, x) for n, g in enumerate(self.generations, start=1) for x in g.candidates]

    def to_json(self, keys: list[str]) -> dict[str, Any]:
        """What state.json holds: numbers and names only (its size grows with the candidates evaluated)."""
        return {"format": STATE_FORMAT, "version": STATE_VERSION, "fingerprint": self.fingerprint,
                "parameters": keys, "strategy": self.strategy,
                "generations": [{"candidates": g.candidates, "scores": g.scores} for g in self.generations]}


def _new_state(tune: Tune) -> TuneState:
    """A fresh optimiser for ``tune``: CMA-ES from the start controller's values (clipped into the
    ranges), with the tune's step, population and seed."""
    s = tune.spec
    lo, hi = _bounds(tune)
    x0 = np.clip((np.array([tune.start_values()[k] for k in tune.keys]) - lo) / (hi - lo), 0.0, 1.0)
    opts = {"bounds": [0.0, 1.0], "seed": s.seed + 1, "randn": Randn(s.seed), "verbose": -9, "verb_log": 0,
            "verb_disp": 0}
    if s.popsize is not None:
        opts["popsize"] = s.popsize
    es = cma.CMAEvolutionStrategy(x0.tolist(), s.sigma, opts)
    strategy = {"x0": [float(v) for v in x0], "sigma0": float(s.sigma), "popsize": int(es.popsize), "seed": s.seed,
                "cma": cma.__version__}
    return TuneState(fingerprint=_fingerprint(tune), strategy=strategy, es=es)


def _bounds(tune: Tune) -> tuple[np.ndarray, np.ndarray]:
    ranges = np.array([tune.spec.parameters[k] for k in tune.keys], dtype=float)
    return ranges[:, 0], ranges[:, 1]


def _save_state(path: Path, state: TuneState, tune: Tune) -> None:
    # floats as repr writes them: they read back exactly, so the replay tells CMA-ES the same numbers
    atomic_write_text(path, json.dumps(state.to_json(tune.keys), allow_nan=False) + "\n")


def _load_state(out: Path, tune: Tune, has_history: bool) -> TuneState | None:
    """The saved state of the tune in ``out``, rebuilt; None for a fresh folder. Refused with one line
    (a :class:`BipedsimError`), never loaded: an earlier version's pickle, a file that is not this
    version's state, another tune's state, and one whose replay does not ask the recorded candidates."""
    old = out / OLD_STATE_FILE
    if old.exists() or old.is_symlink():
        raise InputError(f"a tune state of an earlier bipedsim: a Python pickle, which this version never opens "
                         f"(reading one can run any code it holds); give another --out, or remove {OLD_STATE_FILE} "
                         f"and {HISTORY_FILE} to start again", old)
    path = out / STATE_FILE
    if not (path.exists() or path.is_symlink()):
        if has_history:
            raise BipedsimError(f"--out {out}: holds {HISTORY_FILE} but no {STATE_FILE}: not a tune folder "
                                f"this version can resume; give another --out, or remove {HISTORY_FILE}")
        return None
    fingerprint, keys, strategy, generations = parse_state(read_input_text(path, "json"), path, len(tune.keys))
    state = _new_state(tune)
    mine = {k: v for k, v in state.strategy.items() if k != "cma"}
    if fingerprint != state.fingerprint or keys != tune.keys or {k: strategy[k] for k in mine} != mine:
        raise BipedsimError(f"--out {out}: holds a tune of another configuration (the tune file, its "
                            "controller or its references changed since); give another --out, or remove "
                            f"{STATE_FILE} and {HISTORY_FILE} to start again")
    _replay(state, generations, path, written_with=strategy["cma"])
    return state


def _replay(state: TuneState, generations: list[Generation], path: Path, written_with: str) -> None:
    """Move a fresh ``state`` on through the recorded ``generations`` as the tune that wrote them did
    (ask; tell when whole), in this process: the same seed gives the same candidates, which each replayed
    ask must give exactly (another cma or NumPy may sample otherwise: then the tune cannot resume)."""
    es = state.es
    for number, gen in enumerate(generations, start=1):
        es.stop()  # as the tune's loop checks it before each generation (pycma updates its record of it)
        asked = [np.asarray(x, dtype=float) for x in es.ask()]
        n = len(gen.candidates)
        if n > len(asked) or not all(np.array_equal(asked[i], gen.candidates[i]) for i in range(n)):
            raise InputError(f"generation {number}: CMA-ES asks other candidates than the state records (written "
                             f"with cma {written_with}, this is cma {cma.__version__}), so this tune cannot be "
                             f"resumed exactly; give another --out, or remove {STATE_FILE} and {HISTORY_FILE} to "
                             "start again", path)
        if n == len(asked):
            es.tell(asked, list(gen.scores))
        state.generations.append(gen)


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


def _setup(tune: Tune) -> Setup:
    e = tune.spec.experiment
    assert e is not None
    return Setup(references=tune.references, profile=tune.spec.profile, support=tune.spec.support,
                 rows=tuple(tune.experiment().rows()), seconds=e.seconds, init_noise=e.init_noise,
                 fall=None if e.fall is None else asdict(e.fall), objective=tune.spec.objective)


def _values(tune: Tune, x: list[float]) -> dict[str, float]:
    lo, hi = _bounds(tune)
    real = lo + np.asarray(x, dtype=float) * (hi - lo)
    return {k: float(v) for k, v in zip(tune.keys, real)}


def _say(message: str) -> None:
    print(f"bipedsim tune: {message}", file=sys.stderr)


class _Scorer:
    """Scores candidates not yet in the history, appending each row as it finishes."""

    def __init__(self, tune: Tune, out: Path, history: dict[int, dict[str, str]], run: Callable[..., Any],
                 bar: Any) -> None:
        self.tune, self.history, self.run, self.bar = tune, history, run, bar
        self.path, self.columns, self.setup = out / HISTORY_FILE, history_columns(tune), _setup(tune)

    def score(self, generation: int, candidates: list[tuple[int, dict[str, float]]]) -> list[float]:
        todo = [(n, v) for n, v in candidates if n not in self.history]
        for n, v in candidates:
            if n in self.history:
                self._check_same(n, v)
        values = dict(todo)
        tasks = [(n, config.to_dict(self.tune.settings(v)), self.setup) for n, v in todo]
        for res in self.run(tasks, evaluate):
            row = _record(res, generation, values[res["candidate"]])
            _write_history(self.path, self.columns, [row], append=True)
            self.history[res["candidate"]] = {k: str(v) for k, v in row.items()}
            if self.bar is not None:
                self.bar.update(1)
                self.bar.set_postfix(best=f"{self.best()[1]:.4g}")
        return [float(self.history[n]["score"]) for n, _ in candidates]

    def _check_same(self, number: int, values: dict[str, float]) -> None:
        rec = self.history[number]
        if any(float(rec[k]) != v for k, v in values.items()):
            raise BipedsimError(f"{self.path}: candidate {number}'s values differ from the tune's state (the file "
                                f"was edited?); remove {HISTORY_FILE} and {STATE_FILE} to start again")

    def best(self) -> tuple[int, float]:
        return min(((n, float(r["score"])) for n, r in self.history.items()), key=lambda p: (p[1], p[0]))


def run_tune(tune: Tune, out_dir: str | os.PathLike[str], workers: int = 1, backend: str = "local",
             progress: bool = True, say: Callable[[str], None] = _say) -> dict[str, Any]:
    """Tune ``tune``'s parameters into ``out_dir`` (resuming what is there); returns the summary.

    Candidate 0 is the start controller (the baseline, besides the budget); 1 .. ``evaluations`` are
    CMA-ES's, in generations of ``popsize`` (the last one cut to the budget). CMA-ES may stop before
    the budget (its own criteria, e.g. every candidate scoring the same); the summary says why. A
    folder whose tune has finished is left untouched (state.json included): the summary of its history
    is returned with ``nothing_to_do``, the line saying so (and, when ``evaluations`` is now below the
    candidates evaluated, that too). A backend that cannot run here (Ray not installed) is refused
    before anything is written."""
    check_backend(backend)
    if workers < 1:
        raise ConfigError(f"must be at least 1, got {workers}", key="--workers")
    out = prepare_output_dir(out_dir, "--out")
    columns = history_columns(tune)
    has_history = (out / HISTORY_FILE).is_file() and (out / HISTORY_FILE).stat().st_size > 0
    loaded = _load_state(out, tune, has_history)
    state = loaded or _new_state(tune)
    history = _load_history(out / HISTORY_FILE, columns)
    budget = tune.spec.evaluations
    if loaded is not None and _finished(state, history, budget):  # rewrite nothing, state.json included
        return {**summarize(tune, history, state), "nothing_to_do": _nothing_to_do(tune, state, budget)}
    _save_state(out / STATE_FILE, state, tune)
    if history:
        _write_history(out / HISTORY_FILE, columns, [history[n] for n in sorted(history)], append=False)
    bar = progress_bar(budget + 1, tune.spec.name, "candidate", force=True, leave=True) if progress else None
    if bar is not None:
        bar.update(min(len(history), budget + 1))
    n_workers, note = worker_count(workers, int(state.es.popsize))  # capped by the CPUs or a generation
    if note:
        say(note.replace("rollout(s) left", "candidates per generation"))
    try:
        # one pool (or Ray session) for every generation: the workers build each reference's body once
        with backend_session(backend, n_workers) as run:
            scorer = _Scorer(tune, out, history, run, bar)
            scorer.score(0, [(0, tune.start_values())])
            _rescore_lost(tune, state, scorer)
            while state.evaluated < budget and not state.es.stop():
                _generation(tune, state, scorer, out, budget)
                write_outputs(tune, out, scorer.history, state)
    finally:
        if bar is not None:
            bar.close()
    # in candidate order: the same tune gives the same file whatever order the workers finished in
    _write_history(out / HISTORY_FILE, columns, [history[n] for n in sorted(history)], append=False)
    return write_outputs(tune, out, history, state)


def _finished(state: TuneState, history: dict[int, dict[str, str]], budget: int) -> bool:
    """Whether a resumed tune has nothing left to do: its budget spent (or CMA-ES stopped) and every
    candidate evaluated, and the start, in the history."""
    done = state.evaluated >= budget or bool(state.es.stop())
    return done and all(n in history for n in range(state.evaluated + 1))


def _nothing_to_do(tune: Tune, state: TuneState, budget: int) -> str:
    """The line a rerun of a finished tune prints instead of its summary."""
    n, name = state.evaluated, tune.path.name
    if n > budget:
        return (f"tune already finished ({n} candidates evaluated, more than evaluations: {budget} in {name}); "
                f"nothing to do (evaluations above {n} continue it)")
    if n < budget:
        stop = ", ".join(state.es.stop())
        return (f"tune already finished ({n} candidates evaluated; CMA-ES stopped before the budget: {stop}); "
                "nothing to do")
    return f"tune already finished ({n} candidates evaluated); nothing to do (raise evaluations in {name} to continue)"


def _generation(tune: Tune, state: TuneState, scorer: _Scorer, out: Path, budget: int) -> None:
    """Ask, score (the candidates not already in the history), tell, save."""
    # The state is saved only once a generation is scored: a resumed tune replays the saved ones and
    # asks this one again (the same candidates: the same seed). Asks and tells are replayed in the
    # resuming process because pycma finds a told solution's internal (unbounded) form by a hash that
    # differs between processes: told what another process asked, it would recompute it -- another
    # update, other results.
    es = state.es
    asked = [np.asarray(x, dtype=float) for x in es.ask()]
    gen = state.generation + 1
    n = min(len(asked), budget - state.evaluated)  # the state holds the candidates evaluated, not popsize
    scores = scorer.score(gen, [(state.evaluated + 1 + i, _values(tune, asked[i].tolist())) for i in range(n)])
    if n == len(asked):
        es.tell(asked, scores)
    state.generations.append(Generation([x.tolist() for x in asked[:n]], [float(f) for f in scores]))
    _save_state(out / STATE_FILE, state, tune)


def _rescore_lost(tune: Tune, state: TuneState, scorer: _Scorer) -> None:
    """Score again the evaluated candidates missing from history.csv (a row torn by a crash mid-write):
    CMA-ES has their scores already; the history gets back the same rows."""
    for number, (gen, x) in enumerate(state.candidates(), start=1):
        if number not in scorer.history:
            scorer.score(gen, [(number, _values(tune, x))])


# ---------------------------------------------------------------------- outputs
def write_outputs(tune: Tune, out: Path, history: dict[int, dict[str, str]], state: TuneState) -> dict[str, Any]:
    """best.yaml, convergence.png and summary.json from the history so far; returns the summary."""
    summary = summarize(tune, history, state)
    best_n = summary["best"]["candidate"]
    values = {k: float(history[best_n][k]) for k in tune.keys}
    _write_best(tune, out / "best.yaml", values, best_n, summary)
    convergence_plot(history, out / "convergence.png", title=f"{tune.spec.name}: CMA-ES, seed {tune.spec.seed}")
    atomic_write_json(out / "summary.json", summary)
    return summary


def summarize(tune: Tune, history: dict[int, dict[str, str]], state: TuneState) -> dict[str, Any]:
    """The summary (what summary.json holds) of the history so far."""
    best_n = min(history, key=lambda n: (float(history[n]["score"]), n))
    best, start = history[best_n], history[0]
    stop = {k: str(v) for k, v in state.es.stop().items()}
    summary = {"name": tune.spec.name, "file": str(tune.path), "controller": tune.controller_path,
               "references": list(tune.references), "profile": tune.spec.profile, "seed": tune.spec.seed,
               "budget": tune.spec.evaluations, "evaluated": state.evaluated, "generations": state.generation,
               "popsize": int(state.es.popsize), "stopped_early": stop if stop and state.evaluated <
               tune.spec.evaluations else None,
               "start": _summary_row(tune, start), "best": _summary_row(tune, best),
               "config": config.to_dict(tune.spec), "versions": {**versions(), "cma": cma.__version__}}
    return summary


def _summary_row(tune: Tune, rec: dict[str, str]) -> dict[str, Any]:
    return {"candidate": int(rec["candidate"]), "score": float(rec["score"]),
            "terms": {k: float(rec[k]) for k in TERMS}, "survived": int(rec["survived"]),
            "rollouts": int(rec["rollouts"]), "walk_s": float(rec["walk_s"]),
            "parameters": {k: float(rec[k]) for k in tune.keys}}


def _write_best(tune: Tune, path: Path, values: dict[str, float], number: int, summary: dict[str, Any]) -> None:
    """The best candidate as a complete controller file, with a header saying how it was found."""
    data = config.to_dict(tune.settings(values))
    if "name" in data:
        data["name"] = f"{tune.spec.name}-best"
    s, b = summary["start"], summary["best"]
    lines = [f"Found by `bipedsim tune {tune.path.name}` (CMA-ES, pycma; seed {tune.spec.seed}): candidate "
             f"{number} of {summary['evaluated']} evaluated in {summary['generations']} generation(s).",
             f"start: {tune.controller_path or 'the default controller'}; references: "
             + ", ".join(Path(r).name if r else "the built-in walk" for r in tune.references) + ".",
             f"score {b['score']:.4g} (start {s['score']:.4g}; lower is better); pushes survived "
             f"{b['survived']}/{b['rollouts']} (start {s['survived']}/{s['rollouts']}).",
             "tuned: " + ", ".join(f"{k} {s['parameters'][k]:g} -> {v:.4g}" for k, v in values.items()) + "."]
    if tune.spec.profile == "creature":  # a creature's settings are a controller file's creature: section
        data = {"creature": data}
        lines.append("A controller file whose creature: section holds the creature's settings: "
                     "bipedsim run best.yaml --bvh REFERENCE.")
    else:
        lines.append("A complete controller file: bipedsim run best.yaml [--bvh REFERENCE].")
    header = "".join(f"# {line}\n" for line in lines)
    atomic_write_text(path, header + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100))


def convergence_plot(history: dict[int, dict[str, str]], path: Path, title: str) -> None:
    """Every candidate's score and the best so far, against the candidates scored."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nums = sorted(history)
    scores = np.array([float(history[n]["score"]) for n in nums])
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.scatter(nums, scores, s=10, c="tab:gray", label="candidate")
    ax.plot(nums, np.minimum.accumulate(scores), c="tab:blue", label="best so far")
    ax.axhline(scores[0], c="tab:red", ls="--", lw=1, label="start controller")
    ax.set_xlabel("candidate (0: the start controller)")
    if np.all(scores > 0):
        ax.set_yscale("log")  # a broken start scores tens, a good controller about one
    ax.set_ylabel("score (lower is better)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())


def format_tune_summary(summary: dict[str, Any], out_dir: str | os.PathLike[str]) -> str:
    """The lines ``bipedsim tune`` prints: the best candidate against the start, each parameter's
    start and tuned value, why CMA-ES stopped early (if it did) and the files written; for a rerun of a
    finished tune, one line saying there was nothing to do and where its results are."""
    if summary.get("nothing_to_do"):
        return (f"{summary['nothing_to_do']}; its results: {out_dir}/best.yaml, history.csv, convergence.png, "
                "summary.json")
    s, b = summary["start"], summary["best"]
    lines = [f"{summary['evaluated']} candidates in {summary['generations']} generation(s): best score "
             f"{b['score']:.4g} (candidate {b['candidate']}), start {s['score']:.4g}",
             f"  pushes survived {b['survived']}/{b['rollouts']} (start {s['survived']}/{s['rollouts']}); walk "
             f"{b['walk_s']:g} s (start {s['walk_s']:g} s)"]
    lines += [f"  {k}: {s['parameters'][k]:g} -> {v:.4g}" for k, v in b["parameters"].items()]
    if summary["stopped_early"]:
        lines.append(f"  CMA-ES stopped before the budget: {', '.join(summary['stopped_early'])}")
    lines.append(f"wrote {out_dir}/best.yaml, history.csv, convergence.png, summary.json")
    return "\n".join(lines)


def interrupted_message(tune: Tune, out_dir: str | os.PathLike[str]) -> str:
    n = len(_load_history(Path(out_dir) / HISTORY_FILE, history_columns(tune)))
    return (f"interrupted; {out_dir}/{HISTORY_FILE} holds {n} of {tune.spec.evaluations + 1} candidates; run the "
            "same command again to resume")


__all__ = ["CONFIG_CLASSES", "HISTORY_FILE", "OLD_STATE_FILE", "STATE_FILE", "Generation", "TuneState",
           "convergence_plot", "format_tune_summary", "history_columns", "interrupted_message", "parse_state",
           "run_tune", "write_outputs"]
