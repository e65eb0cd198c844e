"""wall_follower: paper 004's sonar left-wall following as a node: /sonar/* and /odom in, /cmd_vel and
/wall_follower/event out, commanded on /wall_follower/command (by mission_executor).

A thin adapter around rfidnav_control.wall_following.WallFollower: a timer at ``control_rate_hz`` (sim time) feeds
it the latest range of each sonar topic (plus that sonar's mounting offset, so ranges are from the robot's centre)
and the latest odometry pose, and publishes its velocity and events. It is idle until the first command: a
``follow`` or a turn starts a new follower (what was measured of the walls on an earlier drive is not kept); its
``stopped`` event makes it idle again. Its state (``idle`` or the follower's) goes out on /wall_follower/state
every STATE_PERIOD_S, so a commander can tell a lost command from a slow one. While a sonar is silent longer than
``sonar_timeout_s`` it stops the robot rather than drive blind, and says so. Inputs are checked
(rfidnav_common.inputs) and what fails is dropped and counted with a throttled warning: a range that is NaN, negative
or beyond any sonar's reach (+-inf are kept: no echo, closer than the minimum, REP 117) or not in its rangefinder's
frame (sonar_NAME for /sonar/NAME), an /odom pose that is not finite, beyond any map or not odom -> base_link, a
stop distance that is not a finite distance.
"""

from __future__ import annotations

import math
from typing import Any

from geometry_msgs.msg import Pose2D, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Range

from rfidnav_common import inputs
from rfidnav_common.frames import ODOM_FRAME, SONAR_FRAME_PREFIX
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, declare_parameters, input_drops, run_node, twist
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_control.parameters import SONAR_FIELDS, WallFollowerParameters
from rfidnav_control.wall_following import ACTIONS, STOPPED, OdomPose, Sonar, WallFollower
from rfidnav_msgs.msg import WallFollowerCommand, WallFollowerEvent

STATE_PERIOD_S = 0.5
IDLE = "idle"


class WallFollowerNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("wall_follower", **node_options)
        self.params: WallFollowerParameters = declare_parameters(self, WallFollowerParameters)
        self.settings = self.params.settings()
        self.follower: WallFollower | None = None          # None: idle
        self.ranges: dict[str, tuple[float, float]] = {}    # field -> (range from the centre, sim time received)
        self.odom: OdomPose | None = None
        self.drops = input_drops(self)
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", COMMAND_QOS)
        self.event_pub = self.create_publisher(WallFollowerEvent, "wall_follower/event", COMMAND_QOS)
        self.state_pub = self.create_publisher(WallFollowerEvent, "wall_follower/state", COMMAND_QOS)
        for field, topic, offset in zip(SONAR_FIELDS, self.params.sonar_topics, self.params.sonar_offsets_m):
            self.create_subscription(Range, topic, self.range_callback(field, topic, offset), SENSOR_QOS)
        self.create_subscription(Odometry, "odom", self.on_odom, SENSOR_QOS)
        self.create_subscription(WallFollowerCommand, "wall_follower/command", self.on_command, COMMAND_QOS)
        self.create_timer(1.0 / self.params.control_rate_hz, self.control_step)
        self.create_timer(STATE_PERIOD_S, self.publish_state)
        self.get_logger().info(f"idle until commanded; set distance {self.settings.wall_distance_m:g} m, "
                               f"{self.settings.speed_mps:g} m/s, {self.params.control_rate_hz:g} steps/s")

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # ---------------------------------------------------------------------------------------- inputs
    def range_callback(self, field: str, topic: str, offset: float):
        expected_frame = SONAR_FRAME_PREFIX + topic.rsplit("/", 1)[-1]

        def on_range(msg: Range) -> None:
            try:
                inputs.frame(msg.header.frame_id, expected_frame)
                # +inf (no echo) stays inf; -inf (closer than the minimum, REP 117) stays below any threshold.
                distance = msg.range if math.isinf(msg.range) else inputs.length(msg.range, "range") + offset
            except inputs.BadInput as error:
                self.drops.drop(topic, error)
                return
            self.ranges[field] = (distance, self.now_s())
        return on_range

    def on_odom(self, msg: Odometry) -> None:
        try:
            self.odom = OdomPose(*inputs.odometry_pose(msg))
        except inputs.BadInput as error:
            self.drops.drop("odom", error)

    def on_command(self, msg: WallFollowerCommand) -> None:
        action = msg.action
        if action not in (*ACTIONS, WallFollowerCommand.FOLLOW, WallFollowerCommand.STOP):
            self.drops.drop("wall_follower/command", f"unknown action '{action}'")
            return
        if action == WallFollowerCommand.STOP:
            if self.follower is not None:
                # A stop whose distance is no distance is dropped like any bad message: it changes nothing, and
                # the executor's plan goes on (stopping at once on it let one foreign message end a mission
                # 1.25 m short of its goal).
                try:
                    self.follower.command_stop(inputs.length(msg.stop_within_m, "stop_within_m"))
                except (inputs.BadInput, ValueError) as error:
                    self.drops.drop("wall_follower/command", error)
            return
        if self.follower is None:
            self.follower = WallFollower(self.settings)
            self.get_logger().info("following the left wall")
        if action != WallFollowerCommand.FOLLOW:
            self.follower.command_turn(action)

    # ------------------------------------------------------------------------------------- control
    def control_step(self) -> None:
        if self.follower is None:
            return
        sonar = self.latest_sonar()
        if sonar is None or self.odom is None:
            self.drive(0.0, 0.0)
            return
        command = self.follower.step(sonar, self.odom)
        self.drive(command.linear, command.angular)
        if command.event is not None:
            self.publish_event(command.event)
        if command.event == STOPPED:
            self.follower = None
            self.get_logger().info(f"stopped at odom ({self.odom.x:.2f}, {self.odom.y:.2f}); idle")

    def latest_sonar(self) -> Sonar | None:
        """The follower's Sonar from the latest ranges; None (with a warning) while any is missing or stale."""
        now = self.now_s()
        stale = [topic for field, topic in zip(SONAR_FIELDS, self.params.sonar_topics)
                 if field not in self.ranges or now - self.ranges[field][1] > self.params.sonar_timeout_s]
        if stale:
            self.get_logger().warning(f"no recent range on {', '.join(stale)}: holding still",
                                      throttle_duration_sec=5.0)
            return None
        return Sonar(**{field: self.ranges[field][0] for field in SONAR_FIELDS})

    # -------------------------------------------------------------------------------------- output
    def drive(self, linear: float, angular: float) -> None:
        self.cmd_pub.publish(twist(linear, angular))

    def publish_event(self, event: str) -> None:
        self.event_pub.publish(self.report(event))

    def publish_state(self) -> None:
        self.state_pub.publish(self.report(""))

    def report(self, event: str) -> WallFollowerEvent:
        msg = WallFollowerEvent(event=event, state=self.follower.state if self.follower is not None else IDLE)
        if self.odom is not None:
            msg.odom_pose = Pose2D(x=float(self.odom.x), y=float(self.odom.y), theta=float(self.odom.yaw))
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = ODOM_FRAME
        return msg


def main(args: list[str] | None = None) -> int:
    return run_node(WallFollowerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
