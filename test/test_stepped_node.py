"""The stepped clock's node side (rfidnav_common.stepped_node) and robot_sim stepping on answers, in-process on a
private context, stepped with ``spin_once`` until a stated condition holds; and the domain lease's probe."""

from __future__ import annotations

import math

import pytest
import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rclpy.time import Time
from std_srvs.srv import Trigger

from rfidnav_bringup.errors import LaunchError
from rfidnav_bringup.processes import DomainLease
from rfidnav_common import stepped_node
from rfidnav_common.clock_source import steps_due
from rfidnav_common.errors import ConfigError
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS
from rfidnav_common.step_ledger import StepLedger
from rfidnav_common.stepped_node import STEP_ACK_QOS, STEP_ACK_TOPIC, SteppedNode, step_report_of
from rfidnav_msgs.msg import StepAck, StepResend
from rfidnav_sim.robot_sim_node import RobotSimNode
from support.domains import handed_domains
from support.graph import Graph, ground_truth
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("node")

WORLD = WORKSPACE / "config/worlds/line_follow.yaml"


class Recording(SteppedNode):
    """A participant that logs what it saw in order: timer firings (with its clock) and messages."""

    def __init__(self, context: Context) -> None:
        super().__init__("participant", context=context,
                         parameter_overrides=[Parameter("stepped_clock", value=True)])
        self.seen: list[tuple[str, float]] = []
        self.pub = self.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
        self.create_subscription(Odometry, "/sim/ground_truth", self.on_truth, SENSOR_QOS)
        self.create_timer(0.1, self.on_timer)

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_timer(self) -> None:
        self.seen.append(("timer", round(self.now_s(), 3)))

    def on_truth(self, msg: Odometry) -> None:
        self.seen.append(("truth", round(self.now_s(), 3)))
        self.pub.publish(Twist())


def answers(graph: Graph) -> list[StepAck]:
    received: list[StepAck] = []
    graph.probe.create_subscription(StepAck, STEP_ACK_TOPIC, received.append, STEP_ACK_QOS)
    return received


def test_a_stepped_node_takes_time_from_stamps_fires_due_timers_first_and_answers_with_its_counts(graph) -> None:
    received = answers(graph)
    node = graph.add(Recording(graph.context))
    truth = graph.probe.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
    graph.spin_until(lambda: truth.get_subscription_count() == 1 and received, "the participant's first answer")
    assert step_report_of(received[-1]).consumed == {"/sim/ground_truth": 0}
    for stamp_s in (0.04, 0.08, 0.12, 0.16, 0.24):
        truth.publish(ground_truth(0.0, 0.0, 0.0, stamp_s))
    graph.spin_until(lambda: len(node.seen) >= 7, "five messages and two timer periods")
    # The 0.1 s timer fires on the 0.12 message, before it is handled, and the 0.2 s one on the 0.24 message.
    assert node.seen == [("truth", 0.04), ("truth", 0.08), ("timer", 0.12), ("truth", 0.12), ("truth", 0.16),
                         ("timer", 0.24), ("truth", 0.24)]
    graph.spin_until(lambda: step_report_of(received[-1]).consumed["/sim/ground_truth"] == 5, "the last answer")
    last = step_report_of(received[-1])
    assert last.node == "/participant" and last.produced == {"/cmd_vel": 5}


def test_a_stepped_node_answers_again_when_its_publisher_matches_a_subscription_and_reports_the_count(graph) -> None:
    received = answers(graph)
    graph.add(Recording(graph.context))
    graph.spin_until(lambda: received, "the participant's first answer")
    assert step_report_of(received[-1]).matched == {"/cmd_vel": 0}   # nothing listens to its commands yet
    graph.probe.create_subscription(Twist, "/cmd_vel", lambda _message: None, COMMAND_QOS)
    # Nothing was handled or published: only the match makes it answer.
    graph.spin_until(lambda: step_report_of(received[-1]).matched == {"/cmd_vel": 1}, "an answer with the match")
    assert step_report_of(received[-1]).produced == {"/cmd_vel": 0}


