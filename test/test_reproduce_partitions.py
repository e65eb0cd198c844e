"""``./rfidnav reproduce partitions``: the paper's localizer and our filter compared on the same robot (antenna
geometry, motion primitives, speeds) from the nodes' parameter files, the boom-and-spin robot as an ablation that
differs in nothing else, a conditions table that lists every setting, a time cost that charges turns, evaluation
tasks apart from the development ones, paired differences on the same tasks; and a reduced run's rows, tables and
plots."""

from __future__ import annotations

import importlib
import json
import math
import pkgutil
from pathlib import Path

import pytest
import yaml

from rfidnav_common.errors import ConfigError
from rfidnav_experiments.reproduce.partitions import reproduce_partitions
from rfidnav_experiments.reproduce.partitions.conditions import SOURCES, conditions
from rfidnav_experiments.reproduce.partitions.deployments import deployment_accuracy, saved_pct, tag_counts
from rfidnav_experiments.reproduce.partitions.jobs import (
    NavigationJob,
    NavigationResult,
    evaluation_jobs,
    navigate,
    navigation_jobs,
    oracle_time_cost_pct,
    task_of,
)
from rfidnav_experiments.reproduce.partitions.report import count_lines
from rfidnav_experiments.reproduce.partitions.settings import (
    ABLATION,
    DEVELOPMENT_SEED,
    DISTANCES_M,
    EVALUATION_SEED,
    FILTER,
    FILTER_LEVELS,
    LEVELS,
    METHOD_FILES,
    METHODS,
    NAVIGATION_RANGES_M,
    PAPER,
    headline_level,
    localizer_settings,
    method_levels,
    navigator_settings,
    params_path,
    robot_speeds,
)
from rfidnav_experiments.reproduce.partitions.summary import group, paired_difference
from rfidnav_experiments.reproduce.tables import CONDITION_SOURCES
from rfidnav_localization.partition import LocalizerSettings
from rfidnav_scenario.metrics import extra_time_cost_pct

pytestmark = pytest.mark.tier("unit")

PACKAGE = "rfidnav_experiments.reproduce.partitions"


def file_values(method: str, which: int) -> dict:
    """The ros__parameters of a method's localizer (0) or navigator (1) file, as written."""
    node = ("partition_localizer", "partition_navigator")[which]
    return yaml.safe_load(params_path(METHOD_FILES[method][which]).read_text())[node]["ros__parameters"]


def test_the_experiments_use_the_nodes_parameter_files() -> None:
    # The paper file is the defaults; the tagged area is the robot map's (partition_field's 5 x 5 m).
    assert localizer_settings(PAPER) == LocalizerSettings(deployment_area=(0.0, 0.0, 5.0, 5.0))
    assert localizer_settings(FILTER).method == localizer_settings(ABLATION).method == "filter"
    assert navigator_settings(PAPER, 3).approximation_level == 3
    assert navigator_settings(PAPER, 3).deviation_check == "partition"
    assert navigator_settings(FILTER, 5).deviation_check == "pose"
    assert headline_level() == file_values(PAPER, 1)["approximation_level"] == 4


def test_the_filter_and_the_paper_localizer_run_on_the_same_robot_with_the_same_motion_primitives() -> None:
    paper, ours = localizer_settings(PAPER), localizer_settings(FILTER)
    assert paper.antenna_offset_m == ours.antenna_offset_m == 0.0          # on the rotation axis, as the paper's agent
    for level in LEVELS:
        assert navigator_settings(PAPER, level).spin_quarter_turns == 0
        assert navigator_settings(FILTER, level).spin_quarter_turns == 0
    assert robot_speeds(PAPER) == robot_speeds(FILTER)


def test_the_ablation_differs_from_the_filter_only_in_the_boom_and_the_spin() -> None:
    for which, expected in ((0, {"antenna", "antenna_offset_m"}), (1, {"spin_quarter_turns"})):
        filter_values, ablation_values = file_values(FILTER, which), file_values(ABLATION, which)
        assert set(filter_values) == set(ablation_values)
        assert {key for key in filter_values if filter_values[key] != ablation_values[key]} == expected
    assert localizer_settings(ABLATION).antenna_offset_m == pytest.approx(0.25)
    assert navigator_settings(ABLATION, 4).spin_quarter_turns > 0
    assert method_levels(ABLATION) == (headline_level(),)


