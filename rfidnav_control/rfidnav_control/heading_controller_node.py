"""heading_controller: action server /follow_tag_route driving /cmd_vel from /rfid/reads (paper 001).

A thin adapter around TagRouteFollower: every TagReadArray (one inventory round) while a goal is
active becomes one follower step and one /cmd_vel. Reads with a non-finite number are dropped and
counted before they reach the controller.

A goal is followed from the moment it is accepted; its execute callback runs only once the outcome is known
(reached, failed, cancelled), so no coroutine waits in the executor. That keeps the node on rclpy's
EventsExecutor (see rfidnav_common.ros.events_executor), at the price of the goal status reading ACCEPTED
rather than EXECUTING while the route is followed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from geometry_msgs.msg import Twist
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node

from rfidnav_common.robot_map import load_route_map
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, close_goal, declare_parameters, run_node, seconds_of, twist
from rfidnav_control.fuzzy import FuzzyHeadingController
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_control.tag_route import Command, TagRouteFollower, observe
from rfidnav_msgs.action import FollowTagRoute
from rfidnav_msgs.msg import TagReadArray


@dataclass
class ActiveGoal:
    handle: ServerGoalHandle
    started_s: float
    last_step_s: float
    tags_reached: int = 0
    outcome: tuple[str, str] | None = None   # (succeeded | aborted | canceled, message) once concluded


class HeadingControllerNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("heading_controller", **node_options)
        self.params: HeadingControllerParameters = declare_parameters(self, HeadingControllerParameters)
        route_map = load_route_map(self.params.map_file)
        self.follower = TagRouteFollower(self.params.follower_settings(),
                                         FuzzyHeadingController(self.params.fuzzy_spec()), route_map.arrival_tags)
        self.active: ActiveGoal | None = None
        self.dropped_reads = 0
        self.cmd_pub = self.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
        self.create_subscription(TagReadArray, "/rfid/reads", self.on_reads, SENSOR_QOS)
        self.action_server = ActionServer(
            self, FollowTagRoute, "/follow_tag_route", execute_callback=self.finish,
            goal_callback=self.on_goal, handle_accepted_callback=self.on_accepted,
            cancel_callback=lambda _: CancelResponse.ACCEPT)
        self.create_timer(0.1, self.supervise)
        self.get_logger().info(f"route map '{route_map.name}' with {len(route_map.arrival_tags)} tags; "
                               f"{len(self.params.rules)} fuzzy rules, arrival by {self.params.arrival}")

    def destroy_node(self) -> None:
        # rclpy's destroy_node leaves waitables alive: without this the action server (and its latched goal
        # status) outlives the node in a process that goes on, e.g. a test that built the node in-process.
        self.action_server.destroy()
        super().destroy_node()

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_goal(self, goal: FollowTagRoute.Goal) -> GoalResponse:
        route = list(goal.tag_ids)
        problem = None
        if self.active is not None:
            problem = "another route is being followed"
        elif not route:
            problem = "the route is empty"
        elif unknown := self.follower.unknown_tags(route):
            problem = f"unknown tag ids {', '.join(unknown)} (not in the route map {self.params.map_file})"
        if problem:
            self.get_logger().error(f"goal rejected: {problem}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_accepted(self, handle: ServerGoalHandle) -> None:
        now = self.now_s()
        self.follower.start(list(handle.request.tag_ids), now)
        self.active = ActiveGoal(handle, now, now)
        self.get_logger().info(f"following {len(handle.request.tag_ids)} tags: {' '.join(handle.request.tag_ids)}")

    def conclude(self, state: str, message: str) -> None:
        """Stop the robot and let the action server run ``finish`` (the execute callback) with the outcome."""
        self.active.outcome = (state, message)
        self.cmd_pub.publish(Twist())
        self.active.handle.execute()

    def finish(self, handle: ServerGoalHandle) -> FollowTagRoute.Result:
        active, self.active = self.active, None
        success, message = close_goal(self, handle, active.outcome, "route")
        return FollowTagRoute.Result(success=success, message=message,
                                     tags_reached=active.tags_reached, elapsed_s=self.now_s() - active.started_s)

    def on_reads(self, msg: TagReadArray) -> None:
        observations = [observe(reading) for reading in msg.readings]
        valid = [o for o in observations if o is not None]
        if len(valid) < len(observations):
            self.dropped_reads += len(observations) - len(valid)
            self.get_logger().warning(f"dropped reads with non-finite values ({self.dropped_reads} so far)",
                                      throttle_duration_sec=5.0)
        active = self.active
        if active is None or active.outcome is not None:
            return
        # The round's own stamp, not arrival time: delivery jitter must not change the commanded yaw rate.
        command = self.follower.step(seconds_of(msg.header.stamp), valid)
        active.last_step_s = self.now_s()
        if command.arrived_index is not None:
            active.tags_reached = command.arrived_index + 1
        self.publish(command)
        if self.follower.finished:
            self.conclude("succeeded", f"reached all {active.tags_reached} tags")
        elif command.failure:
            self.conclude("aborted", command.failure)

    def publish(self, command: Command) -> None:
        self.cmd_pub.publish(twist(command.linear_mps, command.angular_radps))
        feedback = FollowTagRoute.Feedback(
            target_index=command.target_index, target_tag_id=command.target_tag_id,
            phase_difference_rad=command.phase_difference_rad, heading_change_rad=command.heading_change_rad,
            mode=command.mode)
        self.active.handle.publish_feedback(feedback)

    def supervise(self) -> None:
        """Cancel requests and a silent reader are noticed here, as no reads may arrive to notice them."""
        active = self.active
        if active is None or active.outcome is not None:
            return
        if active.handle.is_cancel_requested:
            self.conclude("canceled", "cancelled by the client")
            return
        silent_s = self.now_s() - active.last_step_s
        if silent_s > self.params.unheard_timeout_s:
            self.conclude("aborted", f"no inventory rounds on /rfid/reads for {silent_s:.1f} s")


def main(args: list[str] | None = None) -> int:
    return run_node(HeadingControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
