"""Exceptions of rfidnav_localization."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class LocalizationError(RfidnavError):
    """A localizer was asked for something its observations cannot give (e.g. a pose before any tag read)."""
