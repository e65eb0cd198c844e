"""Exceptions of rfidnav_planning."""

from __future__ import annotations

from rfidnav_common.errors import RfidnavError


class PlanningError(RfidnavError):
    """No plan can be made: the start or goal lies outside the deployment, or the deployment is not triangular."""
