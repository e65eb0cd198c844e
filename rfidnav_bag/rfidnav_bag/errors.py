"""Exceptions of rfidnav_bag (recording, playing and reading rosbag2 MCAP bags)."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class BagError(RfidnavError):
    """A bag is missing, truncated, or not a rosbag2 MCAP directory rfidnav can read; names the path."""
