"""Two robots in one world over DDS (issue 35): ``./rfidnav run building_ring_pair`` (paper 004, two missions
through one junction and one spur), each robot's nodes under its namespace, one simulator, one stepped clock, one
bag; per-robot outcomes and metrics and the run's own (how near they came), the joint report, and the same commands
for the same seed. Paper 003's pair is test_fleet_flat_graph's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from rfidnav_bag.bags import read_messages
from rfidnav_bringup.report import run_metrics
from support.frames import frame_tree
from support.runs import recorded_commands, run_cli, run_scenario, run_summary, scenario_document

pytestmark = pytest.mark.tier("graph")

ROBOTS = ("r1", "r2")


@pytest.fixture(scope="module")
def ring_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("ring"), "building_ring_pair", "--rtf", "max", "--seed", "1")


def test_both_robots_reach_their_nodes_on_the_ring_each_scored_on_its_own_track(ring_run: Path) -> None:
    document = run_summary(ring_run)
    assert document["success"] is True, document["message"]
    assert set(document["robots"]) == set(ROBOTS)
    for robot, goal, shortest in (("r1", "F", 40.0), ("r2", "A", 15.0)):
        outcome = document["robots"][robot]
        assert outcome["success"] is True and f"at the goal '{goal}'" in outcome["message"], outcome
        metrics = outcome["metrics"]
        assert metrics["success"] and metrics["final_distance_m"] < 0.5 and metrics["wall_crossings"] == 0
        assert metrics["shortest_path_m"] == pytest.approx(shortest)
        assert run_metrics(ring_run, robot) == pytest.approx(metrics)      # from the bag alone
    assert all(node["exit_code"] == 0 and node["restarts"] == 0 for node in document["nodes"].values())
    # The run's own metrics: how near the two came (r2 is through D long before r1 gets there).
    assert document["metrics"]["closest_pair"] == "r1, r2" and document["metrics"]["closest_approach_m"] > 2.0
    assert sorted(document["clock"]["participants"]) == sorted(
        [f"/{robot}/{node}" for robot in ROBOTS
         for node in ("sonar_sim", "rfid_reader_sim", "wall_follower", "mission_executor")] + ["/recorder"])


def test_each_robots_nodes_use_only_its_own_topics_and_frames_under_one_map(ring_run: Path) -> None:
    graph = json.loads((ring_run / "graph.json").read_text())["nodes"]
    for robot in ROBOTS:
        for node in ("wall_follower", "mission_executor"):
            topics = graph[f"{robot}/{node}"]["subscriptions"] + graph[f"{robot}/{node}"]["publishers"]
            own = [t for t in topics if t not in ("/rosout", "/parameter_events", "/sim/step_ack", "/tf",
                                                  "/tf_static") and not t.startswith("/stepped_clock/")]
            assert own and all(t.startswith(f"/{robot}/") for t in own), (robot, node, topics)
            assert not any(t.startswith((f"/{robot}/sim/", "/sim/ground")) for t in
                           graph[f"{robot}/{node}"]["subscriptions"]), (robot, node)
    tree = frame_tree(ring_run)
    for robot in ROBOTS:
        assert tree.root_of(f"{robot}/rfid_antenna_1") == "map"
        assert tree.parents[f"{robot}/base_link"] == f"{robot}/odom"
        assert tree.parents[f"{robot}/odom"] == "map"


def test_each_robots_reader_reads_the_wall_tags_of_its_own_way(ring_run: Path) -> None:
    read = {robot: {r.tag_id for _, _, msg in read_messages(ring_run / "bag", [f"/{robot}/rfid/reads"])
                    for r in msg.readings} for robot in ROBOTS}
    # r1: C's south tag (8) on the rung, D's east tags (11, 12), F's (15); r2: D's west tag (14), A's north (1).
    assert {"8", "11", "15"} <= read["r1"] and {"14", "1"} <= read["r2"], read


def test_the_same_seed_gives_both_robots_the_same_commands(tmp_path: Path) -> None:
    """Two runs of one seed, on shorter missions than the ring's (r1 to C, r2 to D: the same nodes, a quarter of
    the time): both robots' commands equal, bit for bit."""
    document = scenario_document("building_ring_pair")
    document["robots"][0]["mission"]["goal"] = {"goal_node": "C"}
    document["robots"][1]["mission"]["goal"] = {"goal_node": "D"}
    scenario = tmp_path / "short_pair.yaml"
    scenario.write_text(yaml.safe_dump(document))
    first = run_scenario(tmp_path / "first", str(scenario), "--rtf", "max", "--seed", "1")
    again = run_scenario(tmp_path / "again", str(scenario), "--rtf", "max", "--seed", "1")
    assert run_summary(first)["success"] is True, run_summary(first)["message"]
    for robot in ROBOTS:
        commands_first = recorded_commands(first, f"/{robot}/cmd_vel")
        assert len(commands_first) > 100, robot
        assert recorded_commands(again, f"/{robot}/cmd_vel") == commands_first, robot
    assert run_summary(again)["robots"] == run_summary(first)["robots"]


def test_the_report_of_a_run_of_two_gives_each_robots_metrics_and_one_joint_plot(ring_run: Path,
                                                                                  tmp_path: Path) -> None:
    result = run_cli("report", str(ring_run), "--out", str(tmp_path), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert set(report["metrics"]) == {*ROBOTS, "closest_approach_m", "closest_approach_at_s", "closest_pair"}
    assert report["metrics"]["closest_approach_m"] == pytest.approx(
        run_summary(ring_run)["metrics"]["closest_approach_m"])
    assert report["metrics"]["r1"]["final_distance_m"] == pytest.approx(
        run_summary(ring_run)["robots"]["r1"]["metrics"]["final_distance_m"])
    assert [Path(p).name for p in report["plots"]] == ["trajectory.png"]
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
