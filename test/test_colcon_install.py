"""The packages as a colcon workspace: colcon (pinned in requirements.txt) builds the ament_python packages into an
install beside the ROS 2 wheels, a scenario runs from that install with its configuration found under share/, colcon
test runs a package's share of the suite, and rosdep resolves the keys rosdep/rfidnav.yaml adds.

rfidnav_msgs (CMake, 1-4 min or more on two loaded cores) is not rebuilt: the build ignores it and takes the one
./rfidnav setup installed in the venv, the underlay on AMENT_PREFIX_PATH, as a workspace built on /opt/ros would.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path

import pytest

from support.packages import (
    ROSDEP_FRAGMENT,
    WORKSPACE,
    owner,
    packages,
    python_packages,
    rosdep_fragment,
    suite_modules,
)

pytestmark = pytest.mark.tier("graph")

UNDERLAY = Path(sys.prefix)                     # the venv: ROS 2 wheels, rfidnav_msgs, colcon
SCENARIO = "line_follow_90"                     # the shortest tag route: ~40 s simulated, seconds at --rtf max
TESTED_PACKAGE = "rfidnav_localization"         # colcon test of one package: its share of the suite


@dataclass(frozen=True)
class Workspace:
    root: Path

    @property
    def install(self) -> Path:
        return self.root / "install"

    def colcon(self, *args: str, timeout: float = 900) -> subprocess.CompletedProcess:
        """colcon VERB over the source tree, with build, install, log and test-result folders under ``root``."""
        verb, *rest = args
        bases = {"build": ["--build-base", "build", "--install-base", "install"],
                 "test": ["--build-base", "build", "--install-base", "install", "--test-result-base", "results"],
                 "test-result": ["--test-result-base", "results"]}.get(verb, [])
        paths = ["--base-paths", str(WORKSPACE)] if verb in ("build", "test", "list") else []
        command = [str(UNDERLAY / "bin" / "colcon"), "--log-base", "log", verb, *paths, *bases, *rest]
        return subprocess.run(command, cwd=self.root, env=underlay_environment(), capture_output=True, text=True,
                              timeout=timeout)

    def sourced(self, command: str, timeout: float = 300) -> subprocess.CompletedProcess:
        """``command`` in bash after sourcing the install's local_setup.bash, as a user of the install would."""
        env = underlay_environment()
        env.pop("ROS_DOMAIN_ID", None)   # the orchestrator leases its own domain
        return subprocess.run(["bash", "-c", f"source {self.install / 'local_setup.bash'} && {command}"],
                              cwd=self.root, env=env, capture_output=True, text=True, timeout=timeout)


def underlay_environment() -> dict[str, str]:
    """The environment of a shell that has the venv (ROS 2 wheels) as its underlay and nothing of this workspace's
    sources on its paths."""
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", "COLCON_PREFIX_PATH")}
    env.update(PATH=f"{UNDERLAY / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}", VIRTUAL_ENV=str(UNDERLAY),
               AMENT_PREFIX_PATH=str(UNDERLAY), CMAKE_PREFIX_PATH=str(UNDERLAY))
    return env


def output(result: subprocess.CompletedProcess) -> str:
    return f"exit {result.returncode}\n--- stdout\n{result.stdout[-4000:]}\n--- stderr\n{result.stderr[-4000:]}"


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    """One colcon build of the ament_python packages (copied, not linked, into the install)."""
    built = Workspace(tmp_path_factory.mktemp("colcon"))
    result = built.colcon("build", "--packages-ignore", "rfidnav_msgs")
    assert result.returncode == 0, output(result)
    return built


def test_colcon_finds_the_eleven_packages_of_the_workspace_with_their_build_types(tmp_path: Path) -> None:
    listed = Workspace(tmp_path).colcon("list")
    assert listed.returncode == 0, output(listed)
    found = dict(line.split("\t")[0::2] for line in listed.stdout.splitlines())
    assert found == {package: "(ros.ament_cmake)" if package == "rfidnav_msgs" else "(ros.ament_python)"
                     for package in packages()}


def test_the_install_holds_every_configuration_file_in_rfidnav_scenarios_share(workspace: Workspace) -> None:
    installed = workspace.install / "rfidnav_scenario" / "share" / "rfidnav_scenario" / "config"
    sources = sorted(path.relative_to(WORKSPACE / "config") for path in (WORKSPACE / "config").rglob("*")
                     if path.is_file())
    assert sorted(path.relative_to(installed) for path in installed.rglob("*") if path.is_file()) == sources
    for relative in sources:
        copy = installed / relative
        assert not copy.is_symlink() and copy.read_bytes() == (WORKSPACE / "config" / relative).read_bytes(), relative


def test_each_package_is_on_the_installs_ament_index_with_its_manifest(workspace: Workspace) -> None:
    for package in python_packages():
        prefix = workspace.install / package
        assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / package).is_file(), package
        manifest = ElementTree.parse(prefix / "share" / package / "package.xml").getroot()
        assert manifest.findtext("name") == package


