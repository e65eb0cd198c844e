"""create_base: the Open Interface bytes, decoding, wheel-speed limit, encoder wrap-around and odometry as pure
functions; then the node against a fake Create 2 on a pseudo-terminal (test/fake_create.py): start-up, driving,
odometry, bumper / cliff / wheel-drop stops and blocks, the watchdog, short replies, NaN commands, shutdown, and a
port that is not there."""

from __future__ import annotations

import dataclasses
import errno
import math
import signal
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import pytest
import serial
import yaml
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter

from rfidnav_common import base_safety as safety
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, odometry_pose, twist
from rfidnav_drivers import create_oi as oi
from rfidnav_drivers.create_base_node import SERIAL_THREAD_ENDED, CreateBaseNode, port_error, spin
from rfidnav_drivers.errors import DriverError
from rfidnav_drivers.parameters import CreateBaseParameters
from rfidnav_msgs.msg import BaseEvent
from support.fake_create import Command, FakeCreate
from support.graph import Graph
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

GEOMETRY = oi.WheelGeometry()
MISSING_PORT = "/dev/ttyRFIDNAV_NO_SUCH_PORT"


# ------------------------------------------------------------------------------------------------ pure

def drive_bytes(right_mm_s: int, left_mm_s: int) -> bytes:
    """Drive Direct as the spec lays it out: opcode, right high, right low, left high, left low (two's complement)."""
    r, left = right_mm_s & 0xFFFF, left_mm_s & 0xFFFF
    return bytes([145, r >> 8, r & 0xFF, left >> 8, left & 0xFF])


@pytest.mark.parametrize("linear, angular, right, left", [
    (0.2, 0.0, 200, 200),
    (-0.1, 0.0, -100, -100),
    (0.0, 2.0, 235, -235),                 # on the spot: +-w*b/2
    (0.1, -0.8, 6, 194),                   # 0.1 -+ 0.094
    (0.5, 2.0, 500, 180),                  # 0.735 / 0.265 scaled by 0.5/0.735: the arc kept
    (-0.9, 0.0, -500, -500),
])
def test_drive_direct_bytes_right_wheel_first_and_limited_keeping_the_curvature(linear, angular, right, left):
    speeds = oi.wheel_speeds(linear, angular, 0.235, 0.5)
    assert oi.drive_direct_command(speeds.right_mps, speeds.left_mps) == drive_bytes(right, left)
    assert max(abs(speeds.left_mps), abs(speeds.right_mps)) <= 0.5 + 1e-12
    if linear != 0.0:                       # the curvature w/v of the limited speeds is the commanded one
        curvature = (speeds.right_mps - speeds.left_mps) / 0.235 / ((speeds.right_mps + speeds.left_mps) / 2)
        assert curvature == pytest.approx(angular / linear)


def test_drive_direct_clamps_to_the_open_interface_range_and_stops_with_zeros():
    assert oi.drive_direct_command(0.7, -0.7) == drive_bytes(500, -500)
    assert oi.STOP_DRIVING == bytes([145, 0, 0, 0, 0])
    assert oi.wheel_speeds(0.3, 0.0, 0.235, 0.25) == oi.WheelSpeeds(0.25, 0.25)   # a configured lower limit


def test_start_and_query_list_commands():
    assert oi.mode_command("safe") == bytes([128, 131])
    assert oi.mode_command("full") == bytes([128, 132])
    assert oi.query_list_command() == bytes([149, 7, 7, 9, 10, 11, 12, 43, 44])
    assert oi.reply_size() == 9


@pytest.mark.parametrize("previous, current, delta", [
    (100, 250, 150), (250, 100, -150),
    (65530, 5, 11),                        # forward across the rollover 65535 -> 0
    (5, 65530, -11),                       # backing up across it
    (0, 32767, 32767), (0, 32769, -32767),
])
def test_encoder_deltas_wrap_around_both_ways(previous, current, delta):
    assert oi.encoder_delta(previous, current) == delta


def feed(odometry: oi.EncoderOdometry, start: tuple[int, int], left_m: float, right_m: float,
         steps: int = 40) -> oi.OdometryStep:
    """Drive both wheels uniformly through ``left_m`` / ``right_m`` in ``steps`` readings of 16-bit counts."""
    step = odometry.update(*start, 0.02)
    for i in range(1, steps + 1):
        left = round(start[0] + oi.counts_for(left_m * i / steps, GEOMETRY)) % 65536
        right = round(start[1] + oi.counts_for(right_m * i / steps, GEOMETRY)) % 65536
        step = odometry.update(left, right, 0.02)
    return step


