"""The live view (``./rfidnav run ... --live PORT``) and ``./rfidnav view`` as a Foxglove client sees them.

The client here is the ``websockets`` package speaking the Foxglove WebSocket protocol (subprotocol
``foxglove.sdk.v1``, the one foxglove-sdk's server accepts) byte for byte: JSON serverInfo, advertise and
subscribe, binary message data (opcode 1), time (2), playback control requests (client opcode 3) and playback
state (5). Messages are decoded with rosbags against the schema text the server advertised, not against
rfidnav's types, so "Foxglove can decode it" means what it says. Every wait is on a frame or a line with a
deadline, never a sleep.
"""

from __future__ import annotations

import json
import math
import os
import queue
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pytest
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from websockets.sync.client import ClientConnection, connect

from rfidnav_bag.bag_view import PlaybackClock
from rfidnav_bag.bags import clock_stamp_ns, message_definition, typestore
from rfidnav_bag.live_view import Demand, Offer, cdr_channel, live_qos, ws_url
from support.runs import WORKSPACE

if TYPE_CHECKING:
    from support.graph import Graph

SUBPROTOCOL = "foxglove.sdk.v1"
WAIT_S = 60.0   # a run's start on a loaded two-core machine; each wait normally takes well under a second
MESSAGE_DATA, TIME, PLAYBACK_STATE = 1, 2, 5   # server binary opcodes
TEXT = 0                                        # a JSON message (here: no binary opcode is 0)
UNKNOWN_CHANNEL = "Unknown channel ID: "        # the server's status on a subscription it cannot serve
PLAYBACK_CONTROL_REQUEST = 3                    # client binary opcode
PLAY, PAUSE = 0, 1
PLAYING, PAUSED, ENDED = 0, 1, 3


# ------------------------------------------------------------------------------------------- the client

@dataclass
class Frame:
    opcode: int
    subscription: int = 0
    log_time: int = 0
    payload: bytes = b""


@dataclass
class FoxgloveClient:
    """One connection: the channels advertised so far, frames read one at a time with a deadline."""

    ws: ClientConnection
    server_info: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)   # by topic
    subscriptions: dict[int, str] = field(default_factory=dict)         # subscription id: topic

    def next_frame(self, deadline: float) -> Frame | None:
        """The next frame (None at the deadline); a JSON message is taken in and comes back as opcode TEXT."""
        remaining = deadline - _now()
        if remaining <= 0:
            return None
        try:
            message = self.ws.recv(timeout=remaining)
        except TimeoutError:
            return None
        if isinstance(message, str):
            self.take(json.loads(message))
            return Frame(TEXT)
        opcode = message[0]
        if opcode == MESSAGE_DATA:
            subscription, log_time = struct.unpack_from("<IQ", message, 1)
            return Frame(opcode, subscription, log_time, bytes(message[13:]))
        if opcode == TIME:
            return Frame(opcode, log_time=struct.unpack_from("<Q", message, 1)[0])
        return Frame(opcode, payload=bytes(message[1:]))

    def take(self, message: dict[str, Any]) -> None:
        if message["op"] == "serverInfo":
            self.server_info = message
        elif message["op"] == "advertise":
            self.channels.update({channel["topic"]: channel for channel in message["channels"]})
        elif message["op"] == "status" and message["message"].startswith(UNKNOWN_CHANNEL):
            # foxglove-sdk 0.30 can refuse a subscription sent the moment a channel is advertised (it has told
            # the client before it knows the channel itself); asking again once it says so is what helps.
            channel_id = int(message["message"][len(UNKNOWN_CHANNEL):])
            self.subscribe(*(topic for topic, channel in self.channels.items() if channel["id"] == channel_id))

    def wait_for_channels(self, topics: set[str], deadline: float) -> None:
        while not topics <= self.channels.keys():
            if self.next_frame(deadline) is None:
                pytest.fail(f"channels {sorted(topics - self.channels.keys())} were never advertised "
                            f"(advertised: {sorted(self.channels)})")

    def subscribe(self, *topics: str) -> None:
        subscriptions = []
        for topic in topics:
            subscription = len(self.subscriptions) + 1
            self.subscriptions[subscription] = topic
            subscriptions.append({"id": subscription, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def playback_request(self, command: int, speed: float, request_id: str, seek_ns: int | None = None) -> None:
        self.ws.send(struct.pack("<BBfBQI", PLAYBACK_CONTROL_REQUEST, command, speed, seek_ns is not None,
                                 seek_ns or 0, len(request_id)) + request_id.encode())

    def decode(self, topic: str, payload: bytes) -> Any:
        """A message decoded by rosbags from the schema text the server advertised for its channel."""
        channel = self.channels[topic]
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(channel["schema"], channel["schemaName"]))
        return store.deserialize_cdr(payload, channel["schemaName"])


@dataclass(frozen=True)
class PlaybackStateFrame:
    status: int
    current_time: int
    speed: float
    did_seek: bool
    request_id: str


def playback_state(frame: Frame) -> PlaybackStateFrame:
    status, current_time, speed, did_seek, length = struct.unpack_from("<BQfBI", frame.payload)
    request_id = frame.payload[18:18 + length].decode()
    return PlaybackStateFrame(status, current_time, speed, bool(did_seek), request_id)


def _now() -> float:
    return time.monotonic()


@contextmanager
def foxglove_client(url: str) -> Iterator[FoxgloveClient]:
    # No keepalive pings: a test that stops reading for a moment must not lose the connection over them.
    with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=WAIT_S, max_size=None, ping_interval=None) as ws:
        assert ws.subprotocol == SUBPROTOCOL
        client = FoxgloveClient(ws)
        deadline = _now() + WAIT_S
        while not client.server_info:
            client.take(json.loads(ws.recv(timeout=max(0.0, deadline - _now()))))
        yield client


