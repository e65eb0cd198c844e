"""./rfidnav reproduce two_tier: its conditions table lists every parameter the runs read (each field of the nodes'
parameter classes has a row or a reason it is not read), its seed comes from the evaluation ledger, the two spiral
searches of Fig. 10 and its sensitivity run on identical placements, and a reduced reproduction prints the conditions
first, writes them into its JSON rows, reports Fig. 10 at the paper's distances with n, intervals and the paired
difference, the sensitivity to the distance definition and the reader's delay, and comes out the paper's way where
the paper makes a comparison (two-tier fixes at centimetres, fingerprinting at metres, indirect beats direct) and
ours where we claim one (planned legs arrive at least as often as straight ones and bump less in the flats)."""

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

from rfidnav_common.errors import ConfigError
from rfidnav_common.polling import PollClock
from rfidnav_common.seeding import rng_for
from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce.tables import condition_json_rows, interpreted, is_condition_source, rowless_fields
from rfidnav_experiments.reproduce.two_tier import (
    CENTRE,
    DELAYS,
    DEVELOPMENT_SEED,
    DISTANCES_TO,
    EVALUATION_SEED,
    EXPERIMENT,
    FIG10_DISTANCES_M,
    FIG10_SIZE_M,
    HOMES,
    LATENCY,
    LEGS,
    METHOD_SOURCES,
    METHODS,
    NEAREST,
    NOT_READ,
    PAPER_FIG10_M,
    SENSITIVITY_VARIANTS,
    SOURCES,
    conditions,
    fig10,
    fig10_placement,
    fig10_sensitivity,
    home,
    reproduce_two_tier,
    spiral_methods,
)
from rfidnav_experiments.runners.tag_route import role_parameters
from rfidnav_experiments.runners.two_tier import (
    FLOOR_READER,
    FLOOR_READER_FILE,
    FOOTPRINT_RADIUS_M,
    LOCATE_SETTINGS,
    NAVIGATOR,
    ODOMETRY_SCALE_ERROR,
)
from rfidnav_localization.parameters import LocationServerParameters
from rfidnav_planning.parameters import TwoTierNavigatorParameters
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario
from rfidnav_sim.parameters import CompassParameters, ReaderParameters, RobotSimParameters, WifiSimParameters
from rfidnav_sim.wifi_model import PropagationSettings
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("slow")   # the rows come from one reduced reproduction (~30 s on two cores)

PARAMS = CONFIG_DIR / "params"
FILES = {"rfid_reader_sim": FLOOR_READER_FILE, "two_tier_navigator": PARAMS / "two_tier_navigator.yaml",
         "compass_sim": PARAMS / "compass_sim.yaml", "wifi_sim": PARAMS / "wifi_sim.yaml",
         "location_server": PARAMS / "location_server.yaml", "robot_sim": PARAMS / "robot_sim.yaml"}
# The nodes whose parameters the runs read, by the prefix of their rows; world.wifi is the world's propagation.
PARAMETER_CLASSES = {"rfid_reader_sim": ReaderParameters, "two_tier_navigator": TwoTierNavigatorParameters,
                     "compass_sim": CompassParameters, "wifi_sim": WifiSimParameters,
                     "location_server": LocationServerParameters, "robot_sim": RobotSimParameters,
                     "world.wifi": PropagationSettings}


@pytest.mark.tier("unit")
def test_every_parameter_a_run_reads_has_a_row_and_every_other_field_a_reason() -> None:
    fields = {f"{prefix}.{field.name}" for prefix, cls in PARAMETER_CLASSES.items()
              for field in dataclasses.fields(cls)}
    missing = rowless_fields(SOURCES, PARAMETER_CLASSES) - set(NOT_READ)
    assert not missing, f"parameters without a row in the conditions table (or a reason in NOT_READ): {missing}"
    assert not set(SOURCES) & set(NOT_READ)
    assert set(NOT_READ) <= fields                  # a reason for a field that no longer exists is stale
    for node, path in FILES.items():                # every key of the shipped files is a field (so it is covered)
        keys = yaml.safe_load(path.read_text())[node]["ros__parameters"]
        assert {f"{node}.{key}" for key in keys} <= fields, path
    world = yaml.safe_load((CONFIG_DIR / "worlds" / "two_tier_home.yaml").read_text())
    assert {f"world.wifi.{key}" for key in world["wifi"]} - {"world.wifi.seed"} <= set(SOURCES)


