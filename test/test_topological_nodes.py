"""wall_follower and mission_executor as nodes (paper 004), each driven by a probe standing in for the other
and for the sensors: idle until commanded, holding still on silent or NaN sonar, a mission's commands and
feedback from scripted reads and events, refused goals, cancel."""

from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from sensor_msgs.msg import Range

from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS
from rfidnav_control.parameters import SONAR_FIELDS, WallFollowerParameters
from rfidnav_control.wall_follower_node import WallFollowerNode
from rfidnav_msgs.action import NavigateToNode
from rfidnav_msgs.msg import (
    TagReadArray,
    TagReading,
    WallFollowerCommand,
    WallFollowerEvent,
)
from rfidnav_planning.mission_executor_node import MissionExecutorNode
from rfidnav_sim.sonar_model import PAPER_LAYOUT
from support.graph import Graph
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("node")

FIG5_MAP = WORKSPACE / "config/maps/building_fig5.yaml"
BESIDE_A_WALL = {"front": math.inf, "front_left": math.inf, "front_right": math.inf, "left": 0.8, "right": 0.8}


@pytest.mark.tier("unit")
def test_the_sonar_offsets_are_those_of_the_simulated_layout() -> None:
    layout = {r.name: r.position[0] * math.cos(r.bearing_rad) + r.position[1] * math.sin(r.bearing_rad)
              for r in PAPER_LAYOUT}
    parameters = WallFollowerParameters()
    for topic, offset in zip(parameters.sonar_topics, parameters.sonar_offsets_m):
        assert offset == pytest.approx(layout[topic.removeprefix("sonar/")], abs=1e-3), topic


class FollowerProbe:
    """Sonar and odometry publishers, and what the wall follower sends back."""

    def __init__(self, graph: Graph) -> None:
        self.graph = graph
        probe = graph.probe
        self.sonar_pubs = {field: probe.create_publisher(Range, topic, SENSOR_QOS)
                           for field, topic in zip(SONAR_FIELDS, WallFollowerParameters().sonar_topics)}
        self.odom_pub = probe.create_publisher(Odometry, "/odom", SENSOR_QOS)
        self.command_pub = probe.create_publisher(WallFollowerCommand, "/wall_follower/command", COMMAND_QOS)
        self.twists: list[Twist] = []
        self.events: list[str] = []
        self.states: list[str] = []
        probe.create_subscription(Twist, "/cmd_vel", self.twists.append, COMMAND_QOS)
        probe.create_subscription(WallFollowerEvent, "/wall_follower/state", lambda m: self.states.append(m.state),
                                  COMMAND_QOS)
        probe.create_subscription(WallFollowerEvent, "/wall_follower/event", lambda m: self.events.append(m.event),
                                  COMMAND_QOS)
        self.ranges = dict(BESIDE_A_WALL)
        self.silent = False
        self.timer = probe.create_timer(0.05, self.publish)

    def publish(self) -> None:
        if self.silent:
            return
        offsets = dict(zip(SONAR_FIELDS, WallFollowerParameters().sonar_offsets_m))
        for field, publisher in self.sonar_pubs.items():
            value = self.ranges[field]
            reading = Range(range=value - offsets[field] if math.isfinite(value) else value)
            reading.header.frame_id = "sonar_" + publisher.topic_name.removeprefix("/sonar/")
            publisher.publish(reading)
        odom = Odometry(child_frame_id="base_link")
        odom.header.frame_id = "odom"
        odom.pose.pose.orientation.w = 1.0
        self.odom_pub.publish(odom)

    def command(self, action: str, within_m: float = 0.0) -> None:
        self.command_pub.publish(WallFollowerCommand(action=action, stop_within_m=within_m))


def test_the_wall_follower_is_idle_until_commanded_then_drives_and_stops(graph: Graph) -> None:
    node = graph.add(WallFollowerNode(context=graph.context))
    probe = FollowerProbe(graph)
    graph.spin_until(lambda: len(node.ranges) == len(SONAR_FIELDS) and node.odom is not None, "sonar and odometry")
    for _ in range(10):                                    # several control periods with data and no command
        graph.executor.spin_once(timeout_sec=0.05)
    assert probe.twists == [] and node.follower is None
    graph.spin_until(lambda: probe.command_pub.get_subscription_count() > 0, "the command topic")
    probe.command("follow")
    graph.spin_until(lambda: probe.twists and probe.twists[-1].linear.x > 0.0, "driving forward")
    assert probe.twists[-1].linear.x == 0.2 and abs(probe.twists[-1].angular.z) < 1e-6   # parallel at 0.8 m
    graph.spin_until(lambda: probe.states and probe.states[-1] == "following", "the state heartbeat")
    probe.command("stop", 0.0)
    graph.spin_until(lambda: "stopped" in probe.events, "the stopped event")
    assert probe.twists[-1].linear.x == 0.0 and node.follower is None
    graph.spin_until(lambda: probe.states[-1] == "idle", "idle in the state heartbeat")


