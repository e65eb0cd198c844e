"""The location server's SQLite database: write-then-read round trips, migration, and broken files.

Files are built and inspected with the stdlib sqlite3 module directly, so the tests check what is on disk,
not only what the store reports about itself.
"""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import pytest

from rfidnav_localization.errors import StoreError
from rfidnav_localization.fingerprint import Fingerprint
from rfidnav_localization.location_store import (
    SCHEMA_VERSION,
    LocationStore,
    TagGroupRecord,
    TagRecord,
)

pytestmark = pytest.mark.tier("unit")

FINGERPRINTS = [
    Fingerprint((0.0, 0.0), {"aa:01": -41.5, "aa:02": -70.25}, "grid"),
    Fingerprint((1.0, 0.0), {"aa:01": -48.0, "aa:03": -88.0}, "survey"),
    Fingerprint((1.0, 2.5), {"aa:02": -55.0}, "robot"),
    Fingerprint((3.0, 2.5), {"aa:02": -61.0, "aa:03": -59.5}, "robot"),
]
CROSS = TagGroupRecord("hall-1", "cross", (2.0, 1.0), 0.3, 0.25,
                 {"E2001": (2.0, 1.0), "E2002": (2.15, 1.0), "E2003": (1.85, 1.0), "E2004": (2.0, 1.15),
                  "E2005": (2.0, 0.85)})
CIRCLE = TagGroupRecord("hall-2", "circle", (6.0, 1.0), 0.6, 0.0, {"E3001": (6.3, 1.0), "E3002": (5.7, 1.0)})

V1_SCHEMA = [   # a version-1 file as rfidnav wrote it before the tag map existed
    "CREATE TABLE fingerprints (id INTEGER PRIMARY KEY, x REAL NOT NULL, y REAL NOT NULL, "
    "source TEXT NOT NULL, created_s REAL NOT NULL)",
    "CREATE TABLE fingerprint_rss (fingerprint_id INTEGER NOT NULL REFERENCES fingerprints(id) "
    "ON DELETE CASCADE, bssid TEXT NOT NULL, rssi_dbm REAL NOT NULL, PRIMARY KEY (fingerprint_id, bssid))",
    "CREATE INDEX fingerprints_source ON fingerprints(source)",
]


def raw(path: Path, *statements: str) -> list[tuple]:
    connection = sqlite3.connect(path)
    try:
        rows = [connection.execute(statement).fetchall() for statement in statements]
        connection.commit()
        return rows[-1]
    finally:
        connection.close()


def filled_store(path: Path) -> None:
    with LocationStore.open(path, create=True) as store:
        assert store.add_fingerprints(FINGERPRINTS, created_s=100.0) == [1, 2, 3, 4]
        store.add_tag_group(CROSS)
        store.add_tag_group(CIRCLE)


def test_round_trip_keeps_fingerprints_and_tags(tmp_path):
    path = tmp_path / "site.db"
    filled_store(path)
    assert not (tmp_path / "site.db-wal").exists()      # closing checkpointed the journal into the file
    with LocationStore.open(path) as store:
        assert store.fingerprints() == FINGERPRINTS and store.fingerprint_count() == 4
        assert store.tag_groups() == [CROSS, CIRCLE]
        assert store.tag("E2004") == TagRecord("E2004", (2.0, 1.15), "hall-1", "cross")
        assert store.tag("E9999") is None
        assert store.add_fingerprint(Fingerprint((5.0, 5.0), {"aa:09": -77.0}, "robot")) == 5
    assert raw(path, "PRAGMA user_version") == [(SCHEMA_VERSION,)]
    assert raw(path, "PRAGMA journal_mode") == [("wal",)]
    assert raw(path, "SELECT COUNT(*) FROM fingerprint_rss") == [(8,)]
    assert raw(path, "SELECT created_s FROM fingerprints WHERE id = 1") == [(100.0,)]


def test_clear_fingerprints_by_source_cascades_to_their_readings(tmp_path):
    path = tmp_path / "site.db"
    filled_store(path)
    with LocationStore.open(path) as store:
        assert store.clear_fingerprints("robot") == 2
        assert store.fingerprints() == FINGERPRINTS[:2]
    assert raw(path, "SELECT COUNT(*) FROM fingerprint_rss") == [(4,)]   # foreign keys are enforced
    with LocationStore.open(path) as store:
        assert store.clear_fingerprints() == 2 and store.fingerprint_count() == 0
        assert len(store.tag_groups()) == 2


