"""A tune's optimiser (:class:`TuneState`): pycma's CMA-ES made from the tune (start, step, population,
seed), saved after each generation, and rebuilt for a resumed tune by replaying the recorded asks and
tells from the same seed (each replayed ask must give the recorded candidates exactly)."""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cma
import numpy as np

from bipedsim import config
from bipedsim.errors import BipedsimError, InputError
from bipedsim.experiments.tune.spec import Tune
from bipedsim.experiments.tune.state_file import (
    HISTORY_FILE,
    OLD_STATE_FILE,
    STATE_FILE,
    STATE_FORMAT,
    STATE_VERSION,
    Generation,
    parse_state,
)
from bipedsim.files import (
    atomic_write_text,
    read_input_text,
)


class Randn:
    """CMA-ES's normal samples from its own generator, seeded by the tune (pycma's ``randn`` option
    would take NumPy's global one, which other code in the process may draw from between generations)."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)

    def __call__(self, *shape: int) -> np.ndarray:
        return self.rng.standard_normal(shape)


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