def test_odometry_of_a_straight_metre_across_the_rollover():
    odometry = oi.EncoderOdometry(GEOMETRY)
    step = feed(odometry, (64000, 65000), 1.0, 1.0)      # about 2249 counts: both counters roll over
    one_count = GEOMETRY.metres_per_count
    assert step.pose.x == pytest.approx(1.0, abs=one_count)
    assert step.pose.y == pytest.approx(0.0, abs=1e-9) and step.pose.yaw == pytest.approx(0.0, abs=1e-9)
    assert step.linear_mps == pytest.approx(1.0 / 40 / 0.02, rel=0.02) and step.angular_radps == pytest.approx(0.0)


def test_odometry_of_a_quarter_turn_on_the_spot():
    odometry = oi.EncoderOdometry(GEOMETRY)
    arc = math.pi / 2 * 0.235 / 2
    step = feed(odometry, (100, 65400), -arc, arc)        # the left counter goes back across 0
    assert step.pose.yaw == pytest.approx(math.pi / 2, abs=2 * GEOMETRY.metres_per_count / 0.235)
    assert math.hypot(step.pose.x, step.pose.y) < 1e-3
    assert step.linear_mps == pytest.approx(0.0, abs=0.02) and step.angular_radps > 0.0


def test_the_first_reading_only_sets_the_reference():
    odometry = oi.EncoderOdometry(GEOMETRY)
    assert odometry.update(12345, 54321, 0.0).pose == oi.Pose()
    assert odometry.update(12345, 54321, 0.02).pose == oi.Pose()


def test_sensor_reply_decoding():
    state = oi.decode_sensors(bytes([0b1010, 0, 1, 0, 0, 0xFF, 0xFE, 0x01, 0x02]))
    assert state == oi.SensorState(bump_left=True, bump_right=False, wheel_drop_left=True, wheel_drop_right=False,
                                   cliff_left=False, cliff_front_left=True, cliff_front_right=False,
                                   cliff_right=False, left_count=65534, right_count=258)
    right = oi.decode_sensors(bytes([0b0101, 0, 0, 0, 1, 0, 0, 0, 0]))
    assert [name for name, on in right.conditions().items() if on] == ["bump_right", "cliff_right",
                                                                        "wheel_drop_right"]
    with pytest.raises(ValueError, match="4 bytes"):
        oi.decode_sensors(bytes(4))
    with pytest.raises(ValueError, match="out of step"):
        oi.decode_sensors(bytes([0x10, 0, 0, 0, 0, 0, 0, 0, 0]))      # reserved bits: read out of step
    with pytest.raises(ValueError, match="out of step"):
        oi.decode_sensors(bytes([0, 0, 7, 0, 0, 0, 0, 0, 0]))


def test_condition_names_are_those_of_base_event_and_edges_are_found():
    assert set(safety.CONDITIONS) == {BaseEvent.BUMP_LEFT, BaseEvent.BUMP_RIGHT, BaseEvent.CLIFF_LEFT,
                                      BaseEvent.CLIFF_FRONT_LEFT, BaseEvent.CLIFF_FRONT_RIGHT, BaseEvent.CLIFF_RIGHT,
                                      BaseEvent.WHEEL_DROP_LEFT, BaseEvent.WHEEL_DROP_RIGHT}
    assert safety.WATCHDOG == BaseEvent.WATCHDOG
    tracker = safety.ConditionTracker()
    pressed = oi.decode_sensors(bytes([0b0010, 0, 0, 0, 0, 0, 0, 0, 0])).conditions()
    assert tracker.update(pressed) == (["bump_left"], []) and tracker.bumped and not tracker.halted
    assert tracker.update(pressed) == ([], [])
    cliff = oi.decode_sensors(bytes([0, 1, 0, 0, 0, 0, 0, 0, 0])).conditions()
    assert tracker.events(cliff) == [safety.BaseEventRecord("cliff_left", True, "all_motion_blocked"),
                                     safety.BaseEventRecord("bump_left", False, "released")]
    assert tracker.halted and not tracker.bumped


def test_motion_gate():
    assert safety.gate_motion(0.2, 0.5, bumped=True, halted=False) == (0.0, 0.5)     # turn away on the spot
    assert safety.gate_motion(-0.1, 0.5, bumped=True, halted=False) == (-0.1, 0.5)   # back up
    assert safety.gate_motion(-0.1, 0.5, bumped=False, halted=True) == (0.0, 0.0)
    assert safety.gate_motion(0.2, 0.5, bumped=False, halted=False) == (0.2, 0.5)


