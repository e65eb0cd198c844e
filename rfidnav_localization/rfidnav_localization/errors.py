"""Exceptions of rfidnav_localization."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class LocalizationError(RfidnavError):
    """A localizer was asked for something its observations cannot give (e.g. a pose before any tag read)."""


class LocateError(RfidnavError):
    """A WiFi scan cannot be placed on the radio map (empty scan or map, no access point in common, bad RSS).

    The node answers the request with this message instead of a position, so the robot can scan again.
    """


class StoreError(RfidnavError):
    """The location server's database file is missing, not an SQLite database, damaged, or of another schema.

    The message names the file, e.g. ``maps/site.db: schema version 3 is newer than this rfidnav knows (2)``.
    """

    def __init__(self, path: str, problem: str) -> None:
        self.path = path
        self.problem = problem
        super().__init__(f"{path}: {problem}")
