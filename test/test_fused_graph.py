"""The fused localizer over DDS, one process per node, recorded to MCAP: in ./rfidnav run mixed_floor the two-tier
navigator drives the mission with paper 003's localizer while rfid_localizer, in its own process, weighs every kind
of tag the floor carries, WiFi fixes from the location server and the compass, on /fused/pose; in mixed_floor_fused
its pose drives the robot (pose_navigator) and its map -> odom is the tf tree's. Its errors come from the bag: each
pose against the ground truth at its stamp."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from rfidnav_bag.bags import read_messages
from rfidnav_bringup.metrics import position_errors
from rfidnav_bringup.report import load_run
from support.frames import assert_estimates_are_published_as_map_to_odom
from support.runs import navigation_subscriptions, run_scenario

pytestmark = pytest.mark.tier("graph")


@pytest.fixture(scope="module")
def mixed_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "mixed_floor", "--rtf", "5", "--seed", "1")


@pytest.fixture(scope="module")
def driving_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "mixed_floor_fused", "--rtf", "5", "--seed", "1")


def fused_poses(run: Path, topic: str = "/fused/pose") -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    times, xy, covariances = [], [], []
    for _, _, message in read_messages(run / "bag", [topic]):
        times.append(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9)
        xy.append((message.pose.pose.position.x, message.pose.pose.position.y))
        covariances.append(np.asarray(message.pose.covariance).reshape(6, 6))
    return np.array(times), np.array(xy), covariances


def test_the_fused_pose_beside_the_navigator_tracks_the_robot_to_a_decimetre_from_every_kind_of_evidence(
        mixed_run: Path) -> None:
    summary = json.loads((mixed_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    times, xy, covariances = fused_poses(mixed_run)
    errors = position_errors(load_run(mixed_run).ground_truth, times, xy)
    assert len(errors) > 100                                    # a pose per reader round, 25 a second
    assert math.sqrt(float(np.mean(np.square(errors)))) < 0.25
    assert all(np.allclose(c, c.T) and c[0, 0] > 0.0 and c[5, 5] > 0.0 for c in covariances)
    used = set()
    for _, _, status in read_messages(mixed_run / "bag", ["/fused/status"]):
        assert status.method == "fused"
        used.update(status.evidence_used)
    assert used == {"lattice", "tag_group", "ceiling_phase", "ceiling_range_rate", "wall_tag", "wifi", "compass"}


def test_the_fused_localizer_knows_neither_world_nor_ground_truth(mixed_run: Path) -> None:
    subscriptions = navigation_subscriptions(mixed_run, ("rfid_localizer",))
    assert {"/odom", "/rfid/reads", "/compass", "/wifi/scan", "/initialpose"} <= subscriptions["rfid_localizer"]


def test_the_fused_pose_drives_the_robot_to_its_goal_and_is_the_tf_trees_map_to_odom(driving_run: Path) -> None:
    summary = json.loads((driving_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    assert summary["metrics"]["final_error_m"] < 0.5 and summary["metrics"]["wall_crossings"] == 0
    times, xy, _ = fused_poses(driving_run, "/localization/pose")
    errors = position_errors(load_run(driving_run).ground_truth, times, xy)
    assert math.sqrt(float(np.mean(np.square(errors)))) < 0.25
    assert assert_estimates_are_published_as_map_to_odom(driving_run) > 100
    subscriptions = navigation_subscriptions(driving_run, ("rfid_localizer", "pose_navigator"))
    assert "/localization/pose" in subscriptions["pose_navigator"]
