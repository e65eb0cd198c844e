"""robot_sim: differential-drive base, simulation clock, wheel odometry, ground truth, world markers, and the
bumper: the base stalls at the world's walls and reports each press and release on /base/event, stopping and
refusing forward motion while pressed, as create_base does (rfidnav_sim.kinematics).

Owns simulated time: steps the base at ``step_s`` and publishes /clock (at ``odom_rate_hz``, with
/odom and /sim/ground_truth). Two clocks:

- free-running (``stepped_clock`` false): ``rtf`` seconds of sim time pass per wall second whether or not the
  graph keeps up; every other node runs with use_sim_time. For real time, hardware beside the simulator, replay.
- stepped (``stepped_clock`` true, the orchestrator's default for simulated runs): after each publication the
  simulator waits until every node in ``step_participants`` has handled everything published so far
  (their answers on /sim/step_ack: rfidnav_common.stepped_node, rfidnav_common.step_ledger) before it steps
  on; a /cmd_vel that answers a step is applied from the next. ``rtf`` is then a ceiling (0: none), and a run
  depends on its seed, not on the machine's load.

A /cmd_vel beyond the base's limits (its wheel speed forward, both wheels at it in opposite directions turning) is
scaled down to them and counted as clamped; one with a NaN or an infinity is dropped and counted
(rfidnav_common.inputs).

With ``start_paused`` the clock stays at zero until ``~/start`` (std_srvs/Trigger) is called, so slow process
start-up costs no sim time. With the stepped clock ``~/wired`` (std_srvs/Trigger) says whether every participant's
publishers and subscriptions have matched each other, or what is still waited for.
"""

from __future__ import annotations

import time
from typing import Any

from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from rfidnav_common import inputs
from rfidnav_common.base_safety import BaseEventRecord
from rfidnav_common.errors import ConfigError
from rfidnav_common.frames import BASE_FRAME, ODOM_FRAME, Frame
from rfidnav_common.ros import COMMAND_QOS, LATCHED_QOS, SENSOR_QOS, declare_parameters, run_node, time_msg
from rfidnav_common.step_ledger import StepLedger, StepReport
from rfidnav_common.stepped_node import STEP_ACK_READER_QOS, STEP_ACK_TOPIC, SteppedNode, step_report_of
from rfidnav_common.transforms import FrameBroadcaster, publish_static_frames
from rfidnav_msgs.msg import BaseEvent, StepAck
from rfidnav_sim.conversions import base_event_message, odometry_message, world_markers
from rfidnav_sim.parameters import RobotSimParameters
from rfidnav_sim.world import load_world

# Stepped clock: steps taken in one callback at most before the executor runs again (with no participant to
# wait for, an unbounded loop would starve the ~/start service and shutdown); the wall timer goes on with them.
STEPS_PER_CALLBACK = 500
STALL_REPORT_S = 10.0   # wall time a step may wait before the simulator says who it is waiting for