# ------------------------------------------------------------------------------------------- processes

class Cli:
    """``./rfidnav ARGS`` in a subprocess whose output lines are read by a thread (to wait on one)."""

    def __init__(self, *args: str) -> None:
        env = dict(os.environ)
        env.pop("ROS_DOMAIN_ID", None)   # the orchestrator leases its own domain
        self.popen = subprocess.Popen([sys.executable, "-m", "rfidnav_bringup.cli", *args], cwd=WORKSPACE, env=env,
                                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.lines: queue.Queue[str | None] = queue.Queue()
        self.output: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def wait_for_line(self, *words: str, timeout_s: float = WAIT_S) -> str:
        deadline = _now() + timeout_s
        while True:
            try:
                line = self.lines.get(timeout=max(0.0, deadline - _now()))
            except queue.Empty:
                pytest.fail(f"no line with {words} within {timeout_s:.0f} s:\n{''.join(self.output)}")
            if line is None:
                pytest.fail(f"exited ({self.popen.wait()}) without a line with {words}:\n{''.join(self.output)}")
            self.output.append(line)
            if all(word in line for word in words):
                return line

    def finish(self, timeout_s: float = 300.0) -> tuple[int, str]:
        code = self.popen.wait(timeout=timeout_s)
        while (line := self.lines.get(timeout=WAIT_S)) is not None:
            self.output.append(line)
        return code, "".join(self.output)

    def stop(self) -> None:
        """Ctrl-C (an orchestrator then stops its nodes in order), SIGKILL only if that does not end it."""
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGINT)
            try:
                self.popen.wait(timeout=WAIT_S)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()


def url_in(line: str) -> str:
    return next(word for word in line.split() if word.startswith("ws://"))