def test_the_conditions_table_lists_every_setting_of_the_localizer_and_navigator_files_with_a_source() -> None:
    for method in METHODS:
        for which, node in enumerate(("partition_localizer", "partition_navigator")):
            keys = {f"{node}.{key}" for key in file_values(method, which)}
            assert keys <= set(SOURCES), (method, keys - set(SOURCES))
    rows = conditions(runs=10)
    assert [row.setting for row in rows] == list(SOURCES)
    assert {row.source for row in rows} <= set(CONDITION_SOURCES)
    assert all(set(row.values) == set(METHODS) and row.note for row in rows)
    offset = next(row for row in rows if row.setting == "partition_localizer.antenna_offset_m").values
    assert offset[PAPER] == offset[FILTER] == 0.0 and offset[ABLATION] == pytest.approx(0.25)
    assert next(row for row in rows if row.setting == "runs.per_curve").values[PAPER] == 10


def test_the_time_cost_charges_rotation() -> None:
    # On the straight line itself, a quarter turn at 0.8 rad/s costs (pi/2 / 0.8) s against 2 m / 0.2 m/s = 10 s.
    assert extra_time_cost_pct(2.0, 0.0, 2.0, 0.2, 0.8) == 0.0
    assert extra_time_cost_pct(2.0, math.pi / 2, 2.0, 0.2, 0.8) == pytest.approx(100.0 * (math.pi / 2 / 0.8) / 10.0)
    # A navigation turns (towards the goal at least): its time cost exceeds its path cost by exactly its turns' time.
    job = NavigationJob(PAPER, 0.2, 4, 2, DEVELOPMENT_SEED)
    run = navigate(job)
    speeds = robot_speeds(PAPER)
    assert run.success and run.turned_rad > 0.0
    assert run.travel_time_s > run.straight_distance_m / speeds.speed_mps
    turns_pct = 100.0 * (run.turned_rad / speeds.turn_rate_radps) / (run.straight_distance_m / speeds.speed_mps)
    assert run.extra_time_cost_pct == pytest.approx(run.extra_cost_pct + turns_pct)
    assert oracle_time_cost_pct(job) > 0.0


def test_the_evaluation_tasks_are_not_the_development_tasks() -> None:
    assert EVALUATION_SEED != DEVELOPMENT_SEED
    assert {job.seed for job in evaluation_jobs(5)} == {EVALUATION_SEED}
    assert {job.seed for job in navigation_jobs(5)} == {DEVELOPMENT_SEED}      # what the tests develop on
    for r in NAVIGATION_RANGES_M:
        development = {task_of(NavigationJob(PAPER, r, 4, index, DEVELOPMENT_SEED)) for index in range(20)}
        evaluation = {task_of(NavigationJob(PAPER, r, 4, index, EVALUATION_SEED)) for index in range(20)}
        assert not development & evaluation


def test_every_level_and_method_faces_the_same_tasks() -> None:
    jobs = navigation_jobs(10, ranges=(0.2,), levels=(1, 8))
    assert len(jobs) == 3 * 2 * 10
    assert sorted({job.distance_m for job in jobs}) == list(DISTANCES_M)
    # Same (r, index): the same start and goal, whatever the method and level; other indices differ.
    tasks: dict[int, set] = {job.index: set() for job in jobs}
    for job in jobs:
        tasks[job.index].add(task_of(job))
    assert all(len(task) == 1 for task in tasks.values())
    assert len({next(iter(task)) for task in tasks.values()}) == len(tasks)
    for job in jobs:
        (sx, sy, _), goal = task_of(job)
        assert math.dist((sx, sy), goal) == pytest.approx(job.distance_m)
    # The default grid: the paper at every level, the filter at some (the headline's among them), the ablation at
    # the headline level only.
    levels = {(job.method, job.level) for job in navigation_jobs(5)}
    assert {level for method, level in levels if method == PAPER} == set(LEVELS)
    assert {level for method, level in levels if method == FILTER} == set(FILTER_LEVELS)
    assert {level for method, level in levels if method == ABLATION} == {headline_level()}


def result(method: str, index: int, cost: float, success: bool = True) -> NavigationResult:
    job = NavigationJob(method, 0.2, 4, index, EVALUATION_SEED)
    return NavigationResult(job, success, "", cost, 2.0 * cost, cost, 0.0, 0)


def test_paired_differences_are_taken_task_by_task_over_the_tasks_both_completed() -> None:
    groups = group([result(PAPER, 0, 10.0), result(PAPER, 1, 20.0), result(PAPER, 2, 30.0),
                    result(FILTER, 2, 1.0), result(FILTER, 1, 4.0), result(FILTER, 0, 5.0, success=False)])
    difference = paired_difference(groups, FILTER, PAPER, 0.2, 4, "extra_cost_pct")
    assert difference.n == 2 and difference.mean == pytest.approx(((4.0 - 20.0) + (1.0 - 30.0)) / 2)
    assert difference.half_width is not None and difference.half_width > 0.0
    time_difference = paired_difference(groups, FILTER, PAPER, 0.2, 4, "extra_time_cost_pct")
    assert time_difference.mean == pytest.approx(2.0 * difference.mean)


