"""What the Foxglove WebSocket servers of rfidnav share (no rclpy): channels that carry a topic's CDR bytes as
recorded, with the ros2msg definition the bag's schema records carry, and who is watching which topic.

Both servers use foxglove-sdk's (``foxglove.start_server``): the live bridge (``foxglove_bridge_node``) forwards
the running graph, ``bag_view`` plays a recorded bag. Foxglove decodes a channel whose ``encoding`` is ``cdr``
with ``schemaEncoding`` ``ros2msg`` from the schema text alone, so nothing is decoded or re-encoded here.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass

import foxglove
from foxglove import Schema

from rfidnav_bag.bags import message_definition

__all__ = [
    "DEFAULT_HOST", "DEFAULT_PORT", "MESSAGE_ENCODING", "SCHEMA_ENCODING", "Demand", "LiveQos", "Offer",
    "cdr_channel", "live_qos", "ws_url",
]

DEFAULT_PORT = 8765          # Foxglove's default for "Open connection -> Foxglove WebSocket"
DEFAULT_HOST = "127.0.0.1"   # this machine only; a robot's bridge can bind 0.0.0.0 (the node's host parameter)
MESSAGE_ENCODING = "cdr"
SCHEMA_ENCODING = "ros2msg"
LATCHED_DEPTH = 10           # latched topics keep their last few messages (markers, maps, action status)
STREAM_DEPTH = 100           # a stream's queue in the bridge: beyond that it drops the oldest (it may lag)


def ws_url(host: str, port: int) -> str:
    """The address to give Foxglove (``localhost`` for a server bound to every interface or to loopback)."""
    shown = "localhost" if host in ("0.0.0.0", "127.0.0.1", "::", "::1", "localhost") else host
    return f"ws://{shown}:{port}"


def cdr_channel(topic: str, msgtype: str, context: foxglove.Context | None = None) -> foxglove.Channel:
    """A Foxglove channel for ``topic`` whose messages are the topic's CDR bytes, its schema the ros2msg
    definition (with every nested type) that bags.message_definition gives the bag's MCAP schema records.

    Raises BagError when the type is unknown (no definition to give Foxglove)."""
    definition, _ = message_definition(msgtype)
    schema = Schema(name=msgtype, encoding=SCHEMA_ENCODING, data=definition.encode("utf-8"))
    return foxglove.Channel(topic, schema=schema, message_encoding=MESSAGE_ENCODING, context=context)


@dataclass(frozen=True)
class Offer:
    """One publisher's QoS as far as matching goes."""

    reliable: bool
    latched: bool  # transient local: a late subscriber gets its last messages


@dataclass(frozen=True)
class LiveQos:
    """How the bridge subscribes to a topic."""

    reliable: bool
    latched: bool
    depth: int


def live_qos(offers: Iterable[Offer]) -> LiveQos:
    """The subscription that matches every publisher without ever making one wait for the bridge.

    A topic whose publishers all latch is subscribed reliable and transient local, so the bridge gets the
    messages they published before it subscribed (the map, the markers); a reliable durable subscription would
    not match a volatile publisher, hence "all". Every other topic is subscribed best effort: it matches reliable
    and best-effort publishers alike, and a publisher never re-sends to a bridge that fell behind -- the bridge
    loses what it cannot keep up with, the graph does not notice."""
    offers = list(offers)
    latched = bool(offers) and all(o.latched and o.reliable for o in offers)
    return LiveQos(reliable=latched, latched=latched, depth=LATCHED_DEPTH if latched else STREAM_DEPTH)


class Demand:
    """Which topics a Foxglove client subscribes to, counted over clients (thread safe: the server calls its
    listener from its own threads, the node reads it from the executor's)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._subscribers: Counter[str] = Counter()

    def subscribe(self, topic: str) -> None:
        with self._lock:
            self._subscribers[topic] += 1

    def unsubscribe(self, topic: str) -> None:
        with self._lock:
            self._subscribers[topic] -= 1
            if self._subscribers[topic] <= 0:
                del self._subscribers[topic]

    def topics(self) -> frozenset[str]:
        with self._lock:
            return frozenset(self._subscribers)
