"""Writing rosbag2 directories with MCAP storage, the way rosbag2's SequentialWriter and its MCAP plugin do.

No rclpy here (the recorder node feeds it raw CDR). The wheels ship no rosbag2, and rosbags' Writer writes one
file named ``NAME.mcap`` and cannot split, so the files are written with the ``mcap`` library and the
metadata here, in rosbag2's Jazzy layout (metadata version 9):

- ``NAME/metadata.yaml`` and ``NAME/NAME_0.mcap``, ``NAME_1.mcap``, ... (rosbag2's file names);
- every file is a complete MCAP (profile ``ros2``, chunks with message indexes, summary with schemas, channels,
  statistics and chunk indexes) in which every topic recorded so far is registered again, as rosbag2 does
  on a split, so each file decodes on its own (Foxglove opens one file at a time); channels carry
  ``offered_qos_profiles`` and ``topic_type_hash`` metadata, and each file ends with a ``rosbag2`` metadata
  record holding the bag's metadata so far, as rosbag2's MCAP plugin writes them;
- compression is the MCAP plugin's storage-level kind (rosbag2: ``compression: Zstd`` in the storage config):
  chunks compressed with zstd, the files still indexed. ``compression_format`` and ``compression_mode`` in
  metadata.yaml stay empty as rosbag2 leaves them, because they announce rosbag2's own file or message
  compression, which a reader would have to undo before the storage plugin could read the files; the chunk
  records name their compression;
- splitting follows rosbag2: before a message is written, the next file is started if the current one has
  reached ``max_bag_size`` bytes or the message is more than ``max_bag_duration_ns`` after the file's first.
  A file grows a chunk at a time, so with splitting by size chunks are at most a quarter of the limit: a file
  ends at most a chunk and its summary past it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import yaml
from mcap.well_known import MessageEncoding, Profile, SchemaEncoding
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.interfaces import Qos

from rfidnav_bag.errors import BagError

__all__ = ["COMPRESSIONS", "MIN_SPLIT_SIZE", "BagWriter", "StorageOptions", "Topic"]

BAG_VERSION = 9  # what Jazzy's rosbag2 writes (structured QoS in metadata.yaml)
ROS_DISTRO = "jazzy"  # the distribution of the rclpy wheels the recorder runs on
CHUNK_SIZE = 768 * 1024  # libmcap's default chunk size, which rosbag2's MCAP plugin keeps
MIN_SPLIT_SIZE = 1024  # rosbag2's MCAP plugin refuses smaller max_bagfile_size values
COMPRESSIONS = {"none": CompressionType.NONE, "zstd": CompressionType.ZSTD}
LIBRARY = f"rfidnav_bag ({LIBRARY_IDENTIFIER})"


@dataclass(frozen=True)
class StorageOptions:
    """How a bag is stored: chunk compression (a key of COMPRESSIONS) and when to start the next file (0: never).
    The recorder validates them (RecorderParameters)."""

    compression: str = "none"
    max_bag_size: int = 0  # [bytes]
    max_bag_duration_ns: int = 0  # [ns of bag time]


@dataclass(frozen=True)
class Topic:
    """A recorded topic (rosbag2's topic metadata) and the message definition its schema carries."""

    id: int
    name: str
    msgtype: str
    definition: str  # ros2msg text with every nested type
    rihs01: str
    offered_qos: tuple[Qos, ...]
    serialization_format: str = MessageEncoding.CDR


@dataclass
class _File:
    """The MCAP file being written and what metadata.yaml says about it."""

    path: Path
    stream: BinaryIO
    mcap: McapWriter
    channels: dict[int, int] = field(default_factory=dict)  # Topic.id -> channel id in this file
    schemas: dict[str, int] = field(default_factory=dict)  # msgtype -> schema id in this file
    start_ns: int = 0
    end_ns: int = 0
    message_count: int = 0

    def document(self) -> dict[str, Any]:
        return {"path": self.path.name, "starting_time": {"nanoseconds_since_epoch": self.start_ns},
                "duration": {"nanoseconds": self.end_ns - self.start_ns}, "message_count": self.message_count}


def _qos_document(qos: Qos) -> dict[str, Any]:
    """One offered profile as metadata version 9 writes it."""
    def time(value: Any) -> dict[str, int]:
        return {"sec": value.sec, "nsec": value.nsec}

    return {"history": qos.history.name.lower(), "depth": qos.depth, "reliability": qos.reliability.name.lower(),
            "durability": qos.durability.name.lower(), "deadline": time(qos.deadline),
            "lifespan": time(qos.lifespan), "liveliness": qos.liveliness.name.lower(),
            "liveliness_lease_duration": time(qos.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": qos.avoid_ros_namespace_conventions}


def _dump(document: Any) -> str:
    return yaml.safe_dump(document, sort_keys=False, default_flow_style=False)


class BagWriter:
    """Create a rosbag2 directory at ``path`` (it must not exist): ``open``, ``add_topic``, ``write``, ``close``."""

    def __init__(self, path: str | Path, options: StorageOptions = StorageOptions()) -> None:
        self.path = Path(path)
        self.options = options
        self.topics: list[Topic] = []
        self.counts: dict[int, int] = {}  # Topic.id -> messages written
        self.closed_files: list[_File] = []
        self.current: _File | None = None
        self.finished = False  # metadata.yaml written
        self.chunk_size = min(CHUNK_SIZE, options.max_bag_size // 4) if options.max_bag_size else CHUNK_SIZE

    # -- files ------------------------------------------------------------------------------------------

    def open(self) -> None:
        try:
            self.path.mkdir(parents=True)
        except FileExistsError:
            raise BagError(f"{self.path} exists already; a bag is never overwritten") from None
        self.current = self._start_file()

    def _start_file(self) -> _File:
        path = self.path / f"{self.path.name}_{len(self.closed_files)}.mcap"
        stream = path.open("xb")
        writer = McapWriter(stream, chunk_size=self.chunk_size, compression=COMPRESSIONS[self.options.compression])
        writer.start(profile=Profile.ROS2, library=LIBRARY)
        file = _File(path, stream, writer)
        for topic in self.topics:
            self._register(file, topic)
        return file

    def _register(self, file: _File, topic: Topic) -> None:
        if topic.msgtype not in file.schemas:
            file.schemas[topic.msgtype] = file.mcap.register_schema(topic.msgtype, SchemaEncoding.ROS2,
                                                                    topic.definition.encode())
        file.channels[topic.id] = file.mcap.register_channel(
            topic.name, topic.serialization_format, file.schemas[topic.msgtype],
            {"offered_qos_profiles": _dump([_qos_document(q) for q in topic.offered_qos]),
             "topic_type_hash": topic.rihs01})

    def _finish_current(self) -> None:
        file = self.current
        assert file is not None
        file.mcap.add_metadata("rosbag2", {"serialized_metadata": _dump(self._information())})
        file.mcap.finish()
        file.stream.close()
        self.closed_files.append(file)
        self.current = None

    def _should_split(self, file: _File, timestamp_ns: int) -> bool:
        if not file.message_count:
            return False
        by_size = self.options.max_bag_size and file.stream.tell() >= self.options.max_bag_size
        by_duration = (self.options.max_bag_duration_ns
                       and timestamp_ns - file.start_ns > self.options.max_bag_duration_ns)
        return bool(by_size or by_duration)

    # -- topics and messages ----------------------------------------------------------------------------

    def add_topic(self, name: str, msgtype: str, definition: str, rihs01: str,
                  offered_qos: tuple[Qos, ...] = ()) -> Topic:
        """A topic to write messages of; its schema and channel go into the current file and every later one."""
        if self.current is None:
            raise BagError(f"{self.path}: the bag is not open")
        if any(t.name == name for t in self.topics):
            raise BagError(f"{self.path}: topic {name} is recorded already")
        topic = Topic(len(self.topics) + 1, name, msgtype, definition, rihs01, tuple(offered_qos))
        self.topics.append(topic)
        self.counts[topic.id] = 0
        self._register(self.current, topic)
        return topic

    def write(self, topic: Topic, timestamp_ns: int, data: bytes) -> None:
        """One serialised message, stamped ``timestamp_ns`` (its log and publish time); OSError if the disk
        refuses it."""
        file = self.current
        if file is None:
            raise BagError(f"{self.path}: the bag is not open (or its next file could not be created)")
        if self._should_split(file, timestamp_ns):
            self._finish_current()
            file = self.current = self._start_file()
        file.mcap.add_message(file.channels[topic.id], log_time=timestamp_ns, data=data, publish_time=timestamp_ns)
        if not file.message_count:
            file.start_ns = file.end_ns = timestamp_ns
        file.start_ns = min(file.start_ns, timestamp_ns)
        file.end_ns = max(file.end_ns, timestamp_ns)
        file.message_count += 1
        self.counts[topic.id] += 1

    # -- metadata ---------------------------------------------------------------------------------------

    @property
    def files(self) -> list[_File]:
        return self.closed_files + ([self.current] if self.current is not None else [])

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    def _information(self) -> dict[str, Any]:
        """``rosbag2_bagfile_information``: the whole bag so far, in rosbag2's order of keys."""
        files = [f for f in self.files if f.message_count]
        start = min((f.start_ns for f in files), default=0)
        end = max((f.end_ns for f in files), default=0)
        return {
            "version": BAG_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": end - start},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": self.message_count,
            "topics_with_message_count": [
                {"topic_metadata": {"name": t.name, "type": t.msgtype, "serialization_format": t.serialization_format,
                                    "offered_qos_profiles": [_qos_document(q) for q in t.offered_qos],
                                    "type_description_hash": t.rihs01},
                 "message_count": self.counts[t.id]}
                for t in self.topics],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f.path.name for f in self.files],
            "files": [f.document() for f in self.files],
            "custom_data": None,
            "ros_distro": ROS_DISTRO,
        }

    def close(self) -> None:
        """Finish the last file, then write metadata.yaml (through a temporary file: a reader never sees half of
        it). Safe to call twice, and after a failed split (the files finished so far are listed)."""
        if self.finished:
            return
        if self.current is not None:
            self._finish_current()
        self.finished = True
        temporary = self.path / "metadata.yaml.tmp"
        temporary.write_text(_dump({"rosbag2_bagfile_information": self._information()}), encoding="utf-8")
        os.replace(temporary, self.path / "metadata.yaml")