def test_the_parameter_file_documents_the_code_defaults():
    text = (WORKSPACE / "config/params/create_base.yaml").read_text()
    values = yaml.safe_load(text)["create_base"]["ros__parameters"]
    assert values == dataclasses.asdict(CreateBaseParameters())
    for name in values:
        line = next(line for line in text.splitlines() if line.strip().startswith(f"{name}:"))
        assert "#" in line, f"{name} has no comment"


def test_port_errors_name_the_port_and_what_to_check():
    denied = port_error("/dev/ttyUSB3", serial.SerialException(errno.EACCES, "could not open port: denied"))
    assert "/dev/ttyUSB3" in str(denied) and "dialout" in str(denied)
    missing = port_error("/dev/ttyUSB3", serial.SerialException(errno.ENOENT, "could not open port: no such file"))
    assert "/dev/ttyUSB3" in str(missing) and "not found" in str(missing) and "\n" not in str(missing)


# ------------------------------------------------------------------------------------------------ node

class Base:
    """create_base on a fake Create, with a probe that commands it and collects /odom and /base/event."""

    def __init__(self, graph: Graph, fake: FakeCreate, overrides: dict[str, Any]) -> None:
        self.graph, self.fake = graph, fake
        parameters = {"port": fake.slave_path, "command_timeout_s": 60.0, **overrides}   # no watchdog stop
        self.node: CreateBaseNode = graph.add(CreateBaseNode(
            context=graph.context, parameter_overrides=[Parameter(k, value=v) for k, v in parameters.items()]))
        self.odoms: list[Odometry] = []
        self.events: list[BaseEvent] = []
        probe = graph.probe
        self.cmd_pub = probe.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
        odom_sub = probe.create_subscription(Odometry, "/odom", self.odoms.append, SENSOR_QOS)
        event_sub = probe.create_subscription(BaseEvent, "/base/event", self.events.append, COMMAND_QOS)
        graph.spin_until(lambda: self.cmd_pub.get_subscription_count() > 0 and odom_sub.get_publisher_count() > 0
                         and event_sub.get_publisher_count() > 0, "create_base's topics")
        graph.spin_until(lambda: len(self.odoms) >= 2, "the first odometry from the fake Create's replies")

    def drive(self, linear: float, angular: float) -> tuple[int, int]:
        """Publish a /cmd_vel and return the Drive Direct (right, left mm/s) the fake receives for it."""
        since = len(self.fake.received())
        self.cmd_pub.publish(twist(linear, angular))
        self.graph.spin_until(lambda: self.fake.drives(since), f"a Drive Direct for /cmd_vel ({linear}, {angular})")
        return self.fake.drives(since)[0]

    def wait_event(self, event: str, active: bool) -> BaseEvent:
        found: list[BaseEvent] = []

        def arrived() -> bool:
            found[:] = [e for e in self.events if e.event == event and e.active == active]
            return bool(found)
        self.graph.spin_until(arrived, f"a BaseEvent {event} active={active}")
        return found[0]

    def pose(self) -> tuple[float, float, float]:
        return odometry_pose(self.odoms[-1])

    def shutdown(self) -> None:
        if self.node in self.graph.nodes:
            self.graph.executor.remove_node(self.node)
            self.graph.nodes.remove(self.node)
            self.node.destroy_node()


@pytest.fixture
def fake() -> Iterator[FakeCreate]:
    fake = FakeCreate(left_count=65500, right_count=65450)     # the odometry crosses the rollover at once
    yield fake
    fake.close()


@pytest.fixture
def start_base(graph: Graph, fake: FakeCreate) -> Iterator[Callable[..., Base]]:
    """create_base(**parameter overrides) on the fake; destroyed before the fake closes its pty."""
    started: list[Base] = []

    def start(**overrides: Any) -> Base:
        started.append(Base(graph, fake, overrides))
        return started[-1]
    yield start
    for base in started:
        base.shutdown()


@pytest.fixture
def base(start_base: Callable[..., Base]) -> Base:
    return start_base()


