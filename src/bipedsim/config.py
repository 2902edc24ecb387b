"""YAML -> validated, typed configuration.

Configuration classes are frozen dataclasses. :func:`from_dict` builds one from a mapping, checking
every key against the fields (unknown keys are rejected with the allowed ones listed), every value
against the field's type, and the bounds given in the field's metadata::

    kp: float = field(default=300.0, metadata={"min": 0.0})
    mode: str = field(default="pd", metadata={"choices": ("pd", "spd")})

Every error is a :class:`~bipedsim.errors.ConfigError` naming the file and the dotted key.
"""

from __future__ import annotations

import dataclasses
import math
import os
import types
import typing
from pathlib import Path
from typing import Any, TypeVar, Union, get_args, get_origin, get_type_hints

import yaml

from bipedsim.errors import ConfigError, InputError
from bipedsim.files import read_input_text

T = TypeVar("T")


#: Deepest nesting of mappings and lists a YAML file may have; configuration files here nest about 5
#: deep. PyYAML builds nested nodes recursively, so a deeper file would end in a RecursionError.
MAX_YAML_DEPTH = 64
#: Most values a YAML file may hold with its aliases expanded (``*name`` repeats an anchored value: ten
#: nested levels of ten aliases each stand for 10**10 values in a file of a few hundred bytes).
MAX_YAML_NODES = 1_000_000

_MERGE_TAG = "tag:yaml.org,2002:merge"


class _UniqueKeyLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses a mapping naming one key twice (PyYAML keeps the last silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG:
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.get(key)
            except TypeError:  # an unhashable key: the base class says so with its own message
                continue
            if first is not None:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} is given twice (first on line {first}); give it once",
                    key_node.start_mark)
            seen[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


def _check_size(text: str) -> None:
    """Raise :class:`yaml.YAMLError` where the nesting passes :data:`MAX_YAML_DEPTH` or the values with
    aliases expanded pass :data:`MAX_YAML_NODES` (read from the event stream, which PyYAML parses without
    recursion and without expanding aliases)."""
    stack: list[list[Any]] = [[0, None]]  # per open collection: expanded values so far, its anchor
    anchors: dict[str, int] = {}
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        if isinstance(event, yaml.MappingStartEvent | yaml.SequenceStartEvent):
            if len(stack) > MAX_YAML_DEPTH:
                raise yaml.parser.ParserError(None, None, f"nested more than {MAX_YAML_DEPTH} levels deep",
                                              event.start_mark)
            stack.append([0, event.anchor])
            continue
        if isinstance(event, yaml.MappingEndEvent | yaml.SequenceEndEvent):
            n, anchor = stack.pop()
            n += 1
        elif isinstance(event, yaml.ScalarEvent):
            n, anchor = 1, event.anchor
        elif isinstance(event, yaml.AliasEvent):
            n, anchor = anchors.get(event.anchor, 1), None
        else:
            continue
        if anchor is not None:
            anchors[anchor] = n
        stack[-1][0] += n
        if stack[-1][0] > MAX_YAML_NODES:
            raise yaml.parser.ParserError(None, None, f"holds more than {MAX_YAML_NODES} values with its "
                                          "aliases expanded", event.start_mark)


def parse_yaml(text: str, path: str | os.PathLike[str] | None = None) -> Any:
    """Parse YAML ``text`` safely (no Python objects): nesting at most :data:`MAX_YAML_DEPTH` deep, no key
    given twice in one mapping, at most :data:`MAX_YAML_NODES` values with aliases expanded. Errors become
    :class:`ConfigError` with the line and column."""
    try:
        _check_size(text)
        return yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(f"{where}invalid YAML: {problem}", path=path) from None


def load_yaml(path: str | os.PathLike[str]) -> Any:
    """Read and parse a YAML file (see :func:`parse_yaml`); the file is refused before it is read when it
    is not a regular file or is larger than the YAML limit (:func:`bipedsim.files.read_input_text`)."""
    try:
        text = read_input_text(path, "yaml")
    except InputError as exc:
        raise ConfigError(exc.reason, path=path) from None
    return parse_yaml(text, path=Path(path))


def _type_name(tp: Any) -> str:
    origin = get_origin(tp)
    if origin in (Union, types.UnionType):
        return " or ".join(_type_name(a) for a in get_args(tp))
    if origin is typing.Literal:
        return " or ".join(repr(a) for a in get_args(tp))
    if origin is not None:
        args = ", ".join(_type_name(a) for a in get_args(tp) if a is not Ellipsis)
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if tp is type(None):
        return "null"
    return getattr(tp, "__name__", str(tp))


def _convert(value: Any, tp: Any, key: str, path: str | None) -> Any:
    origin = get_origin(tp)
    if tp is Any:
        return value
    if origin in (Union, types.UnionType):
        args = get_args(tp)
        if value is None and type(None) in args:
            return None
        real = [a for a in args if a is not type(None)]
        if len(real) == 1:  # Optional[X]: X's own, more precise error
            return _convert(value, real[0], key, path)
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(value, a, key, path)
            except ConfigError as exc:
                errors.append(exc)
        raise ConfigError(f"expected {_type_name(tp)}, got {value!r}", path=path, key=key)
    if dataclasses.is_dataclass(tp):
        return from_dict(tp, value, path=path, prefix=key)  # type: ignore[arg-type]
    if origin in (list, tuple):
        if not isinstance(value, list | tuple):
            raise ConfigError(f"expected a list ({_type_name(tp)}), got {value!r}", path=path, key=key)
        args = get_args(tp)
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise ConfigError(f"expected {len(args)} items, got {len(value)}", path=path, key=key)
            return tuple(_convert(v, a, f"{key}[{i}]", path) for i, (v, a) in enumerate(zip(value, args)))
        item = args[0] if args else Any
        out = [_convert(v, item, f"{key}[{i}]", path) for i, v in enumerate(value)]
        return tuple(out) if origin is tuple else out
    if origin is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"expected a mapping, got {value!r}", path=path, key=key)
        kt, vt = get_args(tp) or (Any, Any)
        return {_convert(k, kt, key, path): _convert(v, vt, f"{key}.{k}", path) for k, v in value.items()}
    if origin is typing.Literal:
        if value not in get_args(tp):
            raise ConfigError(f"must be one of {list(get_args(tp))}, got {value!r}", path=path, key=key)
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"expected true or false, got {value!r}", path=path, key=key)
        return value
    if tp is float:
        if isinstance(value, str):
            # YAML 1.1 reads 1.0e9 (no sign in the exponent) as text; take it as the number meant
            try:
                value = float(value)
            except ValueError:
                raise ConfigError(f"expected a number, got {value!r}", path=path, key=key) from None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"expected a number, got {value!r}", path=path, key=key)
        if not math.isfinite(float(value)):
            raise ConfigError(f"must be a finite number, got {value!r}", path=path, key=key)
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"expected an integer, got {value!r}", path=path, key=key)
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"expected a string, got {value!r}", path=path, key=key)
        return value
    return value


