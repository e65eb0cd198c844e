"""Bad input (issue 2, section 7): a broken scenario, world, map or parameter file -- an unknown package or
executable included -- is one ConfigError naming the file and the field, raised while loading, before any process
starts; the CLI prints one line (no traceback), exits non-zero and creates no run folder.

Each case copies line_follow_90 and the files it references into tmp_path (relative paths kept) and breaks one
thing."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from rfidnav_common.errors import ConfigError, UnknownExecutableError
from rfidnav_common.install import package_share, resolve_executable
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario
from support.config_files import copy_config, edit
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

CONFIG = WORKSPACE / "config"
SCENARIO = "scenarios/line_follow_90.yaml"
REFERENCED = (SCENARIO, "worlds/line_follow.yaml", "maps/line_follow.yaml", "params/robot_sim.yaml",
              "params/reader_uhf_2ant.yaml", "params/flc_tuned.yaml", "params/flc_paper.yaml")


@pytest.fixture
def config(tmp_path: Path) -> Path:
    return copy_config(tmp_path, REFERENCED)


@dataclass(frozen=True)
class Case:
    break_it: Callable[[Path], None]
    file: str              # relative to config/, the file the error must name
    field: str             # the dotted field the error must name ("" for a file-level error)
    words: tuple[str, ...] = ()   # further words the message must contain


def use_flc_paper_with_nan_speed(root: Path) -> None:
    edit(root / SCENARIO, "params: ../params/flc_tuned.yaml", "params: ../params/flc_paper.yaml")
    edit(root / "params/flc_paper.yaml", "forward_speed_mps: 0.2", "forward_speed_mps: .nan")


def use_flc_paper_after_tuned_with_negative_speed(root: Path) -> None:
    edit(root / SCENARIO, "params: ../params/flc_tuned.yaml",
         "params: [../params/flc_tuned.yaml, ../params/flc_paper.yaml]")
    edit(root / "params/flc_paper.yaml", "forward_speed_mps: 0.2", "forward_speed_mps: -0.2")


def unbalanced_bracket(root: Path) -> None:
    edit(root / SCENARIO, "goal: {tag_ids: [C1, C2]}", "goal: {tag_ids: [C1, C2}")


SCENARIO_LINES = (CONFIG / SCENARIO).read_text().splitlines()
GOAL_LINE = next(n for n, line in enumerate(SCENARIO_LINES, 1) if "goal: {tag_ids" in line)

CASES = {
    "missing mission.action": Case(
        lambda root: edit(root / SCENARIO, "  action: /follow_tag_route\n", ""),
        SCENARIO, "mission.action", ("missing",)),
    "missing world name": Case(
        lambda root: edit(root / "worlds/line_follow.yaml", "name: line_follow\n", ""),
        "worlds/line_follow.yaml", "name", ("missing",)),
    "wrong type robot.x": Case(
        lambda root: edit(root / SCENARIO, "x: -5.0", 'x: "abc"'),
        SCENARIO, "robot.x", ("number", "abc")),
    "wrong type in a parameter file": Case(
        lambda root: edit(root / "params/reader_uhf_2ant.yaml", "rate_hz: 25.0", "rate_hz: fast"),
        "params/reader_uhf_2ant.yaml", "rfid_reader_sim.ros__parameters.rate_hz", ("number",)),
    "wrong type of a tag position": Case(
        lambda root: edit(root / "worlds/line_follow.yaml", "position: [0.0, 5.0, 3.0]", "position: up"),
        "worlds/line_follow.yaml", "tags[1].position", ("list",)),
    "duplicate tag id in the world": Case(
        lambda root: edit(root / "worlds/line_follow.yaml", "{id: F2,", "{id: C1,"),
        "worlds/line_follow.yaml", "tags[3].id", ("duplicate", "C1")),
    "NaN in a tag position": Case(
        lambda root: edit(root / "worlds/line_follow.yaml", "position: [0.0, 5.0, 3.0]", "position: [0.0, .nan, 3.0]"),
        "worlds/line_follow.yaml", "tags[1].position[1]", ("finite",)),
    "Inf in the robot start": Case(
        lambda root: edit(root / SCENARIO, "y: -5.0", "y: .inf"),
        SCENARIO, "robot.y", ("finite",)),
    "NaN in a parameter file": Case(
        use_flc_paper_with_nan_speed,
        "params/flc_paper.yaml", "heading_controller.ros__parameters.forward_speed_mps", ("finite",)),
    "NaN in a list parameter": Case(
        lambda root: edit(root / "params/reader_uhf_2ant.yaml", "antenna_max_range_m: [12.0, 12.0, 0.10]",
                          "antenna_max_range_m: [12.0, .nan, 0.10]"),
        "params/reader_uhf_2ant.yaml", "rfid_reader_sim.ros__parameters.antenna_max_range_m[1]", ("finite",)),
    "unknown top-level field": Case(
        lambda root: edit(root / SCENARIO, "metrics: [tracking]", "metrics: [tracking]\ncolour: red"),
        SCENARIO, "colour", ("unknown",)),
    "unknown robot field": Case(
        lambda root: edit(root / SCENARIO, "yaw_deg: 90.0}", "yaw_deg: 90.0, z: 1.0}"),
        SCENARIO, "robot.z", ("unknown",)),
    "unknown parameter": Case(
        lambda root: edit(root / "params/robot_sim.yaml", "step_s: 0.01", "step_s: 0.01\n    warp_drive: true"),
        "params/robot_sim.yaml", "robot_sim.ros__parameters.warp_drive", ("unknown",)),
    "unknown tag field in the world": Case(
        lambda root: edit(root / "worlds/line_follow.yaml", "{id: C1, position: [0.0, 0.0, 3.0]}",
                          "{id: C1, position: [0.0, 0.0, 3.0], colour: red}"),
        "worlds/line_follow.yaml", "tags[0].colour", ("unknown",)),
    "malformed YAML names the line": Case(
        unbalanced_bracket, SCENARIO, "", ("YAML", f"line {GOAL_LINE}")),
    "route goal tag missing from the map": Case(
        lambda root: edit(root / SCENARIO, "tag_ids: [C1, C2]", "tag_ids: [C1, C9]"),
        SCENARIO, "mission.goal", ("C9",)),
    "parameter file without the node key": Case(
        lambda root: edit(root / "params/reader_uhf_2ant.yaml", "rfid_reader_sim:\n", "reader_sim:\n"),
        "params/reader_uhf_2ant.yaml", "rfid_reader_sim", ("no parameters",)),
    "parameter file that is not found": Case(
        lambda root: (root / "params/robot_sim.yaml").unlink(),
        SCENARIO, "nodes.robot_sim.params", ("not found",)),
    "world file that is not found": Case(
        lambda root: (root / "worlds/line_follow.yaml").unlink(),
        SCENARIO, "world", ("world file not found", "worlds/line_follow.yaml")),
    "map without arrival tags": Case(
        lambda root: edit(root / "maps/line_follow.yaml", "arrival_tags: {C1: F1, C2: F2}", "arrival_tags: {}"),
        "maps/line_follow.yaml", "arrival_tags", ()),
    "out-of-range parameter value": Case(
        lambda root: edit(root / "params/reader_uhf_2ant.yaml", "miss_probability: 0.0", "miss_probability: 1.5"),
        "params/reader_uhf_2ant.yaml", "rfid_reader_sim.ros__parameters.miss_probability", ("[0, 1)", "1.5")),
    "out-of-range value in the second parameter file": Case(
        use_flc_paper_after_tuned_with_negative_speed,
        "params/flc_paper.yaml", "heading_controller.ros__parameters.forward_speed_mps", ("positive",)),
    "out-of-range value in a scenario override": Case(
        lambda root: edit(root / SCENARIO, "params: ../params/reader_uhf_2ant.yaml}",
                          "params: ../params/reader_uhf_2ant.yaml, overrides: {miss_probability: 1.5}}"),
        SCENARIO, "nodes.rfid_reader.overrides.miss_probability", ("[0, 1)",)),
    "wrong type in a scenario override": Case(
        lambda root: edit(root / SCENARIO, "params: ../params/reader_uhf_2ant.yaml}",
                          "params: ../params/reader_uhf_2ant.yaml, overrides: {rate_hz: fast}}"),
        SCENARIO, "nodes.rfid_reader.overrides.rate_hz", ("number",)),
    "validate() error naming no single field": Case(
        lambda root: edit(root / "params/flc_tuned.yaml", "right_antenna: 2", "right_antenna: 1"),
        "params/flc_tuned.yaml", "heading_controller.ros__parameters", ("left_antenna and right_antenna", "differ")),
    "unknown package": Case(
        lambda root: edit(root / SCENARIO, "package: rfidnav_control,", "package: nope_pkg,"),
        SCENARIO, "nodes.heading_controller.package", ("unknown package 'nope_pkg'",)),
    "unknown executable": Case(
        lambda root: edit(root / SCENARIO, "executable: heading_controller", "executable: nope_exe"),
        SCENARIO, "nodes.heading_controller.executable", ("'nope_exe'", "heading_controller")),
    "command that is not a program": Case(
        lambda root: edit(root / SCENARIO, "package: rfidnav_control, executable: heading_controller",
                          "command: nope_driver --port 1"),
        SCENARIO, "nodes.heading_controller.command", ("'nope_driver'",)),
}


def test_the_unbroken_copy_loads(config: Path):
    scenario = load_scenario(str(config / SCENARIO))
    assert scenario.name == "line_follow_90"
    assert scenario.world_file == (config / "worlds/line_follow.yaml").resolve()
    assert scenario.mission.goal == {"tag_ids": ["C1", "C2"]}


@pytest.mark.parametrize("name", sorted(CASES))
def test_broken_file_is_one_config_error_naming_file_and_field(config: Path, name: str):
    case = CASES[name]
    case.break_it(config)
    with pytest.raises(ConfigError) as raised:
        load_scenario(str(config / SCENARIO))
    error = raised.value
    message = str(error)
    expected_file = (config / case.file).resolve()
    assert Path(error.source).resolve() == expected_file, message
    assert str(expected_file) in message
    if case.field:
        assert error.field == case.field, message
        assert f": {case.field}:" in message
    for word in case.words:
        assert word in message, message
    assert "\n" not in message


def test_nan_is_rejected_by_name_not_by_python(config: Path):
    """A NaN must not slip through as a float (NaN compares false with every bound)."""
    use_flc_paper_with_nan_speed(config)
    with pytest.raises(ConfigError, match=r"forward_speed_mps: expected a finite number"):
        load_scenario(str(config / SCENARIO))


# ------------------------------------------------------------------------------------ unknown package/executable

def test_the_config_is_found_in_the_share_directory_of_rfidnav_scenario_on_the_ament_index():
    share = package_share("rfidnav_scenario")
    assert CONFIG_DIR == share / "config"
    assert (CONFIG_DIR / SCENARIO).samefile(WORKSPACE / "config" / SCENARIO)   # linked from the sources by set-up
    assert (share / "package.xml").samefile(WORKSPACE / "rfidnav_scenario" / "package.xml")


def test_a_package_on_no_ament_index_is_an_unknown_executable_error_naming_where_it_looked():
    with pytest.raises(UnknownExecutableError,
                       match=r"'nope_pkg' is in no ament index \(searched .*\); run ./rfidnav setup"):
        package_share("nope_pkg")


def test_unknown_package_is_an_unknown_executable_error():
    with pytest.raises(UnknownExecutableError, match=r"unknown package 'nope_pkg'"):
        resolve_executable("nope_pkg", "x")


def test_unknown_executable_is_an_unknown_executable_error_listing_the_known_ones():
    with pytest.raises(UnknownExecutableError) as raised:
        resolve_executable("rfidnav_sim", "nope")
    message = str(raised.value)
    assert "'rfidnav_sim'" in message and "'nope'" in message
    assert "robot_sim" in message and "rfid_reader_sim" in message


def test_known_executable_resolves_to_a_runnable_command():
    command = resolve_executable("rfidnav_sim", "robot_sim")
    assert command
    assert Path(command[0]).exists()


@pytest.mark.parametrize("replacement, field, words", [
    ("nope_pkg:robot_sim", "heading_controller.package", ("unknown package 'nope_pkg'",)),
    ("rfidnav_sim:nope", "heading_controller.executable", ("'nope'", "robot_sim")),
    ("nope_driver --port 1", "heading_controller", ("'nope_driver'",)),
    ("", "heading_controller", ("empty command",)),
])
def test_swap_to_an_unknown_executable_is_a_config_error_naming_the_option(config: Path, replacement: str,
                                                                          field: str, words: tuple[str, ...]):
    with pytest.raises(ConfigError) as raised:
        load_scenario(str(config / SCENARIO), swaps={"heading_controller": replacement})
    assert (raised.value.source, raised.value.field) == ("--swap", field), str(raised.value)
    for word in words:
        assert word in str(raised.value)


def test_swap_resolves_the_replacement_and_keeps_a_command_line(config: Path):
    scenario = load_scenario(str(config / SCENARIO), swaps={"rfid_reader": "rfidnav_bag:player",
                                                            "heading_controller": "true --flag"})
    reader, controller = scenario.nodes["rfid_reader"], scenario.nodes["heading_controller"]
    assert reader.command == tuple(resolve_executable("rfidnav_bag", "player"))
    assert reader.param_files
    assert (controller.package, controller.command, controller.param_files) == (None, ("true", "--flag"), ())


# -------------------------------------------------------------------------------------------------------- CLI

def run_cli(scenario: Path, out: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    return subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "run", str(scenario), "--out", str(out),
                           "--rtf", "5"], capture_output=True, text=True, timeout=60, env=env, cwd=WORKSPACE)


@pytest.mark.tier("graph")
@pytest.mark.parametrize("name", ["wrong type robot.x", "NaN in a parameter file", "duplicate tag id in the world"])
def test_cli_run_of_a_broken_scenario_prints_one_line_and_starts_nothing(config: Path, tmp_path: Path, name: str):
    case = CASES[name]
    case.break_it(config)
    out = tmp_path / "runs"
    result = run_cli(config / SCENARIO, out)
    assert result.returncode != 0
    assert "Traceback" not in result.stderr, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert str((config / case.file).resolve()) in lines[0]
    assert case.field in lines[0]
    # Nothing started: no run folder (nor the --out folder itself).
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.tier("graph")
def test_cli_run_with_an_unknown_package_names_the_scenario_field_and_starts_nothing(config: Path, tmp_path: Path):
    edit(config / SCENARIO, "package: rfidnav_control, executable: heading_controller",
         "package: nope_pkg, executable: heading_controller")
    out = tmp_path / "runs"
    result = run_cli(config / SCENARIO, out)
    assert result.returncode != 0
    assert "Traceback" not in result.stderr, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert str((config / SCENARIO).resolve()) in lines[0]
    assert "nodes.heading_controller.package" in lines[0] and "nope_pkg" in lines[0]
    assert not out.exists() or not any(out.iterdir())


def test_a_validate_error_names_its_field_as_data_and_reads_as_before() -> None:
    from rfidnav_common.errors import ParameterError
    from rfidnav_planning.parameters import PartitionNavigatorParameters

    with pytest.raises(ParameterError) as raised:
        PartitionNavigatorParameters(map_file="map.yaml", max_replans=-1).validate()
    assert isinstance(raised.value, ValueError)     # callers that catch ValueError keep working
    assert (raised.value.field, raised.value.problem) == ("max_replans", "must not be negative")
    assert str(raised.value) == "max_replans: must not be negative"
    between_fields = "rate_hz and hop_dwell_s must be positive"
    assert str(ParameterError("", between_fields)) == between_fields


# ------------------------------------------------------------------------------- the loader and declared limits

def test_a_yaml_merge_key_may_override_what_it_merges_but_a_key_given_twice_is_refused(tmp_path: Path) -> None:
    from rfidnav_common.config import load_yaml_file

    merged = tmp_path / "merged.yaml"
    merged.write_text("base: &base {a: 1, b: 2}\nitem:\n  <<: *base\n  b: 3\n")
    assert load_yaml_file(merged)["item"] == {"a": 1, "b": 3}
    twice = tmp_path / "twice.yaml"
    twice.write_text("item:\n  a: 1\n  b: 2\n  a: 3\n")
    with pytest.raises(ConfigError, match=r"twice.yaml: not valid YAML: line 4, column 3: duplicate key 'a' "
                                          r"\(first given on line 2\)"):
        load_yaml_file(twice)


def test_text_that_is_not_utf8_is_named_by_its_byte_offset_and_line(tmp_path: Path) -> None:
    from rfidnav_common.config import load_yaml_file

    latin1 = tmp_path / "latin1.yaml"
    latin1.write_bytes("name: x\ndescription: café\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"latin1.yaml: not UTF-8 text: byte 0xe9 at offset 24 \(line 2\)"):
        load_yaml_file(latin1)


def test_limits_are_declared_with_the_field_and_checked_item_by_item() -> None:
    import dataclasses

    from rfidnav_common.config import PORT, Limits, check_limits, param
    from rfidnav_common.errors import ParameterError

    @dataclasses.dataclass(frozen=True)
    class Example:
        ports: list[int] = param("ports", [1, 2], PORT)
        mode: str = param("mode", "a", Limits(choices=("a", "b")))
        fraction: float = param("fraction", 0.5, Limits(0.0, 1.0, high_open=True))

    field = dataclasses.fields(Example)[0]
    assert field.metadata == {"doc": "ports", "min": 1, "max": 65535}
    check_limits(Example())
    for bad, name, problem in ((Example(ports=[1, 0]), "ports[1]", "must be in [1, 65535], got 0"),
                               (Example(mode="c"), "mode", "'c' is not one of: a, b"),
                               (Example(fraction=1.0), "fraction", "must be in [0, 1), got 1")):
        with pytest.raises(ParameterError) as raised:
            check_limits(bad)
        assert (raised.value.field, raised.value.problem) == (name, problem)


def test_only_a_field_declared_unbounded_takes_infinity_and_every_other_stays_finite() -> None:
    import dataclasses
    import math

    from rfidnav_common.config import Limits, param, parameters_from_mapping

    @dataclasses.dataclass(frozen=True)
    class Example:
        rtf: float = param("rtf", 1.0, Limits(0.0, low_open=True, unbounded=True))
        rate: float = param("rate", 1.0, Limits(0.0, low_open=True))

    assert parameters_from_mapping(Example, {"rtf": math.inf}, "example.yaml").rtf == math.inf
    for data, problem in (({"rate": math.inf}, "rate: expected a finite number, got inf"),
                          ({"rtf": -math.inf}, "rtf: expected a finite number, got -inf"),
                          ({"rtf": math.nan}, "rtf: expected a finite number, got nan"),
                          ({"rtf": 0.0}, "rtf: must be positive or .inf (no bound), got 0")):
        with pytest.raises(ConfigError) as raised:
            parameters_from_mapping(Example, data, "example.yaml")
        assert str(raised.value) == f"example.yaml: {problem}", data


def test_every_shipped_scenario_with_every_robot_profile_and_every_parameter_file_is_within_its_ranges() -> None:
    from rfidnav_common.config import Section, node_parameter_section, parameters_from_mapping
    from rfidnav_common.node_registry import registered_nodes
    from rfidnav_scenario.scenario import ROBOT_DIR, SCENARIO_DIR, robot_profile

    scenarios = {path.stem: load_scenario(str(path)) for path in sorted(SCENARIO_DIR.glob("*.yaml"))}
    for profile_file in sorted(ROBOT_DIR.glob("*.yaml")):
        profile = robot_profile(str(profile_file))
        # Paper 001's robot for a profile of its roles, else paper 003's (the location server).
        fitting = next(name for name in ("line_follow_90", "two_tier_home")
                       if set(profile.roles) | set(profile.parts) <= set(scenarios[name].nodes))
        load_scenario(fitting, robot_profile_name=str(profile_file))
    classes = {registration.node_name: registration.parameters for registration in registered_nodes().values()}
    required = {"world_file": "w.yaml", "map_file": "m.yaml"}
    checked = 0
    for file in sorted((CONFIG_DIR / "params").glob("*.yaml")):
        for node in Section.from_file(file).keys():
            cls = classes[node]
            section = node_parameter_section(file, node)
            values = {**{k: v for k, v in required.items() if k in cls.__dataclass_fields__}, **section.data}
            if cls.__name__ == "PartitionLocalizerParameters":
                values["map_file"] = section.data.get("map_file", "unused")
            parameters_from_mapping(cls, values, section.source, section.prefix)
            checked += 1
    assert checked >= 24


def test_a_relative_action_name_is_the_one_the_orchestrator_resolves(config: Path) -> None:
    edit(config / SCENARIO, "action: /follow_tag_route", "action: follow_tag_route")
    assert load_scenario(str(config / SCENARIO)).mission.action == "follow_tag_route"
