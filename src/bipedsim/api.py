"""The Python API: what ``bipedsim run``, ``bipedsim sweep`` and ``bipedsim tune`` do, as functions that
return their results (for notebooks and scripts). The commands call these, so a command and its
function give the same results; ``import bipedsim`` makes them available as ``bipedsim.run``,
``bipedsim.sweep`` and ``bipedsim.tune`` when first used.

>>> import bipedsim
>>> out = bipedsim.run(seconds=5.0, pushes=["150:90:0.2:2.0"])   # the built-in walk, pushed left
>>> out.outcome, round(out.distance_m, 2)

Units as everywhere in the package: s, m, N, rad (push directions in degrees from the heading).
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import check_backend, run_sweep
from bipedsim.experiments.sweep_folder import load_results
from bipedsim.experiments.tune import load_tune, run_tune
from bipedsim.experiments.tune.cmaes import HISTORY_FILE, STATE_FILE
from bipedsim.files import check_distinct_paths, folder_files, prepare_output_dir
from bipedsim.render.video import VideoOptions
from bipedsim.sim.outputs import RunResult, run_to_folder
from bipedsim.sim.push import Push
from bipedsim.sim.recorder import DEFAULT_RECORD_HZ
from bipedsim.sim.rollout import Outcome

PathLike = str | os.PathLike[str]

#: The files ``bipedsim sweep`` writes into its output folder (checked against its inputs).
SWEEP_FILES = ("results.csv", "summary.json", "experiment.json", "push_polar.png")
#: The files ``bipedsim tune`` writes into its output folder besides its history and state.
TUNE_FILES = ("best.yaml", "convergence.png", "summary.json")


def run(controller: PathLike | None = None, bvh: PathLike | None = None, *, seconds: float = 10.0, seed: int = 0,
        init_noise: float = 0.0, pushes: Sequence[str | Push] = (), out: PathLike | None = None,
        profile: str | None = None, support: bool = False, mass: float | None = None,
        scale: float | str | None = None, up: str | None = None, positions: str | None = None,
        fps: float | None = None, events: PathLike | None = None, reconstruct: bool | None = None,
        record_hz: float = DEFAULT_RECORD_HZ, plots: bool = False, csv: PathLike | None = None,
        export_bvh: PathLike | None = None, video: PathLike | None = None, gif: PathLike | None = None,
        video_options: VideoOptions | None = None, progress: bool = False,
        say: Callable[[str], None] | None = None, ground: Sequence[str] | None = None) -> Outcome:
    """One rollout, as ``bipedsim run [CONTROLLER] --bvh BVH ...`` runs it; its :class:`Outcome`
    (verdict, distance m, speeds m/s, tracking RMSE rad, recovery figures, fidelity to the clip, what
    made it). ``controller``: a controller YAML (None: the defaults); ``bvh``: a clip (None: the built-in
    walk); ``seconds``: simulated s; ``init_noise``: initial velocity noise (std, rad/s and m/s) drawn
    from ``seed``; ``pushes``: ``MAG:DIR:DUR:START`` strings (N, degrees from the heading, s, s) or
    :class:`~bipedsim.sim.push.Push`; ``reconstruct``: search a humanoid clip's feed-forward
    correction first (None: the settings', or ``BIPEDSIM_RECONSTRUCT``); ``ground``: ``--ground`` terms
    (``slope:DEG``, ``step:H:D``, ``rough:A:W[:SEED]``, ``friction:MU``; docs/ground.md). ``out``: the run
    folder to write (``outcome.json``, ``trajectory.npz``, ``model.xml``, and the optional plots, CSV, BVH, videos;
    None: a temporary folder, removed after). The rest: as
    :func:`~bipedsim.sim.outputs.run_to_folder`, which this calls. Errors: :class:`~bipedsim.errors.BipedsimError`
    naming the option."""
    return run_folder(controller, bvh, seconds=seconds, seed=seed, init_noise=init_noise, pushes=pushes, out=out,
                      profile=profile, support=support, mass=mass, scale=scale, up=up, positions=positions, fps=fps,
                      events=events, reconstruct=reconstruct, record_hz=record_hz, plots=plots, csv=csv,
                      export_bvh=export_bvh, video=video, gif=gif, video_options=video_options, progress=progress,
                      say=say, ground=ground).outcome


def run_folder(controller: PathLike | None = None, bvh: PathLike | None = None, *, out: PathLike | None = None,
               **options: Any) -> RunResult:
    """:func:`run`, returning everything the run made (:class:`~bipedsim.sim.outputs.RunResult`: the
    folder, outcome, scenario, trajectory and files written); with ``out`` None the folder is a
    temporary one, gone when this returns (the trajectory stays in memory)."""
    if out is not None:
        return run_to_folder(out, config=controller, bvh=bvh, **options)
    with tempfile.TemporaryDirectory(prefix="bipedsim-run-") as tmp:
        return run_to_folder(Path(tmp) / "run", config=controller, bvh=bvh, **options)


@dataclass
class SweepResult:
    """A sweep's results: one record per rollout (``results.csv``'s columns, numbers as numbers, empty
    cells as None), in the experiment's order; the summary (``summary.json``); the output folder."""

    rows: list[dict[str, Any]]
    summary: dict[str, Any]
    out: Path


