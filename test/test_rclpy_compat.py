"""rclpy beyond its public API is reached for in one module, rfidnav_common.rclpy_compat; these tests fail, by
name, when an rclpy upgrade moves what it reaches for."""

from __future__ import annotations

import inspect
import time
from importlib.metadata import version
from pathlib import Path

import pytest
import rclpy
from rclpy.clock import ROSClock
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import String

from rfidnav_common import rclpy_compat
from rfidnav_common.ros import events_executor
from support.graph import WAIT_S

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


@pytest.mark.tier("node")
@pytest.mark.parametrize("make_executor", [events_executor, SingleThreadedExecutor], ids=["events", "single"])
def test_a_callback_marked_for_message_info_gets_each_message_and_its_publication_number_from_either_executor(
        make_executor, domain: int) -> None:
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    try:
        executor = make_executor(context=context)
        node = Node("numbers", context=context)
        executor.add_node(node)
        taken: list[tuple[str, int]] = []

        def on_message(*handed: object) -> None:
            message, info = rclpy_compat.message_and_info(*handed)
            taken.append((message.data, info["publication_sequence_number"]))

        publisher = node.create_publisher(String, "/numbered", 10)
        rclpy_compat.hand_message_info(node.create_subscription(String, "/numbered", on_message, 10))
        deadline = time.monotonic() + WAIT_S
        while publisher.get_subscription_count() < 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        for text in ("a", "b"):
            publisher.publish(String(data=text))
        while len(taken) < 2 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        assert taken == [("a", 1), ("b", 2)]
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()
        context.destroy()
