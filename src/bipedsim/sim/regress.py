"""Regression suites: scenarios (reference, controller, pushes) with an expected outcome."""

from __future__ import annotations

import os
import re
from dataclasses import asdict
from pathlib import Path

from bipedsim.sim.experiment import Suite, load_suite
from bipedsim.sim.push import Push
from bipedsim.sim.rollout import RolloutSpec


def run_scenarios(suite: Suite, base: Path) -> list[tuple[str, str, str, float | None]]:
    """(name, expected, got, fall time) per scenario."""
    from bipedsim.sim.runner import load_scenario, run_scenario

    def res(p: str | None) -> str | None:
        return None if p is None else str(p if Path(p).is_absolute() else (base / p).resolve())

    out = []
    for sc_spec in suite.scenarios:
        sc = load_scenario(res(sc_spec.controller), res(sc_spec.reference))
        pushes = [Push(**{k: v for k, v in asdict(p).items() if k != "controller"}) for p in sc_spec.pushes]
        for p in pushes:
            p.validate()
        spec = RolloutSpec(seconds=sc_spec.seconds, seed=sc_spec.seed, fall=suite.fall.criteria())
        o, _ = run_scenario(sc, spec, pushes=pushes)
        out.append((sc_spec.name, sc_spec.expect, o.outcome, o.fall_time_s))
    return out


def run_suite(path: str | os.PathLike[str], update: bool = False) -> int:
    """Print a table; exit status 1 on any mismatch (0 after ``update`` rewrote the expectations)."""
    p = Path(path)
    suite = load_suite(p)
    results = run_scenarios(suite, p.resolve().parent)
    width = max(len(n) for n, *_ in results)
    print(f"{'scenario':{width}s}  {'expected':8s}  {'got':8s}  fall time")
    bad = 0
    for name, exp, got, ft in results:
        mark = "" if exp == got else "   <-- MISMATCH"
        bad += exp != got
        print(f"{name:{width}s}  {exp:8s}  {got:8s}  {'' if ft is None else f'{ft:.2f} s'}{mark}")
    if update and bad:
        text = p.read_text()
        lines = text.splitlines(keepends=True)
        k = 0
        for i, ln in enumerate(lines):
            m = re.match(r"^(\s*(?:-\s*)?expect:\s*)(\S+)(.*)$", ln.rstrip("\n"))
            if m and k < len(results):
                lines[i] = f"{m.group(1)}{results[k][2]}{m.group(3)}\n"
                k += 1
        from bipedsim.io import atomic_write_text

        atomic_write_text(p, "".join(lines))
        print(f"updated {bad} expectation(s) in {p}")
        return 0
    print(f"{len(results) - bad}/{len(results)} as expected")
    return 1 if bad else 0
