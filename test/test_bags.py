"""Recorder, player and bag access: real DDS between this process and the node processes.

Recorded bags are checked with third-party readers only (``mcap`` + ``mcap_ros2``, rosbags' AnyReader and
``rosbags-convert``) so "self-describing" means what it says: no rfidnav type knowledge is involved in decoding.
Readiness is always a signal (matched subscriptions, process exit), never a sleep; every wait has a deadline.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import rclpy
import yaml
from builtin_interfaces.msg import Time
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Odometry
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header
from visualization_msgs.msg import Marker, MarkerArray

from rfidnav_bag import bags
from rfidnav_bag.bags import (
    bag_info,
    format_bag_info,
    message_definition,
    read_messages,
    read_raw,
    typestore,
)
from rfidnav_bag.errors import BagError
from rfidnav_bag.recover import recover_bag
from rfidnav_bag.salvage import scan_file
from rfidnav_bag.writer import CHUNK_DURATION_NS, BagWriter, StorageOptions
from rfidnav_common.ros import LATCHED_QOS, message_class
from rfidnav_msgs.action import FollowTagRoute
from rfidnav_msgs.msg import TagReadArray, TagReading

pytestmark = pytest.mark.tier("graph")

BIN = Path(sys.prefix) / "bin"
N = 40  # messages per streamed topic in the round trip
FEEDBACK_N = 5
FEEDBACK_TOPIC = "/follow_tag_route/_action/feedback"
# The test keeps every message until the recorder acknowledged it: loss would then be the recorder's.
KEEP = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=N + 10, reliability=ReliabilityPolicy.RELIABLE,
                  durability=DurabilityPolicy.VOLATILE)
RECEIVE = KEEP
RECEIVE_LATCHED = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)


# ------------------------------------------------------------------------------------------- helpers

@dataclass
class Ros:
    """A private rclpy context with one node and an executor the test steps."""

    node: Node
    executor: SingleThreadedExecutor

    def drain(self) -> None:
        """Run the callbacks of whatever already arrived."""
        for _ in range(5):
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, condition: Callable[[], bool], timeout_s: float, what: str) -> None:
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)


@pytest.fixture
def ros(request: pytest.FixtureRequest) -> Iterator[Ros]:
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node(f"test_bags_{request.node.name.split('[')[0]}", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        yield Ros(node, executor)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)


class Processes:
    """Node processes started by a test; whatever is still running at the end is stopped."""

    def __init__(self, log_dir: Path) -> None:
        self.log_dir = log_dir
        self.started: list[tuple[subprocess.Popen, Path]] = []

    def start(self, executable: str, params: dict[str, str], file_size_limit: int | None = None) -> subprocess.Popen:
        """``file_size_limit``: RLIMIT_FSIZE of the process, SIGXFSZ ignored, so that a write past it fails with
        EFBIG as one to a full disk fails with ENOSPC (its DDS then talks UDP only: the limit would refuse the
        shared-memory segments)."""
        log = self.log_dir / f"{executable}-{len(self.started)}.log"
        command = [str(BIN / executable), "--ros-args"]
        for name, value in params.items():
            command += ["-p", f"{name}:={value}"]
        env = dict(os.environ)
        limit = None
        if file_size_limit is not None:
            env["FASTDDS_BUILTIN_TRANSPORTS"] = "UDPv4"

            def limit() -> None:
                signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
                resource.setrlimit(resource.RLIMIT_FSIZE, (file_size_limit, file_size_limit))
        with log.open("wb") as handle:  # the child keeps its own descriptor
            process = subprocess.Popen(command, stdout=handle, stderr=subprocess.STDOUT, env=env, preexec_fn=limit)
        self.started.append((process, log))
        return process

    def log_of(self, process: subprocess.Popen) -> str:
        for started, log in self.started:
            if started is process:
                return log.read_text(errors="replace")
        return ""

    def wait(self, process: subprocess.Popen, timeout_s: float) -> int:
        try:
            return process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            raise AssertionError(f"process did not exit within {timeout_s} s; log:\n{self.log_of(process)}") from None

    def stop_all(self) -> None:
        for process, _ in self.started:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
                try:
                    process.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait(timeout=5)


@pytest.fixture
def processes(tmp_path: Path) -> Iterator[Processes]:
    started = Processes(tmp_path)
    try:
        yield started
    finally:
        started.stop_all()


def reads_message(i: int) -> TagReadArray:
    readings = [TagReading(stamp=Time(sec=i, nanosec=antenna), tag_id=f"T{i:03d}", antenna=antenna,
                           rssi_dbm=-50.0 - i - antenna, phase_rad=0.01 * i, i=0.5 * i, q=-0.25 * i,
                           frequency_hz=902.75e6 + 0.5e6 * antenna)
                for antenna in (1, 2)]
    return TagReadArray(header=header(i, "reader"), readings=readings)


def odom_message(i: int) -> Odometry:
    message = Odometry(header=header(i, "odom"), child_frame_id="base_link")
    message.pose.pose.position.x = 0.1 * i
    message.twist.twist.angular.z = -0.01 * i
    return message


def header(i: int, frame: str) -> Header:
    return Header(stamp=Time(sec=i, nanosec=123), frame_id=frame)


def marker_message() -> MarkerArray:
    marker = Marker(ns="tags", id=7, type=Marker.SPHERE, action=Marker.ADD)
    marker.header.frame_id = "map"
    marker.pose.position.x = 3.5
    return MarkerArray(markers=[marker])


def feedback_message(i: int) -> Any:
    message = FollowTagRoute.Impl.FeedbackMessage()
    message.feedback.target_index = i
    message.feedback.target_tag_id = f"C{i}"
    message.feedback.mode = "seeking"
    message.feedback.phase_difference_rad = 0.1 * i
    return message


def wait_matched(ros: Ros, publishers: list[Any], timeout_s: float = 20.0) -> None:
    ros.spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers), timeout_s,
                   f"subscriptions on {[p.topic_name for p in publishers]}")


def wait_acked(publishers: list[Any], timeout_s: float = 10.0) -> None:
    for publisher in publishers:
        assert publisher.wait_for_all_acked(Duration(seconds=timeout_s)), f"{publisher.topic_name} not acknowledged"


def decoded_by_topic(mcap_file: Path, topics: list[str]) -> dict[str, list[Any]]:
    """Decode with mcap + mcap_ros2 only, from the schemas embedded in the file."""
    decoded: dict[str, list[Any]] = {topic: [] for topic in topics}
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, message in reader.iter_decoded_messages(topics=topics):
            decoded[channel.topic].append(message)
    return decoded


def write_bag(path: Path, messages: list[tuple[str, str, int, bytes]], latched: Collection[str] = (),
              options: StorageOptions = StorageOptions()) -> None:
    """A bag as the recorder writes it (its writer, MCAP, definitions embedded), for player tests."""
    writer = BagWriter(path, options)
    writer.open()
    topics = {}
    never = QosTime(0, 0)
    for topic, msgtype, _, _ in messages:
        if topic not in topics:
            qos = Qos(QosHistory.UNKNOWN, 0, QosReliability.RELIABLE,
                      QosDurability.TRANSIENT_LOCAL if topic in latched else QosDurability.VOLATILE,
                      never, never, QosLiveliness.AUTOMATIC, never, False)
            topics[topic] = writer.add_topic(topic, msgtype, *message_definition(msgtype), (qos,))
    for topic, _, timestamp, data in messages:
        writer.write(topics[topic], timestamp, data)
    writer.close()


T0_NS = 100_000_000_000  # the synthetic bag starts at 100 s (sim time)


@pytest.fixture(scope="module")
def synthetic_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """30 odometry messages 0.1 s apart from 100 s, pose.x = index; one latched marker array."""
    path = tmp_path_factory.mktemp("synthetic") / "bag"
    messages = [("/sim/markers", "visualization_msgs/msg/MarkerArray", T0_NS, serialize_message(marker_message()))]
    messages += [("/odom", "nav_msgs/msg/Odometry", T0_NS + i * 100_000_000, serialize_message(odom_message(i)))
                 for i in range(30)]
    write_bag(path, messages, latched={"/sim/markers"})
    return path


# ------------------------------------------------------------------------------------------- types

@pytest.mark.tier("unit")
def test_typestore_hashes_equal_rosidl_hashes() -> None:
    """Every rfidnav type, action-derived ones included, has the field layout rosidl generated:
    its RIHS01 hash equals the one in the installed type description (.json)."""
    share = Path(sys.prefix) / "share" / "rfidnav_msgs"
    store = typestore()
    checked = []
    for description in sorted(share.glob("*/*.json")):
        for entry in json.loads(description.read_text())["type_hashes"]:
            name = entry["type_name"]
            # A service or an action itself is not a message: its requests, responses and the rest are.
            interface_itself = "/msg/" not in name and "_" not in name.rsplit("/", 1)[1]
            if name.startswith("rfidnav_msgs/") and not interface_itself and \
                    not name.endswith(("_Event", "_SendGoal", "_GetResult")):
                assert store.hash_rihs01(name) == entry["hash_string"], name
                checked.append(name)
    assert {"rfidnav_msgs/msg/TagReadArray", "rfidnav_msgs/action/FollowTagRoute_FeedbackMessage",
            "rfidnav_msgs/action/FollowTagRoute_SendGoal_Request",
            "rfidnav_msgs/action/FollowTagRoute_GetResult_Response", "rfidnav_msgs/srv/Locate_Request",
            "rfidnav_msgs/srv/Locate_Response", "rfidnav_msgs/msg/WifiScan"} <= set(checked)


@pytest.mark.tier("unit")
def test_action_types_resolve_to_generated_classes() -> None:
    assert message_class("rfidnav_msgs/action/FollowTagRoute_FeedbackMessage") is FollowTagRoute.Impl.FeedbackMessage
    assert message_class("rfidnav_msgs/msg/TagReadArray") is TagReadArray
    assert message_class("no_such_pkg/msg/Thing") is None


# ------------------------------------------------------------------------------------------- recorder

@dataclass
class Recording:
    bag: Path
    log: str


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Recording:
    """Record N tag-read arrays, N odometry messages, action feedback and a marker array latched before the
    recorder started; stop the recorder with SIGINT."""
    tmp = tmp_path_factory.mktemp("recording")
    context = Context()
    rclpy.init(context=context)
    node = rclpy.create_node("test_bags_publisher", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    ros = Ros(node, executor)
    processes = Processes(tmp)
    try:
        markers = node.create_publisher(MarkerArray, "/sim/markers", LATCHED_QOS)
        markers.publish(marker_message())  # before the recorder exists: only durability can deliver it
        reads = node.create_publisher(TagReadArray, "/rfid/reads", KEEP)
        odom = node.create_publisher(Odometry, "/odom", KEEP)
        feedback = node.create_publisher(FollowTagRoute.Impl.FeedbackMessage, FEEDBACK_TOPIC, KEEP)
        recorder = processes.start("recorder", {"output_dir": str(tmp / "bag"),
                                                "exclude_topics": "[/parameter_events]"})
        wait_matched(ros, [markers, reads, odom, feedback])
        for i in range(N):
            reads.publish(reads_message(i))
            odom.publish(odom_message(i))
        for i in range(FEEDBACK_N):
            feedback.publish(feedback_message(i))
        wait_acked([markers, reads, odom, feedback])
        recorder.send_signal(signal.SIGINT)
        code = processes.wait(recorder, 20)
        log = processes.log_of(recorder)
        assert code == 0, log
    finally:
        # Gone before the tests run: a live latched publisher here would answer the player tests' subscribers.
        processes.stop_all()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    return Recording(tmp / "bag", log)


def test_recording_decodes_with_third_party_readers(recording: Recording) -> None:
    mcap_files = list(recording.bag.glob("*.mcap"))
    assert len(mcap_files) == 1 and (recording.bag / "metadata.yaml").is_file()
    decoded = decoded_by_topic(mcap_files[0], ["/rfid/reads", "/odom", "/sim/markers"])

    assert len(decoded["/rfid/reads"]) == N, "tag reads lost or duplicated"
    for i, message in enumerate(decoded["/rfid/reads"]):
        assert (message.header.stamp.sec, message.header.frame_id) == (i, "reader")
        assert [(r.tag_id, r.antenna) for r in message.readings] == [(f"T{i:03d}", 1), (f"T{i:03d}", 2)]
        assert message.readings[1].rssi_dbm == pytest.approx(-52.0 - i)
        assert message.readings[0].frequency_hz == pytest.approx(903.25e6)
        assert message.readings[0].phase_rad == pytest.approx(0.01 * i)
    assert len(decoded["/odom"]) == N
    assert [m.pose.pose.position.x for m in decoded["/odom"]] == pytest.approx([0.1 * i for i in range(N)])
    assert all(m.child_frame_id == "base_link" for m in decoded["/odom"])
    assert len(decoded["/sim/markers"]) == 1, "the latched marker array published before recording was missed"
    marker = decoded["/sim/markers"][0].markers[0]
    assert (marker.ns, marker.id, marker.pose.position.x) == ("tags", 7, pytest.approx(3.5))


def test_recording_embeds_definitions_of_action_types(recording: Recording) -> None:
    """mcap_ros2 rejects the underscore in rosidl's action-derived names, so decode the feedback topic with
    a stock Jazzy rosbags store that learns the type from the bag's schema record alone. The text names the
    nested types where they live (``rfidnav_msgs/action/FollowTagRoute_Feedback``), so its hash is rosidl's."""
    with next(recording.bag.glob("*.mcap")).open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        channel = next(c for c in summary.channels.values() if c.topic == FEEDBACK_TOPIC)
        schema = summary.schemas[channel.schema_id]
        raw = [m.data for _, c, m in reader.iter_messages(topics=[FEEDBACK_TOPIC])]
    assert (schema.name, schema.encoding) == ("rfidnav_msgs/action/FollowTagRoute_FeedbackMessage", "ros2msg")
    assert "MSG: rfidnav_msgs/action/FollowTagRoute_Feedback\n" in schema.data.decode()
    store = get_typestore(Stores.ROS2_JAZZY)
    types = get_types_from_msg(schema.data.decode(), schema.name)
    assert "rfidnav_msgs/action/FollowTagRoute_Feedback" in types
    store.register(types)
    assert store.hash_rihs01(schema.name) == channel.metadata["topic_type_hash"] == typestore().hash_rihs01(
        schema.name)
    messages = [store.deserialize_cdr(data, schema.name) for data in raw]
    assert [(m.feedback.target_index, m.feedback.target_tag_id) for m in messages] == [
        (i, f"C{i}") for i in range(FEEDBACK_N)]


