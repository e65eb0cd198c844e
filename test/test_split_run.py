"""One run's graph split between two computers (issue 35): ``./rfidnav run ... --part robot`` starts the simulators
and drivers, ``--part station`` the rest and the recorder, both in one named ROS domain and DDS partition. Here the
two parts are two orchestrators on this machine; the same run over a network is the netns test's."""

from __future__ import annotations

import json
import secrets
from pathlib import Path

import pytest

from rfidnav_bringup.partition import PROFILES_VARIABLE
from rfidnav_bringup.processes import DomainLease
from rfidnav_bringup.run_plan import PARTS, ROBOT_PART, STATION_PART, RunOptions, RunPlan, part_of
from rfidnav_common.errors import ConfigError
from rfidnav_scenario.scenario import load_scenario
from support.domains import handed_domains
from support.runs import one_run, recorded_commands, run_cli, run_scenario, start_cli

pytestmark = pytest.mark.tier("graph")

SEED = "2"


@pytest.mark.tier("unit")
def test_the_robot_part_holds_the_simulators_and_drivers_and_the_station_the_rest_and_the_recorder(
        tmp_path: Path) -> None:
    scenario = load_scenario("two_tier_home")
    robot = RunPlan(scenario, RunOptions(part=ROBOT_PART), tmp_path / "robot")
    station = RunPlan(scenario, RunOptions(part=STATION_PART), tmp_path / "station")
    assert set(robot.roles) == {"robot_sim", "rfid_reader", "wifi", "compass"}, robot.roles
    assert set(station.roles) == set(scenario.nodes) - set(robot.roles)
    assert not robot.starts_recorder and station.starts_recorder
    # Both parts step one clock: its participants are the whole run's, wherever each runs.
    assert robot.stepped_with == station.stepped_with == RunPlan(scenario, RunOptions(), tmp_path).stepped_with
    assert [plan.name for plan in robot.write()] == ["simulator"]
    assert {plan.name for plan in station.write()} == {"recorder", *station.roles}
    profile = load_scenario("line_follow_90", robot_profile_name="create2_llrp")
    assert {role for role, spec in profile.nodes.items() if part_of(spec) == ROBOT_PART} == {"robot_sim", "rfid_reader"}


@pytest.mark.tier("unit")
def test_a_robot_profile_assigns_a_role_to_the_other_part(tmp_path: Path) -> None:
    scenario = load_scenario("two_tier_home", robot_profile_name="location_server_on_robot")
    robot = RunPlan(scenario, RunOptions(part=ROBOT_PART), tmp_path / "robot")
    station = RunPlan(scenario, RunOptions(part=STATION_PART), tmp_path / "station")
    assert set(robot.roles) == {"robot_sim", "rfid_reader", "wifi", "compass", "location_server"}, robot.roles
    assert set(station.roles) == {"two_tier_navigator"}
    assert {plan.name for plan in station.write()} == {"recorder", "two_tier_navigator"}
    assert "location_server" in station.expected_graph().elsewhere
    assert "location_server" not in robot.expected_graph().elsewhere


@pytest.mark.tier("unit")
@pytest.mark.parametrize("parts, field, words", [
    ("{location_server: laptop}", "parts.location_server", "one of robot, station"),
    ("{mapper: robot}", "parts.mapper", "no role 'mapper' in two_tier_home.yaml"),
    ("{}", "roles", "replaces at least one role or assigns one to a part")])
def test_a_profiles_bad_part_is_one_error_naming_it(tmp_path: Path, parts: str, field: str, words: str) -> None:
    profile = tmp_path / "robot.yaml"
    profile.write_text(f"name: robot\nparts: {parts}\n")
    with pytest.raises(ConfigError) as raised:
        load_scenario("two_tier_home", robot_profile_name=str(profile))
    assert raised.value.field == field and words in str(raised.value), str(raised.value)


@pytest.mark.tier("unit")
def test_a_profile_may_not_split_the_roles_of_one_process_between_the_parts(tmp_path: Path) -> None:
    profile = tmp_path / "robot.yaml"
    profile.write_text("name: robot\nparts: {compass: station}\n")      # the simulators share one process
    scenario = load_scenario("two_tier_home", robot_profile_name=str(profile))
    with pytest.raises(ConfigError, match="'simulator' holds roles of both parts of a split run"):
        RunPlan(scenario, RunOptions(part=ROBOT_PART), tmp_path / "robot")


@pytest.mark.tier("unit")
def test_an_unknown_part_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="unknown part 'both'"):
        RunPlan(load_scenario("line_follow_90"), RunOptions(part="both"), tmp_path)


@pytest.mark.tier("unit")
def test_the_cli_knows_the_run_plans_parts() -> None:
    from rfidnav_bringup.cli import SPLIT_RUN_PARTS

    assert SPLIT_RUN_PARTS == PARTS


@pytest.mark.tier("unit")
def test_a_part_without_its_domain_or_partition_is_refused_in_one_line_before_anything_starts(tmp_path: Path) -> None:
    no_domain = run_cli("run", "line_follow_90", "--part", "robot", "--partition", "p1", "--out", str(tmp_path),
                        without=(PROFILES_VARIABLE,))
    assert no_domain.returncode == 2 and "--part: a split run's two parts meet in one ROS domain" in no_domain.stderr
    # Without --partition and without a profile naming one (the test session's, which its runs inherit).
    no_partition = run_cli("run", "line_follow_90", "--part", "robot", "--domain", "60", "--out", str(tmp_path),
                           without=(PROFILES_VARIABLE,))
    assert no_partition.returncode == 2, no_partition.stdout + no_partition.stderr
    assert "give it with --partition NAME" in no_partition.stdout + no_partition.stderr
    assert not any(tmp_path.iterdir())


def test_a_run_split_into_its_robot_and_station_parts_gives_the_whole_runs_commands(tmp_path: Path) -> None:
    whole = recorded_commands(run_scenario(tmp_path / "whole", "line_follow_90", "--rtf", "max", "--seed", SEED))
    with DomainLease(handed_domains()) as free:     # a domain of this worker's share, free now
        domain = free.domain_id
    shared = ("run", "line_follow_90", "--rtf", "max", "--seed", SEED, "--domain", str(domain),
              "--partition", f"rfidnav-test-{secrets.token_hex(4)}", "--quiet")
    # Their own partition, not the test session's (whose profile they would inherit): --partition names it.
    with start_cli(*shared, "--part", "robot", "--out", str(tmp_path / "robot"), without=(PROFILES_VARIABLE,)) as robot:
        station = run_cli(*shared, "--part", "station", "--out", str(tmp_path / "station"),
                          without=(PROFILES_VARIABLE,))
        robot_output, _ = robot.communicate(timeout=120)
    assert station.returncode == 0, station.stdout + station.stderr
    assert robot.returncode == 0, robot_output
    station_run, robot_run = one_run(tmp_path / "station"), one_run(tmp_path / "robot")
    assert recorded_commands(station_run) == whole
    robot_summary = json.loads((robot_run / "summary.json").read_text())
    assert robot_summary["message"] == "the station's orchestrator left the graph"
    assert set(robot_summary["nodes"]) == {"simulator"} and not (robot_run / "bag").exists()
    assert set(json.loads((station_run / "summary.json").read_text())["nodes"]) == {"recorder", "heading_controller"}

