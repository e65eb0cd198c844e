"""Typed, validated access to YAML configuration (scenarios, worlds, maps, parameter files).

Every problem is one :class:`ConfigError` naming the file and the dotted field, raised before anything
starts: ``config/worlds/hallway.yaml: tags[2].position: expected 3 numbers, got 2``.

Every file is read by :func:`load_yaml_file`: UTF-8 only, no key given twice in one mapping. Every number is finite
and within ``MAX_MAGNITUDE`` (no coordinate, speed or range of an indoor robot comes near it); every integer fits
the int64 of a ROS parameter. A parameter dataclass field declares its own range next to its default and doc
(:func:`param`, :class:`Limits`); :func:`parameters_from_mapping` enforces it before the class's ``validate()``.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import typing
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import yaml

from rfidnav_common.errors import ConfigError, ParameterError

_MISSING: Any = object()

MAX_MAGNITUDE = 1e6            # no number of a configuration lies beyond (1000 km, 11 days, 1 MHz, ...)
INT64_MIN, INT64_MAX = -(1 << 63), (1 << 63) - 1   # a ROS 2 integer parameter
MAX_DURATION_S = 86400.0       # timeouts and periods: one day of (sim) time at most
MAX_SPEED_MPS = 5.0            # an indoor robot (the Create 2's wheels: 0.5 m/s)
MAX_RATE_HZ = 1000.0           # sensor and control rates
MAX_READ_RANGE_M = 100.0       # beyond any RFID read (UHF passive: ~12 m, active tags: ~100 m)
MAX_PORT = 65535               # reader antenna ports (TagReading.antenna is a uint16) and TCP ports


class _UniqueKeyLoader(yaml.SafeLoader):
    """yaml.SafeLoader that refuses a key given twice in one mapping (PyYAML keeps the last one silently) and an
    alias inside the node it names (``a: &x [*x]``: a structure that contains itself, which no check can walk)."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.open_anchors: set[str] = set()

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent) and self.peek_event().anchor in self.open_anchors:
            event = self.peek_event()
            raise yaml.composer.ComposerError(None, None, f"alias *{event.anchor} inside the node it names (a "
                                                          "structure that contains itself)", event.start_mark)
        return super().compose_node(parent, index)

    def compose_sequence_node(self, anchor: str | None) -> Any:
        return self._composing(anchor, super().compose_sequence_node)

    def compose_mapping_node(self, anchor: str | None) -> Any:
        return self._composing(anchor, super().compose_mapping_node)

    def _composing(self, anchor: str | None, compose: Any) -> Any:
        if anchor is not None:
            self.open_anchors.add(anchor)
        try:
            return compose(anchor)
        finally:
            self.open_anchors.discard(anchor or "")

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        first_line: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":      # ``<<: *defaults``: overriding is what it is for
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first = first_line.get(key)
            except TypeError:                # an unhashable key: SafeLoader's own error names it
                continue
            if first is not None:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping", node.start_mark,
                    f"duplicate key '{key}' (first given on line {first})", key_node.start_mark)
            first_line[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep=deep)


