"""The mission client (rfidnav_bringup.mission_client) alone, against a tiny route server on a private context (the
single-goal server every mission node uses): a goal is sent and accepted, its feedback shown, its result read; a
rejected goal is named; a cancelled goal ends with the server's result; a respawned server gets the goal again."""

from __future__ import annotations

import pytest
from rclpy.node import Node

from rfidnav_bringup.errors import ReadinessError
from rfidnav_bringup.graph_watch import Waiter
from rfidnav_bringup.mission_client import MissionClient, feedback_text
from rfidnav_common.errors import ConfigError
from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer
from rfidnav_msgs.action import FollowTagRoute
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

ACTION = "/test_route"


class RouteServer(Node):
    """Follows a route until the test concludes it; refuses every goal with ``refusal``."""

    def __init__(self, graph: Graph, refusal: str | None = None) -> None:
        super().__init__("route_server", context=graph.context)
        self.routes: list[list[str]] = []
        self.goals: SingleGoalServer[ActiveGoal] = SingleGoalServer(
            self, FollowTagRoute, ACTION, what="route", busy="another route is being followed",
            check=lambda _goal: refusal, new_goal=ActiveGoal,
            started=lambda goal: self.routes.append(list(goal.handle.request.tag_ids)), result=self.result)

    def result(self, goal: ActiveGoal, success: bool, message: str) -> FollowTagRoute.Result:
        return FollowTagRoute.Result(success=success, message=message, tags_reached=len(goal.handle.request.tag_ids))

    def destroy_node(self) -> None:
        self.goals.destroy()
        super().destroy_node()


class Progress:
    """The progress line: what it was shown, and whether each was a milestone."""

    def __init__(self) -> None:
        self.shown: list[tuple[str, bool]] = []

    def show(self, text: str, milestone: bool = False) -> None:
        self.shown.append((text, milestone))


def client(graph: Graph, stopping: bool = False) -> tuple[MissionClient, Progress]:
    progress = Progress()
    waiter = Waiter(graph.executor, lambda: None, lambda: stopping, lambda: "")
    mission = MissionClient(graph.probe, FollowTagRoute, ACTION, waiter, progress, "hallway",
                            lambda: "\n  route_server: no map")
    graph.clients.append(mission.client)
    return mission, progress


def ready(graph: Graph, refusal: str | None = None) -> tuple[RouteServer, MissionClient, Progress]:
    server = graph.add(RouteServer(graph, refusal))
    mission, progress = client(graph)
    mission.wait_for_server(f"action server {ACTION}")
    return server, mission, progress


def test_a_goal_is_accepted_its_feedback_shown_and_its_result_read(graph: Graph) -> None:
    server, mission, progress = ready(graph)
    assert mission.send(mission.goal({"tag_ids": ["H1", "H2"]}, "hallway.yaml: mission.goal"))
    assert server.routes == [["H1", "H2"]] and not mission.done
    for index, tag in ((0, "H1"), (0, "H1"), (1, "H2")):
        server.goals.publish_feedback(FollowTagRoute.Feedback(target_index=index, target_tag_id=tag,
                                                              mode="seeking"), always=True)
    graph.spin_until(lambda: len(progress.shown) == 3, "the three feedback messages")
    assert [milestone for _, milestone in progress.shown] == [True, False, True]   # a new target is a milestone
    assert progress.shown[-1][0].startswith("[hallway] target_index=1 target_tag_id=H2 ")
    assert mission.feedback.target_tag_id == "H2"
    server.goals.conclude(GoalOutcome.SUCCEEDED, "reached H2")
    graph.spin_until(lambda: mission.done, "the goal's result")
    result = mission.result()
    assert result.success and result.message == "reached H2" and result.tags_reached == 2


def test_a_rejected_goal_fails_naming_the_action_and_the_server_s_last_lines(graph: Graph) -> None:
    _, mission, _ = ready(graph, refusal="the route is empty")
    with pytest.raises(ReadinessError) as error:
        mission.send(mission.goal({"tag_ids": []}, "mission.goal"))
    assert str(error.value) == f"goal rejected by {ACTION}\n  route_server: no map"


def test_a_goal_of_a_field_the_action_does_not_have_is_refused_naming_where_it_was_given(graph: Graph) -> None:
    mission, _ = client(graph)
    with pytest.raises(ConfigError, match="hallway.yaml: mission.goal"):
        mission.goal({"tag_idz": ["H1"]}, "hallway.yaml: mission.goal")


def test_a_cancelled_goal_ends_with_the_server_s_result(graph: Graph) -> None:
    server, mission, _ = ready(graph)
    assert mission.send(mission.goal({"tag_ids": ["H1"]}, "mission.goal"))
    mission.cancel()
    assert mission.done
    result = mission.result()
    assert not result.success and result.message == "cancelled by the client"
    assert server.goals.active is None



def test_a_cancel_not_waited_for_still_reaches_the_server(graph: Graph) -> None:
    server, mission, _ = ready(graph)
    assert mission.send(mission.goal({"tag_ids": ["H1"]}, "mission.goal"))
    mission.cancel(wait=False)
    assert not mission.done      # it returned before the answer
    graph.spin_until(lambda: server.goals.active is None, "the server ending the cancelled goal")
    graph.spin_until(lambda: mission.done, "the goal's result")
    assert mission.result().message == "cancelled by the client"

def test_the_goal_is_sent_again_to_a_respawned_server(graph: Graph) -> None:
    first, mission, _ = ready(graph)
    goal = mission.goal({"tag_ids": ["H1", "H2"]}, "mission.goal")
    assert mission.send(goal)
    graph.nodes.remove(first)   # its process died: the goal with it
    graph.executor.remove_node(first)
    first.destroy_node()
    respawned = graph.add(RouteServer(graph))
    assert mission.resend(goal, "heading_controller")
    assert respawned.routes == [["H1", "H2"]]
    respawned.goals.conclude(GoalOutcome.SUCCEEDED, "reached H2")
    graph.spin_until(lambda: mission.done, "the respawned server's result")
    assert mission.result().message == "reached H2"


def test_a_goal_sent_as_the_run_stops_is_not_followed(graph: Graph) -> None:
    graph.add(RouteServer(graph))
    mission, _ = client(graph, stopping=True)
    assert not mission.send(FollowTagRoute.Goal(tag_ids=["H1"]))
    assert not mission.done and mission.result() is None


def test_feedback_reads_as_one_line_of_fields_with_floats_to_three_decimals() -> None:
    feedback = FollowTagRoute.Feedback(target_index=2, target_tag_id="H3", phase_difference_rad=0.12345,
                                       heading_change_rad=-1.5, mode="arriving")
    assert feedback_text(feedback) == ("target_index=2 target_tag_id=H3 phase_difference_rad=+0.123 "
                                       "heading_change_rad=-1.500 mode=arriving")