def test_a_stop_whose_distance_is_no_distance_is_dropped_and_changes_nothing(graph: Graph) -> None:
    node = graph.add(WallFollowerNode(context=graph.context))
    probe = FollowerProbe(graph)
    graph.spin_until(lambda: probe.command_pub.get_subscription_count() > 0, "the command topic")
    probe.command("follow")
    graph.spin_until(lambda: probe.twists and probe.twists[-1].linear.x > 0.0, "driving forward")
    for bad in (math.nan, math.inf, -1.0):
        dropped = node.drops.dropped("/wall_follower/command")
        probe.command("stop", bad)
        graph.spin_until(lambda dropped=dropped: node.drops.dropped("/wall_follower/command") > dropped,
                         f"the stop within {bad} m dropped")
    twists = len(probe.twists)
    graph.spin_until(lambda: len(probe.twists) > twists + 5, "five more control periods")
    assert all(twist.linear.x == 0.2 for twist in probe.twists[twists:]) and "stopped" not in probe.events
    assert node.follower is not None and node.follower.stop_from is None


def test_silent_or_nan_sonar_holds_the_robot_still_and_the_node_stays_up(graph: Graph) -> None:
    graph.add(WallFollowerNode(context=graph.context, parameter_overrides=[
        Parameter("sonar_timeout_s", value=0.3)]))
    probe = FollowerProbe(graph)
    graph.spin_until(lambda: probe.command_pub.get_subscription_count() > 0, "the command topic")
    probe.command("follow")
    graph.spin_until(lambda: probe.twists and probe.twists[-1].linear.x > 0.0, "driving forward")
    probe.silent = True
    graph.spin_until(lambda: graph.logged("wall_follower", "no recent range"), "the silent-sonar warning")
    graph.spin_until(lambda: probe.twists[-1].linear.x == 0.0, "a stop")
    probe.ranges["left"] = math.nan
    probe.silent = False
    graph.spin_until(lambda: graph.logged("wall_follower", "/sonar/left: dropped", "nan is not finite"),
                     "the NaN warning")
    probe.command("sideways")
    graph.spin_until(lambda: graph.logged("wall_follower", "unknown action 'sideways'"), "the unknown-action error")
    probe.ranges["left"] = 0.8
    graph.spin_until(lambda: probe.twists[-1].linear.x > 0.0, "driving again once the left sonar is back")


class ExecutorProbe:
    """A stand-in wall follower (listening for commands, sending events), the reader, and an action client."""

    def __init__(self, graph: Graph, listen: bool = True) -> None:
        self.graph = graph
        probe = graph.probe
        self.commands: list[tuple[str, float]] = []
        if listen:
            probe.create_subscription(WallFollowerCommand, "/wall_follower/command",
                                      lambda m: self.commands.append((m.action, m.stop_within_m)), COMMAND_QOS)
        self.event_pub = probe.create_publisher(WallFollowerEvent, "/wall_follower/event", COMMAND_QOS)
        self.reads_pub = probe.create_publisher(TagReadArray, "/rfid/reads", SENSOR_QOS)
        self.client = ActionClient(probe, NavigateToNode, "/navigate_to_node")
        graph.clients.append(self.client)
        self.feedback: list[NavigateToNode.Feedback] = []
        graph.spin_until(self.client.server_is_ready, "the action server")

    def send(self, node: str):
        sent = self.client.send_goal_async(NavigateToNode.Goal(goal_node=node),
                                           feedback_callback=lambda m: self.feedback.append(m.feedback))
        self.graph.spin_until(sent.done, "the goal's answer")
        return sent.result()

    def read(self, *tags: str) -> None:
        msg = TagReadArray(readings=[TagReading(tag_id=tag, antenna=1, rssi_dbm=-60.0, frequency_hz=2.45e9)
                                     for tag in tags])
        msg.header.frame_id = "base_link"
        self.reads_pub.publish(msg)

    def event(self, name: str) -> None:
        self.event_pub.publish(follower_report(event=name))


def follower_report(event: str = "", state: str = "") -> WallFollowerEvent:
    """A WallFollowerEvent as the wall follower sends it (in odom)."""
    report = WallFollowerEvent(event=event, state=state)
    report.header.frame_id = "odom"
    return report


def executor_node(graph: Graph) -> MissionExecutorNode:
    return graph.add(MissionExecutorNode(context=graph.context, parameter_overrides=[
        Parameter("map_file", value=str(FIG5_MAP))]))


