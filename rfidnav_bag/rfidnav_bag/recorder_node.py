"""recorder: record every topic of the graph into a rosbag2 directory with MCAP storage.

The wheels ship no rosbag2, so this node is the suite's ``ros2 bag record -a``:

- it polls the graph (``discovery_period_s``, wall time) and subscribes to every topic that has a publisher,
  hidden action topics (``/x/_action/feedback``, ``/x/_action/status``) and /rosout included, except
  ``exclude_topics``;
- subscriptions are raw (CDR bytes straight into the bag, nothing deserialised) with QoS adapted to the
  publishers the way rosbag2 does it: reliable only if every publisher is reliable, transient local only if
  every publisher is transient local (a durable subscription does not match a volatile publisher, so "any"
  would lose the volatile ones), KEEP_LAST 1000 so a slow disk or a burst drops nothing. A publisher that
  appears later with weaker QoS makes the recorder re-subscribe with the weaker profile;
- the MCAP schema records carry each type's full message definition (from ``bags.typestore()``), so the
  bag decodes in Foxglove, with ``mcap_ros2`` or with rosbags without rfidnav installed;
- the files are written by :mod:`rfidnav_bag.writer` in rosbag2's layout (``bag/bag_0.mcap``, ...), chunks
  compressed with zstd if ``compression`` says so, split into several files by ``max_bag_size`` or
  ``max_bag_duration_s`` (``ros2 bag record --max-bag-size`` / ``--max-bag-duration``);
- every ``checkpoint_period_s`` (wall time) the chunk in progress is written and metadata.yaml brought up to
  date, so a recorder that is killed loses at most that, or a second of bag time (the writer's chunk bound).

Timestamps are the node clock at reception. Runs use ``use_sim_time``, so bag time is sim time; a message
that arrives before the first /clock is stamped 0 (the ROS time of a sim-time node with no clock yet).

Stopping: SIGINT, SIGTERM or SIGHUP stops recording, drains what DDS already delivered to this process (for
at most DRAIN_LIMIT_S; a second signal ends the drain at once), then finalises the bag (MCAP summary and
metadata.yaml); exit 0. rclpy's own handlers are not installed because they shut the context down at once,
which would drop the messages still queued in the subscriptions. A recorder whose orchestrator died gets SIGINT
from the kernel (the orchestrator sets the parent-death signal) and finalises the same way.

Disk full (or over quota, an I/O error, a file over the size limit): the first write the disk refuses ends the
recording. The recorder logs one ERROR line saying so and what the bag still holds, closes what it can (the
chunks already written stay readable, metadata.yaml lists them if the disk still takes it) and exits with
WRITE_FAILED_EXIT (3), which the orchestrator reports as the recorder's exit.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from rfidnav_bag.bags import clock_stamp_ns, message_definition, register_installed_type
from rfidnav_bag.errors import BagError, BagWriteError
from rfidnav_bag.writer import COMPRESSIONS, MIN_SPLIT_SIZE, BagWriter, StorageOptions, Topic
from rfidnav_common.config import param
from rfidnav_common.errors import ConfigError, ParameterError
from rfidnav_common.ros import declare_parameters, events_executor, message_class, run_node, stop_requested
from rfidnav_common.stepped_node import SteppedNode

RECORD_DEPTH = 1000
WRITE_FAILED_EXIT = 3  # the exit code of a recorder stopped by a write the disk refused
DRAIN_IDLE_S = 0.05  # stop draining once a wait this long delivered nothing
DRAIN_LIMIT_S = 2.0


@dataclass(frozen=True)
class RecorderParameters:
    output_dir: str = param("rosbag2 directory to create (must not exist)", "")
    exclude_topics: list[str] = param("topics not to record (exact names)", [])
    discovery_period_s: float = param("wall-time period of the graph poll for new topics [s]", 0.2)
    stamp_from_clock_topic: bool = param(
        "stamp messages with the latest recorded /clock (0 before the first) instead of the node clock: "
        "sim time without a second /clock subscription, which costs a callback per clock tick", False)
    compression: str = param("chunk compression of the MCAP files: none or zstd (rosbag2's MCAP storage "
                             "config 'compression: Zstd'); the files stay indexed and open in every reader", "none")
    max_bag_size: int = param("start the next file (bag_1.mcap, ...) once the current one holds this many bytes; "
                              f"0: one file, else at least {MIN_SPLIT_SIZE} (ros2 bag record --max-bag-size)", 0)
    max_bag_duration_s: float = param(
        "start the next file when a message is stamped more than this many seconds (bag time: sim time in a "
        "simulated run) after the current file's first; 0: never (ros2 bag record --max-bag-duration)", 0.0)
    checkpoint_period_s: float = param(
        "wall-time period of writing the chunk in progress and rewriting metadata.yaml [s]: what a killed "
        "recorder can lose beyond the writer's bound of a second of bag time", 1.0)

    def validate(self) -> None:
        if not self.output_dir:
            raise ParameterError("output_dir", "required (the rosbag2 directory to create)")
        if Path(self.output_dir).exists():
            raise ParameterError("output_dir", f"{self.output_dir} exists already; a bag is never overwritten")
        if not self.discovery_period_s > 0.0:
            raise ParameterError("discovery_period_s", f"must be > 0, got {self.discovery_period_s}")
        if self.compression not in COMPRESSIONS:
            raise ParameterError("compression", f"must be one of {', '.join(COMPRESSIONS)}, got '{self.compression}'")
        if self.max_bag_size != 0 and self.max_bag_size < MIN_SPLIT_SIZE:
            raise ParameterError("max_bag_size", f"must be 0 (one file) or at least {MIN_SPLIT_SIZE} bytes, "
                                 f"got {self.max_bag_size}")
        if not self.max_bag_duration_s >= 0.0:
            raise ParameterError("max_bag_duration_s", f"must be >= 0 (0: no split), got {self.max_bag_duration_s}")
        if not self.checkpoint_period_s > 0.0:
            raise ParameterError("checkpoint_period_s", f"must be > 0, got {self.checkpoint_period_s}")

    def storage_options(self) -> StorageOptions:
        return StorageOptions(compression=self.compression, max_bag_size=self.max_bag_size,
                              max_bag_duration_ns=round(self.max_bag_duration_s * 1e9))


def recordable_definition(msgtype: str) -> tuple[str, str]:
    """(definition, RIHS01 hash) that the bag embeds for ``msgtype``; a BagError saying why a topic of this
    type cannot be recorded (no Python class installed, no definition to make the bag self-describing)."""
    if message_class(msgtype) is None:
        raise BagError(f"its type {msgtype} has no Python message module installed")
    if not register_installed_type(msgtype):
        raise BagError(f"no message definition found for {msgtype} (needed to make the bag self-describing)")
    return message_definition(msgtype)


def _qos_time(duration: Any) -> QosTime:
    seconds, nanoseconds = divmod(int(duration.nanoseconds), 1_000_000_000)
    return QosTime(seconds, nanoseconds)


def to_bag_qos(profile: QoSProfile) -> Qos:
    """An offered rclpy QoS profile in rosbags' form (rosbag2 metadata). DDS discovery does not carry
    history and depth, so publishers show up as history 'unknown', depth 0 -- as in rosbag2's own bags."""
    def member(enum: Any, policy: Any, unknown: Any) -> Any:
        return enum.__members__.get(getattr(policy, "name", ""), unknown)

    return Qos(
        history=member(QosHistory, profile.history, QosHistory.UNKNOWN),
        depth=int(profile.depth),
        reliability=member(QosReliability, profile.reliability, QosReliability.UNKNOWN),
        durability=member(QosDurability, profile.durability, QosDurability.UNKNOWN),
        deadline=_qos_time(profile.deadline),
        lifespan=_qos_time(profile.lifespan),
        liveliness=member(QosLiveliness, profile.liveliness, QosLiveliness.UNKNOWN),
        liveliness_lease_duration=_qos_time(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )


def subscription_qos(offered: list[QoSProfile]) -> QoSProfile:
    """The QoS that matches every offered profile and loses nothing any of them would deliver."""
    reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
    latched = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=RECORD_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def _weaker(current: QoSProfile, needed: QoSProfile) -> bool:
    """Whether ``needed`` asks less than ``current``: then some publisher does not match ``current``."""
    return ((current.reliability == ReliabilityPolicy.RELIABLE and needed.reliability != current.reliability)
            or (current.durability == DurabilityPolicy.TRANSIENT_LOCAL and needed.durability != current.durability))


def _describe(qos: QoSProfile) -> str:
    return f"{qos.reliability.name.lower()}, {qos.durability.name.lower()}"


class RecorderNode(SteppedNode):
    # With the stepped clock it may lag: what it has not written yet changes nothing the loop sees, and half the
    # publishers' queue (SENSOR_QOS, 100) still leaves room before a message could be lost.
    step_slack = 50

    def __init__(self) -> None:
        super().__init__("recorder")
        self.params: RecorderParameters = declare_parameters(self, RecorderParameters)
        self.excluded = set(self.params.exclude_topics)
        self.message_count = 0
        self.connections: dict[str, Topic] = {}
        self.recorded_qos: dict[str, QoSProfile] = {}
        self.publisher_counts: dict[str, int] = {}
        self.topic_subscriptions: dict[str, Subscription] = {}
        self.unrecordable: set[str] = set()  # topics already reported as impossible to record
        self.exit_code = 0  # WRITE_FAILED_EXIT once the disk refused a write: recording is over
        self.clock_ns = 0  # latest /clock seen, when stamping from the clock topic
        self.writer = BagWriter(self.params.output_dir, self.params.storage_options())
        try:
            self.writer.open()
        except (BagError, OSError) as error:
            raise ConfigError(f"parameters of node '{self.get_fully_qualified_name()}'", "output_dir",
                              f"cannot create the bag: {error}") from error
        # Wall (steady) time: with use_sim_time a ROS-time timer would not tick before the first /clock.
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        self.discovery_timer = self.create_timer(self.params.discovery_period_s, self.discover, clock=wall)
        self.checkpoint_timer = self.create_timer(self.params.checkpoint_period_s, self.checkpoint, clock=wall)
        self.get_logger().info(f"recording into {self.params.output_dir}")

    # -- discovery ------------------------------------------------------------------------------------

    def discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self.excluded or topic in self.unrecordable:
                continue
            publishers = self.count_publishers(topic)
            if publishers == self.publisher_counts.get(topic, 0):
                continue  # nothing changed since the last poll
            self.publisher_counts[topic] = publishers
            if publishers == 0:
                continue  # only subscribers, or the publishers left: nothing to record (yet)
            if topic in self.topic_subscriptions:
                self.adapt(topic)
            else:
                self.add_topic(topic, types)

    def offered_profiles(self, topic: str) -> list[QoSProfile]:
        return [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]

    def add_topic(self, topic: str, types: list[str]) -> None:
        msgtype = types[0]
        if len(types) > 1:
            self.get_logger().warning(f"{topic} is published with several types {types}; recording {msgtype}")
        try:
            definition, rihs01 = recordable_definition(msgtype)
        except BagError as error:
            self.skip(topic, str(error))
            return
        offered = self.offered_profiles(topic)
        if not offered:  # the publisher left between the count and the query: look again next poll
            self.publisher_counts.pop(topic, None)
            return
        qos = subscription_qos(offered)
        try:
            recorded = self.writer.add_topic(topic, msgtype, definition, rihs01,
                                             tuple(to_bag_qos(q) for q in offered))
        except (BagError, OSError) as error:
            self.skip(topic, f"the bag refused the topic: {error}")
            return
        self.connections[topic] = recorded
        self.subscribe(topic, message_class(msgtype), qos)
        self.get_logger().info(f"recording {topic} [{msgtype}] ({_describe(qos)})")

    def adapt(self, topic: str) -> None:
        """A publisher joined: re-subscribe if it offers less than the current subscription requests."""
        offered = self.offered_profiles(topic)
        if not offered:
            self.publisher_counts.pop(topic, None)
            return
        needed = subscription_qos(offered)
        current = self.recorded_qos[topic]
        if not _weaker(current, needed):
            return
        self.get_logger().warning(f"{topic}: a publisher offers only {_describe(needed)}; re-subscribing "
                                  f"(was {_describe(current)})")
        cls = self.topic_subscriptions[topic].msg_type
        self.destroy_subscription(self.topic_subscriptions.pop(topic))
        self.subscribe(topic, cls, needed)

    def subscribe(self, topic: str, cls: type, qos: QoSProfile) -> None:
        recorded = self.connections[topic]
        self.topic_subscriptions[topic] = self.create_subscription(
            cls, topic, lambda data, r=recorded: self.write(r, data), qos, raw=True)
        self.recorded_qos[topic] = qos

    def skip(self, topic: str, why: str) -> None:
        self.unrecordable.add(topic)
        self.get_logger().error(f"not recording {topic}: {why}")

    # -- writing --------------------------------------------------------------------------------------

    def write(self, recorded: Topic, data: bytes) -> None:
        if self.params.stamp_from_clock_topic:
            clock_ns = clock_stamp_ns(data) if recorded.name == "/clock" else None
            if clock_ns is not None:
                self.clock_ns = clock_ns
            stamp_ns = self.clock_ns
        else:
            stamp_ns = self.get_clock().now().nanoseconds
        if self.exit_code:
            return  # recording stopped: what still arrives until the process ends is not recorded
        try:
            self.writer.write(recorded, stamp_ns, data)
        except BagWriteError as error:
            self.stop_recording(error)
            return
        self.message_count += 1

    def checkpoint(self) -> None:
        if self.exit_code:
            return
        try:
            self.writer.checkpoint()
        except BagWriteError as error:
            self.stop_recording(error)

    def stop_recording(self, error: BagWriteError) -> None:
        """The disk refused a write: the writer has closed what it could; say so once, and end the process."""
        self.exit_code = WRITE_FAILED_EXIT
        self.stop_timers()
        self.get_logger().error(str(error))

    def stop_timers(self) -> None:
        self.discovery_timer.cancel()
        self.checkpoint_timer.cancel()

    def destroy_node(self) -> None:
        try:
            self.close()
        finally:
            super().destroy_node()

    def close(self) -> int:
        """Finalise the bag (MCAP summary, then metadata.yaml); the exit code. Safe to call twice."""
        if self.writer.finished:
            return self.exit_code
        try:
            self.writer.close()
        except BagWriteError as error:
            self.stop_recording(error)
            return self.exit_code
        files = len(self.writer.files)
        self.get_logger().info(f"bag closed: {self.message_count} messages on {len(self.connections)} topics "
                               f"in {self.params.output_dir} ({files} file{'s' if files > 1 else ''})")
        return self.exit_code


def _drain(executor: Executor, node: RecorderNode) -> None:
    """Record what already reached this process: spin until a short wait delivers nothing (bounded by
    DRAIN_LIMIT_S: repeated signals do not cut it short, since a dying parent sends one per thread)."""
    deadline = time.monotonic() + DRAIN_LIMIT_S
    while time.monotonic() < deadline and not node.exit_code:
        before = node.message_count
        executor.spin_once(timeout_sec=DRAIN_IDLE_S)
        if node.message_count == before:
            return


def spin_until_stopped(executor: Executor, node: RecorderNode) -> int:
    """Record until SIGINT, SIGTERM or SIGHUP (rfidnav_common.ros.stop_requested), shutdown or a write the disk
    refused, then what already reached this process; finalise the bag. The exit code: 0, or WRITE_FAILED_EXIT."""
    while not stop_requested() and not node.exit_code and rclpy.ok(context=node.context):
        # Bounded waits: a Python signal handler runs only when control returns from the executor.
        executor.spin_once(timeout_sec=0.1)
    node.stop_timers()
    _drain(executor, node)
    return node.close()


def main(args: list[str] | None = None) -> int:
    """rfidnav_common.ros.run_node with its own spin: a stop drains before the bag closes."""
    return run_node(RecorderNode, args, events_executor, spin_until_stopped)


if __name__ == "__main__":
    raise SystemExit(main())
