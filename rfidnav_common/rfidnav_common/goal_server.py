"""The single-goal action server of the rfidnav action servers (heading_controller, partition_navigator,
two_tier_navigator, mission_executor): one goal at a time, cancel, a watchdog, and the way a goal ends.

One goal at a time: a goal sent while another runs is rejected (the robot cannot follow two), as is one the
node's own check refuses; each rejection is logged with its reason.

A goal is followed from the moment it is accepted, by the node's own callbacks (sensor messages, timers); its
execute callback runs only once the outcome is known (:meth:`SingleGoalServer.conclude`), so that no coroutine
waits in the executor. That keeps the nodes on rclpy's EventsExecutor (see
:func:`rfidnav_common.ros.events_executor`: in rclpy 7.1 a task awaiting a Future busy-loops a core there), at
the price of the goal status reading ACCEPTED rather than EXECUTING while the goal is followed. So a goal ends in
three steps: ``conclude`` records the outcome and stops the robot, ``handle.execute()`` schedules the execute
callback, and that callback sets the goal's final state and returns the node's result. Between the first and the
last the goal is still the active one (a new goal is rejected) but no longer running (its inputs are ignored).

A cancel request and a silent input are noticed by :meth:`SingleGoalServer.supervise` (on its own timer, or
called by the node's control loop), as no message may arrive to notice them.

Feedback (:meth:`SingleGoalServer.publish_feedback`) is throttled to what a person reads: it goes out at once
when anything but a floating-point field changes (a new target, phase or node: what the reports and metrics
read from the bag), otherwise at most every ``FEEDBACK_PERIOD_S`` of the node's time. Each message costs every
subscriber (the recorder, the client) a wake-up, and a controller steps at 25 Hz.
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node


class GoalOutcome(enum.Enum):
    SUCCEEDED = "succeeded"
    ABORTED = "aborted"
    CANCELED = "canceled"

    @classmethod
    def of(cls, success: bool) -> GoalOutcome:
        """The outcome of a goal the node's core finished, successfully or not."""
        return cls.SUCCEEDED if success else cls.ABORTED


@dataclass
class ActiveGoal:
    """One accepted goal; a node subclasses it with what it tracks per goal."""

    handle: ServerGoalHandle
    # When the node last heard the input that drives the goal (set on acceptance): what the watchdog checks.
    last_heard_s: float = field(default=0.0, kw_only=True)


GoalT = TypeVar("GoalT", bound=ActiveGoal)
FEEDBACK_PERIOD_S = 0.5
FLOATING_TYPES = ("double", "float")


def discrete_fields(message: Any) -> tuple[Any, ...]:
    """The values of a message's fields that are not floating point, nested messages' included (a change of
    any of them is an event, not noise)."""
    values: list[Any] = []
    for name, kind in message.get_fields_and_field_types().items():
        value = getattr(message, name)
        if hasattr(value, "get_fields_and_field_types"):
            values.append(discrete_fields(value))
        elif kind not in FLOATING_TYPES:
            values.append(value if not isinstance(value, list) else tuple(value))
    return tuple(values)


@dataclass(frozen=True)
class Watchdog:
    """Abort a running goal when its input has not been heard (:meth:`SingleGoalServer.heard`) for ``timeout_s``."""

    timeout_s: float
    input_name: str                          # for the message: "no {input_name} for 5.2 s"