def test_migration_from_a_hand_built_v1_file(tmp_path):
    path = tmp_path / "old.db"
    raw(path, *V1_SCHEMA,
        "INSERT INTO fingerprints VALUES (7, 1.5, -2.0, 'survey', 12.0)",
        "INSERT INTO fingerprint_rss VALUES (7, 'bb:01', -66.0)",
        "INSERT INTO fingerprint_rss VALUES (7, 'bb:02', -71.5)",
        "PRAGMA user_version = 1")
    with LocationStore.open(path) as store:
        assert store.fingerprints() == [Fingerprint((1.5, -2.0), {"bb:01": -66.0, "bb:02": -71.5}, "survey")]
        assert store.tag_groups() == []
        store.add_tag_group(CIRCLE)
        assert [tag.tag_id for tag in store.tags_near(6.0, 1.0, 0.5)] == ["E3001", "E3002"]
    assert raw(path, "PRAGMA user_version") == [(2,)]
    assert {name for (name,) in raw(path, "SELECT name FROM sqlite_master WHERE type = 'table'")} \
        == {"fingerprints", "fingerprint_rss", "tag_groups", "tags"}


def test_tags_near_returns_exactly_the_tags_within_the_radius(tmp_path):
    tags = {f"T{i:02d}{j:02d}": (0.5 * i, 0.5 * j) for i in range(-8, 9) for j in range(-8, 9)}
    with LocationStore.open(tmp_path / "tags.db", create=True) as store:
        store.add_tag_group(TagGroupRecord("field", "square", (0.0, 0.0), 8.0, 0.0, tags))
        for x, y, radius in [(0.0, 0.0, 1.0), (0.3, -0.7, 1.3), (4.0, 4.0, 0.5), (10.0, 10.0, 1.0), (-1.1, 2.2, 0.0),
                             (-1.0, 2.0, 0.0)]:
            expected = sorted((math.hypot(tx - x, ty - y), tag_id) for tag_id, (tx, ty) in tags.items()
                              if math.hypot(tx - x, ty - y) <= radius)
            assert [tag.tag_id for tag in store.tags_near(x, y, radius)] == [tag_id for _, tag_id in expected]
        # The boundary belongs to the disc: (1.5, 2.0) is exactly 2.5 m from the origin.
        assert "T0304" in [tag.tag_id for tag in store.tags_near(0.0, 0.0, 2.5)]
        assert "T0304" not in [tag.tag_id for tag in store.tags_near(0.0, 0.0, 2.4999)]
        assert store.tags_near(0.0, 0.0, 0.2) == [TagRecord("T0000", (0.0, 0.0), "field", "square")]
        with pytest.raises(ValueError, match="radius"):
            store.tags_near(0.0, 0.0, -1.0)


def test_a_tag_group_clashing_with_a_stored_tag_is_refused_whole(tmp_path):
    path = tmp_path / "site.db"
    filled_store(path)
    clash = TagGroupRecord("hall-3", "triangle", (9.0, 1.0), 0.4, 0.0, {"E3999": (9.0, 1.2), "E2003": (9.0, 0.8)})
    with LocationStore.open(path) as store:
        with pytest.raises(StoreError) as raised:
            store.add_tag_group(clash)
        assert str(raised.value) == (f"{path}: tag group hall-3: conflicts with what the store holds "
                                     "(UNIQUE constraint failed: tags.tag_id)")
        assert store.tag("E3999") is None and [group.group_id for group in store.tag_groups()] == ["hall-1", "hall-2"]


def test_missing_file_is_refused_without_creating_it(tmp_path):
    path = tmp_path / "nowhere.db"
    with pytest.raises(StoreError) as raised:
        LocationStore.open(path)
    assert str(raised.value) == f"{path}: no such location database (create it first)"
    assert raised.value.path == str(path) and not path.exists()


def test_garbage_bytes_are_not_a_database(tmp_path):
    path = tmp_path / "garbage.db"
    path.write_bytes(b"this is a spreadsheet, honestly\n" * 200)
    with pytest.raises(StoreError, match="not a readable SQLite database") as raised:
        LocationStore.open(path)
    assert str(raised.value).startswith(f"{path}: ")