def test_tag_counts_report_what_the_lattices_give() -> None:
    counts = tag_counts()
    assert saved_pct(counts, "triangular") == pytest.approx(22.3, abs=1.5)
    assert saved_pct(counts, "compressed") < 0.0     # more tags than the grid, unlike the paper's 9 % fewer
    lines = "\n".join(count_lines(counts))
    assert "paper: 31 %" in lines and "paper: 9 %" in lines


def test_deployment_accuracy_orders_the_layouts_as_the_paper_does() -> None:
    accuracy = {layout: deployment_accuracy(layout, 0.2, 200) for layout in ("grid", "triangular", "compressed")}
    location = {layout: a.location_m.mean for layout, a in accuracy.items()}
    orientation = {layout: a.orientation_deg.mean for layout, a in accuracy.items()}
    assert location["grid"] < location["triangular"]                # Fig. 16
    assert location["compressed"] < location["triangular"]          # Fig. 19
    assert orientation["triangular"] < orientation["grid"]          # Fig. 17
    assert all(0.0 < a.location_m.mean < 0.2 and a.location_m.n == 200 and a.location_m.half_width > 0.0
               for a in accuracy.values())


def set_everywhere(monkeypatch: pytest.MonkeyPatch, name: str, value: object) -> None:
    """Set ``name`` in every module of the package that holds it: each module imports the settings it reads from
    settings.py, so setting it there alone would not reach them."""
    package = importlib.import_module(PACKAGE)
    for module in (package, *(importlib.import_module(f"{PACKAGE}.{info.name}")
                              for info in pkgutil.iter_modules(package.__path__))):
        if hasattr(module, name):
            monkeypatch.setattr(module, name, value)


@pytest.mark.tier("slow")
def test_reduced_reproduction_writes_conditions_rows_tables_and_plots(tmp_path: Path, monkeypatch, capsys) -> None:
    for name, value in (("NAVIGATION_RANGES_M", (0.2, 0.5)), ("LEVELS", (2, 4)), ("FIG11_RUNS", 10),
                        ("ACCURACY_SAMPLES", 20), ("ACCURACY_RANGES_M", (0.2, 0.5))):
        set_everywhere(monkeypatch, name, value)
    code = reproduce_partitions(runs=5, out_dir=tmp_path, as_json=True)
    rows = json.loads(capsys.readouterr().out)
    assert rows == json.loads((tmp_path / "partitions_rows.json").read_text())
    assert code == 0
    assert all(set(row) == {"experiment", "setting", "metric", "ours", "paper"} for row in rows)
    conditions = [row for row in rows if row["metric"] == "condition"]
    assert rows[:len(conditions)] == conditions and len(conditions) == len(SOURCES)
    assert {row["experiment"] for row in rows} == {"partitions", "partitions.headline", "partitions.fig11",
                                                  "partitions.fig12_14", "partitions.fig15_18", "partitions.fig16_20"}
    headline = {(row["metric"], row["setting"].get("method"), row["setting"]["read_range_m"]): row["ours"]
                for row in rows if row["experiment"] == "partitions.headline"}
    for r in (0.2, 0.5):
        for method in METHODS:
            assert headline[("extra_time_cost_pct_n", method, r)] == 5
            assert headline[("extra_time_cost_pct", method, r)] > headline[("extra_cost_pct", method, r)]
        assert isinstance(headline[("target_extra_time_cost_pct_met", FILTER, r)], bool)
    paired = [row for row in rows if row["metric"] == "paired_difference_extra_time_cost_pct"]
    assert {(row["setting"]["ours"], row["setting"]["baseline"]) for row in paired} == \
        {(FILTER, PAPER), (ABLATION, FILTER), (ABLATION, PAPER)}
    costs = [row for row in rows if row["metric"] == "extra_cost_pct" and row["experiment"] == "partitions.fig12_14"
             and "distance_m" in row["setting"]]
    assert len(costs) == 2 * (2 + 2 + 1) * len(DISTANCES_M)
    assert all(row["ours"] is None or math.isfinite(row["ours"]) for row in costs)
    saved = {row["setting"]["layout"]: row for row in rows if row["metric"] == "saved_vs_grid_pct"}
    assert saved["triangular"]["paper"] == 31.0 and saved["compressed"]["paper"] == 9.0
    for name in ("partitions_headline.png", "partitions_fig11_orientation.png", "partitions_fig12_14_cost.png",
                 "partitions_fig15_20_deployments.png", "partitions_trajectories.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_too_few_runs_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--runs"):
        reproduce_partitions(runs=2, out_dir=tmp_path, as_json=False)
