"""The run plan (rfidnav_bringup.run_plan) alone, without rclpy and without starting a process: which clock runs,
what the run's folder holds, which processes start with which command lines and parameter files."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import yaml

from rfidnav_bringup.run_plan import LIVE_ROLE, RECORDER_ROLE, ProcessPlan, RunOptions, RunPlan
from rfidnav_common.clock_topics import RESEND_TOPICS
from rfidnav_common.errors import ConfigError
from rfidnav_scenario.scenario import Scenario, load_scenario

pytestmark = pytest.mark.tier("unit")


@pytest.fixture(scope="module")
def hallway() -> Scenario:
    """Paper 001's hallway: robot_sim and rfid_reader share the process ``simulator``, heading_controller respawns."""
    return load_scenario("hallway")


def planned(scenario: Scenario, tmp_path: Path, **options) -> tuple[RunPlan, dict[str, ProcessPlan]]:
    plan = RunPlan(scenario, RunOptions(out_dir=tmp_path, **options), tmp_path / "run")
    return plan, {process.name: process for process in plan.write()}


def parameter(command: list[str], name: str) -> str:
    """The value of ``-p NAME:=VALUE`` in ``command``."""
    values = [arg.partition(":=")[2] for arg in command if arg.startswith(f"{name}:=")]
    assert len(values) == 1, f"{name} given {len(values)} times in {command}"
    return values[0]


def test_the_recorder_starts_first_then_one_process_per_role_or_group(hallway: Scenario, tmp_path: Path) -> None:
    _, processes = planned(hallway, tmp_path)
    assert list(processes) == [RECORDER_ROLE, "simulator", "heading_controller", "rfid_localizer"]
    simulator = processes["simulator"].command
    assert simulator[:3] == [sys.executable, "-m", "rfidnav_bringup.container"]
    assert simulator[3:7] == ["--node", "rfidnav_sim:robot_sim", "--node", "rfidnav_sim:rfid_reader_sim"]
    files = [simulator[i + 1] for i, arg in enumerate(simulator) if arg == "--params-file"]
    assert [Path(file).name for file in files] == ["robot_sim.yaml", "rfid_reader.yaml"]


def test_a_role_s_own_process_keeps_its_respawn_and_a_group_s_does_not(hallway: Scenario, tmp_path: Path) -> None:
    _, processes = planned(hallway, tmp_path)
    controller = hallway.nodes["heading_controller"]
    assert (processes["heading_controller"].respawn, processes["heading_controller"].max_respawns) == \
        (True, controller.max_respawns)
    assert not processes["simulator"].respawn and not processes[RECORDER_ROLE].respawn


def test_each_node_of_ours_gets_one_parameter_file_keyed_by_its_node_name_with_what_the_run_injects(
        hallway: Scenario, tmp_path: Path) -> None:
    plan, processes = planned(hallway, tmp_path, seed=7)
    command, given = processes["heading_controller"].command, list(hallway.nodes["heading_controller"].command)
    assert command[:len(given)] == given
    assert command[-3:] == ["--ros-args", "--params-file", str(tmp_path / "run" / "params" / "heading_controller.yaml")]
    document = yaml.safe_load(Path(command[-1]).read_text())
    (node_name, section), = document.items()
    assert node_name == hallway.nodes["heading_controller"].registration.node_name
    values = section["ros__parameters"]
    assert (values["stepped_clock"], values["seed"]) == (True, 7)
    assert values["map_file"] == str(hallway.map_file)
    clock_source = yaml.safe_load((plan.run_dir / "params" / "robot_sim.yaml").read_text())
    assert clock_source["robot_sim"]["ros__parameters"]["step_participants"] == list(plan.stepped_with)


def test_the_run_s_folder_holds_the_world_the_map_and_the_resolved_scenario_with_the_run_s_options(
        hallway: Scenario, tmp_path: Path) -> None:
    plan, _ = planned(hallway, tmp_path, seed=3, rtf=math.inf)
    assert (plan.run_dir / "world.yaml").read_text() == hallway.world_file.read_text()
    assert (plan.run_dir / "map.yaml").read_text() == hallway.map_file.read_text()
    run = yaml.safe_load((plan.run_dir / "scenario.yaml").read_text())["run"]
    assert run == {"seed": 3, "rtf": "max", "clock": "stepped"}
    assert plan.log_path("simulator") == plan.run_dir / "logs" / "simulator.log"


def test_the_stepped_clock_waits_for_our_nodes_of_the_loop_and_the_recorder_and_leaves_its_answers_unrecorded(
        hallway: Scenario, tmp_path: Path) -> None:
    plan, processes = planned(hallway, tmp_path, record_exclude=("/rosout",))
    assert plan.stepped_with is not None and plan.stepped_with[-1] == f"/{RECORDER_ROLE}"
    assert "/robot_sim" not in plan.stepped_with   # the clock source waits for the others
    recorder = processes[RECORDER_ROLE].command
    assert "stepped_clock:=true" in recorder
    assert json.loads(parameter(recorder, "exclude_topics")) == ["/rosout", "/sim/step_ack", *RESEND_TOPICS]
    summary = plan.clock_summary()
    assert summary["mode"] == "stepped" and summary["participants"] == list(plan.stepped_with)
    assert "robot_sim" not in summary["free_running_roles"]


