"""location_server (paper 003): its three services over DDS, its database, and its start-up errors."""

from __future__ import annotations

from pathlib import Path

import pytest
from rclpy.parameter import Parameter

from rfidnav_localization.errors import StoreError
from rfidnav_localization.fingerprint import Fingerprint
from rfidnav_localization.location_server_node import LocationServerNode
from rfidnav_localization.location_store import LocationStore
from rfidnav_msgs.msg import AccessPointRss, WifiScan
from rfidnav_msgs.srv import AddFingerprint, GetTagMap, Locate
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

BSSIDS = ("02:00:00:00:00:01", "02:00:00:00:00:02", "02:00:00:00:00:03")
AP_POSITIONS = ((0.0, 0.0), (6.0, 0.0), (0.0, 6.0))


def rss_at(x: float, y: float) -> dict[str, float]:
    """A made-up radio map: RSS falls 3 dB per metre from each AP (distinct at every grid point)."""
    return {bssid: -30.0 - 3.0 * ((x - ax) ** 2 + (y - ay) ** 2) ** 0.5
            for bssid, (ax, ay) in zip(BSSIDS, AP_POSITIONS)}


def scan_message(rss: dict[str, float]) -> WifiScan:
    scan = WifiScan(interface="test", access_points=[AccessPointRss(bssid=b, rssi_dbm=v) for b, v in rss.items()])
    scan.header.frame_id = "base_link"
    return scan


@pytest.fixture
def database(tmp_path: Path) -> Path:
    path = tmp_path / "site.db"
    with LocationStore.open(path, create=True) as store:
        store.add_fingerprints([Fingerprint((float(x), float(y)), rss_at(x, y), "grid")
                                for x in range(6) for y in range(6)])
    return path


@pytest.fixture
def map_file(tmp_path: Path) -> Path:
    path = tmp_path / "home.yaml"
    path.write_text("name: home\ntag_groups:\n  - {id: G1, shape: cross, centre: [2.0, 3.0], size_m: 0.3}\n")
    return path


def start_server(graph: Graph, database: Path, map_file: Path) -> LocationServerNode:
    return graph.add(LocationServerNode(context=graph.context, parameter_overrides=[
        Parameter("database_file", value=str(database)), Parameter("map_file", value=str(map_file)),
        Parameter("k", value=1)]))


def call(graph: Graph, service_type: type, name: str, request):
    client = graph.probe.create_client(service_type, name)
    graph.spin_until(client.service_is_ready, f"{name} to be ready")
    future = client.call_async(request)
    graph.spin_until(future.done, f"the answer of {name}")
    return future.result()


def test_locate_answers_from_the_radio_map_and_fails_with_a_reason(graph: Graph, database: Path,
                                                                   map_file: Path) -> None:
    start_server(graph, database, map_file)
    rss = {**rss_at(4.0, 1.0), "aa:aa:aa:aa:aa:aa": -60.0}
    answer = call(graph, Locate, "/location_server/locate", Locate.Request(scan=scan_message(rss)))
    assert answer.success, answer.message
    assert (answer.x, answer.y) == pytest.approx((4.0, 1.0))
    assert answer.known_aps == 3 and list(answer.ignored_bssids) == ["aa:aa:aa:aa:aa:aa"]
    assert answer.uncertainty_m > 0.0
    empty = call(graph, Locate, "/location_server/locate", Locate.Request(scan=scan_message({})))
    assert not empty.success and "empty" in empty.message
    strangers = call(graph, Locate, "/location_server/locate",
                     Locate.Request(scan=scan_message({"aa:aa:aa:aa:aa:aa": -50.0})))
    assert not strangers.success and strangers.message


def test_tag_map_serves_the_map_file_groups_and_rejects_a_bad_query(graph: Graph, database: Path,
                                                                    map_file: Path) -> None:
    start_server(graph, database, map_file)
    near = call(graph, GetTagMap, "/location_server/tag_map", GetTagMap.Request(x=2.0, y=3.0, radius_m=0.5))
    assert near.success and len(near.tags) == 13       # a 30 cm cross, tags every 5 cm: 4 arms x 3 + centre
    assert {tag.group_id for tag in near.tags} == {"G1"} and {tag.shape for tag in near.tags} == {"cross"}
    assert [tag.tag_id for tag in near.tags] == sorted(tag.tag_id for tag in near.tags)
    far = call(graph, GetTagMap, "/location_server/tag_map", GetTagMap.Request(x=9.0, y=9.0, radius_m=0.5))
    assert far.success and not far.tags
    bad = call(graph, GetTagMap, "/location_server/tag_map", GetTagMap.Request(x=0.0, y=0.0, radius_m=-1.0))
    assert not bad.success and "radius" in bad.message


