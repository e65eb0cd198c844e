"""Exceptions of rfidnav_drivers; each message is meant for a person and names the device and what to check."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class DriverError(RfidnavError):
    """A device cannot be used: not there, no permission, or it answers something this driver cannot read."""
