"""Exceptions shared by every rfidnav package."""

from __future__ import annotations


class RfidnavError(Exception):
    """Base of every error rfidnav raises on purpose; its message is meant for a person."""


class ConfigError(RfidnavError):
    """A configuration file (scenario, world, map, parameters) is missing, malformed or inconsistent.

    The message names the file and the field, e.g. ``config/worlds/hallway.yaml: tags[3].z: expected a number``.
    """

    def __init__(self, source: str, field: str, problem: str) -> None:
        self.source = source
        self.field = field
        self.problem = problem
        where = f"{source}: {field}" if field else source
        super().__init__(f"{where}: {problem}")


class UnknownExecutableError(RfidnavError):
    """A package or executable that is not installed. ``field`` is ``package`` (not installed) or ``executable``
    (the package has no such executable)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


class ParameterError(ValueError):
    """A parameter or settings class's ``validate()`` found a value it cannot work with.

    ``field`` is the offending field's name, or "" when the problem lies between fields (``problem`` then names
    them); the message reads ``field: problem``. A ValueError, so callers that catch ValueError keep working;
    rfidnav_common.config reports it against the file and line that set the field."""

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        super().__init__(f"{field}: {problem}" if field else problem)
