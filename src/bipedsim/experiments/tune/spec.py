"""Tune files (``TUNE.yaml``): which controller to start from, which of its values to tune within
which ranges, the reference clip(s), the budget, and the experiment whose rollouts score a candidate.

Everything is checked before any rollout, to the standard of the other YAML files: unknown keys,
reversed or empty ranges, dotted keys the controller does not have (or that are not numbers), a range
end the controller itself would refuse (a negative gain), missing files, an experiment that does not
fit its run -- each error names the file and the key (:class:`~bipedsim.errors.ConfigError`).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from bipedsim import config
from bipedsim.control.creature.controller import CreatureControlConfig
from bipedsim.control.settings import ControllerConfig, load_controller
from bipedsim.errors import ConfigError
from bipedsim.experiments.experiment import Experiment, ExperimentSpec, check_experiment, resolve_relative
from bipedsim.experiments.tune.objective import Objective
from bipedsim.sim.runner import PROFILES

#: The controller settings a candidate changes, by body kind (``profile``): the humanoid's SIMBICON
#: controller file, or the creature controller's settings.
CONFIG_CLASSES: dict[str, type] = {"humanoid": ControllerConfig, "creature": CreatureControlConfig}
#: Keys of the tune's ``experiment`` block that belong to the tune itself (given once, at the top).
TOP_LEVEL_KEYS = ("reference", "profile", "support")
#: The largest budget (candidates evaluated). Each candidate is several rollouts of seconds each, so
#: 100,000 is weeks of CPU time; the bound keeps a typo (an extra zero or three) from sizing the history
#: and the saved state beyond any real tune.
MAX_EVALUATIONS = 100_000
#: The largest generation: CMA-ES samples a whole generation at once (memory and time in proportion).
MAX_POPSIZE = 10_000
#: The most candidate values (evaluations x parameters) a tune may record: its saved state holds every
#: candidate evaluated (about 20 bytes a value in JSON), so this keeps the state under 40 MB, within the
#: size a resumed tune reads back without raising a limit (``bipedsim.files.INPUT_LIMITS_MB["json"]``).
MAX_STATE_VALUES = 2_000_000


@dataclass(frozen=True)
class TuneSpec:
    """A tune file, validated. Ranges and values are in the controller's own units."""

    name: str = "tune"
    #: the controller file to start from (relative to the tune file); null: the default controller
    controller: str | None = None
    #: a BVH file or a list of them (relative to the tune file); null: the built-in walk
    reference: str | tuple[str, ...] | None = None
    #: the body kind built from the reference(s) (``bipedsim run --profile``)
    profile: str = field(default="humanoid", metadata={"choices": PROFILES})
    #: a creature's root support (``bipedsim run --support``)
    support: bool = False
    #: dotted controller keys -> [low, high]
    parameters: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: candidates evaluated by CMA-ES (the start controller is evaluated besides, as the baseline)
    evaluations: int = field(default=96, metadata={"min": 1, "max": MAX_EVALUATIONS})
    seed: int = field(default=1, metadata={"min": 0})
    #: candidates per generation (at most ``evaluations``); null: CMA-ES's default, 4 + 3 ln(parameters)
    popsize: int | None = field(default=None, metadata={"min": 2, "max": MAX_POPSIZE})
    #: CMA-ES's initial step, as a fraction of each parameter's range
    sigma: float = field(default=0.3, metadata={"gt": 0.0, "max": 1.0})
    #: the rollouts that score each candidate (sweep format: grid, runs or random), besides an
    #: unperturbed walk of its ``seconds``
    experiment: ExperimentSpec | None = None
    objective: Objective = field(default_factory=Objective)

    def validate(self) -> None:
        if not self.parameters:
            raise ValueError("parameters: name at least one controller key to tune, e.g. "
                             "balance.sagittal.cd: [0.0, 1.5]")
        for key, (lo, hi) in self.parameters.items():
            if not lo < hi:
                raise ValueError(f"parameters.{key}: [low, high] must have low < high, got [{lo:g}, {hi:g}]")
        if self.popsize is not None and self.popsize > self.evaluations:
            # CMA-ES learns only from whole generations: one larger than the budget is never told
            raise ValueError(f"popsize: {self.popsize} candidates per generation is more than the whole budget "
                             f"(evaluations: {self.evaluations}); give popsize <= evaluations")
        values = self.evaluations * len(self.parameters)
        if values > MAX_STATE_VALUES:
            raise ValueError(f"evaluations: {self.evaluations} candidates x {len(self.parameters)} parameters is "
                             f"{values:,} values to record, above the {MAX_STATE_VALUES:,} a tune holds; give "
                             "fewer evaluations or parameters")
        if self.experiment is None:
            raise ValueError("experiment: give the experiment whose rollouts score each candidate "
                             "(seconds and a grid, runs or random pushes, as in experiments/*.yaml)")
        if self.reference is not None and not isinstance(self.reference, str):
            if not self.reference:
                raise ValueError("reference: an empty list; give a BVH file, a list of them, or null")
            twice = next((r for i, r in enumerate(self.reference) if r in self.reference[:i]), None)
            if twice is not None:
                raise ValueError(f"reference: {twice} is listed twice")
        exp = self.experiment
        ctl = exp.grid.controller if exp.grid else (exp.random.controller if exp.random else ())
        ctl = ctl or tuple(r.controller for r in exp.runs if r.controller)
        if ctl:
            where = "grid" if exp.grid else ("random" if exp.random else "runs")
            raise ValueError(f"experiment.{where}: names controller files; a tune scores its own candidates "
                             "(give the controller to start from as controller:)")

    def references(self) -> tuple[str | None, ...]:
        """The reference clips as given (``None``: the built-in walk)."""
        if self.reference is None or isinstance(self.reference, str):
            return (self.reference,)
        return tuple(self.reference)


