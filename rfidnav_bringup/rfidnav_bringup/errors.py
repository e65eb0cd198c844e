"""Exceptions of rfidnav_bringup (orchestration, bags, reports)."""

from __future__ import annotations

from rfidnav_common.errors import ConfigError, RfidnavError

__all__ = ["BagError", "ConfigError", "RfidnavError", "LaunchError", "ReadinessError"]


class BagError(RfidnavError):
    """A bag is missing, truncated, or not a rosbag2 MCAP directory rfidnav can read; names the path."""


class LaunchError(RfidnavError):
    """A node process could not be started (unknown package or executable, bad command)."""


class ReadinessError(RfidnavError):
    """The node graph did not become ready: names the node or action that is missing, with its last log lines."""
