"""``./rfidnav echo TOPIC``: print a topic's messages as YAML documents (ros2cli is not among the PyPI wheels), to
check a driver alone, e.g. ``.venv/bin/llrp_reader --ros-args -p host:=10.0.0.5 & ./rfidnav echo /rfid/reads``.

The message type is taken from the graph, so the publisher must be up within ``wait_s``; the subscription's QoS
follows the publishers' as ros2cli's does: best effort if any publisher is (a best-effort publisher is heard only
by a best-effort subscriber), transient local if all are (a latched publisher, e.g. /sim/markers or /tf_static,
hands its last message only to a transient-local subscriber). It ends after ``count`` messages, or fails when they
did not all come within ``timeout_s``.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

import yaml
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rfidnav_bringup.partition import JOIN_ADVICE, UNKNOWN_NODE_NAME
from rfidnav_common.errors import RfidnavError
from rfidnav_common.ros import message_class, standalone_node


class EchoError(RfidnavError):
    """The topic cannot be echoed: no publisher, an unknown type, or too few messages in time."""


def plain(message: Any) -> Any:
    """A message as plain Python values (nested messages as dicts, arrays as lists), for YAML."""
    if hasattr(message, "get_fields_and_field_types"):
        return {name: plain(getattr(message, name)) for name in message.get_fields_and_field_types()}
    if isinstance(message, (list, tuple)) or hasattr(message, "tolist"):
        return [plain(item) for item in (message.tolist() if hasattr(message, "tolist") else message)]
    return message


def matching_qos(publishers: list[QoSProfile]) -> QoSProfile:
    """A subscription that every one of ``publishers`` serves, getting what a latched one keeps."""
    best_effort = any(p.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers)
    latched = bool(publishers) and all(p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                      reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def echo(topic: str, count: int, wait_s: float, timeout_s: float, out: TextIO = sys.stdout,
         domain_id: int | None = None) -> int:
    """Print ``count`` messages of ``topic``; returns how many came (EchoError when fewer did in time). The
    domain is ROS_DOMAIN_ID's unless ``domain_id`` is given."""
    received: list[Any] = []
    with standalone_node("rfidnav_echo", domain_id) as (node, executor):
        type_name = wait_for_type(node, executor, topic, wait_s)
        cls = message_class(type_name)
        if cls is None:
            raise EchoError(f"{topic}: type {type_name} is not installed here")
        qos = matching_qos([info.qos_profile for info in node.get_publishers_info_by_topic(topic)])

        def on_message(message: Any) -> None:
            if len(received) < count:
                received.append(message)
                out.write(yaml.safe_dump(plain(message), sort_keys=False) + "---\n")
                out.flush()

        node.create_subscription(cls, topic, on_message, qos)
        deadline = time.monotonic() + timeout_s
        while len(received) < count and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        if len(received) < count:
            raise EchoError(f"{topic}: {len(received)} of {count} messages within {timeout_s:g} s"
                            + ("" if received else partition_hint(node, topic)))
        return len(received)


def partition_hint(node: Node, topic: str) -> str:
    """Why nothing came, when the topic's publishers are all of nodes this process cannot name: outside its DDS
    partition (a run's graph, heard of in discovery but never matched)."""
    publishers = node.get_publishers_info_by_topic(topic)
    if not publishers or any(info.node_name != UNKNOWN_NODE_NAME for info in publishers):
        return ""
    return f"; its publishers are outside this process's DDS partition ({JOIN_ADVICE})"


def wait_for_type(node: Node, executor: SingleThreadedExecutor, topic: str, wait_s: float) -> str:
    """The type of ``topic`` (pkg/msg/Name) once someone publishes it."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        types = dict(node.get_topic_names_and_types()).get(topic)
        if types and node.count_publishers(topic) > 0:
            return types[0]
        executor.spin_once(timeout_sec=0.1)
    raise EchoError(f"{topic}: no publisher within {wait_s:g} s (is the driver running, on this ROS_DOMAIN_ID?)")