def test_recording_opens_in_anyreader_and_converts_to_a_ros1_bag(recording: Recording, tmp_path: Path) -> None:
    """rosbags' AnyReader checks every schema against the recorded hash before it reads anything."""
    def decoded(bag: Path) -> dict[str, list[Any]]:
        messages: dict[str, list[Any]] = {}
        with AnyReader([bag]) as reader:
            for connection, _, data in reader.messages():
                messages.setdefault(connection.topic, []).append(reader.deserialize(data, connection.msgtype))
        return messages

    ros2 = decoded(recording.bag)
    assert [m.feedback.target_tag_id for m in ros2[FEEDBACK_TOPIC]] == [f"C{i}" for i in range(FEEDBACK_N)]
    assert [m.readings[0].tag_id for m in ros2["/rfid/reads"]] == [f"T{i:03d}" for i in range(N)]
    # ROS 1 has no action namespace: rosbags' ROS 1 writer takes nested types from msg/ only (see README).
    converted = subprocess.run([str(BIN / "rosbags-convert"), "--src", str(recording.bag),
                                "--dst", str(tmp_path / "recording.bag"), "--exclude-topic", FEEDBACK_TOPIC],
                               capture_output=True, text=True, timeout=120)
    assert converted.returncode == 0, converted.stdout + converted.stderr
    ros1 = decoded(tmp_path / "recording.bag")
    ros2.pop(FEEDBACK_TOPIC)
    assert {topic: len(messages) for topic, messages in ros1.items()} == {
        topic: len(messages) for topic, messages in ros2.items()}
    # ROS 1 classes differ (a Header with seq), the values do not
    assert [(m.header.stamp.sec, [(r.tag_id, r.rssi_dbm) for r in m.readings]) for m in ros1["/rfid/reads"]] == [
        (m.header.stamp.sec, [(r.tag_id, r.rssi_dbm) for r in m.readings]) for m in ros2["/rfid/reads"]]


