"""Exceptions of rfidnav_bringup (orchestration, scenarios, node processes)."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class LaunchError(RfidnavError):
    """A node process could not be started (unknown package or executable, bad command)."""


class ReadinessError(RfidnavError):
    """The node graph did not become ready: names the node or action that is missing, with its last log lines."""


class NodeExitedError(ReadinessError):
    """A node process exited while the graph was being readied: final, never worth waiting out or asking again."""
