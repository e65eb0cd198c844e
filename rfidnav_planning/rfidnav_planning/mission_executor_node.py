"""mission_executor: action server /navigate_to_node (paper 004), deciding turns on the topological map from the wall
tags read on /rfid/reads and the wall follower's events, and commanding the follower on /wall_follower/command.

A thin adapter around rfidnav_planning.mission_executor.MissionExecutor, glued to the follower exactly as the
in-process runner glues the two cores: each inventory round's tag ids go to ``on_reads``, each follower event to
``on_junction`` (the odometry pose each event and state carries to ``on_odometry``, for the distance driven, which may
find a dead-end goal whose tag was missed), each decision's ``follower_command`` to the follower; the goal ends with
the follower's ``stopped`` (the executor's stop, driven on to the node) or at once when the executor gives up. What the
executor learns of ``?`` hallways is kept for later goals, and each feedback lists it (``learned_hallways``: a report
measures the shortest path on that map). A goal is refused for a node not in the map, while another goal runs, or while
no wall follower listens on /wall_follower/command. A follower that says it is idle (/wall_follower/state) while a
mission runs did not hear its command (it restarted, or its subscription matched after the command went out): it is
told again to follow, with the turn waiting for the next junction. One goal at a time and cancel:
rfidnav_common.goal_server. A round not in base_link and reads no reader reports (rfidnav_common.inputs: an empty tag
id, port 0, numbers beyond physics) are dropped and counted with a throttled warning, as are follower events and states
not in odom or with a pose beyond any map: a wall tag is taken only from a read that could be a reader's."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rfidnav_common import inputs
from rfidnav_common.frames import ODOM_FRAME
from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, declare_parameters, input_drops, run_node
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.topological_map import load_topological_map
from rfidnav_msgs.action import NavigateToNode
from rfidnav_msgs.msg import TagReadArray, WallFollowerCommand, WallFollowerEvent
from rfidnav_planning.mission_executor import EVENTS, FOLLOW, STOP, Decision, MissionExecutor
from rfidnav_planning.parameters import MissionExecutorParameters

STOPPED = "stopped"                       # the wall follower's event when a stop is done
IDLE = "idle"                             # the wall follower's state with no drive to follow


@dataclass
class MissionGoal(ActiveGoal):
    next_action: str = FOLLOW


class MissionExecutorNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("mission_executor", **node_options)
        self.params: MissionExecutorParameters = declare_parameters(self, MissionExecutorParameters)
        self.map = load_topological_map(self.params.map_file)
        self.executor_core = MissionExecutor(self.map, self.params.weight, self.params.recover_missed_tags)
        self.drops = input_drops(self)
        self.command_pub = self.create_publisher(WallFollowerCommand, "wall_follower/command", COMMAND_QOS)
        self.create_subscription(TagReadArray, "rfid/reads", self.on_reads, SENSOR_QOS)
        self.create_subscription(WallFollowerEvent, "wall_follower/event", self.on_event, COMMAND_QOS)
        self.create_subscription(WallFollowerEvent, "wall_follower/state", self.on_follower_state, COMMAND_QOS)
        # No stop on every end: a mission that succeeds ends with the follower already stopped.
        self.goals: SingleGoalServer[MissionGoal] = SingleGoalServer(
            self, NavigateToNode, "navigate_to_node", what="mission", busy="another goal is being navigated to",
            check=self.refusal, new_goal=MissionGoal, started=self.on_started, result=self.result,
            abandon=lambda _message: self.command(STOP, 0.0))
        self.get_logger().info(f"map '{self.map.name}': {len(self.map.nodes)} nodes; routes by {self.params.weight}")

    def destroy_node(self) -> None:
        self.goals.destroy()
        super().destroy_node()

    # ------------------------------------------------------------------------------------ goals
    def refusal(self, goal: NavigateToNode.Goal) -> str | None:
        if goal.goal_node not in self.map.nodes:
            return f"'{goal.goal_node}' is not a node of map '{self.map.name}'"
        if self.command_pub.get_subscription_count() == 0:
            return "no wall follower listens on /wall_follower/command"
        return None

    def on_started(self, goal: MissionGoal) -> None:
        decision = self.executor_core.start(goal.handle.request.goal_node)
        self.get_logger().info(decision.message)
        self.command(WallFollowerCommand.FOLLOW)

    def result(self, _goal: MissionGoal, success: bool, message: str) -> NavigateToNode.Result:
        mission = self.executor_core.state
        return NavigateToNode.Result(success=success, message=message, nodes_visited=list(mission.nodes_visited),
                                     tags_missed=mission.tags_missed, replans=mission.replans)

    # ---------------------------------------------------------------------------------- sensing
    def on_reads(self, msg: TagReadArray) -> None:
        reads = inputs.round_reads(msg, self.drops)
        if self.goals.running is None or not reads:
            return
        tag_ids = [read.tag_id for read in reads]
        for decision in self.executor_core.on_reads(tag_ids):
            self.apply(decision)

    def follower_report(self, topic: str, msg: WallFollowerEvent) -> bool:
        """Whether the follower's event or state is usable: in odom, its pose within any map (then fed to the
        executor for the distance driven); else dropped and counted."""
        try:
            inputs.frame(msg.header.frame_id, ODOM_FRAME)
            x, y = inputs.point(msg.odom_pose.x, msg.odom_pose.y, "odom_pose")
        except inputs.BadInput as error:
            self.drops.drop(topic, error)
            return False
        # An idle follower may have no pose yet: it is left out. The distance may find a dead-end goal.
        if msg.state != IDLE:
            decision = self.executor_core.on_odometry(x, y)
            if decision is not None and self.goals.running is not None:
                self.apply(decision)
        return True

    def on_event(self, msg: WallFollowerEvent) -> None:
        if not self.follower_report("wall_follower/event", msg) or self.goals.running is None:
            return
        if msg.event == STOPPED:
            outcome = self.executor_core.state.outcome
            if outcome is not None:
                self.goals.conclude(GoalOutcome.of(outcome.success), outcome.message)
            else:
                self.goals.conclude(GoalOutcome.ABORTED, "the wall follower stopped")
            return
        if msg.event not in EVENTS:
            self.get_logger().warning(f"/wall_follower/event: unknown event '{msg.event}' ignored")
            return
        self.apply(self.executor_core.on_junction(msg.event))

    def apply(self, decision: Decision) -> None:
        active = self.goals.active
        if decision.message:
            self.get_logger().info(decision.message)
        active.next_action = decision.action
        command = self.executor_core.follower_command(decision)
        if command is not None:
            self.command(command.action, command.within_m)
        self.publish_feedback()
        if decision.finished and not decision.success:
            self.command(STOP, 0.0)
            self.goals.conclude(GoalOutcome.ABORTED, decision.message)

    # ------------------------------------------------------------------------------------ output
    def command(self, action: str, within_m: float = 0.0) -> None:
        self.command_pub.publish(WallFollowerCommand(action=action, stop_within_m=float(within_m)))

    def publish_feedback(self) -> None:
        mission = self.executor_core.state
        goal = self.goals.active
        self.goals.publish_feedback(NavigateToNode.Feedback(
            current_node=mission.current_node or "", arrival_direction=mission.arrival_side or "",
            last_tag=mission.last_tag or "", next_action=goal.next_action,
            tags_missed=mission.tags_missed, replans=mission.replans,
            learned_hallways=[edge.text() for edge in mission.learned_edges]), always=True)   # one per decision

    def on_follower_state(self, msg: WallFollowerEvent) -> None:
        if not self.follower_report("wall_follower/state", msg) or self.goals.running is None or msg.state != IDLE:
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


def main(args: list[str] | None = None) -> int:
    return run_node(MissionExecutorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
