"""Paper 003's robot survey over DDS (issue 35): ``./rfidnav run two_tier_home_survey``, two_tier_navigator's
/survey action, builds the location server's radio map from an empty one while the robot drives from the dock to
its eleven landmarks (~45 s of wall time); a two-tier mission then navigates on that radio map alone (~30 s).
``./rfidnav bench survey`` compares both with the in-process survey's."""

from __future__ import annotations

import bisect
import json
import math
import re
import sqlite3
from pathlib import Path

import pytest

from rfidnav_bag.bags import read_messages
from rfidnav_experiments.bench.survey import location_server_params, surveyed_fingerprints
from support.runs import navigation_subscriptions, run_cli, run_scenario

pytestmark = pytest.mark.tier("graph")

@pytest.fixture(scope="module")
def survey_run(tmp_path_factory) -> Path:
    # Its success is every landmark reached: a leg may end at a wall, as the in-process survey's legs may.
    return run_scenario(tmp_path_factory.mktemp("runs"), "two_tier_home_survey", "--rtf", "max", "--seed", "1",
                        mission_may_fail=True)


def true_positions(run: Path) -> tuple[list[float], list[tuple[float, float]]]:
    """The robot's true track from the bag: (stamps [s], positions)."""
    stamps, positions = [], []
    for _, _, msg in read_messages(run / "bag", ["/sim/ground_truth"]):
        stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
        positions.append((msg.pose.pose.position.x, msg.pose.pose.position.y))
    return stamps, positions


def test_the_survey_drives_to_every_landmark_and_fills_an_empty_radio_map(survey_run: Path) -> None:
    summary = json.loads((survey_run / "summary.json").read_text())
    found = re.match(r"(\d+) of 11 landmarks reached, (\d+) fingerprints added", summary["message"])
    assert found, summary["message"]
    reached, added = int(found[1]), int(found[2])
    assert summary["success"] is (reached == 11)
    fingerprints = surveyed_fingerprints(survey_run)
    assert len(fingerprints) == added >= 20      # the flat's 96 m^2, a scan every 0.5 m near fixes: dozens
    with sqlite3.connect(survey_run / "location.db") as database:
        assert database.execute("SELECT DISTINCT source FROM fingerprints").fetchall() == [("survey",)]
        assert database.execute("SELECT COUNT(*) FROM tag_groups").fetchone()[0] == 12     # the map's, as ever
    assert all(node["exit_code"] == 0 and node["restarts"] == 0 for node in summary["nodes"].values())
    log = (survey_run / "logs" / "two_tier_navigator.log").read_text()
    assert len(re.findall(r"survey leg \d+/11: to ", log)) == 11 and "survey leg 1/11: to T2 from the dock" in log


def test_each_fingerprint_is_where_the_robot_believed_it_was_near_a_tag_fix(survey_run: Path) -> None:
    """Recorded at the believed position, never the true one, yet within 2 m of odometry of a centimetre fix: a
    few centimetres from where the robot really was when the scan was taken (the bag's ground truth)."""
    stamps, positions = true_positions(survey_run)
    with sqlite3.connect(survey_run / "location.db") as database:
        rows = database.execute("SELECT x, y, created_s FROM fingerprints ORDER BY id").fetchall()
    errors = []
    for x, y, created_s in rows:
        index = min(bisect.bisect_left(stamps, created_s), len(stamps) - 1)
        assert abs(stamps[index] - created_s) < 0.05, "no ground truth at the scan's stamp"
        errors.append(math.dist((x, y), positions[index]))
    assert 0.0 < max(errors) < 0.3, errors
    assert len(set(map(tuple, (row[:2] for row in rows)))) == len(rows)    # every scan at a place of its own


def test_the_surveying_navigator_knows_no_ground_truth(survey_run: Path) -> None:
    subscriptions = navigation_subscriptions(survey_run, ("two_tier_navigator",))
    assert "/sim/ground_truth" not in subscriptions["two_tier_navigator"]


def test_a_two_tier_mission_navigates_on_the_surveyed_radio_map_alone(survey_run: Path, tmp_path: Path) -> None:
    fingerprints = surveyed_fingerprints(survey_run)
    params = location_server_params(fingerprints, tmp_path, "surveyed")
    run = run_scenario(tmp_path / "runs", "two_tier_home", "--rtf", "max", "--seed", "1", "--params",
                       f"location_server={params}")
    summary = json.loads((run / "summary.json").read_text())
    server_log = (run / "logs" / "location_server.log").read_text()
    assert f"{len(fingerprints)} fingerprints, 12 tag groups" in server_log     # the survey's map, not the grid's
    assert summary["success"] is True, summary["message"]
    assert summary["metrics"]["final_error_m"] < 0.17


def test_a_survey_goal_naming_an_unknown_landmark_is_rejected_in_one_line(tmp_path: Path) -> None:
    result = run_cli("run", "two_tier_home_survey", "--rtf", "max", "--seed", "1", "--out", str(tmp_path),
                     "--goal", "{dock: T1, landmarks: [Q7], spacing_m: 0.5}")
    assert result.returncode != 0
    assert "goal rejected by /survey" in result.stdout + result.stderr
    assert "no tag group 'Q7' in the map" in result.stdout + result.stderr
