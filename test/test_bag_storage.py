"""How bags are stored: rosbag2's layout and file names, splitting by size and by duration, zstd chunk compression.

The bags are written with the recorder's writer (rfidnav_bag.writer) straight from serialised messages, no graph,
and read back with rosbags (our readers), with mcap's own readers file by file (Foxglove's path), and with
rosbags' AnyReader, which checks each schema's text against the RIHS01 hash the bag records.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosgraph_msgs.msg import Clock

from rfidnav_bag.bags import bag_info, format_bag_info, message_definition, read_raw
from rfidnav_bag.writer import MIN_SPLIT_SIZE, BagWriter, StorageOptions

pytestmark = pytest.mark.tier("unit")

NEVER = QosTime(0, 0)
QOS = (Qos(QosHistory.UNKNOWN, 0, QosReliability.RELIABLE, QosDurability.VOLATILE, NEVER, NEVER,
           QosLiveliness.AUTOMATIC, NEVER, False),)
STEP_NS = 10_000_000  # 100 Hz
T0_NS = 5_000_000_000
ODOM = "nav_msgs/msg/Odometry"
CLOCK = "rosgraph_msgs/msg/Clock"

Message = tuple[str, int, bytes]  # topic, timestamp, CDR


def odometry(i: int) -> bytes:
    """An odometry message as a robot would send it: a pose that moves, covariances that barely change."""
    message = Odometry(child_frame_id="base_link")
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(T0_NS + i * STEP_NS, 1_000_000_000)
    message.header.frame_id = "odom"
    message.pose.pose.position.x = 0.01 * i
    message.pose.pose.position.y = math.sin(i / 50)
    message.pose.pose.orientation.z, message.pose.pose.orientation.w = math.sin(i / 100), math.cos(i / 100)
    message.pose.covariance = [0.001 * (i % 7)] * 36
    message.twist.twist.linear.x = 0.2
    message.twist.twist.angular.z = 0.1 * math.cos(i / 30)
    return serialize_message(message)


def clock(i: int) -> bytes:
    message = Clock()
    message.clock.sec, message.clock.nanosec = divmod(T0_NS + i * STEP_NS, 1_000_000_000)
    return serialize_message(message)


def write(path: Path, options: StorageOptions, count: int) -> list[Message]:
    """``count`` rounds of /clock then /odom, 10 ms apart, through the recorder's writer; what was written."""
    writer = BagWriter(path, options)
    writer.open()
    topics = {name: writer.add_topic(name, msgtype, *message_definition(msgtype), QOS)
              for name, msgtype in (("/clock", CLOCK), ("/odom", ODOM))}
    written: list[Message] = []
    for i in range(count):
        stamp = T0_NS + i * STEP_NS
        for name, data in (("/clock", clock(i)), ("/odom", odometry(i))):
            writer.write(topics[name], stamp, data)
            written.append((name, stamp, data))
    writer.close()
    return written


def information(bag: Path) -> dict:
    return yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


def in_time_order(messages) -> list[Message]:
    """Messages as a reader in log-time order may give them: /clock and /odom of one round share a stamp, and when
    a chunk ends between the two (chunks also end on the wall clock's checkpoints) a reader may give either first."""
    return sorted((tuple(m) for m in messages), key=lambda m: (m[-2], m[0]))


def mcap_messages(mcap_file: Path) -> list[Message]:
    with mcap_file.open("rb") as stream:
        return [(channel.topic, message.log_time, message.data)
                for _, channel, message in make_reader(stream).iter_messages(log_time_order=True)]


def chunk_compressions(mcap_file: Path) -> list[str]:
    """The compression field of every Chunk record in the file, read record by record."""
    with mcap_file.open("rb") as stream:
        return [record.compression for record in StreamReader(stream, emit_chunks=True).records
                if isinstance(record, Chunk)]


def test_a_bag_is_named_as_rosbag2_names_it_and_says_jazzy(tmp_path: Path) -> None:
    written = write(tmp_path / "bag", StorageOptions(), 50)
    assert sorted(p.name for p in (tmp_path / "bag").iterdir()) == ["bag_0.mcap", "metadata.yaml"]
    meta = information(tmp_path / "bag")
    assert meta["ros_distro"] == "jazzy" and meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["relative_file_paths"] == ["bag_0.mcap"]
    assert meta["files"] == [{"path": "bag_0.mcap", "starting_time": {"nanoseconds_since_epoch": T0_NS},
                              "duration": {"nanoseconds": 49 * STEP_NS}, "message_count": 100}]
    assert {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]} == {
        "/clock": 50, "/odom": 50}
    assert (meta["compression_format"], meta["compression_mode"]) == ("", "")
    assert [tuple(m) for m in read_raw(tmp_path / "bag")] == [(t, ODOM if t == "/odom" else CLOCK, s, d)
                                                              for t, s, d in written]
    with (tmp_path / "bag" / "bag_0.mcap").open("rb") as stream:
        reader = make_reader(stream)
        header = reader.get_header()
        metadata = {record.name: record.metadata for record in reader.iter_metadata()}
        channels = {c.topic: c.metadata for c in reader.get_summary().channels.values()}
    assert header.profile == "ros2"
    assert yaml.safe_load(metadata["rosbag2"]["serialized_metadata"])["message_count"] == 100
    assert channels["/odom"]["topic_type_hash"] == message_definition(ODOM)[1]
    assert yaml.safe_load(channels["/odom"]["offered_qos_profiles"])[0]["reliability"] == "reliable"


