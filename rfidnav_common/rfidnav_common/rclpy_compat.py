"""Every use of rclpy that is not its public API, in one place, written against rclpy 7.1.6 (ROS 2 Jazzy).

``test/test_rclpy_compat.py`` checks the installed rclpy is the version this was written against and that what it
reaches for is still there, so an rclpy upgrade fails there, by name, instead of somewhere in the stepped clock.
"""

from __future__ import annotations

from typing import Any

from rclpy.clock import ROSClock
from rclpy.subscription import Subscription

WRITTEN_AGAINST_RCLPY = "7.1.6"


def drive_ros_time_without_clock_topic(clock: ROSClock) -> None:
    """Make ``clock`` read ROS time that its owner sets (``set_ros_time_override``) without a ``/clock``
    subscription: rclpy's TimeSource does the same when ``/clock`` arrives, through this switch it keeps private
    (a stepped node takes its time from the stamps it handles instead)."""
    clock._set_ros_time_is_active(True)


def hand_message_info(subscription: Subscription) -> None:
    """Have every executor hand ``subscription``'s callback each message's info too (its DDS publication sequence
    number): rclpy decides that by the callback's signature when it is set, through a field it keeps private. A
    callback so marked takes its arguments through :func:`message_and_info`, since rclpy 7.1's EventsExecutor
    calls it with one (message, info) tuple where its other executors pass two arguments."""
    subscription._callback_type = Subscription.CallbackType.WithMessageInfo


def message_and_info(*taken: Any) -> tuple[Any, dict[str, Any]]:
    """What an executor handed a callback marked by :func:`hand_message_info`: the message and its info."""
    message, info = taken if len(taken) == 2 else taken[0]
    return message, info
