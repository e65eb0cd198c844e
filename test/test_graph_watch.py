"""The graph watch (rfidnav_bringup.graph_watch) alone, on a private context with stand-ins for the run's nodes: its
waits end once the graph holds what they wait for and fail naming it, the recorder is awaited on each topic it will
record, the clock source's ~/wired and ~/start are asked until they answer, graph.json says who publishes what, a stall
is said once and ends the mission after a minute, and a second node of one of our names ends the run."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import rclpy
import rclpy.client
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.task import Future
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger

import rfidnav_bringup.graph_watch
from rfidnav_bringup.errors import NodeExitedError, ReadinessError
from rfidnav_bringup.graph_watch import GraphWatch, StallWatch, Waiter
from rfidnav_bringup.run_plan import ExpectedGraph
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

EXPECTED = ExpectedGraph(nodes=frozenset({"talker"}), simulators=("talker",), clock_source="clock_source",
                         simulated=True, record_exclude=("/rosout", "/parameter_events"))


class Watched:
    """A graph watch as the orchestrator's node has it, with what it said."""

    def __init__(self, graph: Graph, expected: ExpectedGraph = EXPECTED, check: Callable[[], None] = lambda: None,
                 stopping: Callable[[], bool] = lambda: False) -> None:
        node = graph.add(Node("rfidnav_orchestrator", context=graph.context,
                              parameter_overrides=[rclpy.parameter.Parameter("use_sim_time", value=True)]))
        self.said: list[str] = []
        waiter = Waiter(graph.executor, check, stopping, lambda: "  talker (running):\n    last words")
        self.watch = GraphWatch(node, waiter, expected, 7, self.said.append)


