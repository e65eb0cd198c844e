"""Every use of rclpy that is not its public API, in one place, written against rclpy 7.1.6 (ROS 2 Jazzy).

``test/test_rclpy_compat.py`` checks the installed rclpy is the version this was written against and that what it
reaches for is still there, so an rclpy upgrade fails there, by name, instead of somewhere in the stepped clock.
"""

from __future__ import annotations

from rclpy.clock import ROSClock

WRITTEN_AGAINST_RCLPY = "7.1.6"


def drive_ros_time_without_clock_topic(clock: ROSClock) -> None:
    """Make ``clock`` read ROS time that its owner sets (``set_ros_time_override``) without a ``/clock``
    subscription: rclpy's TimeSource does the same when ``/clock`` arrives, through this switch it keeps private
    (a stepped node takes its time from the stamps it handles instead)."""
    clock._set_ros_time_is_active(True)