@pytest.mark.tier("unit")
def test_the_conditions_table_gives_each_row_its_value_and_source_and_says_where_it_interprets_the_paper() -> None:
    rows = conditions()
    assert [row.setting for row in rows] == list(SOURCES)
    assert all(is_condition_source(row.source) and set(row.values) == set(METHODS) for row in rows)
    by_setting = {row.setting: row for row in rows}
    assert by_setting["rfid_reader_sim.round_failure_probability"].values["ours"] == 0.1
    assert by_setting["rfid_reader_sim.round_failure_probability"].source == "ours"
    # The paper's 500-600 ms communication delay is used as the poll period: an interpretation, said so.
    for key in ("rfid_reader_sim.rate_hz", "rfid_reader_sim.round_jitter_s"):
        assert by_setting[key].source.startswith(interpreted(""))
    # The matcher and the footprint the runs use are the shipped nodes' and are listed.
    assert LOCATE_SETTINGS == file_locate_settings()
    assert by_setting["location_server.k"].values["paper"] == 3
    assert by_setting["location_server.missing_rss_dbm"].values["ours"] == -100.0
    assert by_setting["robot_sim.footprint_radius_m"].values["ours"] == FOOTPRINT_RADIUS_M == 0.17
    # Where the methods' values come from different places, each method has its own source.
    assert len(set(by_setting["fig10.spiral_d_m"].values.values())) == 2        # the methods differ there
    for key, sources in METHOD_SOURCES.items():
        assert set(sources) == set(METHODS) and by_setting[key].sources == sources
    # The world.wifi rows are two_tier_home's; every home's world propagates alike (its APs and seed its own).
    assert {home(name).scenario.world.wifi for name in HOMES} == {home("two_tier_home").scenario.world.wifi}


def file_locate_settings():
    values = yaml.safe_load((PARAMS / "location_server.yaml").read_text())["location_server"]["ros__parameters"]
    return dataclasses.replace(LocationServerParameters(), **{key: values[key] for key in
                                                              ("k", "missing_rss_dbm", "min_common_aps",
                                                               "weighting")}).locate_settings()


@pytest.mark.tier("unit")
def test_the_evaluation_seed_is_the_ledgers_and_the_report_names_the_set() -> None:
    assert EVALUATION_SEED == evaluation.current(EXPERIMENT).seeds[0]
    old = [entry for entry in evaluation.LEDGER if entry.experiment == EXPERIMENT and 301 in entry.seeds]
    assert [entry.status for entry in old] == ["development"] and EVALUATION_SEED != 301
    seeds = {row.setting: row for row in conditions(seed=EVALUATION_SEED)}["runs.seed"].values["ours"]
    assert seeds.startswith(f"{EVALUATION_SEED} (evaluation set '{evaluation.current(EXPERIMENT).name}')")
    assert "development" in {row.setting: row for row in conditions(seed=301)}["runs.seed"].values["ours"]


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


def test_fig10_and_its_sensitivity_run_both_methods_on_identical_placements() -> None:
    spiral = fig10(3, DEVELOPMENT_SEED)
    sensitivity = fig10_sensitivity(3, DEVELOPMENT_SEED)
    assert set(sensitivity) == set(SENSITIVITY_VARIANTS)
    for distance in FIG10_DISTANCES_M:
        placements = [[search.placement for search in spiral[method][distance]] for method in METHODS]
        assert placements[0] == placements[1] and len(placements[0]) == 3
        for (distance_to, delay), searched in sensitivity.items():
            for method in METHODS:
                assert [search.placement for search in searched[method][distance]] == placements[0]
                assert {(s.distance_to, s.delay) for s in searched[method][distance]} == {(distance_to, delay)}


@pytest.mark.tier("unit")
def test_the_nearest_tag_definition_puts_the_groups_nearest_tag_at_the_distance_on_the_same_bearing() -> None:
    for distance in (0.0, 0.1, 0.4, 1.0):
        for index in range(5):
            placement = fig10_placement(EVALUATION_SEED, distance, index)
            centred, nearest = placement.group(CENTRE), placement.group(NEAREST)
            assert math.hypot(*centred.centre) == pytest.approx(distance, abs=1e-12)
            assert min(math.hypot(*tag) for tag in nearest.tag_positions()) == pytest.approx(distance, abs=1e-9)
            assert nearest.rotation_rad == centred.rotation_rad and nearest.size_m == FIG10_SIZE_M
            along = math.hypot(*nearest.centre)
            assert distance <= along <= distance + FIG10_SIZE_M / 2 + 1e-9
            if along > 0:
                bearing = math.atan2(nearest.centre[1], nearest.centre[0])
                assert math.remainder(bearing - placement.bearing_rad, 2 * math.pi) == pytest.approx(0, abs=1e-9)


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
    expected = condition_json_rows(EXPERIMENT, conditions(seed=DEVELOPMENT_SEED))
    assert rows[:len(expected)] == json.loads(json.dumps(expected))
    assert all(set(row) == {"experiment", "setting", "metric", "ours", "paper"} for row in rows)
    assert not any(row["metric"] == "condition" for row in rows[len(expected):])
    assert f"seed {DEVELOPMENT_SEED}: the development seed" in lines[0]
    # A figure is quoted in the docs as <!--fig two_tier METRIC key=value ...-->: the values of a figure's setting
    # are single words, and no two figures share a metric and a setting.
    figures = rows[len(expected):]
    assert all(" " not in str(value) for row in figures for value in row["setting"].values())
    keys = [(row["metric"], json.dumps(row["setting"], sort_keys=True)) for row in figures]
    assert len(keys) == len(set(keys))


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
    # The paper's Fig. 11: indirect moving (through landmarks) ends nearer the target than direct moving. A run
    # that stalls at a wall has no error (n counts the runs that arrived); at least one of each arrives here.
    direct, = values(rows, "fig11_moving", "median_error_m", moving="direct")
    indirect, = values(rows, "fig11_moving", "median_error_m", moving="indirect")
    assert direct is not None and indirect is not None and indirect < direct
    # Fig. 12: the two-tier fix at centimetres at every turning point, fingerprinting at metres.
    fingerprinting = values(rows, "fig12_turning_points", "median_error_m", method="fingerprinting")
    two_tier = values(rows, "fig12_turning_points", "median_error_m", method="two_tier_ours")
    assert len(two_tier) == 8 and None not in two_tier and max(two_tier) < 0.06 and min(fingerprinting) > 0.1
    # Our target, met on the development seed (exit 0), ours no worse than the same polls taken the paper's way.
    met, = values(rows, "tag_fix", "target_met")
    assert met is True and code == 0 and "target" in printed and "not met" not in printed
    ours, = values(rows, "tag_fix", "median_error_m", method="ours", fixes="turning_points")
    paper, = values(rows, "tag_fix", "median_error_m", method="paper", fixes="turning_points")
    assert ours < 0.03 and ours <= paper
    difference, = values(rows, "tag_fix", "paired_difference_m", method="ours-paper")
    assert difference <= 0.0
    # The site survey's radio map places the robot better than its own survey's, both at metres.
    grid, = values(rows, "radio_map", "median_error_m", map="grid")
    survey, = values(rows, "radio_map", "median_error_m", map="survey")
    assert 0.5 < grid < survey < 3.0
    # The walls stop the robot: no navigation's true track crosses one.
    assert values(rows, "navigations", "wall_crossings") == [0]


