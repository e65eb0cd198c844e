"""``./rfidnav bag recover RUN_OR_BAG [--out DIR]``: a complete copy of a bag that was not finalised or is
damaged, as ``mcap recover`` makes of one MCAP file.

The source is read from the start of each file, chunk by chunk (:func:`rfidnav_bag.bags.open_bag` with
``salvage``: a damaged chunk is skipped rather than ending the read; what was lost is in ``info.notes``). Its
topics -- name, type, message definition, RIHS01 hash, offered QoS -- and its messages, in time order, go through
the recorder's writer into a new rosbag2 directory: one MCAP file with chunks, message indexes and summary, and
metadata.yaml, which rosbags' AnyReader, mcap's seeking reader and mcap_ros2 open like any finished bag. Chunks
are zstd-compressed if the source's were. The source is left as it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.well_known import SchemaEncoding
from rosbags.interfaces import MessageDefinitionFormat

from rfidnav_bag.bags import BagInfo, open_bag
from rfidnav_bag.errors import BagError
from rfidnav_bag.writer import BagWriter, StorageOptions

__all__ = ["Recovery", "default_output", "recover_bag"]

_SCHEMA_ENCODINGS = {MessageDefinitionFormat.MSG: SchemaEncoding.ROS2, MessageDefinitionFormat.IDL: "ros2idl",
                     MessageDefinitionFormat.NONE: ""}


@dataclass(frozen=True)
class Recovery:
    """What ``recover_bag`` read (``source``: its info, notes included) and wrote."""

    source: BagInfo
    output: Path
    message_count: int
    topic_count: int


def default_output(bag: Path) -> Path:
    """Beside the bag: ``bag`` -> ``bag_recovered``."""
    return bag.with_name(f"{bag.name}_recovered")


def recover_bag(source: str | Path, output: str | Path | None = None) -> Recovery:
    """Copy whatever of ``source`` is readable into a new, finalised bag at ``output`` (default: beside it,
    ``<bag>_recovered``; it must not exist). BagError if nothing is readable or the copy cannot be written."""
    with open_bag(source, salvage=True) as bag:
        target = Path(output) if output is not None else default_output(bag.path)
        compression = "zstd" if "zstd" in bag.info.compression else "none"
        writer = BagWriter(target, StorageOptions(compression=compression))
        try:
            writer.open()
        except OSError as error:
            raise BagError(f"{target}: cannot create the recovered bag: {error}") from error
        topics = {
            connection.id: writer.add_topic(
                connection.topic, connection.msgtype, connection.msgdef.data, connection.digest,
                tuple(getattr(connection.ext, "offered_qos_profiles", ())),
                schema_encoding=_SCHEMA_ENCODINGS[connection.msgdef.format])
            for connection in bag.connections}
        count = 0
        try:
            if bag.connections:
                for connection, timestamp, data in bag.messages(bag.connections):
                    writer.write(topics[connection.id], timestamp, bytes(data))
                    count += 1
        finally:  # a chunk that fails to read mid-way still leaves a finalised copy of what came before it
            writer.close()
        return Recovery(bag.info, target, count, len(topics))
