"""The location server's database (paper 003): the radio map and the tag map, in one plain SQLite file.

Fingerprints are what tier one matches a scan against; tag groups (floor tags along a circle, cross, triangle or
square, paper 003 fig. 6) are what the server hands a located robot for its tier-two search. The schema version
is ``PRAGMA user_version``: an older file is upgraded through the ordered ``MIGRATIONS`` (one transaction each),
a newer one is refused rather than guessed at. Foreign keys are on, the journal is WAL (readers never block the
surveying robot), and each write is one transaction: a crash keeps all of a fingerprint or tag group or none.
Every failure names the file (StoreError): missing, not SQLite, damaged (``PRAGMA quick_check`` at open finds a
truncated file before a query trips over it), a newer schema, or without the tables and columns read here.
"""

from __future__ import annotations

import math
import sqlite3
import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from rfidnav_common.tag_groups import SHAPES
from rfidnav_localization.errors import StoreError
from rfidnav_localization.fingerprint import Fingerprint

_Record = TypeVar("_Record")

MIGRATIONS: tuple[tuple[str, ...], ...] = (
    (   # v1: the radio map
        "CREATE TABLE fingerprints (id INTEGER PRIMARY KEY, x REAL NOT NULL, y REAL NOT NULL, "
        "source TEXT NOT NULL, created_s REAL NOT NULL)",
        "CREATE TABLE fingerprint_rss (fingerprint_id INTEGER NOT NULL REFERENCES fingerprints(id) "
        "ON DELETE CASCADE, bssid TEXT NOT NULL, rssi_dbm REAL NOT NULL, PRIMARY KEY (fingerprint_id, bssid))",
        "CREATE INDEX fingerprints_source ON fingerprints(source)",
    ),
    (   # v2: the tag map
        "CREATE TABLE tag_groups (group_id TEXT PRIMARY KEY, shape TEXT NOT NULL, x REAL NOT NULL, "
        "y REAL NOT NULL, size_m REAL NOT NULL, rotation_rad REAL NOT NULL)",
        "CREATE TABLE tags (tag_id TEXT PRIMARY KEY, x REAL NOT NULL, y REAL NOT NULL, group_id TEXT NOT NULL "
        "REFERENCES tag_groups(group_id) ON DELETE CASCADE)",
        "CREATE INDEX tags_x ON tags(x)",
        "CREATE INDEX tags_group ON tags(group_id)",
    ),
)
SCHEMA_VERSION = len(MIGRATIONS)
_EXPECTED_COLUMNS = {     # table: (the schema version that made it, the columns this code reads)
    "fingerprints": (1, {"id", "x", "y", "source", "created_s"}),
    "fingerprint_rss": (1, {"fingerprint_id", "bssid", "rssi_dbm"}),
    "tag_groups": (2, {"group_id", "shape", "x", "y", "size_m", "rotation_rad"}),
    "tags": (2, {"tag_id", "x", "y", "group_id"}),
}
_TAG_SELECT = "SELECT t.tag_id, t.x, t.y, t.group_id, g.shape FROM tags t JOIN tag_groups g USING (group_id)"


@dataclass(frozen=True)
class TagRecord:
    tag_id: str                         # EPC as upper-case hex, or the tag's name in simulation
    position: tuple[float, float]       # map frame [m]
    group_id: str
    shape: str


@dataclass(frozen=True)
class TagGroupRecord:
    """A tag group as installed (``rfidnav_common.tag_groups.TagGroup`` for its shape, size and rotation), with
    the surveyed ids and positions of its tags: given as a mapping tag id -> position (or as pairs), stored as
    pairs sorted by tag id so records compare equal after a round trip."""

    group_id: str
    shape: str
    centre: tuple[float, float]
    size_m: float                       # cross: bar length, circle: diameter, triangle, square: side [m]
    rotation_rad: float
    tags: tuple[tuple[str, tuple[float, float]], ...]

    def __post_init__(self) -> None:
        if not isinstance(self.group_id, str) or not self.group_id:
            raise ValueError(f"group_id: must be a non-empty string, got {self.group_id!r}")
        if self.shape not in SHAPES:
            raise ValueError(f"shape: '{self.shape}' is not one of {', '.join(SHAPES)}")
        centre = _point("centre", self.centre)
        if not (math.isfinite(self.size_m) and self.size_m > 0.0):
            raise ValueError(f"size_m: must be a positive number, got {self.size_m}")
        if not math.isfinite(self.rotation_rad):
            raise ValueError(f"rotation_rad: must be finite, got {self.rotation_rad}")
        pairs = self.tags.items() if isinstance(self.tags, Mapping) else self.tags
        tags: dict[str, tuple[float, float]] = {}
        for tag_id, position in pairs:
            if not isinstance(tag_id, str) or not tag_id or tag_id in tags:
                raise ValueError(f"tags: tag id {tag_id!r} is empty, not a string, or given twice")
            tags[tag_id] = _point(f"tags[{tag_id}]", position)
        if not tags:
            raise ValueError("tags: a tag group needs at least one tag")
        object.__setattr__(self, "centre", centre)
        object.__setattr__(self, "size_m", float(self.size_m))
        object.__setattr__(self, "rotation_rad", float(self.rotation_rad))
        object.__setattr__(self, "tags", tuple(sorted(tags.items())))