@pytest.mark.parametrize("kept_fraction", [0.5, 0.9])
def test_a_truncated_file_is_refused_at_open(tmp_path, kept_fraction):
    path = tmp_path / "site.db"
    with LocationStore.open(path, create=True) as store:
        store.add_fingerprints([Fingerprint((float(i), 0.0), {f"cc:{j:02d}": -50.0 - j for j in range(20)})
                                for i in range(300)])
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * kept_fraction)])
    with pytest.raises(StoreError) as raised:
        LocationStore.open(path)
    assert str(raised.value).startswith(f"{path}: ") and "database" in str(raised.value)


def test_a_newer_schema_is_refused_untouched(tmp_path):
    path = tmp_path / "future.db"
    filled_store(path)
    raw(path, "PRAGMA journal_mode = DELETE", f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    with pytest.raises(StoreError) as raised:
        LocationStore.open(path)
    assert str(raised.value) == f"{path}: schema version 3 is newer than this rfidnav knows (2)"
    assert raw(path, "PRAGMA journal_mode") == [("delete",)]


@pytest.mark.parametrize("statements, problem", [
    (["DROP TABLE tags"], "schema version 2 but table 'tags' is missing"),
    (["ALTER TABLE fingerprint_rss DROP COLUMN rssi_dbm"], "table 'fingerprint_rss' lacks column(s) rssi_dbm"),
])
def test_a_database_missing_expected_tables_is_refused(tmp_path, statements, problem):
    path = tmp_path / "site.db"
    filled_store(path)
    raw(path, *statements)
    with pytest.raises(StoreError) as raised:
        LocationStore.open(path)
    assert str(raised.value) == f"{path}: {problem}"


def test_a_broken_v1_file_is_refused_before_migrating(tmp_path):
    path = tmp_path / "old.db"
    raw(path, V1_SCHEMA[0], "PRAGMA user_version = 1")
    with pytest.raises(StoreError) as raised:
        LocationStore.open(path)
    assert str(raised.value) == f"{path}: schema version 1 but table 'fingerprint_rss' is missing"
    assert raw(path, "PRAGMA user_version") == [(1,)]
    assert raw(path, "SELECT name FROM sqlite_master WHERE type = 'table'") == [("fingerprints",)]


@pytest.mark.parametrize("statements, problem", [
    (["CREATE TABLE invoices (id INTEGER)"], "holds tables invoices"),
    ([], "empty"),
])
def test_a_foreign_or_empty_sqlite_file_is_not_a_location_database(tmp_path, statements, problem):
    path = tmp_path / "other.db"
    path.touch()
    raw(path, *statements, "PRAGMA user_version")
    with pytest.raises(StoreError, match=f"not a location database .*{problem}") as raised:
        LocationStore.open(path)
    assert raised.value.path == str(path)


def test_create_on_an_empty_file_initialises_it(tmp_path):
    path = tmp_path / "new.db"
    path.touch()
    with LocationStore.open(path, create=True) as store:
        assert store.fingerprint_count() == 0 and store.tag_groups() == []
    assert raw(path, "PRAGMA user_version") == [(SCHEMA_VERSION,)]


def test_rows_the_dataclasses_refuse_are_reported_with_the_file(tmp_path):
    path = tmp_path / "edited.db"
    filled_store(path)
    raw(path, "UPDATE fingerprints SET source = 'guess' WHERE id = 2")
    with LocationStore.open(path) as store, pytest.raises(StoreError) as raised:
        store.fingerprints()
    assert str(raised.value) == f"{path}: fingerprint 2: source: 'guess' is not one of grid, survey, robot"


def test_a_closed_store_refuses_work(tmp_path):
    path = tmp_path / "site.db"
    filled_store(path)
    store = LocationStore.open(path)
    store.close()
    with pytest.raises(StoreError, match="closed"):
        store.fingerprint_count()


@pytest.mark.parametrize("fields, field", [
    (("g", "hexagon", (0.0, 0.0), 1.0, 0.0, {"t": (0.0, 0.0)}), "shape"),
    (("g", "cross", (0.0, 0.0), 0.0, 0.0, {"t": (0.0, 0.0)}), "size_m"),
    (("g", "cross", (0.0, math.inf), 1.0, 0.0, {"t": (0.0, 0.0)}), "centre"),
    (("g", "cross", (0.0, 0.0), 1.0, 0.0, {}), "tags"),
    (("", "cross", (0.0, 0.0), 1.0, 0.0, {"t": (0.0, 0.0)}), "group_id"),
])
def test_tag_group_validation_names_the_field(fields, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        TagGroupRecord(*fields)
