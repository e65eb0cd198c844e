"""Robot profiles (config/robots/*.yaml, `./rfidnav run SCENARIO --robot PROFILE`): drivers in the place of
simulator roles, real time without the simulated base, and one clear error for a profile that cannot work: a
simulator left without its base, an unknown role, a bad driver parameter, a reader without a port the nodes read."""

from __future__ import annotations

from pathlib import Path

import pytest

from rfidnav_common.errors import ConfigError
from rfidnav_scenario.scenario import ROBOT_DIR, injected_parameters, load_scenario, node_parameters
from support.runs import WORKSPACE, run_cli

pytestmark = pytest.mark.tier("unit")


def test_the_create2_llrp_profile_puts_the_drivers_in_and_runs_in_real_time() -> None:
    scenario = load_scenario("hallway", robot_profile_name="create2_llrp")
    base, reader = scenario.nodes["robot_sim"], scenario.nodes["rfid_reader"]
    assert (base.package, base.executable, base.sim, base.clock_source) == ("rfidnav_drivers", "create_base",
                                                                           False, False)
    assert (reader.executable, reader.param_files[0].name) == ("llrp_reader", "llrp_reader.yaml")
    assert not scenario.simulated
    injected = injected_parameters(scenario, scenario.nodes["heading_controller"], seed=1, rtf=1.0)
    assert "use_sim_time" not in injected                     # wall clock: nothing publishes /clock


def test_a_reader_on_the_simulated_base_keeps_sim_time() -> None:
    scenario = load_scenario("hallway", robot_profile_name="sim_base_llrp")
    assert scenario.simulated and scenario.nodes["rfid_reader"].executable == "llrp_reader"
    assert injected_parameters(scenario, scenario.nodes["rfid_reader"], seed=1, rtf=1.0)["use_sim_time"] is True


def test_a_profile_leaving_simulators_without_their_base_is_refused() -> None:
    with pytest.raises(ConfigError, match="not the simulator roles sonar of building_floor.yaml"):
        load_scenario("building_floor", robot_profile_name="create2_llrp")


def test_an_unknown_profile_or_role_is_one_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError,
                       match="no robot profile 'tank'.*known: create2_llrp, location_server_on_robot, sim_base_llrp"):
        load_scenario("hallway", robot_profile_name="tank")
    profile = tmp_path / "lidar.yaml"
    profile.write_text("name: lidar\nroles:\n  lidar: {package: rfidnav_drivers, executable: llrp_reader}\n")
    with pytest.raises(ConfigError) as raised:
        load_scenario("hallway", robot_profile_name=str(profile))
    assert raised.value.field == "roles.lidar" and "no role 'lidar' in hallway.yaml" in str(raised.value)


def test_a_drivers_bad_parameter_is_named_before_anything_starts(tmp_path: Path) -> None:
    params = tmp_path / "llrp_reader.yaml"
    params.write_text("llrp_reader:\n  ros__parameters:\n    host: 10.0.0.5\n    antennas: [1, two]\n")
    with pytest.raises(ConfigError) as raised:
        load_scenario("hallway", robot_profile_name="sim_base_llrp", param_files={"rfid_reader": params})
    assert raised.value.field.endswith("antennas[1]") and "expected an integer" in str(raised.value)


def test_the_shipped_reader_parameters_cover_every_port_the_controller_reads() -> None:
    # The done-criterion of the real-robot profile: the shipped llrp_reader.yaml, untouched, with the shipped
    # controller files of the paper-001 scenarios.
    for name in ("hallway", "line_follow_90", "acute_path"):
        scenario = load_scenario(name, robot_profile_name="create2_llrp")
        reader = node_parameters(scenario, scenario.nodes["rfid_reader"], seed=0, rtf=1.0)
        controller = node_parameters(scenario, scenario.nodes["heading_controller"], seed=0, rtf=1.0)
        assert set(controller.antenna_ports_read().values()) <= set(reader.antennas), name


def write_profile_with_reader(folder: Path, antennas: str) -> Path:
    """A robot profile (create2_llrp's drivers) whose reader inventories ``antennas``."""
    params = folder / "two_antennas.yaml"
    params.write_text(f"llrp_reader:\n  ros__parameters:\n    host: 10.0.0.5\n    antennas: {antennas}\n")
    base = ROBOT_DIR.parent / "params" / "create_base.yaml"
    profile = folder / "two_antennas_robot.yaml"
    profile.write_text("name: two_antennas_robot\nroles:\n"
                       f"  robot_sim: {{package: rfidnav_drivers, executable: create_base, params: {base.resolve()}}}\n"
                       f"  rfid_reader: {{package: rfidnav_drivers, executable: llrp_reader, params: {params}}}\n")
    return profile


def test_a_profile_whose_reader_misses_the_floor_antenna_is_refused_naming_the_port(tmp_path: Path) -> None:
    profile = write_profile_with_reader(tmp_path, "[1, 2]")
    with pytest.raises(ConfigError) as raised:
        load_scenario("hallway", robot_profile_name=str(profile))
    error = raised.value
    assert error.source == str(tmp_path / "two_antennas.yaml")
    assert error.field == "llrp_reader.ros__parameters.antennas"
    assert "reads come from ports 1, 2 only" in error.problem and "missing port 3" in error.problem
    # The node, its parameter and the file that asked for the port.
    controller_file = (WORKSPACE / "config/params/flc_tuned.yaml").resolve()
    assert (f"heading_controller's floor_antenna = 3 ({controller_file}: "
            "heading_controller.ros__parameters.floor_antenna)") in error.problem


def test_every_missing_port_is_named_in_one_error_and_all_ports_is_not_checked(tmp_path: Path) -> None:
    profile = write_profile_with_reader(tmp_path, "[2]")
    with pytest.raises(ConfigError, match=r"missing ports 1, 3 .*") as raised:
        load_scenario("hallway", robot_profile_name=str(profile))
    assert "left_antenna = 1" in str(raised.value) and "floor_antenna = 3" in str(raised.value)
    # `antennas: []` inventories whatever the reader has: known only once it runs, so the scenario loads.
    load_scenario("hallway", robot_profile_name=str(write_profile_with_reader(tmp_path, "[]")))


def test_a_simulated_reader_without_the_port_a_node_reads_is_refused_too(tmp_path: Path) -> None:
    # The reader simulator's ports are its antennas in order: reader_hf_floor has one, so port 3 is not there.
    controller = tmp_path / "controller.yaml"
    controller.write_text((WORKSPACE / "config/params/flc_tuned.yaml").read_text())
    with pytest.raises(ConfigError) as raised:
        load_scenario("hallway", param_files={"rfid_reader": WORKSPACE / "config/params/reader_hf_floor.yaml",
                                              "heading_controller": controller})
    assert raised.value.field == "rfid_reader_sim.ros__parameters.antenna_facing"
    assert "missing ports 2, 3" in str(raised.value)


@pytest.mark.tier("graph")
def test_run_refuses_such_a_profile_before_anything_starts_with_exit_2(tmp_path: Path) -> None:
    profile = write_profile_with_reader(tmp_path, "[1, 2]")
    result = run_cli("run", "hallway", "--robot", str(profile), "--out", str(tmp_path / "runs"))
    assert result.returncode == 2
    assert "llrp_reader.ros__parameters.antennas" in result.stderr and "missing port 3" in result.stderr
    assert not (tmp_path / "runs").exists()        # no run folder, no process
