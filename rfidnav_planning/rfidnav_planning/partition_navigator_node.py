"""partition_navigator: action server /navigate_to_point driving /cmd_vel from /localization/status (paper 000).

A thin adapter around PartitionNavigator: each LocalizationStatus (one inventory round, from
partition_localizer, or from the localizer whose ``status_topic`` the scenario names) becomes one navigator
decision. "Drive on" is the forward speed; "rotate by an
angle" is a turn on the spot closed on /odom (the core's TurnOnTheSpot), after which the navigator is told
the turn is done.
Every new plan is published on /planning/path (partition centres) and /planning/partitions (their tags).
One goal at a time, cancel and the watchdog on /localization/status: rfidnav_common.goal_server.
A status not in the map frame or with a value beyond any map, and /odom that is not a pose in odom, are dropped and
counted with a throttled warning (rfidnav_common.inputs); a goal tolerance beyond any map is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from geometry_msgs.msg import Pose2D, Twist
from nav_msgs.msg import Odometry, Path

from rfidnav_common import inputs
from rfidnav_common.errors import ConfigError
from rfidnav_common.frames import MAP_FRAME
from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer, Watchdog
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.ros import (
    COMMAND_QOS,
    LATCHED_QOS,
    SENSOR_QOS,
    declare_parameters,
    input_drops,
    run_node,
    stamp_seconds,
    twist,
)
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.tag_lattice import Coordinate
from rfidnav_msgs.action import NavigateToPoint
from rfidnav_msgs.msg import LocalizationStatus, PartitionPath
from rfidnav_planning.conversions import estimate_from_status, plan_messages
from rfidnav_planning.parameters import PartitionNavigatorParameters
from rfidnav_planning.partition_navigation import (
    FORWARD,
    REPLANNING,
    ROTATE,
    STOP,
    Decision,
    GoalRejected,
    PartitionNavigator,
    TurnOnTheSpot,
)


@dataclass
class NavigationGoal(ActiveGoal):
    turn: TurnOnTheSpot
    phase: str = "localizing"
    previous_partition: frozenset[Coordinate] | None = None
    travelled_m: float = 0.0


class PartitionNavigatorNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("partition_navigator", **node_options)
        self.params: PartitionNavigatorParameters = declare_parameters(self, PartitionNavigatorParameters)
        robot_map = load_route_map(self.params.map_file)
        if robot_map.deployment_area is None:
            raise ConfigError(self.params.map_file, "deployment_area", "partition navigation needs the tagged area")
        self.navigator = PartitionNavigator(self.params.settings(), robot_map.deployment_area)
        self.odom_pose: tuple[float, float, float] | None = None
        self.drops = input_drops(self)
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", COMMAND_QOS)
        self.path_pub = self.create_publisher(Path, "planning/path", LATCHED_QOS)
        self.partitions_pub = self.create_publisher(PartitionPath, "planning/partitions", LATCHED_QOS)
        self.create_subscription(LocalizationStatus, self.params.status_topic, self.on_status, SENSOR_QOS)
        self.create_subscription(Odometry, "odom", self.on_odom, SENSOR_QOS)
        turn_settings = self.params.turn_settings()
        self.goals: SingleGoalServer[NavigationGoal] = SingleGoalServer(
            self, NavigateToPoint, "navigate_to_point", what="navigation", busy="another goal is being navigated to",
            check=self.refusal, new_goal=lambda handle: NavigationGoal(handle, TurnOnTheSpot(turn_settings)),
            started=self.on_started, result=self.result,
            stop=lambda: self.drive(0.0, 0.0), abandon=self.navigator.cancel,
            watchdog=Watchdog(self.params.unheard_timeout_s, self.params.status_topic))
        self.get_logger().info(f"deployment area {list(robot_map.deployment_area)} m; "
                               f"approximation level {self.params.approximation_level}")

    def destroy_node(self) -> None:
        self.goals.destroy()
        super().destroy_node()

    # ------------------------------------------------------------------------------------ goals
    def refusal(self, goal: NavigateToPoint.Goal) -> str | None:
        try:
            inputs.length(goal.tolerance_m, "tolerance_m")
            self.navigator.check_goal((goal.target.x, goal.target.y), goal.tolerance_m)
        except (inputs.BadInput, GoalRejected) as error:
            return str(error)
        return None

    def on_started(self, goal: NavigationGoal) -> None:
        target = goal.handle.request.target
        self.navigator.start((target.x, target.y), goal.handle.request.tolerance_m)
        self.get_logger().info(f"navigating to ({target.x:.3f}, {target.y:.3f})")
        self.drive(0.0, 0.0)

    def result(self, goal: NavigationGoal, success: bool, message: str) -> NavigateToPoint.Result:
        navigation = self.navigator.state
        return NavigateToPoint.Result(success=success, message=message,
                                      path_length_m=float(goal.travelled_m), replans=navigation.replans,
                                      partitions_traversed=navigation.partitions_entered)

    # ---------------------------------------------------------------------------------- sensing
    def on_odom(self, msg: Odometry) -> None:
        try:
            pose = inputs.odometry_pose(msg)
        except inputs.BadInput as error:
            self.drops.drop("odom", error)
            return
        previous, self.odom_pose = self.odom_pose, pose
        active = self.goals.running
        if active is None:
            return
        if previous is not None:
            active.travelled_m += math.dist(previous[:2], pose[:2])
        if active.turn.turning:
            self.turn_step(active, pose[2])

    def turn_step(self, active: NavigationGoal, yaw: float) -> None:
        rate = active.turn.yaw_rate(yaw)
        if rate is None:
            self.apply(self.navigator.rotation_done())
        else:
            self.drive(0.0, rate)

    def on_status(self, msg: LocalizationStatus) -> None:
        active = self.goals.running
        if active is not None:
            self.goals.heard()
        try:
            inputs.frame(msg.header.frame_id, MAP_FRAME)
            estimate = estimate_from_status(msg, stamp_seconds(self, msg.header.stamp),
                                            active.previous_partition if active is not None else None)
        except inputs.BadInput as error:
            self.drops.drop(self.params.status_topic, error)
            return
        if active is None:
            return
        if estimate.partition:
            active.previous_partition = estimate.partition
        decision = self.navigator.on_estimate(estimate, active.travelled_m)
        if not active.turn.turning or decision.finished:   # a turn in progress is finished by on_odom
            self.apply(decision)
        # Re-planning is reported as such; otherwise the phase the navigator is in now (rotating once it turns).
        phase = decision.phase if decision.phase == REPLANNING else self.navigator.state.phase
        self.publish_feedback(active, phase, estimate.position, estimate.yaw)

    def apply(self, decision: Decision) -> None:
        active = self.goals.active
        active.phase = decision.phase
        if decision.new_plan is not None:
            self.publish_plan(decision)
        if decision.finished:
            self.goals.conclude(GoalOutcome.of(decision.success), decision.message)
        elif decision.motion.kind == ROTATE and self.odom_pose is None:
            active.turn.start(decision.motion.rotate_by_rad, None)
            self.drive(0.0, 0.0)                # no heading to turn from yet: wait for /odom
        elif decision.motion.kind == ROTATE:
            active.turn.start(decision.motion.rotate_by_rad, self.odom_pose[2])
            self.turn_step(active, self.odom_pose[2])
        elif decision.motion.kind == FORWARD:
            self.drive(self.params.forward_speed_mps, 0.0)
        elif decision.motion.kind == STOP:
            self.drive(0.0, 0.0)

    # ------------------------------------------------------------------------------------ output
    def drive(self, linear: float, angular: float) -> None:
        self.cmd_pub.publish(twist(linear, angular))

    def publish_plan(self, decision: Decision) -> None:
        lattice = self.navigator.state.lattice
        path, partitions = plan_messages(decision.new_plan, lattice, self.navigator.state.replans,
                                         self.get_clock().now().to_msg(), MAP_FRAME)
        self.path_pub.publish(path)
        self.partitions_pub.publish(partitions)

    def publish_feedback(self, active: NavigationGoal, phase: str, position: tuple[float, float] | None,
                         yaw: float | None) -> None:
        navigation = self.navigator.state
        feedback = NavigateToPoint.Feedback(phase=phase, partitions_traversed=navigation.partitions_entered,
                                            replans=navigation.replans)
        if position is not None:
            feedback.estimated_pose = Pose2D(x=float(position[0]), y=float(position[1]),
                                             theta=float(yaw) if yaw is not None else 0.0)
            feedback.distance_to_goal_m = float(math.dist(position, navigation.goal))
        self.goals.publish_feedback(feedback)


def main(args: list[str] | None = None) -> int:
    return run_node(PartitionNavigatorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