class SingleGoalServer(Generic[GoalT]):
    """An action server that follows one goal at a time for ``node``.

    The node supplies what is its own: ``check`` (why a goal request is refused, or None), ``new_goal`` (its
    per-goal state), ``started`` (start following it), ``result`` (the action result, given the goal, its
    success and message), and optionally ``stop`` (stop the robot, on every end) and ``abandon`` (tell the
    node's core that the goal ends by cancel or watchdog, not by its own decision). ``what`` names a goal in
    the log ("route succeeded: ..."). With ``supervise_period_s`` None the node calls :meth:`supervise`
    itself, from its control loop."""

    def __init__(self, node: Node, action_type: Any, action_name: str, *, what: str, busy: str,
                 check: Callable[[Any], str | None], new_goal: Callable[[ServerGoalHandle], GoalT],
                 started: Callable[[GoalT], None], result: Callable[[GoalT, bool, str], Any],
                 stop: Callable[[], None] | None = None, abandon: Callable[[str], object] | None = None,
                 watchdog: Watchdog | None = None, supervise_period_s: float | None = 0.1) -> None:
        self.node = node
        self.what, self.busy = what, busy
        self.check, self.new_goal, self.started, self.result = check, new_goal, started, result
        self.stop, self.abandon, self.watchdog = stop, abandon, watchdog
        self.active: GoalT | None = None            # accepted, until its execute callback has run
        self.feedback_sent: tuple[float, tuple[Any, ...]] | None = None   # when, and its discrete fields
        self.outcome: tuple[GoalOutcome, str] | None = None   # once concluded
        self.action_server = ActionServer(
            node, action_type, action_name, execute_callback=self.finish, goal_callback=self.on_goal,
            handle_accepted_callback=self.on_accepted, cancel_callback=lambda _: CancelResponse.ACCEPT)
        if supervise_period_s is not None:
            node.create_timer(supervise_period_s, self.supervise)

    def destroy(self) -> None:
        """Call from the node's destroy_node: rclpy's leaves waitables alive, so without this the action server
        (and its latched goal status) outlives the node in a process that goes on, e.g. a test."""
        self.action_server.destroy()

    @property
    def running(self) -> GoalT | None:
        """The goal being followed: accepted and not concluded (a concluded goal's inputs are ignored)."""
        return self.active if self.outcome is None else None

    def heard(self) -> None:
        """The running goal's input arrived: the watchdog starts counting again."""
        if self.active is not None:
            self.active.last_heard_s = self.now_s()

    def publish_feedback(self, feedback: Any, always: bool = False) -> None:
        """Publish the active goal's feedback if it says something new or FEEDBACK_PERIOD_S went by, or ``always``
        (a node whose feedback marks its own rare decisions, as the mission executor's junctions)."""
        now_s, discrete = self.now_s(), discrete_fields(feedback)
        if self.feedback_sent is not None and not always:
            sent_s, sent_discrete = self.feedback_sent
            if discrete == sent_discrete and now_s - sent_s < FEEDBACK_PERIOD_S:
                return
        self.feedback_sent = (now_s, discrete)
        self.active.handle.publish_feedback(feedback)

    def conclude(self, outcome: GoalOutcome, message: str) -> None:
        """End the running goal with ``outcome``: stop the robot and let the action server run the execute
        callback, which reports it."""
        self.outcome = (outcome, message)
        if self.stop is not None:
            self.stop()
        self.active.handle.execute()

    def supervise(self) -> GoalT | None:
        """Conclude the running goal if its client cancelled it or its input fell silent; returns the goal if it
        still runs."""
        goal = self.running
        if goal is None:
            return None
        if goal.handle.is_cancel_requested:
            self.end_unasked(GoalOutcome.CANCELED, "cancelled by the client")
            return None
        if self.watchdog is not None:
            silent_s = self.now_s() - goal.last_heard_s
            if silent_s > self.watchdog.timeout_s:
                self.end_unasked(GoalOutcome.ABORTED, f"no {self.watchdog.input_name} for {silent_s:.1f} s")
                return None
        return goal

    # ------------------------------------------------------------------------- action server callbacks
    def on_goal(self, request: Any) -> GoalResponse:
        problem = self.busy if self.active is not None else self.check(request)
        if problem is not None:
            self.node.get_logger().error(f"goal rejected: {problem}")
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def on_accepted(self, handle: ServerGoalHandle) -> None:
        # Active before ``started`` runs: starting may already conclude the goal.
        self.active, self.outcome, self.feedback_sent = self.new_goal(handle), None, None
        self.active.last_heard_s = self.now_s()
        self.started(self.active)

    def finish(self, handle: ServerGoalHandle) -> Any:
        goal, self.active = self.active, None
        outcome, message = self.outcome
        {GoalOutcome.SUCCEEDED: handle.succeed, GoalOutcome.ABORTED: handle.abort,
         GoalOutcome.CANCELED: handle.canceled}[outcome]()
        self.node.get_logger().info(f"{self.what} {outcome.value}: {message}")
        return self.result(goal, outcome is GoalOutcome.SUCCEEDED, message)

    # ----------------------------------------------------------------------------------------- helpers
    def end_unasked(self, outcome: GoalOutcome, message: str) -> None:
        if self.abandon is not None:
            self.abandon(message)
        self.conclude(outcome, message)

    def now_s(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9
