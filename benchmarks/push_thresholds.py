"""Push thresholds by the replica protocol, beside the field's anchors, in one run.

Runs (or resumes) a replicated push grid and prints, per direction, the threshold every gait state meets
(the largest magnitude at least ``survive`` of the replicas survive at it and at every lower magnitude)
as force (N) and impulse (N s), with its ratio to SIMBICON's demonstrated 350 N x 0.2 s (70 N s) and to
Lee, Kim & Lee 2010's recoveries while tracking motion capture (48-64 N s sagittal, 32-42 N s lateral;
the ratio is to the lower end). It also counts the cells whose single trial (replica 0) gives another
threshold than the replicas: the lucky and unlucky phases a single-trial grid reports as thresholds.

    python benchmarks/push_thresholds.py [EXPERIMENT.yaml] [--out DIR] [--workers N]
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
from pathlib import Path

from bipedsim.experiments.experiment import load_experiment
from bipedsim.experiments.sweep import run_sweep
from bipedsim.experiments.sweep_summary import summarise, threshold_table

DEFAULT = Path(__file__).resolve().parents[1] / "experiments" / "push_grid.yaml"
#: N s: SIMBICON's (Yin, Loken & van de Panne 2007) demonstrated push, 350 N x 0.2 s
SIMBICON_NS = 70.0
#: N s, (low, high): Lee, Kim & Lee 2010, recoveries while tracking motion capture
LEE_SAGITTAL_NS = (48.0, 64.0)
LEE_LATERAL_NS = (32.0, 42.0)


def anchor(direction: float) -> tuple[str, float] | None:
    """The Lee et al. range that applies to a push ``direction`` (degrees; 0 forward, 90 left): its label and
    its lower end (N s), or None for the diagonals."""
    d = direction % 180.0
    if d == 0.0:
        return "sagittal", LEE_SAGITTAL_NS[0]
    if d == 90.0:
        return "lateral", LEE_LATERAL_NS[0]
    return None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("experiment", nargs="?", default=str(DEFAULT))
    ap.add_argument("--out", help="the sweep's folder (resumed when it holds results); default: a temporary one")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    exp = load_experiment(args.experiment)
    rep = exp.spec.replicas
    if rep is None:
        print(f"{args.experiment}: no replicas: block; this benchmark measures the replica protocol")
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.out or tmp)
        summary = run_sweep(exp, out, workers=args.workers, progress=False)
        with open(out / "results.csv", encoding="utf-8", newline="") as f:
            rows = list(csv.DictReader(f))
    single = summarise([r for r in rows if r["repeat"] == "0"])
    print(threshold_table(summary))
    durations = {g["duration_s"] for g in summary["by_direction_and_phase"]}
    dur = durations.pop() if len(durations) == 1 else None
    print(f"{'direction':>9}  {'threshold':>9}  {'impulse':>8}  {'/ SIMBICON 70':>13}  {'/ Lee et al. (low end)':>22}")
    for d, v in summary["largest_survived_per_direction_n"].items():
        ns = None if v is None or dur is None else v * dur
        a = anchor(float(d))
        simb = "-" if ns is None else f"{ns / SIMBICON_NS:.2f}"
        lee = "-" if ns is None or a is None else f"{ns / a[1]:.2f} ({a[0]} {a[1]:g})"
        thr = "-" if v is None else f"{v:g} N"
        imp = "-" if ns is None else f"{ns:g} N s"
        print(f"{d:>7} deg  {thr:>9}  {imp:>8}  {simb:>13}  {lee:>22}")
    by_rep = {(g["controller"], g["body"], g["duration_s"], g["direction_deg"], g["phase"]): g["threshold_n"]
              for g in summary["by_direction_and_phase"]}
    differ = [k for k, g in ((k, g) for g in single["by_direction_and_phase"]
                             for k in [(g["controller"], g["body"], g["duration_s"], g["direction_deg"], g["phase"])])
              if by_rep.get(k) != g["threshold_n"]]
    print(f"cells whose single trial (replica 0) gives another threshold than {rep.survive} of {rep.count} "
          f"replicas: {len(differ)} of {len(by_rep)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