def load_yaml_file(path: Path) -> Any:
    """Parse a YAML file; a missing or unreadable file, text that is not UTF-8, a syntax error or a key given twice is
    a ConfigError naming the file (and line, or byte offset)."""
    source = str(path)
    path = Path(path)
    try:
        if path.exists() and not path.is_file():
            raise ConfigError(source, "", "not a file")
        data = path.read_bytes()
    except FileNotFoundError:
        raise ConfigError(source, "", "file not found") from None
    except OSError as error:
        raise ConfigError(source, "", f"cannot read: {error.strerror}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data.count(b"\n", 0, error.start) + 1
        raise ConfigError(source, "", f"not UTF-8 text: byte 0x{data[error.start]:02x} at offset {error.start} "
                                      f"(line {line})") from None
    return load_yaml_text(text, source)


def load_yaml_text(text: str, source: str) -> Any:
    """Parse YAML text (a file's, or an option's such as ``--goal``); a syntax error or a key given twice is a
    ConfigError naming ``source`` and the line."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(error, "problem", None) or str(error)
        raise ConfigError(source, "", f"not valid YAML: {where}{problem}") from None
    except RecursionError:
        raise ConfigError(source, "", "not valid YAML: nested too deeply") from None


class Section:
    """A mapping from a configuration file with typed getters that report file and field on error."""

    def __init__(self, data: Any, source: str, prefix: str = "") -> None:
        if not isinstance(data, Mapping):
            raise ConfigError(source, prefix, f"expected a mapping, got {type_name(data)}")
        self.data = data
        self.source = source
        self.prefix = prefix

    @classmethod
    def from_file(cls, path: Path) -> Section:
        data = load_yaml_file(path)
        if data is None:
            raise ConfigError(str(path), "", "file is empty")
        return cls(data, str(path))

    def field(self, key: str | int) -> str:
        if isinstance(key, int):
            return f"{self.prefix}[{key}]"
        return f"{self.prefix}.{key}" if self.prefix else key

    def error(self, key: str | int, problem: str) -> ConfigError:
        return ConfigError(self.source, self.field(key), problem)

    def has(self, key: str) -> bool:
        return key in self.data

    def keys(self) -> list[str]:
        return list(self.data.keys())

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        if key not in self.data:
            if default is _MISSING:
                raise self.error(key, "missing required field")
            return default
        return self.data[key]

    def reject_unknown(self, allowed: Iterable[str]) -> None:
        """An unknown key is an error naming it, the known key nearest to it (a typo) and all the known ones."""
        allowed = set(allowed)
        for key in self.data:
            if key not in allowed:
                raise self.error(str(key), unknown_field(str(key), allowed))

    def number(self, key: str, default: Any = _MISSING, *, minimum: float | None = None,
               maximum: float | None = None, positive: bool = False) -> float:
        value = self.raw(key, default)
        return check_number(value, self.source, self.field(key), minimum=minimum, maximum=maximum, positive=positive)

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int = INT64_MIN,
                maximum: int = INT64_MAX) -> int:
        return check_integer(self.raw(key, default), self.source, self.field(key), minimum=minimum, maximum=maximum)

    def string(self, key: str, default: Any = _MISSING, *, choices: Iterable[str] | None = None) -> str:
        value = self.raw(key, default)
        if not isinstance(value, str) or not value:
            raise self.error(key, f"expected a non-empty string, got {type_name(value)}")
        if choices is not None and value not in set(choices):
            raise self.error(key, f"'{value}' is not one of: {', '.join(sorted(choices))}")
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got {type_name(value)}")
        return value

    def section(self, key: str, default: Any = _MISSING) -> Section:
        return Section(self.raw(key, default), self.source, self.field(key))

    def sections(self, key: str, default: Any = _MISSING) -> list[Section]:
        items = self.raw(key, default)
        if not isinstance(items, list):
            raise self.error(key, f"expected a list, got {type_name(items)}")
        return [Section(item, self.source, f"{self.field(key)}[{index}]") for index, item in enumerate(items)]

    def numbers(self, key: str, default: Any = _MISSING, *, length: int | None = None) -> list[float]:
        items = self.raw(key, default)
        if not isinstance(items, list):
            raise self.error(key, f"expected a list of numbers, got {type_name(items)}")
        if length is not None and len(items) != length:
            raise self.error(key, f"expected {length} numbers, got {len(items)}")
        return [check_number(item, self.source, f"{self.field(key)}[{i}]") for i, item in enumerate(items)]

    def integers(self, key: str, default: Any = _MISSING) -> list[int]:
        items = self.raw(key, default)
        if not isinstance(items, list):
            raise self.error(key, f"expected a list of integers, got {type_name(items)}")
        return [check_integer(item, self.source, f"{self.field(key)}[{index}]") for index, item in enumerate(items)]

    def strings(self, key: str, default: Any = _MISSING, *, unique: bool = False) -> list[str]:
        items = self.raw(key, default)
        if not isinstance(items, list):
            raise self.error(key, f"expected a list of strings, got {type_name(items)}")
        seen: set[str] = set()
        for index, item in enumerate(items):
            if not isinstance(item, str) or not item:
                raise ConfigError(self.source, f"{self.field(key)}[{index}]",
                                  f"expected a non-empty string, got {type_name(item)}")
            if unique and item in seen:
                raise ConfigError(self.source, f"{self.field(key)}[{index}]", f"duplicate '{item}'")
            seen.add(item)
        return list(items)


def check_number(value: Any, source: str, field: str, *, minimum: float | None = None,
                 maximum: float | None = None, positive: bool = False) -> float:
    """A finite float within ``MAX_MAGNITUDE`` (and the bounds given), or a ConfigError naming source and field."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(source, field, f"expected a number, got {type_name(value)}")
    try:
        number = float(value)
    except OverflowError:                # an integer beyond any float
        raise ConfigError(source, field, f"must be within ±{MAX_MAGNITUDE:g}, got {value}") from None
    if not math.isfinite(number):
        raise ConfigError(source, field, f"expected a finite number, got {value}")
    if abs(number) > MAX_MAGNITUDE:
        raise ConfigError(source, field, f"must be within ±{MAX_MAGNITUDE:g}, got {number:g}")
    if positive and number <= 0.0:
        raise ConfigError(source, field, f"must be positive, got {number:g}")
    if minimum is not None and number < minimum:
        raise ConfigError(source, field, f"must be at least {minimum:g}, got {number:g}")
    if maximum is not None and number > maximum:
        raise ConfigError(source, field, f"must be at most {maximum:g}, got {number:g}")
    return number


def check_integer(value: Any, source: str, field: str, *, minimum: int = INT64_MIN, maximum: int = INT64_MAX) -> int:
    """An integer within the bounds given (by default the int64 of a ROS parameter), or a ConfigError naming source
    and field."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(source, field, f"expected an integer, got {type_name(value)}")
    if value < minimum:
        raise ConfigError(source, field, f"must be at least {minimum}, got {value}")
    if value > maximum:
        raise ConfigError(source, field, f"must be at most {maximum}, got {value}")
    return value


def unknown_field(key: str, known: Iterable[str]) -> str:
    """The problem of an unknown key: the nearest known one (a typo), then every known one."""
    known = sorted(known)
    return f"unknown field ({did_you_mean(key, known)}expected one of: {', '.join(known)})"


def did_you_mean(key: str, known: Iterable[str]) -> str:
    """"did you mean 'NAME'? " for the known name nearest to a mistyped ``key`` (difflib), else ""."""
    nearest = difflib.get_close_matches(key, list(known), n=1)
    return f"did you mean '{nearest[0]}'? " if nearest else ""


def type_name(value: Any) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, bool):
        return f"boolean {value}"
    if isinstance(value, (int, float)):
        return f"number {value}"
    if isinstance(value, str):
        return f"string '{value}'" if value else "an empty string"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, Mapping):
        return "a mapping"
    return type(value).__name__


def typed_values(cls: type, data: Any, source: str, prefix: str = "") -> dict[str, Any]:
    """Type-check ``data`` against the fields of parameter dataclass ``cls``; return the values given.

    Fields may be float, int, bool, str, list[float], list[int] or list[str] (the ROS 2 parameter types);
    unknown fields and NaN/Inf are errors, but for ``+inf`` in a field whose limits are ``unbounded``."""
    hints = typing.get_type_hints(cls)
    unbounded = {field.name for field in dataclasses.fields(cls) if Limits.of(field).unbounded}
    section = Section(data if data is not None else {}, source, prefix)
    section.reject_unknown(hints)
    getters = {float: section.number, bool: section.boolean, int: section.integer, str: section.string}
    values: dict[str, Any] = {}
    for name in section.keys():
        kind = hints[name]
        if name in unbounded and section.raw(name) == math.inf:
            values[name] = math.inf
        elif kind in getters:
            values[name] = getters[kind](name)
        elif kind == list[float]:
            values[name] = section.numbers(name)
        elif kind == list[int]:
            values[name] = section.integers(name)
        elif kind == list[str]:
            values[name] = section.strings(name)
        else:
            raise TypeError(f"{cls.__name__}.{name}: unsupported parameter type {kind}")
    return values


def parameters_from_mapping(cls: type, data: Any, source: str, prefix: str = "",
                            origins: Mapping[str, tuple[str, str]] | None = None) -> Any:
    """Build and validate parameter dataclass ``cls`` from ``data``; missing fields take their defaults.

    Each field's declared :class:`Limits` are checked first (:func:`check_limits`), then ``validate()`` (what lies
    between fields). A :class:`ParameterError` naming one of ``cls``'s fields is reported against that field
    where its value came from: ``origins`` maps field names to the (source, prefix) of the file that set them;
    without ``origins`` every value came from ``source``/``prefix``. Any other ``validate()`` error (between
    fields, about a field of an inner settings class, or a plain ValueError) is reported against
    ``source``/``prefix``."""
    instance = cls(**typed_values(cls, data, source, prefix))
    validate = getattr(instance, "validate", None)
    try:
        check_limits(instance)
        if validate is not None:
            validate()
    except ParameterError as error:
        if origins is None:
            origins = dict.fromkeys(typing.get_type_hints(cls), (source, prefix))
        name = error.field.partition("[")[0]        # a list's item: "antenna_max_range_m[1]"
        if name in origins:
            origin, origin_prefix = origins[name]
            field = f"{origin_prefix}.{error.field}" if origin_prefix else error.field
            raise ConfigError(origin, field, error.problem) from None
        raise ConfigError(source, prefix, str(error)) from None
    except ValueError as error:   # recorder_node's and player_node's validate() raise no ParameterError yet
        raise ConfigError(source, prefix, str(error)) from None
    return instance


def node_parameter_section(path: Path, node_name: str) -> Section:
    """The ``ros__parameters`` of ``node_name`` (or of the ``/**`` wildcard) in a ROS 2 parameter file."""
    document = Section.from_file(path)
    if document.has(node_name):
        node_section = document.section(node_name)
    else:
        wildcard = [key for key in document.keys() if key in ("/**", "**")]
        if not wildcard:
            raise ConfigError(str(path), node_name, "no parameters for this node (expected a top-level "
                              f"'{node_name}:' with 'ros__parameters:')")
        node_section = document.section(wildcard[0])
    values = node_section.raw("ros__parameters")
    return Section(values if values is not None else {}, str(path), node_section.field("ros__parameters"))


def node_parameter_values(cls: type, path: Path, node_name: str) -> dict[str, Any]:
    """The type-checked values of a ROS 2 parameter file (``node_name: ros__parameters: {...}``)."""
    section = node_parameter_section(path, node_name)
    return typed_values(cls, section.data, section.source, section.prefix)


@dataclasses.dataclass(frozen=True)
class Limits:
    """The values a parameter field may take (each item, for a list): numbers from ``low`` to ``high``, a bound left
    out when it is ``*_open`` and absent when None; or one of ``choices`` (strings, or integers such as baud rates).
    ``unbounded``: the number may also be ``+inf`` (``.inf`` in YAML), a value with no bound, such as an RTF that
    sets no ceiling; every other number is finite. Declared with the field (:func:`param`), as its metadata ``min``,
    ``max``, ``min_exclusive``, ``max_exclusive``, ``choices`` and ``unbounded``."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple[Any, ...] = ()
    unbounded: bool = False

    def metadata(self) -> dict[str, Any]:
        entries = {"min": self.low, "max": self.high, "min_exclusive": self.low_open or None,
                   "max_exclusive": self.high_open or None, "choices": self.choices or None,
                   "unbounded": self.unbounded or None}
        return {key: value for key, value in entries.items() if value is not None}

    @classmethod
    def of(cls, field: dataclasses.Field) -> Limits:
        meta = field.metadata
        return cls(meta.get("min"), meta.get("max"), meta.get("min_exclusive", False),
                   meta.get("max_exclusive", False), tuple(meta.get("choices", ())), meta.get("unbounded", False))

    def problem(self, value: Any) -> str | None:
        """Why ``value`` is outside these limits; None when it is inside (or of a type they do not limit)."""
        if self.choices:
            if value in self.choices:
                return None
            shown = f"'{value}'" if isinstance(value, str) else str(value)
            return f"{shown} is not one of: {', '.join(map(str, self.choices))}"
        if isinstance(value, str):
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return None
        above = self.low is None or (value > self.low if self.low_open else value >= self.low)
        below = self.high is None or (value < self.high if self.high_open else value <= self.high)
        return None if above and below else f"must be {self.text()}, got {_number_text(value)}"

    def text(self) -> str:
        """The limits in words: "positive and at most 5", "in [0, 1)", "at least 1", ..."""
        low, high = _number_text(self.low), _number_text(self.high)
        below = "" if self.high is None else f"below {high}" if self.high_open else f"at most {high}"
        if self.unbounded:
            return f"{Limits(self.low, self.high, self.low_open, self.high_open).text()} or .inf (no bound)"
        if self.low == 0 and self.low_open:
            return "positive" + (f" and {below}" if below else "")
        if self.low is None:
            return below
        if self.high is None:
            return f"above {low}" if self.low_open else f"at least {low}"
        return f"in {'(' if self.low_open else '['}{low}, {high}{')' if self.high_open else ']'}"


def _number_text(value: float | None) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}" if value is not None else ""


# The ranges most parameters share (MAX_* above: the bounds of what is plausible).
POSITIVE = Limits(0.0, low_open=True)                    # (every number is within MAX_MAGNITUDE, when read)
NON_NEGATIVE = Limits(0.0)
FRACTION = Limits(0.0, 1.0)                              # [0, 1]
PROBABILITY = Limits(0.0, 1.0, high_open=True)           # [0, 1): at 1 nothing would ever be read
DURATION_S = Limits(0.0, MAX_DURATION_S, low_open=True)
SPEED_MPS = Limits(0.0, MAX_SPEED_MPS, low_open=True)
RATE_HZ = Limits(0.0, MAX_RATE_HZ, low_open=True)
READ_RANGE_M = Limits(0.0, MAX_READ_RANGE_M, low_open=True)
YAW_DEG = Limits(-360.0, 360.0)
YAW_RATE_RADPS = Limits(0.0, 10.0, low_open=True)        # more than a turn and a half a second: no indoor robot
DBM = Limits(-200.0, 100.0)                              # radio powers, from below any noise floor to 10 kW
PORT = Limits(1, MAX_PORT)
SEED = Limits(0)                                         # (every integer fits int64, when read)
AT_LEAST_ONE = Limits(1)


def param(doc: str, default: Any, limits: Limits | None = None) -> Any:
    """A parameter dataclass field: its default, the description the node declares with it and the values it may
    take (:class:`Limits`; without them a number need only be finite, within MAX_MAGNITUDE, and an integer fit int64,
    which every value read is checked for)."""
    metadata = {"doc": doc, **(limits.metadata() if limits is not None else {})}
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def check_limits(parameters: Any) -> None:
    """Each field of a parameter dataclass instance (each item of a list field) within its declared
    :class:`Limits`; else a ParameterError naming the field (an item as ``name[index]``)."""
    for field in dataclasses.fields(parameters):
        limits = Limits.of(field)
        value = getattr(parameters, field.name)
        for index, item in enumerate(value) if isinstance(value, list) else ((None, value),):
            problem = limits.problem(item)
            if problem is not None:
                raise ParameterError(field.name if index is None else f"{field.name}[{index}]", problem)
