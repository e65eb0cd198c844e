"""Writing rosbag2 directories with MCAP storage, the way rosbag2's SequentialWriter and its MCAP plugin do,
so that whatever happens to the recorder the bag stays readable up to about a second before it.

No rclpy here (the recorder node feeds it raw CDR). The wheels ship no rosbag2, and rosbags' Writer writes one
file named ``NAME.mcap`` and cannot split, so the files are written with the ``mcap`` library and the
metadata here, in rosbag2's Jazzy layout (metadata version 9):

- ``NAME/metadata.yaml`` and ``NAME/NAME_0.mcap``, ``NAME_1.mcap``, ... (rosbag2's file names);
- every file is a complete MCAP once closed (profile ``ros2``, chunks with message indexes, summary with schemas,
  channels, statistics and chunk indexes) in which every topic recorded so far is registered again, as rosbag2
  does on a split, so each file decodes on its own (Foxglove opens one file at a time); channels carry
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

Crash safety. A file that is never closed (recorder killed, disk full) has no summary, and mcap's seeking
reader, mcap_ros2 and rosbags refuse it; its chunks are still there, each written whole, and a streaming read
(``rfidnav_bag.salvage``) gets every complete one. So chunks are kept short: a chunk is written (the mcap
writer's ``flush()``: the chunk in progress finished, the stream flushed to the operating system) before a
message more than ``CHUNK_DURATION_NS`` of bag time after the chunk's first, or once it holds ``CHUNK_SIZE``
bytes, or at a ``checkpoint()`` (the recorder's, every wall second). What a killed recorder loses is the chunk
in progress: at most a second of bag time, or a wall second, whichever is shorter. metadata.yaml is written when
the bag is opened and rewritten (rfidnav_common.files.write_atomically: a reader never sees half of it) at every
checkpoint, split and close; it counts what is in written chunks, so after a crash it says what is on disk up to
the last checkpoint. Chunks are not fsync'ed: the operating system keeps what a killed process wrote, a power
cut may not.

Disk full (or over quota, an I/O error, a file over the size limit): the first OSError stops the writer for
good. It closes what it can, rewrites metadata.yaml from the chunks already on disk (if the disk still takes
that) and raises :class:`BagWriteError`; the files keep every chunk written before the error.
"""

from __future__ import annotations

import contextlib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import yaml
from mcap.well_known import MessageEncoding, Profile, SchemaEncoding
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.interfaces import Qos

from rfidnav_bag.errors import BagError, BagWriteError
from rfidnav_bag.salvage import scan_file
from rfidnav_common.files import write_atomically

__all__ = ["CHUNK_DURATION_NS", "CHUNK_SIZE", "COMPRESSIONS", "MIN_SPLIT_SIZE", "BagWriter", "StorageOptions",
           "Topic"]

BAG_VERSION = 9  # what Jazzy's rosbag2 writes (structured QoS in metadata.yaml)
ROS_DISTRO = "jazzy"  # the distribution of the rclpy wheels the recorder runs on
CHUNK_SIZE = 768 * 1024  # libmcap's default chunk size, which rosbag2's MCAP plugin keeps [bytes]
CHUNK_DURATION_NS = 1_000_000_000  # a chunk spans less than this much bag time
MESSAGE_RECORD_BYTES = 31  # a Message record around its data: opcode, length, channel, sequence, two times
NEVER_BY_SIZE = 2**62  # the mcap writer's own chunk size: chunks are cut here (CHUNK_SIZE), never there
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
    definition: str  # ros2msg text with every nested type (or ros2idl: schema_encoding)
    rihs01: str
    offered_qos: tuple[Qos, ...]
    serialization_format: str = MessageEncoding.CDR
    schema_encoding: str = SchemaEncoding.ROS2