@dataclass
class Tune:
    """A loaded tune: the spec, its file, the start controller's settings (a plain mapping) and the
    references resolved against the file's folder."""

    spec: TuneSpec
    path: Path
    controller_path: str | None
    references: tuple[str | None, ...]
    start: dict[str, Any]

    @property
    def keys(self) -> list[str]:
        return list(self.spec.parameters)

    def experiment(self) -> Experiment:
        return Experiment(spec=self.spec.experiment, path=self.path)  # type: ignore[arg-type]

    def start_values(self) -> dict[str, float]:
        return {k: float(get_dotted(self.start, k)) for k in self.keys}

    def settings(self, values: dict[str, float]) -> Any:
        """The controller settings (a :class:`ControllerConfig` or :class:`CreatureControlConfig`) of
        the start controller with ``values`` (dotted key -> value) put in; ConfigError names the tune
        file when the result is a controller the project refuses."""
        data = self.start
        for k, v in values.items():
            data = set_dotted(data, k, float(v))
        cls = CONFIG_CLASSES[self.spec.profile]
        try:
            return config.from_dict(cls, data)
        except ConfigError as exc:
            shown = ", ".join(f"{k}={v:g}" for k, v in values.items())
            raise ConfigError(f"the candidate {shown} is a controller bipedsim refuses ({exc}); narrow the "
                              "ranges", path=self.path, key="parameters") from None


def get_dotted(data: Any, key: str) -> Any:
    """``data``'s value at dotted ``key`` (``pd.gains.hip.kp``); KeyError naming the first missing part."""
    cur = data
    for i, part in enumerate(key.split(".")):
        if not isinstance(cur, dict) or part not in cur:
            raise KeyError(".".join(key.split(".")[:i + 1]))
        cur = cur[part]
    return cur