def free_port() -> int:
    """A port nothing listens on now (the OS's pick); the server binds it a moment later."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


# ------------------------------------------------------------------------------------------- unit: the core

@pytest.mark.tier("unit")
def test_the_time_of_a_clock_message_is_read_from_its_cdr_in_either_byte_order() -> None:
    store = typestore()
    clock = store.types["rosgraph_msgs/msg/Clock"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    message = clock(clock=stamp(sec=12, nanosec=345_000_000))
    little = bytes(store.serialize_cdr(message, "rosgraph_msgs/msg/Clock"))
    big = bytes(store.serialize_cdr(message, "rosgraph_msgs/msg/Clock", little_endian=False))
    assert clock_stamp_ns(little) == clock_stamp_ns(big) == 12_345_000_000
    assert clock_stamp_ns(little[:8]) is None


@pytest.mark.tier("unit")
def test_latched_topics_are_subscribed_durable_and_every_other_best_effort() -> None:
    latched = live_qos([Offer(reliable=True, latched=True), Offer(reliable=True, latched=True)])
    assert (latched.reliable, latched.latched) == (True, True)
    # One volatile publisher: a durable subscription would not match it, so the topic is a stream.
    mixed = live_qos([Offer(reliable=True, latched=True), Offer(reliable=True, latched=False)])
    stream = live_qos([Offer(reliable=True, latched=False)])
    assert (mixed.reliable, mixed.latched) == (stream.reliable, stream.latched) == (False, False)
    assert stream.depth > latched.depth > 0


@pytest.mark.tier("unit")
def test_a_topic_is_wanted_while_any_client_subscribes_to_it() -> None:
    demand = Demand()
    demand.subscribe("/odom")
    demand.subscribe("/odom")
    demand.subscribe("/tf")
    demand.unsubscribe("/odom")
    assert demand.topics() == {"/odom", "/tf"}
    demand.unsubscribe("/odom")
    demand.unsubscribe("/tf")
    assert demand.topics() == frozenset()


@pytest.mark.tier("unit")
def test_a_channel_carries_the_cdr_of_its_topic_with_the_definition_the_bag_embeds() -> None:
    channel = cdr_channel("/odom", "nav_msgs/msg/Odometry")
    schema = channel.schema()
    assert channel.message_encoding == "cdr"
    assert schema is not None and schema.name == "nav_msgs/msg/Odometry" and schema.encoding == "ros2msg"
    assert bytes(schema.data).decode() == message_definition("nav_msgs/msg/Odometry")[0]
    channel.close()
    assert ws_url("127.0.0.1", 8765) == "ws://localhost:8765"


@pytest.mark.tier("unit")
def test_the_playback_clock_follows_play_pause_seek_and_speed() -> None:
    clock = PlaybackClock(start_ns=1_000_000_000, end_ns=5_000_000_000, speed=2.0, position_ns=1_000_000_000)
    assert not clock.playing and clock.wall_until(2_000_000_000, 0.0) == math.inf
    clock.play(10.0)
    assert clock.now_ns(10.5) == 2_000_000_000              # half a wall second at 2x
    assert clock.wall_until(3_000_000_000, 10.5) == pytest.approx(0.5)
    clock.pause(10.5)
    assert clock.now_ns(99.0) == 2_000_000_000              # paused: time stands
    clock.seek(4_500_000_000, 99.0)
    clock.set_speed(1.0, 99.0)
    clock.play(100.0)
    assert clock.now_ns(100.25) == 4_750_000_000
    assert clock.now_ns(200.0) == 5_000_000_000             # never past the end
    clock.seek(0, 200.0)
    assert clock.now_ns(200.0) == 1_000_000_000             # nor before the start
    clock.set_speed(float("nan"), 200.0)
    assert clock.speed > 0.0


# ------------------------------------------------------------------------------------------- node: the bridge

@pytest.mark.tier("node")
def test_stamping_from_the_clock_the_bridge_forwards_a_watched_topic_only_once_a_clock_has_come(graph: Graph) -> None:
    from builtin_interfaces.msg import Time
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock
    from visualization_msgs.msg import Marker, MarkerArray

    from rfidnav_bag.foxglove_bridge_node import FoxgloveBridgeNode
    from rfidnav_common.ros import LATCHED_QOS, SENSOR_QOS

    latched = graph.probe.create_publisher(MarkerArray, "/markers", LATCHED_QOS)
    latched.publish(MarkerArray(markers=[Marker(ns="walls", id=7)]))
    clock = graph.probe.create_publisher(Clock, "/clock", SENSOR_QOS)
    port = free_port()
    graph.add(FoxgloveBridgeNode(context=graph.context, parameter_overrides=[
        Parameter("port", value=port), Parameter("discovery_period_s", value=0.05),
        Parameter("stamp_from_clock_topic", value=True)]))

    def subscribed(topic: str) -> bool:
        return any(info.node_name == "foxglove_bridge" for info in graph.probe.get_subscriptions_info_by_topic(topic))

    with foxglove_client(f"ws://localhost:{port}") as client:
        frames: list[Frame] = []

        def read() -> bool:
            frame = client.next_frame(_now() + 0.01)
            if frame is not None and frame.opcode == MESSAGE_DATA and client.subscriptions[frame.subscription] == \
                    "/markers":
                frames.append(frame)
            return True

        graph.spin_until(lambda: read() and {"/markers", "/clock"} <= client.channels.keys(), "both channels")
        client.subscribe("/markers")
        # Watched, but no /clock yet: only /clock is subscribed to, so nothing goes out stamped at time 0.
        graph.spin_until(lambda: read() and subscribed("/clock"), "the bridge to subscribe to /clock")
        assert not subscribed("/markers") and not frames
        graph.spin_until(lambda: (clock.publish(Clock(clock=Time(sec=3, nanosec=500))), read())[1] and bool(frames),
                         "the latched markers once a /clock has come")
        assert frames[0].log_time == 3_000_000_500                       # stamped with that simulated time


@pytest.mark.tier("node")
def test_the_bridge_subscribes_while_watched_and_gives_a_late_client_the_latched_message(graph: Graph) -> None:
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from visualization_msgs.msg import Marker, MarkerArray

    from rfidnav_bag.foxglove_bridge_node import FoxgloveBridgeNode
    from rfidnav_common.ros import LATCHED_QOS

    latched = graph.probe.create_publisher(MarkerArray, "/markers", LATCHED_QOS)
    latched.publish(MarkerArray(markers=[Marker(ns="walls", id=7)]))
    port = free_port()
    graph.add(FoxgloveBridgeNode(context=graph.context, parameter_overrides=[
        Parameter("port", value=port), Parameter("discovery_period_s", value=0.05)]))

    def bridge_subscription() -> Any:
        found = [info for info in graph.probe.get_subscriptions_info_by_topic("/markers")
                 if info.node_name == "foxglove_bridge"]
        return found[0] if found else None

    with foxglove_client(f"ws://localhost:{port}") as client:
        assert "time" not in client.server_info["capabilities"]   # no /clock to follow: the node's own clock
        frames: list[Frame] = []

        def read() -> bool:
            """Take the frames that arrived (a moment's wait at most) between two turns of the executor."""
            frame = client.next_frame(_now() + 0.01)
            if frame is not None and frame.opcode == MESSAGE_DATA:
                frames.append(frame)
            return True

        graph.spin_until(lambda: read() and "/markers" in client.channels, "the bridge to advertise /markers")
        assert bridge_subscription() is None                        # nobody watches yet: no subscription
        client.subscribe("/markers")
        graph.spin_until(lambda: read() and bool(frames), "the latched marker array, published before anyone watched")
        message = client.decode("/markers", frames[0].payload)
        assert [(m.ns, m.id) for m in message.markers] == [("walls", 7)]
        assert abs(frames[0].log_time - time.time_ns()) < 60_000_000_000   # stamped with the node's (wall) clock
        subscription = bridge_subscription()
        assert subscription.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL

        # A volatile publisher joins: a durable subscription would not match it, so the bridge re-subscribes.
        graph.probe.create_publisher(MarkerArray, "/markers", QoSProfile(
            depth=10, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE))
        graph.spin_until(lambda: bridge_subscription() is not None
                         and bridge_subscription().qos_profile.durability == DurabilityPolicy.VOLATILE,
                         "the bridge to re-subscribe volatile")
        assert bridge_subscription().qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT

        client.ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": [
            sid for sid, topic in client.subscriptions.items() if topic == "/markers"]}))
        graph.spin_until(lambda: bridge_subscription() is None, "the bridge to drop the unwatched subscription")