def test_a_mission_from_tag_23_to_g_commands_the_follower_and_succeeds_on_stopped(graph: Graph) -> None:
    node = executor_node(graph)
    probe = ExecutorProbe(graph)
    graph.spin_until(lambda: node.command_pub.get_subscription_count() > 0, "the follower stand-in")
    handle = probe.send("g")
    assert handle.accepted
    graph.spin_until(lambda: probe.commands == [("follow", 0.0)], "the follow command")
    probe.read("23", "23")
    graph.spin_until(lambda: len(probe.commands) == 2, "the turn for h")
    assert probe.commands[1] == ("right", 0.0)
    last = probe.feedback[-1]
    assert (last.current_node, last.arrival_direction, last.last_tag, last.next_action) == ("h", "W", "23", "right")
    probe.event("junction_centre")          # the follower turns with the command it has: nothing is sent again
    graph.spin_until(lambda: probe.feedback[-1].next_action == "right" and len(probe.feedback) >= 2,
                     "the feedback of h's centre")
    probe.event("turn_done")
    probe.read("19")
    graph.spin_until(lambda: probe.commands[-1][0] == "stop", "the stop")
    assert probe.commands == [("follow", 0.0), ("right", 0.0), ("stop", 4.0)]   # on to g's centre: 2 x tag_to_node
    result = handle.get_result_async()
    probe.event("stopped")
    graph.spin_until(result.done, "the result")
    outcome = result.result().result
    assert outcome.success and list(outcome.nodes_visited) == ["h", "g"]
    assert (outcome.tags_missed, outcome.replans) == (0, 0)


def test_a_goal_reached_through_an_explored_hallway_reports_the_hallway_in_its_feedback(graph: Graph,
                                                                                      tmp_path) -> None:
    # Fig. 5 with h - f unmapped at both ends: f is reached only by exploring h's "?" side East.
    text = FIG5_MAP.read_text()
    for known, unknown in (("E: {node: f, tags: [24]}", 'E: {node: "?", tags: [24]}'),
                           ("W: {node: h, tags: [17]}", 'W: {node: "?", tags: [17]}')):
        text = text.replace(known, unknown)
    partial = tmp_path / "fig5_without_h_f.yaml"
    partial.write_text(text)
    graph.add(MissionExecutorNode(context=graph.context, parameter_overrides=[
        Parameter("map_file", value=str(partial))]))
    probe = ExecutorProbe(graph)
    assert probe.send("f").accepted
    graph.spin_until(lambda: probe.commands == [("follow", 0.0)], "the follow command")
    probe.read("23")                        # h from the West: straight on into the "?" hallway East
    graph.spin_until(lambda: probe.feedback and probe.feedback[-1].last_tag == "23", "the feedback of tag 23")
    assert list(probe.feedback[-1].learned_hallways) == []
    probe.event("junction_centre")
    probe.read("17")                        # f from the West: the hallway is learned, and f is the goal
    graph.spin_until(lambda: probe.commands[-1][0] == "stop", "the stop at f")
    graph.spin_until(lambda: probe.feedback[-1].last_tag == "17", "the feedback of tag 17")
    assert list(probe.feedback[-1].learned_hallways) == ["h.E -> f.W"]


def test_goals_are_refused_for_unknown_nodes_or_without_a_wall_follower(graph: Graph) -> None:
    node = executor_node(graph)
    probe = ExecutorProbe(graph, listen=False)
    assert not probe.send("g").accepted
    graph.spin_until(lambda: graph.logged("mission_executor", "no wall follower listens"), "the refusal's reason")
    graph.probe.create_subscription(WallFollowerCommand, "/wall_follower/command", lambda m: None, COMMAND_QOS)
    graph.spin_until(lambda: node.command_pub.get_subscription_count() > 0, "a follower")
    assert not probe.send("z").accepted
    graph.spin_until(lambda: graph.logged("mission_executor", "'z' is not a node of map 'building_fig5'"),
                     "the refusal's reason")


def test_a_cancelled_mission_stops_the_follower(graph: Graph) -> None:
    executor_node(graph)
    probe = ExecutorProbe(graph)
    handle = probe.send("g")
    graph.spin_until(lambda: probe.commands, "the follow command")
    cancelled = handle.cancel_goal_async()
    graph.spin_until(cancelled.done, "the cancel answer")
    result = handle.get_result_async()
    graph.spin_until(result.done, "the result")
    assert not result.result().result.success and probe.commands[-1] == ("stop", 0.0)


def test_a_wall_follower_that_says_it_is_idle_during_a_mission_is_commanded_again(graph: Graph) -> None:
    executor_node(graph)
    probe = ExecutorProbe(graph)
    state_pub = graph.probe.create_publisher(WallFollowerEvent, "/wall_follower/state", COMMAND_QOS)
    probe.send("g")
    graph.spin_until(lambda: probe.commands == [("follow", 0.0)], "the follow command")
    probe.read("23")
    graph.spin_until(lambda: probe.commands[-1] == ("right", 0.0), "the turn for h")
    state_pub.publish(follower_report(state="following"))      # heard: nothing to do
    state_pub.publish(follower_report(state="idle"))           # restarted, or the command was lost
    graph.spin_until(lambda: probe.commands[2:] == [("follow", 0.0), ("right", 0.0)], "the commands again")
    probe.read("19")
    graph.spin_until(lambda: probe.commands[-1][0] == "stop", "the stop")
    count = len(probe.commands)
    state_pub.publish(follower_report(state="idle"))           # idle after the stop: the mission is ending
    for _ in range(10):
        graph.executor.spin_once(timeout_sec=0.05)
    assert len(probe.commands) == count
