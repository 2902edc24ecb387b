"""Experiment specs (``experiments/*.yaml``): push grids or lists over magnitudes, directions, gait
phases and controller configurations, with repeats and seeds; and regression suites.

Everything is validated before any rollout starts: unknown keys, negative durations, unknown bodies,
empty grids, repeated values, missing files, run lengths past :data:`~bipedsim.sim.limits.MAX_ROLLOUT_S`,
more rollouts than :data:`MAX_ROLLOUTS`, pushes that would not lie inside the run -- each error names the
file and the key.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from bipedsim import config
from bipedsim.control.settings import check_settings_for_body, load_controller, unread_settings
from bipedsim.data import BUILTIN_WALK
from bipedsim.errors import ConfigError
from bipedsim.experiments.grid import Grid, ground_label
from bipedsim.experiments.replicas import Replicas
from bipedsim.model.build import build_model
from bipedsim.model.ground import check_ground
from bipedsim.reference.prepare import load_source
from bipedsim.sim.limits import MAX_ROLLOUT_S
from bipedsim.sim.push import DEFAULT_AFTER_S, DEFAULT_PUSH_BODY, Push, check_pushes, random_pushes
from bipedsim.sim.rollout import FallCriteria
from bipedsim.sim.runner import PROFILES

#: Most rollouts one experiment may expand to: 100 000 rollouts of a few seconds are days of CPU time
#: and a results.csv of ~30 MB; a larger count is a typo (and would not fit in memory: 1e12 pushes).
MAX_ROLLOUTS = 100_000
#: Longest name (characters) of an experiment, a suite or a scenario: names head tables, progress bars
#: and summaries, one line each.
MAX_NAME_CHARS = 200


def check_name(name: str, key: str = "name") -> None:
    """Raise ``ValueError("KEY: ...")`` unless ``name`` is one printable line: not empty, at most
    :data:`MAX_NAME_CHARS` characters, no control characters (a terminal escape sequence in a name
    would recolour or rewrite the terminal it is printed to; a newline would split a table's row) and
    no other character :meth:`str.isprintable` refuses (format characters such as a right-to-left
    override, line separators). Every name an experiment or suite file gives is checked here."""
    if not name.strip():
        raise ValueError(f"{key}: must not be empty")
    if len(name) > MAX_NAME_CHARS:
        raise ValueError(f"{key}: {len(name)} characters; a name has at most {MAX_NAME_CHARS}")
    bad = next((c for c in name if not c.isprintable()), None)
    if bad is not None:
        raise ValueError(f"{key}: holds the unprintable character U+{ord(bad):04X} (at {name.index(bad) + 1} of "
                         f"{len(name)}); a name is printed as it is: give letters, digits, spaces and punctuation")


@dataclass(frozen=True)
class RandomPushes:
    """``count`` rollouts, each with one push of uniform random magnitude, direction and start time,
    drawn from the experiment's ``seed`` (the same pushes for every controller listed)."""

    count: int = field(default=32, metadata={"min": 1})
    magnitude: tuple[float, float] = (100.0, 300.0)  #: N, [low, high]
    direction: tuple[float, float] = (0.0, 360.0)  #: degrees from the heading, [low, high]
    duration: float = field(default=0.2, metadata={"gt": 0.0})
    window: tuple[float, float] = (2.0, 5.0)  #: start times (s), [low, high]
    controller: tuple[str, ...] = ()
    #: summary.json bins the random directions into sectors this wide (degrees)
    sector: float = field(default=45.0, metadata={"gt": 0.0, "max": 180.0})

    def validate(self) -> None:
        for key in ("magnitude", "direction", "window"):
            lo, hi = getattr(self, key)
            if lo > hi:
                raise ValueError(f"{key}: [low, high] reversed: [{lo}, {hi}]")
        if self.magnitude[0] < 0:
            raise ValueError(f"magnitude: must be >= 0 N, got {self.magnitude[0]}")
        if self.window[0] < 0:
            raise ValueError(f"window: start times must be >= 0 s, got {self.window[0]}")

    def pushes(self, seed: int, body: str) -> list[Push]:
        raw = random_pushes(seed, self.count, magnitude=self.magnitude, duration=self.duration,
                            window=self.window, body=body, direction=self.direction)
        # rounded to what a results.csv row shows: 0.1 N, 0.1 degree, 1 ms
        return [Push(magnitude=round(p.magnitude, 1), direction=round(p.direction, 1) % 360.0,
                     duration=p.duration, start=round(float(p.start), 3), body=body) for p in raw]


@dataclass(frozen=True)
class PushItem:
    """One push of a ``runs:`` list or a suite scenario: ``start`` (s) or ``state`` (+ ``fraction``)."""

    magnitude: float
    direction: float = 0.0
    duration: float = 0.2
    start: float | None = None
    state: int | None = None
    #: of the state's nominal duration; only with ``state`` (None: half way)
    fraction: float | None = None
    vertical: float = 0.0
    controller: str | None = None

    def validate(self) -> None:
        if self.start is not None and self.state is not None:
            raise ValueError("start: give a start time or a gait state, not both")
        if self.start is None and self.state is None:
            raise ValueError("start: give a start time (s) or a gait state (state, fraction)")
        if self.fraction is not None and self.state is None:
            raise ValueError("fraction: only with state (a fraction of that gait state)")

    def push(self, body: str = "torso", after: float = DEFAULT_AFTER_S) -> Push:
        return Push(magnitude=self.magnitude, direction=self.direction, duration=self.duration, start=self.start,
                    state=self.state, fraction=0.5 if self.fraction is None else self.fraction,
                    vertical=self.vertical, body=body, after=after)


@dataclass(frozen=True)
class ExperimentSpec:
    name: str = "experiment"
    seconds: float = field(default=6.0, metadata={"gt": 0.0, "max": MAX_ROLLOUT_S})
    reference: str | None = None  #: BVH (relative to the file); null: the built-in walk
    #: the body kind built from the reference and its controller (``bipedsim run --profile``)
    profile: str = field(default="auto", metadata={"choices": PROFILES})
    #: a creature's root support (``bipedsim run --support``)
    support: bool = False
    body: str = DEFAULT_PUSH_BODY
    after: float = field(default=DEFAULT_AFTER_S, metadata={"min": 0.0})
    repeats: int = field(default=1, metadata={"min": 1})
    seed: int = field(default=0, metadata={"min": 0})  # numpy's generators take no negative seed
    init_noise: float = field(default=0.0, metadata={"min": 0.0})
    grid: Grid | None = None
    #: a grid's cells run as replicas (a threshold protocol); null: one trial per cell (and ``repeats``)
    replicas: Replicas | None = None
    runs: tuple[PushItem, ...] = ()
    random: RandomPushes | None = None
    #: null: the body kind's default criteria (FallCriteria.for_body)
    fall: FallCriteria | None = None
    #: the ground every rollout walks on (``bipedsim run --ground``'s terms); empty: flat
    ground: tuple[str, ...] = ()

    def validate(self) -> None:
        check_name(self.name)
        check_ground(self.ground)
        if self.ground and self.grid is not None and self.grid.ground:
            raise ValueError("ground: give the ground once, as ground or as the grid's dimension grid.ground")
        given = [k for k, v in (("grid", self.grid), ("runs", self.runs), ("random", self.random)) if v]
        if not given:
            raise ValueError("grid: give a grid, a list of runs or random pushes -- the experiment has no rollouts")
        if len(given) > 1:
            raise ValueError(f"{given[1]}: give one of grid, runs and random, not {' and '.join(given)}")
        if self.replicas is not None:
            if self.grid is None:
                raise ValueError("replicas: only with a grid (replicas run each grid cell several times)")
            if self.repeats > 1:
                raise ValueError("replicas: give replicas or repeats, not both (replicas are repeats of a cell "
                                 "from perturbed states)")
            if self.init_noise > 0:
                raise ValueError("replicas: replicas.noise sets the replicas' initial noise; leave init_noise out")
            g, r = self.grid, self.replicas
            if g.start and max(g.start) + r.start_offset + max(g.duration) > self.seconds:
                raise ValueError(f"replicas.start_offset: a push may start at {max(g.start):g} s + "
                                 f"{r.start_offset:g} s and last {max(g.duration):g} s, past the end of the run "
                                 f"({self.seconds:g} s, seconds); a push must end within the run")
        self._check_count()
        self._check_runs()
        if self.random is not None:
            r = self.random
            if r.window[1] + r.duration > self.seconds:
                raise ValueError(f"random.window: a push may start at {r.window[1]:g} s and last {r.duration:g} s, "
                                 f"past the end of the run ({self.seconds:g} s, seconds); a push must end within "
                                 "the run")

    def _check_count(self) -> None:
        """At most :data:`MAX_ROLLOUTS`, counted before anything is expanded (1e12 would not fit)."""
        if self.grid is not None:
            per, key, what = self.grid.size(), "grid", f"a grid of {self.grid.size()}"
        elif self.random is not None:
            n_ctl = len(self.random.controller) or 1
            per, key = self.random.count * n_ctl, "random.count"
            what = f"count {self.random.count} x {n_ctl} controller(s)"
        else:
            per, key, what = len(self.runs), "runs", f"{len(self.runs)} runs"
        total = per * (self.replicas.count if self.replicas is not None else self.repeats)
        if total > MAX_ROLLOUTS:
            key = "repeats" if self.repeats > MAX_ROLLOUTS else key
            raise ValueError(f"{key}: the experiment asks for {total} rollouts ({what} x {self.repeats} repeat(s)); "
                             f"at most {MAX_ROLLOUTS} per experiment -- split it into several")

    def _check_runs(self) -> None:
        for i, r in enumerate(self.runs):
            if r in self.runs[:i]:
                # two equal rollouts would share one row key: a resumed sweep would run only one
                raise ValueError(f"runs[{i}]: the same as runs[{self.runs.index(r)}]; use repeats to run a push "
                                 "more than once")


@dataclass(frozen=True)
class Row:
    """One rollout of an experiment."""

    index: int
    key: str  #: stable identity (parameters + repeat), for resuming
    controller: str | None
    push: Push
    repeat: int  #: the repeat, or the replica of a replicated grid
    seed: int
    #: the replica's phase offset: of the state's nominal duration (phase-timed push) or s (timed);
    #: ``push`` holds it, the row's fraction and start columns the cell's own
    offset: float = 0.0
    #: initial velocity noise (rad/s, m/s) of this row; None: the experiment's ``init_noise``
    init_noise: float | None = None
    #: the ground's terms this row walks on (empty: flat)
    ground: tuple[str, ...] = ()

    def params(self) -> dict[str, Any]:
        p = self.push
        return {"index": self.index, "key": self.key, "controller": self.controller or "default",
                "magnitude": p.magnitude, "direction": p.direction, "duration": p.duration,
                "state": "" if p.state is None else p.state,
                "fraction": "" if p.state is None else self._cell(p.fraction),
                "start": "" if p.start is None else self._cell(p.start), "vertical": p.vertical, "body": p.body,
                "ground": ground_label(self.ground), "repeat": self.repeat, "seed": self.seed,
                "phase_offset": round(self.offset, 9)}

    def _cell(self, value: float) -> float:
        """A fraction or start time of this row's push as its cell has it (without the replica's offset)."""
        return round(value - self.offset, 9) if self.offset else value


@dataclass
class Experiment:
    spec: ExperimentSpec
    path: Path

    def resolve(self, rel: str | None) -> str | None:
        return resolve_relative(self.path.parent, rel)

    def rows(self) -> list[Row]:
        s = self.spec
        # (controller, push, the grid's ground: None where the grid has no ground dimension)
        items: list[tuple[str | None, Push, tuple[str, ...] | None]] = []
        if s.grid is not None:
            g = s.grid
            timings: list[dict[str, Any]] = ([{"state": st, "fraction": fr} for st, fr in g.phase]
                                             or [{"start": t} for t in g.start])
            for ctl, gnd, body, mag, dirn, dur, tim, vert in itertools.product(
                    g.controller or (None,), g.ground or (None,), g.body or (s.body,), g.magnitude, g.direction,
                    g.duration, timings, g.vertical):
                items.append((ctl, Push(magnitude=mag, direction=dirn, duration=dur, vertical=vert, body=body,
                                        after=s.after, **tim), gnd))
        elif s.random is not None:
            for push in s.random.pushes(s.seed, s.body):
                for ctl in s.random.controller or (None,):
                    items.append((ctl, push, None))
        else:
            for r in s.runs:
                items.append((r.controller, r.push(body=s.body, after=s.after), None))
        if s.replicas is not None:
            return self._replica_rows(items, s.replicas)
        rows: list[Row] = []
        keys: set[str] = set()
        for rep in range(s.repeats):
            for ctl, push, gnd in items:
                # a grid's ground is part of the row's identity (an experiment-wide one is not, as before)
                ident = json.dumps([ctl, asdict(push), rep] + ([list(gnd)] if gnd is not None else []),
                                   sort_keys=True)
                key = hashlib.sha1(ident.encode()).hexdigest()[:12]
                # random pushes, rounded to what a row shows, can repeat: each row needs its own key
                twin = 1
                while key in keys:
                    key = hashlib.sha1(f"{ident}#{twin}".encode()).hexdigest()[:12]
                    twin += 1
                keys.add(key)
                idx = len(rows)
                rows.append(Row(index=idx, key=key, controller=self.resolve(ctl), push=push, repeat=rep,
                                seed=s.seed + idx, ground=s.ground if gnd is None else gnd))
        return rows


    def _replica_rows(self, items: list[tuple[str | None, Push, tuple[str, ...] | None]],
                      rep: Replicas) -> list[Row]:
        """The rows of a replicated grid: every cell ``rep.count`` times, replica-major. A replica's
        seed (``seed`` + replica) draws its initial noise, the same for every cell, so one unpushed
        rollout per replica serves them all; its phase offset is drawn per cell (the same for every
        controller and ground of the grid)."""
        s = self.spec
        rows: list[Row] = []
        for replica in range(rep.count):
            for ctl, push, gnd in items:
                # the controllers and grounds of a grid meet the same perturbations: a paired comparison
                cell = json.dumps({k: v for k, v in asdict(push).items() if k != "magnitude"}, sort_keys=True)
                moved, off = rep.shifted(push, s.seed, replica, cell)
                ident = json.dumps([ctl, asdict(moved), replica, "replica"]
                                   + ([list(gnd)] if gnd is not None else []), sort_keys=True)
                key = hashlib.sha1(ident.encode()).hexdigest()[:12]
                rows.append(Row(index=len(rows), key=key, controller=self.resolve(ctl), push=moved, repeat=replica,
                                seed=s.seed + replica, offset=off, init_noise=rep.init_noise(replica),
                                ground=s.ground if gnd is None else gnd))
        return rows


def load_experiment(path: str | os.PathLike[str]) -> Experiment:
    """Load and validate an experiment file: keys, values, referenced files, body names, pushes."""
    p = Path(path)
    spec = config.load(ExperimentSpec, p)
    return check_experiment(Experiment(spec=spec, path=p.resolve()), p)


def check_experiment(exp: Experiment, path: str | os.PathLike[str], prefix: str = "") -> Experiment:
    """Check what a parsed experiment refers to: its rollouts, every push against the run's length,
    the reference and controller files, the push body. ``prefix`` goes before each key an error names
    (``"experiment."`` for an experiment inside another file, e.g. a tune)."""
    p, spec = Path(path), exp.spec
    rows = exp.rows()
    if not rows:
        raise ConfigError("the experiment expands to no rollouts", path=p, key=f"{prefix}grid")
    # repeats hold the same pushes; replicas move them
    per_repeat = len(rows) if spec.replicas is not None else len(rows) // spec.repeats
    for r in rows[:per_repeat]:
        key = "grid" if spec.grid else ("random" if spec.random else f"runs[{r.index}]")
        check_pushes([r.push], spec.seconds, path=p, key=f"{prefix}{key}", seconds_key=f"{prefix}seconds")
    ref = exp.resolve(spec.reference)
    if ref is not None and not Path(ref).is_file():
        raise ConfigError(f"no such file {ref}", path=p, key=f"{prefix}reference")
    ctl_key = f"{prefix}random.controller" if spec.random else f"{prefix}grid.controller"
    controllers = sorted({r.controller for r in rows if r.controller})
    for ctl in controllers:
        if not Path(ctl).is_file():
            raise ConfigError(f"no such controller file {ctl}", path=p, key=ctl_key)
    bodies, kind = _body_names(ref, spec.profile, spec.support)
    for ctl in controllers:
        _check_controller(ctl, kind, p, ctl_key)
    if spec.body not in bodies and spec.body != DEFAULT_PUSH_BODY:
        raise ConfigError(f"unknown body {spec.body!r}; bodies are {', '.join(sorted(bodies))}", path=p,
                          key=f"{prefix}body")
    for b in spec.grid.body if spec.grid is not None else ():
        if b not in bodies and b != DEFAULT_PUSH_BODY:
            raise ConfigError(f"unknown body {b!r}; bodies are {', '.join(sorted(bodies))}", path=p,
                              key=f"{prefix}grid.body")
    return exp


def _check_controller(ctl: str, kind: str, path: Path, key: str) -> None:
    """Load the controller file ``ctl`` named at ``key`` of the file at ``path`` and refuse settings a
    body of ``kind`` would not read (the error names both files)."""
    cfg = load_controller(ctl)
    try:
        check_settings_for_body(cfg, kind, path=ctl)
    except ConfigError as exc:
        raise ConfigError(str(exc), path=path, key=key) from None


def _body_names(reference: str | None, profile: str = "auto", support: bool = False) -> tuple[set[str], str]:
    """The names of the bodies built from ``reference`` (None: the built-in walk) as the rollouts build
    them, and the body's kind (``humanoid`` or ``creature``)."""
    _, _, motion, kind = load_source(reference or BUILTIN_WALK, profile=profile,  # as the rollouts read it
                                        support=support)
    built = build_model(motion, kind, source=reference or BUILTIN_WALK)
    return {built.model.body(i).name for i in range(1, built.model.nbody)}, kind


def _body_kind(reference: str | None, profile: str, support: bool) -> str:
    """The kind of body a scenario builds: ``profile`` when given, else measured from ``reference`` as
    the rollouts read it (None: the built-in walk, a humanoid)."""
    if profile != "auto":
        return profile
    if reference is None:
        return "humanoid"
    return load_source(reference, profile=profile, support=support)[3]


# ---------------------------------------------------------------------- regression suites
#: What a scenario may expect (push_not_applied is never expected: it says the scenario is broken).
EXPECTATIONS = ("no_fall", "fall", "diverged")


@dataclass(frozen=True)
class SuiteScenario:
    """One scenario of a regression suite: a reference, a controller, pushes and the expected outcome."""

    name: str
    expect: str = field(default="no_fall", metadata={"choices": EXPECTATIONS})
    reference: str | None = None
    controller: str | None = None
    profile: str = field(default="auto", metadata={"choices": PROFILES})
    support: bool = False
    seconds: float = field(default=8.0, metadata={"gt": 0.0, "max": MAX_ROLLOUT_S})
    seed: int = field(default=0, metadata={"min": 0})  # numpy's generators take no negative seed
    pushes: tuple[PushItem, ...] = ()
    #: the ground's terms (``bipedsim run --ground``; :class:`~bipedsim.model.ground.Ground`); empty: flat
    ground: tuple[str, ...] = ()

    def validate(self) -> None:
        check_name(self.name)
        check_ground(self.ground)
        for j, item in enumerate(self.pushes):
            if item.controller is not None:
                raise ValueError(f"pushes[{j}].controller: a suite's pushes take the scenario's controller; "
                                 "give controller on the scenario")

    def push_list(self) -> list[Push]:
        return [item.push() for item in self.pushes]


@dataclass(frozen=True)
class Suite:
    name: str = "suite"
    scenarios: tuple[SuiteScenario, ...] = ()
    #: null: the body kind's default criteria (FallCriteria.for_body)
    fall: FallCriteria | None = None

    def validate(self) -> None:
        check_name(self.name)
        if not self.scenarios:
            raise ValueError("scenarios: the suite has no scenarios")
        names = [s.name for s in self.scenarios]
        for i, n in enumerate(names):
            if n in names[:i]:
                raise ValueError(f"scenarios[{i}].name: {n!r} is also scenarios[{names.index(n)}]'s name; "
                                 "scenario names must be unique")


def resolve_relative(base: Path, rel: str | None) -> str | None:
    """``rel`` (a path in a file at ``base``'s folder) as an absolute path; None stays None."""
    if rel is None:
        return None
    p = Path(rel)
    return str(p if p.is_absolute() else (base / p).resolve())


def load_suite(path: str | os.PathLike[str]) -> Suite:
    """Load and validate a suite: keys, values, the files it names and every push against its
    scenario's length, before any rollout."""
    p = Path(path)
    suite = config.load(Suite, p)
    base = p.resolve().parent
    for i, sc in enumerate(suite.scenarios):
        check_pushes(sc.push_list(), sc.seconds, path=p, key=f"scenarios[{i}].pushes",
                     seconds_key=f"scenarios[{i}].seconds")
        ref = resolve_relative(base, sc.reference)
        if ref is not None and not Path(ref).is_file():
            raise ConfigError(f"no such file {ref}", path=p, key=f"scenarios[{i}].reference")
        ctl = resolve_relative(base, sc.controller)
        if ctl is not None:
            if not Path(ctl).is_file():
                raise ConfigError(f"no such controller file {ctl}", path=p, key=f"scenarios[{i}].controller")
            cfg = load_controller(ctl)
            if unread_settings(cfg, "humanoid") or unread_settings(cfg, "creature"):  # one kind's settings
                try:
                    check_settings_for_body(cfg, _body_kind(ref, sc.profile, sc.support), path=ctl)
                except ConfigError as exc:
                    raise ConfigError(str(exc), path=p, key=f"scenarios[{i}].controller") from None
    return suite
