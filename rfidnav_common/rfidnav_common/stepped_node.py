"""SteppedNode: the rclpy Node every rfidnav node derives from, and its part in the stepped simulation clock.

With the parameter ``stepped_clock`` false (hardware, replay, the free-running clock) it is a plain rclpy Node.
With it true (the orchestrator sets it on every participant of a stepped simulated run) the node takes part in
lockstep without code of its own:

- every subscription callback and every publish is counted, per resolved topic, and after the callbacks the
  executor had ready (or a publish from outside one: an action callback, or a publisher or subscription matching a
  new peer: the counts include how many each has matched) the node publishes its cumulative counts on
  ``/sim/step_ack``
  (rfidnav_msgs/StepAck); the simulator advances time only when every counted message has been handled
  (rfidnav_common.step_ledger);
- its clock is simulated time taken from the stamps of the messages it handles (``header.stamp``, or a
  ``/clock`` message's ``clock``), so it needs no ``/clock`` subscription;
- timers on its clock (``create_timer`` without a ``clock``) fire when a handled message moves that time past
  their due time, before the message's own callback runs: a timer due at ``t`` sees the inputs of the steps
  before ``t`` and never some of ``t``'s, whatever order the messages of one step arrive in;
- a service call made with :meth:`SteppedNode.call_service` holds the step until its answer has been handled, so
  the answer lands in the step it was asked in, as in the in-process runners, whatever the machine's load: the
  node counts its calls and their answers as a topic of its own that it both produces and consumes (a server
  that never answers holds the step for ``SERVICE_HOLD_S`` of wall time at most); and a service of a participant
  is a topic its server produces and its participant clients consume, so that the first step (and the goal)
  waits until every client has found its server, as for a topic's publisher and subscriptions.

A node whose answers the loop does not wait on (the recorder) sets ``step_slack``: it may fall that many messages
behind on an input before it holds a step, and it answers every ``step_slack // 2`` messages or, when idle,
within ``SLACK_ANSWER_PERIOD_S`` of wall time, instead of after every callback.

A participant in the simulator's own process (a container, rfidnav_bringup.container) hands its counts to the
simulator directly instead of over DDS: both run on one executor thread, so the counts read are current.

A node that is not ours (a hardware driver, a user's node) simply is no participant: nothing waits for it.
"""

from __future__ import annotations

import random
import time
from array import array
from collections import deque
from collections.abc import Callable
from itertools import count
from typing import Any, cast

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.client import Client
from rclpy.clock import Clock, ClockType, ROSClock
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.subscription import Subscription
from rclpy.task import Future
from rclpy.time import Time

from rfidnav_common.clock_topics import RESEND_REQUEST_TOPIC, RESEND_TOPIC, RESEND_TOPICS
from rfidnav_common.in_order import WIDEST_HOLE, InOrder
from rfidnav_common.inputs import STAMP_TOLERANCE_S
from rfidnav_common.rclpy_compat import drive_ros_time_without_clock_topic, hand_message_info, message_and_info
from rfidnav_common.step_ledger import STEP_ACK_TOPIC, StepReport
from rfidnav_msgs.msg import StepAck, StepResend  # type: ignore[attr-defined]  # generated

STEPPED_CLOCK_PARAMETER = "stepped_clock"
# Topics no participant's publisher counts (logs, parameter events, an action's own topics): handling them
# cannot complete a step, so they are not counted and cost no answer.
UNCOUNTED_TOPICS = ("/rosout", "/parameter_events", STEP_ACK_TOPIC, *RESEND_TOPICS)
# A counted publisher's last messages, kept to be sent again: the depth its subscriptions keep (SENSOR_QOS).
RESEND_DEPTH = WIDEST_HOLE
RESEND_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=RESEND_DEPTH * 10,
                        reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
ACTION_TOPIC_MARK = "/_action/"
SLACK_ANSWER_PERIOD_S = 0.02
# Wall seconds a step waits for a service's answer before it goes on without it (a server that died with the call
# out, or one that is no participant): then the client's own timeout, in simulated time, can run.
SERVICE_HOLD_S = 10.0
SERVICE_POLL_S = 0.05     # how often a node with services or clients looks whether their matching changed
# The clock owner (robot_sim) of each rclpy context, for participants in its process.
_CLOCK_OWNERS: dict[int, SteppedNode] = {}
# Counts are cumulative, so only a node's latest answer matters: a participant keeps one. Transient local, so
# that the answer a node gives on starting (which inputs it has) reaches a simulator that discovers it later.
STEP_ACK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
# The simulator's side: one topic without keys is one instance for all writers, so the reader's depth must hold
# an answer of every participant at once, or one node's answer overwrites another's.
STEP_ACK_READER_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                                 reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def service_topic(service_name: str) -> str:
    """The counted topic that stands for a service in the step ledger: its server produces it, each participant
    client consumes it, so a step waits until the clients have found the server (unwired), as for a topic."""
    return f"{service_name} (service)"


