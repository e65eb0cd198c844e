"""Full-graph test of paper 003 over DDS: ./rfidnav run two_tier_home, one process per node, recorded to MCAP
(robot_sim, the HF floor reader, wifi_sim, compass_sim, location_server, two_tier_navigator); one run shared by
the tests of this module (~30 s of wall time at RTF 5)."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rfidnav_bringup.report import run_metrics
from support.frames import assert_estimates_are_published_as_map_to_odom, frame_tree
from support.runs import navigation_subscriptions, run_scenario

pytestmark = pytest.mark.tier("graph")

NAVIGATION_NODES = ("location_server", "two_tier_navigator")


@pytest.fixture(scope="module")
def home_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "two_tier_home", "--rtf", "max", "--seed", "1")


def test_the_robot_reaches_the_target_with_centimetre_fixes(home_run: Path) -> None:
    summary = json.loads((home_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    metrics = summary["metrics"]
    assert metrics["final_error_m"] < 0.15
    assert len(metrics["fix_error_m"]) >= 4 and metrics["fix_error_median_m"] < 0.06
    assert metrics["max_error_m"] < 0.2                   # a tag fix is never metres off, as tier one is
    assert metrics["searches"] >= 1 and 0.0 < metrics["search_length_m"] < metrics["path_length_m"]
    assert all(node["exit_code"] == 0 and node["restarts"] == 0 for node in summary["nodes"].values())
    assert run_metrics(home_run)["fix_error_m"] == pytest.approx(metrics["fix_error_m"])   # from the bag alone


def test_navigation_nodes_know_neither_world_nor_ground_truth(home_run: Path) -> None:
    subscriptions = navigation_subscriptions(home_run, NAVIGATION_NODES)
    assert {"/wifi/scan", "/compass", "/rfid/reads", "/odom"} <= subscriptions["two_tier_navigator"]

def test_the_location_database_lives_in_the_run_folder_with_the_maps(home_run: Path) -> None:
    with sqlite3.connect(home_run / "location.db") as database:
        assert database.execute("SELECT COUNT(*) FROM fingerprints").fetchone()[0] == 96
        assert database.execute("SELECT COUNT(*) FROM tag_groups").fetchone()[0] == 12


def test_the_bag_holds_scans_compass_and_tiers_that_third_party_readers_decode(home_run: Path) -> None:
    mcap_file = next((home_run / "bag").glob("*.mcap"))
    counts = {"/wifi/scan": 0, "/compass": 0}
    tiers = set()
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages(
                topics=["/wifi/scan", "/compass", "/localization/status"]):
            if channel.topic == "/localization/status":
                tiers.add(decoded.last_fix_tier)
            else:
                counts[channel.topic] += 1
                if channel.topic == "/wifi/scan":
                    assert len(decoded.access_points) == 4
    assert counts["/wifi/scan"] > 10 and counts["/compass"] > 100
    assert {1, 2} <= tiers


def test_the_navigators_estimate_is_map_to_odom_and_the_compass_frame_resolves(home_run: Path) -> None:
    assert assert_estimates_are_published_as_map_to_odom(home_run) > 10
    assert frame_tree(home_run).root_of("compass") == "map"
