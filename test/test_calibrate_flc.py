"""Paper 001's open calibration and its faithful baseline: flc_paper has nothing the paper lacks, the calibrated
file is flc_paper with only its output range scaled and reproduces the figures it was fitted to, the evaluation
seeds are not the calibration's, and the reproduction's conditions table lists every setting of its files."""

from __future__ import annotations

import dataclasses
import json

import pytest
import yaml

from rfidnav_common.config import node_parameter_values
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_experiments.calibrate.flc import (
    CALIBRATED_FILE,
    CALIBRATION_SEEDS,
    FITTED_SCENARIOS,
    HELD_OUT_SCENARIOS,
    OPEN_SETTINGS,
    PAPER_FILE,
    Opens,
    Point,
    calibrated_reader,
    points_of,
    scenario_named,
    timeout_s,
    with_opens,
)
from rfidnav_experiments.reproduce.flc.conditions import evaluation_seeds
from rfidnav_experiments.reproduce.flc.provenance import SOURCES, conditions
from rfidnav_experiments.reproduce.flc.rows import sweep_rows
from rfidnav_experiments.reproduce.tables import INTERPRETED, is_condition_source, rowless_fields
from rfidnav_experiments.runners.tag_route import RouteRun, controller_parameters, floor_read_radius_m, run_tag_route
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.parameters import ReaderParameters, RobotSimParameters

pytestmark = pytest.mark.tier("unit")
RECORD = CALIBRATED_FILE.with_name("flc_paper_calibration.json")


def controller_values(path) -> dict:
    return node_parameter_values(HeadingControllerParameters, path, "heading_controller")


def test_flc_paper_has_no_guard_the_paper_lacks_and_keeps_its_speed_and_arrival_rule() -> None:
    for path in (PAPER_FILE, CALIBRATED_FILE):
        values = controller_values(path)
        assert values["receding_detection"] is False, path
        assert values["turn_speed_fraction"] == values["approach_speed_fraction"] == 1.0, path
        assert values["arrival"] == "first_read" and values["filter_rounds"] == 1, path
        assert values["forward_speed_mps"] == 0.2, path


def test_the_calibrated_controller_is_flc_paper_with_only_its_output_range_scaled() -> None:
    paper, calibrated = controller_values(PAPER_FILE), controller_values(CALIBRATED_FILE)
    scale = json.loads(RECORD.read_text())["chosen"]["output_scale"]
    assert calibrated["output_range_rad"] == pytest.approx(paper["output_range_rad"] * scale)
    assert calibrated["output_set_points"] == pytest.approx([p * scale for p in paper["output_set_points"]])
    unchanged = set(paper) - {"output_range_rad", "output_set_points"}
    assert {key: calibrated[key] for key in unchanged} == {key: paper[key] for key in unchanged}


def test_the_calibrated_reader_changes_only_the_phase_noise_of_the_scenarios_reader() -> None:
    sections = yaml.safe_load(CALIBRATED_FILE.read_text())
    assert set(sections["rfid_reader_sim"]["ros__parameters"]) == {"phase_noise_rad_per_m"}
    scenario = scenario_named("line_follow_90")
    reader = calibrated_reader(scenario, 7)
    noise = json.loads(RECORD.read_text())["chosen"]["phase_noise_rad_per_m"]
    assert reader.phase_noise_rad_per_m == noise
    shipped = node_parameter_values(type(reader), CONFIG_DIR / "params" / "reader_uhf_2ant.yaml", "rfid_reader_sim")
    assert {key: getattr(reader, key) for key in shipped if key != "phase_noise_rad_per_m"} == \
        {key: value for key, value in shipped.items() if key != "phase_noise_rad_per_m"}


def test_the_evaluation_seeds_are_never_the_calibrations() -> None:
    assert not set(evaluation_seeds(50)) & set(CALIBRATION_SEEDS)


def test_the_conditions_table_lists_every_setting_of_the_reader_and_base_files_with_a_source() -> None:
    for path, node in ((CONFIG_DIR / "params" / "reader_uhf_2ant.yaml", "rfid_reader_sim"),
                       (CONFIG_DIR / "params" / "robot_sim.yaml", "robot_sim")):
        keys = yaml.safe_load(path.read_text())[node]["ros__parameters"]
        assert {f"{node}.{key}" for key in keys} <= set(SOURCES), path
    rows = conditions()
    assert [row.setting for row in rows] == list(SOURCES)
    assert all(is_condition_source(row.source) for row in rows)
    assert all(is_condition_source(source) for row in rows if row.sources for source in row.sources.values())
    noise = next(row for row in rows if row.setting == "rfid_reader_sim.phase_noise_rad_per_m")
    assert noise.source == "calibrated" and len(set(noise.values.values())) == 1   # the same for both


def test_every_parameter_a_run_reads_has_a_row() -> None:
    """The reader's, the base's and the controller's parameter classes, field by field."""
    missing = rowless_fields(SOURCES, {"rfid_reader_sim": ReaderParameters, "robot_sim": RobotSimParameters,
                                       "heading_controller": HeadingControllerParameters})
    assert not missing, missing


