"""pose_navigator: action server /navigate_to_point driving /cmd_vel on a localizer's pose (ours, issue 20).

A thin adapter around PoseNavigator: the pose comes from whichever localizer the scenario names (``pose_topic``:
rfid_localizer's /localization/pose, or any PoseWithCovarianceStamped in the map frame), as a Nav2 controller
takes AMCL's. A timer at ``control_rate_hz`` (sim time) steps the core with the latest pose -- none while it is
older than ``pose_timeout_s`` -- and publishes its command. One goal at a time and cancel (checked at each control
step): rfidnav_common.goal_server.

A pose not in the map frame, not a planar pose or with a covariance that is not finite is dropped and counted
with a throttled warning (rfidnav_common.inputs); a goal beyond any map, or outside the extent of the robot map's
floor plan, is refused.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from geometry_msgs.msg import Pose2D, PoseWithCovarianceStamped, Twist

from rfidnav_common import inputs
from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, declare_parameters, input_drops, run_node, stamp_seconds, twist
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_msgs.action import NavigateToPoint
from rfidnav_planning.conversions import point_goal_refusal, pose_from_message
from rfidnav_planning.parameters import PoseNavigatorParameters
from rfidnav_planning.pose_navigation import Pose, PoseNavigator, Step
from rfidnav_planning.wall_paths import WallMap

NODE_NAME = "pose_navigator"


class PoseNavigatorNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__(NODE_NAME, **node_options)
        self.params: PoseNavigatorParameters = declare_parameters(self, PoseNavigatorParameters)
        map_file = self.params.map_file
        floor = WallMap() if map_file == "unused" else WallMap.of(load_route_map(Path(map_file)))
        self.navigator = PoseNavigator(self.params.settings(), floor)
        self.drops = input_drops(self)
        self.pose: Pose | None = None
        self.pose_stamp_s = -math.inf
        self.travelled_m = 0.0
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", COMMAND_QOS)
        self.create_subscription(PoseWithCovarianceStamped, self.params.pose_topic, self.on_pose, SENSOR_QOS)
        self.goals: SingleGoalServer[ActiveGoal] = SingleGoalServer(
            self, NavigateToPoint, "navigate_to_point", what="navigation", busy="another goal is being navigated to",
            check=self.refusal, new_goal=ActiveGoal, started=self.on_started, result=self.result, stop=self.stop,
            supervise_period_s=None)
        self.create_timer(1.0 / self.params.control_rate_hz, self.control_step)
        self.get_logger().info(f"driving on the poses of {self.params.pose_topic}")

    def destroy_node(self) -> None:
        self.goals.destroy()
        super().destroy_node()

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        try:
            pose = pose_from_message(msg, self.params.map_frame)
            stamp_s = stamp_seconds(self, msg.header.stamp)
        except inputs.BadInput as error:
            self.drops.drop(self.params.pose_topic, error)
            return
        if self.pose is not None and self.goals.running is not None:
            self.travelled_m += math.dist((pose.x, pose.y), (self.pose.x, self.pose.y))
        self.pose = pose
        self.pose_stamp_s = stamp_s

    # -------------------------------------------------------------------------------------- goals
    def refusal(self, goal: NavigateToPoint.Goal) -> str | None:
        return point_goal_refusal(goal, self.navigator.refusal)

    def on_started(self, goal: ActiveGoal) -> None:
        target = goal.handle.request.target
        self.get_logger().info(f"navigating to ({target.x:.3f}, {target.y:.3f})")
        self.travelled_m = 0.0
        self.navigator.start((target.x, target.y))

    def stop(self) -> None:
        self.cmd_pub.publish(twist(0.0, 0.0))

    def result(self, _goal: ActiveGoal, success: bool, message: str) -> NavigateToPoint.Result:
        return NavigateToPoint.Result(success=success, message=message, path_length_m=float(self.travelled_m))

    # ------------------------------------------------------------------------------------ control
    def control_step(self) -> None:
        if self.goals.supervise() is None:
            return
        fresh = self.now_s() - self.pose_stamp_s <= self.params.pose_timeout_s
        step = self.navigator.step(self.pose if fresh else None)
        if step.finished:
            self.goals.conclude(GoalOutcome.of(step.success), step.message)
            return
        self.cmd_pub.publish(twist(*step.command))
        self.publish_feedback(step)

    def publish_feedback(self, step: Step) -> None:
        feedback = NavigateToPoint.Feedback(phase=step.phase)
        pose, target = self.pose, self.navigator.target
        if pose is not None and target is not None:
            feedback.estimated_pose = Pose2D(x=pose.x, y=pose.y, theta=pose.yaw)
            feedback.distance_to_goal_m = float(math.dist((pose.x, pose.y), target))
        self.goals.publish_feedback(feedback)


def main(args: list[str] | None = None) -> int:
    return run_node(PoseNavigatorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