# ------------------------------------------------------------------------------------------- graph: live

# A live run's messages are stamped with the latest /clock the view had handled: sim time, not wall time (that
# would be 1.7e18 ns away). The view is no stepped participant, and /clock reaches it on a subscription of its own:
# on a loaded machine one runs ahead of the other by as much sim time as a stall lets the clock go on (0.12 s
# beside a second pytest worker, at RTF 3), so the bound is seconds, not a step: 10 s, 2 s of wall time at RTF 5.
SIM_TIME_LAG_NS = 10_000_000_000


@pytest.mark.tier("graph")
def test_a_live_run_serves_its_topics_as_cdr_with_their_definitions_and_the_sim_time(tmp_path: Path) -> None:
    port = free_port()
    # To the route's first tag at RTF 5: what is checked is served while the mission runs; the run then ends by itself.
    cli = Cli("run", "line_follow_0", "--rtf", "5", "--seed", "1", "--goal", "{tag_ids: [C1]}", "--out", str(tmp_path),
              "--quiet", "--live", str(port))
    try:
        line = cli.wait_for_line("live view:", "ws://")
        assert url_in(line) == f"ws://localhost:{port}"
        with foxglove_client(url_in(line)) as client:
            assert "time" in client.server_info["capabilities"]      # a simulated run: the server's time is sim time
            deadline = _now() + WAIT_S
            client.wait_for_channels({"/odom", "/rfid/reads", "/clock", "/tf", "/tf_static",
                                      "/follow_tag_route/_action/status"}, deadline)
            assert "/sim/step_ack" not in client.channels              # bookkeeping, left out as from the bag
            for channel in client.channels.values():
                assert channel["encoding"] == "cdr" and channel["schemaEncoding"] == "ros2msg", channel
                assert channel["schema"].strip(), channel["topic"]
            client.subscribe("/odom", "/rfid/reads", "/tf")
            odometry, reads, transforms, server_times = [], [], [], []
            while len(odometry) < 20 or not transforms or not any(message.readings for _, message in reads):
                frame = client.next_frame(deadline)
                assert frame is not None, f"{len(odometry)} /odom, {len(reads)} /rfid/reads by the deadline"
                # (a round with no tag in range reads nothing: wait for one that reads a tag)
                if frame.opcode == TIME:
                    server_times.append(frame.log_time)
                elif frame.opcode == MESSAGE_DATA:
                    topic = client.subscriptions[frame.subscription]
                    message = client.decode(topic, frame.payload)
                    received = {"/odom": odometry, "/rfid/reads": reads, "/tf": transforms}[topic]
                    received.append((frame.log_time, message))
        assert server_times and server_times[-1] > 0
        for log_time, message in odometry:
            assert message.header.frame_id == "odom" and message.child_frame_id == "base_link"
            stamp_ns = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
            assert abs(log_time - stamp_ns) <= SIM_TIME_LAG_NS, (log_time, stamp_ns)
        assert all(math.isfinite(m.pose.pose.position.x) for _, m in odometry)
        assert [t for t, _ in odometry] == sorted(t for t, _ in odometry)
        for log_time, message in reads:
            stamp_ns = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
            assert abs(log_time - stamp_ns) <= SIM_TIME_LAG_NS, (log_time, stamp_ns)
        reading = next(message for _, message in reads if message.readings).readings[0]
        assert reading.tag_id and reading.antenna in (1, 2) and 0.0 <= reading.phase_rad < 2 * math.pi
        assert -100.0 < reading.rssi_dbm < 0.0
        pairs = {(t.header.frame_id, t.child_frame_id) for _, message in transforms for t in message.transforms}
        assert ("odom", "base_link") in pairs
        code, output = cli.finish()
    finally:
        cli.stop()
    assert code == 0, output
    run = next(tmp_path.iterdir())
    summary = json.loads((run / "summary.json").read_text())
    assert summary["nodes"]["live_view"]["exit_code"] == 0
    assert "/foxglove_bridge" not in summary["clock"]["participants"]
    assert summary["cpu"]["process_cpu_s"]["live_view"] is not None


