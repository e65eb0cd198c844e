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
