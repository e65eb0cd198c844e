"""./rfidnav reproduce two_tier: its conditions table lists every setting the runs use, the two spiral searches of
Fig. 10 run on identical placements, and a reduced reproduction prints the conditions first, writes them into its
JSON rows, reports Fig. 10 at the paper's distances with n, intervals and the paired difference, and comes out
the paper's way where the paper makes a comparison (two-tier fixes at centimetres, fingerprinting at metres,
indirect beats direct)."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from rfidnav_bringup.scenario import CONFIG_DIR, load_scenario
from rfidnav_common.errors import ConfigError
from rfidnav_common.polling import PollClock
from rfidnav_common.seeding import rng_for
from rfidnav_experiments.reproduce.tables import condition_json_rows
from rfidnav_experiments.reproduce.two_tier import (
    DEVELOPMENT_SEED,
    EVALUATION_SEED,
    EXPERIMENT,
    FIG10_DISTANCES_M,
    HOMES,
    LEGS,
    METHODS,
    PAPER_FIG10_M,
    SOURCES,
    conditions,
    fig10,
    fig10_placement,
    reproduce_two_tier,
)
from rfidnav_experiments.runners.tag_route import role_parameters
from rfidnav_experiments.runners.two_tier import FLOOR_READER, FLOOR_READER_FILE, NAVIGATOR, ODOMETRY_SCALE_ERROR
from rfidnav_planning.parameters import TwoTierNavigatorParameters
from rfidnav_sim.parameters import ReaderParameters
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("slow")   # the rows come from one reduced reproduction (~30 s on two cores)

PARAMS = CONFIG_DIR / "params"
FILES = {"rfid_reader_sim": FLOOR_READER_FILE, "two_tier_navigator": PARAMS / "two_tier_navigator.yaml",
         "compass_sim": PARAMS / "compass_sim.yaml", "wifi_sim": PARAMS / "wifi_sim.yaml"}
NOT_ON_THIS_READER = {"world_file", "seed", "side_area_width_m", "passage_miss_probability", "unreadable_tags"}


@pytest.mark.tier("unit")
def test_the_conditions_table_lists_every_setting_of_the_files_and_parameters_the_runs_use() -> None:
    for node, path in FILES.items():
        keys = yaml.safe_load(path.read_text())[node]["ros__parameters"]
        assert {f"{node}.{key}" for key in keys} <= set(SOURCES), path
    world = yaml.safe_load((CONFIG_DIR / "worlds" / "two_tier_home.yaml").read_text())
    assert {f"world.wifi.{key}" for key in world["wifi"]} <= set(SOURCES)
    # A parameter declared in code but left out of its file shapes the runs too.
    reader_fields = {field.name for field in dataclasses.fields(ReaderParameters)} - NOT_ON_THIS_READER
    assert {f"rfid_reader_sim.{name}" for name in reader_fields} <= set(SOURCES)
    navigator_fields = {field.name for field in dataclasses.fields(TwoTierNavigatorParameters)} - {"map_file"}
    assert {f"two_tier_navigator.{name}" for name in navigator_fields} <= set(SOURCES)
    rows = conditions()
    assert [row.setting for row in rows] == list(SOURCES)
    assert all(row.source in ("paper", "calibrated", "ours") and set(row.values) == set(METHODS) for row in rows)
    by_setting = {row.setting: row for row in rows}
    assert by_setting["rfid_reader_sim.round_failure_probability"].values["ours"] == 0.1
    assert by_setting["rfid_reader_sim.round_failure_probability"].source == "ours"
    assert len(set(by_setting["fig10.spiral_d_m"].values.values())) == 2        # the methods differ there


@pytest.mark.tier("unit")
def test_the_in_process_runs_read_through_the_reader_and_navigator_the_dds_scenario_runs() -> None:
    scenario = load_scenario(CONFIG_DIR / "scenarios" / "two_tier_home.yaml")
    reader = role_parameters(scenario, "rfid_reader_sim", 1)
    assert dataclasses.replace(reader, world_file=FLOOR_READER.world_file, seed=FLOOR_READER.seed) == FLOOR_READER
    navigator = role_parameters(scenario, "two_tier_navigator", 1)
    assert dataclasses.replace(navigator, map_file=NAVIGATOR.map_file) == NAVIGATOR
    robot = role_parameters(scenario, "robot_sim", 1)
    assert robot.odom_left_scale_error == robot.odom_right_scale_error == ODOMETRY_SCALE_ERROR
    assert FLOOR_READER.polling().interval_s == pytest.approx(0.5)
    assert FLOOR_READER.polling().max_interval_s == pytest.approx(0.6)
    assert EVALUATION_SEED != DEVELOPMENT_SEED


@pytest.mark.tier("unit")
def test_a_fig10_placement_is_the_same_for_both_methods_down_to_the_readers_polls() -> None:
    for distance in (0.4, 0.5):
        for index in range(5):
            placement = fig10_placement(EVALUATION_SEED, distance, index)
            assert placement == fig10_placement(EVALUATION_SEED, distance, index)
            clocks = [PollClock(FLOOR_READER.polling(), rng_for(placement.reader_seed, "polls")) for _ in METHODS]
            for _ in range(20):
                times = {clock.next_poll_s for clock in clocks}
                assert len(times) == 1
                reads = set()
                for clock in clocks:
                    clock.due(clock.next_poll_s)
                    reads.add(clock.reads())
                assert len(reads) == 1
    assert fig10_placement(EVALUATION_SEED, 0.4, 0) != fig10_placement(EVALUATION_SEED, 0.4, 1)


def test_fig10_runs_both_methods_on_identical_placements() -> None:
    spiral = fig10(3, DEVELOPMENT_SEED)
    for distance in FIG10_DISTANCES_M:
        placements = [[search.placement for search in spiral[method][distance]] for method in METHODS]
        assert placements[0] == placements[1] and len(placements[0]) == 3


@pytest.fixture(scope="module")
def reproduction(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, list[dict], int]:
    out = tmp_path_factory.mktemp("two_tier")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = reproduce_two_tier(runs=2, out_dir=out, as_json=False, seed=DEVELOPMENT_SEED, fig10_runs=10)
    assert (out / "two_tier_figs10_12.png").stat().st_size > 10_000
    return printed.getvalue(), json.loads((out / "two_tier_rows.json").read_text()), code


def values(rows: list[dict], experiment: str, metric: str, **setting) -> list:
    return [r["ours"] for r in rows if r["experiment"] == experiment and r["metric"] == metric
            and all(r["setting"].get(k) == v for k, v in setting.items())]


def test_the_report_prints_the_conditions_first_and_the_json_rows_carry_them(
        reproduction: tuple[str, list[dict], int]) -> None:
    printed, rows, _ = reproduction
    lines = printed.splitlines()
    assert lines[2].startswith("conditions:") and all(setting in printed for setting in SOURCES)
    expected = condition_json_rows(EXPERIMENT, conditions())
    assert rows[:len(expected)] == json.loads(json.dumps(expected))
    assert all(set(row) == {"experiment", "setting", "metric", "ours", "paper"} for row in rows)
    assert not any(row["metric"] == "condition" for row in rows[len(expected):])


def test_fig10_gives_every_point_its_n_and_interval_and_the_paired_difference(
        reproduction: tuple[str, list[dict], int]) -> None:
    printed, rows, _ = reproduction
    for method in METHODS:
        lengths = [r for r in rows if r["experiment"] == "fig10_spiral" and r["metric"] == "search_length_m"
                   and r["setting"]["method"] == method]
        assert [r["setting"]["distance_m"] for r in lengths] == list(FIG10_DISTANCES_M)
        assert all(r["setting"]["placements"] == 10 and 0 < r["setting"]["found"] <= 10 for r in lengths)
        assert {r["setting"]["distance_m"]: r["paper"] for r in lengths if r["paper"] is not None} == PAPER_FIG10_M
        assert len(values(rows, "fig10_spiral", "search_length_ci95_m", method=method)) == len(FIG10_DISTANCES_M)
    assert len(values(rows, "fig10_spiral", "paired_difference_m")) == len(FIG10_DISTANCES_M)
    assert "40 cm: paper ~120 cm" in printed and "50 cm: paper ~300 cm" in printed
    paper_far, ours_far = (values(rows, "fig10_spiral", "search_length_m", method=m, distance_m=1.0)[0]
                           for m in METHODS)
    assert ours_far < paper_far                             # the wider spiral reaches far placements sooner


def test_fig11_and_fig12_come_out_the_papers_way_and_the_target_is_reported(
        reproduction: tuple[str, list[dict], int]) -> None:
    printed, rows, code = reproduction
    # Walls stop the robot and the navigator does not steer round them: a run that stalls has no error to report
    # (None, n counting only the runs that arrived); the runs that arrived show less error with landmarks.
    direct, = values(rows, "fig11_moving", "median_error_m", moving="direct")
    indirect, = values(rows, "fig11_moving", "median_error_m", moving="indirect")
    if direct is not None and indirect is not None:
        assert indirect < direct
    fingerprinting = values(rows, "fig12_turning_points", "median_error_m", method="fingerprinting")
    two_tier = [value for value in values(rows, "fig12_turning_points", "median_error_m", method="two_tier ours")
                if value is not None]
    assert two_tier and max(two_tier) < 0.06 and min(fingerprinting) > 0.1
    met, = values(rows, "tag_fix", "target_met")
    assert isinstance(met, bool) and code == (0 if met else 1)
    assert ("target" in printed) and ("not met" in printed) == (not met)
    grid, = values(rows, "radio_map", "median_error_m", map="grid")
    survey, = values(rows, "radio_map", "median_error_m", map="survey")
    assert 0.1 < grid < 3.0 and 0.1 < survey < 3.0
    # The walls stop the robot: no navigation's true track crosses one.
    assert values(rows, "navigations", "wall_crossings") == [0]


def test_every_home_is_reported_with_both_kinds_of_legs_and_no_run_crosses_a_wall(
        reproduction: tuple[str, list[dict], int]) -> None:
    printed, rows, _ = reproduction
    assert "homes (ours)" in printed
    for home in HOMES:
        for legs in LEGS:
            assert values(rows, "homes", "wall_crossings", home=home, legs=legs) == [0]
            arrived, = values(rows, "homes", "arrived_pct", home=home, legs=legs, runs=2)
            bumps, = values(rows, "homes", "bumps", home=home, legs=legs)
            assert arrived in (0.0, 50.0, 100.0) and bumps >= 0
            assert values(rows, "homes", "path_length_median_m", home=home, legs=legs)[0] > 1.0


def test_theorem1_rows_carry_the_printed_and_the_rayleigh_expectation(
        reproduction: tuple[str, list[dict], int]) -> None:
    _, rows, _ = reproduction
    theorem = [r for r in rows if r["experiment"] == "theorem1" and r["metric"] == "search_length_m"]
    rayleigh = values(rows, "theorem1", "rayleigh_expectation_m")
    assert [r["setting"]["sigma_m"] for r in theorem] == [0.25, 0.5, 1.0]
    for row, expected in zip(theorem, rayleigh):
        assert expected > row["paper"] > 0.0 and row["ours"] > 0.0


@pytest.mark.tier("graph")
def test_a_bad_run_count_is_one_clear_error_from_the_command(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--runs"):
        reproduce_two_tier(runs=0, out_dir=tmp_path, as_json=False)
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "reproduce", "two_tier", "--runs", "-1",
                             "--out", str(tmp_path)], capture_output=True, text=True, cwd=WORKSPACE, timeout=300)
    assert result.returncode != 0 and "--runs" in result.stderr


def test_tier_one_answered_from_a_localizers_pose_takes_the_place_of_the_location_servers_locate() -> None:
    from rfidnav_experiments.reproduce.two_tier import SETTINGS, home
    from rfidnav_experiments.runners.two_tier import StepSeen, run_two_tier

    place = home("two_tier_flat")
    seen: list[StepSeen] = []

    def oracle() -> tuple[tuple[float, float], float] | None:
        """A localizer that knows where the robot is (the test harness's truth), from its first step on."""
        if not seen:
            return None
        return (seen[-1].truth[0], seen[-1].truth[1]), 0.05

    x, y, yaw_deg = place.scenario.robot
    target = place.scenario.mission.goal["target"]
    run = run_two_tier(place.site, (x, y, math.radians(yaw_deg)), (target["x"], target["y"]), SETTINGS,
                       rng_for(DEVELOPMENT_SEED, "tier one test"), 1, max_time_s=900.0, floor=place.floor,
                       observe=seen.append, reader_parameters=FLOOR_READER, tier_one=oracle, scan_period_s=1.0)
    assert run.success, run.message
    # Every request was answered where the robot stood (it stands still while asking), none by fingerprints.
    assert run.tier_one_errors_m and max(run.tier_one_errors_m) == pytest.approx(0.0, abs=1e-9)
    # The periodic scans' answers reach the observers (a localizer beside that locates each scan).
    assert sum(step.wifi_fix is not None for step in seen) >= run.duration_s / 1.0 - 2