def test_a_stepped_node_answers_again_when_its_subscription_matches_a_publisher_and_reports_the_count(graph) -> None:
    received = answers(graph)
    graph.add(Recording(graph.context))
    graph.spin_until(lambda: received, "the participant's first answer")
    assert step_report_of(received[-1]).subscribed == {"/sim/ground_truth": 0}   # no ground truth published yet
    graph.probe.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
    # Nothing was handled or published: only the match makes it answer.
    graph.spin_until(lambda: step_report_of(received[-1]).subscribed == {"/sim/ground_truth": 1},
                     "an answer with the match")
    assert step_report_of(received[-1]).consumed == {"/sim/ground_truth": 0}


class Producer(SteppedNode):
    """A participant publishing ground truth, which a Recording consumes."""

    def __init__(self, context: Context) -> None:
        super().__init__("producer", context=context, parameter_overrides=[Parameter("stepped_clock", value=True)])
        self.pub = self.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)


class ResentTo(Recording):
    """A Recording that counts the messages sent again to it, taken or not."""

    def __init__(self, context: Context) -> None:
        self.resends_seen = 0
        super().__init__(context)

    def on_resend(self, resend: StepResend) -> None:
        if resend.consumer == self.get_fully_qualified_name():
            self.resends_seen += 1
        super().on_resend(resend)


def test_messages_a_participant_lost_with_its_dds_match_are_sent_again_once_and_handled_in_order(graph) -> None:
    producer = graph.add(Producer(graph.context))
    for stamp_s in (0.04, 0.08, 0.12):      # before the consumer is there: it never gets them, as if lost
        producer.pub.publish(ground_truth(0.0, 0.0, 0.0, stamp_s))
    consumer = graph.add(ResentTo(graph.context))
    graph.spin_until(lambda: producer.pub.get_subscription_count() == 1
                     and producer.count_subscribers(stepped_node.RESEND_REQUEST_TOPIC) >= 2
                     and consumer.count_publishers(stepped_node.RESEND_TOPIC) >= 2, "the topics matched")

    def ask(request: int) -> None:
        seen = consumer.resends_seen
        producer.request_resend(request, "/participant", "/sim/ground_truth", 3)
        graph.spin_until(lambda: consumer.resends_seen == seen + 3, f"request {request}'s three resends")

    # It lost nothing (its subscription never lost the producer): a slow consumer's messages are still coming.
    ask(1)
    assert consumer.seen == [] and consumer.consumed_counts["/sim/ground_truth"] == 0
    # DDS dropped the producer (its lease ended) and found it again: the three come again, in order, answered as
    # the originals would have been.
    subscription = consumer.counted_subscriptions["/sim/ground_truth"][0]
    consumer.rematched(subscription, 0)
    consumer.rematched(subscription, 1)
    ask(2)
    assert consumer.seen == [("truth", 0.04), ("truth", 0.08), ("timer", 0.12), ("truth", 0.12)]   # its 0.1 s timer
    assert consumer.consumed_counts["/sim/ground_truth"] == 3 and consumer.produced_counts["/cmd_vel"] == 3
    # Asked again (a request crossing the consumer's answer): made good already, nothing is handled twice.
    ask(2)
    ask(3)
    assert consumer.consumed_counts["/sim/ground_truth"] == 3 and len(consumer.seen) == 4



class Shallow(SteppedNode):
    """A participant whose input keeps one message: one it has not taken when the next comes is overwritten, lost
    to it between two it gets (as when DDS drops a match and finds it again)."""

    def __init__(self, context: Context) -> None:
        super().__init__("shallow", context=context, parameter_overrides=[Parameter("stepped_clock", value=True)])
        self.stamps: list[float] = []
        self.create_subscription(Odometry, "/sim/ground_truth", self.on_truth,
                                 QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE))

    def on_truth(self, msg: Odometry) -> None:
        self.stamps.append(round(Time.from_msg(msg.header.stamp).nanoseconds * 1e-9, 3))


