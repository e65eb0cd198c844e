"""robot_sim: differential-drive base, simulation clock, wheel odometry, ground truth, world markers, and the
bumper: the base stalls at the world's walls and reports each press and release on /base/event, stopping and
refusing forward motion while pressed, as create_base does (rfidnav_sim.kinematics).

Owns simulated time: steps the base at ``step_s`` and publishes /clock (at ``odom_rate_hz``, with
/odom and /sim/ground_truth) so that ``rtf`` seconds of sim time pass per wall second. Every other node runs
with use_sim_time. With ``start_paused`` the clock stays at zero until ``~/start`` (std_srvs/Trigger) is called,
so slow process start-up costs no sim time.
"""

from __future__ import annotations

import math
import time
from typing import Any

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from rfidnav_common.base_safety import BaseEventRecord
from rfidnav_common.ros import COMMAND_QOS, LATCHED_QOS, SENSOR_QOS, declare_parameters, run_node, time_msg
from rfidnav_msgs.msg import BaseEvent
from rfidnav_sim.conversions import base_event_message, odometry_message, world_markers
from rfidnav_sim.parameters import RobotSimParameters
from rfidnav_sim.world import load_world


class RobotSimNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("robot_sim", **node_options)
        self.params: RobotSimParameters = declare_parameters(self, RobotSimParameters)
        p = self.params
        self.world = load_world(p.world_file)
        self.base = p.base(self.world.wall_segments())
        self.steps = 0
        self.steps_per_odom = max(1, round(1.0 / (p.odom_rate_hz * p.step_s)))
        self.running = not p.start_paused
        self.wall_origin = time.monotonic()

        self.clock_pub = self.create_publisher(ClockMsg, "/clock", SENSOR_QOS)
        self.odom_pub = self.create_publisher(Odometry, "/odom", SENSOR_QOS)
        self.truth_pub = self.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, "/sim/markers", LATCHED_QOS)
        self.event_pub = self.create_publisher(BaseEvent, "/base/event", COMMAND_QOS)
        self.create_subscription(Twist, "/cmd_vel", self.on_cmd_vel, COMMAND_QOS)
        self.create_service(Trigger, "~/start", self.on_start)
        # The clock source cannot pace itself on sim time: a steady wall timer drives the steps,
        # running as many as are due so that the long-run rate is exactly rtf. Waking more often than
        # every 10 ms wall buys nothing at 50 Hz of published sim time and costs CPU the graph needs.
        period = max(p.step_s / p.rtf, 0.01)
        self.create_timer(period, self.on_tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.markers_pub.publish(world_markers(self.world, self.sim_time_msg()))
        self.get_logger().info(
            f"world '{self.world.name}' with {len(self.world.tags)} tags; step {p.step_s} s at RTF {p.rtf}"
            + (" (paused until ~/start)" if p.start_paused else ""))

    def sim_time_msg(self):
        return time_msg(self.steps * self.params.step_s)

    def on_cmd_vel(self, msg: Twist) -> None:
        if not (math.isfinite(msg.linear.x) and math.isfinite(msg.angular.z)):
            self.get_logger().warning("ignored /cmd_vel with a non-finite value", throttle_duration_sec=5.0)
            return
        self.base.set_command(msg.linear.x, msg.angular.z)

    def on_start(self, _request, response):
        if not self.running:
            self.running = True
            self.wall_origin = time.monotonic()
            self.get_logger().info("clock started")
        response.success = True
        response.message = f"running at sim time {self.steps * self.params.step_s:.3f} s"
        return response

    def on_tick(self) -> None:
        if not self.running:
            return
        p = self.params
        due = int((time.monotonic() - self.wall_origin) * p.rtf / p.step_s)
        # After a stall (a slow machine), do not burst through the backlog faster than 50 steps a tick.
        for _ in range(min(due - self.steps, 50)):
            events = self.base.step(p.step_s)
            self.steps += 1
            for event in events:
                self.publish_event(event)
            # /clock, /odom and ground truth share one rate: nothing in the graph needs finer time, and
            # every /clock message costs each use_sim_time node a callback.
            if self.steps % self.steps_per_odom == 0:
                self.publish_clock()
                self.publish_odometry()
        if due - self.steps > 50:
            self.wall_origin = time.monotonic() - self.steps * p.step_s / p.rtf

    def publish_event(self, event: BaseEventRecord) -> None:
        if event.active:
            truth = self.base.truth
            self.get_logger().warning(f"{event.event} at ({truth.x:.2f}, {truth.y:.2f}): stopped the base; "
                                      f"{event.action.replace('_', ' ')} while it holds")
        self.event_pub.publish(base_event_message(event, self.sim_time_msg()))

    def publish_clock(self) -> None:
        self.clock_pub.publish(ClockMsg(clock=self.sim_time_msg()))

    def publish_odometry(self) -> None:
        stamp = self.sim_time_msg()
        velocity = self.base.velocity
        self.truth_pub.publish(odometry_message(self.base.truth, velocity, stamp, self.world.frame_id))
        self.odom_pub.publish(odometry_message(self.base.odom, velocity, stamp, "odom"))


def main(args: list[str] | None = None) -> int:
    return run_node(RobotSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