def test_added_fingerprints_are_used_and_stored_and_a_restart_keeps_one_tag_map(graph: Graph, database: Path,
                                                                                map_file: Path) -> None:
    server = start_server(graph, database, map_file)
    sample = {"02:00:00:00:00:09": -40.0, BSSIDS[0]: -20.0}
    added = call(graph, AddFingerprint, "/location_server/add_fingerprint",
                 AddFingerprint.Request(x=7.5, y=7.5, source="survey", scan=scan_message(sample)))
    assert added.success and added.fingerprint_count == 37
    refused = call(graph, AddFingerprint, "/location_server/add_fingerprint",
                   AddFingerprint.Request(x=1.0, y=1.0, source="survey", scan=scan_message({})))
    assert not refused.success and refused.fingerprint_count == 37
    answer = call(graph, Locate, "/location_server/locate", Locate.Request(scan=scan_message(sample)))
    assert (answer.x, answer.y) == pytest.approx((7.5, 7.5))
    graph.nodes.remove(server)
    graph.executor.remove_node(server)
    server.destroy_node()
    with LocationStore.open(database) as store:
        assert store.fingerprint_count() == 37
        assert [group.group_id for group in store.tag_groups()] == ["G1"]
    start_server(graph, database, map_file)        # the map's group is already there: not added twice
    with LocationStore.open(database) as store:
        assert len(store.tag_groups()) == 1


def test_a_missing_or_corrupt_database_is_one_error_naming_the_file(graph: Graph, tmp_path: Path,
                                                                    map_file: Path) -> None:
    missing = tmp_path / "nowhere.db"
    with pytest.raises(StoreError, match=str(missing)):
        start_server(graph, missing, map_file)
    corrupt = tmp_path / "corrupt.db"
    corrupt.write_bytes(b"not a database at all" * 100)
    with pytest.raises(StoreError, match=str(corrupt)):
        start_server(graph, corrupt, map_file)


@pytest.mark.tier("graph")
def test_the_latency_bench_runs_the_server_in_its_own_process_and_reports_percentiles() -> None:
    from rfidnav_experiments.bench.location_server import benchmark

    figures = benchmark(requests=20)
    assert figures["requests"] == 20 and figures["fingerprints"] == 96
    assert 0.0 < figures["p50_ms"] <= figures["p99_ms"] <= figures["max_ms"]
    assert figures["matcher_ms"] > 0.0


def test_extreme_scans_and_fingerprints_off_the_map_are_refused_and_later_scans_still_locate(
        graph: Graph, database: Path, map_file: Path) -> None:
    server = start_server(graph, database, map_file)
    for rss in (1e308, -1e308, 200.0):
        answer = call(graph, Locate, "/location_server/locate",
                      Locate.Request(scan=scan_message({**rss_at(4.0, 1.0), BSSIDS[0]: rss})))
        assert not answer.success and BSSIDS[0] in answer.message and "dBm" in answer.message, answer.message
    for x, y in ((1e308, 1e308), (40.0, 1.0), (-20.0, -20.0)):     # the map covers [0, 5] x [0, 5] (+ 10 m)
        added = call(graph, AddFingerprint, "/location_server/add_fingerprint",
                     AddFingerprint.Request(x=x, y=y, source="survey", scan=scan_message(rss_at(1.0, 1.0))))
        assert not added.success and added.fingerprint_count == 36, added.message
    assert "outside the map" in added.message and "[0, 5] x [0, 5] m" in added.message, added.message
    wrong_frame = scan_message(rss_at(4.0, 1.0))
    wrong_frame.header.frame_id = "map"
    answer = call(graph, Locate, "/location_server/locate", Locate.Request(scan=wrong_frame))
    assert not answer.success and "expected 'base_link'" in answer.message
    twice = scan_message(rss_at(4.0, 1.0))
    twice.access_points.append(AccessPointRss(bssid=BSSIDS[0], rssi_dbm=-30.0))
    answer = call(graph, Locate, "/location_server/locate", Locate.Request(scan=twice))
    assert not answer.success and f"{BSSIDS[0]} listed twice" in answer.message, answer.message
    assert server.drops.dropped() == 8
    # Growing the map a margin at a time is a survey: 14 m out is taken once 8 m out was.
    for x in (13.0, 19.0):
        added = call(graph, AddFingerprint, "/location_server/add_fingerprint",
                     AddFingerprint.Request(x=x, y=1.0, source="survey", scan=scan_message(rss_at(5.0, 1.0))))
        assert added.success, added.message
    answer = call(graph, Locate, "/location_server/locate", Locate.Request(scan=scan_message(rss_at(4.0, 1.0))))
    assert answer.success and (answer.x, answer.y) == pytest.approx((4.0, 1.0))
    graph.spin_until(lambda: graph.logged("location_server", "/location_server/add_fingerprint: dropped"),
                     "the warning that counts the refused fingerprints")