def test_messages_lost_between_two_a_participant_had_are_sent_again_and_all_handled_in_the_order_published(
        graph) -> None:
    producer = graph.add(Producer(graph.context))
    consumer = graph.add(Shallow(graph.context))
    graph.spin_until(lambda: producer.pub.get_subscription_count() == 1
                     and producer.count_subscribers(stepped_node.RESEND_REQUEST_TOPIC) >= 2
                     and consumer.count_publishers(stepped_node.RESEND_TOPIC) >= 2, "the topics matched")
    producer.pub.publish(ground_truth(0.0, 0.0, 0.0, 0.04))
    graph.spin_until(lambda: consumer.stamps == [0.04], "the first message")
    graph.executor.remove_node(consumer)
    for stamp_s in (0.08, 0.12, 0.16):      # the consumer not spinning: only the last stays in its input
        producer.pub.publish(ground_truth(0.0, 0.0, 0.0, stamp_s))
    assert producer.pub.wait_for_all_acked(Duration(seconds=60)), "the consumer's DDS never acknowledged them"
    graph.executor.add_node(consumer)
    order = consumer.resend_handlers["/sim/ground_truth"][2]
    graph.spin_until(order.lacks, "the consumer taking the last, after the hole")
    # Held until the hole is filled: handled now, it would come before the two published ahead of it.
    assert consumer.stamps == [0.04] and consumer.consumed_counts["/sim/ground_truth"] == 1
    producer.request_resend(1, "/shallow", "/sim/ground_truth", 3)       # what the ledger finds it behind
    graph.spin_until(lambda: len(consumer.stamps) == 4, "the two lost, sent again, and the one held")
    assert consumer.stamps == [0.04, 0.08, 0.12, 0.16] and consumer.consumed_counts["/sim/ground_truth"] == 4
    graph.spin_until(lambda: graph.logged("shallow", "2 message(s) on /sim/ground_truth lost", "sent again"),
                     "the consumer saying what it recovered")

class Caller(SteppedNode):
    """A participant that calls a Trigger service and logs, in order, each answer it handled and what it then
    reported."""

    def __init__(self, context: Context) -> None:
        super().__init__("caller", context=context, parameter_overrides=[Parameter("stepped_clock", value=True)])
        self.client = self.create_client(Trigger, "/answerer")
        self.handled: list[Future] = []

    def call(self) -> Future:
        return self.call_service(self.client, Trigger.Request(), self.handled.append)


CALLS = "/answerer (answers to /caller)"


def answerer(graph: Graph) -> Node:
    """A server not spun until the test adds it to the executor: until then its answer does not come."""
    server = Node("answerer_node", context=graph.context)
    server.create_service(Trigger, "/answerer", lambda _request, response: response)
    return server


def test_a_stepped_nodes_service_call_holds_the_step_until_the_answer_has_been_handled(graph) -> None:
    received = answers(graph)
    caller = graph.add(Caller(graph.context))
    server = answerer(graph)
    graph.spin_until(lambda: caller.client.service_is_ready() and received, "the service and a first answer")
    ledger = StepLedger(["/caller"])
    assert ledger.report(step_report_of(received[-1])) and ledger.answered()   # nothing out yet
    caller.call()
    graph.spin_until(lambda: step_report_of(received[-1]).produced.get(CALLS) == 1, "the answer counting the call")
    ledger.report(step_report_of(received[-1]))
    assert [u.describe() for u in ledger.unanswered()] == [f"/caller on {CALLS} (1 behind)"]
    graph.add(server)
    graph.spin_until(lambda: step_report_of(received[-1]).consumed.get(CALLS) == 1, "the answer counting the reply")
    assert len(caller.handled) == 1 and caller.handled[0].result() is not None   # handled before it was counted
    ledger.report(step_report_of(received[-1]))
    assert ledger.answered()


def test_a_call_left_unanswered_is_cancelled_after_the_hold_and_the_step_goes_on(graph, monkeypatch) -> None:
    monkeypatch.setattr(stepped_node, "SERVICE_HOLD_S", 0.0)
    received = answers(graph)
    caller = graph.add(Caller(graph.context))
    server = answerer(graph)            # never spun: it will not answer
    graph.spin_until(lambda: caller.client.service_is_ready() and received, "the service and a first answer")
    future = caller.call()
    graph.spin_until(lambda: step_report_of(received[-1]).consumed.get(CALLS) == 1, "the call to be given up")
    assert future.cancelled() and caller.handled == [future]
    assert step_report_of(received[-1]).produced[CALLS] == 1
    assert graph.logged("caller", "no answer on /answerer")
    server.destroy_node()