class ClockSource(Node):
    """The clock source's services: ~/wired answers ``wired_after`` times 'not yet', ~/start publishes /clock (but
    for the first ``lost_starts`` requests, as if they were lost)."""

    def __init__(self, graph: Graph, wired_after: int = 0, lost_starts: int = 0) -> None:
        super().__init__("clock_source", context=graph.context)
        self.wired_asked = self.start_asked = 0
        self.wired_after, self.lost_starts = wired_after, lost_starts
        self.clock = self.create_publisher(Clock, "/clock", 10)
        self.create_service(Trigger, "~/wired", self.on_wired)
        self.create_service(Trigger, "~/start", self.on_start)

    def on_wired(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.wired_asked += 1
        response.success = self.wired_asked > self.wired_after
        response.message = "" if response.success else "/talker's /odom has no subscription of /listener"
        return response

    def on_start(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        self.start_asked += 1
        if self.start_asked > self.lost_starts:
            message = Clock()
            message.clock.sec = 1
            self.clock.publish(message)
        response.success = True
        return response


def test_a_wait_for_nodes_ends_once_they_are_in_the_graph(graph: Graph) -> None:
    watched = Watched(graph)
    graph.add(Node("talker", context=graph.context))
    watched.watch.wait_for_nodes({"talker"}, "the talker to join the graph")
    assert "talker" in watched.watch.node.get_node_names()


def test_a_wait_that_times_out_names_what_it_waited_for_and_every_process_s_last_lines(graph: Graph) -> None:
    watched = Watched(graph)
    with pytest.raises(ReadinessError) as error:
        watched.watch.waiter.spin_until(lambda: False, 0.2, lambda: "a node that never comes")
    assert str(error.value) == "timed out after 0 s waiting for a node that never comes\n  talker (running):\n" \
                               "    last words"


def test_a_wait_ends_at_once_when_the_run_stops_and_fails_when_a_node_dies(graph: Graph) -> None:
    Watched(graph, stopping=lambda: True).watch.waiter.spin_until(lambda: False, 60.0, "nothing")

    def died() -> None:
        raise NodeExitedError("node talker exited with code 1")

    with pytest.raises(NodeExitedError, match="talker exited"):
        Watched(graph, check=died).watch.waiter.spin_until(lambda: False, 60.0, "nothing")


def test_the_recorder_is_awaited_on_each_topic_it_will_record_but_the_excluded(graph: Graph) -> None:
    watched = Watched(graph)
    talker = graph.add(Node("talker", context=graph.context))
    talker.create_publisher(Odometry, "/odom", 10)
    graph.spin_until(lambda: "/odom" in watched.watch.unrecorded_topics(), "the talker's topic to be seen")
    assert watched.watch.unrecorded_topics() == ["/odom"]   # not /rosout nor /parameter_events: excluded
    recorder = graph.add(Node("recorder", context=graph.context))
    recorder.create_subscription(Odometry, "/odom", lambda _: None, 10)
    watched.watch.wait_for_recording()
    assert watched.watch.unrecorded_topics() == []


def test_the_wiring_is_awaited_until_the_clock_source_says_every_participant_is_wired(graph: Graph) -> None:
    source = graph.add(ClockSource(graph, wired_after=2))
    Watched(graph).watch.wait_for_wiring()
    assert source.wired_asked == 3


def test_a_wiring_question_whose_answer_is_lost_is_asked_again(graph: Graph, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(rfidnav_bringup.graph_watch, "RESEND_TIMEOUT_S", 0.5)
    call_async = rclpy.client.Client.call_async
    lost: list[Any] = []

    def first_lost(client: rclpy.client.Client, request: Any) -> Future:
        if not lost:                      # as if the request or its answer never arrived: a future never done
            lost.append(request)
            return Future()
        return call_async(client, request)
    monkeypatch.setattr(rclpy.client.Client, "call_async", first_lost)
    source = graph.add(ClockSource(graph))
    Watched(graph).watch.wait_for_wiring()
    assert len(lost) == 1 and source.wired_asked == 1


def test_wiring_that_never_completes_times_out_with_what_the_clock_source_waits_for(
        graph: Graph, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(rfidnav_bringup.graph_watch, "READY_TIMEOUT_S", 1.0)
    graph.add(ClockSource(graph, wired_after=10**6))
    with pytest.raises(ReadinessError, match="publishers and subscriptions to match: /talker's /odom has no "
                                             "subscription of /listener"):
        Watched(graph).watch.wait_for_wiring()


def test_the_clock_starts_at_the_clock_source_s_start_asked_again_when_a_request_is_lost(
        graph: Graph, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(rfidnav_bringup.graph_watch, "RESEND_TIMEOUT_S", 0.5)
    source = graph.add(ClockSource(graph, lost_starts=1))
    watched = Watched(graph)
    watched.watch.start_clock()
    assert source.start_asked == 2 and watched.watch.sim_seconds() == 1.0


def test_a_run_without_a_clock_source_starts_no_clock(graph: Graph) -> None:
    Watched(graph, replace(EXPECTED, clock_source=None, simulated=False)).watch.start_clock()


def test_graph_json_says_who_publishes_and_subscribes_what_without_the_orchestrator(graph: Graph,
                                                                                   tmp_path: Path) -> None:
    watched = Watched(graph)
    talker = graph.add(Node("talker", context=graph.context))
    talker.create_publisher(Odometry, "/odom", 10)
    listener = graph.add(Node("listener", context=graph.context))
    listener.create_subscription(Odometry, "/odom", lambda _: None, 10)
    graph.spin_until(lambda: watched.watch.node.count_subscribers("/odom") == 1, "the listener to be seen")
    watched.watch.write_graph(tmp_path / "graph.json")
    document = json.loads((tmp_path / "graph.json").read_text())
    assert document["simulator_nodes"] == ["talker"]
    assert "rfidnav_orchestrator" not in document["nodes"]
    assert "/odom" in document["nodes"]["talker"]["publishers"]
    assert "/odom" in document["nodes"]["listener"]["subscriptions"]


def test_a_second_node_of_one_of_our_names_ends_the_run_unless_its_process_was_just_respawned(graph: Graph) -> None:
    watched = Watched(graph)
    for _ in range(2):
        graph.add(Node("talker", context=graph.context))
    graph.spin_until(lambda: watched.watch.node.get_node_names().count("talker") == 2, "both talkers in the graph")
    watched.watch.check_single_graph()      # once: discovery can show a node twice for a moment
    with pytest.raises(ReadinessError, match="another graph joined ROS domain 7: two nodes named /talker; the run "
                                             "stops before the two mix"):
        watched.watch.check_single_graph()  # twice in a row: a second graph
    with pytest.raises(ReadinessError, match="two nodes named /talker"):
        watched.watch.check_single_graph_now()
    watched.watch.respawned(["/talker"])
    watched.watch.check_single_graph()
    watched.watch.check_single_graph()


def test_a_publisher_of_a_node_not_of_the_run_ends_the_run_naming_it_and_its_topic(graph: Graph) -> None:
    watched = Watched(graph)
    talker = graph.add(Node("talker", context=graph.context))
    talker.create_publisher(Odometry, "/odom", 10)
    graph.spin_until(lambda: watched.watch.node.get_publishers_info_by_topic("/odom"), "the talker's /odom")
    watched.watch.check_single_graph()                   # our own publishers, and /rosout of every node
    injector = graph.add(Node("injector", context=graph.context))
    injector.create_publisher(Odometry, "/odom", 10)
    graph.spin_until(lambda: len(watched.watch.node.get_publishers_info_by_topic("/odom")) == 2, "the injector's")
    with pytest.raises(ReadinessError, match="a publisher not of this run joined ROS domain 7: /injector on /odom; "
                                             "the run stops before its messages mix with the run's"):
        watched.watch.check_single_graph()



def test_with_a_role_of_unknown_name_no_publisher_is_foreign_but_the_unnamed_are_still_counted(
        graph: Graph, monkeypatch: pytest.MonkeyPatch) -> None:
    watched = Watched(graph, replace(EXPECTED, unnamed_roles=("driver",)))
    noted: list[dict] = []
    monkeypatch.setattr(watched.watch, "note_unnamed", lambda unnamed, _now: noted.append(dict(unnamed)))
    driver = graph.add(Node("vendor_driver", context=graph.context))    # the role's node, named by its command
    driver.create_publisher(Odometry, "/odom", 10)
    graph.spin_until(lambda: watched.watch.node.get_publishers_info_by_topic("/odom"), "the driver's /odom")
    watched.watch.check_single_graph()       # not ended: /vendor_driver may be the role's
    # The publishers without a node name (outside the run's partition) are looked for at every check all the same.
    assert noted == [{}]

def test_a_stall_is_said_once_with_the_clock_source_s_last_warning_and_ends_the_mission_after_a_minute(
        graph: Graph) -> None:
    watched = Watched(graph)
    source = graph.add(Node("clock_source", context=graph.context))
    source.get_logger().warning("step 12 waits for /talker")
    graph.spin_until(lambda: watched.watch.clock_source_says == "step 12 waits for /talker",
                     "the clock source's warning on /rosout")
    watch, stall = watched.watch, StallWatch(sim_s=3.0, since_wall_s=100.0)
    assert watch.check_stall(stall, 3.0, 104.0, {}) == "" and watched.said == []
    assert watch.check_stall(stall, 3.0, 106.0, {}) == ""
    assert watched.said == ["\nsim time has not advanced for 6 s (wall) at 3.00 s; step 12 waits for /talker"]
    assert watch.check_stall(stall, 3.0, 120.0, {}) == "" and len(watched.said) == 1
    assert watch.check_stall(stall, 3.0, 160.0, {}) == \
        "sim time has not advanced for 60 s (wall) at 3.00 s; step 12 waits for /talker"
    assert watch.check_stall(stall, 3.5, 161.0, {}) == "" and not stall.reported   # the clock moves again


def test_a_stall_of_a_split_run_with_nothing_stopped_here_names_the_other_computers_nodes_and_the_link(
        graph: Graph) -> None:
    watched = Watched(graph, replace(EXPECTED, elsewhere=("heading_controller", "recorder")))
    stall = StallWatch(sim_s=3.0, since_wall_s=100.0)
    assert watched.watch.check_stall(stall, 3.0, 106.0, {}) == ""
    assert watched.said == ["\nsim time has not advanced for 6 s (wall) at 3.00 s (nothing stopped here; "
                            "heading_controller, recorder run on the other computer: is the link to it down?)"]


def test_a_run_in_real_time_has_no_clock_to_stall(graph: Graph) -> None:
    watched = Watched(graph, replace(EXPECTED, simulated=False))
    stall = StallWatch(sim_s=0.0, since_wall_s=100.0)
    assert watched.watch.check_stall(stall, 0.0, 200.0, {}) == "" and watched.said == []
    assert stall.since_wall_s == 200.0