def test_the_free_running_clock_has_no_participants_and_records_everything_not_excluded(
        hallway: Scenario, tmp_path: Path) -> None:
    plan, processes = planned(hallway, tmp_path, clock="free")
    assert plan.stepped_with is None and plan.record_exclude == ()
    recorder = processes[RECORDER_ROLE].command
    assert "stepped_clock:=true" not in recorder and not any(a.startswith("exclude_topics") for a in recorder)
    assert plan.clock_summary() == {"mode": "free"}


def test_the_recorder_is_given_the_bag_s_folder_and_storage_options(hallway: Scenario, tmp_path: Path) -> None:
    plan, processes = planned(hallway, tmp_path, compress=True, max_bag_size=2_000_000, max_bag_duration_s=60)
    recorder = processes[RECORDER_ROLE].command
    assert parameter(recorder, "output_dir") == str(plan.run_dir / "bag")
    assert parameter(recorder, "stamp_from_clock_topic") == "true"
    assert parameter(recorder, "compression") == "zstd"
    assert parameter(recorder, "max_bag_size") == "2000000" and parameter(recorder, "max_bag_duration_s") == "60.0"


def test_without_recording_no_recorder_starts_nor_takes_part_in_the_clock(hallway: Scenario, tmp_path: Path) -> None:
    plan, processes = planned(hallway, tmp_path, record=False)
    assert RECORDER_ROLE not in processes
    assert plan.stepped_with is not None and f"/{RECORDER_ROLE}" not in plan.stepped_with


def test_the_live_view_starts_after_the_recorder_and_hides_what_the_recorder_leaves_out(
        hallway: Scenario, tmp_path: Path) -> None:
    _, processes = planned(hallway, tmp_path, live_port=8765)
    assert list(processes)[:2] == [RECORDER_ROLE, LIVE_ROLE]
    live = processes[LIVE_ROLE].command
    assert parameter(live, "port") == "8765"
    assert json.loads(parameter(live, "exclude_topics")) == ["/sim/step_ack", *RESEND_TOPICS]


def test_a_command_line_with_nothing_to_add_runs_as_given(hallway: Scenario, tmp_path: Path) -> None:
    given = replace(hallway.nodes["rfid_localizer"], package=None, stepped=False, param_files=(), overrides={},
                    command=("my_localizer", "--fast"))
    scenario = replace(hallway, nodes={**hallway.nodes, "rfid_localizer": given})
    _, processes = planned(scenario, tmp_path)
    assert processes["rfid_localizer"].command == ["my_localizer", "--fast"]


def test_a_run_without_the_simulated_base_runs_in_real_time(tmp_path: Path) -> None:
    plan = RunPlan(load_scenario("line_follow_90", robot_profile_name="create2_llrp"), RunOptions(out_dir=tmp_path),
                   tmp_path / "run")
    assert (plan.clock, plan.clock_note) == ("real time", " (no simulated base: hardware)")
    assert plan.stepped_with is None and not plan.expected_graph().simulated


def test_a_clock_source_that_cannot_step_runs_the_free_clock_and_says_why(hallway: Scenario, tmp_path: Path) -> None:
    source = replace(hallway.nodes["robot_sim"], executable="other_sim")
    scenario = replace(hallway, nodes={**hallway.nodes, "robot_sim": source})
    plan = RunPlan(scenario, RunOptions(out_dir=tmp_path), tmp_path / "run")
    assert (plan.clock, plan.clock_note) == ("free", " (the clock source robot_sim cannot step)")


@pytest.mark.parametrize("options, option", [(RunOptions(clock="lockstep"), "--clock"),
                                             (RunOptions(clock="free", rtf=math.inf), "--rtf")])
def test_a_clock_that_cannot_run_is_refused_naming_its_option(hallway: Scenario, tmp_path: Path,
                                                              options: RunOptions, option: str) -> None:
    with pytest.raises(ConfigError, match=option):
        RunPlan(hallway, options, tmp_path / "run")


def test_the_mission_s_server_is_the_process_of_its_role_else_of_the_first_non_simulator(
        hallway: Scenario, tmp_path: Path) -> None:
    plan = RunPlan(hallway, RunOptions(out_dir=tmp_path), tmp_path / "run")
    assert plan.mission_process() == "heading_controller"
    served = replace(hallway, mission=replace(hallway.mission, server="rfid_localizer"))
    assert RunPlan(served, RunOptions(out_dir=tmp_path), tmp_path / "run").mission_process() == "rfid_localizer"


def test_a_group_s_node_names_are_those_of_its_roles(hallway: Scenario, tmp_path: Path) -> None:
    plan = RunPlan(hallway, RunOptions(out_dir=tmp_path), tmp_path / "run")
    assert plan.node_names_of("simulator") == ["/robot_sim", "/rfid_reader_sim"]
    assert plan.node_names_of("heading_controller") == ["/heading_controller"]


def test_the_expected_graph_names_the_scenario_s_nodes_its_simulators_and_its_clock_source(
        hallway: Scenario, tmp_path: Path) -> None:
    expected = RunPlan(hallway, RunOptions(out_dir=tmp_path), tmp_path / "run").expected_graph()
    assert expected.nodes == {spec.name for spec in hallway.nodes.values()}
    assert expected.simulators == ("rfid_reader_sim", "robot_sim")
    assert expected.clock_source == "robot_sim" and expected.simulated
    assert expected.record_exclude == ("/sim/step_ack", *RESEND_TOPICS)


def test_the_run_plan_loads_without_rclpy() -> None:
    code = "import sys, rfidnav_bringup.run_plan; sys.exit('rclpy' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
