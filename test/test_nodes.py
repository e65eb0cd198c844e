"""Node tests: real nodes constructed in this process on a private rclpy Context, driven by a probe node on
the same executor, stepped with ``spin_once`` until a stated condition holds (no sleeps).

Each test leases its own DDS domain (as ``./rfidnav run`` does), so concurrent sessions never cross-talk.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import Trigger

from rfidnav_bag.bags import message_definition
from rfidnav_bag.player_node import PlayerNode
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, time_msg
from rfidnav_control.heading_controller_node import HeadingControllerNode
from rfidnav_msgs.action import FollowTagRoute
from rfidnav_msgs.msg import BaseEvent, TagReadArray, TagReading
from rfidnav_sim.rfid_reader_sim_node import RfidReaderSimNode
from rfidnav_sim.robot_sim_node import RobotSimNode
from support.graph import Graph, ground_truth
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("node")

ROUTE_MAP = WORKSPACE / "config/maps/line_follow.yaml"     # C1 -> F1, C2 -> F2
WORLD = WORKSPACE / "config/worlds/line_follow.yaml"       # C1 (0, 0, 3), C2 (0, 5, 3), F1, F2 on the floor
WAIT_S = 10.0   # generous for a loaded 2-core machine; each wait normally takes milliseconds
FREQUENCY_HZ = 915.25e6
ROUND_S = 0.04


def reading(tag_id: str, antenna: int, phase: float, **bad: float) -> TagReading:
    """A read as a reader reports it (I/Q consistent with the phase); ``bad`` overrides fields with NaN/Inf."""
    read = TagReading(tag_id=tag_id, antenna=antenna, rssi_dbm=-55.0, phase_rad=phase % (2 * math.pi),
                      i=math.cos(phase), q=math.sin(phase), frequency_hz=FREQUENCY_HZ)
    for field, value in bad.items():
        setattr(read, field, value)
    return read


def target_round(tag_id: str, phase_difference_rad: float) -> list[TagReading]:
    """The target read by the left (1) and right (2) antennas with phi1 - phi2 = ``phase_difference_rad``."""
    return [reading(tag_id, 1, 1.0 + phase_difference_rad), reading(tag_id, 2, 1.0)]


class ControllerHarness:
    """heading_controller (paper defaults, the line_follow route map) with a probe that sends it rounds."""

    def __init__(self, graph: Graph) -> None:
        self.graph = graph
        self.node: HeadingControllerNode = graph.add(HeadingControllerNode(
            context=graph.context, parameter_overrides=[Parameter("map_file", value=str(ROUTE_MAP))]))
        probe = graph.probe
        self.commands: list[Twist] = []
        self.feedback: list[FollowTagRoute.Feedback] = []
        self.reads_pub = probe.create_publisher(TagReadArray, "/rfid/reads", SENSOR_QOS)
        cmd_sub = probe.create_subscription(Twist, "/cmd_vel", self.commands.append, COMMAND_QOS)
        self.client = ActionClient(probe, FollowTagRoute, "/follow_tag_route")
        graph.clients.append(self.client)
        graph.spin_until(lambda: self.client.server_is_ready() and self.reads_pub.get_subscription_count() > 0
                         and cmd_sub.get_publisher_count() > 0, "heading_controller's action server and topics")
        # Rounds are stamped on a fixed 25 Hz grid: the node steps on the rounds' own stamps. A small origin
        # keeps the round time exact in float seconds (at an epoch time it is off by ~1e-7 s).
        self.stamp_s = 100.0
        self.sent_rounds = 0

    def send_goal(self, tag_ids: list[str]):
        future = self.client.send_goal_async(FollowTagRoute.Goal(tag_ids=tag_ids),
                                             feedback_callback=lambda m: self.feedback.append(m.feedback))
        self.graph.spin_until(future.done, f"an answer to the goal {tag_ids}")
        return future.result()

    def start_route(self, tag_ids: list[str]):
        handle = self.send_goal(tag_ids)
        assert handle.accepted, f"goal {tag_ids} rejected: {self.graph.logged('heading_controller')}"
        # Accepted is answered before the goal executes; rounds sent before that would be ignored.
        self.graph.spin_until(lambda: self.node.goals.active is not None, "the goal to start executing")
        return handle

    def send_round(self, readings: list[TagReading]) -> Twist:
        """Publish one inventory round while a goal is active and return the /cmd_vel it is answered with."""
        self.stamp_s += ROUND_S
        msg = TagReadArray(readings=readings)
        msg.header.stamp = time_msg(self.stamp_s)
        msg.header.frame_id = "base_link"
        for read in readings:
            read.stamp = msg.header.stamp
        before = len(self.commands)
        self.reads_pub.publish(msg)
        self.sent_rounds += 1
        self.graph.spin_until(lambda: len(self.commands) > before, f"a /cmd_vel for round {self.sent_rounds}")
        return self.commands[before]


# ------------------------------------------------------------------------------------- heading_controller

@pytest.mark.parametrize("route, named", [(["C1", "NOPE"], "NOPE"), (["X9"], "X9"), ([], "empty")])
def test_controller_rejects_an_unknown_or_empty_route_naming_the_problem(graph: Graph, route, named) -> None:
    controller = ControllerHarness(graph)
    handle = controller.send_goal(route)
    assert not handle.accepted, f"route {route} was accepted"
    graph.spin_until(lambda: graph.logged("heading_controller", "goal rejected", named),
                     f"heading_controller to log why {route} was rejected (naming '{named}')")
    if named != "empty":
        message = graph.logged("heading_controller", "goal rejected")[0]
        assert "C1" not in message.split("unknown tag ids")[-1].split("(")[0], message  # only the unknown ones
    assert controller.node.goals.active is None
    # Still serving: a valid route is accepted afterwards.
    controller.start_route(["C1"])


def test_controller_steers_towards_the_tag_and_reports_each_arrival(graph: Graph) -> None:
    controller = ControllerHarness(graph)
    handle = controller.start_route(["C1", "C2"])
    result_future = handle.get_result_async()

    # phi1 - phi2 > 0: the tag is nearer the right antenna, so turn clockwise (negative yaw rate).
    right = controller.send_round(target_round("C1", +0.5))
    left = controller.send_round(target_round("C1", -0.5))
    ahead = controller.send_round(target_round("C1", 0.0))
    assert right.linear.x == pytest.approx(0.2) and right.angular.z < -0.1, right
    assert left.angular.z == pytest.approx(-right.angular.z), (left, right)
    assert ahead.angular.z == pytest.approx(0.0, abs=1e-9)
    unheard = controller.send_round([reading("C2", 1, 0.3)])
    assert (unheard.linear.x, unheard.angular.z) == (pytest.approx(0.2), 0.0), "a missed round keeps going straight"

    # The floor tag under C1 marks arrival; the next target is C2.
    controller.send_round([reading("F1", 3, 2.0),
                           *target_round("C2", 0.2)])
    graph.spin_until(lambda: controller.feedback and controller.feedback[-1].target_tag_id == "C2",
                     "feedback naming C2 as the target after F1 was read")
    # Feedback is throttled (rfidnav_common.goal_server): rounds that change only floats within 0.5 s send none.
    before_arrival = controller.feedback[:-1]
    assert before_arrival and {f.target_index for f in before_arrival} == {0}
    # The first rounds seek; the round that missed C1 is a change of mode, so it is reported at once.
    assert before_arrival[0].mode == "seeking" and before_arrival[-1].mode == "unheard"

    controller.send_round([reading("F2", 3, 2.0)])
    graph.spin_until(result_future.done, "the route's result after F2 was read")
    result = result_future.result().result
    assert result.success and result.tags_reached == 2, result
    assert "2 tags" in result.message
    graph.spin_until(lambda: len(controller.commands) >= 7, "the stop command sent when the route ends")
    assert (controller.commands[-1].linear.x, controller.commands[-1].angular.z) == (0.0, 0.0)
    assert controller.node.goals.active is None


NAN, INF = math.nan, math.inf


def test_controller_drops_and_counts_non_finite_reads_and_stays_up(graph: Graph) -> None:
    controller = ControllerHarness(graph)
    node = controller.node
    fuzzy_inputs: list[float] = []
    fuzzy = node.follower.heading_controller
    node.follower.heading_controller = lambda dphi: fuzzy_inputs.append(dphi) or fuzzy(dphi)
    handle = controller.start_route(["C1", "C2"])

    rounds = [
        # A good target pair beside bad copies of it: the good pair steers, the bad reads are dropped.
        target_round("C1", 0.4) + [reading("C1", 1, 0.0, i=NAN), reading("C1", 2, 0.0, q=INF)],
        # The left antenna's only read of the target is bad: the target counts as unheard this round.
        [reading("C1", 1, 0.0, phase_rad=NAN, i=0.0, q=0.0), reading("C1", 2, 1.0)],
        # A bad read of the floor tag must not count as arriving under C1.
        target_round("C1", -0.3) + [reading("F1", 3, 1.0, i=-INF), reading("F1", 3, 1.0, rssi_dbm=INF)],
        # Nothing usable at all.
        [reading("C1", 1, 0.0, i=NAN, q=NAN, phase_rad=NAN), reading("C1", 2, 0.0, frequency_hz=INF),
         reading("C2", 1, 0.0, frequency_hz=NAN)],
    ]
    bad_reads = 2 + 1 + 2 + 3
    commands = [controller.send_round(readings) for readings in rounds]
    assert node.drops.dropped("/rfid/reads") == bad_reads
    for command in commands:
        assert all(math.isfinite(v) for v in (command.linear.x, command.linear.y, command.linear.z,
                                              command.angular.x, command.angular.y, command.angular.z)), command
    assert commands[0].angular.z < -0.1 and commands[2].angular.z > 0.1, "the good pairs still steer"
    assert (commands[1].linear.x, commands[1].angular.z) == (pytest.approx(0.2), 0.0), "unheard: straight on"
    assert (commands[3].linear.x, commands[3].angular.z) == (pytest.approx(0.2), 0.0), "unheard: straight on"
    assert len(fuzzy_inputs) == 2 and all(math.isfinite(x) for x in fuzzy_inputs), fuzzy_inputs
    graph.spin_until(lambda: len(controller.feedback) >= len(rounds), "feedback for every round")
    assert all(math.isfinite(f.phase_difference_rad) and math.isfinite(f.heading_change_rad)
               for f in controller.feedback)
    assert {f.target_tag_id for f in controller.feedback} == {"C1"}, "a NaN read of F1 counted as arrival"
    graph.spin_until(lambda: graph.logged("heading_controller", "/rfid/reads: dropped", "not finite"),
                     "the warning that counts dropped reads on /rosout")

    # Still alive and steering: a good read of F1 is an arrival, and the goal is still the same goal.
    controller.send_round([reading("F1", 3, 1.0), *target_round("C2", 0.0)])
    graph.spin_until(lambda: controller.feedback[-1].target_tag_id == "C2", "arrival at C1 after the bad reads")
    assert node.goals.active is not None and node.goals.active.handle.goal_id == handle.goal_id
    assert node.drops.dropped("/rfid/reads") == bad_reads


# ---------------------------------------------------------------------------------------- rfid_reader_sim


def test_reader_sim_publishes_one_round_per_period_on_the_ground_truth_clock(graph: Graph) -> None:
    reader = graph.add(RfidReaderSimNode(context=graph.context, parameter_overrides=[
        Parameter("world_file", value=str(WORLD)), Parameter("seed", value=7)]))
    rounds: list[TagReadArray] = []
    truth_pub = graph.probe.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
    reads_sub = graph.probe.create_subscription(TagReadArray, "/rfid/reads", rounds.append, SENSOR_QOS)
    graph.spin_until(lambda: truth_pub.get_subscription_count() > 0 and reads_sub.get_publisher_count() > 0,
                     "rfid_reader_sim's topics")
    # Heading north 0.5 m left of the line x = 0: C1 (3 m up, 1 m ahead) is to the right.
    stamps = [round(0.02 * k, 2) for k in range(1, 11)]   # ground truth at 50 Hz, rounds at 25 Hz
    for stamp in stamps:
        truth_pub.publish(ground_truth(-0.5, -1.0, 90.0, stamp))
    expected = [0.02, 0.04, 0.08, 0.12, 0.16, 0.2]   # the first pose at or after each round's due time
    graph.spin_until(lambda: len(rounds) >= len(expected), f"{len(expected)} rounds on /rfid/reads")
    assert [round(r.header.stamp.sec + r.header.stamp.nanosec * 1e-9, 6) for r in rounds] == expected
    differences = []
    for msg in rounds:
        seen = {(r.tag_id, r.antenna) for r in msg.readings}
        assert {("C1", 1), ("C1", 2), ("C2", 1), ("C2", 2)} <= seen, seen
        assert not {tag for tag, _ in seen} & {"F1", "F2"}, "floor tags are out of the downward antenna's range"
        for r in msg.readings:
            assert r.stamp == msg.header.stamp
            assert 0.0 <= r.phase_rad < 2 * math.pi and r.frequency_hz == pytest.approx(FREQUENCY_HZ)
            assert math.atan2(r.q, r.i) % (2 * math.pi) == pytest.approx(r.phase_rad, abs=1e-9)
        phase = {r.antenna: r.phase_rad for r in msg.readings if r.tag_id == "C1"}
        differences.append(math.remainder(phase[1] - phase[2], 2 * math.pi))
    # Left antenna farther from a tag on the right: phi1 > phi2 by 4*pi*(0.06 m * 0.5/2.9)/lambda ~ 0.4 rad,
    # the sign heading_controller turns clockwise on. Phase noise (0.02 rad/m) is ~0.06 rad at 2.9 m.
    mean = sum(differences) / len(differences)
    assert 0.25 < mean < 0.55, differences
    assert reader.get_name() == "rfid_reader_sim"


# ---------------------------------------------------------------------------------------------- robot_sim

def test_robot_sim_stops_at_a_wall_and_reports_the_bump_on_base_event(graph: Graph, tmp_path: Path) -> None:
    world = tmp_path / "wall.yaml"
    world.write_text("name: wall\ntags:\n  - {id: C1, position: [0.0, 0.0, 3.0]}\nwalls:\n  - [1.0, -2.0, 1.0, 2.0]\n")
    graph.add(RobotSimNode(context=graph.context, parameter_overrides=[
        Parameter("world_file", value=str(world)), Parameter("rtf", value=10.0)]))
    events: list[BaseEvent] = []
    truth: list[Odometry] = []
    cmd_pub = graph.probe.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
    graph.probe.create_subscription(BaseEvent, "/base/event", events.append, COMMAND_QOS)
    graph.probe.create_subscription(Odometry, "/sim/ground_truth", truth.append, SENSOR_QOS)
    graph.spin_until(lambda: cmd_pub.get_subscription_count() > 0 and truth, "robot_sim's topics")
    forward = Twist()
    forward.linear.x = 0.3

    def pressed() -> bool:
        cmd_pub.publish(forward)          # a controller's stream of commands: the bump must stop it all the same
        return len({e.event for e in events if e.active}) == 2

    graph.spin_until(pressed, "both bumpers pressed on /base/event (the wall is straight ahead)")
    assert {(e.event, e.action) for e in events if e.active} == {("bump_left", "forward_blocked"),
                                                                 ("bump_right", "forward_blocked")}
    at_bump = len(truth)
    graph.spin_until(lambda: (cmd_pub.publish(forward), len(truth) > at_bump + 25)[1], "half a second more")
    assert truth[-1].pose.pose.position.x <= 1.0 - 0.17 + 1e-6      # pressed against the wall, not through it


def test_robot_sim_simulates_two_robots_under_their_names_that_stop_at_each_other(graph: Graph,
                                                                                 tmp_path: Path) -> None:
    """Two robots 2 m apart driven at each other on their own /rN/cmd_vel: each one's ground truth and bumpers on
    its own topics, both stopped with their footprints touching, none driven through the other."""
    world = tmp_path / "open.yaml"
    world.write_text("name: open\ntags:\n  - {id: C1, position: [0.0, 0.0, 3.0]}\n")
    graph.add(RobotSimNode(context=graph.context, parameter_overrides=[
        Parameter("world_file", value=str(world)), Parameter("rtf", value=10.0),
        Parameter("robots", value=["r1", "r2"]), Parameter("robot_starts", value=[0.0, 0.0, 0.0, 2.0, 0.0, 180.0])]))
    commands = {name: graph.probe.create_publisher(Twist, f"/{name}/cmd_vel", COMMAND_QOS) for name in ("r1", "r2")}
    events: dict[str, list[BaseEvent]] = {"r1": [], "r2": []}
    truth: dict[str, list[Odometry]] = {"r1": [], "r2": []}
    for name in commands:
        graph.probe.create_subscription(BaseEvent, f"/{name}/base/event", events[name].append, COMMAND_QOS)
        graph.probe.create_subscription(Odometry, f"/{name}/sim/ground_truth", truth[name].append, SENSOR_QOS)
    graph.spin_until(lambda: all(c.get_subscription_count() for c in commands.values()) and all(truth.values()),
                     "both robots' topics")
    assert truth["r2"][-1].pose.pose.position.x == pytest.approx(2.0, abs=0.01)
    forward = Twist()
    forward.linear.x = 0.3

    def both_pressed() -> bool:
        for publisher in commands.values():
            publisher.publish(forward)
        return all(any(e.active for e in events[name]) for name in events)

    graph.spin_until(both_pressed, "each robot's bumpers pressed on its own /base/event")

    def seconds(message: Odometry) -> float:
        return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9

    # Half a second of sim time more for both, then both robots' positions at one stamp: the two topics' latest
    # messages may be of different steps on a loaded machine.
    pressed_s = max(seconds(truth[name][-1]) for name in truth)
    graph.spin_until(lambda: (both_pressed(), all(seconds(truth[name][-1]) > pressed_s + 0.5 for name in truth))[1],
                     "half a second of sim time more for both")
    at = {name: {round(seconds(m), 6): m.pose.pose.position.x for m in truth[name]} for name in truth}
    stamp = max(set(at["r1"]) & set(at["r2"]))
    assert stamp > pressed_s + 0.5
    gap = at["r2"][stamp] - at["r1"][stamp]
    assert 2 * 0.17 - 0.01 < gap < 2 * 0.17 + 0.01      # touching, not through each other


# ------------------------------------------------------------------------------------------------- player

def test_player_holds_playback_until_started(graph: Graph, tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    writer = Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    definition, rihs01 = message_definition("rosgraph_msgs/msg/Clock")
    connection = writer.add_connection("/clock", "rosgraph_msgs/msg/Clock", msgdef=definition, rihs01=rihs01)
    stamps_ns = [1_000_000_000 + 10_000_000 * k for k in range(5)]
    for stamp_ns in stamps_ns:
        writer.write(connection, stamp_ns, serialize_message(ClockMsg(clock=time_msg(stamp_ns * 1e-9))))
    writer.close()

    player = graph.add(PlayerNode(context=graph.context, parameter_overrides=[
        Parameter("bag", value=str(bag)), Parameter("start_paused", value=True)]))
    received: list[ClockMsg] = []
    clock_sub = graph.probe.create_subscription(ClockMsg, "/clock", received.append, SENSOR_QOS)
    start = graph.probe.create_client(Trigger, "/player/start")
    graph.spin_until(lambda: clock_sub.get_publisher_count() > 0 and start.service_is_ready(),
                     "the player's /clock and ~/start")
    for _ in range(20):   # ~20 ticks of the player's 5 ms timer: playback would be over by now
        graph.executor.spin_once(timeout_sec=0.05)
    assert not received and player.published == 0 and not player.done.done(), "played while paused"

    answer = start.call_async(Trigger.Request())
    graph.spin_until(lambda: answer.done() and player.done.done() and len(received) == len(stamps_ns),
                     "playback of the 5 messages after ~/start")
    assert answer.result().success
    assert [m.clock.sec * 1_000_000_000 + m.clock.nanosec for m in received] == stamps_ns
    assert player.done.result() == 0