def test_recording_info_counts_and_exclusions(recording: Recording) -> None:
    info = bag_info(recording.bag)
    topics = {t.name: t for t in info.topics}
    assert topics["/rfid/reads"].count == N and topics["/odom"].count == N
    assert topics["/sim/markers"].count == 1 and topics[FEEDBACK_TOPIC].count == FEEDBACK_N
    assert topics["/rfid/reads"].msgtype == "rfidnav_msgs/msg/TagReadArray"
    assert "/parameter_events" not in topics, "exclude_topics ignored"
    assert "/rosout" in topics
    assert topics["/sim/markers"].latched and "transient_local" in (topics["/sim/markers"].qos or "")
    assert not topics["/odom"].latched and topics["/odom"].reliable
    assert info.storage == "mcap"
    assert info.message_count == sum(t.count for t in info.topics)
    assert info.start_ns <= info.end_ns and info.duration_s == pytest.approx((info.end_ns - info.start_ns) / 1e9)
    table = format_bag_info(info)
    assert "/rfid/reads" in table and f"{N}" in table and "rfidnav_msgs/msg/TagReadArray" in table
    assert "recording /sim/markers [visualization_msgs/msg/MarkerArray]" in recording.log

    values = [(topic, m.readings[0].tag_id) for topic, _, m in read_messages(recording.bag, ["/rfid/reads"])]
    assert values == [("/rfid/reads", f"T{i:03d}") for i in range(N)]
    stamps = [t for _, t, _ in read_messages(recording.bag)]
    assert stamps == sorted(stamps)


