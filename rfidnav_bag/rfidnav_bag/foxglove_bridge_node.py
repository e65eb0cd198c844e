"""foxglove_bridge: the running graph, live, in Foxglove (``./rfidnav run SCENARIO --live [PORT]``).

A Foxglove WebSocket server (foxglove-sdk's) in a plain rclpy node:

- it polls the graph (``discovery_period_s``, wall time) and advertises one channel per topic the recorder would
  record (``recorder_node.recordable_definition``: a type with a Python class and a definition), /tf and
  /tf_static included, new topics as they appear, except ``exclude_topics``; each channel's schema is the ros2msg
  definition the bag's MCAP schema records carry (``live_view.cdr_channel``);
- it subscribes to a topic only while a Foxglove client subscribes to its channel, raw (the CDR bytes go to
  Foxglove as they came: encoding ``cdr``, nothing deserialised), with ``live_view.live_qos``: latched topics
  reliable and transient local (the client gets the map and markers published before it looked), every other
  best effort with a bounded queue, so a bridge that falls behind drops messages and never slows a publisher;
- with ``stamp_from_clock_topic`` (simulated runs) it reads /clock while anyone watches, stamps each message
  with the latest simulated time and broadcasts that time to the clients (the Time capability), so Foxglove's
  clock is the simulation's; it subscribes to the watched topics only once a /clock has come (before it, a message
  would have no time to be stamped with, and went out at time 0); without it messages carry the node's clock
  (wall time on a robot).

It is not a participant of the stepped clock (no SteppedNode, no answers on /sim/step_ack): robot_sim never
waits for it, and what it misses is lost for the viewer only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import foxglove
from foxglove.websocket import Capability, ChannelView, Client, ServerListener
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription

from rfidnav_bag.bags import clock_stamp_ns
from rfidnav_bag.errors import BagError
from rfidnav_bag.live_view import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    Demand,
    LiveQos,
    Offer,
    cdr_channel,
    live_qos,
    ws_url,
)
from rfidnav_bag.recorder_node import recordable_definition
from rfidnav_common.config import param
from rfidnav_common.errors import ConfigError, ParameterError
from rfidnav_common.ros import declare_parameters, message_class, run_node

CLOCK_TOPIC = "/clock"


@dataclass(frozen=True)
class FoxgloveBridgeParameters:
    port: int = param("TCP port of the Foxglove WebSocket server", DEFAULT_PORT)
    host: str = param("address it binds: 127.0.0.1 for this machine only, 0.0.0.0 for every interface",
                      DEFAULT_HOST)
    exclude_topics: list[str] = param("topics not to serve (exact names)", [])
    discovery_period_s: float = param(
        "wall-time period of the graph poll for new topics and of following the clients' subscriptions [s]", 0.2)
    stamp_from_clock_topic: bool = param(
        "stamp messages with the latest /clock and broadcast it as the server's time (simulated runs), instead "
        "of the node clock", False)

    def validate(self) -> None:
        if not 1 <= self.port <= 65535:
            raise ParameterError("port", f"must be a TCP port (1-65535), got {self.port}")
        if not self.host:
            raise ParameterError("host", "required (127.0.0.1, 0.0.0.0 or an interface's address)")
        if not self.discovery_period_s > 0.0:
            raise ParameterError("discovery_period_s", f"must be > 0, got {self.discovery_period_s}")


class _Forwarding(NamedTuple):
    """A topic the bridge subscribes to: with which QoS, chosen for how many publishers."""

    subscription: Subscription
    qos: LiveQos
    publishers: int


class _Subscriptions(ServerListener):
    """The server's callbacks (its own threads) put the clients' subscriptions into a Demand."""

    def __init__(self, demand: Demand) -> None:
        self.demand = demand

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.demand.subscribe(channel.topic)

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        self.demand.unsubscribe(channel.topic)


def _qos_profile(qos: LiveQos) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.latched else DurabilityPolicy.VOLATILE)


class FoxgloveBridgeNode(Node):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("foxglove_bridge", **node_options)
        self.params: FoxgloveBridgeParameters = declare_parameters(self, FoxgloveBridgeParameters)
        self.excluded = set(self.params.exclude_topics)
        self.demand = Demand()
        self.foxglove_context = foxglove.Context()
        self.channels: dict[str, foxglove.Channel] = {}
        self.msgtypes: dict[str, str] = {}
        self.unservable: set[str] = set()   # topics already reported as impossible to serve
        self.forwarding: dict[str, _Forwarding] = {}
        self.clock_ns: int | None = None   # latest /clock seen, when stamping from the clock topic
        self.forwarded = 0
        try:
            self.server = foxglove.start_server(
                name="rfidnav live", host=self.params.host, port=self.params.port,
                capabilities=[Capability.Time] if self.params.stamp_from_clock_topic else [],
                server_listener=_Subscriptions(self.demand), context=self.foxglove_context)
        except RuntimeError as error:  # the SDK's error for an address it cannot bind (in use, not ours)
            raise ConfigError(f"parameters of node '{self.get_fully_qualified_name()}'", "port",
                              f"cannot serve on {self.params.host}:{self.params.port}: {error}") from error
        self.url = ws_url(self.params.host, self.server.port)
        # Wall (steady) time: with use_sim_time a ROS-time timer would not tick before the first /clock.
        self.poll_timer = self.create_timer(self.params.discovery_period_s, self.poll,
                                            clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f"serving the graph to Foxglove at {self.url}")

    # -- the graph's topics ---------------------------------------------------------------------------

    def poll(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self.channels or topic in self.excluded or topic in self.unservable:
                continue
            if self.count_publishers(topic):
                self.advertise(topic, types)
        self.follow_demand()

    def advertise(self, topic: str, types: list[str]) -> None:
        msgtype = types[0]
        try:
            recordable_definition(msgtype)   # what the recorder checks: a Python class and a definition
            self.channels[topic] = cdr_channel(topic, msgtype, self.foxglove_context)
        except BagError as error:
            self.unservable.add(topic)
            self.get_logger().error(f"not serving {topic}: {error}")
            return
        self.msgtypes[topic] = msgtype
        self.get_logger().info(f"advertising {topic} [{msgtype}]")

    # -- following the clients ------------------------------------------------------------------------

    def follow_demand(self) -> None:
        """Subscribe to what the clients watch (and /clock while anything is watched; stamping from it, only /clock
        until its first message), re-subscribe when the publishers changed (another QoS may be needed), drop what
        nobody watches any more."""
        wanted: set[str] = set(self.demand.topics() & self.channels.keys())
        if wanted and self.params.stamp_from_clock_topic:
            clock = {CLOCK_TOPIC} & self.channels.keys()
            wanted = wanted | clock if self.clock_ns is not None else clock   # nothing to stamp with yet
        for topic in self.forwarding.keys() - wanted:
            self.destroy_subscription(self.forwarding.pop(topic).subscription)
        for topic in wanted:
            current = self.forwarding.get(topic)
            publishers = self.count_publishers(topic)
            if current is not None and current.publishers == publishers:
                continue   # the same publishers as when it subscribed: the same QoS
            qos = live_qos(Offer(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE,
                                 p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL)
                           for p in self.get_publishers_info_by_topic(topic))
            if current is not None and current.qos == qos:
                self.forwarding[topic] = current._replace(publishers=publishers)
                continue
            if current is not None:
                self.destroy_subscription(current.subscription)
            self.forwarding[topic] = _Forwarding(self.subscribe(topic, qos), qos, publishers)

    def subscribe(self, topic: str, qos: LiveQos) -> Subscription:
        channel = self.channels[topic]
        callback = self.on_clock if topic == CLOCK_TOPIC else lambda data: self.forward(channel, data)
        return self.create_subscription(message_class(self.msgtypes[topic]), topic, callback, _qos_profile(qos),
                                        raw=True)

    # -- forwarding -----------------------------------------------------------------------------------

    def stamp_ns(self) -> int:
        if not self.params.stamp_from_clock_topic:
            return self.get_clock().now().nanoseconds
        assert self.clock_ns is not None          # follow_demand forwards nothing before the first /clock
        return self.clock_ns

    def forward(self, channel: foxglove.Channel, data: bytes) -> None:
        channel.log(data, log_time=self.stamp_ns())
        self.forwarded += 1

    def on_clock(self, data: bytes) -> None:
        stamp = clock_stamp_ns(data)
        if stamp is not None and self.params.stamp_from_clock_topic:
            first, self.clock_ns = self.clock_ns is None, stamp
            self.server.broadcast_time(stamp)
            if first:
                self.follow_demand()               # now the watched topics can be stamped: subscribe to them
        if self.clock_ns is not None or not self.params.stamp_from_clock_topic:
            self.forward(self.channels[CLOCK_TOPIC], data)

    def destroy_node(self) -> None:
        try:
            self.server.stop()
            # Printed, not logged: on Ctrl-C the context is shut down by now and /rosout is gone with it.
            print(f"stopped serving {self.url}: {self.forwarded} messages forwarded", flush=True)
        finally:
            super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(FoxgloveBridgeNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
