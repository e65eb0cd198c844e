"""Robot profiles (config/robots/*.yaml, `./rfidnav run SCENARIO --robot PROFILE`): drivers in the place of
simulator roles, real time without the simulated base, and one clear error for a profile that cannot work."""

from __future__ import annotations

from pathlib import Path

import pytest

from rfidnav_bringup.scenario import injected_parameters, load_scenario
from rfidnav_common.errors import ConfigError

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
    with pytest.raises(ConfigError, match="no robot profile 'tank'.*known: create2_llrp, sim_base_llrp"):
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
