"""The stepped simulation clock's bookkeeping: has every participant answered the step? (pure, no rclpy)

The simulator advances simulated time only when the graph of participating nodes is quiescent: every message
that the simulator or a participant has published on a topic has been handled by every participant that
consumes the topic. Each participant reports its cumulative counts (messages handled per input topic, messages
published per output topic: rfidnav_common.stepped_node); the simulator's own counts come in the same form.
Because a participant publishes its answer only after its callback has returned, a message it publishes in
answer to step ``k`` is counted before its consumption of step ``k``'s input is: until both are known the step
is not done, so no message can be in flight unseen. This is the counting form of distributed termination
detection; it needs no stamps, so it covers messages without a header (``/cmd_vel``) and timers alike.

Only topics with a counted producer are checked: a foreign or hardware node's messages (whose counts nobody
reports) never hold a step, so such a node runs free-running beside the stepped ones.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

# The simulation clocks a run can have: stepped (this ledger decides each step), or free-running at a fixed RTF.
CLOCKS = ("stepped", "free")


@dataclass(frozen=True)
class StepReport:
    """One participant's cumulative counts, as it last reported them."""
    node: str
    incarnation: int
    consumed: Mapping[str, int]
    produced: Mapping[str, int]


@dataclass(frozen=True)
class Unanswered:
    """A participant that has not handled every counted message on one of its inputs (yet)."""
    node: str
    topic: str
    behind: int            # messages published but not handled; 0 for a participant never heard from

    def describe(self) -> str:
        if not self.topic:
            return f"{self.node} (not heard from yet)"
        return f"{self.node} on {self.topic} ({self.behind} behind)"


@dataclass
class _Participant:
    report: StepReport | None = None
    # Per input topic: messages published before the topic was first reported, which it will never handle.
    baseline: dict[str, int] = field(default_factory=dict)
    # What earlier incarnations published: still published, though the process that counted them is gone.
    retired_produced: dict[str, int] = field(default_factory=dict)


class StepLedger:
    """The latest counts of each named participant; :meth:`unanswered` is empty when the step is done."""

    def __init__(self, participants: Iterable[str]) -> None:
        self.participants: dict[str, _Participant] = {name: _Participant() for name in participants}

    def report(self, report: StepReport) -> bool:
        """Take a participant's latest counts; False for a node that is not a participant (ignored)."""
        entry = self.participants.get(report.node)
        if entry is None:
            return False
        previous = entry.report
        if previous is not None and previous.incarnation != report.incarnation:
            # A restart: what the dead process published stays published; the new one owes nothing old.
            for topic, count in previous.produced.items():
                entry.retired_produced[topic] = entry.retired_produced.get(topic, 0) + count
            entry.baseline = {}
        entry.report = report
        for topic, consumed in report.consumed.items():
            # An input first reported now (a new process, or a subscription made late, as the recorder's are)
            # owes nothing published before: those messages went by before it listened.
            if topic not in entry.baseline:
                entry.baseline[topic] = max(0, self.published(topic) - consumed)
        return True

    def published(self, topic: str) -> int:
        """Messages on ``topic`` counted by any participant, restarted ones included."""
        total = 0
        for entry in self.participants.values():
            total += entry.retired_produced.get(topic, 0)
            if entry.report is not None:
                total += entry.report.produced.get(topic, 0)
        return total

    def unanswered(self) -> list[Unanswered]:
        """Who still has to answer: participants never heard from, then inputs with unhandled messages."""
        waiting = [Unanswered(name, "", 0) for name, entry in self.participants.items() if entry.report is None]
        for name, entry in self.participants.items():
            if entry.report is None:
                continue
            for topic, consumed in entry.report.consumed.items():
                behind = self.published(topic) - entry.baseline.get(topic, 0) - consumed
                if behind > 0:
                    waiting.append(Unanswered(name, topic, behind))
        return waiting
