"""Exceptions of rfidnav_bag (recording, playing and reading rosbag2 MCAP bags)."""

from __future__ import annotations

from pathlib import Path

from rfidnav_common.errors import RfidnavError


class BagError(RfidnavError):
    """A bag is missing, truncated, or not a rosbag2 MCAP directory rfidnav can read; names the path."""


class BagWriteError(BagError):
    """The disk refused a write to a bag (full, over quota, an I/O error, a file over the size limit): the writer
    has stopped for good, and what it wrote before stays readable. ``reason`` is the system's word for it."""

    def __init__(self, bag: Path, error: OSError, on_disk: int, lost: int, metadata: str) -> None:
        self.reason = error.strerror or str(error)
        self.errno = error.errno
        super().__init__(f"cannot write {bag}: {self.reason}; recording stopped with {on_disk:,} messages on disk "
                         f"(readable), {lost:,} lost with the chunk in progress; {metadata}")