@pytest.mark.tier("graph")
def test_a_live_view_on_a_port_in_use_fails_the_run_naming_the_port(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        cli = Cli("run", "line_follow_0", "--out", str(tmp_path), "--no-record", "--quiet", "--live", str(port))
        try:
            code, output = cli.finish()
        finally:
            cli.stop()
    assert code != 0
    assert f"cannot serve on 127.0.0.1:{port}" in output, output


# ------------------------------------------------------------------------------------------- graph: view

ODOM_PERIOD_NS = 100_000_000
ODOM_COUNT = 30
START_NS = 1_000_000_000
MARKER_NS = 1_050_000_000


def _qos(durability: QosDurability) -> Qos:
    zero = QosTime(0, 0)
    return Qos(history=QosHistory.UNKNOWN, depth=0, reliability=QosReliability.RELIABLE, durability=durability,
               deadline=zero, lifespan=zero, liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=zero,
               avoid_ros_namespace_conventions=False)


def write_bag(path: Path) -> None:
    """A 3 s bag as the recorder writes one: /odom at 10 Hz whose x is the seconds since its first message, and a
    latched marker array published once, between the first two."""
    store = typestore()
    types = store.types
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for topic, msgtype, durability in (("/odom", "nav_msgs/msg/Odometry", QosDurability.VOLATILE),
                                           ("/markers", "visualization_msgs/msg/MarkerArray",
                                            QosDurability.TRANSIENT_LOCAL)):
            definition, rihs01 = message_definition(msgtype)
            connections[topic] = writer.add_connection(topic, msgtype, msgdef=definition, rihs01=rihs01,
                                                       serialization_format="cdr",
                                                       offered_qos_profiles=[_qos(durability)])
        for index in range(ODOM_COUNT):
            stamp_ns = START_NS + index * ODOM_PERIOD_NS
            if index == 1:
                markers = types["visualization_msgs/msg/MarkerArray"](markers=[])
                writer.write(connections["/markers"], MARKER_NS,
                             bytes(store.serialize_cdr(markers, "visualization_msgs/msg/MarkerArray")))
            writer.write(connections["/odom"], stamp_ns,
                         bytes(store.serialize_cdr(odometry(types, stamp_ns, x=index * ODOM_PERIOD_NS / 1e9),
                                                   "nav_msgs/msg/Odometry")))


def odometry(types: dict[str, Any], stamp_ns: int, x: float) -> Any:
    """A rosbags nav_msgs/Odometry at ``x`` (no rclpy: the bag is written as a third party would)."""
    vector = types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    pose = types["geometry_msgs/msg/Pose"](position=types["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.0),
                                           orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                                             w=1.0))
    return types["nav_msgs/msg/Odometry"](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000,
                                                      nanosec=stamp_ns % 1_000_000_000),
            frame_id="odom"),
        child_frame_id="base_link",
        pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](
            twist=types["geometry_msgs/msg/Twist"](linear=vector, angular=vector), covariance=np.zeros(36)))