@dataclass
class _Tally:
    """Messages counted: how many of each topic, and the span of their timestamps."""

    counts: Counter[int] = field(default_factory=Counter)  # Topic.id -> messages
    start_ns: int = 0
    end_ns: int = 0

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    def add(self, topic_id: int, timestamp_ns: int) -> None:
        if not self.counts:
            self.start_ns = self.end_ns = timestamp_ns
        elif timestamp_ns > self.end_ns:
            self.end_ns = timestamp_ns
        elif timestamp_ns < self.start_ns:
            self.start_ns = timestamp_ns
        self.counts[topic_id] += 1

    def merge(self, other: _Tally) -> None:
        if not other.counts:
            return
        if not self.counts:
            self.start_ns, self.end_ns = other.start_ns, other.end_ns
        self.start_ns = min(self.start_ns, other.start_ns)
        self.end_ns = max(self.end_ns, other.end_ns)
        self.counts.update(other.counts)


@dataclass
class _File:
    """The MCAP file being written: what its written chunks hold (``written``, what metadata.yaml lists) and what
    the chunk in progress holds (``pending``, in memory until the chunk is written)."""

    path: Path
    stream: BinaryIO
    mcap: McapWriter
    channels: dict[int, int] = field(default_factory=dict)  # Topic.id -> channel id in this file
    schemas: dict[str, int] = field(default_factory=dict)  # msgtype -> schema id in this file
    written: _Tally = field(default_factory=_Tally)
    pending: _Tally = field(default_factory=_Tally)
    pending_bytes: int = 0

    @property
    def message_count(self) -> int:
        return self.written.message_count + self.pending.message_count

    @property
    def start_ns(self) -> int:
        return min(t.start_ns for t in (self.written, self.pending) if t.counts)

    def document(self) -> dict[str, Any]:
        tally = self.written
        return {"path": self.path.name, "starting_time": {"nanoseconds_since_epoch": tally.start_ns},
                "duration": {"nanoseconds": tally.end_ns - tally.start_ns}, "message_count": tally.message_count}


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
    # libyaml's emitter: the same text as PyYAML's, five times faster (metadata.yaml is rewritten every second)
    return yaml.dump(document, Dumper=yaml.CSafeDumper, sort_keys=False, default_flow_style=False)