def set_dotted(data: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    """A copy of ``data`` with ``value`` at dotted ``key`` (which must exist: :func:`get_dotted`)."""
    head, _, rest = key.partition(".")
    out = dict(data)
    out[head] = set_dotted(data[head], rest, value) if rest else value
    return out


def _start_settings(spec: TuneSpec, ctl_path: str | None, path: Path) -> dict[str, Any]:
    """The start controller's settings as a mapping, from its file over the defaults (a creature's: the
    file's ``creature:`` section)."""
    if spec.profile == "creature":  # its settings: a controller file's creature: section, or the defaults
        if ctl_path is not None and not Path(ctl_path).is_file():
            raise ConfigError(f"no such controller file {ctl_path}", path=path, key="controller")
        start = CreatureControlConfig() if ctl_path is None else load_controller(ctl_path).creature
        return config.to_dict(replace(start, support=spec.support or start.support))
    if spec.support:
        raise ConfigError("root support holds a creature's root; it needs profile: creature", path=path,
                          key="support")
    if ctl_path is not None and not Path(ctl_path).is_file():
        raise ConfigError(f"no such controller file {ctl_path}", path=path, key="controller")
    return config.to_dict(load_controller(ctl_path))


def _check_parameters(tune: Tune) -> None:
    """Every dotted key names a number of the controller, and the controller takes each range end."""
    spec, path = tune.spec, tune.path
    cls = CONFIG_CLASSES[spec.profile]
    for key, (lo, hi) in spec.parameters.items():
        where = f"parameters.{key}"
        if spec.profile == "creature" and key.startswith("support_") and not spec.support:
            raise ConfigError("the root support's gains act only with root support: without support: true "
                              "every candidate would score the same", path=path, key=where)
        try:
            value = get_dotted(tune.start, key)
        except KeyError as exc:
            raise ConfigError(f"the {spec.profile} controller has no key {exc.args[0]!r}; the tunable values "
                              f"are its numbers, e.g. {', '.join(_examples(tune.start)[:6])}", path=path,
                              key=where) from None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"is {value!r} in the start controller, not a number; only numbers can be tuned",
                              path=path, key=where)
        for end in (lo, hi):
            try:
                config.from_dict(cls, set_dotted(tune.start, key, float(end)))
            except ConfigError as exc:
                raise ConfigError(f"the controller refuses {end:g} here ({exc.reason})", path=path,
                                  key=where) from None


def _examples(data: dict[str, Any], prefix: str = "") -> list[str]:
    """Dotted keys of the numbers in ``data`` (for an error's hint)."""
    out: list[str] = []
    for k, v in data.items():
        if isinstance(v, dict):
            out += _examples(v, f"{prefix}{k}.")
        elif isinstance(v, int | float) and not isinstance(v, bool):
            out.append(f"{prefix}{k}")
    return out


def load_tune(path: str | os.PathLike[str]) -> Tune:
    """Load and check a tune file (keys, ranges, controller keys, files, the experiment against each
    reference's body); every error is a ConfigError naming the file and the key."""
    p = Path(path)
    raw = config.load_yaml(p)
    if isinstance(raw, dict) and isinstance(raw.get("experiment"), dict):
        for k in TOP_LEVEL_KEYS:
            if k in raw["experiment"]:
                raise ConfigError(f"{k} belongs to the tune, not its experiment: give it once, at the top of "
                                  "the file", path=p, key=f"experiment.{k}")
    spec = config.from_dict(TuneSpec, raw, path=p)
    base = p.resolve().parent
    refs = tuple(resolve_relative(base, r) for r in spec.references())
    for i, ref in enumerate(refs):
        if ref is not None and not Path(ref).is_file():
            key = "reference" if isinstance(spec.reference, str) else f"reference[{i}]"
            raise ConfigError(f"no such file {ref}", path=p, key=key)
    if spec.profile == "creature" and None in refs:
        raise ConfigError("the creature profile needs a motion: give a BVH file", path=p, key="reference")
    ctl = resolve_relative(base, spec.controller)
    tune = Tune(spec=spec, path=p.resolve(), controller_path=ctl, references=refs,
                start=_start_settings(spec, ctl, p))
    _check_parameters(tune)
    for ref in refs:
        exp_spec = dataclasses.replace(spec.experiment, reference=ref, profile=spec.profile,  # type: ignore[type-var]
                                       support=spec.support)
        check_experiment(Experiment(spec=exp_spec, path=tune.path), p, prefix="experiment.")
    return tune


__all__ = ["CONFIG_CLASSES", "MAX_EVALUATIONS", "MAX_POPSIZE", "MAX_STATE_VALUES", "Tune", "TuneSpec", "get_dotted",
           "load_tune", "set_dotted"]