def test_a_row_whose_sets_differ_in_value_and_origin_gives_one_source_per_set() -> None:
    rows = {row.setting: row for row in conditions()}
    for key in ("heading_controller.turn_speed_fraction", "heading_controller.approach_speed_fraction",
                "heading_controller.arrival", "heading_controller.filter_rounds",
                "heading_controller.receding_detection"):
        row = rows[key]
        assert row.values["flc_paper"] != row.values["flc_tuned"], key
        assert row.sources is not None and row.sources["flc_tuned"] == "ours", key
        assert row.sources["flc_paper"] in {"paper", INTERPRETED}, key
    assert rows["heading_controller.output_range_rad"].sources == {"flc_paper": "calibrated", "flc_tuned": "ours"}


def test_the_calibrations_best_point_is_inside_its_grid_and_its_held_out_spread_recorded() -> None:
    record = json.loads(RECORD.read_text())
    assert record["interior"] is True
    chosen, grid = record["chosen"], record["grid"]
    assert min(grid["phase_noise_rad_per_m"]) < chosen["phase_noise_rad_per_m"] < max(grid["phase_noise_rad_per_m"])
    assert min(grid["output_scale"]) < chosen["output_scale"] < max(grid["output_scale"])
    near = [p for p in record["points"] if p["objective"] is not None
            and p["objective"] <= chosen["objective"] * (1 + record["held_out"]["near_best"])]
    assert len(record["held_out"]["points"]) == len(near) >= 1
    for name in HELD_OUT_SCENARIOS:
        spread = record["held_out"]["spread"][name]
        values = [p["rmse_m"][name] for p in record["held_out"]["points"] if p["rmse_m"][name] is not None]
        assert spread["min_m"] == min(values) and spread["max_m"] == max(values)
    swept = {name for p in record["sweep"] for name in p["open"]}
    assert swept == {setting.name for setting in OPEN_SETTINGS}


def test_the_reproductions_sweep_rows_give_each_swept_value_its_recorded_figures_beside_the_papers() -> None:
    record = json.loads(RECORD.read_text())
    rows = sweep_rows(record)
    assert len(rows) == sum(len(point["rmse_m"]) + 2 for point in record["sweep"])
    for point in record["sweep"]:
        (name, value), = point["open"].items()
        mine = [row for row in rows if (row["setting"]["open_setting"], row["setting"]["value"]) == (name, value)]
        rmse = {row["setting"]["scenario"]: (row["ours"], row["paper"]) for row in mine
                if row["metric"] == "sweep_rmse_m"}
        assert rmse == {scenario: (value_m, record["fitted_to"]["rmse_m"][scenario])
                        for scenario, value_m in point["rmse_m"].items()}
        approach, = (row for row in mine if row["metric"] == "sweep_approach_s")
        assert (approach["ours"], approach["paper"]) == (point["approach_s"], 110.0)
        failures, = (row for row in mine if row["metric"] == "sweep_failures")
        assert failures["ours"] == point["failures"]


def test_the_open_settings_reach_the_runs_parameters() -> None:
    scenario = scenario_named("line_follow_90")
    controller = controller_parameters(scenario, PAPER_FILE, 1)
    reader = calibrated_reader(scenario, 1)
    grid = with_opens(controller, reader, ())
    assert grid[0].max_yaw_rate_radps == 2.0 and grid[1].rate_hz == 25.0 and grid[2] == "rate"
    assert grid[1].antenna_max_range_m == reader.antenna_max_range_m
    swept, swept_reader, update = with_opens(controller, reader, (("max_yaw_rate_radps", 0.5),
                                                                  ("control_period_s", 0.2),
                                                                  ("heading_update", "setpoint"),
                                                                  ("floor_read_radius_m", 0.01)))
    assert swept.max_yaw_rate_radps == 0.5 and swept.nominal_round_s == 0.2 and swept_reader.rate_hz == 5.0
    assert update == "setpoint"
    assert floor_read_radius_m(swept_reader, swept) == pytest.approx(0.01)
    assert floor_read_radius_m(reader, controller) == pytest.approx(0.0866, abs=1e-4)


def test_a_point_with_a_failed_run_is_never_chosen() -> None:
    good = Point(0.05, 0.3, {"line_follow_90": 0.034, "line_follow_0": 0.093}, 110.0, failures=0)
    failed = dataclasses.replace(good, failures=1)
    assert good.objective == pytest.approx(0.0) and failed.objective == float("inf")


@pytest.mark.tier("slow")
def test_the_calibrated_file_reproduces_the_figures_it_was_fitted_to() -> None:
    chosen = json.loads(RECORD.read_text())["chosen"]
    runs: list[tuple[float, float, Opens, str, RouteRun]] = []
    for name in FITTED_SCENARIOS:
        scenario = scenario_named(name)
        for seed in CALIBRATION_SEEDS:      # as the reproduction builds its baseline, from the files
            controller = controller_parameters(scenario, CALIBRATED_FILE, seed)
            run = run_tag_route(scenario, controller, seed, reader=calibrated_reader(scenario, seed),
                                timeout_s=timeout_s(scenario))
            runs.append((chosen["phase_noise_rad_per_m"], chosen["output_scale"], (), name, run))
    (point,) = points_of(runs)
    assert point.failures == 0
    for name in FITTED_SCENARIOS:
        assert point.rmse_m[name] == pytest.approx(chosen["rmse_m"][name], rel=0.02), name
    assert point.approach_s == pytest.approx(chosen["approach_s"], rel=0.02)
