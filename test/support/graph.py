"""Nodes under test and a probe node on one private rclpy context and executor, stepped with ``spin_once`` until a
stated condition holds (no sleeps)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import pytest
import rclpy
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Log
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.ros import time_msg

WAIT_S = 10.0   # generous for a loaded 2-core machine; each wait normally takes milliseconds


# /rosout is transient local: a subscriber that joins late still gets what the nodes logged.
ROSOUT_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Graph:
    """A private context, one executor, and the nodes under test plus a probe node on it."""

    def __init__(self, domain_id: int) -> None:
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.nodes: list[Node] = []
        self.clients: list[ActionClient] = []
        self.probe = self.add(Node("probe", context=self.context))
        self.logs: list[Log] = []
        self.probe.create_subscription(Log, "/rosout", self.logs.append, ROSOUT_QOS)

    def add(self, node: Node) -> Any:
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin_until(self, condition: Callable[[], bool], what: str, timeout_s: float = WAIT_S) -> None:
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout_s:.0f} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def logged(self, node_name: str, *words: str) -> list[str]:
        return [log.msg for log in self.logs if log.name == node_name and all(w in log.msg for w in words)]

    def close(self) -> None:
        """Destroy everything, so no DDS entity outlives the test (the domain goes back to the lease pool):
        rclpy's destroy_node leaves action clients and servers alive, and the participant lives until the
        context is destroyed."""
        self.executor.shutdown()
        for client in self.clients:
            client.destroy()
        for node in self.nodes:
            node.destroy_node()
        self.context.try_shutdown()
        self.context.destroy()


def ground_truth(x: float, y: float, yaw_deg: float, stamp_s: float) -> Odometry:
    msg = Odometry()
    msg.header.stamp = time_msg(stamp_s)
    msg.header.frame_id, msg.child_frame_id = "map", "base_link"
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    qx, qy, qz, qw = yaw_to_quaternion(math.radians(yaw_deg))
    msg.pose.pose.orientation.x, msg.pose.pose.orientation.y = qx, qy
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = qz, qw
    return msg
