"""Exceptions of rfidnav_control; each message is meant for a person and names the offending item."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class ControlError(RfidnavError):
    """A controller was given something it cannot act on (a bad specification, a NaN measurement)."""


class FuzzySpecError(ControlError):
    """A fuzzy controller specification is inconsistent, e.g. unsorted set points or a rule naming an unknown set.

    Raised while the specification is built, so a bad parameter file fails before any node starts driving.
    """
