"""Full-graph test of paper 000 over DDS: ./rfidnav run partition_field, one process per node, recorded to MCAP.

robot_sim, rfid_reader_sim (reading the lattice described in the world), partition_localizer and
partition_navigator, and the fused localizer beside on its own topics; one run shared by the tests of this module
(~15 s of wall time)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rfidnav_bringup.report import run_metrics
from rfidnav_common.tag_lattice import decode_tag_id, make_deployment
from support.frames import assert_estimates_are_published_as_map_to_odom
from support.runs import evidence_used, navigation_subscriptions, pose_errors, run_cli, run_scenario

pytestmark = pytest.mark.tier("graph")

NAVIGATION_NODES = ("partition_localizer", "partition_navigator")


@pytest.fixture(scope="module")
def field_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "partition_field", "--rtf", "max", "--seed", "1")


def test_partition_navigation_reaches_the_goal_partition(field_run: Path) -> None:
    summary = json.loads((field_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    metrics = summary["metrics"]
    # Ground truth: the robot stopped in the goal's partition (within 2 r of the goal) after driving at least
    # nearly the straight distance, and not absurdly more (paper 000 Fig. 13: tens of percent at r = 20 cm).
    assert metrics["final_error_m"] <= 0.4
    assert -10.0 < metrics["extra_cost_pct"] < 100.0
    assert metrics["replans"] is not None and metrics["replans"] >= 0
    assert all(node["exit_code"] == 0 for node in summary["nodes"].values()), summary["nodes"]
    field = make_deployment("triangular", 0.2, (0.0, 0.0, 5.0, 5.0))
    assert math.isclose(metrics["straight_distance_m"], math.dist((1.0, 1.2), (4.0, 3.8)), abs_tol=0.02)
    assert field.partition_at(4.0, 3.8)


def test_navigation_nodes_know_neither_world_nor_ground_truth(field_run: Path) -> None:
    subscriptions = navigation_subscriptions(field_run, NAVIGATION_NODES)
    assert "/rfid/reads" in subscriptions["partition_localizer"]
    assert "/localization/status" in subscriptions["partition_navigator"]

def test_bag_holds_plans_and_status_that_third_party_readers_decode(field_run: Path) -> None:
    mcap_file = next((field_run / "bag").glob("*.mcap"))
    plans, statuses = [], 0
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages(topics=["/planning/partitions",
                                                                            "/localization/status"]):
            if channel.topic == "/planning/partitions":
                plans.append(decoded)
            else:
                statuses += 1
                for tag_id in decoded.partition_tag_ids:
                    assert decode_tag_id(tag_id).layout == "triangular"
    assert statuses > 100
    assert plans and all(len(plan.partitions) >= 1 for plan in plans)
    # The first plan runs from where the robot localized to the goal, in partitions whose centres approach it.
    first = plans[0]
    assert (first.goal.x, first.goal.y) == pytest.approx((4.0, 3.8))
    distances = [math.dist((p.centre.x, p.centre.y), (4.0, 3.8)) for p in first.partitions]
    assert distances[-1] < distances[0]


def test_the_fused_localizer_beside_the_partition_localizer_places_the_robot_from_the_lattice_ids_alone(
        field_run: Path) -> None:
    errors, covariances = pose_errors(field_run, "/fused/pose")
    assert len(errors) > 100 and all(np.allclose(c, c.T) for c in covariances)
    # reproduce fused: 4.7 +- 0.7 cm on this field; the first rounds are before the first tag is read
    assert float(np.median(errors)) < 0.1 and math.sqrt(float(np.mean(np.square(errors)))) < 0.3
    assert evidence_used(field_run, "/fused/status") == {"lattice"}


def test_report_recomputes_the_summary_metrics(field_run: Path) -> None:
    summary = json.loads((field_run / "summary.json").read_text())
    assert run_metrics(field_run) == summary["metrics"]


def test_a_goal_off_the_deployment_is_refused_before_anything_starts(tmp_path: Path) -> None:
    result = run_cli("run", "partition_field", "--goal", "{target: {x: 7.0, y: 1.0, z: 0.0}, tolerance_m: 0.0}",
                     "--out", str(tmp_path))
    assert result.returncode == 2
    assert "outside the map's deployment_area" in result.stderr and "Traceback" not in result.stderr
    assert not list(tmp_path.iterdir())


def test_the_localizers_estimate_is_published_as_map_to_odom(field_run: Path) -> None:
    assert assert_estimates_are_published_as_map_to_odom(field_run) > 10
