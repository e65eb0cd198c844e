"""create_base: an iRobot Create 2 (Roomba 600+) on its Open Interface serial port as the robot base: /cmd_vel in,
/odom and /base/event out -- in place of robot_sim on the real robot.

A thin adapter around rfidnav_drivers.create_oi (the bytes, the limits, the odometry). All serial I/O is done by one
dedicated thread, so no executor callback ever waits on the port: the /cmd_vel callback only hands the latest
command over and wakes the thread. At ``sensor_rate_hz`` the thread asks for the bumpers, cliff sensors, wheel
drops and encoders in one Query List and publishes one /odom per reply; a missing or garbled reply is counted and
warned about. A bumper, cliff or wheel drop that starts stops the base from that thread at once (not on the next
command) and is published on /base/event, as is its end; while a bumper is pressed forward motion is refused, while
a cliff or wheel drop holds all motion is. The command watchdog runs in the same thread, on the monotonic clock, so
that it stops the base even when the executor is stuck. Message stamps are the node's clock.

A /cmd_vel beyond the base's limits (``max_wheel_speed_mps`` forward, both wheels at it in opposite directions
turning) is scaled down to them, keeping the arc, and counted as clamped; one with a NaN or an infinity anywhere
is dropped and counted (rfidnav_common.inputs). The base is stopped (Drive Direct 0, 0) on every way out: Ctrl-C,
SIGTERM and an exception end the spin and destroy_node stops it; a serial thread that ends -- a bug, or the port
failing for SERIAL_FAILURE_LIMIT_S on end (a cable pulled) -- stops it first, and the process then exits with
SERIAL_THREAD_ENDED (1), so the orchestrator respawns it on a freshly opened port rather than leave a node up that
no longer drives anything.
"""

from __future__ import annotations

import errno
import threading
import time
from typing import Any

import rclpy
import serial
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from tf2_msgs.msg import TFMessage

from rfidnav_common import base_safety as safety
from rfidnav_common import inputs
from rfidnav_common.frames import Frame
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, declare_parameters, input_drops, run_node, spin_until_shutdown
from rfidnav_common.transforms import TF_QOS, tf_message
from rfidnav_drivers import create_oi as oi
from rfidnav_drivers.errors import DriverError
from rfidnav_drivers.parameters import CreateBaseParameters
from rfidnav_msgs.msg import BaseEvent

REPLY_TIMEOUT_S = 0.1      # the Create answers in a few ms; a reply not complete by then is counted as missed
WRITE_TIMEOUT_S = 0.1
START_PAUSE_S = 0.05       # between Start and the mode: the OI needs a moment after Start (serial thread only)
WARN_EVERY_S = 5.0
SERIAL_ERRORS = (serial.SerialException, OSError)
SERIAL_FAILURE_LIMIT_S = 2.0   # every serial read and write failing this long: the port is gone (a cable pulled)
SERIAL_THREAD_ENDED = 1        # exit code when the serial thread ended while the node was not stopping


def port_error(port: str, error: OSError) -> DriverError:
    """One clear message for a serial port that cannot be opened: what is wrong and what to check."""
    if error.errno in (errno.ENOENT, errno.ENODEV, errno.ENXIO):
        return DriverError(f"create_base: serial port {port} not found: is the Create's USB serial cable plugged in? "
                           f"List the ports with `ls /dev/serial/by-id/ /dev/ttyUSB*` and set the port parameter")
    if error.errno in (errno.EACCES, errno.EPERM):
        return DriverError(f"create_base: no permission to open serial port {port}: add your user to the dialout "
                           f"group (`sudo usermod -aG dialout $USER`, then log in again; `ls -l {port}` shows the "
                           f"port's group)")
    if error.errno == errno.EBUSY:
        return DriverError(f"create_base: serial port {port} is busy: another program has it open")
    return DriverError(f"create_base: cannot open serial port {port}: {error}")


class CreateBaseNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("create_base", **node_options)
        self.params: CreateBaseParameters = declare_parameters(self, CreateBaseParameters)
        p = self.params
        try:
            self.port: serial.Serial | None = serial.Serial(p.port, p.baud, timeout=REPLY_TIMEOUT_S,
                                                            write_timeout=WRITE_TIMEOUT_S)
        except serial.SerialException as error:
            super().destroy_node()
            raise port_error(p.port, error) from None
        self.geometry = oi.WheelGeometry(p.wheel_base_m, p.wheel_diameter_m, p.counts_per_rev)
        self.query = oi.query_list_command()
        self.reply_size = oi.reply_size()
        # Shared with the /cmd_vel callback, under the lock: the latest command not yet sent and when it came.
        self.lock = threading.Lock()
        self.command: tuple[float, float] | None = None
        self.last_command_s: float | None = None          # time.monotonic(); None: no command yet
        # Serial thread only:
        self.odometry = oi.EncoderOdometry(self.geometry)
        self.conditions = safety.ConditionTracker()
        self.watchdog_tripped = False
        self.last_reply_s: float | None = None
        self.missed_replies = 0
        self.io_errors = 0
        self.failing_since: float | None = None           # time.monotonic() of the first failure in a row
        self.drops = input_drops(self, WARN_EVERY_S)
        self.max_angular_radps = 2.0 * p.max_wheel_speed_mps / p.wheel_base_m   # both wheels at the limit

        self.odom_pub = self.create_publisher(Odometry, "odom", SENSOR_QOS)
        self.tf_pub = self.create_publisher(TFMessage, "/tf", TF_QOS) if self.params.publish_tf else None
        self.event_pub = self.create_publisher(BaseEvent, "base/event", COMMAND_QOS)
        self.create_subscription(Twist, "cmd_vel", self.on_cmd_vel, COMMAND_QOS)
        self.wake = threading.Event()
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self.serial_loop, name="create_base_serial", daemon=True)
        self.thread.start()
        self.get_logger().info(f"Create on {p.port} at {p.baud} baud, {p.mode} mode; sensors at "
                               f"{p.sensor_rate_hz:g} Hz, wheels at most {p.max_wheel_speed_mps:g} m/s, "
                               f"watchdog {p.command_timeout_s:g} s")

    # ---------------------------------------------------------------------------------------- executor side
    def on_cmd_vel(self, msg: Twist) -> None:
        try:
            for name in ("linear.y", "linear.z", "angular.x", "angular.y"):   # unused, but a NaN there is garbage
                inputs.number(getattr(getattr(msg, name.split(".")[0]), name.split(".")[1]), name)
            command = inputs.velocity(msg.linear.x, msg.angular.z, self.params.max_wheel_speed_mps,
                                      self.max_angular_radps)
        except inputs.BadInput as error:
            self.drops.drop("cmd_vel", error)
            return
        if command.clamped:
            self.drops.clamp("cmd_vel", f"({msg.linear.x:g} m/s, {msg.angular.z:g} rad/s) beyond the base's limits, "
                                         f"scaled to ({command.linear_mps:g}, {command.angular_radps:g})")
        with self.lock:
            self.command = (command.linear_mps, command.angular_radps)
            self.last_command_s = time.monotonic()
        self.wake.set()

    def destroy_node(self) -> None:
        """Stop the serial thread, then the base: Drive Direct 0, 0 and Stop (the OI stops listening), and close
        the port."""
        self.stopping.set()
        self.wake.set()
        if self.thread.is_alive():
            self.thread.join(timeout=2.0)
        if self.port is not None:
            try:
                self.port.write(oi.STOP_DRIVING + bytes([oi.STOP]))
                self.port.flush()
            except SERIAL_ERRORS as error:
                self.get_logger().warning(f"could not stop the base on {self.params.port}: {error}")
            finally:
                self.port.close()
                self.port = None
        super().destroy_node()

    # ------------------------------------------------------------------------------------------ serial thread
    def serial_loop(self) -> None:
        try:
            self.start_oi()
            period = 1.0 / self.params.sensor_rate_hz
            next_query = time.monotonic()
            while not self.stopping.is_set():
                if self.port_lost():
                    return
                self.send_pending_command()
                self.check_watchdog()
                now = time.monotonic()
                if now >= next_query:
                    next_query = max(next_query + period, now)      # a late cycle is not caught up in a burst
                    self.sensor_cycle()
                else:
                    self.wake.wait(next_query - now)
                    self.wake.clear()
        finally:
            if not self.stopping.is_set():
                # A bug (its traceback follows) or a lost port ended the thread: with no watchdog left, stop the
                # base now; main() then exits SERIAL_THREAD_ENDED, and the orchestrator respawns the node.
                self.get_logger().fatal("the serial thread ended: stopping the base; create_base exits to be "
                                        "restarted")
                self.write(oi.STOP_DRIVING)

    def port_lost(self) -> bool:
        """Whether every serial read and write has failed for SERIAL_FAILURE_LIMIT_S (said once, as fatal)."""
        if self.failing_since is None or time.monotonic() - self.failing_since < SERIAL_FAILURE_LIMIT_S:
            return False
        self.get_logger().fatal(f"serial port {self.params.port}: every read and write failed for "
                                f"{SERIAL_FAILURE_LIMIT_S:g} s ({self.io_errors} errors): the port is lost")
        return True

    def start_oi(self) -> None:
        """Start, then Safe or Full; bytes the base sent before (its boot banner) are dropped."""
        opcodes = oi.mode_command(self.params.mode)
        try:
            self.port.reset_input_buffer()
            self.port.write(opcodes[:1])
            self.stopping.wait(START_PAUSE_S)
            self.port.write(opcodes[1:])
        except SERIAL_ERRORS as error:
            self.io_failed(error)

    def write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except SERIAL_ERRORS as error:
            self.io_failed(error)

    def io_failed(self, error: OSError) -> None:
        self.io_errors += 1
        if self.failing_since is None:
            self.failing_since = time.monotonic()
        self.get_logger().error(f"serial port {self.params.port}: {error} ({self.io_errors} errors so far)",
                                throttle_duration_sec=WARN_EVERY_S)

    def send_pending_command(self) -> None:
        with self.lock:
            command, self.command = self.command, None
        if command is None:
            return
        if self.watchdog_tripped:
            self.watchdog_tripped = False
            self.publish_event(safety.WATCHDOG, False, safety.RELEASED)
        linear, angular = safety.gate_motion(*command, bumped=self.conditions.bumped, halted=self.conditions.halted)
        if (linear, angular) != command:
            held = [name for name, active in self.conditions.active.items() if active]
            self.get_logger().warning(f"/cmd_vel ({command[0]:g} m/s, {command[1]:g} rad/s) limited to "
                                      f"({linear:g}, {angular:g}) while {', '.join(held)} holds",
                                      throttle_duration_sec=WARN_EVERY_S)
        speeds = oi.wheel_speeds(linear, angular, self.params.wheel_base_m, self.params.max_wheel_speed_mps)
        self.write(oi.drive_direct_command(speeds.right_mps, speeds.left_mps))

    def check_watchdog(self) -> None:
        with self.lock:
            last = self.last_command_s
        if last is None or self.watchdog_tripped or time.monotonic() - last <= self.params.command_timeout_s:
            return
        self.watchdog_tripped = True
        self.write(oi.STOP_DRIVING)
        self.get_logger().warning(f"no /cmd_vel for {self.params.command_timeout_s:g} s: stopped the base")
        self.publish_event(safety.WATCHDOG, True, safety.STOPPED)

    def sensor_cycle(self) -> None:
        try:
            if self.port.in_waiting:
                self.port.reset_input_buffer()       # the rest of a late reply: it would shift this one
            self.port.write(self.query)
            reply = self.port.read(self.reply_size)
        except SERIAL_ERRORS as error:
            self.io_failed(error)
            return
        received = time.monotonic()
        self.failing_since = None            # the port answers (a garbled reply is the link's, not the port's)
        try:
            state = oi.decode_sensors(reply)
        except ValueError as error:
            self.missed_replies += 1
            self.get_logger().warning(f"no usable sensor reply from {self.params.port}: {error} "
                                      f"({self.missed_replies} missed so far)", throttle_duration_sec=WARN_EVERY_S)
            return
        self.handle_conditions(state)
        dt = received - self.last_reply_s if self.last_reply_s is not None else 0.0
        self.last_reply_s = received
        self.publish_odometry(self.odometry.update(state.left_count, state.right_count, dt))

    def handle_conditions(self, state: oi.SensorState) -> None:
        was_halted = self.conditions.halted
        events = self.conditions.events(state.conditions())
        if any(event.active for event in events):
            self.write(oi.STOP_DRIVING)
        for event in events:
            if event.active:
                self.get_logger().warning(f"{event.event}: stopped the base; {event.action.replace('_', ' ')} "
                                          "while it holds")
            else:
                self.get_logger().info(f"{event.event} cleared")
            self.publish_event(event.event, event.active, event.action)
        if was_halted and not self.conditions.halted and self.params.mode == "safe":
            # In Safe mode the base itself drops to Passive on a cliff or wheel drop and ignores driving until
            # it is put back into Safe mode.
            self.write(bytes([oi.SAFE]))

    def publish_event(self, event: str, active: bool, action: str) -> None:
        msg = BaseEvent(event=event, active=active, action=action)
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self.params.base_frame
        self.publish(self.event_pub, msg)

    def publish_odometry(self, step: oi.OdometryStep) -> None:
        msg = Odometry()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self.params.odom_frame
        msg.child_frame_id = self.params.base_frame
        pose = msg.pose.pose
        pose.position.x, pose.position.y = step.pose.x, step.pose.y
        q = yaw_to_quaternion(step.pose.yaw)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (float(v) for v in q)
        msg.twist.twist.linear.x = step.linear_mps
        msg.twist.twist.angular.z = step.angular_radps
        self.publish(self.odom_pub, msg)
        if self.tf_pub is not None:     # odom -> base_link (REP 105), from the serial thread as /odom is
            frame = Frame.planar(self.params.odom_frame, self.params.base_frame, (step.pose.x, step.pose.y,
                                                                                   step.pose.yaw))
            self.publish(self.tf_pub, tf_message([frame], msg.header.stamp))

    def publish(self, publisher: Publisher, msg: Any) -> None:
        """Publish from the serial thread; after Ctrl-C the context is shut down before destroy_node stops the
        thread, and what it still publishes then is dropped rather than ending the thread with a traceback."""
        try:
            publisher.publish(msg)
        except RuntimeError:             # rclpy's RCLError: "publisher's context is invalid"
            if self.context.ok():
                raise


def spin(executor: Executor, node: Node) -> int:
    """Until Ctrl-C or SIGTERM (0), or until the serial thread ends (SERIAL_THREAD_ENDED): a node whose thread is
    gone drives nothing and watches nothing, so it exits to be respawned rather than stay up."""
    if not isinstance(node, CreateBaseNode):
        raise TypeError(f"spin: expected create_base's node, got {type(node).__name__}")
    spin_until_shutdown(executor, node, until=lambda: not node.thread.is_alive())
    return SERIAL_THREAD_ENDED if rclpy.ok(context=node.context) and not node.thread.is_alive() else 0


def main(args: list[str] | None = None) -> int:
    # SingleThreadedExecutor: the serial thread publishes /odom and /base/event beside the executor, and with
    # rclpy's EventsExecutor that once ended in a RuntimeError out of spin_once at shutdown (CI, a loaded machine).
    return run_node(CreateBaseNode, args, make_executor=SingleThreadedExecutor, spin=spin)


if __name__ == "__main__":
    raise SystemExit(main())