@pytest.mark.tier("node")
@pytest.mark.parametrize("mode, opcode", [("safe", oi.SAFE), ("full", oi.FULL)])
def test_the_node_starts_the_open_interface_in_its_mode_and_queries_the_sensors(
        graph: Graph, fake: FakeCreate, start_base, mode, opcode):
    base = start_base(mode=mode)
    assert fake.opcodes()[:2] == [oi.START, opcode] and fake.mode == mode
    queries = [c for c in fake.received() if c.opcode == oi.QUERY_LIST]
    assert queries and all(bytes([oi.QUERY_LIST, *c.args]) == oi.query_list_command() for c in queries)
    assert fake.unknown_bytes == []
    odom = base.odoms[-1]
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
    assert base.pose() == pytest.approx((0.0, 0.0, 0.0))       # start-up counts are only the reference


@pytest.mark.tier("node")
def test_a_forward_command_drives_both_wheels_and_odometry_advances_along_x(graph: Graph, base: Base):
    assert base.drive(0.2, 0.0) == (200, 200)
    graph.spin_until(lambda: base.pose()[0] > 0.1, "/odom to advance 10 cm")
    x, y, yaw = base.pose()
    assert abs(y) < 1e-6 and abs(yaw) < 1e-6, (x, y, yaw)
    recent = [o.twist.twist.linear.x for o in base.odoms[-10:]]
    assert statistics.median(recent) == pytest.approx(0.2, abs=0.05), recent
    assert all(o.twist.twist.angular.z == pytest.approx(0.0, abs=1e-6) for o in base.odoms)
    stamps = [o.header.stamp.sec + o.header.stamp.nanosec * 1e-9 for o in base.odoms]
    assert stamps == sorted(stamps) and stamps[-1] > 0.0


@pytest.mark.tier("node")
def test_a_turn_command_gives_opposite_wheel_speeds_and_a_turning_pose(graph: Graph, base: Base):
    right, left = base.drive(0.0, 1.0)
    assert right == -left and right in (117, 118), (right, left)
    graph.spin_until(lambda: base.pose()[2] > 0.2, "/odom's yaw to turn anticlockwise")
    assert math.hypot(*base.pose()[:2]) < 0.01
    assert base.drive(0.5, 2.0) == (500, 180)                   # limited to 0.5 m/s, keeping the arc


@pytest.mark.tier("node")
def test_a_bump_stops_at_once_and_blocks_forward_motion_until_released(graph: Graph, fake: FakeCreate, base: Base):
    assert base.drive(0.2, 0.0) == (200, 200)
    since = len(fake.received())
    pressed_s = time.monotonic()
    fake.set(bump_left=True)
    graph.spin_until(lambda: (0, 0) in fake.drives(since), "the Drive Direct 0, 0 after the bump")
    assert time.monotonic() - pressed_s < 3.0         # no command was sent meanwhile, and the watchdog is off
    assert fake.speeds() == (0, 0)
    event = base.wait_event(BaseEvent.BUMP_LEFT, True)
    assert event.action == "forward_blocked" and event.header.frame_id == "base_link"

    assert base.drive(0.2, 0.0) == (0, 0)                       # forward: refused
    right, left = base.drive(0.2, 1.0)                          # an arc forward: only its turn is left
    assert right == -left and right > 0, (right, left)
    assert base.drive(-0.1, 0.0) == (-100, -100)                # backing up: allowed
    assert base.drive(0.0, 2.0) == (235, -235)                  # turning on the spot: allowed
    graph.spin_until(lambda: graph.logged("create_base", "bump_left", "holds"), "the log of the refused motion")

    fake.set(bump_left=False)
    released = base.wait_event(BaseEvent.BUMP_LEFT, False)
    assert released.action == "released"
    assert base.drive(0.2, 0.0) == (200, 200)
    assert [e.active for e in base.events if e.event == BaseEvent.BUMP_LEFT] == [True, False]


@pytest.mark.tier("node")
@pytest.mark.parametrize("condition", [BaseEvent.CLIFF_FRONT_LEFT, BaseEvent.WHEEL_DROP_RIGHT])
def test_a_cliff_or_wheel_drop_blocks_all_motion_and_safe_mode_comes_back(graph: Graph, fake: FakeCreate,
                                                                           base: Base, condition: str):
    assert base.drive(0.2, 0.0) == (200, 200)
    since = len(fake.received())
    set_s = time.monotonic()
    fake.set(**{condition: True})
    graph.spin_until(lambda: (0, 0) in fake.drives(since), f"the Drive Direct 0, 0 after {condition}")
    assert time.monotonic() - set_s < 3.0
    assert base.wait_event(condition, True).action == "all_motion_blocked"
    assert base.drive(0.0, 2.0) == (0, 0)
    assert base.drive(-0.1, 0.0) == (0, 0)

    since = len(fake.received())
    fake.set(**{condition: False})
    assert base.wait_event(condition, False).action == "released"
    graph.spin_until(lambda: fake.mode == "safe", "create_base to put the base back into Safe mode")
    assert oi.SAFE in [c.opcode for c in fake.received()[since:]]
    assert base.drive(0.2, 0.0) == (200, 200)
    assert fake.speeds() == (200, 200)