def sweep(experiment: PathLike, out: PathLike, *, workers: int = 1, backend: str = "local",
          progress: bool = False, say: Callable[[str], None] | None = None) -> SweepResult:
    """Every rollout of the experiment YAML ``experiment`` not already in ``out/results.csv``, as
    ``bipedsim sweep EXPERIMENT --out OUT`` runs them (resumable: a second call runs only what is
    missing). ``workers``: parallel rollouts; ``backend``: ``local`` processes or ``ray``. Every check
    (the file, its reference and controllers, outputs that would overwrite an input) comes before any
    rollout. ``say`` gets the sweep's one-line notes (rows dropped from a damaged results.csv, workers
    capped; default: printed to stderr)."""
    check_backend(backend)  # before the output folder is made
    exp = load_experiment(experiment)
    controllers = sorted({r.controller for r in exp.rows() if r.controller})
    check_distinct_paths(folder_files("the --out file", out, SWEEP_FILES),
                         [("the experiment file", experiment), ("its reference", exp.resolve(exp.spec.reference)),
                          *(("its controller", c) for c in controllers)])
    folder = prepare_output_dir(out, "--out")
    kw = {} if say is None else {"say": say}
    summary = run_sweep(exp, folder, workers=workers, backend=backend, progress=progress, **kw)
    rows, _ = load_results(folder / "results.csv", exp.rows())
    rows.sort(key=lambda r: int(r["index"]))
    return SweepResult([{k: _typed(v) for k, v in r.items()} for r in rows], summary, folder)


def tune(tune_file: PathLike, out: PathLike, *, workers: int = 1, backend: str = "local", progress: bool = False,
         say: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Tune the controller values the tune YAML names with CMA-ES, as ``bipedsim tune TUNE --out OUT``
    does (resuming what ``out`` holds); the summary (best candidate, its score and values, why CMA-ES
    stopped), also in ``out/summary.json`` with ``best.yaml`` and the history."""
    spec = load_tune(tune_file)
    check_distinct_paths(folder_files("the --out file", out, (*TUNE_FILES, HISTORY_FILE, STATE_FILE)),
                         [("the tune file", tune_file), ("its controller", spec.controller_path),
                          *(("its reference", r) for r in spec.references)])
    kw = {} if say is None else {"say": say}
    return run_tune(spec, out, workers=workers, backend=backend, progress=progress, **kw)


def _typed(text: str | None) -> Any:
    """A CSV cell as Python data: an int, a float, True/False, None for an empty cell, else the text."""
    if text is None or text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    for kind in (int, float):
        try:
            value = kind(text)
        except ValueError:
            continue
        return value if kind is int or math.isfinite(value) or text.lower() in ("inf", "-inf", "nan") else text
    return text


__all__ = ["SWEEP_FILES", "TUNE_FILES", "SweepResult", "run", "run_folder", "sweep", "tune"]
