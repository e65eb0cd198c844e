"""The node registry (the ``rfidnav.nodes`` entry points, rfidnav_common.node_registry): every node executable we ship
is registered with its parameters class; a simulator no package registers is refused before anything starts; and a
sensor simulator of a package of its own, written by following docs/extending.md (test/data/thermometer_sim), takes
part in the stepped clock without a line of rfidnav changed."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest
import yaml

from rfidnav_bag.bags import read_messages
from rfidnav_common.errors import ConfigError
from rfidnav_common.node_registry import NodeRegistration, registered_node, registered_nodes
from rfidnav_scenario.scenario import load_scenario, node_parameters
from support.runs import WORKSPACE, run_scenario, scenario_document

pytestmark = pytest.mark.tier("unit")

NODE_PACKAGES = ("rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_planning", "rfidnav_drivers")
STEPPED_PACKAGES = ("rfidnav_sim", "rfidnav_control", "rfidnav_localization", "rfidnav_planning")
THERMOMETER = WORKSPACE / "test" / "data" / "thermometer_sim"
SCENARIO = "line_follow_90"
RATE_HZ = 10.0


@pytest.fixture(scope="module")
def thermometer_site(tmp_path_factory) -> Path:
    """The thermometer package installed as a user would (pip, into a folder of its own) and on sys.path.

    pip builds from a copy: setuptools leaves a build/ folder beside setup.py, which must not land in the tree."""
    site = tmp_path_factory.mktemp("site")
    source = shutil.copytree(THERMOMETER, tmp_path_factory.mktemp("source") / THERMOMETER.name)
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
                    "--no-index", "--disable-pip-version-check", "--target", str(site), str(source)], check=True)
    sys.path.insert(0, str(site))
    yield site
    sys.path.remove(str(site))
    registered_node.cache_clear()


def scenario_with(tmp_path: Path, role: str, entry: dict) -> Path:
    """SCENARIO with one more role, written to ``tmp_path`` with the scenario's paths made absolute."""
    document = scenario_document(SCENARIO)
    document["nodes"][role] = entry
    path = tmp_path / f"{SCENARIO}_{role}.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


def test_every_node_executable_the_node_packages_ship_is_registered_under_its_own_name() -> None:
    for package in NODE_PACKAGES:
        scripts = {entry.name for entry in metadata.distribution(package).entry_points
                   if entry.group == "console_scripts"}
        registered = {executable for (owner, executable) in registered_nodes() if owner == package}
        assert registered == scripts, package
        for executable in scripts:
            registration = registered_node(package, executable)
            assert isinstance(registration, NodeRegistration) and registration.node_name == executable
            assert registration.stepped == (package in STEPPED_PACKAGES), (package, executable)


def test_an_unregistered_executable_or_package_has_no_registration() -> None:
    assert registered_node("rfidnav_bag", "player") is None
    assert registered_node("no_such_package", "robot_sim") is None


def test_a_simulator_no_package_registers_is_refused_naming_its_entry(tmp_path: Path) -> None:
    path = scenario_with(tmp_path, "replayed", {"package": "rfidnav_bag", "executable": "player", "sim": True})
    with pytest.raises(ConfigError) as raised:
        load_scenario(str(path))
    assert raised.value.source == str(path) and raised.value.field == "nodes.replayed.sim"
    assert "no rfidnav.nodes entry point registers rfidnav_bag:player" in raised.value.problem


def test_a_simulator_given_as_a_command_line_must_say_whether_it_is_stepped(tmp_path: Path) -> None:
    entry = {"command": f"{sys.executable} -c pass", "sim": True}
    with pytest.raises(ConfigError, match=r"nodes\.own\.sim: .*a command line is not registered"):
        load_scenario(str(scenario_with(tmp_path, "own", entry)))
    assert load_scenario(str(scenario_with(tmp_path, "own", {**entry, "stepped": False}))).nodes["own"].sim


def test_a_simulator_of_another_package_is_a_participant_with_its_parameters_checked(thermometer_site: Path,
                                                                                       tmp_path: Path) -> None:
    entry = {"package": "rfidnav_thermometer", "executable": "thermometer_sim", "sim": True}
    scenario = load_scenario(str(scenario_with(tmp_path, "thermometer", entry)))
    assert "thermometer" in [spec.role for spec in scenario.step_participants()]
    parameters = node_parameters(scenario, scenario.nodes["thermometer"], seed=4, rtf=1.0)
    assert type(parameters).__name__ == "ThermometerParameters" and parameters.seed == 4
    bad = scenario_with(tmp_path, "thermometer", {**entry, "overrides": {"rate_hz": -1.0}})
    with pytest.raises(ConfigError, match=r"nodes\.thermometer\.overrides\.rate_hz: must be positive"):
        load_scenario(str(bad))


@pytest.mark.tier("graph")
def test_a_slow_simulator_of_another_package_holds_the_stepped_clock_and_misses_no_reading(
        thermometer_site: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """At --rtf max a reading takes 20 ms of wall time, several times the wall time a step takes (~4 ms): a node off the
    stepped clock would fall behind and lose ground-truth messages (they are best effort), so readings would go
    missing; a participant holds each step until it has answered, so there is one at every 1/rate s of sim time."""
    entry = {"package": "rfidnav_thermometer", "executable": "thermometer_sim", "sim": True,
             "overrides": {"rate_hz": RATE_HZ, "work_s": 0.02}}
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(thermometer_site),
                                                                    os.environ.get("PYTHONPATH")])))
    run = run_scenario(tmp_path / "runs", str(scenario_with(tmp_path, "thermometer", entry)), "--rtf", "max",
                       "--seed", "5")
    summary = json.loads((run / "summary.json").read_text())
    assert "/thermometer_sim" in summary["clock"]["participants"] and summary["success"] is True
    stamps = [msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
              for _, _, msg in read_messages(run / "bag", ["/temperature"])]
    assert len(stamps) >= RATE_HZ * (summary["sim_duration_s"] - 1.0)
    # the first reading is at the first pose, off the grid; from the second on, one at each grid point
    gaps = [round(later - earlier, 6) for earlier, later in zip(stamps[1:], stamps[2:])]
    assert 0.0 < stamps[1] - stamps[0] <= 1.0 / RATE_HZ + 1e-6
    assert all(abs(gap - 1.0 / RATE_HZ) < 1e-6 for gap in gaps), sorted(set(gaps))