@pytest.mark.tier("node")
def test_the_watchdog_stops_the_base_without_commands_and_releases_on_the_next(graph: Graph, fake: FakeCreate,
                                                                                start_base):
    base = start_base(command_timeout_s=0.3)
    sent_s = time.monotonic()
    assert base.drive(0.2, 0.0) == (200, 200)
    since = len(fake.received())
    event = base.wait_event(BaseEvent.WATCHDOG, True)
    assert time.monotonic() - sent_s >= 0.3 and event.action == "stopped"
    # The event comes over DDS, the stop over the pty to the fake's own thread: either may be first.
    graph.spin_until(lambda: fake.drives(since), "the watchdog's Drive Direct at the fake Create")
    assert fake.drives(since) == [(0, 0)] and fake.speeds() == (0, 0)
    assert base.drive(0.1, 0.0) == (100, 100)
    assert base.wait_event(BaseEvent.WATCHDOG, False).action == "released"
    assert [e.active for e in base.events if e.event == BaseEvent.WATCHDOG] == [True, False]


@pytest.mark.tier("node")
def test_short_and_missing_replies_are_counted_and_warned_about(graph: Graph, fake: FakeCreate, base: Base):
    for reply_bytes in (4, 0):
        missed = base.node.missed_replies
        fake.reply_bytes = reply_bytes
        graph.spin_until(lambda missed=missed: base.node.missed_replies >= missed + 2,
                         f"replies of {reply_bytes} bytes counted")
    graph.spin_until(lambda: graph.logged("create_base", "no usable sensor reply"), "the warning about replies")
    assert base.drive(0.1, 0.0) == (100, 100)                   # still serving commands
    fake.reply_bytes = None
    count = len(base.odoms)
    graph.spin_until(lambda: len(base.odoms) > count + 5, "odometry again once the replies are whole")
    assert base.node.thread.is_alive()


@pytest.mark.tier("node")
def test_a_nan_command_is_dropped_with_a_warning(graph: Graph, fake: FakeCreate, base: Base):
    since = len(fake.received())
    base.cmd_pub.publish(twist(math.nan, 0.0))
    graph.spin_until(lambda: graph.logged("create_base", "/cmd_vel: dropped", "nan is not finite"),
                     "a warning about the NaN command")
    assert base.drive(0.1, 0.0) == (100, 100)
    assert fake.drives(since) == [(100, 100)]                  # nothing was sent for the NaN one


# /cmd_vel at its extremes: (linear, angular) -> the Drive Direct sent (right, left mm/s), None when dropped.
COMMAND_CASES = [     # (1e308, 1e308): both scaled to 0.5 m/s and 0.5 rad/s, then the arc within the wheel limit
    ((1.7e308, 0.0), (500, 500)), ((-1e308, 0.0), (-500, -500)), ((1e308, 1e308), (500, 395)),
    ((0.0, 1.7e308), (500, -500)), ((0.0, -1e308), (-500, 500)), ((0.6, 0.0), (500, 500)),
    ((-0.0, -0.0), (0, 0)), ((math.nan, 0.0), None), ((0.0, math.inf), None), ((-math.inf, 0.0), None),
]


@pytest.mark.tier("node")
def test_commands_beyond_the_limits_are_clamped_non_finite_ones_dropped_and_the_serial_thread_lives_on(
        graph: Graph, fake: FakeCreate, base: Base):
    for (linear, angular), expected in COMMAND_CASES:
        clamped, dropped = base.node.drops.clamped("/cmd_vel"), base.node.drops.dropped("/cmd_vel")
        if expected is None:
            base.cmd_pub.publish(twist(linear, angular))
            graph.spin_until(lambda dropped=dropped: base.node.drops.dropped("/cmd_vel") > dropped,
                             f"/cmd_vel ({linear}, {angular}) dropped")
            continue
        right, left = base.drive(linear, angular)
        assert (right, left) == pytest.approx(expected, abs=1), (linear, angular)
        beyond = max(abs(linear) / 0.5, abs(angular) / (2 * 0.5 / 0.235)) > 1.0
        assert base.node.drops.clamped("/cmd_vel") == clamped + beyond, (linear, angular)
    assert base.node.thread.is_alive()
    assert base.drive(0.1, 0.0) == (100, 100)            # still driving on commands
    graph.spin_until(lambda: graph.logged("create_base", "/cmd_vel: clamped"), "the warning about clamping")
    assert all(math.isfinite(v) for o in base.odoms for v in (*odometry_pose(o), o.twist.twist.linear.x))