@pytest.mark.parametrize("signals", [[signal.SIGTERM], [signal.SIGHUP], [signal.SIGINT, signal.SIGINT]],
                         ids=["sigterm", "sighup", "two_sigints"])
def test_a_stop_signal_finalizes_a_readable_bag(ros: Ros, processes: Processes, tmp_path: Path,
                                               signals: list[signal.Signals]) -> None:
    """SIGTERM and SIGHUP stop the recorder as Ctrl-C does, and a second signal only cuts the drain short."""
    odom = ros.node.create_publisher(Odometry, "/odom", KEEP)
    recorder = processes.start("recorder", {"output_dir": str(tmp_path / "bag"), "discovery_period_s": "0.1"})
    wait_matched(ros, [odom])
    for i in range(5):
        odom.publish(odom_message(i))
    wait_acked([odom])
    for signum in signals:
        recorder.send_signal(signum)
    assert processes.wait(recorder, 20) == 0, processes.log_of(recorder)
    assert "bag closed" in processes.log_of(recorder)
    info = bag_info(tmp_path / "bag")
    assert info.notes == () and info.topic("/odom").count == 5
    assert [m.pose.pose.position.x for _, _, m in read_messages(tmp_path / "bag", ["/odom"])] == pytest.approx(
        [0.0, 0.1, 0.2, 0.3, 0.4])


# ------------------------------------------------------------------------------------------- crashes

CLOCK_STEP_NS = 10_000_000
ROUNDS = 500   # /clock from 0 to 4.99 s
LATEST_NS = (ROUNDS - 1) * CLOCK_STEP_NS
CLOCK_KEEP = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=ROUNDS, reliability=ReliabilityPolicy.RELIABLE)


def clock_at(stamp_ns: int) -> Clock:
    return Clock(clock=Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000))


