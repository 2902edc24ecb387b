"""How far the per-clip search gets before every sample falls, for settings of the search, in one run.

    python benchmarks/search_reach.py CLIP.bvh ... [--set hinge_sigma=0.02 --set hinge_sigma=0.06 ...]
        [--cap 12] [--workers 2]

Per clip and per ``--set`` (each a comma-separated list of ``reconstruct:`` settings, e.g.
``hinge_sigma=0.06,coherence=0.9``; none: the defaults): the seconds of the clip the search covered
before every sample of a window fell (``+``: it got to ``--cap`` s, where this benchmark stops it), as a
share of the clip's own span, and its wall time. The searches whose body drifts from a fast or a slumped
clip window by window stop mid-clip; the table in docs/results.md (*The search's spread and its span*)
was measured with it.
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import fields, replace

from bipedsim.sim.reconstruct import search_corrections, search_span
from bipedsim.sim.runner import load_scenario


class _Capped(Exception):
    """The search got to the cap."""


def _settings(text: str, cfg: object) -> dict[str, object]:
    """``key=value,...`` as typed ``reconstruct:`` settings of ``cfg``."""
    kinds = {f.name: type(getattr(cfg, f.name)) for f in fields(cfg)}  # type: ignore[arg-type]
    out: dict[str, object] = {}
    for part in filter(None, text.split(",")):
        key, _, value = part.partition("=")
        if key not in kinds:
            raise SystemExit(f"--set: unknown reconstruct setting {key!r}; settings: {', '.join(kinds)}")
        out[key] = kinds[key](value) if kinds[key] is not type(None) else float(value)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("clips", nargs="+", help="BVH files")
    ap.add_argument("--set", action="append", default=None, help="settings to compare (repeatable)")
    ap.add_argument("--cap", type=float, default=12.0, help="s of search after which a clip counts as carried")
    ap.add_argument("--workers", type=int, default=2, help="search processes")
    a = ap.parse_args()
    ways = a.set or [""]
    print(f"{'clip':36s} {'way':28s} {'span s':>7s} {'reach s':>8s} {'share':>6s} {'wall s':>7s}")
    for path in a.clips:
        sc = load_scenario(bvh=path, reconstruct=False)
        for way in ways:
            cfg = replace(sc.cfg.reconstruct, **_settings(way, sc.cfg.reconstruct))
            ctrl = sc.controller()
            span = search_span(ctrl, 0)

            def stop(done: float, _total: float) -> None:
                if done >= a.cap:
                    raise _Capped(done)

            t0 = time.perf_counter()
            capped = ""
            try:
                corr, _ = search_corrections(sc.built.model, ctrl, cfg, sc.fall_criteria(), workers=a.workers,
                                             progress=stop)
                reach = (corr.end - ctrl.start_frame()) * sc.clip.frame_time if corr is not None else 0.0
            except _Capped as done:
                reach, capped = float(done.args[0]), "+"
            finally:
                ctrl.restore_model()
            wall = time.perf_counter() - t0
            share = min(reach, span) / span if span > 0 else 0.0
            print(f"{os.path.basename(path)[:36]:36s} {way or 'defaults':28s} {span:7.1f} {reach:7.1f}{capped:1s} "
                  f"{share:6.2f} {wall:7.0f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
