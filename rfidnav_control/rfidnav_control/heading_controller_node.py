"""heading_controller: action server /follow_tag_route driving /cmd_vel from /rfid/reads (paper 001).

A thin adapter around TagRouteFollower: every TagReadArray (one inventory round) while a goal is
active becomes one follower step and one /cmd_vel. A round in another frame than base_link, and reads with a
number no reader reports (rfidnav_common.inputs.tag_read: non-finite, an RSS or a frequency beyond physics, port
0), are dropped and counted before they reach the controller (phases of any size are wrapped); rounds whose left
and right reads of the target are on different channels are not steered on (tag_route.pair_phases) and counted
too, each with a throttled warning. One route at a time, cancel and the watchdog on /rfid/reads:
rfidnav_common.goal_server.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from geometry_msgs.msg import Twist

from rfidnav_common import inputs
from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer, Watchdog
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.ros import (
    COMMAND_QOS,
    SENSOR_QOS,
    declare_parameters,
    input_drops,
    run_node,
    seconds_of,
    sim_clock_seconds,
    twist,
)
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_control.fuzzy import FuzzyHeadingController
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_control.tag_route import Command, TagRouteFollower
from rfidnav_msgs.action import FollowTagRoute
from rfidnav_msgs.msg import TagReadArray


@dataclass
class RouteGoal(ActiveGoal):
    started_s: float
    tags_reached: int = 0


class HeadingControllerNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("heading_controller", **node_options)
        self.params: HeadingControllerParameters = declare_parameters(self, HeadingControllerParameters)
        route_map = load_route_map(self.params.map_file)
        self.follower = TagRouteFollower(self.params.follower_settings(),
                                         FuzzyHeadingController(self.params.fuzzy_spec()), route_map.arrival_tags,
                                         map_source=f"the route map {self.params.map_file}")
        self.drops = input_drops(self)
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", COMMAND_QOS)
        self.create_subscription(TagReadArray, "rfid/reads", self.on_reads, SENSOR_QOS)
        self.goals: SingleGoalServer[RouteGoal] = SingleGoalServer(
            self, FollowTagRoute, "follow_tag_route", what="route", busy="another route is being followed",
            check=lambda goal: self.follower.refusal(list(goal.tag_ids)),
            new_goal=lambda handle: RouteGoal(handle, started_s=self.now_s()),
            started=self.on_started, result=self.result, stop=lambda: self.cmd_pub.publish(Twist()),
            watchdog=Watchdog(self.params.unheard_timeout_s, "inventory rounds on /rfid/reads"))
        self.get_logger().info(f"route map '{route_map.name}' with {len(route_map.arrival_tags)} tags; "
                               f"{len(self.params.rules)} fuzzy rules, arrival by {self.params.arrival}")

    def destroy_node(self) -> None:
        self.goals.destroy()
        super().destroy_node()

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_started(self, goal: RouteGoal) -> None:
        route = list(goal.handle.request.tag_ids)
        self.follower.start(route, goal.started_s)
        self.get_logger().info(f"following {len(route)} tags: {' '.join(route)}")

    def result(self, goal: RouteGoal, success: bool, message: str) -> FollowTagRoute.Result:
        return FollowTagRoute.Result(success=success, message=message,
                                     tags_reached=goal.tags_reached, elapsed_s=self.now_s() - goal.started_s)

    def on_reads(self, msg: TagReadArray) -> None:
        # The phase difference needs both phases and the channels they were read on.
        valid = inputs.round_reads(msg, self.drops, sim_clock_seconds(self), required=("phase_rad", "frequency_hz"))
        if valid is None:
            return
        goal = self.goals.running
        if goal is None:
            return
        # The round's own stamp, not arrival time: delivery jitter must not change the commanded yaw rate.
        cross_channel_before = self.follower.cross_channel_rounds
        command = self.follower.step(seconds_of(msg.header.stamp), valid)
        if self.follower.cross_channel_rounds > cross_channel_before:
            self.get_logger().warning(
                f"rounds with the target's left and right reads on different channels, not steered on "
                f"({self.follower.cross_channel_rounds} so far)", throttle_duration_sec=5.0)
        self.goals.heard()
        if command.arrived_index is not None:
            goal.tags_reached = command.arrived_index + 1
        self.publish(goal, command)
        if self.follower.finished:
            self.goals.conclude(GoalOutcome.SUCCEEDED, f"reached all {goal.tags_reached} tags")
        elif command.failure:
            self.goals.conclude(GoalOutcome.ABORTED, command.failure)

    def publish(self, goal: RouteGoal, command: Command) -> None:
        self.cmd_pub.publish(twist(command.linear_mps, command.angular_radps))
        feedback = FollowTagRoute.Feedback(
            target_index=command.target_index, target_tag_id=command.target_tag_id,
            phase_difference_rad=command.phase_difference_rad, heading_change_rad=command.heading_change_rad,
            mode=command.mode)
        self.goals.publish_feedback(feedback)


def main(args: list[str] | None = None) -> int:
    return run_node(HeadingControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