@pytest.mark.tier("graph")
def test_view_plays_a_bag_in_log_time_order_and_honours_pause_seek_and_play(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    write_bag(bag)
    end_ns = START_NS + (ODOM_COUNT - 1) * ODOM_PERIOD_NS
    cli = Cli("view", str(bag), "--port", "0", "--rate", "0.5")
    try:
        with foxglove_client(url_in(cli.wait_for_line("ws://"))) as client:
            info = client.server_info
            assert {"time", "playbackControl"} <= set(info["capabilities"])
            assert (info["dataStartTime"], info["dataEndTime"]) == (
                {"sec": 1, "nsec": 0}, {"sec": end_ns // 1_000_000_000, "nsec": end_ns % 1_000_000_000})
            deadline = _now() + WAIT_S
            client.wait_for_channels({"/odom", "/markers"}, deadline)
            for topic, msgtype in (("/odom", "nav_msgs/msg/Odometry"),
                                   ("/markers", "visualization_msgs/msg/MarkerArray")):
                channel = client.channels[topic]
                assert (channel["encoding"], channel["schemaEncoding"], channel["schemaName"]) == (
                    "cdr", "ros2msg", msgtype)
                assert channel["schema"] == message_definition(msgtype)[0]
            client.subscribe("/odom", "/markers")   # the first subscription starts playback

            played: list[tuple[int, float]] = []
            markers_at: list[int] = []
            server_times: list[int] = []
            while len(played) < 5:
                frame = client.next_frame(deadline)
                assert frame is not None, f"{len(played)} /odom messages by the deadline"
                if frame.opcode == TIME:
                    server_times.append(frame.log_time)
                elif frame.opcode == MESSAGE_DATA and client.subscriptions[frame.subscription] == "/odom":
                    message = client.decode("/odom", frame.payload)
                    played.append((frame.log_time, message.pose.pose.position.x))
                elif frame.opcode == MESSAGE_DATA:
                    markers_at.append(frame.log_time)
            assert [t for t, _ in played] == [START_NS + i * ODOM_PERIOD_NS for i in range(5)]
            assert all(x == pytest.approx((t - START_NS) / 1e9) for t, x in played)
            assert markers_at == [MARKER_NS]
            assert server_times and all(START_NS <= t <= end_ns for t in server_times)

            client.playback_request(PAUSE, 0.5, "pause-1")
            state = wait_for_state(client, "pause-1", deadline)
            assert state.status == PAUSED and not state.did_seek

            seek_ns = START_NS + 20 * ODOM_PERIOD_NS + ODOM_PERIOD_NS // 2
            client.playback_request(PLAY, 4.0, "seek-1", seek_ns=seek_ns)
            after: list[int] = []
            resent: list[int] = []
            states: list[PlaybackStateFrame] = []
            expected_after = [START_NS + i * ODOM_PERIOD_NS for i in range(21, ODOM_COUNT)]
            # The SDK sends message data and playback states on separate queues: the last messages may come
            # after the state that says the playback ended.
            while not states or states[-1].status != ENDED or len(after) < len(expected_after):
                frame = client.next_frame(deadline)
                assert frame is not None, f"playback never ended (states: {states})"
                if frame.opcode == MESSAGE_DATA and client.subscriptions[frame.subscription] == "/odom":
                    after.append(frame.log_time)
                elif frame.opcode == MESSAGE_DATA:
                    resent.append(frame.log_time)
                elif frame.opcode == PLAYBACK_STATE:
                    states.append(playback_state(frame))
            answer, ended = states[0], states[-1]
            assert answer.request_id == "seek-1"
            assert answer.status == PLAYING and answer.did_seek and answer.current_time == seek_ns
            assert answer.speed == pytest.approx(4.0)
            # After the seek: the rest of /odom in order, from the first message at or after the time asked, and the
            # latched markers of before it once more.
            assert after == expected_after
            assert resent == [MARKER_NS]
            assert ended.current_time == end_ns
        cli.popen.send_signal(signal.SIGINT)
        code, output = cli.finish(timeout_s=WAIT_S)
    finally:
        cli.stop()
    assert code == 0, output


def wait_for_state(client: FoxgloveClient, request_id: str, deadline: float) -> PlaybackStateFrame:
    while True:
        frame = client.next_frame(deadline)
        assert frame is not None, f"no playback state answering {request_id}"
        if frame.opcode == PLAYBACK_STATE and playback_state(frame).request_id == request_id:
            return playback_state(frame)


@pytest.mark.tier("graph")
def test_view_of_a_path_that_is_no_run_fails_naming_it(tmp_path: Path) -> None:
    code, output = Cli("view", str(tmp_path / "nothing_here")).finish(timeout_s=WAIT_S)
    assert code == 2
    assert "nothing_here" in output and "not a run folder" in output
