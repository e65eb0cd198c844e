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

Counting finds a message that is late, not one that is lost: DDS delivers a volatile message only to the
subscriptions its publisher has matched when it is sent, and discovery between two processes can lag well
behind both joining the graph on a loaded machine. So each participant also reports, per topic it produces, how
many subscriptions its publisher has matched (and per topic it consumes, how many publishers its subscription
has), and a step (the first one included) waits until every producer and every consumer of a topic have matched
each other (:func:`unwired`): a message sent before then would be lost and its consumer counted behind for ever.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field

# The simulation clocks a run can have: stepped (this ledger decides each step), or free-running at a fixed RTF.
CLOCKS = ("stepped", "free")
# Where the participants answer each step (rfidnav_common.stepped_node); here so that pure code (the run plan, which
# leaves it out of the bag) can name it without rclpy.
STEP_ACK_TOPIC = "/sim/step_ack"
# Messages per input an observer (a participant whose outputs no lockstep participant consumes: a localizer only
# recorded, as rfid_localizer beside the hallway route) may be behind before it holds a step: it then works on
# the other core while the loop goes on. A quarter of the inputs' queue (SENSOR_QOS keeps 100), so nothing is lost.
OBSERVER_SLACK = 25


@dataclass(frozen=True)
class StepReport:
    """One participant's cumulative counts, as it last reported them."""
    node: str
    incarnation: int
    consumed: Mapping[str, int]
    produced: Mapping[str, int]
    slack: int = 0         # messages per input it may be behind without holding a step
    # Per produced topic: the subscriptions its publisher has matched (the fewest, with several publishers).
    matched: Mapping[str, int] = field(default_factory=dict)
    # Per consumed topic: the publishers its subscription has matched (the fewest, with several subscriptions).
    subscribed: Mapping[str, int] = field(default_factory=dict)


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


@dataclass(frozen=True)
class Unwired:
    """A participant whose publisher on a topic has not matched every participant consuming it, or whose
    subscription has not matched every participant producing it (yet)."""
    node: str
    topic: str
    matched: int
    needed: int
    side: str = "publisher"          # or "subscription"

    def describe(self) -> str:
        if self.side == "publisher":
            return f"{self.node}'s {self.topic} to reach its consumers ({self.matched} of {self.needed} matched)"
        return f"{self.node}'s subscription to {self.topic} to match its producers ({self.matched} of {self.needed})"


def unwired(reports: Iterable[StepReport]) -> Iterator[Unwired]:
    """Participants not yet matched with every participant on the other side of a topic: a publisher that has
    matched fewer subscriptions than there are participants consuming its topic, or a subscription fewer
    publishers than there are participants producing it. DDS delivers a message only where both sides have matched
    each other. More is fine: a foreign node (``rfidnav echo``, a driver) may be on the topic too."""
    reports = list(reports)
    consumers: dict[str, int] = {}
    producers: dict[str, int] = {}
    for report in reports:
        for topic in report.consumed:
            consumers[topic] = consumers.get(topic, 0) + 1
        for topic in report.produced:
            producers[topic] = producers.get(topic, 0) + 1
    for report in reports:
        for topic, matched in report.matched.items():
            if matched < consumers.get(topic, 0):
                yield Unwired(report.node, topic, matched, consumers[topic])
        for topic, matched in report.subscribed.items():
            # Its own publisher does not deliver to its own subscription's count: a node consuming what it
            # produces (none does) would be counted once too many; producers are other participants.
            needed = producers.get(topic, 0) - (topic in report.produced)
            if matched < needed:
                yield Unwired(report.node, topic, matched, needed, "subscription")


def observers(reports: Iterable[StepReport]) -> Iterator[str]:
    """Participants the loop need not wait for step by step: no slack of their own, and none of their outputs
    consumed by a participant without slack (itself included: a service call's answers are its own topic). What
    they publish only the recorder takes, so where they are in their inputs' queues changes no other node's input;
    they handle their inputs in the order they came all the same, so their outputs do not depend on the lag."""
    reports = list(reports)
    lockstep_consumers: dict[str, int] = {}
    for report in reports:
        if not report.slack:
            for topic in report.consumed:
                lockstep_consumers[topic] = lockstep_consumers.get(topic, 0) + 1
    for report in reports:
        if not report.slack and not any(lockstep_consumers.get(topic) for topic in report.produced):
            yield report.node


