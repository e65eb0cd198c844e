"""rclpy beyond its public API is reached for in one module, rfidnav_common.rclpy_compat; these tests fail, by
name, when an rclpy upgrade moves what it reaches for."""

from __future__ import annotations

import inspect
from importlib.metadata import version
from pathlib import Path

import pytest
from rclpy.clock import ROSClock
from rclpy.node import Node

from rfidnav_common import rclpy_compat

pytestmark = pytest.mark.tier("unit")

WORKSPACE = Path(__file__).resolve().parents[1]


def test_the_installed_rclpy_is_the_one_the_compatibility_module_was_written_against() -> None:
    assert version("ros-jazzy-rclpy") == rclpy_compat.WRITTEN_AGAINST_RCLPY, \
        "rclpy changed: check each function of rfidnav_common/rclpy_compat.py against it, then update the version"
    pinned = (WORKSPACE / "requirements.txt").read_text()
    assert f"ros-jazzy-rclpy[fastrtps]=={rclpy_compat.WRITTEN_AGAINST_RCLPY}" in pinned


def test_the_private_clock_switch_it_uses_still_exists_and_turns_ros_time_on() -> None:
    assert callable(getattr(ROSClock, "_set_ros_time_is_active", None))
    clock = ROSClock()
    assert not clock.ros_time_is_active
    rclpy_compat.drive_ros_time_without_clock_topic(clock)
    assert clock.ros_time_is_active


def test_node_still_takes_the_publisher_class_the_stepped_node_counts_with() -> None:
    assert "publisher_class" in inspect.signature(Node.create_publisher).parameters


def test_no_module_but_the_compatibility_module_calls_rclpys_private_clock_switch() -> None:
    callers = [path.relative_to(WORKSPACE).as_posix() for path in WORKSPACE.glob("rfidnav_*/rfidnav_*/**/*.py")
               if "_set_ros_time_is_active" in path.read_text()]
    assert callers == ["rfidnav_common/rfidnav_common/rclpy_compat.py"]
