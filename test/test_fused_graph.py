"""The fused localizer over DDS, one process per node, recorded to MCAP: in ./rfidnav run mixed_floor the two-tier
navigator drives the mission with paper 003's localizer while rfid_localizer, in its own process, weighs every kind
of tag the floor carries, WiFi fixes from the location server and the compass, on /fused/pose; in two_tier_flat
(paper 003's world) the same beside it on the tag groups, WiFi and the compass; in mixed_floor_fused its pose drives
the robot (pose_navigator) and its map -> odom is the tf tree's; in partition_field_fused (paper 000's field) its
status drives the partition navigator, paper 000's localizer beside it; in hallway (paper 001) and building_ring
(paper 004) it rides beside the route follower and the mission executor on their building's tag survey; in
two_tier_flat_fused paper 003's navigator takes its tier one from it. Its errors come from the bag: each pose against
the ground truth at its stamp. And the stepped clock holds a step for a slow location server's answers: the commands
and the fused poses are those of the prompt run."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from rfidnav_bag.bags import read_messages
from rfidnav_msgs.msg import LocalizationStatus
from support.frames import assert_estimates_are_published_as_map_to_odom
from support.runs import (
    WORKSPACE,
    evidence_used,
    navigation_subscriptions,
    pose_errors,
    recorded_commands,
    run_scenario,
    scenario_document,
)

pytestmark = pytest.mark.tier("graph")

WIFI_TIER = LocalizationStatus.TIER_WIFI      # two_tier_navigator's tier one, whatever answered it


@pytest.fixture(scope="module")
def mixed_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "mixed_floor", "--rtf", "max", "--seed", "1")


@pytest.fixture(scope="module")
def driving_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "mixed_floor_fused", "--rtf", "max", "--seed", "1")


@pytest.fixture(scope="module")
def flat_run(tmp_path_factory) -> Path:
    # Seed 2: one the paper's navigator completes (it arrives in 80 % of runs on this flat, README; at seed 1 it
    # stalls at a wall), so that the fused localizer rides a whole mission beside it.
    return run_scenario(tmp_path_factory.mktemp("runs"), "two_tier_flat", "--rtf", "max", "--seed", "2")


@pytest.fixture(scope="module")
def partition_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "partition_field_fused", "--rtf", "max", "--seed", "1")


@pytest.fixture(scope="module")
def hallway_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "hallway", "--rtf", "max", "--seed", "1")


@pytest.fixture(scope="module")
def ring_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "building_ring", "--rtf", "max", "--seed", "1")


@pytest.fixture(scope="module")
def tier_one_run(tmp_path_factory) -> Path:
    # Paper 003's navigator may stall at a wall where its estimate is off (it arrives in 80 % of runs on this flat with
    # its own tier one): the test asks where its tier one came from, not that it arrived.
    return run_scenario(tmp_path_factory.mktemp("runs"), "two_tier_flat_fused", "--rtf", "max", "--seed", "1",
                        mission_may_fail=True)


def rms(errors: np.ndarray) -> float:
    return math.sqrt(float(np.mean(np.square(errors))))


def test_the_fused_pose_beside_the_navigator_tracks_the_robot_to_a_decimetre_from_every_kind_of_evidence(
        mixed_run: Path) -> None:
    summary = json.loads((mixed_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    errors, covariances = pose_errors(mixed_run, "/fused/pose")
    assert len(errors) > 100                                    # a pose per reader round, 25 a second
    assert rms(errors) < 0.25
    assert all(np.allclose(c, c.T) and c[0, 0] > 0.0 and c[5, 5] > 0.0 for c in covariances)
    assert evidence_used(mixed_run, "/fused/status") == {"lattice", "tag_group", "ceiling_phase",
                                                         "ceiling_range_rate", "wall_tag", "wifi", "compass"}


def test_on_paper_003s_flat_the_fused_localizer_rides_beside_the_two_tier_navigator_on_tag_groups_wifi_and_compass(
        flat_run: Path) -> None:
    summary = json.loads((flat_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    errors, _ = pose_errors(flat_run, "/fused/pose")
    assert len(errors) > 100
    # reproduce fused: 0.95 +- 0.29 m on this flat over 10 runs (WiFi places it between the tag groups)
    assert rms(errors) < 2.0 and float(np.median(errors)) < 1.0
    assert evidence_used(flat_run, "/fused/status") == {"tag_group", "wifi", "compass"}
    assert "/fused/pose" not in navigation_subscriptions(flat_run, ("two_tier_navigator",))["two_tier_navigator"]


def test_the_fused_localizer_knows_neither_world_nor_ground_truth(mixed_run: Path) -> None:
    subscriptions = navigation_subscriptions(mixed_run, ("rfid_localizer",))
    assert {"/odom", "/rfid/reads", "/compass", "/wifi/scan", "/initialpose"} <= subscriptions["rfid_localizer"]


def test_the_fused_pose_drives_the_robot_to_its_goal_and_is_the_tf_trees_map_to_odom(driving_run: Path) -> None:
    summary = json.loads((driving_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    assert summary["metrics"]["final_error_m"] < 0.5 and summary["metrics"]["wall_crossings"] == 0
    errors, _ = pose_errors(driving_run, "/localization/pose")
    assert rms(errors) < 0.25
    assert assert_estimates_are_published_as_map_to_odom(driving_run) > 100
    subscriptions = navigation_subscriptions(driving_run, ("rfid_localizer", "pose_navigator"))
    assert "/localization/pose" in subscriptions["pose_navigator"]


def test_on_paper_000s_field_the_partition_navigator_drives_on_the_fused_status_with_the_papers_localizer_beside(
        partition_run: Path) -> None:
    summary = json.loads((partition_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    # Position arrival: the estimate within r/4 = 5 cm of the goal (reproduce fused: 2-6 cm by the truth).
    assert summary["metrics"]["final_error_m"] < 0.2
    fused, _ = pose_errors(partition_run, "/fused/pose")
    paper, _ = pose_errors(partition_run, "/localization/pose")
    assert len(fused) > 100 and len(paper) > 100
    assert rms(fused) < 0.15 and rms(paper) < 0.3
    assert evidence_used(partition_run, "/fused/status") == {"lattice"}
    assert assert_estimates_are_published_as_map_to_odom(partition_run, status_topic="/fused/status") > 100
    subscriptions = navigation_subscriptions(partition_run, ("partition_navigator",))["partition_navigator"]
    assert "/fused/status" in subscriptions and "/localization/status" not in subscriptions


def test_on_paper_001s_hallway_the_fused_localizer_rides_beside_the_route_follower_on_the_ceiling_tags_phase(
        hallway_run: Path) -> None:
    summary = json.loads((hallway_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    errors, _ = pose_errors(hallway_run, "/fused/pose")
    assert len(errors) > 1000
    # reproduce fused: 0.67 +- 0.39 m over 10 runs, most of it at the start (the mirror image along the hallway
    # until the first floor tag); here 0.39 m, median 3.5 cm. The odometry alone is metres off by the end.
    assert float(np.median(errors)) < 0.3 and rms(errors) < 1.5
    assert evidence_used(hallway_run, "/fused/status") == {"ceiling_phase", "ceiling_range_rate", "tag_group"}
    subscriptions = navigation_subscriptions(hallway_run, ("heading_controller",))["heading_controller"]
    assert not any(topic.startswith("/fused") for topic in subscriptions)


def test_on_paper_004s_ring_the_fused_localizer_rides_beside_the_executor_on_the_wall_tag_survey(
        ring_run: Path) -> None:
    summary = json.loads((ring_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    errors, _ = pose_errors(ring_run, "/fused/pose")
    assert len(errors) > 500
    # Plates tens of metres apart on a 37 x 15 m floor, no compass (reproduce fused: 4.7 +- 0.7 m over 10 runs):
    # metres off between tags, placed by each plate (here 6.1 m RMSE, median 1.4 m).
    assert float(np.median(errors)) < 3.0 and rms(errors) < 10.0
    assert evidence_used(ring_run, "/fused/status") == {"wall_tag"}     # every plate read is one the survey knows


def test_paper_003s_navigator_takes_each_tier_one_fix_from_the_fused_pose(tier_one_run: Path) -> None:
    summary = json.loads((tier_one_run / "summary.json").read_text())
    assert summary["metrics"]["path_length_m"] > 1.0, summary["message"]       # it drove on its tier one
    errors, _ = pose_errors(tier_one_run, "/fused/pose")
    # A pose per reader poll, two a second. Tracking, not lost: a pose anywhere on this 14 x 8 m flat would be
    # 4-5 m RMS off. How far off it is depends on where the robot stalls: 0.3-1.9 m in-process over seeds 1-12;
    # here at seed 1, 1.5 m in every run, loaded or not, since the stepped clock holds service calls (before, the
    # location server's answers landed as late as the load made them: 2.5 m in one loaded CI run).
    assert len(errors) > 20 and rms(errors) < 3.5
    subscriptions = navigation_subscriptions(tier_one_run, ("two_tier_navigator",))["two_tier_navigator"]
    assert "/fused/pose" in subscriptions
    # Each tier-one fix (standing still, no distance since) is, to the bit, a pose rfid_localizer published.
    fused = {(m.pose.pose.position.x, m.pose.pose.position.y)
             for _, _, m in read_messages(tier_one_run / "bag", ["/fused/pose"])}
    fixes = [(m.x, m.y) for _, _, m in read_messages(tier_one_run / "bag", ["/localization/status"])
             if m.method == "two_tier" and m.last_fix_tier == WIFI_TIER and m.distance_since_fix_m == 0.0]
    assert fixes and all(fix in fused for fix in fixes)


def test_a_slow_location_server_slows_the_run_but_changes_neither_commands_nor_fused_poses(
        flat_run: Path, tmp_path: Path) -> None:
    """Paper 003's navigator calls the location server (locate, tag map), and so does rfid_localizer beside it
    (locate): each call holds its step until the answer has been handled, so an answer 0.3 s of wall time late
    (at --rtf max, seconds of simulated time) lands in the same step as a prompt one (flat_run's)."""
    document = scenario_document("two_tier_flat")
    server = document["nodes"]["location_server"]
    document["nodes"]["location_server"] = {
        "command": f"{sys.executable} {WORKSPACE / 'test/support/slow_location_server.py'}",
        "name": "location_server", "stepped": True, "params": server["params"],
        # A command role is not told the run's folder: its database goes here, not into the working directory.
        "overrides": {**server["overrides"], "database_file": str(tmp_path / "location.db")}}
    (tmp_path / "slow.yaml").write_text(yaml.safe_dump(document))
    slow = run_scenario(tmp_path / "slow", str(tmp_path / "slow.yaml"), "--rtf", "max", "--seed", "2")
    # rfid_localizer alone locates a scan a second, over a mission of a minute or more: tens of slow answers.
    assert wall_duration_s(slow) > wall_duration_s(flat_run) + 10 * 0.3
    assert len(recorded_commands(flat_run)) > 100 and recorded_commands(slow) == recorded_commands(flat_run)
    # rfid_localizer goes on for the steps after the mission until the clock source stops (~/settle), as many as
    # the load lets through: one run's poses are the other's up to where the shorter ends.
    shorter, longer = sorted((fused_poses(slow), fused_poses(flat_run)), key=len)
    assert len(shorter) > 50 and longer[:len(shorter)] == shorter


def wall_duration_s(run: Path) -> float:
    return json.loads((run / "summary.json").read_text())["wall_duration_s"]


def fused_poses(run: Path) -> list[tuple[float, float, float]]:
    return [(msg.pose.pose.position.x, msg.pose.pose.position.y, msg.pose.pose.orientation.z)
            for _, _, msg in read_messages(run / "bag", ["/fused/pose"])]