@dataclass
class _Participant:
    report: StepReport | None = None
    # Per input topic: messages published before the topic was first reported, which it will never handle.
    baseline: dict[str, int] = field(default_factory=dict)


class StepLedger:
    """The latest counts of each named participant; :meth:`unanswered` is empty when the step is done.

    Totals per topic are kept up to date as reports come in, so that the check the simulator makes after every
    answer costs one comparison per participant input."""

    def __init__(self, participants: Iterable[str]) -> None:
        self.participants: dict[str, _Participant] = {name: _Participant() for name in participants}
        self.totals: dict[str, int] = {}       # messages published per topic, restarted processes' included
        self.wired = False                     # every producer reaches every consumer; recomputed on a change
        self.observers: frozenset[str] = frozenset()   # recomputed when a participant's topics change

    def report(self, report: StepReport) -> bool:
        """Take a participant's latest counts; False for a node that is not a participant (ignored)."""
        entry = self.participants.get(report.node)
        if entry is None:
            return False
        previous = entry.report
        restarted = previous is not None and previous.incarnation != report.incarnation
        if restarted:
            # What the dead process published stays published; the new one owes nothing old.
            entry.baseline = {}
        before = previous.produced if previous is not None and not restarted else {}
        for topic, count in report.produced.items():
            if count != before.get(topic, 0):
                self.totals[topic] = self.totals.get(topic, 0) + count - before.get(topic, 0)
        entry.report = report
        topics_changed = (previous is None or previous.consumed.keys() != report.consumed.keys()
                          or previous.produced.keys() != report.produced.keys() or previous.slack != report.slack)
        if topics_changed or (previous is not None and (previous.matched != report.matched
                                                        or previous.subscribed != report.subscribed)):
            self.wired = not self._unwired()
        if topics_changed:
            self.observers = frozenset(observers(self._reports()))
        for topic, consumed in report.consumed.items():
            # An input first reported now (a new process, or a subscription made late, as the recorder's are)
            # owes nothing published before: those messages went by before it listened.
            if topic not in entry.baseline:
                entry.baseline[topic] = max(0, self.published(topic) - consumed)
        return True

    def published(self, topic: str) -> int:
        """Messages on ``topic`` counted by any participant, restarted ones included."""
        return self.totals.get(topic, 0)

    def unanswered(self) -> list[Unanswered | Unwired]:
        """Who still has to answer: participants never heard from, producers not matched with their consumers,
        then inputs with unhandled messages."""
        return list(self._waiting())

    def answered(self) -> bool:
        """Whether the step is done: :meth:`unanswered` is empty (stopping at the first that is not)."""
        return next(self._waiting(), None) is None

    def _reports(self) -> list[StepReport]:
        return [entry.report for entry in self.participants.values() if entry.report is not None]

    def _unwired(self) -> list[Unwired]:
        return list(unwired(self._reports()))

    def wiring(self) -> list[Unanswered | Unwired]:
        """What the graph still waits for before a message sent now would reach every participant it is for:
        participants never heard from, then publishers and subscriptions not matched with each other."""
        return [*self._never_heard(), *self._unwired()]

    def _never_heard(self) -> Iterator[Unanswered]:
        for name, entry in self.participants.items():
            if entry.report is None:
                yield Unanswered(name, "", 0)

    def settled(self) -> bool:
        """Whether every participant has handled everything published, slack or not: the graph is quiet (the
        end of a mission, with the clock stopped)."""
        return self.answered() and not self.behind()

    def behind(self) -> list[Unanswered]:
        """Every input with a message not handled yet, within slack or not."""
        return list(self._behind(lambda _name, _report: 0))

    def _waiting(self) -> Iterator[Unanswered | Unwired]:
        yield from self._never_heard()
        if not self.wired:
            yield from self._unwired()
        observing = self.observers
        yield from self._behind(lambda name, report: max(report.slack, OBSERVER_SLACK if name in observing else 0))

    def _behind(self, allowed: Callable[[str, StepReport], int]) -> Iterator[Unanswered]:
        for name, entry in self.participants.items():
            report = entry.report
            if report is None:
                continue
            for topic, consumed in report.consumed.items():
                behind = self.published(topic) - entry.baseline[topic] - consumed
                if behind > allowed(name, report):
                    yield Unanswered(name, topic, behind)
