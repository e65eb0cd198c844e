"""player: republish a recorded rosbag2 directory, the suite's ``ros2 bag play``.

Messages go out as the raw CDR bytes stored in the bag (nothing is deserialised), paced by wall time:
a message stamped ``t`` is due ``(t - t0) / rate`` wall seconds after playback started, where ``t0`` is the
bag's start plus ``start_s``. A steady-clock timer publishes every message whose due time has passed, so
pacing never drifts and no callback sleeps; with ``use_sim_time`` the timer still runs (it is not a ROS-time
timer, which would wait for a /clock that only this node may publish).

QoS: latched topics (every recorded publisher transient local: maps, markers, action status) are published
transient local, so late joiners get the last message as they would from the original publisher. Every
topic is published reliable: a reliable publisher serves both reliable and best-effort subscribers, whereas
a best-effort one would not match a reliable subscriber.

``clock:=true`` publishes /clock from the playback position at ``clock_rate_hz`` (a recorded /clock is then
left out so there is one time source); otherwise a recorded /clock is replayed like any topic.
``wait_for_subscribers`` holds playback until each named topic has a subscriber -- for a topic of the bag,
until one is matched to our publisher, so the first message is not published into the void.
``start_paused`` holds it until ``~/start`` (std_srvs/Trigger) is called as well (``ros2 bag play
--start-paused``): a test or an orchestrator first readies the graph -- sends the goal a node under test
must be executing before the first message arrives -- and then starts playback.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from builtin_interfaces.msg import Time
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.task import Future
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import Trigger

from rfidnav_bag.bags import BagInfo, RawMessage, TopicInfo, bag_info, read_raw
from rfidnav_bag.errors import BagError
from rfidnav_common.config import param
from rfidnav_common.errors import ParameterError
from rfidnav_common.ros import declare_parameters, message_class, run_node, stop_requested

TICK_S = 0.005  # the pacing timer's period: the worst lateness of a message [s, wall]
VOLATILE_DEPTH = 100  # room for a burst of due messages at a high rate before a reliable reader acks
ACK_TIMEOUT_S = 2.0  # at the end, how long to let subscribers acknowledge the last messages


@dataclass(frozen=True)
class PlayerParameters:
    bag: str = param("rosbag2 directory to play", "")
    rate: float = param("playback speed: bag seconds per wall second", 1.0)
    topics: list[str] = param("topics to play (empty: all)", [])
    loop: bool = param("start over at the end of the bag", False)
    clock: bool = param("publish /clock from the bag's timestamps (like ros2 bag play --clock)", False)
    clock_rate_hz: float = param("rate of /clock when clock is true [Hz, wall time]", 100.0)
    start_s: float = param("skip the first seconds of bag time [s]", 0.0)
    wait_for_subscribers: list[str] = param("topics that need a subscriber before playback starts", [])
    start_paused: bool = param("hold playback until ~/start (std_srvs/Trigger) is called", False)

    def validate(self) -> None:
        if not self.bag:
            raise ParameterError("bag", "required (the rosbag2 directory to play)")
        if not self.rate > 0.0:
            raise ParameterError("rate", f"must be > 0, got {self.rate}")
        if not self.clock_rate_hz > 0.0:
            raise ParameterError("clock_rate_hz", f"must be > 0, got {self.clock_rate_hz}")
        if not self.start_s >= 0.0:
            raise ParameterError("start_s", f"must be >= 0, got {self.start_s}")


def publisher_qos(topic: TopicInfo) -> QoSProfile:
    depths = [q.depth for q in topic.offered_qos if q.depth > 0]
    if topic.latched:
        depth = max(depths, default=1)
        durability = DurabilityPolicy.TRANSIENT_LOCAL
    else:
        depth = max([VOLATILE_DEPTH, *depths])
        durability = DurabilityPolicy.VOLATILE
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=durability)


class PlayerNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("player", **node_options)
        self.params: PlayerParameters = declare_parameters(self, PlayerParameters)
        self.info: BagInfo = bag_info(self.params.bag)
        for note in self.info.notes:   # a bag that was not finalised: what was lost
            self.get_logger().warning(f"{self.params.bag}: {note}")
        self.done: Future = Future()
        selected = list(self.info.selected(self.params.topics,
                                           f"parameters of node '{self.get_fully_qualified_name()}'", "topics"))
        if self.params.clock and any(t.name == "/clock" for t in selected):
            self.get_logger().info("clock:=true: the recorded /clock is not replayed (this node publishes it)")
            selected = [t for t in selected if t.name != "/clock"]

        self.topic_publishers: dict[str, Publisher] = {}
        for topic in selected:
            cls = message_class(topic.msgtype)
            if cls is None:
                self.get_logger().error(f"not playing {topic.name}: type {topic.msgtype} is not installed")
                continue
            self.topic_publishers[topic.name] = self.create_publisher(cls, topic.name, publisher_qos(topic))
        self.clock_publisher = (self.create_publisher(ClockMsg, "/clock", 10) if self.params.clock else None)

        self.start_ns = self.info.start_ns + round(self.params.start_s * 1e9)
        if self.info.message_count and self.start_ns > self.info.end_ns:
            self.get_logger().warning(f"start_s {self.params.start_s} is past the bag's end "
                                      f"({self.info.duration_s:.3f} s): nothing to play")
        self.waiting_for = list(self.params.wait_for_subscribers)
        self.paused = self.params.start_paused
        self.create_service(Trigger, "~/start", self.on_start)
        self.messages: Iterator[RawMessage] | None = None
        self.pending: RawMessage | None = None
        self.wall_t0 = 0.0
        self.next_clock_wall = 0.0
        self.published = 0
        self.tick_timer = self.create_timer(min(TICK_S, 1.0 / self.params.clock_rate_hz), self.tick,
                                            clock=Clock(clock_type=ClockType.STEADY_TIME))
        if self.paused:
            self.get_logger().info("paused until ~/start is called")
        if self.waiting_for:
            self.get_logger().info(f"waiting for subscribers on {', '.join(self.waiting_for)}")
        self.get_logger().info(f"playing {self.params.bag}: {len(self.topic_publishers)} topics, "
                               f"rate {self.params.rate:g}, start at {self.params.start_s:g} s"
                               f"{', looping' if self.params.loop else ''}")

    # -- readiness --------------------------------------------------------------------------------------

    def has_subscriber(self, topic: str) -> bool:
        # Matched to our publisher, not merely present in the graph: discovery lists a subscription a moment before
        # DDS matches it, and what is published in that moment never reaches it (the first /clock of a run, seen
        # with three test workers on two cores).
        publisher = self.topic_publishers.get(topic) or (self.clock_publisher if topic == "/clock" else None)
        if publisher is not None:
            return publisher.get_subscription_count() > 0
        return self.count_subscribers(topic) > 0

    def on_start(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        if self.paused:
            self.paused = False
            self.get_logger().info("started")
        response.success = True
        response.message = ("playing" if self.messages is not None else
                            f"waiting for subscribers on {', '.join(self.waiting_for)}" if self.waiting_for else
                            "starting")
        return response

    # -- playback ---------------------------------------------------------------------------------------

    def restart(self) -> None:
        self.messages = read_raw(self.info.path, list(self.topic_publishers), start_ns=self.start_ns)
        self.pending = self.next_message()
        # Playback starts once its first message is read: opening the bag and its first chunk took a loaded machine
        # 0.16 s, which the first /clock skipped (1.32 s of bag at rate 2 where the offset was 1.0).
        self.wall_t0 = time.monotonic()
        self.next_clock_wall = self.wall_t0

    def next_message(self) -> RawMessage | None:
        assert self.messages is not None
        if not self.topic_publishers:
            return None
        return next(self.messages, None)

    def bag_time_at(self, wall: float) -> int:
        return self.start_ns + round((wall - self.wall_t0) * self.params.rate * 1e9)

    def tick(self) -> None:
        if self.done.done():
            return
        try:
            self.play_due()
        except BagError as error:  # a damaged chunk in the middle of the bag
            self.get_logger().error(str(error))
            self.finish(1)

    def play_due(self) -> None:
        if self.paused:
            return
        if self.waiting_for:
            self.waiting_for = [t for t in self.waiting_for if not self.has_subscriber(t)]
            if self.waiting_for:
                return
        if self.messages is None:
            self.restart()
        now = time.monotonic()
        bag_now = self.bag_time_at(now)
        while self.pending is not None and self.pending.timestamp_ns <= bag_now:
            self.topic_publishers[self.pending.topic].publish(self.pending.data)
            self.published += 1
            self.pending = self.next_message()
        if self.clock_publisher is not None and now >= self.next_clock_wall:
            self.clock_publisher.publish(ClockMsg(clock=Time(sec=bag_now // 1_000_000_000,
                                                                nanosec=bag_now % 1_000_000_000)))
            period = 1.0 / self.params.clock_rate_hz
            # Fixed grid of due times (no drift); after a stall, resume from now instead of bursting.
            self.next_clock_wall = max(self.next_clock_wall + period, now - period)
        if self.pending is None:
            if self.params.loop:
                self.restart()
            else:
                self.finish(0)

    def finish(self, code: int) -> None:
        if code == 0:
            self.get_logger().info(f"playback finished: {self.published} messages")
        self.tick_timer.cancel()
        self.done.set_result(code)

    def wait_for_acknowledgements(self) -> None:
        """Let reliable subscribers receive the last messages before the publishers disappear."""
        deadline = time.monotonic() + ACK_TIMEOUT_S
        publishers = list(self.topic_publishers.values())
        if self.clock_publisher is not None:
            publishers.append(self.clock_publisher)
        for publisher in publishers:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not publisher.wait_for_all_acked(Duration(nanoseconds=int(remaining * 1e9))):
                self.get_logger().warning(f"{publisher.topic_name}: not every subscriber acknowledged the "
                                          "last messages")


def spin_until_played(executor: Executor, node: PlayerNode) -> int:
    """Spin until playback is done (or the process is stopped); its exit code."""
    while not node.done.done() and not stop_requested() and node.context.ok():
        executor.spin_once(timeout_sec=0.1)
    if not node.done.done():
        return 0       # stopped (Ctrl-C): nobody is owed the last messages, and the user waits for the end
    node.wait_for_acknowledgements()
    return node.done.result()


def main(args: list[str] | None = None) -> int:
    # SingleThreadedExecutor: spin_until_future_complete busy-loops rclpy 7.1's EventsExecutor.
    return run_node(PlayerNode, args, SingleThreadedExecutor, spin_until_played)


if __name__ == "__main__":
    raise SystemExit(main())
