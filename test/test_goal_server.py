"""The single-goal action server helper (rfidnav_common.goal_server), on a minimal node of its own: one goal at a
time, the node's refusals, its conclusion, cancel and the watchdog, seen from an action client."""

from __future__ import annotations

import pytest
from action_msgs.msg import GoalStatus
from rclpy.action import ActionClient
from rclpy.node import Node

from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer, Watchdog
from rfidnav_msgs.action import FollowTagRoute
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

WATCHDOG_S = 0.5


class MinimalServer(Node):
    """Follows a route goal until the test concludes it; records what the helper asked of it."""

    def __init__(self, graph: Graph, watchdog: Watchdog | None) -> None:
        super().__init__("minimal_server", context=graph.context)
        self.started: list[ActiveGoal] = []
        self.stops = 0
        self.abandoned: list[str] = []
        self.goals: SingleGoalServer[ActiveGoal] = SingleGoalServer(
            self, FollowTagRoute, "/minimal_route", what="route", busy="another route is being followed",
            check=lambda goal: None if goal.tag_ids else "the route is empty", new_goal=ActiveGoal,
            started=self.started.append, result=self.result, stop=self.stop, abandon=self.abandoned.append,
            watchdog=watchdog)

    def stop(self) -> None:
        self.stops += 1

    def result(self, goal: ActiveGoal, success: bool, message: str) -> FollowTagRoute.Result:
        return FollowTagRoute.Result(success=success, message=message, tags_reached=len(goal.handle.request.tag_ids))

    def destroy_node(self) -> None:
        self.goals.destroy()
        super().destroy_node()


class Client:
    def __init__(self, graph: Graph, watchdog: Watchdog | None = None) -> None:
        self.graph = graph
        self.server: MinimalServer = graph.add(MinimalServer(graph, watchdog))
        self.client = ActionClient(graph.probe, FollowTagRoute, "/minimal_route")
        graph.clients.append(self.client)
        graph.spin_until(self.client.server_is_ready, "the minimal action server")

    def send(self, tag_ids: list[str]):
        future = self.client.send_goal_async(FollowTagRoute.Goal(tag_ids=tag_ids))
        self.graph.spin_until(future.done, f"an answer to the goal {tag_ids}")
        return future.result()

    def start(self, tag_ids: list[str]):
        handle = self.send(tag_ids)
        assert handle.accepted, f"goal {tag_ids} rejected"
        self.graph.spin_until(lambda: self.server.goals.running is not None, "the goal to be followed")
        return handle

    def result_of(self, handle):
        future = handle.get_result_async()
        self.graph.spin_until(future.done, "the goal's result")
        return future.result()


def test_a_second_goal_is_rejected_while_one_runs(graph: Graph) -> None:
    client = Client(graph)
    first = client.start(["C1"])
    second = client.send(["C2"])
    assert not second.accepted
    graph.spin_until(lambda: graph.logged("minimal_server", "goal rejected", "another route is being followed"),
                     "the rejection's reason on /rosout")
    assert client.server.goals.running.handle.goal_id == first.goal_id
    assert len(client.server.started) == 1


def test_a_goal_the_node_refuses_is_rejected_with_the_nodes_reason(graph: Graph) -> None:
    client = Client(graph)
    assert not client.send([]).accepted
    graph.spin_until(lambda: graph.logged("minimal_server", "goal rejected", "the route is empty"),
                     "the node's reason on /rosout")
    assert client.server.goals.active is None and not client.server.started


@pytest.mark.parametrize("outcome, status", [(GoalOutcome.SUCCEEDED, GoalStatus.STATUS_SUCCEEDED),
                                             (GoalOutcome.ABORTED, GoalStatus.STATUS_ABORTED)])
def test_a_concluded_goal_ends_with_its_outcome_and_the_nodes_result_and_frees_the_server(
        graph: Graph, outcome: GoalOutcome, status: int) -> None:
    client = Client(graph)
    handle = client.start(["C1", "C2"])
    client.server.goals.conclude(outcome, "as the node decided")
    assert client.server.goals.running is None, "a concluded goal's inputs must be ignored"
    answer = client.result_of(handle)
    assert answer.status == status
    assert answer.result.success == (outcome is GoalOutcome.SUCCEEDED)
    assert answer.result.message == "as the node decided" and answer.result.tags_reached == 2
    assert client.server.stops == 1 and not client.server.abandoned
    graph.spin_until(lambda: graph.logged("minimal_server", f"route {outcome.value}: as the node decided"),
                     "the outcome on /rosout")
    assert client.server.goals.active is None
    client.start(["C3"])


def test_cancelling_a_goal_ends_it_as_canceled_and_tells_the_node(graph: Graph) -> None:
    client = Client(graph)
    handle = client.start(["C1"])
    cancel = handle.cancel_goal_async()
    graph.spin_until(cancel.done, "the answer to the cancel request")
    answer = client.result_of(handle)
    assert answer.status == GoalStatus.STATUS_CANCELED
    assert not answer.result.success and answer.result.message == "cancelled by the client"
    assert client.server.abandoned == ["cancelled by the client"] and client.server.stops == 1


def test_a_goal_whose_input_falls_silent_is_aborted_by_the_watchdog(graph: Graph) -> None:
    client = Client(graph, Watchdog(WATCHDOG_S, "test input"))
    handle = client.start(["C1"])
    answer = client.result_of(handle)
    assert answer.status == GoalStatus.STATUS_ABORTED
    assert answer.result.message.startswith("no test input for "), answer.result.message
    silent_s = float(answer.result.message.split()[-2])
    assert silent_s >= WATCHDOG_S   # to the message's 0.1 s
    assert client.server.abandoned == [answer.result.message] and client.server.stops == 1
