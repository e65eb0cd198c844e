"""mission_executor: action server /navigate_to_node (paper 004), deciding turns on the topological map from the wall
tags read on /rfid/reads and the wall follower's events, and commanding the follower on /wall_follower/command.

A thin adapter around rfidnav_planning.mission_executor.MissionExecutor, glued to the follower exactly as the
in-process runner glues the two cores: each inventory round's tag ids go to ``on_reads``, each follower event to
``on_junction``, each decision's ``follower_command`` to the follower; the goal ends with the follower's
``stopped`` (the executor's stop, driven on to the node) or at once when the executor gives up. What the executor
learns of ``?`` hallways is kept for later goals. A goal is refused for a node not in the map, while another goal
runs, or while no wall follower listens on /wall_follower/command. A follower that says it is idle
(/wall_follower/state) while a mission runs did not hear its command (it restarted, or its subscription matched
after the command went out): it is told again to follow, with the turn waiting for the next junction. As in the
other action servers, the goal is followed from its acceptance and its execute callback runs only once the
outcome is known.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node

from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, close_goal, declare_parameters, run_node
from rfidnav_common.topological_map import load_topological_map
from rfidnav_msgs.action import NavigateToNode
from rfidnav_msgs.msg import TagReadArray, WallFollowerCommand, WallFollowerEvent
from rfidnav_planning.mission_executor import EVENTS, FOLLOW, STOP, Decision, MissionExecutor
from rfidnav_planning.parameters import MissionExecutorParameters

STOPPED = "stopped"                       # the wall follower's event when a stop is done
IDLE = "idle"                             # the wall follower's state with no drive to follow


@dataclass
class ActiveGoal:
    handle: ServerGoalHandle
    next_action: str = FOLLOW
    outcome: tuple[str, str] | None = None   # (succeeded | aborted | canceled, message) once concluded


class MissionExecutorNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("mission_executor", **node_options)
        self.params: MissionExecutorParameters = declare_parameters(self, MissionExecutorParameters)
        self.map = load_topological_map(self.params.map_file)
        self.executor_core = MissionExecutor(self.map, self.params.weight, self.params.recover_missed_tags)
        self.active: ActiveGoal | None = None
        self.command_pub = self.create_publisher(WallFollowerCommand, "/wall_follower/command", COMMAND_QOS)
        self.create_subscription(TagReadArray, "/rfid/reads", self.on_reads, SENSOR_QOS)
        self.create_subscription(WallFollowerEvent, "/wall_follower/event", self.on_event, COMMAND_QOS)
        self.create_subscription(WallFollowerEvent, "/wall_follower/state", self.on_follower_state, COMMAND_QOS)
        self.action_server = ActionServer(
            self, NavigateToNode, "/navigate_to_node", execute_callback=self.finish,
            goal_callback=self.on_goal, handle_accepted_callback=self.on_accepted,
            cancel_callback=lambda _: CancelResponse.ACCEPT)
        self.create_timer(0.1, self.supervise)
        self.get_logger().info(f"map '{self.map.name}': {len(self.map.nodes)} nodes; routes by {self.params.weight}")

    def destroy_node(self) -> None:
        self.action_server.destroy()
        super().destroy_node()

    # ------------------------------------------------------------------------------------ goals
    def on_goal(self, goal: NavigateToNode.Goal) -> GoalResponse:
        problem = None
        if self.active is not None:
            problem = "another goal is being navigated to"
        elif goal.goal_node not in self.map.nodes:
            problem = f"'{goal.goal_node}' is not a node of map '{self.map.name}'"
        elif self.command_pub.get_subscription_count() == 0:
            problem = "no wall follower listens on /wall_follower/command"
        if problem is not None:
            self.get_logger().error(f"goal rejected: {problem}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_accepted(self, handle: ServerGoalHandle) -> None:
        self.active = ActiveGoal(handle)
        decision = self.executor_core.start(handle.request.goal_node)
        self.get_logger().info(decision.message)
        self.command(WallFollowerCommand.FOLLOW)

    def conclude(self, state: str, message: str) -> None:
        self.active.outcome = (state, message)
        self.active.handle.execute()

    def finish(self, handle: ServerGoalHandle) -> NavigateToNode.Result:
        active, self.active = self.active, None
        success, message = close_goal(self, handle, active.outcome, "mission")
        mission = self.executor_core.state
        return NavigateToNode.Result(success=success, message=message, nodes_visited=list(mission.nodes_visited),
                                     tags_missed=mission.tags_missed, replans=mission.replans)

    # ---------------------------------------------------------------------------------- sensing
    def on_reads(self, msg: TagReadArray) -> None:
        if self.active is None or self.active.outcome is not None or not msg.readings:
            return
        for decision in self.executor_core.on_reads(reading.tag_id for reading in msg.readings):
            self.apply(decision)

    def on_event(self, msg: WallFollowerEvent) -> None:
        if self.active is None or self.active.outcome is not None:
            return
        if msg.event == STOPPED:
            outcome = self.executor_core.state.outcome
            if outcome is not None and outcome.success:
                self.conclude("succeeded", outcome.message)
            else:
                self.conclude("aborted", outcome.message if outcome is not None else "the wall follower stopped")
            return
        if msg.event not in EVENTS:
            self.get_logger().warning(f"/wall_follower/event: unknown event '{msg.event}' ignored")
            return
        self.apply(self.executor_core.on_junction(msg.event))

    def apply(self, decision: Decision) -> None:
        active = self.active
        if decision.message:
            self.get_logger().info(decision.message)
        active.next_action = decision.action
        command = self.executor_core.follower_command(decision)
        if command is not None:
            self.command(command.action, command.within_m)
        self.publish_feedback()
        if decision.finished and not decision.success:
            self.command(STOP, 0.0)
            self.conclude("aborted", decision.message)

    # ------------------------------------------------------------------------------------ output
    def command(self, action: str, within_m: float = 0.0) -> None:
        self.command_pub.publish(WallFollowerCommand(action=action, stop_within_m=float(within_m)))

    def publish_feedback(self) -> None:
        mission = self.executor_core.state
        self.active.handle.publish_feedback(NavigateToNode.Feedback(
            current_node=mission.current_node or "", arrival_direction=mission.arrival_side or "",
            last_tag=mission.last_tag or "", next_action=self.active.next_action,
            tags_missed=mission.tags_missed, replans=mission.replans))

    def on_follower_state(self, msg: WallFollowerEvent) -> None:
        active = self.active
        if active is None or active.outcome is not None or msg.state != IDLE:
            return
        if self.executor_core.state.stop_commanded:
            return                  # idle after the stop: the mission ends with its "stopped" event
        # Idle while a mission runs: the follow command (and the turn waiting for the next junction) was not heard.
        self.get_logger().warning("the wall follower is idle during the mission: commanding it again",
                                  throttle_duration_sec=5.0)
        self.command(WallFollowerCommand.FOLLOW)
        awaiting = self.executor_core.state.awaiting
        if awaiting is not None:
            self.command(awaiting)

    def supervise(self) -> None:
        """A cancel request is noticed here: no read or event may arrive to notice it."""
        active = self.active
        if active is None or active.outcome is not None or not active.handle.is_cancel_requested:
            return
        self.command(STOP, 0.0)
        self.conclude("canceled", "cancelled by the client")


def main(args: list[str] | None = None) -> int:
    return run_node(MissionExecutorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