def test_a_node_without_the_parameter_is_a_plain_node(graph) -> None:
    received = answers(graph)
    node = graph.add(SteppedNode("plain", context=graph.context))
    timer = node.create_timer(0.1, lambda: None)
    assert not node.stepped and hasattr(timer, "timer_period_ns")   # an rclpy timer, not the adapter's
    graph.spin_until(lambda: graph.probe.count_publishers(STEP_ACK_TOPIC) == 0, "no answer publisher")
    assert received == []


def robot_sim(graph: Graph, participants: list[str]) -> RobotSimNode:
    return graph.add(RobotSimNode(context=graph.context, parameter_overrides=[
        Parameter("world_file", value=str(WORLD)), Parameter("stepped_clock", value=True),
        Parameter("step_participants", value=participants), Parameter("rtf", value=math.inf),
        Parameter("start_paused", value=True)]))


def test_robot_sim_steps_only_as_far_as_its_participants_have_answered(graph) -> None:
    """A participant that never handles what it is sent holds the clock where it is: the simulator waits for it,
    however long, instead of letting time run on without it."""
    sim = robot_sim(graph, ["/participant"])
    start = graph.probe.create_client(Trigger, "/robot_sim/start")
    graph.spin_until(start.service_is_ready, "the start service")
    start.call_async(Trigger.Request())
    graph.spin_until(lambda: sim.clock.running, "the clock to be started")
    for _ in range(50):
        graph.executor.spin_once(timeout_sec=0.01)
    assert sim.clock.steps == 0 and [u.describe() for u in sim.clock.ledger.unanswered()] == [
        "/participant (not heard from yet)"]
    node = graph.add(Recording(graph.context))
    # Now every ground truth is answered (with a command): time moves, one publication at a time.
    graph.spin_until(lambda: sim.clock.steps >= 40, "the clock to move once the participant answers")
    truths = [entry for entry in node.seen if entry[0] == "truth"]
    assert truths and sim.clock.ledger.published("/sim/ground_truth") - len(truths) <= 1


def test_robot_sim_refuses_an_unbounded_rtf_without_the_stepped_clock(graph) -> None:
    with pytest.raises(ConfigError, match=r"rtf: an unbounded RTF .* needs the stepped clock"):
        RobotSimNode(context=graph.context, parameter_overrides=[
            Parameter("world_file", value=str(WORLD)), Parameter("rtf", value=math.inf)])


def test_robot_sim_refuses_an_rtf_of_zero_as_not_positive_since_unbounded_is_inf(graph) -> None:
    with pytest.raises(ConfigError, match=r"rtf: must be positive or \.inf \(no bound\), got 0"):
        RobotSimNode(context=graph.context, parameter_overrides=[
            Parameter("world_file", value=str(WORLD)), Parameter("stepped_clock", value=True),
            Parameter("rtf", value=0.0)])


def test_a_domain_in_use_by_a_foreign_node_is_skipped_and_named() -> None:
    domains = handed_domains()
    free = DomainLease(range(domains.start, domains.stop - 1))   # one left after it for the lease that skips it
    domain = free.domain_id
    free.close()
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    foreign = Node("somebody_elses_node", context=context)
    try:
        with pytest.raises(LaunchError, match="somebody_elses_node"):
            DomainLease(range(domain, domain + 1))
        lease = DomainLease(range(domain, domains.stop))
        try:
            assert lease.domain_id != domain and lease.skipped[domain] == ["/somebody_elses_node"]
        finally:
            lease.close()
    finally:
        foreign.destroy_node()
        context.try_shutdown()


def test_the_clock_source_allows_as_many_steps_as_the_rtf_gives_and_no_bound_at_an_infinite_rtf() -> None:
    assert steps_due(1.0, 5.0, 0.01) == 500 and steps_due(0.0, 5.0, 0.01) == 0
    assert steps_due(0.0099, 1.0, 0.01) == 0 and steps_due(0.0101, 1.0, 0.01) == 1
    assert steps_due(1e6, math.inf, 0.01) is None
