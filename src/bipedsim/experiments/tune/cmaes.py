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

This module is the loop; the state file is read and checked in
:mod:`~bipedsim.experiments.tune.state_file`, the optimiser made and replayed in
:mod:`~bipedsim.experiments.tune.state`, ``history.csv`` kept in :mod:`~bipedsim.experiments.tune.history`
and the summary, ``best.yaml`` and the plot written by :mod:`~bipedsim.experiments.tune.results`.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from bipedsim import config
from bipedsim.errors import BipedsimError, ConfigError
from bipedsim.experiments.backends import backend_session, check_backend, worker_count
from bipedsim.experiments.tune.evaluate import Setup, evaluate
from bipedsim.experiments.tune.history import _load_history, _record, _write_history, history_columns
from bipedsim.experiments.tune.results import (
    _write_best,
    convergence_plot,
    format_tune_summary,
    interrupted_message,
    summarize,
)
from bipedsim.experiments.tune.spec import CONFIG_CLASSES, Tune
from bipedsim.experiments.tune.state import TuneState, _bounds, _load_state, _new_state, _save_state
from bipedsim.experiments.tune.state_file import (
    HISTORY_FILE,
    OLD_STATE_FILE,
    STATE_FILE,
    Generation,
    parse_state,
)
from bipedsim.files import atomic_write_json, prepare_output_dir, progress_bar


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


__all__ = ["CONFIG_CLASSES", "HISTORY_FILE", "OLD_STATE_FILE", "STATE_FILE", "Generation", "TuneState",
           "convergence_plot", "format_tune_summary", "history_columns", "interrupted_message", "parse_state",
           "run_tune", "write_outputs"]
