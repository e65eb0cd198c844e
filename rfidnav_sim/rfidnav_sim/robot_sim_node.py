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
from rfidnav_common.clock_source import ClockSource
from rfidnav_common.frames import BASE_FRAME, ODOM_FRAME, Frame, frame_prefix
from rfidnav_common.ros import COMMAND_QOS, LATCHED_QOS, SENSOR_QOS, declare_parameters, input_drops, run_node, time_msg
from rfidnav_common.step_ledger import StepReport
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import FrameBroadcaster, publish_static_frames
from rfidnav_msgs.msg import BaseEvent
from rfidnav_sim.conversions import base_event_message, odometry_message, world_markers
from rfidnav_sim.kinematics import DiffDriveBase
from rfidnav_sim.parameters import RobotSimParameters
from rfidnav_sim.rig import steps_per_sample
from rfidnav_sim.world import load_world


class SimulatedRobot:
    """One base of the world and its topics: under its name (``r1/odom``), or in the root namespace for the one
    robot of a run without ``robots``."""

    def __init__(self, node: RobotSimNode, name: str, base: DiffDriveBase) -> None:
        self.node = node
        self.name = name
        self.base = base
        topic = (lambda relative: f"{name}/{relative}") if name else (lambda relative: relative)
        self.odom_pub = node.create_publisher(Odometry, topic("odom"), SENSOR_QOS)
        self.truth_pub = node.create_publisher(Odometry, topic("sim/ground_truth"), SENSOR_QOS)
        self.event_pub = node.create_publisher(BaseEvent, topic("base/event"), COMMAND_QOS)
        self.frames = FrameBroadcaster(node, frame_prefix(name))     # odom -> base_link, with each /odom
        self.cmd_vel_topic = node.resolve_topic_name(topic("cmd_vel"))
        node.create_subscription(Twist, topic("cmd_vel"), self.on_cmd_vel, COMMAND_QOS)

    def on_cmd_vel(self, msg: Twist) -> None:
        limits = self.base.limits
        drops = self.node.drops
        try:
            command = inputs.velocity(msg.linear.x, msg.angular.z, limits.max_wheel_speed_mps,
                                      2.0 * limits.max_wheel_speed_mps / limits.track_width_m)
        except inputs.BadInput as error:
            drops.drop(self.cmd_vel_topic, error)
            return
        if command.clamped:
            drops.clamp(self.cmd_vel_topic, f"({msg.linear.x:g} m/s, {msg.angular.z:g} rad/s) beyond the base's "
                                            f"limits, scaled to ({command.linear_mps:g}, {command.angular_radps:g})")
        self.base.set_command(command.linear_mps, command.angular_radps)

    def step(self, step_s: float) -> None:
        for event in self.base.step(step_s):
            if event.active:
                truth = self.base.truth
                who = f"{self.name}: " if self.name else ""
                self.node.get_logger().warning(f"{who}{event.event} at ({truth.x:.2f}, {truth.y:.2f}): stopped the "
                                               f"base; {event.action.replace('_', ' ')} while it holds")
            self.event_pub.publish(base_event_message(event, self.node.sim_time_msg()))

    def publish_odometry(self, stamp: Any, world_frame: str) -> None:
        base = self.base
        velocity = base.velocity
        self.truth_pub.publish(odometry_message(base.truth, velocity, stamp, world_frame))
        self.odom_pub.publish(odometry_message(base.odom, velocity, stamp, ODOM_FRAME))
        odom = base.odom
        self.frames.send([Frame.planar(ODOM_FRAME, BASE_FRAME, (odom.x, odom.y, odom.yaw))], stamp)


class RobotSimNode(SteppedNode):
    answers_steps = False   # it owns the clock: it reads its own counts

    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("robot_sim", **node_options)
        self.params: RobotSimParameters = declare_parameters(self, RobotSimParameters)
        p = self.params
        self.world = load_world(p.world_file)
        self.drops = input_drops(self)
        self.steps_per_odom = steps_per_sample(p.step_s, p.odom_rate_hz)
        # First, as the counted publishers and subscriptions made next report to it; it serves and runs once
        # everything a step publishes exists.
        self.clock = ClockSource(self, step_s=p.step_s, rtf=p.rtf, participants=p.step_participants,
                                 start_paused=p.start_paused, on_step=self.step)
        self.clock_pub = self.create_publisher(ClockMsg, "/clock", SENSOR_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, "/sim/markers", LATCHED_QOS)
        self.robots = [SimulatedRobot(self, name, base) for name, base in p.fleet(self.world.wall_segments()).items()]
        if p.map_to_odom_at_start:
            publish_static_frames(self, p.start_frames(), prefix="")
        self.markers_pub.publish(world_markers(self.world, self.sim_time_msg()))
        fleet = f"robots {', '.join(p.robots)}; " if p.robots else ""
        self.get_logger().info(
            f"world '{self.world.name}' with {len(self.world.tags)} tags; {fleet}step {p.step_s} s, "
            f"{self.clock.describe()}" + (" (paused until ~/start)" if p.start_paused else ""))
        self.clock.serve()

    @property
    def base(self) -> DiffDriveBase:
        """The base of a run of one robot."""
        return self.robots[0].base

    def sim_time_msg(self):
        return time_msg(self.clock.now_s)

    def take_answer(self, report: StepReport) -> None:
        self.clock.take_answer(report)

    def changed(self) -> None:
        self.clock.owner_changed()

    def step(self) -> None:
        """One step of the clock: the bases move, in the order of robots; /clock, /odom and ground truth share one
        rate (nothing in the graph needs finer time, and every /clock message costs each use_sim_time node a
        callback)."""
        for robot in self.robots:
            robot.step(self.params.step_s)
        if self.clock.steps % self.steps_per_odom == 0:
            stamp = self.sim_time_msg()
            self.clock_pub.publish(ClockMsg(clock=stamp))
            for robot in self.robots:
                robot.publish_odometry(stamp, self.world.frame_id)


def main(args: list[str] | None = None) -> int:
    return run_node(RobotSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