def test_the_configuration_and_the_code_come_from_the_install_once_it_is_sourced(workspace: Workspace) -> None:
    result = workspace.sourced(f"{sys.executable} -c 'import rfidnav_scenario.scenario as s, rfidnav_sim; "
                               "print(s.CONFIG_DIR); print(s.__file__); print(rfidnav_sim.__file__); "
                               f"print(s.load_scenario(\"{SCENARIO}\").path)'")
    assert result.returncode == 0, output(result)
    config_dir, scenario_module, sim_module, scenario_file = result.stdout.split()
    assert Path(config_dir) == workspace.install / "rfidnav_scenario" / "share" / "rfidnav_scenario" / "config"
    assert Path(scenario_module).is_relative_to(workspace.install / "rfidnav_scenario")
    assert Path(sim_module).is_relative_to(workspace.install / "rfidnav_sim")
    assert Path(scenario_file) == Path(config_dir) / "scenarios" / f"{SCENARIO}.yaml"


def test_a_scenario_run_with_the_installed_rfidnav_executable_succeeds_on_the_installed_nodes(
        workspace: Workspace) -> None:
    executable = workspace.install / "rfidnav_bringup" / "lib" / "rfidnav_bringup" / "rfidnav"
    result = workspace.sourced(f"{executable} run {SCENARIO} --rtf max", timeout=600)
    assert result.returncode == 0, output(result)
    [run] = (workspace.root / "bags").iterdir()   # from an install, runs go to ./bags
    summary = json.loads((run / "summary.json").read_text())
    assert summary["success"] is True and summary["metrics"]["tags_reached"] == 2, summary
    controller = (run / "logs" / "heading_controller.log").read_text().splitlines()[0]
    assert controller.startswith(f"$ {workspace.install / 'rfidnav_control' / 'lib' / 'rfidnav_control'}/"), controller
    assert (run / "bag" / "metadata.yaml").is_file()   # the installed recorder wrote the bag


def test_the_installed_rfidnav_test_says_in_one_line_that_the_suite_runs_from_a_source_tree(
        workspace: Workspace) -> None:
    result = workspace.sourced(f"{workspace.install / 'rfidnav_bringup' / 'lib' / 'rfidnav_bringup' / 'rfidnav'} test")
    assert result.returncode == 2, output(result)
    assert result.stderr.count("\n") == 1 and "colcon test" in result.stderr, result.stderr


def test_colcon_test_runs_a_packages_share_of_the_suite_from_the_install(workspace: Workspace) -> None:
    result = workspace.colcon("test", "--packages-ignore", "rfidnav_msgs", "--packages-select", TESTED_PACKAGE)
    assert result.returncode == 0, output(result)
    report = ElementTree.parse(workspace.root / "results" / TESTED_PACKAGE / "pytest.xml").getroot()
    cases = report.findall(".//testcase")
    # classname: <package>.<package>.test.<module>[.<class>], the junit prefix colcon passes before pytest's name
    modules = {next(part for part in case.get("classname", "").split(".") if part.startswith("test_"))
               for case in cases}
    assert modules == {path.stem for path in suite_modules() if owner(path) == TESTED_PACKAGE}
    assert not report.findall(".//failure") and not report.findall(".//error")
    summary = workspace.colcon("test-result", "--all")
    assert summary.returncode == 0 and f"{len(cases)} tests, 0 errors, 0 failures" in summary.stdout, output(summary)


def test_rosdep_resolves_each_key_of_the_fragment_to_its_pip_package_on_each_os(tmp_path: Path) -> None:
    """rosdep itself (pinned) reads rosdep/rfidnav.yaml from a sources list, as README's instructions set it up;
    offline, so its index lists no ROS distribution (the rosdistro keys cannot be resolved here)."""
    sources = tmp_path / "sources.list.d"
    sources.mkdir()
    (sources / "50-rfidnav.list").write_text(f"yaml {ROSDEP_FRAGMENT.as_uri()}\n")
    index = tmp_path / "index-v4.yaml"
    index.write_text("%YAML 1.1\n---\ndistributions: {}\ntype: index\nversion: 4\n")
    env = dict(os.environ, ROSDEP_SOURCE_PATH=str(sources), ROS_HOME=str(tmp_path / "ros"),
               ROSDISTRO_INDEX_URL=index.as_uri(), ROS_PYTHON_VERSION="3")
    rosdep = str(UNDERLAY / "bin" / "rosdep")
    update = subprocess.run([rosdep, "update"], env=env, capture_output=True, text=True, timeout=120)
    assert update.returncode == 0, output(update)
    keys = rosdep_fragment()
    for system in ("ubuntu:noble", "debian:bookworm", "fedora:40"):
        resolved = subprocess.run([rosdep, "resolve", *keys, f"--os={system}"], env=env, capture_output=True,
                                  text=True, timeout=120)
        assert resolved.returncode == 0, output(resolved)
        assert resolved.stdout.split() == [word for key, packages in keys.items()
                                           for word in (f"#ROSDEP[{key}]", "#pip", *packages)], system