class LocationStore:
    """An open location database; use ``LocationStore.open`` (a context manager that closes the file)."""

    def __init__(self, path: Path, connection: sqlite3.Connection) -> None:
        self.path = path
        self._connection = connection

    @classmethod
    def open(cls, path: str | Path, create: bool = False) -> LocationStore:
        """Open the store at ``path``, upgrading an older schema; ``create`` makes a new one if it is missing."""
        path = Path(path)
        if not create and not path.is_file():
            raise StoreError(str(path), "no such location database (create it first)")
        try:
            connection = sqlite3.connect(path, isolation_level=None)   # transactions are explicit
        except sqlite3.Error as error:
            raise StoreError(str(path), f"cannot open: {error}") from None
        store = cls(path, connection)
        try:
            store._prepare(create)
        except BaseException:
            connection.close()
            raise
        return store

    def close(self) -> None:
        self._connection.close()

    def __enter__(self) -> LocationStore:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def add_fingerprint(self, fingerprint: Fingerprint, created_s: float | None = None) -> int:
        """Store ``fingerprint`` taken at ``created_s`` (default: now, wall clock); returns its id."""
        return self.add_fingerprints([fingerprint], created_s)[0]

    def add_fingerprints(self, fingerprints: Iterable[Fingerprint], created_s: float | None = None) -> list[int]:
        """Store a survey's fingerprints in one transaction (one disk sync for the lot); returns their ids."""
        stamp = time.time() if created_s is None else created_s
        ids: list[int] = []
        with self._transaction("adding fingerprints") as cursor:
            for fingerprint in fingerprints:
                x, y = fingerprint.position
                cursor.execute("INSERT INTO fingerprints (x, y, source, created_s) VALUES (?, ?, ?, ?)",
                               (x, y, fingerprint.source, stamp))
                ids.append(cursor.lastrowid)
                cursor.executemany("INSERT INTO fingerprint_rss VALUES (?, ?, ?)",
                                   [(cursor.lastrowid, bssid, rss) for bssid, rss in fingerprint.rss])
        return ids

    def fingerprints(self) -> list[Fingerprint]:
        """Every fingerprint, in the order added."""
        rows = self._query("SELECT f.id, f.x, f.y, f.source, r.bssid, r.rssi_dbm FROM fingerprints f "
                           "LEFT JOIN fingerprint_rss r ON r.fingerprint_id = f.id ORDER BY f.id")
        grouped: dict[int, tuple[tuple[float, float], str, list[tuple[str, float]]]] = {}
        for fingerprint_id, x, y, source, bssid, rss in rows:
            readings = grouped.setdefault(fingerprint_id, ((x, y), source, []))[2]
            if bssid is not None:
                readings.append((bssid, rss))
        return [self._checked(f"fingerprint {fingerprint_id}", Fingerprint, position, tuple(readings), source)
                for fingerprint_id, (position, source, readings) in grouped.items()]

    def fingerprint_count(self) -> int:
        return self._query("SELECT COUNT(*) FROM fingerprints")[0][0]

    def clear_fingerprints(self, source: str | None = None) -> int:
        """Delete the fingerprints of ``source`` (all when None), e.g. before a fresh robot survey; returns how many."""
        with self._transaction("clearing fingerprints") as cursor:
            if source is None:
                cursor.execute("DELETE FROM fingerprints")
            else:
                cursor.execute("DELETE FROM fingerprints WHERE source = ?", (source,))
            return cursor.rowcount

    def add_tag_group(self, group: TagGroupRecord) -> None:
        """Store ``group`` and its tags, or nothing of it if its id or a tag id is already stored."""
        with self._transaction(f"tag group {group.group_id}") as cursor:
            cursor.execute("INSERT INTO tag_groups VALUES (?, ?, ?, ?, ?, ?)",
                           (group.group_id, group.shape, *group.centre, group.size_m, group.rotation_rad))
            cursor.executemany("INSERT INTO tags VALUES (?, ?, ?, ?)",
                               [(tag_id, x, y, group.group_id) for tag_id, (x, y) in group.tags])

    def tag_groups(self) -> list[TagGroupRecord]:
        """Every tag group with its tags, by group id."""
        groups = self._query("SELECT group_id, shape, x, y, size_m, rotation_rad FROM tag_groups ORDER BY group_id")
        tags: dict[str, list[tuple[str, tuple[float, float]]]] = {}
        for tag_id, x, y, group_id in self._query("SELECT tag_id, x, y, group_id FROM tags"):
            tags.setdefault(group_id, []).append((tag_id, (x, y)))
        return [self._checked(f"tag group {group_id}", TagGroupRecord, group_id, shape, (x, y), size_m, rotation_rad,
                              tuple(tags.get(group_id, ())))
                for group_id, shape, x, y, size_m, rotation_rad in groups]

    def tag(self, tag_id: str) -> TagRecord | None:
        rows = self._query(f"{_TAG_SELECT} WHERE t.tag_id = ?", (tag_id,))
        return _tag_record(rows[0]) if rows else None

    def tags_near(self, x: float, y: float, radius_m: float) -> list[TagRecord]:
        """The tags within ``radius_m`` of (x, y), boundary included, nearest first (ties by tag id)."""
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(radius_m) and radius_m >= 0.0):
            raise ValueError(f"tags_near: needs a finite point and radius >= 0, got ({x}, {y}), {radius_m}")
        rows = self._query(
            f"{_TAG_SELECT} WHERE t.x BETWEEN ? AND ? AND (t.x - ?) * (t.x - ?) + (t.y - ?) * (t.y - ?) <= ? "
            "ORDER BY (t.x - ?) * (t.x - ?) + (t.y - ?) * (t.y - ?), t.tag_id",
            (x - radius_m, x + radius_m, x, x, y, y, radius_m * radius_m, x, x, y, y))
        return [_tag_record(row) for row in rows]

    def _prepare(self, create: bool) -> None:
        name = str(self.path)
        try:
            self._connection.execute("PRAGMA foreign_keys = ON")
            version = self._connection.execute("PRAGMA user_version").fetchone()[0]
            tables = {row[0] for row in self._connection.execute(
                "SELECT name FROM sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'")}
            problems = [row[0] for row in self._connection.execute("PRAGMA quick_check")]
        except sqlite3.DatabaseError as error:
            raise StoreError(name, f"not a readable SQLite database ({error})") from None
        if problems != ["ok"]:
            raise StoreError(name, f"damaged SQLite database ({problems[0]})")
        if version > SCHEMA_VERSION:
            raise StoreError(name, f"schema version {version} is newer than this rfidnav knows ({SCHEMA_VERSION})")
        if version == 0 and (tables or not create):
            raise StoreError(name, "not a location database (schema version 0"
                             + (f", holds tables {', '.join(sorted(tables))})" if tables else ", empty)"))
        # Checked before anything is written, so a refused file is left as it was.
        for table, (since, expected) in _EXPECTED_COLUMNS.items():
            columns = {row[1] for row in self._query(f"PRAGMA table_info({table})")} if since <= version else expected
            if not columns:
                raise StoreError(name, f"schema version {version} but table '{table}' is missing")
            if expected - columns:
                raise StoreError(name, f"table '{table}' lacks column(s) {', '.join(sorted(expected - columns))}")
        self._connection.execute("PRAGMA journal_mode = WAL")
        self._connection.execute("PRAGMA synchronous = NORMAL")    # WAL keeps it crash-safe; syncs at checkpoints
        for target in range(version + 1, SCHEMA_VERSION + 1):
            with self._transaction(f"migrating to schema version {target}") as cursor:
                for statement in MIGRATIONS[target - 1]:
                    cursor.execute(statement)
                cursor.execute(f"PRAGMA user_version = {target}")

    @contextmanager
    def _transaction(self, what: str) -> Iterator[sqlite3.Cursor]:
        # BEGIN IMMEDIATE takes the write lock up front, so a concurrent writer waits here, not mid-way.
        cursor = self._connection.cursor()
        try:
            cursor.execute("BEGIN IMMEDIATE")
            try:
                yield cursor
                cursor.execute("COMMIT")
            except BaseException:
                if self._connection.in_transaction:    # a failed COMMIT may have rolled back already
                    cursor.execute("ROLLBACK")
                raise
        except sqlite3.IntegrityError as error:
            raise StoreError(str(self.path), f"{what}: conflicts with what the store holds ({error})") from None
        except sqlite3.DatabaseError as error:
            raise StoreError(str(self.path), f"{what}: database error ({error})") from None

    def _query(self, sql: str, parameters: tuple = ()) -> list[tuple]:
        try:
            return self._connection.execute(sql, parameters).fetchall()
        except sqlite3.DatabaseError as error:
            raise StoreError(str(self.path), f"database error ({error})") from None

    def _checked(self, what: str, kind: type[_Record], *fields: object) -> _Record:
        # A hand-edited file may hold values the dataclasses refuse: say which row, in which file.
        try:
            return kind(*fields)
        except (TypeError, ValueError) as error:
            raise StoreError(str(self.path), f"{what}: {error}") from None


def _point(field: str, value: tuple[float, float]) -> tuple[float, float]:
    x, y = (float(component) for component in value)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"{field}: must be a finite point, got {value}")
    return (x, y)


def _tag_record(row: tuple) -> TagRecord:
    tag_id, x, y, group_id, shape = row
    return TagRecord(tag_id, (x, y), group_id, shape)
