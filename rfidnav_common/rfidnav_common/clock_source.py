"""The clock source: simulated time for a graph, as a component the node that owns the clock composes (robot_sim
today; the simulator of another base, or a player pacing a bag, could use it as it is).

It counts the steps, paces them on a steady wall timer at the real-time factor, and publishes nothing itself: each
step it moves its node's sim time (stepped) and calls the owner's ``on_step``, which moves the world and publishes.
Two clocks:

- free-running: ``rtf`` sim seconds per wall second whether or not the graph keeps up (after a stall it catches up
  at most :data:`CATCH_UP_STEPS` steps a tick, then drops the backlog);
- stepped: a step is taken only once every participant has handled everything published so far
  (rfidnav_common.step_ledger); ``rtf`` is then a ceiling, and ``math.inf`` none (as fast as they answer).

With ``start_paused`` time stays at zero until ``~/start`` (std_srvs/Trigger) is called; with the stepped clock
``~/wired`` says whether every participant's publishers and subscriptions have matched, ``~/settle`` stops the
clock and says whether every participant has caught up (after the mission), and a step that waits longer than
:data:`STALL_REPORT_S` (wall) is logged with who it waits for.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

from rclpy.clock import Clock, ClockType
from std_srvs.srv import Trigger

from rfidnav_common.errors import ConfigError
from rfidnav_common.step_ledger import StepLedger, StepReport, Unanswered
from rfidnav_common.stepped_node import STEP_ACK_READER_QOS, STEP_ACK_TOPIC, SteppedNode, step_report_of
from rfidnav_msgs.msg import StepAck  # type: ignore[attr-defined]  # generated

# Stepped clock: steps taken in one callback at most before the executor runs again (with no participant to
# wait for, an unbounded loop would starve the ~/start service and shutdown); the wall timer goes on with them.
STEPS_PER_CALLBACK = 500
CATCH_UP_STEPS = 50     # free-running, after a stall (a slow machine): steps a tick at most, then the rest dropped
STALL_REPORT_S = 10.0   # wall time a step may wait before the clock source says who it is waiting for
# Wall time a step may wait before the clock source asks the producers to send a participant what it lacks again
# (rfidnav_common.stepped_node: only a participant that DDS dropped takes them), and again every as long.
RESEND_AFTER_S = 5.0
TICK_S = 0.01           # the wall timer's shortest period: more often buys nothing at 50 Hz of published sim time


def steps_due(wall_elapsed_s: float, rtf: float, step_s: float) -> int | None:
    """The steps the RTF allows after ``wall_elapsed_s`` of wall time on the clock; None when it sets no bound."""
    return None if math.isinf(rtf) else int(wall_elapsed_s * rtf / step_s)


class ClockSource:
    """The clock of ``node`` (a SteppedNode with ``answers_steps = False``), stepping ``step_s`` at a time."""

    def __init__(self, node: SteppedNode, *, step_s: float, rtf: float, participants: Sequence[str],
                 start_paused: bool, on_step: Callable[[], None]) -> None:
        """``participants``: the fully qualified names whose answers each step waits for (the owner is added: a
        command that answers a step must have reached it). ``rtf``: positive, ``math.inf`` for none."""
        if math.isinf(rtf) and not node.stepped:
            raise ConfigError(f"parameters of node '{node.get_fully_qualified_name()}'", "rtf",
                              "an unbounded RTF (.inf, the command line's max) needs the stepped clock "
                              "(stepped_clock: true)")
        self.node = node
        self.step_s = step_s
        self.rtf = rtf
        self.on_step = on_step
        self.steps = 0
        self.running = False   # until serve(): the owner has built what a step publishes
        self.start_paused = start_paused
        self.stepping = False  # within advance(): the owner's own publications must not step again
        self.wall_origin = time.monotonic()
        self.ledger = StepLedger([*participants, node.get_fully_qualified_name()])
        self.waiting_since = time.monotonic()
        self.reports: dict[str, StepReport] = {}   # each participant's latest, for recover_lost
        self.resend_requests = 0

    def serve(self) -> None:
        """The owner has made everything a step publishes (and keeps this as its ``clock``): offer the services,
        hear the answers, start the timers, and run now (or on ``~/start`` with ``start_paused``)."""
        node = self.node
        node.create_service(Trigger, "~/start", self.on_start)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if node.stepped:
            node.create_subscription(StepAck, STEP_ACK_TOPIC, self.on_step_ack, STEP_ACK_READER_QOS)
            node.create_service(Trigger, "~/wired", self.on_wired)
            node.create_service(Trigger, "~/settle", self.on_settle)
            node.create_timer(STALL_REPORT_S, self.report_stall, clock=steady)
            node.create_timer(RESEND_AFTER_S, self.recover_lost, clock=steady)
        # A clock source cannot pace itself on sim time: a steady wall timer drives the steps, running as many as
        # are due, so that the long-run rate is exactly rtf (at most rtf, stepped, where answers drive them too).
        node.create_timer(max(self.step_s / self.rtf, TICK_S), self.advance, clock=steady)
        self.running = not self.start_paused

    @property
    def now_s(self) -> float:
        return self.steps * self.step_s

    def describe(self) -> str:
        if not self.node.stepped:
            return f"free-running clock at RTF {self.rtf:g}"
        ceiling = "as fast as they answer" if math.isinf(self.rtf) else f"RTF at most {self.rtf:g}"
        return f"stepped clock, {len(self.ledger.participants) - 1} participants, {ceiling}"

    def on_start(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if not self.running:
            self.running = True
            self.wall_origin = time.monotonic() - self.now_s / self.rtf
            self.node.get_logger().info("clock started")
            self.advance()
        response.success = True
        response.message = f"running at sim time {self.now_s:.3f} s"
        return response

    def on_wired(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """Whether every participant has reported and every publisher and subscription of theirs has matched the
        participants on the other side of its topic: the orchestrator sends the goal only then (a message a node
        publishes when its goal comes would otherwise be lost, and its consumer counted behind for ever)."""
        self.ledger.report(self.node.step_report())
        waiting = self.ledger.wiring()
        response.success = not waiting
        response.message = ", ".join(u.describe() for u in waiting) or "every participant wired"
        return response

    def on_settle(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """The mission has ended: stop the clock, and say whether every participant has handled everything
        published so far, slack and all (the orchestrator asks until it has, then stops the graph)."""
        self.running = False
        self.ledger.report(self.node.step_report())
        response.success = self.ledger.settled()
        response.message = (f"stopped at sim time {self.now_s:.3f} s" if response.success else
                            ", ".join(u.describe() for u in self.ledger.behind()))
        return response

    def on_step_ack(self, message: StepAck) -> None:
        self.take_answer(step_report_of(message))

    def take_answer(self, report: StepReport) -> None:
        """A participant's counts, from /sim/step_ack or directly from a participant in the owner's process."""
        self.reports[report.node] = report
        if self.ledger.report(report):
            self.advance()

    def recover_lost(self) -> None:
        """A step held RESEND_AFTER_S or more: ask the producer of each topic a participant is behind on to send it
        the messages it lacks again. One lost them if DDS dropped it (its lease ended while it was paused: SIGSTOP,
        a suspended laptop, a debugger) with them in flight; the others are only slow, and take none (their own
        messages are still coming). A topic with several producers is not asked for: whose messages it lacks
        cannot be told."""
        if not self.running or time.monotonic() - self.waiting_since < RESEND_AFTER_S:
            return
        owner = self.node.step_report()
        reports = {**self.reports, owner.node: owner}.values()
        for waiting in self.ledger.unanswered():
            if not isinstance(waiting, Unanswered) or waiting.behind <= 0:
                continue
            if sum(waiting.topic in report.produced for report in reports) == 1:
                self.resend_requests += 1
                self.node.request_resend(self.resend_requests, waiting.node, waiting.topic, waiting.behind)

    def owner_changed(self) -> None:
        """One of the owner's own counts changed: a command arrived, which can complete a step (a publication is
        its own, from within a step)."""
        if not self.stepping:
            self.advance()

    def advance(self) -> None:
        """Take the steps that are due: all of them free-running, up to the next unanswered publication with the
        stepped clock."""
        if not self.running or self.stepping:
            return
        due = steps_due(time.monotonic() - self.wall_origin, self.rtf, self.step_s)
        if due is not None and not self.node.stepped:
            for _ in range(min(due - self.steps, CATCH_UP_STEPS)):
                self.step()
            if due - self.steps > CATCH_UP_STEPS:
                self.wall_origin = time.monotonic() - self.now_s / self.rtf
            return
        self.stepping = True
        try:
            for _ in range(STEPS_PER_CALLBACK):
                if (due is not None and self.steps >= due) or not self.step_answered():
                    return
                self.step()
        finally:
            self.stepping = False

    def step_answered(self) -> bool:
        self.ledger.report(self.node.step_report())
        if not self.ledger.answered():
            return False
        self.waiting_since = time.monotonic()
        return True

    def report_stall(self) -> None:
        waited_s = time.monotonic() - self.waiting_since
        if self.running and waited_s > STALL_REPORT_S:
            waiting = ", ".join(u.describe() for u in self.ledger.unanswered())
            self.node.get_logger().warning(f"sim time {self.now_s:.2f} s has waited {waited_s:.0f} s (wall) for: "
                                           f"{waiting}")

    def step(self) -> None:
        self.steps += 1
        if self.node.stepped:
            self.node.advance_time(round(self.now_s * 1e9))
        self.on_step()