def record_clock_then_kill(ros: Ros, processes: Processes, bag: Path, checkpoint_period_s: float,
                           until: Callable[[], bool] = lambda: True) -> None:
    """A recorder stamping from /clock, as in a simulated run, records 5 s of /clock published at once; once it
    has handled every message and ``until`` holds, it is SIGKILLed."""
    clock = ros.node.create_publisher(Clock, "/clock", CLOCK_KEEP)
    recorder = processes.start("recorder", {"output_dir": str(bag), "stamp_from_clock_topic": "true",
                                            "discovery_period_s": "0.1",
                                            "checkpoint_period_s": str(checkpoint_period_s),
                                            "exclude_topics": "[/parameter_events,/rosout]"})
    wait_matched(ros, [clock])
    for i in range(ROUNDS):
        clock.publish(clock_at(i * CLOCK_STEP_NS))
    wait_acked([clock])
    # The recorder handles its events in order: once its next graph poll has found a topic that appeared after
    # every /clock reached it, it has written them all (to the chunk in progress, or further).
    probe = ros.node.create_publisher(Odometry, "/probe", KEEP)
    wait_matched(ros, [probe])
    ros.spin_until(until, 20, "the condition before the kill")
    recorder.kill()
    assert processes.wait(recorder, 20) == -signal.SIGKILL


