"""The mission's action client, our counterpart of nav2_simple_commander's BasicNavigator: send the scenario's goal
and have it accepted, pass its feedback on, cancel it, read its result, and send it again to a server whose process
was respawned (the goal died with the old one).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from action_msgs.msg import GoalStatus
from rclpy.action import ActionClient
from rclpy.node import Node

from rfidnav_bringup.errors import NodeExitedError, ReadinessError
from rfidnav_bringup.graph_watch import READY_TIMEOUT_S, RESEND_ATTEMPTS, RESEND_TIMEOUT_S, Waiter
from rfidnav_common.progress import StatusLine
from rfidnav_common.ros import fill_message

CANCEL_TIMEOUT_S = 5.0   # how long a cancelled goal's answer and result are waited for
CONCLUDED = (GoalStatus.STATUS_SUCCEEDED, GoalStatus.STATUS_ABORTED, GoalStatus.STATUS_CANCELED)


class MissionClient:
    def __init__(self, node: Node, action_type: Any, action_name: str, waiter: Waiter, progress: StatusLine,
                 label: str, rejection_detail: Callable[[], str]) -> None:
        """Feedback is shown on ``progress``, after ``label``; ``rejection_detail`` says why a goal may have been
        rejected (the server's last log lines, after a newline), for the error."""
        self.action_type, self.action_name = action_type, action_name
        self.waiter, self.progress, self.label = waiter, progress, label
        self.rejection_detail = rejection_detail
        self.client = ActionClient(node, action_type, action_name)
        self.handle: Any = None          # the accepted goal's handle
        self.result_future: Any = None   # its result, once it comes
        self.result_asked = 0.0          # when (monotonic) the result was last asked for
        self.server_lost = False         # the server's match was dropped since then
        self.feedback: Any = None        # the last feedback
        self.target_index: Any = None    # the last feedback's target, if it has one: a new one is a milestone

    def goal(self, values: dict[str, Any], where: str) -> Any:
        """The action's Goal message with the fields ``values`` (checked: ``where`` names them in an error)."""
        goal = self.action_type.Goal()
        fill_message(goal, values, where)
        return goal

    def wait_for_server(self, what: str) -> None:
        self.waiter.spin_until(self.client.server_is_ready, READY_TIMEOUT_S, what)

    def send(self, goal: Any, timeout_s: float = READY_TIMEOUT_S) -> bool:
        """Send ``goal``: True once accepted, False when the run stops first; a ReadinessError when it is rejected
        or unanswered."""
        send = self.client.send_goal_async(goal, feedback_callback=self.received_feedback)
        self.waiter.spin_until(send.done, timeout_s, "the goal to be accepted")
        if self.waiter.stopping():
            return False
        handle = send.result()
        if not handle.accepted:
            raise ReadinessError(f"goal rejected by {self.action_name}{self.rejection_detail()}")
        self.handle, self.result_future = handle, handle.get_result_async()
        self.result_asked = time.monotonic()
        return True

    def resend(self, goal: Any, server: str) -> bool:
        """Send the goal to a respawned ``server``. Until discovery drops the dead server (its DDS lease), the
        client may count it as available and a request can go unanswered: retry a few times."""
        self.wait_for_server(f"the restarted {server}'s action server")
        for attempt in range(RESEND_ATTEMPTS):
            try:
                return self.send(goal, timeout_s=RESEND_TIMEOUT_S)
            except NodeExitedError:
                raise
            except ReadinessError:
                if attempt == RESEND_ATTEMPTS - 1:
                    raise
        return False

    def received_feedback(self, message: Any) -> None:
        """Show the feedback on the progress line; one with a new target stays above it."""
        feedback = self.feedback = message.feedback
        target = getattr(feedback, "target_index", None)
        milestone, self.target_index = target != self.target_index, target
        self.progress.show(f"[{self.label}] {feedback_text(feedback)}", milestone)

    def ask_result_again(self) -> None:
        """Ask for the goal's result again once the server is back after DDS dropped it (a server paused past its
        lease: the question, or its answer, was lost with the match), and every RESEND_TIMEOUT_S while the goal's
        status says it has ended without the answer: without this the run waited for its timeout although the
        mission had succeeded. The server keeps a goal's result and answers every question, at once or when the
        goal ends."""
        if self.handle is None or self.done:
            return
        if not self.client.server_is_ready():
            self.server_lost = True
            return
        late = time.monotonic() - self.result_asked > RESEND_TIMEOUT_S
        if self.server_lost or (late and self.handle.status in CONCLUDED):
            self.server_lost = False
            self.result_future, self.result_asked = self.handle.get_result_async(), time.monotonic()

    @property
    def done(self) -> bool:
        """The goal has its result (an answer of unknown status is none: a server that does not know the goal, a
        respawned one asked again before the goal is sent to it again)."""
        if self.result_future is None or not self.result_future.done():
            return False
        answer = self.result_future.result()
        return answer is not None and answer.status != GoalStatus.STATUS_UNKNOWN

    def cancel(self, wait: bool = True) -> None:
        """Cancel the goal and, with ``wait``, wait CANCEL_TIMEOUT_S at most for the answer and the goal's result:
        a run that timed out or stalled records how its goal ended. A run stopped by a signal does not wait: its
        nodes are stopped next, which ends the goal too, and its user waits for the prompt (a round trip through
        the server took seconds of a Ctrl-C beside busy processes)."""
        cancel = self.handle.cancel_goal_async()
        if not wait:
            return
        deadline = time.monotonic() + CANCEL_TIMEOUT_S
        while not (cancel.done() and self.result_future.done()) and time.monotonic() < deadline:
            self.waiter.executor.spin_once(timeout_sec=0.05)

    def result(self) -> Any:
        """The goal's result message, None if it has none (yet)."""
        return self.result_future.result().result if self.done else None


def feedback_text(feedback: Any) -> str:
    """A feedback message on one line: each field as name=value, floats to three decimals."""
    fields = feedback.get_fields_and_field_types()
    return " ".join(f"{name}={format_value(getattr(feedback, name))}" for name in fields)


def format_value(value: Any) -> str:
    return f"{value:+.3f}" if isinstance(value, float) else str(value)
