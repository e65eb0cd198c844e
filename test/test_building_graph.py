"""Full-graph tests of paper 004 over DDS: ./rfidnav run building_floor, one process per node, recorded to MCAP
(robot_sim, sonar_sim, the wall-tag reader, wall_follower, mission_executor): the paper's run from tag 23 to g
with every tag read, and again with the goal's tag unreadable (~15 s of wall time each at RTF 5)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rfidnav_bag.bags import read_messages
from rfidnav_bringup.report import run_metrics
from rfidnav_sim.sonar_model import PAPER_LAYOUT
from support.frames import frame_tree
from support.runs import WORKSPACE, navigation_subscriptions, run_scenario

pytestmark = pytest.mark.tier("graph")

NAVIGATION_NODES = ("wall_follower", "mission_executor")


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory) -> Path:
    return run_scenario(tmp_path_factory.mktemp("runs"), "building_floor", "--rtf", "max", "--seed", "1")


@pytest.fixture(scope="module")
def missed_goal_tag_run(tmp_path_factory) -> Path:
    reader = (WORKSPACE / "config/params/reader_wall_side.yaml").read_text()
    assert "unreadable_tags: []" in reader
    params = tmp_path_factory.mktemp("params") / "reader_tag_19_unreadable.yaml"
    params.write_text(reader.replace("unreadable_tags: []", "unreadable_tags: ['19']"))
    return run_scenario(tmp_path_factory.mktemp("runs"), "building_floor", "--rtf", "max", "--seed", "2",
                        "--params", f"rfid_reader={params}")


def test_the_papers_run_reaches_g_with_a_right_turn_at_h(paper_run: Path) -> None:
    summary = json.loads((paper_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    metrics = summary["metrics"]
    assert metrics["success"] and metrics["final_distance_m"] < 0.5
    assert (metrics["tags_missed"], metrics["replans"]) == (0, 0)
    assert metrics["shortest_path_m"] == pytest.approx(11.0)          # 3 m to h, 8 m from h down to g
    assert 0.9 < metrics["path_over_shortest"] < 1.1
    assert all(node["exit_code"] == 0 and node["restarts"] == 0 for node in summary["nodes"].values())
    assert run_metrics(paper_run) == pytest.approx(metrics)            # from the bag alone


def test_with_the_goals_tag_unreadable_the_junction_still_ends_the_mission(missed_goal_tag_run: Path) -> None:
    summary = json.loads((missed_goal_tag_run / "summary.json").read_text())
    assert summary["success"] is True, summary["message"]
    assert "missed tag" in summary["message"]
    metrics = summary["metrics"]
    assert metrics["success"] and metrics["final_distance_m"] < 0.5
    assert metrics["tags_missed"] == 1 and metrics["replans"] == 0


def test_navigation_nodes_know_neither_world_nor_ground_truth(paper_run: Path) -> None:
    subscriptions = navigation_subscriptions(paper_run, NAVIGATION_NODES)
    assert {"/sonar/left", "/sonar/front", "/odom", "/wall_follower/command"} <= subscriptions["wall_follower"]
    assert {"/rfid/reads", "/wall_follower/event"} <= subscriptions["mission_executor"]

def test_the_bag_holds_sonar_tags_commands_and_events_that_third_party_readers_decode(paper_run: Path) -> None:
    mcap_file = next((paper_run / "bag").glob("*.mcap"))
    events, commands, tags, sonar = [], [], set(), 0
    with mcap_file.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages(
                topics=["/sonar/left", "/rfid/reads", "/wall_follower/command", "/wall_follower/event"]):
            if channel.topic == "/sonar/left":
                sonar += 1
            elif channel.topic == "/rfid/reads":
                tags.update(reading.tag_id for reading in decoded.readings)
            elif channel.topic == "/wall_follower/command":
                commands.append(decoded.action)
            else:
                events.append(decoded.event)
    assert sonar > 500                                                 # 20 sweeps/s over ~58 s of sim time
    assert {"23", "19"} <= tags
    assert commands[0] == "follow" and "right" in commands and commands[-1] == "stop"
    assert events.index("junction_centre") < events.index("turn_done") < events.index("stopped")


def test_every_sonar_frame_resolves_to_the_map(paper_run: Path) -> None:
    tree = frame_tree(paper_run)
    topics = [f"/sonar/{rangefinder.name}" for rangefinder in PAPER_LAYOUT]
    sonar_frames = {m.header.frame_id for _, _, m in read_messages(paper_run / "bag", topics)}
    assert len(sonar_frames) == 7 and "sonar_front" in sonar_frames
    assert {tree.root_of(frame) for frame in sonar_frames} == {"map"}
