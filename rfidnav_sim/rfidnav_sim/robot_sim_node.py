"""robot_sim: differential-drive base, simulation clock, wheel odometry, ground truth, world markers, and the
bumper: the base stalls at the world's walls and reports each press and release on /base/event, stopping and
refusing forward motion while pressed, as create_base does (rfidnav_sim.kinematics).

Owns simulated time through a clock source (rfidnav_common.clock_source): it steps the base at ``step_s`` and
publishes /clock (at ``odom_rate_hz``, with /odom and /sim/ground_truth), free-running at ``rtf`` (``stepped_clock``
false: real time, hardware beside the simulator, replay) or, the orchestrator's default for simulated runs, stepped:
after each publication it waits until every node in ``step_participants`` has handled everything published so far
(their answers on /sim/step_ack: rfidnav_common.stepped_node), so that a run depends on its seed, not on the
machine's load; ``rtf`` is then a ceiling (``.inf``: none). A /cmd_vel that answers a step is applied from the next.

A /cmd_vel beyond the base's limits (its wheel speed forward, both wheels at it in opposite directions turning) is
scaled down to them and counted as clamped; one with a NaN or an infinity is dropped and counted
(rfidnav_common.inputs).

``~/start`` (with ``start_paused``) and ``~/wired`` (stepped) are the clock source's services.
"""

from __future__ import annotations

from typing import Any

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Clock as ClockMsg
from visualization_msgs.msg import MarkerArray

from rfidnav_common import inputs
from rfidnav_common.base_safety import BaseEventRecord
from rfidnav_common.clock_source import ClockSource
from rfidnav_common.frames import BASE_FRAME, ODOM_FRAME, Frame
from rfidnav_common.ros import COMMAND_QOS, LATCHED_QOS, SENSOR_QOS, declare_parameters, run_node, time_msg
from rfidnav_common.step_ledger import StepReport
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import FrameBroadcaster, publish_static_frames
from rfidnav_msgs.msg import BaseEvent
from rfidnav_sim.conversions import base_event_message, odometry_message, world_markers
from rfidnav_sim.parameters import RobotSimParameters
from rfidnav_sim.rig import steps_per_sample
from rfidnav_sim.world import load_world


class RobotSimNode(SteppedNode):
    answers_steps = False   # it owns the clock: it reads its own counts

    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("robot_sim", **node_options)
        self.params: RobotSimParameters = declare_parameters(self, RobotSimParameters)
        p = self.params
        self.world = load_world(p.world_file)
        self.base = p.base(self.world.wall_segments())
        self.drops = inputs.Drops(self.get_logger().warning)
        self.steps_per_odom = steps_per_sample(p.step_s, p.odom_rate_hz)
        # First, as the counted publishers and subscriptions made next report to it; it serves and runs once
        # everything a step publishes exists.
        self.clock = ClockSource(self, step_s=p.step_s, rtf=p.rtf, participants=p.step_participants,
                                 start_paused=p.start_paused, on_step=self.step)
        self.clock_pub = self.create_publisher(ClockMsg, "/clock", SENSOR_QOS)
        self.odom_pub = self.create_publisher(Odometry, "/odom", SENSOR_QOS)
        self.truth_pub = self.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, "/sim/markers", LATCHED_QOS)
        self.event_pub = self.create_publisher(BaseEvent, "/base/event", COMMAND_QOS)
        self.frames = FrameBroadcaster(self)     # odom -> base_link, with each /odom
        if p.map_to_odom_at_start:
            publish_static_frames(self, [p.start_frame()])
        self.create_subscription(Twist, "/cmd_vel", self.on_cmd_vel, COMMAND_QOS)
        self.markers_pub.publish(world_markers(self.world, self.sim_time_msg()))
        self.get_logger().info(
            f"world '{self.world.name}' with {len(self.world.tags)} tags; step {p.step_s} s, {self.clock.describe()}"
            + (" (paused until ~/start)" if p.start_paused else ""))
        self.clock.serve()

    def sim_time_msg(self):
        return time_msg(self.clock.now_s)

    def on_cmd_vel(self, msg: Twist) -> None:
        limits = self.base.limits
        try:
            command = inputs.velocity(msg.linear.x, msg.angular.z, limits.max_wheel_speed_mps,
                                      2.0 * limits.max_wheel_speed_mps / limits.track_width_m)
        except inputs.BadInput as error:
            self.drops.drop("/cmd_vel", error)
            return
        if command.clamped:
            self.drops.clamp("/cmd_vel", f"({msg.linear.x:g} m/s, {msg.angular.z:g} rad/s) beyond the base's limits, "
                                         f"scaled to ({command.linear_mps:g}, {command.angular_radps:g})")
        self.base.set_command(command.linear_mps, command.angular_radps)

    def take_answer(self, report: StepReport) -> None:
        self.clock.take_answer(report)

    def changed(self) -> None:
        self.clock.owner_changed()

    def step(self) -> None:
        """One step of the clock: the base moves; /clock, /odom and ground truth share one rate (nothing in the
        graph needs finer time, and every /clock message costs each use_sim_time node a callback)."""
        for event in self.base.step(self.params.step_s):
            self.publish_event(event)
        if self.clock.steps % self.steps_per_odom == 0:
            self.publish_clock()
            self.publish_odometry()

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
        self.odom_pub.publish(odometry_message(self.base.odom, velocity, stamp, ODOM_FRAME))
        odom = self.base.odom
        self.frames.send([Frame.planar(ODOM_FRAME, BASE_FRAME, (odom.x, odom.y, odom.yaw))], stamp)


def main(args: list[str] | None = None) -> int:
    return run_node(RobotSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