@pytest.mark.tier("node")
def test_a_serial_thread_that_dies_stops_the_base_and_ends_the_node_with_exit_1(graph: Graph, fake: FakeCreate,
                                                                                base: Base):
    assert base.drive(0.2, 0.0) == (200, 200)
    since = len(fake.received())

    def broken() -> None:
        raise RuntimeError("a bug in the serial thread")
    base.node.sensor_cycle = broken           # type: ignore[method-assign]  # the next cycle raises
    graph.spin_until(lambda: not base.node.thread.is_alive(), "the serial thread to die")
    assert (0, 0) in fake.drives(since) and fake.speeds() == (0, 0)
    assert spin(graph.executor, base.node) == SERIAL_THREAD_ENDED
    graph.spin_until(lambda: graph.logged("create_base", "serial thread ended"), "the fatal line")


@pytest.mark.tier("node")
def test_shutdown_stops_the_base_then_the_open_interface(graph: Graph, fake: FakeCreate, base: Base):
    assert base.drive(0.2, 0.0) == (200, 200)
    base.shutdown()
    graph.spin_until(lambda: fake.opcodes()[-1:] == [oi.STOP], "Stop after the node was destroyed")
    last = fake.received()[-2:]
    assert last[0].opcode == oi.DRIVE_DIRECT and last[0].args == (0, 0, 0, 0)
    assert fake.mode == "off" and fake.speeds() == (0, 0) and base.node.port is None
    assert not base.node.thread.is_alive()


@pytest.mark.tier("node")
def test_a_missing_port_is_one_driver_error_naming_it(graph: Graph):
    with pytest.raises(DriverError, match=MISSING_PORT) as raised:
        CreateBaseNode(context=graph.context, parameter_overrides=[Parameter("port", value=MISSING_PORT)])
    assert "not found" in str(raised.value)


@pytest.mark.tier("graph")
def test_main_prints_one_line_and_exits_2_for_a_missing_port():
    done = subprocess.run([sys.executable, "-m", "rfidnav_drivers.create_base_node", "--ros-args",
                           "-p", f"port:={MISSING_PORT}"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    fatal = [line for line in done.stderr.splitlines() if "FATAL" in line]
    assert len(fatal) == 1 and MISSING_PORT in fatal[0] and "Traceback" not in done.stderr, done.stderr


@contextmanager
def create_base_process(graph: Graph, fake: FakeCreate) -> Iterator[subprocess.Popen]:
    """create_base in its own process on the fake's port, once it queries the sensors; killed if still running."""
    process = subprocess.Popen([sys.executable, "-m", "rfidnav_drivers.create_base_node", "--ros-args",
                                "-p", f"port:={fake.slave_path}"], stderr=subprocess.PIPE, text=True)
    try:
        graph.spin_until(lambda: fake.queries >= 10 or process.poll() is not None, "the node's sensor queries",
                         timeout_s=60.0)
        assert process.poll() is None, process.communicate()[1]
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


@pytest.mark.tier("graph")
@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_ctrl_c_or_sigterm_stops_the_base_then_the_open_interface_without_a_traceback(
        graph: Graph, fake: FakeCreate, signal_number: int):
    with create_base_process(graph, fake) as process:
        process.send_signal(signal_number)
        stderr = process.communicate(timeout=60)[1]
    assert process.returncode == 0 and "Traceback" not in stderr, stderr
    graph.spin_until(lambda: fake.opcodes()[-1:] == [oi.STOP], "Stop from the interrupted node")
    assert fake.received()[-2] == Command(oi.DRIVE_DIRECT, (0, 0, 0, 0)) and fake.mode == "off"


@pytest.mark.tier("graph")
def test_a_lost_port_ends_the_process_with_exit_1_so_that_it_is_respawned(graph: Graph):
    fake = FakeCreate()
    with create_base_process(graph, fake) as process:
        fake.close()                           # the cable pulled: every read and write fails from now on
        stderr = process.communicate(timeout=60)[1]
    assert process.returncode == SERIAL_THREAD_ENDED, stderr
    assert "the port is lost" in stderr and "Traceback" not in stderr, stderr