def _check_bounds(value: Any, meta: typing.Mapping[str, Any], key: str, path: str | None) -> None:
    if value is None:
        return
    vals = value if isinstance(value, list | tuple) else [value]
    for v in vals:
        if not isinstance(v, int | float) or isinstance(v, bool):
            continue
        if "min" in meta and v < meta["min"]:
            raise ConfigError(f"must be >= {meta['min']}, got {v}", path=path, key=key)
        if "gt" in meta and v <= meta["gt"]:
            raise ConfigError(f"must be > {meta['gt']}, got {v}", path=path, key=key)
        if "max" in meta and v > meta["max"]:
            raise ConfigError(f"must be <= {meta['max']}, got {v}", path=path, key=key)
    if "choices" in meta and value not in meta["choices"]:
        raise ConfigError(f"must be one of {list(meta['choices'])}, got {value!r}", path=path, key=key)


def from_dict(cls: type[T], data: Any, path: str | os.PathLike[str] | None = None,
              prefix: str = "") -> T:
    """Build dataclass ``cls`` from ``data``, validating keys, types and bounds.

    After construction the instance's ``validate()`` method, if any, runs for cross-field checks; it
    should raise ``ValueError`` whose message becomes a :class:`ConfigError` at ``prefix``.
    """
    p = None if path is None else str(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping of keys, got {type(data).__name__}", path=p,
                          key=prefix or None)
    hints = get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}  # type: ignore[arg-type]
    unknown = [k for k in data if k not in fields]
    if unknown:
        k = unknown[0]
        full = f"{prefix}.{k}" if prefix else str(k)
        raise ConfigError(f"unknown key; allowed keys here: {', '.join(sorted(fields))}", path=p, key=full)
    kwargs = {}
    for name, value in data.items():
        full = f"{prefix}.{name}" if prefix else name
        v = _convert(value, hints[name], full, p)
        _check_bounds(v, fields[name].metadata, full, p)
        kwargs[name] = v
    try:
        obj = cls(**kwargs)
    except TypeError as exc:
        raise ConfigError(str(exc), path=p, key=prefix or None) from None
    validate = getattr(obj, "validate", None)
    if callable(validate):
        try:
            validate()
        except ValueError as exc:
            msg = str(exc)
            key = prefix or None
            if ": " in msg and " " not in msg.split(": ", 1)[0]:
                sub, msg = msg.split(": ", 1)
                key = f"{prefix}.{sub}" if prefix else sub
            raise ConfigError(msg, path=p, key=key) from None
    return obj


def to_dict(obj: Any) -> Any:
    """A dataclass (nested) as plain Python data, for recording with outputs."""
    if dataclasses.is_dataclass(obj):
        return {f.name: to_dict(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, list | tuple):
        return [to_dict(v) for v in obj]
    if isinstance(obj, dict):
        return {k: to_dict(v) for k, v in obj.items()}
    return obj


def load(cls: type[T], path: str | os.PathLike[str]) -> T:
    """Load and validate a YAML file into ``cls``."""
    return from_dict(cls, load_yaml(path), path=path)


# ---------------------------------------------------------------------- limits from the environment
def limit_from_env(name: str, default: int) -> int:
    """A count limit, ``default`` unless the environment variable ``BIPEDSIM_MAX_<NAME>`` sets another
    positive whole number (for one command on a machine that can afford more)."""
    env = f"BIPEDSIM_MAX_{name.upper()}"
    text = os.environ.get(env)
    if not text:
        return default
    try:
        value = int(text)
    except ValueError:
        raise ConfigError(f"{env}={text!r}: expected a positive whole number") from None
    if value <= 0:
        raise ConfigError(f"{env}={text!r}: expected a positive whole number")
    return value