class RobotSimNode(SteppedNode):
    answers_steps = False   # it owns the clock: it reads its own counts

    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("robot_sim", **node_options)
        self.params: RobotSimParameters = declare_parameters(self, RobotSimParameters)
        p = self.params
        self.world = load_world(p.world_file)
        self.base = p.base(self.world.wall_segments())
        self.steps = 0
        self.drops = inputs.Drops(self.get_logger().warning)
        self.steps_per_odom = max(1, round(1.0 / (p.odom_rate_hz * p.step_s)))
        self.running = False   # until the end of construction: counted publishers and subscriptions call advance
        self.stepping = False  # within advance(): its own publications must not step again
        self.wall_origin = time.monotonic()
        if p.rtf == 0.0 and not self.stepped:
            raise ConfigError(f"parameters of node '{self.get_fully_qualified_name()}'", "rtf",
                              "0 (as fast as the graph answers) needs the stepped clock (stepped_clock: true)")
        # The simulator is a participant too: the /cmd_vel that answers a step must have reached it.
        self.ledger = StepLedger([*p.step_participants, self.get_fully_qualified_name()])
        self.waiting_since = time.monotonic()

        self.clock_pub = self.create_publisher(ClockMsg, "/clock", SENSOR_QOS)
        self.odom_pub = self.create_publisher(Odometry, "/odom", SENSOR_QOS)
        self.truth_pub = self.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, "/sim/markers", LATCHED_QOS)
        self.event_pub = self.create_publisher(BaseEvent, "/base/event", COMMAND_QOS)
        self.frames = FrameBroadcaster(self)     # odom -> base_link, with each /odom
        if p.map_to_odom_at_start:
            publish_static_frames(self, [p.start_frame()])
        self.create_subscription(Twist, "/cmd_vel", self.on_cmd_vel, COMMAND_QOS)
        self.create_service(Trigger, "~/start", self.on_start)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if self.stepped:
            self.create_subscription(StepAck, STEP_ACK_TOPIC, self.on_step_ack, STEP_ACK_READER_QOS)
            self.create_service(Trigger, "~/wired", self.on_wired)
            self.create_timer(STALL_REPORT_S, self.report_stall, clock=steady)
        # The clock source cannot pace itself on sim time: a steady wall timer drives the steps, running as many
        # as are due so that the long-run rate is exactly rtf (at most rtf, stepped, where answers drive them
        # too). Waking more often than every 10 ms wall buys nothing at 50 Hz of published sim time and costs
        # CPU the graph needs.
        self.create_timer(max(p.step_s / p.rtf, 0.01) if p.rtf > 0.0 else 0.01, self.advance, clock=steady)
        self.markers_pub.publish(world_markers(self.world, self.sim_time_msg()))
        clock = (f"stepped clock, {len(p.step_participants)} participants, "
                 + (f"RTF at most {p.rtf:g}" if p.rtf > 0.0 else "as fast as they answer")
                 if self.stepped else f"free-running clock at RTF {p.rtf:g}")
        self.get_logger().info(
            f"world '{self.world.name}' with {len(self.world.tags)} tags; step {p.step_s} s, {clock}"
            + (" (paused until ~/start)" if p.start_paused else ""))
        self.running = not p.start_paused

    def sim_time_msg(self):
        return time_msg(self.steps * self.params.step_s)

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

    def on_start(self, _request, response):
        if not self.running:
            self.running = True
            self.wall_origin = time.monotonic() - self.steps * self.params.step_s / max(self.params.rtf, 1e-9)
            self.get_logger().info("clock started")
            self.advance()
        response.success = True
        response.message = f"running at sim time {self.steps * self.params.step_s:.3f} s"
        return response

    def on_wired(self, _request, response):
        """Whether every participant has reported and every publisher and subscription of theirs has matched the
        participants on the other side of its topic: the orchestrator sends the goal only then (a message a node
        publishes when its goal comes would otherwise be lost, and its consumer counted behind for ever)."""
        self.ledger.report(self.step_report())
        waiting = self.ledger.wiring()
        response.success = not waiting
        response.message = ", ".join(u.describe() for u in waiting) or "every participant wired"
        return response

    def on_step_ack(self, message: StepAck) -> None:
        self.take_answer(step_report_of(message))

    def take_answer(self, report: StepReport) -> None:
        if self.ledger.report(report):
            self.advance()

    def changed(self) -> None:
        """One of its own counts changed: a /cmd_vel arrived, which can complete a step (a publication is its
        own, from within a step)."""
        if not self.stepping:
            self.advance()

    def advance(self) -> None:
        """Take the steps that are due: all of them free-running, up to the next unanswered publication with the
        stepped clock."""
        if not self.running or self.stepping:
            return
        p = self.params
        due = int((time.monotonic() - self.wall_origin) * p.rtf / p.step_s) if p.rtf > 0.0 else None
        if due is not None and not self.stepped:
            # After a stall (a slow machine), do not burst through the backlog faster than 50 steps a tick.
            for _ in range(min(due - self.steps, 50)):
                self.step()
            if due - self.steps > 50:
                self.wall_origin = time.monotonic() - self.steps * p.step_s / p.rtf
            return
        self.stepping = True
        try:
            for _ in range(STEPS_PER_CALLBACK):
                if (due is not None and self.steps >= due) or not self.step_answered():
                    return
                self.step()
        finally:
            self.stepping = False

    def step_answered(self) -> bool:
        self.ledger.report(self.step_report())
        if not self.ledger.answered():
            return False
        self.waiting_since = time.monotonic()
        return True

    def report_stall(self) -> None:
        waited_s = time.monotonic() - self.waiting_since
        if self.running and waited_s > STALL_REPORT_S:
            waiting = ", ".join(u.describe() for u in self.ledger.unanswered())
            self.get_logger().warning(f"sim time {self.steps * self.params.step_s:.2f} s has waited {waited_s:.0f} s "
                                      f"(wall) for: {waiting}")

    def step(self) -> None:
        p = self.params
        events = self.base.step(p.step_s)
        self.steps += 1
        if self.stepped:
            self.advance_time(round(self.steps * p.step_s * 1e9))
        for event in events:
            self.publish_event(event)
        # /clock, /odom and ground truth share one rate: nothing in the graph needs finer time, and
        # every /clock message costs each use_sim_time node a callback.
        if self.steps % self.steps_per_odom == 0:
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
