"""A tune's results: the summary (``summary.json``), the best candidate as a controller file
(``best.yaml``), the convergence plot (``convergence.png``), and the lines ``bipedsim tune`` prints."""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any

import cma
import numpy as np
import yaml

from bipedsim import config
from bipedsim.experiments.tune.history import _load_history, history_columns
from bipedsim.experiments.tune.objective import TERMS
from bipedsim.experiments.tune.spec import Tune
from bipedsim.experiments.tune.state import TuneState
from bipedsim.experiments.tune.state_file import (
    HISTORY_FILE,
)
from bipedsim.files import (
    atomic_write_bytes,
    atomic_write_text,
    versions,
)


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
