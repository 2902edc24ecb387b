"""Regression suites: scenarios (reference, controller, pushes) with an expected outcome.

``--update`` rewrites the expectations through a YAML round trip (ruamel.yaml) that keeps the file's
comments, key order, flow mappings, quoting and indentation; scenarios are matched by name.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any, NamedTuple

from ruamel.yaml import YAML
from ruamel.yaml.util import load_yaml_guess_indent

from bipedsim.config import parse_yaml
from bipedsim.errors import BipedsimError
from bipedsim.experiments.experiment import EXPECTATIONS, Suite, load_suite, resolve_relative
from bipedsim.files import atomic_write_text, read_input_text
from bipedsim.model.ground import Ground
from bipedsim.sim.rollout import RolloutSpec
from bipedsim.sim.runner import load_scenario, run_scenario

#: Width (characters) past which ruamel.yaml would fold a long line; wide enough that it never does.
_YAML_WIDTH = 4096


def printable(text: str) -> str:
    """``text`` with every character a terminal would not print as itself (control characters, escape
    sequences' ESC, format characters) written as a Python escape (``\\x1b``): a table shows what the
    file says and never what it would do to the terminal. Names are checked when a suite is loaded
    (:func:`~bipedsim.experiments.experiment.check_name`); this keeps every printed line safe whatever made it."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class ScenarioResult(NamedTuple):
    name: str
    expected: str
    got: str
    fall_time_s: float | None
    note: str  #: why a push was not applied, or ""


def run_scenarios(suite: Suite, base: Path) -> list[ScenarioResult]:
    """Run every scenario of ``suite`` (paths in it are relative to ``base``)."""
    out = []
    for sc_spec in suite.scenarios:
        sc = load_scenario(resolve_relative(base, sc_spec.controller), resolve_relative(base, sc_spec.reference),
                           profile=sc_spec.profile, support=sc_spec.support, ground=Ground.parse(list(sc_spec.ground)))
        spec = RolloutSpec(seconds=sc_spec.seconds, seed=sc_spec.seed, fall=suite.fall)
        o, _ = run_scenario(sc, spec, pushes=sc_spec.push_list())
        note = "; ".join(o.extra.get("pushes_not_applied", []))
        out.append(ScenarioResult(sc_spec.name, sc_spec.expect, o.outcome, o.fall_time_s, note))
    return out


def run_suite(path: str | os.PathLike[str], update: bool = False) -> int:
    """Print a table; exit status 1 on any mismatch (0 after ``update`` rewrote the expectations).

    A scenario whose push did not happen (``push_not_applied``) is a mismatch that ``update`` cannot
    fix: the scenario itself needs changing."""
    p = Path(path)
    suite = load_suite(p)  # every check before any rollout
    results = run_scenarios(suite, p.resolve().parent)
    names = {r.name: printable(r.name) for r in results}
    width = max(len(n) for n in names.values())
    print(f"{'scenario':{width}s}  {'expected':8s}  {'got':8s}  fall time")
    bad = [r for r in results if r.expected != r.got]
    for r in results:
        mark = "" if r.expected == r.got else "   <-- MISMATCH"
        ft = "" if r.fall_time_s is None else f"{r.fall_time_s:.2f} s"
        print(f"{names[r.name]:{width}s}  {r.expected:8s}  {r.got:8s}  {ft}{mark}")
        if r.note:
            print(f"{'':{width}s}  push not applied: {printable(r.note)}")
    if update and bad:
        fixable = {r.name: r.got for r in bad if r.got in EXPECTATIONS}
        changed = update_expectations(p, fixable)
        print(f"updated {len(changed)} expectation(s) in {printable(str(p))}"
              + (f": {', '.join(map(printable, changed))}" if changed else ""))
        unfixable = [names[r.name] for r in bad if r.got not in EXPECTATIONS]
        if unfixable:
            print(f"not updated: {', '.join(unfixable)}: a push did not happen; change the scenario (its "
                  "seconds, or the push's timing)")
            return 1
        return 0
    print(f"{len(results) - len(bad)}/{len(results)} as expected")
    return 1 if bad else 0


def update_expectations(path: str | os.PathLike[str], outcomes: dict[str, str]) -> list[str]:
    """Set ``expect`` of each scenario named in ``outcomes`` to its value in the suite file at
    ``path``, keeping everything else of the file as it is; returns the names whose expectation
    changed in the file (an ``expect`` key is added where the scenario had none and the value
    differs from the default ``no_fall``). Written atomically, and only after a check that the new
    text reads back as the old one with just those expectations changed."""
    p = Path(path)
    # read and parsed as every input is (size, nesting, aliases, duplicate keys) before ruamel.yaml, which
    # is here for the round-trip rewrite only, sees the text
    text = read_input_text(p, "yaml")
    parse_yaml(text, p)
    _, indent, seq_indent = load_yaml_guess_indent(text)
    rt = YAML()  # round trip: comments, order, flow style kept
    rt.preserve_quotes = True
    rt.width = _YAML_WIDTH
    rt.indent(mapping=indent or 2, sequence=indent or 2, offset=seq_indent or 0)
    doc = rt.load(text)
    changed = []
    for item in doc["scenarios"]:
        name = str(item["name"])
        if name in outcomes and item.get("expect", "no_fall") != outcomes[name]:
            item["expect"] = outcomes[name]
            changed.append(name)
    if not changed:
        return []
    buf = io.StringIO()
    rt.dump(doc, buf)
    new = buf.getvalue()
    _check_round_trip(p, text, new, {n: outcomes[n] for n in changed})
    atomic_write_text(p, new)
    return changed


def _check_round_trip(path: Path, old: str, new: str, changed: dict[str, str]) -> None:
    """Raise unless ``new`` parses to ``old``'s data with only the ``changed`` expectations different."""
    want: Any = parse_yaml(old, path)
    for item in want["scenarios"]:
        if str(item["name"]) in changed:
            item["expect"] = changed[str(item["name"])]
    if parse_yaml(new, path) != want:
        raise BipedsimError(f"{path}: cannot update the expectations without changing other content; edit them "
                            f"by hand: {', '.join(f'{printable(n)}: {v}' for n, v in changed.items())}")