def test_a_sigkilled_recorder_leaves_a_bag_readable_up_to_the_chunk_in_progress(
        ros: Ros, processes: Processes, tmp_path: Path) -> None:
    """No checkpoint in the run (a period of an hour): what is lost is exactly the chunk in progress, the last
    second of bag time; bag info, read_messages and bag recover read the rest, and the recovered bag opens in
    rosbags, mcap's seeking reader and mcap_ros2."""
    bag = tmp_path / "bag"
    record_clock_then_kill(ros, processes, bag, checkpoint_period_s=3600.0)
    # Unfinished: no summary, so the third-party readers refuse it as it is.
    with pytest.raises(McapError), (bag / "bag_0.mcap").open("rb") as stream:
        make_reader(stream).get_summary()
    info = bag_info(bag)
    stamps = [t for _, t, _ in read_messages(bag, ["/clock"])]
    assert stamps == [i * CLOCK_STEP_NS for i in range(ROUNDS) if i * CLOCK_STEP_NS < 4_000_000_000]
    lost_s = (LATEST_NS - stamps[-1]) / 1e9
    assert 0 < lost_s <= CHUNK_DURATION_NS / 1e9, f"{lost_s} s of bag time lost"  # the chunk spans < 1 s
    assert info.message_count == len(stamps) and len(info.notes) == 1
    assert "bag_0.mcap has no summary" in info.notes[0] and "read 400 messages up to 4.0 s" in info.notes[0]

    recovery = recover_bag(bag)
    assert recovery.message_count == len(stamps) and recovery.source.notes == info.notes
    with AnyReader([recovery.output]) as reader:
        assert [t for _, t, _ in reader.messages()] == stamps
    [mcap_file] = recovery.output.glob("*.mcap")
    with mcap_file.open("rb") as stream:
        decoded = [(channel.topic, message.clock.sec * 1_000_000_000 + message.clock.nanosec) for _, channel, _, message
                   in make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    assert decoded == [("/clock", t) for t in stamps]
    assert bag_info(recovery.output).notes == ()


def bag_metadata(bag: Path) -> dict:
    """The bag's metadata.yaml, its rosbag2_bagfile_information."""
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def test_a_stalled_clock_keeps_nothing_in_memory_past_a_checkpoint(ros: Ros, processes: Processes,
                                                                   tmp_path: Path) -> None:
    """/clock stops (a paused or stalled simulation): within a checkpoint period (wall time) the chunk in
    progress is on disk, so a SIGKILL then loses nothing."""
    bag = tmp_path / "bag"

    def on_disk() -> int:
        return scan_file(bag / "bag_0.mcap").message_count

    def in_metadata() -> int | None:
        try:
            return bag_metadata(bag)["message_count"]
        except (OSError, yaml.YAMLError, TypeError, KeyError):   # not written yet, or caught mid-write
            return None

    # A checkpoint writes the chunk, then metadata.yaml: the kill waits for both (a loaded machine can put it
    # between them), and a checkpoint that never writes the metadata still fails below.
    record_clock_then_kill(ros, processes, bag, checkpoint_period_s=0.5,
                           until=lambda: on_disk() == ROUNDS and in_metadata() == ROUNDS)
    assert [t for _, t, _ in read_messages(bag)] == [i * CLOCK_STEP_NS for i in range(ROUNDS)]
    assert bag_metadata(bag)["message_count"] == ROUNDS, "metadata.yaml not kept current"


def test_a_recorder_whose_disk_is_full_stops_with_one_error_and_exit_3(ros: Ros, processes: Processes,
                                                                       tmp_path: Path) -> None:
    """The recorder under RLIMIT_FSIZE (its writes past 1 MB fail with EFBIG, as a full disk fails them with
    ENOSPC): one ERROR line, exit 3, and the chunks written before stay readable."""
    reads = ros.node.create_publisher(TagReadArray, "/rfid/reads", CLOCK_KEEP)
    recorder = processes.start("recorder", {"output_dir": str(tmp_path / "bag"),
                                            "exclude_topics": "[/parameter_events,/rosout]"},
                               file_size_limit=1_000_000)
    wait_matched(ros, [reads])
    big = reads_message(0)
    big.readings = big.readings * 200   # ~25 kB a message: the 1 MB is reached in a few chunks
    deadline = time.monotonic() + 60
    while recorder.poll() is None:
        assert time.monotonic() < deadline, f"the recorder did not stop:\n{processes.log_of(recorder)}"
        reads.publish(big)
        ros.executor.spin_once(timeout_sec=0.01)
    assert processes.wait(recorder, 20) == 3
    log = processes.log_of(recorder)
    errors = [line for line in log.splitlines() if "[ERROR]" in line]
    assert len(errors) == 1 and "File too large; recording stopped with" in errors[0], log
    assert "Traceback" not in log
    info = bag_info(tmp_path / "bag")
    assert info.message_count == bag_metadata(tmp_path / "bag")["message_count"] > 0, \
        "metadata.yaml does not say what is on disk"
    assert f"with {info.message_count:,} messages on disk" in errors[0]
    assert all(len(m.readings) == 400 for _, _, m in read_messages(tmp_path / "bag", ["/rfid/reads"]))


def test_recorder_refuses_an_existing_output_dir(processes: Processes, tmp_path: Path) -> None:
    recorder = processes.start("recorder", {"output_dir": str(tmp_path)})
    assert processes.wait(recorder, 20) == 2
    assert "exists already" in processes.log_of(recorder)


@pytest.mark.parametrize("params, complaint", [
    ({"compression": "gzip"}, "must be one of none, zstd"),
    ({"max_bag_size": "100"}, "at least 1024 bytes"),
    ({"max_bag_duration_s": "-1.0"}, "must be >= 0"),
], ids=["compression", "max_bag_size", "max_bag_duration_s"])
def test_recorder_rejects_bad_storage_parameters(processes: Processes, tmp_path: Path, params: dict[str, str],
                                                 complaint: str) -> None:
    recorder = processes.start("recorder", {"output_dir": str(tmp_path / "bag"), **params})
    assert processes.wait(recorder, 20) == 2
    log = processes.log_of(recorder)
    assert complaint in log and next(iter(params)) in log and "Traceback" not in log
    assert not (tmp_path / "bag").exists()


def test_recorder_splits_and_compresses_as_its_parameters_say(ros: Ros, processes: Processes,
                                                               tmp_path: Path) -> None:
    reads = ros.node.create_publisher(TagReadArray, "/rfid/reads", KEEP)
    recorder = processes.start("recorder", {"output_dir": str(tmp_path / "bag"), "compression": "zstd",
                                            "max_bag_size": "1024", "exclude_topics": "[/parameter_events,/rosout]"})
    wait_matched(ros, [reads])
    for i in range(N):   # 40 messages of ~250 bytes in 256-byte chunks, 1 KiB files: several files
        reads.publish(reads_message(i))
    wait_acked([reads])
    recorder.send_signal(signal.SIGINT)
    assert processes.wait(recorder, 20) == 0, processes.log_of(recorder)
    info = bag_info(tmp_path / "bag")
    assert len(info.files) >= 2 and info.compression == "zstd", info.files
    assert [m.readings[0].tag_id for _, _, m in read_messages(tmp_path / "bag", ["/rfid/reads"])] == [
        f"T{i:03d}" for i in range(N)]
    assert f"({len(info.files)} files)" in processes.log_of(recorder)


# ------------------------------------------------------------------------------------------- bag errors

def _missing(bag: Path) -> Path:
    return bag.parent / "no_such_bag"


def _plain_file(bag: Path) -> Path:
    path = bag.parent / "not_a_bag.mcap"
    path.write_bytes(b"not a bag")
    return path


def _cut_to_the_magic(bag: Path) -> Path:
    path = bag.parent / "cut"
    shutil.copytree(bag, path)
    mcap_file = next(path.glob("*.mcap"))
    mcap_file.write_bytes(mcap_file.read_bytes()[:8])
    return path


@pytest.mark.tier("unit")
@pytest.mark.parametrize("damage", [_missing, _plain_file, _cut_to_the_magic],
                         ids=["missing", "plain_file", "cut_to_the_magic"])
def test_unreadable_bags_raise_bag_error_naming_the_path(damage: Callable[[Path], Path], tmp_path: Path,
                                                         synthetic_bag: Path) -> None:
    """(Bags that are damaged but partly readable: test_bag_damage.py.)"""
    bag = tmp_path / "bag"
    shutil.copytree(synthetic_bag, bag)
    broken = damage(bag)
    with pytest.raises(BagError) as info_error:
        bag_info(broken)
    assert str(broken) in str(info_error.value)
    with pytest.raises(BagError) as read_error:
        list(read_messages(broken))
    assert str(broken) in str(read_error.value)


@pytest.mark.tier("unit")
def test_unknown_type_without_definition_names_the_topic(tmp_path: Path) -> None:
    writer = Writer(tmp_path / "bag", version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    connection = writer.add_connection("/mystery", "other_pkg/msg/Mystery", msgdef="", rihs01="RIHS01_00")
    writer.write(connection, 1, b"\x00\x01\x00\x00")
    writer.close()
    assert bag_info(tmp_path / "bag").topic("/mystery").count == 1  # info needs no type knowledge
    with pytest.raises(BagError, match="/mystery.*other_pkg/msg/Mystery"):
        list(read_messages(tmp_path / "bag"))


@pytest.mark.tier("unit")
def test_foreign_type_decodes_from_the_definition_in_the_bag(tmp_path: Path) -> None:
    """A bag from another robot's packages: the type is in no installed package, only in the bag."""
    definition = "int32 value\nstring name\ngeometry_msgs/Point where"
    foreign = get_typestore(Stores.ROS2_JAZZY)
    foreign.register(get_types_from_msg(definition, "other_pkg/msg/Blip"))
    blip = foreign.types["other_pkg/msg/Blip"]
    point = foreign.types["geometry_msgs/msg/Point"]
    data = foreign.serialize_cdr(blip(value=42, name="x", where=point(x=1.0, y=2.0, z=3.0)), "other_pkg/msg/Blip")
    writer = Writer(tmp_path / "bag", version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    msgdef, _ = foreign.generate_msgdef("other_pkg/msg/Blip", ros_version=2)
    connection = writer.add_connection("/blip", "other_pkg/msg/Blip", msgdef=msgdef,
                                       rihs01=foreign.hash_rihs01("other_pkg/msg/Blip"))
    writer.write(connection, 5, data)
    writer.close()
    [(topic, stamp, message)] = list(read_messages(tmp_path / "bag"))
    assert (topic, stamp, message.value, message.name, message.where.z) == ("/blip", 5, 42, "x", 3.0)
    assert "other_pkg/msg/Blip" not in typestore().fielddefs, "a bag's definitions leaked into the shared store"


@pytest.mark.tier("unit")
def test_an_interface_package_is_parsed_once_per_content_and_a_torn_cache_is_parsed_again(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bags, "TYPES_CACHE", tmp_path / "cache")
    share = tmp_path / "share" / "blip_msgs"
    (share / "msg").mkdir(parents=True)
    (share / "msg" / "Blip.msg").write_text("int32 value\n")
    parsed = bags._package_types("blip_msgs", share)
    assert list(parsed) == ["blip_msgs/msg/Blip"]
    [cached] = (tmp_path / "cache").iterdir()
    monkeypatch.setattr(bags, "_parse_package_types", lambda *_: pytest.fail("parsed again"))
    assert bags._package_types("blip_msgs", share) == parsed
    monkeypatch.undo()
    monkeypatch.setattr(bags, "TYPES_CACHE", tmp_path / "cache")
    (share / "msg" / "Blip.msg").write_text("int32 value\nstring name\n")     # new content: a new entry
    assert len(bags._package_types("blip_msgs", share)["blip_msgs/msg/Blip"][1]) == 2
    assert len(list((tmp_path / "cache").iterdir())) == 2
    cached.write_bytes(cached.read_bytes()[:5])                              # torn: parsed, and rewritten
    (share / "msg" / "Blip.msg").write_text("int32 value\n")
    assert bags._package_types("blip_msgs", share) == parsed


@pytest.mark.tier("unit")
def test_topic_filter_of_the_readers(synthetic_bag: Path) -> None:
    raw = list(read_raw(synthetic_bag, ["/sim/markers", "/not_recorded"]))
    assert [(m.topic, m.msgtype, m.timestamp_ns) for m in raw] == [
        ("/sim/markers", "visualization_msgs/msg/MarkerArray", T0_NS)]
    assert raw[0].data == serialize_message(marker_message())
    assert list(read_messages(synthetic_bag, ["/not_recorded"])) == []
    odom = [(topic, stamp) for topic, stamp, _ in read_messages(synthetic_bag, ["/odom"])]
    assert odom == [("/odom", T0_NS + i * 100_000_000) for i in range(30)]


# ------------------------------------------------------------------------------------------- player

class Inbox:
    def __init__(self, ros: Ros, topics: dict[str, tuple[type, QoSProfile]]) -> None:
        self.received: dict[str, list[Any]] = {topic: [] for topic in topics}
        self.arrival: dict[str, list[float]] = {topic: [] for topic in topics}
        for topic, (cls, qos) in topics.items():
            ros.node.create_subscription(cls, topic, lambda m, t=topic: self.take(t, m), qos)

    def take(self, topic: str, message: Any) -> None:
        self.received[topic].append(message)
        self.arrival[topic].append(time.monotonic())


def play(ros: Ros, processes: Processes, params: dict[str, str], done: Callable[[], bool]) -> str:
    """Run the player to its end; spin this process until ``done`` holds (all expected messages in)."""
    player = processes.start("player", params)
    ros.spin_until(lambda: player.poll() is not None and done(), 30, "playback and delivery")
    log = processes.log_of(player)
    assert player.returncode == 0, log
    assert "playback finished" in log
    return log


def test_player_republishes_a_recording(ros: Ros, processes: Processes, recording: Recording) -> None:
    inbox = Inbox(ros, {"/rfid/reads": (TagReadArray, RECEIVE), "/odom": (Odometry, RECEIVE),
                        "/sim/markers": (MarkerArray, RECEIVE_LATCHED)})
    play(ros, processes, {"bag": str(recording.bag), "rate": "10.0",
                          "wait_for_subscribers": "[/rfid/reads,/odom,/sim/markers]"},
         lambda: len(inbox.received["/rfid/reads"]) >= N and len(inbox.received["/odom"]) >= N
         and len(inbox.received["/sim/markers"]) >= 1)
    reads = inbox.received["/rfid/reads"]
    assert len(reads) == N, "duplicates"
    assert [m.header.stamp.sec for m in reads] == list(range(N)), "out of order"
    assert reads == [reads_message(i) for i in range(N)], "contents changed on the way"
    assert [m.pose.pose.position.x for m in inbox.received["/odom"]] == pytest.approx([0.1 * i for i in range(N)])
    assert inbox.received["/sim/markers"] == [marker_message()]


def test_player_topic_filter(ros: Ros, processes: Processes, synthetic_bag: Path) -> None:
    inbox = Inbox(ros, {"/odom": (Odometry, RECEIVE), "/sim/markers": (MarkerArray, RECEIVE_LATCHED)})
    play(ros, processes, {"bag": str(synthetic_bag), "rate": "20.0", "topics": "[/odom]",
                          "wait_for_subscribers": "[/odom]"},
         lambda: len(inbox.received["/odom"]) >= 30)
    assert [m.pose.pose.position.x for m in inbox.received["/odom"]] == pytest.approx([0.1 * i for i in range(30)])
    ros.drain()  # had the player published /sim/markers, its exit waited for our ack: it would be here now
    assert inbox.received["/sim/markers"] == [], "a topic outside the filter was played"


def test_player_start_offset_clock_and_pacing(ros: Ros, processes: Processes, synthetic_bag: Path) -> None:
    inbox = Inbox(ros, {"/odom": (Odometry, RECEIVE), "/clock": (Clock, QoSProfile(depth=1000))})
    play(ros, processes, {"bag": str(synthetic_bag), "rate": "2.0", "start_s": "1.0", "clock": "true",
                          "clock_rate_hz": "50.0", "wait_for_subscribers": "[/odom,/clock]"},
         lambda: len(inbox.received["/odom"]) >= 20)
    xs = [m.pose.pose.position.x for m in inbox.received["/odom"]]
    assert xs == pytest.approx([0.1 * i for i in range(10, 30)]), "start_s did not skip the first second"
    # 1.9 s of bag at rate 2: the player sends the first and last message ~0.95 s apart. A loaded machine only
    # delays arrivals, the first one too (0.785 s apart was seen beside two busy DDS graphs), so the bound is
    # half of that; a player that does not pace sends all 20 within milliseconds.
    spread = inbox.arrival["/odom"][-1] - inbox.arrival["/odom"][0]
    assert spread > 0.5, f"not paced: 20 messages within {spread:.3f} s"
    clocks = [c.clock.sec * 1_000_000_000 + c.clock.nanosec for c in inbox.received["/clock"]]
    assert len(clocks) >= 10, "clock:=true published no /clock"
    assert clocks == sorted(clocks), "/clock went backwards"
    assert T0_NS + 1_000_000_000 <= clocks[0] < T0_NS + 1_300_000_000, "/clock does not start at the offset"
    assert clocks[-1] <= T0_NS + 3_100_000_000


def test_player_plays_a_split_bag_in_order(ros: Ros, processes: Processes, tmp_path: Path) -> None:
    messages = [("/odom", "nav_msgs/msg/Odometry", T0_NS + i * 10_000_000, serialize_message(odom_message(i)))
                for i in range(60)]
    write_bag(tmp_path / "bag", messages, options=StorageOptions(compression="zstd", max_bag_size=2048))
    assert len(bag_info(tmp_path / "bag").files) >= 3
    inbox = Inbox(ros, {"/odom": (Odometry, QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                                                         reliability=ReliabilityPolicy.RELIABLE))})
    play(ros, processes, {"bag": str(tmp_path / "bag"), "rate": "10.0", "wait_for_subscribers": "[/odom]"},
         lambda: len(inbox.received["/odom"]) >= 60)
    assert [m.pose.pose.position.x for m in inbox.received["/odom"]] == pytest.approx([0.1 * i for i in range(60)])


@pytest.mark.tier("unit")
def test_replay_of_a_topic_the_bag_lacks_is_refused_in_one_line_before_a_domain_is_leased(synthetic_bag: Path) -> None:
    # In its own process, as a user runs it: "replaying BAG on ROS domain N" is printed once the domain is leased.
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "replay", str(synthetic_bag), "--topics",
                             "/odom", "/nope"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2 and "Traceback" not in result.stderr and "replaying" not in result.stderr
    assert result.stderr.strip().splitlines() == [
        f"rfidnav replay: --topics: /nope not in bag {synthetic_bag} (it has /odom, /sim/markers)"]


def test_player_rejects_a_topic_the_bag_lacks(processes: Processes, synthetic_bag: Path) -> None:
    player = processes.start("player", {"bag": str(synthetic_bag), "topics": "[/odom,/nope]"})
    assert processes.wait(player, 20) == 2
    assert "/nope not in bag" in processes.log_of(player)