def test_a_bag_split_by_size_reads_back_every_message_once_in_order(tmp_path: Path) -> None:
    max_size = 64 * 1024
    written = write(tmp_path / "bag", StorageOptions(max_bag_size=max_size), 1500)
    files = sorted((tmp_path / "bag").glob("*.mcap"), key=lambda p: int(p.stem.rsplit("_", 1)[1]))
    assert len(files) >= 5, "1500 rounds (~1.2 MB) in 64 KiB files"
    assert [p.name for p in files] == [f"bag_{i}.mcap" for i in range(len(files))]
    meta = information(tmp_path / "bag")
    assert meta["relative_file_paths"] == [p.name for p in files]
    assert meta["message_count"] == len(written) == sum(f["message_count"] for f in meta["files"])
    for entry, path in zip(meta["files"], files):
        # A file ends at the first chunk past the size: chunks are a quarter of it; the summary adds a little.
        assert path.stat().st_size < 1.25 * max_size + 16 * 1024, path
        with path.open("rb") as stream:
            statistics = make_reader(stream).get_summary().statistics
        assert entry["message_count"] == statistics.message_count > 0
        assert entry["starting_time"]["nanoseconds_since_epoch"] == statistics.message_start_time
        assert entry["duration"]["nanoseconds"] == statistics.message_end_time - statistics.message_start_time
    # ours (rosbags, all files in turn) and mcap's (one file after the other) return exactly what was written
    read_back = in_time_order([(m.topic, m.timestamp_ns, m.data) for m in read_raw(tmp_path / "bag")])
    assert read_back == in_time_order(written)
    assert in_time_order([m for path in files for m in mcap_messages(path)]) == in_time_order(written)
    with AnyReader([tmp_path / "bag"]) as reader:
        assert in_time_order([(c.topic, t, bytes(d)) for c, t, d in reader.messages()]) == in_time_order(written)
    info = bag_info(tmp_path / "bag")
    assert info.message_count == len(written) and [f.path for f in info.files] == files
    assert info.topic("/odom").count == 1500
    table = format_bag_info(info)
    assert f"Files:            {len(files)}" in table and "bag_1.mcap" in table


def test_a_bag_split_by_duration_keeps_each_file_within_the_duration(tmp_path: Path) -> None:
    max_ns = 2_000_000_000
    written = write(tmp_path / "bag", StorageOptions(max_bag_duration_ns=max_ns), 1000)   # 9.99 s
    meta = information(tmp_path / "bag")
    starts = [f["starting_time"]["nanoseconds_since_epoch"] for f in meta["files"]]
    assert len(meta["files"]) == 5, meta["files"]
    assert all(f["duration"]["nanoseconds"] <= max_ns for f in meta["files"])
    # each next file was opened by a message more than the duration after the previous file's first
    assert all(later - earlier > max_ns for earlier, later in zip(starts, starts[1:]))
    read_back = in_time_order([(m.topic, m.timestamp_ns, m.data) for m in read_raw(tmp_path / "bag")])
    assert read_back == in_time_order(written)


def test_zstd_compressed_chunks_are_smaller_and_read_everywhere(tmp_path: Path) -> None:
    plain = write(tmp_path / "plain", StorageOptions(), 1500)
    written = write(tmp_path / "zstd", StorageOptions(compression="zstd"), 1500)
    assert written == plain
    plain_file, zstd_file = tmp_path / "plain" / "plain_0.mcap", tmp_path / "zstd" / "zstd_0.mcap"
    assert set(chunk_compressions(plain_file)) == {""}
    compressions = chunk_compressions(zstd_file)
    assert len(compressions) >= 2 and set(compressions) == {"zstd"}
    assert zstd_file.stat().st_size < 0.5 * plain_file.stat().st_size, "zstd should at least halve odometry"
    meta = information(tmp_path / "zstd")
    assert (meta["compression_format"], meta["compression_mode"]) == ("", ""), "as rosbag2 for chunk compression"
    read_back = in_time_order([(m.topic, m.timestamp_ns, m.data) for m in read_raw(tmp_path / "zstd")])
    assert read_back == in_time_order(written)
    assert in_time_order(mcap_messages(zstd_file)) == in_time_order(written)
    with zstd_file.open("rb") as stream:
        decoded = [m for _, _, _, m in make_reader(stream, decoder_factories=[DecoderFactory()])
                   .iter_decoded_messages(topics=["/odom"])]
    assert [m.pose.pose.position.x for m in decoded] == pytest.approx([0.01 * i for i in range(1500)])
    assert bag_info(tmp_path / "zstd").compression == "zstd"
    assert bag_info(tmp_path / "plain").compression == "none"


def test_a_split_compressed_bag_is_both(tmp_path: Path) -> None:
    written = write(tmp_path / "bag", StorageOptions(compression="zstd", max_bag_size=16 * 1024), 1500)
    info = bag_info(tmp_path / "bag")
    assert len(info.files) >= 3 and {f.compression for f in info.files} == {"zstd"}
    read_back = in_time_order([(m.topic, m.timestamp_ns, m.data) for m in read_raw(tmp_path / "bag")])
    assert read_back == in_time_order(written)


def test_a_bag_that_was_never_written_to_has_one_empty_file(tmp_path: Path) -> None:
    writer = BagWriter(tmp_path / "bag", StorageOptions(max_bag_size=MIN_SPLIT_SIZE))
    writer.open()
    writer.add_topic("/odom", ODOM, *message_definition(ODOM), QOS)
    writer.close()
    writer.close()   # twice is harmless
    info = bag_info(tmp_path / "bag")
    assert info.message_count == 0 and [f.path.name for f in info.files] == ["bag_0.mcap"]
    assert info.topic("/odom").count == 0