def test_every_home_is_reported_with_both_kinds_of_legs_and_no_run_crosses_a_wall(
        reproduction: tuple[str, list[dict], int]) -> None:
    printed, rows, _ = reproduction
    assert "homes (ours)" in printed
    for name in HOMES:
        for legs in LEGS:
            assert values(rows, "homes", "wall_crossings", home=name, legs=legs) == [0]
            assert values(rows, "homes", "path_length_median_m", home=name, legs=legs)[0] > 1.0
        arrived = {legs: values(rows, "homes", "arrived_pct", home=name, legs=legs, runs=2)[0] for legs in LEGS}
        bumps = {legs: values(rows, "homes", "bumps", home=name, legs=legs)[0] for legs in LEGS}
        # Ours: legs planned round the map's walls arrive at least as often as straight ones; in the flats with
        # rooms off a hallway, where straight legs meet a wall, they arrive in every run and bump far less.
        assert arrived["planned"] >= arrived["straight"], name
        if name != "two_tier_home":
            assert arrived["planned"] == 100.0 and bumps["planned"] < bumps["straight"] / 2, name
            error, = values(rows, "homes", "final_error_median_m", home=name, legs="planned")
            assert error < 0.1


def test_fig10_sensitivity_gives_each_variant_on_the_same_placements_and_its_difference_from_the_main_figure(
        reproduction: tuple[str, list[dict], int]) -> None:
    printed, rows, _ = reproduction
    assert "Fig. 10 sensitivity" in printed
    methods = spiral_methods()
    reader = FLOOR_READER.polling()
    for method in METHODS:
        for distance_to, delay in SENSITIVITY_VARIANTS:
            here = {"method": method, "distance_to": distance_to, "delay": delay}
            lengths = [r for r in rows if r["metric"] == "sensitivity_search_length_m"
                       and all(r["setting"][k] == v for k, v in here.items())]
            assert [r["setting"]["distance_m"] for r in lengths] == list(FIG10_DISTANCES_M)
            assert {r["setting"]["distance_m"]: r["paper"] for r in lengths if r["paper"] is not None} == PAPER_FIG10_M
            assert all(r["setting"]["placements"] == 10 and r["setting"]["found"] >= 8 for r in lengths)
            at_zero = lengths[0]["ours"]
            if delay == LATENCY:
                # Read at once at 0 cm (the start is on the centre tag); the robot learns of it 500-600 ms later.
                speed = methods[method].speed_mps
                assert speed * reader.interval_s <= at_zero <= speed * reader.max_interval_s + 0.02
            else:
                # At 0 cm the nearest tag is the centre's: the same searches as the main figure's.
                difference, = values(rows, "fig10_sensitivity", "sensitivity_difference_m", distance_m=0.0, **here)
                assert difference == 0.0
        # The nearest tag 1 m away puts the group's centre farther: a longer search than to a centre 1 m away.
        main, = values(rows, "fig10_spiral", "search_length_m", method=method, distance_m=1.0)
        nearest, = values(rows, "fig10_sensitivity", "sensitivity_search_length_m", method=method, distance_m=1.0,
                          distance_to=NEAREST, delay="period")
        assert nearest > main
    assert set(DISTANCES_TO) == {CENTRE, NEAREST} and len(DELAYS) == 2


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
    from rfidnav_experiments.reproduce.two_tier import home
    from rfidnav_experiments.runners.two_tier import SETTINGS, StepSeen, run_two_tier

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