class SimTimer:
    """A timer on a stepped node's simulated time: fired by the node as handled stamps pass its due time."""

    def __init__(self, period_ns: int, callback: Callable[[], Any], first_due_ns: int) -> None:
        self.period_ns = period_ns
        self.callback = callback
        self.due_ns = first_due_ns
        self.canceled = False

    def cancel(self) -> None:
        self.canceled = True

    def reset(self) -> None:
        self.canceled = False

    def is_canceled(self) -> bool:
        return self.canceled

    def fire_if_due(self, now_ns: int) -> None:
        """One call however many periods went by (as an rcl timer that fell behind), then the next due time on
        its grid after ``now_ns``."""
        if self.canceled or now_ns < self.due_ns:
            return
        self.due_ns += self.period_ns * ((now_ns - self.due_ns) // self.period_ns + 1)
        self.callback()


def message_stamp_ns(message: Any) -> int | None:
    """The simulated time a message carries: its header's stamp, or a /clock message's time; None without."""
    header = getattr(message, "header", None)
    stamp = getattr(header, "stamp", None) if header is not None else getattr(message, "clock", None)
    if stamp is None or not hasattr(stamp, "nanosec"):
        return None
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class CountedPublisher(Publisher):
    """A publisher that tells its stepped node of each message it sent (rclpy's ``publisher_class`` hook)."""

    on_published: Callable[[Any], None] | None = None

    def publish(self, msg: Any) -> None:
        super().publish(msg)
        if self.on_published is not None:
            self.on_published(msg)


class SteppedNode(Node):
    """An rclpy Node that answers the stepped simulation clock when its ``stepped_clock`` parameter is true."""

    # The simulator owns the clock and reads its own counts: it answers no one.
    answers_steps = True
    step_slack = 0
    # Until the parameter is read: what rclpy's Node creates for itself (parameter events) is not counted.
    stepped = False

    def __init__(self, node_name: str, **node_options: Any) -> None:
        super().__init__(node_name, **node_options)
        self.stepped = bool(self.declare_parameter(
            STEPPED_CLOCK_PARAMETER, False,
            ParameterDescriptor(description="take part in the stepped simulation clock: count messages, "
                                            "answer on /sim/step_ack, take time from handled stamps")).value)
        self.consumed_counts: dict[str, int] = {}
        self.produced_counts: dict[str, int] = {}
        self.counted_publishers: dict[str, list[Publisher]] = {}
        self.counted_subscriptions: dict[str, list[Subscription]] = {}
        # What each counted publisher or subscription has matched on the other side, read when a matched event says
        # it changed (a step report, after every callback and every step, would otherwise ask rcl each time).
        self.peers: dict[Publisher | Subscription, int] = {}
        self.sim_timers: list[SimTimer] = []
        self.sim_time_ns = 0
        self.calls_topics: dict[str, str] = {}          # service name -> the counted topic of its calls' answers
        self.held_calls: dict[Future, tuple[str, float]] = {}   # a call out -> its service, sent (monotonic)
        self.served: list[str] = []                     # services of its own
        self.counted_clients: list[Client] = []
        self.service_timer: Any = None
        # Recovery (rfidnav_msgs/StepResend): each counted publisher's last messages with their publication sequence
        # numbers and whether it has lost a subscription; per consumed topic, how to handle a message sent again,
        # whether a subscription lost a publisher since the topic's last message, and the resends being taken
        # (request, its last number, messages handled).
        self.recent: dict[Publisher, deque[tuple[int, Any]]] = {}
        self.lost_subscription_at: dict[Publisher, int] = {}     # its produced count when it last lost one
        self.resend_handlers: dict[str, tuple[Any, bool, InOrder, Callable[[Any], None]]] = {}
        self.lost_publishers: set[str] = set()
        self.resends_taken: dict[str, tuple[int, int, int]] = {}
        self.resend_requests: Publisher | None = None
        # The latest service_wiring(): per service topic, the clients a served one has (step_report's matched)
        # and, for a client's, 1 once its server is ready (step_report's subscribed).
        self.services_wired: tuple[dict[str, int], dict[str, int]] = ({}, {})
        if not self.stepped:
            return
        self.incarnation = random.SystemRandom().getrandbits(63)
        # Simulated time without a /clock subscription: the clock reads what the adapter sets from the stamps
        # it handles.
        clock = cast(ROSClock, self.get_clock())   # a ROS-time clock: the node's own
        drive_ros_time_without_clock_topic(clock)
        clock.set_ros_time_override(Time(nanoseconds=0, clock_type=clock.clock_type))
        self.in_callback = False
        self.unanswered_changes = 0
        self.answered_at = time.monotonic()
        self.resends = super().create_publisher(StepResend, RESEND_TOPIC, RESEND_QOS)
        super().create_subscription(StepResend, RESEND_REQUEST_TOPIC, self.on_resend_request, RESEND_QOS)
        super().create_subscription(StepResend, RESEND_TOPIC, self.on_resend, RESEND_QOS)
        if not self.answers_steps:
            _CLOCK_OWNERS[id(self.context)] = self
        else:
            self.ack_publisher = super().create_publisher(StepAck, STEP_ACK_TOPIC, STEP_ACK_QOS)
            steady = Clock(clock_type=ClockType.STEADY_TIME)
            if self.step_slack:
                super().create_timer(SLACK_ANSWER_PERIOD_S, self.answer_if_idle, clock=steady)
            # The first answer says which topics the node consumes, so it waits until the node's constructor has
            # made them all: it goes out when the executor first runs, even from a node that consumes nothing.
            self.announced = False
            self.announce_timer = super().create_timer(0.0, self.announce, clock=steady)
            # One answer for the callbacks the executor has ready at once (a step's odometry and round come
            # together): a change starts this timer (the events executor has no guard conditions), whose event
            # comes after the callbacks queued before it.
            self.answer_due = False
            self.answer_timer = super().create_timer(0.0, self.answer_signalled, clock=steady, autostart=False)

    # -------------------------------------------------------------------------------- rclpy overrides
    def create_subscription(self, msg_type: Any, topic: str, callback: Callable[[Any], Any], qos_profile: Any,
                            **kwargs: Any) -> Any:
        resolved = self.resolve_topic_name(topic)
        if not self.stepped or resolved in UNCOUNTED_TOPICS or ACTION_TOPIC_MARK in resolved:
            return super().create_subscription(msg_type, topic, callback, qos_profile, **kwargs)
        self.consumed_counts.setdefault(resolved, 0)

        def counted(message: Any) -> None:
            self.in_callback = True
            try:
                stamp_ns = message_stamp_ns(message) if not isinstance(message, bytes) else None
                if stamp_ns is not None and not self.far_ahead(stamp_ns):
                    self.advance_time(stamp_ns)
                callback(message)
            finally:
                self.consumed_counts[resolved] += 1
                self.in_callback = False
                self.changed()

        order = InOrder()
        made: list[Subscription] = []

        def arrived(*taken: Any) -> None:
            message, info = message_and_info(*taken)
            self.lost_publishers.discard(resolved)
            if self.peers[made[0]] > 1:      # several publishers: their numbers interleave
                order.reset(0)
                counted(message)
                return
            for ready in order.arrived(info["publication_sequence_number"], message):
                counted(ready)

        self.changed()   # a new input: the simulator learns to wait for it
        # A publisher matched (or gone) changes what the node reports, as for its publishers.
        events = kwargs.pop("event_callbacks", None) or SubscriptionEventCallbacks()
        if events.matched is None:
            events.matched = lambda _status: self.rematched(made[0], made[0].get_publisher_count())
        subscription = super().create_subscription(msg_type, topic, arrived, qos_profile, event_callbacks=events,
                                                   **kwargs)
        hand_message_info(subscription)
        made.append(subscription)
        self.peers[subscription] = subscription.get_publisher_count()
        self.counted_subscriptions.setdefault(resolved, []).append(subscription)
        self.resend_handlers.setdefault(resolved, (msg_type, bool(kwargs.get("raw")), order, counted))
        return subscription

    def create_publisher(self, msg_type: Any, topic: str, qos_profile: Any, **kwargs: Any) -> Any:
        if not self.stepped:
            return super().create_publisher(msg_type, topic, qos_profile, **kwargs)
        # A subscription matched (or gone) changes what the node reports: the simulator may be waiting for it.
        events = kwargs.pop("event_callbacks", None) or PublisherEventCallbacks()
        made: list[Publisher] = []
        if events.matched is None:
            events.matched = lambda _status: self.rematched(made[0], made[0].get_subscription_count())
        publisher = cast(CountedPublisher, super().create_publisher(
            msg_type, topic, qos_profile, event_callbacks=events, publisher_class=CountedPublisher, **kwargs))
        made.append(publisher)
        self.peers[publisher] = publisher.get_subscription_count()
        resolved = publisher.topic_name
        self.produced_counts.setdefault(resolved, 0)
        self.counted_publishers.setdefault(resolved, []).append(publisher)
        recent: deque[tuple[int, Any]] = deque(maxlen=RESEND_DEPTH)
        self.recent[publisher] = recent
        numbers = count(1)     # as DDS numbers the publisher's writes

        def counted(message: Any) -> None:
            recent.append((next(numbers), message))
            self.produced_counts[resolved] += 1
            if not self.in_callback:   # within a callback the answer after it counts this too
                self.changed()

        publisher.on_published = counted
        return publisher

    def create_timer(self, timer_period_sec: float, callback: Callable[[], Any], callback_group: Any = None,
                     clock: Any = None, autostart: bool = True) -> Any:
        if not self.stepped or clock is not None:
            return super().create_timer(timer_period_sec, callback, callback_group, clock, autostart)
        period_ns = max(1, round(timer_period_sec * 1e9))
        timer = SimTimer(period_ns, callback, self.sim_time_ns + period_ns)
        timer.canceled = not autostart
        self.sim_timers.append(timer)
        return timer

    def create_service(self, srv_type: Any, srv_name: str, callback: Callable[..., Any], **kwargs: Any) -> Any:
        service = super().create_service(srv_type, srv_name, callback, **kwargs)
        if self.stepped:
            # Produced, never counted up: it is there so that a step waits until the service's participant
            # clients have found it (step_report: its matched is the clients it has).
            self.served.append(service.srv_name)
            self.produced_counts[service_topic(service.srv_name)] = 0
            self.watch_services()
        return service

    def create_client(self, srv_type: Any, srv_name: str, **kwargs: Any) -> Any:
        client = super().create_client(srv_type, srv_name, **kwargs)
        if self.stepped and client.srv_name not in self.calls_topics:
            calls = f"{client.srv_name} (answers to {self.get_fully_qualified_name()})"
            self.calls_topics[client.srv_name] = calls
            self.produced_counts[calls] = self.consumed_counts[calls] = 0
            self.consumed_counts[service_topic(client.srv_name)] = 0
            self.counted_clients.append(client)
            self.watch_services()
        return client

    def watch_services(self) -> None:
        """Poll the services' matching (rclpy has no event for it, as it has for topics): answer again when a
        client finds its server or a server gains a client; and give up calls held too long."""
        if self.service_timer is None:
            self.service_timer = super().create_timer(SERVICE_POLL_S, self.poll_services,
                                                      clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.services_wired = self.service_wiring()
        self.changed()

    def poll_services(self) -> None:
        wiring = self.service_wiring()
        if wiring != self.services_wired:
            self.services_wired = wiring
            self.changed()
        self.release_overdue_calls()

    def service_wiring(self) -> tuple[dict[str, int], dict[str, int]]:
        """Per service topic: the clients each service of its own has, and 1 once each client's server is ready."""
        return ({service_topic(name): self.count_clients(name) for name in self.served},
                {service_topic(client.srv_name): int(client.service_is_ready()) for client in self.counted_clients})

    def call_service(self, client: Client, request: Any, on_answer: Callable[[Future], Any]) -> Future:
        """Call ``client``'s service and hand the future to ``on_answer`` when the answer comes (or, with the stepped
        clock, when it is cancelled after SERVICE_HOLD_S without one). With the stepped clock the step waits until
        ``on_answer`` has handled it."""
        future = client.call_async(request)
        if not self.stepped:
            future.add_done_callback(on_answer)
            return future
        self.produced_counts[self.calls_topics[client.srv_name]] += 1
        self.held_calls[future] = (client.srv_name, time.monotonic())
        if not self.in_callback:
            self.changed()

        def answered(done: Future) -> None:
            outer = self.in_callback
            self.in_callback = True
            try:
                on_answer(done)
            finally:
                self.in_callback = outer
                self.release_call(done)

        future.add_done_callback(answered)
        return future

    def release_call(self, future: Future) -> None:
        """Count a call's answer as handled (once: an answer after SERVICE_HOLD_S was counted then)."""
        held = self.held_calls.pop(future, None)
        if held is None:
            return
        self.consumed_counts[self.calls_topics[held[0]]] += 1
        if not self.in_callback:
            self.changed()

    def release_overdue_calls(self) -> None:
        now = time.monotonic()
        for future, (service, sent) in list(self.held_calls.items()):
            if now - sent >= SERVICE_HOLD_S:
                self.get_logger().warning(f"no answer on {service} in {SERVICE_HOLD_S:g} s of wall time: "
                                          "the call is cancelled and the clock goes on")
                future.cancel()                 # its on_answer sees future.cancelled()
                self.release_call(future)       # (counted already, unless the answer had come meanwhile)

    # ------------------------------------------------------------------------------------- stepping
    def far_ahead(self, stamp_ns: int) -> bool:
        """A stamp more than STAMP_TOLERANCE_S past this node's time, once it has one, is from elsewhere (another run,
        a broken clock: one stamped 2^31 s froze a route's node at that time for good), not the step to come: it
        does not move the clock, and the node's input check (rfidnav_common.inputs.stamp_near) drops the message.
        Every node of ours handles a stream of 2 Hz or more, so no step of its own is that far ahead."""
        return self.sim_time_ns > 0 and stamp_ns - self.sim_time_ns > STAMP_TOLERANCE_S * 1e9

    def advance_time(self, stamp_ns: int) -> None:
        """Move this node's simulated time to ``stamp_ns`` (never back) and fire the timers now due."""
        if stamp_ns <= self.sim_time_ns:
            return
        self.sim_time_ns = stamp_ns
        clock = cast(ROSClock, self.get_clock())
        clock.set_ros_time_override(Time(nanoseconds=stamp_ns, clock_type=clock.clock_type))
        for timer in list(self.sim_timers):
            timer.fire_if_due(stamp_ns)

    def rematched(self, endpoint: Publisher | Subscription, peers: int) -> None:
        """``endpoint``'s matched event: it now has ``peers`` on the other side of its topic (fewer than before: a
        peer gone, or dropped by DDS when its lease ended, with what was in flight to it)."""
        if peers < self.peers.get(endpoint, 0):
            if isinstance(endpoint, Subscription):
                self.lost_publishers.add(endpoint.topic_name)
            else:
                self.lost_subscription_at[endpoint] = self.produced_counts[endpoint.topic_name]
        self.peers[endpoint] = peers
        self.changed()

    # ------------------------------------------------------------------- recovering what was lost
    def request_resend(self, request: int, consumer: str, topic: str, behind: int) -> None:
        """The clock source's side: ask the producer of ``topic`` for the ``behind`` messages ``consumer`` lacks."""
        if self.resend_requests is None:
            self.resend_requests = super().create_publisher(StepResend, RESEND_REQUEST_TOPIC, RESEND_QOS)
        self.resend_requests.publish(StepResend(request=request, consumer=consumer, topic=topic, behind=behind))

    def on_resend_request(self, request: StepResend) -> None:
        """A producer's side: send the consumer the last ``behind`` messages published on the topic again, each with
        its publication sequence number."""
        publishers = self.counted_publishers.get(request.topic, [])
        if len(publishers) != 1:     # none of ours; or two, whose messages the consumer cannot be told apart
            return
        kept = list(self.recent[publishers[0]])
        if request.behind > len(kept):
            self.get_logger().warning(f"{request.consumer} lacks {request.behind} messages on {request.topic}, "
                                      f"more than the {len(kept)} kept to send again", throttle_duration_sec=10.0)
            return
        # Lost here if the publisher lost a subscription after the first of them went out (in flight then).
        lost_match = self.lost_subscription_at.get(publishers[0], -1) > self.produced_counts[request.topic] - \
            request.behind
        for number, message in kept[len(kept) - request.behind:]:
            data = message if isinstance(message, bytes) else serialize_message(message)
            self.resends.publish(StepResend(request=request.request, consumer=request.consumer, topic=request.topic,
                                            behind=request.behind, index=number, lost_match=lost_match,
                                            data=array("B", data)))

    def on_resend(self, resend: StepResend) -> None:
        """A consumer's side: handle a message sent again if this node lacks it (rfidnav_common.in_order): one in a
        hole of the publisher's numbers, or one after the last it had if DDS dropped one side of the topic's match
        (here, or at the producer's: ``lost_match``); a node merely slow still has it coming. Those after a hole
        wait for it, so that they are handled in the order they were published."""
        topic = resend.topic
        if resend.consumer != self.get_fully_qualified_name() or topic not in self.resend_handlers:
            return
        msg_type, raw, order, counted = self.resend_handlers[topic]
        request, last, taken = self.resends_taken.get(topic, (-1, 0, 0))
        if request != resend.request:
            request, last, taken = resend.request, resend.index + resend.behind - 1, 0
        data = bytes(resend.data)
        lost_since = topic in self.lost_publishers or resend.lost_match
        before = len(order.taken_again)
        for message in order.resent(resend.index, data if raw else deserialize_message(data, msg_type), lost_since):
            counted(message)
        taken += len(order.taken_again) - before
        self.resends_taken[topic] = (request, last, taken)
        if resend.index == last and taken:
            self.get_logger().warning(f"{taken} message(s) on {topic} lost to this node (a DDS lease ended: a "
                                      "pause?) were sent again and handled"
                                      + ("; some are still missing" if order.lacks() else ""))

    def changed(self) -> None:
        """A count changed: answer with all counts (they are cumulative, so every answer is complete), at once
        or, with slack, once enough changed."""
        if not self.answers_steps or not self.announced:
            return
        self.unanswered_changes += 1
        if self.unanswered_changes > self.step_slack // 2 and not self.answer_due:
            self.answer_due = True
            self.answer_timer.reset()

    def answer_signalled(self) -> None:
        self.answer_timer.cancel()
        self.answer_due = False
        if self.unanswered_changes:
            self.answer()

    def announce(self) -> None:
        self.announce_timer.cancel()
        self.destroy_timer(self.announce_timer)
        self.announced = True
        self.answer()

    def answer_if_idle(self) -> None:
        if self.unanswered_changes and time.monotonic() - self.answered_at >= SLACK_ANSWER_PERIOD_S:
            self.answer()

    def answer(self) -> None:
        if not self.context.ok():   # shutting down (Ctrl-C came during a callback): nobody waits any more
            return
        self.unanswered_changes = 0
        self.answered_at = time.monotonic()
        owner = _CLOCK_OWNERS.get(id(self.context))
        if owner is not None:
            owner.take_answer(self.step_report())
        else:
            self.ack_publisher.publish(step_ack_message(self.step_report(), self.sim_time_ns))

    def take_answer(self, report: StepReport) -> None:
        """The clock owner's side: a participant's counts (from /sim/step_ack, or directly in its process)."""

    def destroy_node(self) -> None:
        if _CLOCK_OWNERS.get(id(self.context)) is self:
            del _CLOCK_OWNERS[id(self.context)]
        super().destroy_node()

    def step_report(self) -> StepReport:
        peers = self.peers
        matched = {topic: min(peers[p] for p in publishers) for topic, publishers in self.counted_publishers.items()}
        subscribed = {topic: min(peers[s] for s in subscriptions)
                      for topic, subscriptions in self.counted_subscriptions.items()}
        for calls in self.calls_topics.values():   # its own, produced and consumed: nothing to match
            matched[calls] = subscribed[calls] = 1
        matched.update(self.services_wired[0])
        subscribed.update(self.services_wired[1])
        return StepReport(self.get_fully_qualified_name(), self.incarnation, dict(self.consumed_counts),
                          dict(self.produced_counts), self.step_slack, matched, subscribed)


def step_ack_message(report: StepReport, time_ns: int) -> StepAck:
    message = StepAck(node=report.node, incarnation=report.incarnation, slack=report.slack,
                      consumed_topics=list(report.consumed), consumed_counts=list(report.consumed.values()),
                      produced_topics=list(report.produced), produced_counts=list(report.produced.values()),
                      produced_matched=[report.matched.get(topic, 0) for topic in report.produced],
                      consumed_matched=[report.subscribed.get(topic, 0) for topic in report.consumed])
    message.time.sec, message.time.nanosec = divmod(time_ns, 1_000_000_000)
    return message


def step_report_of(message: StepAck) -> StepReport:
    return StepReport(message.node, message.incarnation,
                      dict(zip(message.consumed_topics, message.consumed_counts, strict=True)),
                      dict(zip(message.produced_topics, message.produced_counts, strict=True)), message.slack,
                      dict(zip(message.produced_topics, message.produced_matched, strict=True)),
                      dict(zip(message.consumed_topics, message.consumed_matched, strict=True)))
