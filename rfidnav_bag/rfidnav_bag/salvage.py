"""What is intact of an MCAP file that was never closed (recorder killed, disk full) or was cut or damaged.

mcap's seeking reader, mcap_ros2 and rosbags start from the footer and the summary at the end of a file; a file
the recorder could not close has neither. Its records are still there in order, and a chunk is written whole or
not at all (``rfidnav_bag.writer``), so mcap's StreamReader reads them from the start: every complete chunk, its
schemas, channels and messages, up to the first record that is cut short or does not parse. A chunk whose
framing is intact but whose content is not (its CRC or its compression fails) is skipped and counted, and the
read goes on with the next record. No rclpy, no rosbags here: :mod:`rfidnav_bag.bags` builds on it.
"""

from __future__ import annotations

import struct
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from mcap import stream_reader
from mcap.exceptions import EndOfFile, InvalidMagic, McapError, RecordLengthLimitExceeded
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Metadata, Schema
from mcap.stream_reader import MAGIC_SIZE, StreamReader, breakup_chunk

__all__ = ["FileScan", "SalvagedChannel", "salvaged_messages", "scan_file"]

# What a damaged record raises when mcap parses it: McapError (EndOfFile, a bad magic, an unsupported
# compression), struct.error (a field cut short), ValueError (a CRC mismatch, text that is not UTF-8), and the
# errors of the decompressors mcap uses when they are installed (taken from mcap, whose dependencies they are):
# zstandard's ZstdError, lz4.frame's RuntimeError, for a compressed chunk that does not decompress.
_CODEC_ERRORS: tuple[type[Exception], ...] = (
    ((stream_reader.zstandard.ZstdError,) if stream_reader.zstandard is not None else ())
    + ((RuntimeError,) if stream_reader.lz4 is not None else ()))
_DAMAGE: tuple[type[Exception], ...] = (McapError, struct.error, ValueError, *_CODEC_ERRORS)


@dataclass(frozen=True)
class SalvagedChannel:
    """A channel as the file registers it, with its schema (empty name and data if it has none)."""

    id: int
    topic: str
    message_encoding: str
    metadata: dict[str, str]
    schema_name: str
    schema_encoding: str
    schema_data: bytes


@dataclass
class FileScan:
    """What a read of one file from its start found."""

    path: Path
    size_bytes: int
    channels: dict[int, SalvagedChannel] = field(default_factory=dict)
    counts: Counter[int] = field(default_factory=Counter)  # channel id -> messages read
    start_ns: int = 0
    end_ns: int = 0
    compressions: set[str] = field(default_factory=set)  # of the chunks read: "none", "zstd", "lz4"
    intact_bytes: int = 0  # how far the records read reach: the file's bytes after that are lost
    data_complete: bool = False  # the data section's end was read: no chunk is missing
    complete: bool = False  # footer and closing magic read: a reader that seeks can open it
    damaged_chunks: int = 0
    problem: str | None = None  # why the read stopped before the end of the file; None if it reached it
    cut: bool = False  # it stopped because the file ends inside a record (or at a record's end, too early)
    rosbag2_metadata: str | None = None  # the serialized_metadata of the file's rosbag2 record, if read

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    @property
    def lost_bytes(self) -> int:
        return self.size_bytes - self.intact_bytes

    def count(self, message: Message) -> None:
        if not self.counts:
            self.start_ns = self.end_ns = message.log_time
        self.start_ns = min(self.start_ns, message.log_time)
        self.end_ns = max(self.end_ns, message.log_time)
        self.counts[message.channel_id] += 1


def _stopped(scan: FileScan, error: Exception, footer_read: bool) -> None:
    """Say in ``scan`` why the read stopped at ``scan.intact_bytes``: an exception of _DAMAGE."""
    if isinstance(error, InvalidMagic) and not scan.intact_bytes and not footer_read:
        scan.problem = "it is not an MCAP file (no MCAP magic at its start)"
        return
    if not isinstance(error, EndOfFile | struct.error | RecordLengthLimitExceeded):
        scan.problem = f"its record at byte {scan.intact_bytes:,} does not parse: {error}"
        return
    # A read came short, or a record claims more bytes than the file has left: the file ends inside a record.
    scan.cut = True
    scan.intact_bytes = max(scan.intact_bytes, min(MAGIC_SIZE, scan.size_bytes))  # the magic was read
    if footer_read:
        scan.problem = "its closing magic is cut"
    elif scan.intact_bytes <= MAGIC_SIZE and not scan.lost_bytes:
        scan.problem = "it holds nothing but the MCAP magic"
    elif not scan.lost_bytes:
        scan.problem = "it ends after a complete record, before its summary"
    else:
        scan.problem = f"its last {scan.lost_bytes:,} bytes are an incomplete record"


def _records(path: Path, scan: FileScan) -> Iterator[Message]:
    """Every message of ``path``'s intact chunks in file order; ``scan`` is filled in on the way."""
    schemas: dict[int, Schema] = {}

    def register(record: Schema | Channel) -> None:
        if isinstance(record, Schema):
            schemas[record.id] = record
            return
        schema = schemas.get(record.schema_id)
        scan.channels[record.id] = SalvagedChannel(
            record.id, record.topic, record.message_encoding, dict(record.metadata),
            schema.name if schema else "", schema.encoding if schema else "", schema.data if schema else b"")

    footer_read = False
    if scan.size_bytes == 0:
        scan.problem = "it is empty (0 bytes)"
        scan.cut = True
        return
    with path.open("rb") as stream:
        # A record cannot be longer than the file: a damaged length field then reads as a cut, not as a
        # request for gigabytes of memory.
        records = StreamReader(stream, emit_chunks=True, record_size_limit=scan.size_bytes).records
        while True:
            try:
                record = next(records)
            except StopIteration:
                scan.complete = True
                scan.intact_bytes = stream.tell()
                return
            except _DAMAGE as error:
                _stopped(scan, error, footer_read)
                return
            scan.intact_bytes = stream.tell()
            if isinstance(record, Chunk):
                try:
                    content = breakup_chunk(record, validate_crc=True)
                except _DAMAGE:
                    scan.damaged_chunks += 1
                    continue
                scan.compressions.add(record.compression or "none")
                for inner in content:
                    if isinstance(inner, Message):
                        if inner.channel_id in scan.channels:
                            scan.count(inner)
                            yield inner
                    elif isinstance(inner, Schema | Channel):
                        register(inner)
            elif isinstance(record, Message) and record.channel_id in scan.channels:  # an unchunked file
                scan.count(record)
                yield record
            elif isinstance(record, Schema | Channel):
                register(record)
            elif isinstance(record, DataEnd):
                scan.data_complete = True
            elif isinstance(record, Metadata) and record.name == "rosbag2":
                scan.rosbag2_metadata = record.metadata.get("serialized_metadata")
            elif isinstance(record, Footer):
                footer_read = True


def scan_file(path: Path) -> FileScan:
    """Read ``path`` from its start, counting (OSError if it cannot be opened)."""
    scan = FileScan(path, path.stat().st_size)
    for _ in _records(path, scan):
        pass
    return scan


def salvaged_messages(path: Path) -> Iterator[tuple[SalvagedChannel, Message]]:
    """The messages of ``path``'s intact chunks in file order, each with its channel."""
    scan = FileScan(path, path.stat().st_size)
    for message in _records(path, scan):
        yield scan.channels[message.channel_id], message
