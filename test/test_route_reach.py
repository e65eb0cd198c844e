"""Reach is a property, not a surprise (issue 18): a scenario whose route leg is beyond the reader's reach says so
when it loads (a warning, not an error), the in-tree routes do not, and the heading controller's search carries
the long_legs route (every leg beyond reach) to every tag with both controllers in-process, and over DDS the report
leaves a search out of the tracking error as the in-process runner does.

The reach itself against the link budget by hand: test_rfid_model.py; the search's pattern: test_tag_route.py."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest

from rfidnav_bringup.report import load_run, route_points, run_metrics
from rfidnav_experiments.bench.routes import PARAM_SETS, ROUTES
from rfidnav_experiments.runners.tag_route import controller_parameters, role_parameters, run_tag_route
from rfidnav_scenario.metrics import tracking_metrics
from rfidnav_scenario.scenario import SCENARIO_DIR, load_scenario
from support.config_files import copy_config, edit
from support.runs import WORKSPACE, run_scenario

pytestmark = pytest.mark.tier("unit")

CONFIG_PARAMS = WORKSPACE / "config" / "params"
LINE = ("scenarios/line_follow_90.yaml", "worlds/line_follow.yaml", "maps/line_follow.yaml", "params/robot_sim.yaml",
        "params/reader_uhf_2ant.yaml", "params/flc_tuned.yaml")


def test_a_route_leg_beyond_the_readers_reach_is_a_warning_naming_the_leg_and_the_reach(tmp_path: Path) -> None:
    root = copy_config(tmp_path, LINE)
    # C2 from (0, 5) to (0, 9.2), still 3 m up: 9.2 m from C1, beyond the 9.09 m the link budget gives.
    edit(root / "worlds/line_follow.yaml", "{id: C2, position: [0.0, 5.0, 3.0]}", "{id: C2, position: [0.0, 9.2, 3.0]}")
    scenario = load_scenario(str(root / "scenarios/line_follow_90.yaml"))
    assert len(scenario.warnings) == 1
    warning = scenario.warnings[0]
    assert warning.startswith(f"{root / 'scenarios/line_follow_90.yaml'}: mission.goal.tag_ids: ")
    assert "the leg C1 -> C2 is 9.2 m" in warning and "(9.09 m, from its link budget)" in warning
    assert "has to search for C2" in warning
    edit(root / "worlds/line_follow.yaml", "[0.0, 9.2, 3.0]", "[0.0, 9.0, 3.0]")     # just within reach
    assert load_scenario(str(root / "scenarios/line_follow_90.yaml")).warnings == ()


IN_TREE_ROUTES = sorted(path.stem for path in SCENARIO_DIR.glob("*.yaml")
                        if "tag_ids:" in path.read_text() and path.stem != "long_legs")


def test_the_in_tree_routes_are_paper_001s_four() -> None:
    assert IN_TREE_ROUTES == sorted(set(ROUTES) - {"long_legs"})


@pytest.mark.parametrize("name", IN_TREE_ROUTES)
def test_no_in_tree_route_has_a_leg_beyond_reach(name: str) -> None:
    scenario = load_scenario(name)
    assert len(scenario.mission.goal["tag_ids"]) >= 2 and scenario.warnings == ()


def test_every_leg_of_long_legs_is_beyond_reach_and_eight_to_fourteen_metres() -> None:
    scenario = load_scenario("long_legs")
    route = scenario.mission.goal["tag_ids"]
    assert len(scenario.warnings) == len(route) - 1
    legs = [float(w.split(" is ")[1].split(" m,")[0]) for w in scenario.warnings]
    assert min(legs) >= 8.0 and max(legs) <= 14.0
    assert {tag.position[2] for tag in scenario.world.tags if tag.tag_id in route} <= {2.5, 2.7, 2.8, 3.0}


@pytest.mark.tier("slow")
@pytest.mark.parametrize("params", PARAM_SETS)
def test_the_in_process_runner_reaches_every_tag_of_long_legs_by_searching(params: str) -> None:
    scenario = load_scenario("long_legs")
    run = run_tag_route(scenario, controller_parameters(scenario, CONFIG_PARAMS / f"{params}.yaml", 1), 1)
    assert run.success, run.message
    assert len(run.arrival_times_s) == len(scenario.mission.goal["tag_ids"])
    assert run.metrics.search_s > 60.0           # it did search: no leg is heard from the tag before it


@pytest.mark.tier("slow")
def test_without_the_search_long_legs_fails_unheard_at_its_first_leg() -> None:
    scenario = load_scenario("long_legs")
    controller = controller_parameters(scenario, CONFIG_PARAMS / "flc_paper.yaml", 1)
    run = run_tag_route(scenario, replace(controller, unheard_search=False), 1)
    assert not run.success and len(run.arrival_times_s) == 1
    assert run.message.startswith("target tag 'T2' unheard for 10.")


@pytest.mark.tier("graph")
def test_a_search_over_dds_is_left_out_of_the_tracking_error_and_scored_as_in_process(tmp_path: Path) -> None:
    """long_legs' first leg lies beyond the reader's reach: the follower searches (its feedback's mode) and the
    report leaves the search out of e(t), as the in-process runner does from its commands, and says where the robot
    stopped against the scenario's bound."""
    route = ["T1", "T2"]
    run = run_scenario(tmp_path, "long_legs", "--goal", f"{{tag_ids: [{', '.join(route)}]}}", "--rtf", "max",
                       "--seed", "1")
    metrics = json.loads((run / "summary.json").read_text())["metrics"]
    scenario = load_scenario("long_legs", goal={"tag_ids": route})
    in_process = run_tag_route(scenario, role_parameters(scenario, "heading_controller", 1), 1).metrics
    assert metrics["searches"] == in_process.searches == 1
    assert metrics["search_s"] == pytest.approx(in_process.search_s, abs=0.5)     # DDS: a round or two later
    assert metrics["search_length_m"] == pytest.approx(in_process.search_length_m, abs=0.2)
    record = load_run(run)
    with_search = tracking_metrics(record.ground_truth, route_points(record.world, route), record.arrival_times_s,
                                   record.mission_start_s, record.mission_end_s)
    # Here the search is mostly its turn on the spot, on the leg: leaving it out changes e(t)'s samples, not much more.
    assert metrics["tracking_rmse_m"] != pytest.approx(with_search.tracking_rmse_m, rel=1e-3)
    assert metrics["tracking_rmse_m"] == pytest.approx(in_process.tracking_rmse_m, abs=0.005)
    assert metrics["success"] is True and metrics["final_distance_m"] <= metrics["success_within_m"] == 0.10
    # The same stop against a bound tighter than where it stopped (about 1 cm from T2): no success by ground truth.
    scenario_file = run / "scenario.yaml"
    scenario_file.write_text(scenario_file.read_text().replace("success_within_m: 0.1", "success_within_m: 0.001"))
    assert metrics["final_distance_m"] > 0.001 and run_metrics(run)["success"] is False