class BagWriter:
    """Create a rosbag2 directory at ``path`` (it must not exist): ``open``, ``add_topic``, ``write``,
    ``checkpoint`` now and then, ``close``. After a BagWriteError the writer is done: every later call but
    ``close`` raises BagError."""

    def __init__(self, path: str | Path, options: StorageOptions = StorageOptions()) -> None:
        self.path = Path(path)
        self.options = options
        self.topics: list[Topic] = []
        self.closed_files: list[_File] = []
        self.current: _File | None = None
        self.finished = False  # closed, or stopped by a write error: nothing more is written
        self.failure: BagWriteError | None = None
        self.metadata_current = False  # metadata.yaml says what the written chunks hold
        self.chunk_size = min(CHUNK_SIZE, options.max_bag_size // 4) if options.max_bag_size else CHUNK_SIZE

    # -- files ------------------------------------------------------------------------------------------

    def open(self) -> None:
        """Create the directory, the first file and metadata.yaml (BagError if the directory exists, OSError if
        the disk refuses)."""
        try:
            self.path.mkdir(parents=True)
        except FileExistsError:
            raise BagError(f"{self.path} exists already; a bag is never overwritten") from None
        self.current = self._start_file()
        self._write_metadata()

    def _start_file(self) -> _File:
        path = self.path / f"{self.path.name}_{len(self.closed_files)}.mcap"
        stream = path.open("xb")
        writer = McapWriter(stream, chunk_size=NEVER_BY_SIZE, compression=COMPRESSIONS[self.options.compression])
        writer.start(profile=Profile.ROS2, library=LIBRARY)
        file = _File(path, stream, writer)
        for topic in self.topics:
            self._register(file, topic)
        return file

    def _register(self, file: _File, topic: Topic) -> None:
        if topic.msgtype not in file.schemas:
            file.schemas[topic.msgtype] = file.mcap.register_schema(topic.msgtype, topic.schema_encoding,
                                                                    topic.definition.encode())
        file.channels[topic.id] = file.mcap.register_channel(
            topic.name, topic.serialization_format, file.schemas[topic.msgtype],
            {"offered_qos_profiles": _dump([_qos_document(q) for q in topic.offered_qos]),
             "topic_type_hash": topic.rihs01})

    def _write_chunk(self, file: _File) -> None:
        """Write the chunk in progress (if it holds a message) and hand the file's buffer to the system."""
        file.mcap.flush()
        file.written.merge(file.pending)
        file.pending = _Tally()
        file.pending_bytes = 0
        self.metadata_current = False

    def _finish_current(self) -> None:
        file = self.current
        assert file is not None
        self._write_chunk(file)
        file.mcap.add_metadata("rosbag2", {"serialized_metadata": _dump(self._information())})
        file.mcap.finish()
        file.stream.close()
        self.closed_files.append(file)
        self.current = None

    def _should_split(self, file: _File, timestamp_ns: int) -> bool:
        if not (file.written.counts or file.pending.counts):
            return False
        by_size = self.options.max_bag_size and file.stream.tell() >= self.options.max_bag_size
        by_duration = (self.options.max_bag_duration_ns
                       and timestamp_ns - file.start_ns > self.options.max_bag_duration_ns)
        return bool(by_size or by_duration)

    def _open_file(self) -> _File:
        if self.failure is not None:
            raise BagError(f"{self.path}: recording stopped after a write error ({self.failure.reason})")
        if self.current is None:
            raise BagError(f"{self.path}: the bag is not open")
        return self.current

    # -- topics and messages ----------------------------------------------------------------------------

    def add_topic(self, name: str, msgtype: str, definition: str, rihs01: str, offered_qos: tuple[Qos, ...] = (),
                  schema_encoding: str = SchemaEncoding.ROS2) -> Topic:
        """A topic to write messages of; its schema and channel go into the current file and every later one."""
        file = self._open_file()
        if any(t.name == name for t in self.topics):
            raise BagError(f"{self.path}: topic {name} is recorded already")
        topic = Topic(len(self.topics) + 1, name, msgtype, definition, rihs01, tuple(offered_qos),
                      schema_encoding=schema_encoding)
        self.topics.append(topic)
        self._register(file, topic)
        self.metadata_current = False
        return topic

    def write(self, topic: Topic, timestamp_ns: int, data: bytes) -> None:
        """One serialised message, stamped ``timestamp_ns`` (its log and publish time). BagWriteError if the disk
        refuses it or an earlier chunk (the writer has stopped then), BagError if the bag is not open."""
        file = self._open_file()
        try:
            if self._should_split(file, timestamp_ns):
                self._finish_current()
                file = self.current = self._start_file()
                self._write_metadata()
            elif file.pending.counts and timestamp_ns - file.pending.start_ns >= CHUNK_DURATION_NS:
                self._write_chunk(file)
            file.mcap.add_message(file.channels[topic.id], log_time=timestamp_ns, data=data,
                                  publish_time=timestamp_ns)
            file.pending.add(topic.id, timestamp_ns)
            file.pending_bytes += len(data) + MESSAGE_RECORD_BYTES
            if file.pending_bytes >= self.chunk_size:
                self._write_chunk(file)
        except OSError as error:
            raise self._stop(error) from error

    def checkpoint(self) -> None:
        """Write the chunk in progress and bring metadata.yaml up to date (nothing to do if nothing changed);
        the recorder calls it every wall second, so a stalled clock cannot keep messages in memory.
        BagWriteError as ``write``."""
        file = self._open_file()
        try:
            if file.pending.counts:
                self._write_chunk(file)
            if not self.metadata_current:
                self._write_metadata()
        except OSError as error:
            raise self._stop(error) from error

    # -- metadata ---------------------------------------------------------------------------------------

    @property
    def files(self) -> list[_File]:
        return self.closed_files + ([self.current] if self.current is not None else [])

    @property
    def message_count(self) -> int:
        """Messages accepted so far (written or in the chunk in progress)."""
        return sum(f.message_count for f in self.files)

    @property
    def written_count(self) -> int:
        """Messages in chunks on disk."""
        return sum(f.written.message_count for f in self.files)

    def _information(self) -> dict[str, Any]:
        """``rosbag2_bagfile_information``: what the written chunks of the bag hold, in rosbag2's order of keys."""
        bag = _Tally()
        for file in self.files:
            bag.merge(file.written)
        return {
            "version": BAG_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": bag.end_ns - bag.start_ns},
            "starting_time": {"nanoseconds_since_epoch": bag.start_ns},
            "message_count": bag.message_count,
            "topics_with_message_count": [
                {"topic_metadata": {"name": t.name, "type": t.msgtype, "serialization_format": t.serialization_format,
                                    "offered_qos_profiles": [_qos_document(q) for q in t.offered_qos],
                                    "type_description_hash": t.rihs01},
                 "message_count": bag.counts[t.id]}
                for t in self.topics],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f.path.name for f in self.files],
            "files": [f.document() for f in self.files],
            "custom_data": None,
            "ros_distro": ROS_DISTRO,
        }

    def _write_metadata(self) -> None:
        """metadata.yaml through a temporary file: a reader sees the old one or the new one, never half."""
        write_atomically(self.path / "metadata.yaml", _dump({"rosbag2_bagfile_information": self._information()}))
        self.metadata_current = True

    def _stop(self, error: OSError) -> BagWriteError:
        """After the disk refused a write: close every file as far as it goes and write metadata.yaml for the
        chunks on disk if the disk still takes it; the BagWriteError to raise."""
        self.finished = True
        accepted = self.message_count
        for file in self.files:
            file.pending = _Tally()
        if self.current is not None:
            file = self.current
            # Flushes what the buffer holds (it may fail again), then closes the descriptor in any case; the tail of
            # the file is then an incomplete record, which readers of an unclosed file skip.
            with contextlib.suppress(OSError):
                file.stream.close()
            with contextlib.suppress(OSError):
                file.written = self._on_disk(file)  # the failed chunk may have reached the disk whole
            self.closed_files.append(file)
            self.current = None
        try:
            self._write_metadata()
            metadata = "metadata.yaml says so"
        except OSError as metadata_error:
            metadata = (f"metadata.yaml not rewritten ({metadata_error.strerror or metadata_error}): it says what "
                        "was on disk at the last checkpoint")
            with contextlib.suppress(OSError):
                (self.path / "metadata.yaml.tmp").unlink(missing_ok=True)
        self.failure = BagWriteError(self.path, error, self.written_count, accepted - self.written_count, metadata)
        return self.failure

    @staticmethod
    def _on_disk(file: _File) -> _Tally:
        """What a reader finds in ``file``, which was not closed: its intact chunks, counted per topic."""
        scan = scan_file(file.path)
        topic_of = {channel: topic for topic, channel in file.channels.items()}
        return _Tally(Counter({topic_of[channel]: n for channel, n in scan.counts.items() if channel in topic_of}),
                      scan.start_ns, scan.end_ns)

    def close(self) -> None:
        """Finish the last file, then write metadata.yaml. Safe to call twice, and after a failed split (the
        files finished so far are listed) or a write error (nothing more is written). BagWriteError if the disk
        refuses the summary or metadata.yaml."""
        if self.finished:
            return
        try:
            if self.current is not None:
                self._finish_current()
            self._write_metadata()
        except OSError as error:
            raise self._stop(error) from error
        self.finished = True
