"""Typed, validated access to YAML configuration (scenarios, worlds, maps, parameter files).

Every problem is one :class:`ConfigError` naming the file and the dotted field, raised before anything
starts: ``config/worlds/hallway.yaml: tags[2].position: expected 3 numbers, got 2``.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import yaml

from rfidnav_common.errors import ConfigError, ParameterError

_MISSING: Any = object()


def load_yaml_file(path: Path) -> Any:
    """Parse a YAML file; a missing file or a syntax error is a ConfigError naming the file (and line)."""
    source = str(path)
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise ConfigError(source, "", "file not found") from None
    except OSError as error:
        raise ConfigError(source, "", f"cannot read: {error.strerror}") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(error, "problem", None) or str(error)
        raise ConfigError(source, "", f"not valid YAML: {where}{problem}") from None


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
        allowed = set(allowed)
        for key in self.data:
            if key not in allowed:
                raise self.error(str(key), f"unknown field (expected one of: {', '.join(sorted(allowed))})")

    def number(self, key: str, default: Any = _MISSING, *, minimum: float | None = None,
               maximum: float | None = None, positive: bool = False) -> float:
        value = self.raw(key, default)
        return check_number(value, self.source, self.field(key), minimum=minimum, maximum=maximum, positive=positive)

    def integer(self, key: str, default: Any = _MISSING, *, minimum: int | None = None) -> int:
        value = self.raw(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"expected an integer, got {type_name(value)}")
        if minimum is not None and value < minimum:
            raise self.error(key, f"must be at least {minimum}, got {value}")
        return value

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
        for index, item in enumerate(items):
            if isinstance(item, bool) or not isinstance(item, int):
                raise ConfigError(self.source, f"{self.field(key)}[{index}]", f"expected an integer, got "
                                                                               f"{type_name(item)}")
        return list(items)

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
    """A finite float, or a ConfigError naming source and field."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(source, field, f"expected a number, got {type_name(value)}")
    number = float(value)
    if not math.isfinite(number):
        raise ConfigError(source, field, f"expected a finite number, got {value}")
    if positive and number <= 0.0:
        raise ConfigError(source, field, f"must be positive, got {number:g}")
    if minimum is not None and number < minimum:
        raise ConfigError(source, field, f"must be at least {minimum:g}, got {number:g}")
    if maximum is not None and number > maximum:
        raise ConfigError(source, field, f"must be at most {maximum:g}, got {number:g}")
    return number


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


def require_positive(parameters: Any, *names: str) -> None:
    """For a parameter class's validate(): each named field must be a positive finite number (a ParameterError
    naming the first that is not)."""
    for name in names:
        value = getattr(parameters, name)
        if not (math.isfinite(value) and value > 0.0):
            raise ParameterError(name, f"must be positive, got {value}")


def typed_values(cls: type, data: Any, source: str, prefix: str = "") -> dict[str, Any]:
    """Type-check ``data`` against the fields of parameter dataclass ``cls``; return the values given.

    Fields may be float, int, bool, str, list[float], list[int] or list[str] (the ROS 2 parameter types);
    unknown fields and NaN/Inf are errors."""
    hints = typing.get_type_hints(cls)
    section = Section(data if data is not None else {}, source, prefix)
    section.reject_unknown(hints)
    getters = {float: section.number, bool: section.boolean, int: section.integer, str: section.string}
    values: dict[str, Any] = {}
    for name in section.keys():
        kind = hints[name]
        if kind in getters:
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

    A ``validate()`` :class:`ParameterError` naming one of ``cls``'s fields is reported against that field
    where its value came from: ``origins`` maps field names to the (source, prefix) of the file that set them;
    without ``origins`` every value came from ``source``/``prefix``. Any other ``validate()`` error (between
    fields, about a field of an inner settings class, or a plain ValueError) is reported against
    ``source``/``prefix``."""
    instance = cls(**typed_values(cls, data, source, prefix))
    validate = getattr(instance, "validate", None)
    if validate is not None:
        try:
            validate()
        except ParameterError as error:
            if origins is None:
                origins = dict.fromkeys(typing.get_type_hints(cls), (source, prefix))
            if error.field in origins:
                origin, origin_prefix = origins[error.field]
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


def param(doc: str, default: Any) -> Any:
    """A parameter dataclass field: its default and the description the node declares with it."""
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata={"doc": doc})
    return dataclasses.field(default=default, metadata={"doc": doc})
