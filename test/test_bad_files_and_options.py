"""Bad input (issue 17, items 4 and 5): every file kind the project loads -- scenario, parameter file, world, route
map, topological map, radio map, robot profile -- and every option of the verbs, broken one thing at a time, as an
outside tester would (a byte that is not UTF-8, a key given twice, a typo, NaN, 1e300, an integer beyond int64, a
range that means nothing, a name ROS refuses, a folder that cannot be written, ...).

Each case asserts what a person at the command line sees: exit 2, one line on stderr naming the file and the field
(or the option), no traceback, and nothing started: no node process, no run folder, no file written. The cases run
``./rfidnav``'s own ``main`` in this process (fast: the whole table in seconds) with everything that would start a
run, a process or an experiment replaced by a tripwire; a few run the real command line in its own process.

Each file case copies the shipped scenario and the files it references into tmp_path (relative paths kept) and
breaks one thing there."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from rfidnav_bringup import cli
from support.config_files import copy_config, edit
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("unit")

# The files each scenario reads (relative to config/): copied for each case.
FILES = {
    "line_follow_90": ("scenarios/line_follow_90.yaml", "worlds/line_follow.yaml", "maps/line_follow.yaml",
                       "params/robot_sim.yaml", "params/reader_uhf_2ant.yaml", "params/flc_tuned.yaml",
                       "robots/create2_llrp.yaml", "params/create_base.yaml", "params/llrp_reader.yaml"),
    "two_tier_home": ("scenarios/two_tier_home.yaml", "worlds/two_tier_home.yaml", "maps/two_tier_home.yaml",
                      "maps/two_tier_home_radio_map.yaml", "params/robot_sim.yaml", "params/reader_hf_floor.yaml",
                      "params/wifi_sim.yaml", "params/compass_sim.yaml", "params/location_server.yaml",
                      "params/two_tier_navigator.yaml"),
    "building_floor": ("scenarios/building_floor.yaml", "worlds/building_fig5.yaml", "maps/building_fig5.yaml",
                       "params/robot_sim.yaml", "params/sonar_sim.yaml", "params/reader_wall_side.yaml",
                       "params/wall_follower.yaml", "params/mission_executor.yaml"),
    "partition_field": ("scenarios/partition_field.yaml", "worlds/partition_field.yaml", "maps/partition_field.yaml",
                        "params/robot_sim.yaml", "params/reader_floor_lattice.yaml",
                        "params/partition_localizer_paper.yaml", "params/partition_navigator.yaml",
                        "params/rfid_localizer_floor_lattice.yaml"),
    "building_ring": ("scenarios/building_ring.yaml", "worlds/building_ring.yaml", "maps/building_ring.yaml",
                      "maps/building_ring_survey.yaml", "params/robot_sim.yaml", "params/sonar_sim.yaml",
                      "params/reader_wall_side.yaml", "params/wall_follower.yaml", "params/mission_executor.yaml",
                      "params/rfid_localizer_wall_side.yaml"),
}
# The node name each parameter file holds (its errors name NODE.ros__parameters.KEY).
NODE_OF = {"robot_sim": "robot_sim", "reader_uhf_2ant": "rfid_reader_sim", "reader_hf_floor": "rfid_reader_sim",
           "reader_wall_side": "rfid_reader_sim", "reader_floor_lattice": "rfid_reader_sim",
           "flc_tuned": "heading_controller", "wifi_sim": "wifi_sim", "compass_sim": "compass_sim",
           "location_server": "location_server", "two_tier_navigator": "two_tier_navigator",
           "sonar_sim": "sonar_sim", "wall_follower": "wall_follower", "mission_executor": "mission_executor",
           "partition_localizer_paper": "partition_localizer", "partition_navigator": "partition_navigator",
           "create_base": "create_base", "llrp_reader": "llrp_reader", "rfid_localizer_floor_lattice": "rfid_localizer"}
PROFILE = "robots/create2_llrp.yaml"
BR, S_BR, SURVEY = "building_ring", "scenarios/building_ring.yaml", "maps/building_ring_survey.yaml"
INT64_OVER = str(1 << 64)


# ------------------------------------------------------------------------------------------- ways to break a file

def replaced(relative: str, old: str, new: str) -> Callable[[Path], None]:
    return lambda root: edit(root / relative, old, new)


def not_utf8(relative: str) -> Callable[[Path], None]:
    """A Latin-1 byte (0xE9, "é") in the first comment or value: the file's text is no longer UTF-8."""
    def break_it(root: Path) -> None:
        data = (root / relative).read_bytes()
        at = data.index(b"name: ") + len(b"name: ") if b"name: " in data else data.index(b":") + 2
        (root / relative).write_bytes(data[:at] + b"caf\xe9 " + data[at:])
    return break_it


def utf8_offset(relative: str) -> str:
    data = (WORKSPACE / "config" / relative).read_bytes()
    at = data.index(b"name: ") + len(b"name: ") if b"name: " in data else data.index(b":") + 2
    return f"offset {at + 3}"


def parameter(relative: str, key: str, value: str) -> Callable[[Path], None]:
    """Set ``key`` of a parameter file (the line that gives it, or a new line under ros__parameters)."""
    def break_it(root: Path) -> None:
        path = root / relative
        text = path.read_text()
        line = re.compile(rf"^(\s+){re.escape(key)}:.*$", re.MULTILINE)
        found = line.findall(text)
        assert len(found) <= 1, f"{relative}: {key} given {len(found)} times"
        if found:
            path.write_text(line.sub(lambda match: f"{match.group(1)}{key}: {value}", text))
        else:
            edit(path, "  ros__parameters:\n", f"  ros__parameters:\n    {key}: {value}\n")
    return break_it


def written(relative: str, text: str) -> Callable[[Path], None]:
    return lambda root: (root / relative).write_text(text)


def both(*breaks: Callable[[Path], None]) -> Callable[[Path], None]:
    def break_it(root: Path) -> None:
        for one in breaks:
            one(root)
    return break_it


def key_of(relative: str, key: str) -> str:
    """The field an error about ``key`` of a parameter file names."""
    return f"{NODE_OF[Path(relative).stem]}.ros__parameters.{key}"


# -------------------------------------------------------------------------------------------------- the cases

@dataclass(frozen=True)
class FileCase:
    """``./rfidnav run SCENARIO`` on a copy with one thing broken."""

    scenario: str
    break_it: Callable[[Path], None]
    file: str                         # relative to config/ (the line names it, resolved), or an option ("--goal")
    field: str                        # the dotted field the line names ("" for the file as a whole)
    words: tuple[str, ...] = ()       # further words the line holds
    argv: tuple[str, ...] = ()        # options of run (ROOT stands for the copy's config/)


LF, TT, BF, PF = "line_follow_90", "two_tier_home", "building_floor", "partition_field"
S_LF, S_TT, S_BF, S_PF = (f"scenarios/{name}.yaml" for name in (LF, TT, BF, PF))
W_LF, W_TT, W_BF, W_PF = "worlds/line_follow.yaml", "worlds/two_tier_home.yaml", "worlds/building_fig5.yaml", \
    "worlds/partition_field.yaml"
M_LF, M_TT, M_BF, M_PF = "maps/line_follow.yaml", "maps/two_tier_home.yaml", "maps/building_fig5.yaml", \
    "maps/partition_field.yaml"
RADIO = "maps/two_tier_home_radio_map.yaml"
ROBOT, READER, FLC = "params/robot_sim.yaml", "params/reader_uhf_2ant.yaml", "params/flc_tuned.yaml"
HF, WIFI, COMPASS = "params/reader_hf_floor.yaml", "params/wifi_sim.yaml", "params/compass_sim.yaml"
SERVER, TWO_TIER = "params/location_server.yaml", "params/two_tier_navigator.yaml"
SONAR, SIDE, WALL, EXECUTOR = "params/sonar_sim.yaml", "params/reader_wall_side.yaml", "params/wall_follower.yaml", \
    "params/mission_executor.yaml"
LATTICE, LOCALIZER, NAVIGATOR = "params/reader_floor_lattice.yaml", "params/partition_localizer_paper.yaml", \
    "params/partition_navigator.yaml"
BASE, LLRP = "params/create_base.yaml", "params/llrp_reader.yaml"
WITH_PROFILE = ("--robot", f"ROOT/{PROFILE}")


def p(relative: str, key: str, value: str, *words: str, scenario: str = LF, argv: tuple[str, ...] = (),
      item: int | None = None) -> FileCase:
    """A parameter set to a bad value, named in its file (``item``: the list item named, ``key[item]``)."""
    field = key_of(relative, key) + (f"[{item}]" if item is not None else "")
    return FileCase(scenario, parameter(relative, key, value), relative, field, words, argv)


def goal(scenario: str, old: str, new: str, *words: str) -> FileCase:
    """The scenario's goal broken: named as its mission.goal."""
    relative = f"scenarios/{scenario}.yaml"
    return FileCase(scenario, replaced(relative, old, new), relative, "mission.goal", words)


GOAL_LF, GOAL_PF = "goal: {tag_ids: [C1, C2]}", "goal: {target: {x: 4.0, y: 3.8, z: 0.0}, tolerance_m: 0.0}"
GOAL_TT = "goal: {target: {x: 10.8, y: 6.8, z: 0.0}, tolerance_m: 0.0}"

FILE_CASES: dict[str, FileCase] = {
    # ---- every file kind: text that is not UTF-8 (file, byte offset)
    **{f"non-UTF-8 {relative}": FileCase(scenario, not_utf8(relative), relative, "",
                                          ("not UTF-8", "0xe9", utf8_offset(relative)), argv)
       for scenario, relative, argv in (
           (LF, S_LF, ()), (LF, W_LF, ()), (LF, M_LF, ()), (LF, ROBOT, ()), (LF, READER, ()), (LF, FLC, ()),
           (TT, RADIO, ()), (TT, W_TT, ()), (TT, M_TT, ()), (TT, SERVER, ()), (BF, M_BF, ()), (BF, W_BF, ()),
           (BF, WALL, ()), (PF, W_PF, ()), (PF, LOCALIZER, ()), (LF, PROFILE, WITH_PROFILE),
           (LF, BASE, WITH_PROFILE), (LF, LLRP, WITH_PROFILE))},
    # ---- every file kind: a key given twice (line, key)
    "scenario key twice": FileCase(LF, replaced(S_LF, "metrics: [tracking]", "metrics: [tracking]\nname: again"),
                                   S_LF, "", ("duplicate key 'name'", "first given on line 1")),
    "robot field twice": FileCase(LF, replaced(S_LF, "yaw_deg: 90.0}", "yaw_deg: 90.0, x: 1.0}"), S_LF, "",
                                  ("duplicate key 'x'", "line 5")),
    "world tag field twice": FileCase(LF, replaced(W_LF, "{id: C1, position", "{id: C1, id: C3, position"), W_LF,
                                      "", ("duplicate key 'id'",)),
    "map arrival tag twice": FileCase(LF, replaced(M_LF, "{C1: F1, C2: F2}", "{C1: F1, C2: F2, C1: F2}"), M_LF, "",
                                      ("duplicate key 'C1'",)),
    "parameter twice": FileCase(LF, replaced(ROBOT, "    step_s: 0.01", "    step_s: 0.01\n    step_s: 0.02"), ROBOT,
                                "", ("duplicate key 'step_s'", "first given on line 5")),
    "radio map reading twice": FileCase(TT, replaced(RADIO, "'02:00:00:00:00:02': -39.79,",
                                                     "'02:00:00:00:00:02': -39.79, '02:00:00:00:00:02': -30.0,"),
                                        RADIO, "", ("duplicate key '02:00:00:00:00:02'",)),
    "topological node twice": FileCase(BF, replaced(M_BF, "nodes:\n  c:\n", "nodes:\n  c: {}\n  c:\n"), M_BF, "",
                                       ("duplicate key 'c'",)),
    "profile role twice": FileCase(LF, replaced(PROFILE, "roles:", "roles:\n  rfid_reader: {package: x}"), PROFILE,
                                   "", ("duplicate key 'rfid_reader'",), WITH_PROFILE),
    # ---- unknown keys, with the nearest known one
    "scenario typo": FileCase(LF, replaced(S_LF, "metrics: [tracking]", "metrics: [tracking]\nmision: {}"), S_LF,
                              "mision", ("unknown field", "did you mean 'mission'?")),
    "robot typo": FileCase(LF, replaced(S_LF, "yaw_deg: 90.0}", "yaw: 90.0}"), S_LF, "robot.yaw",
                           ("did you mean 'yaw_deg'?",)),
    "node entry typo": FileCase(LF, replaced(S_LF, "params: ../params/flc_tuned.yaml, respawn: true",
                                             "params: ../params/flc_tuned.yaml, respawns: true"),
                                S_LF, "nodes.heading_controller.respawns", ("did you mean 'respawn'?",)),
    "mission typo": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout: 120"), S_LF, "mission.timeout",
                             ("did you mean 'timeout_s'?",)),
    "world tag typo": FileCase(LF, replaced(W_LF, "{id: C1, position: [0.0, 0.0, 3.0]}",
                                            "{id: C1, postion: [0.0, 0.0, 3.0]}"), W_LF, "tags[0].postion",
                               ("did you mean 'position'?",)),
    "world typo": FileCase(TT, replaced(W_TT, "walls:\n", "wals:\n"), W_TT, "wals", ("did you mean 'walls'?",)),
    "map typo": FileCase(LF, replaced(M_LF, "arrival_tags:", "arival_tags:"), M_LF, "arival_tags",
                         ("did you mean 'arrival_tags'?",)),
    "lattice typo": FileCase(PF, replaced(W_PF, "read_range_m: 0.2", "read_range: 0.2"), W_PF, "lattices[0].read_range",
                             ("did you mean 'read_range_m'?",)),
    "radio map typo": FileCase(TT, replaced(RADIO, "fingerprints:", "fingerprint:"), RADIO, "fingerprint",
                               ("did you mean 'fingerprints'?",)),
    "parameter typo": FileCase(LF, replaced(ROBOT, "step_s: 0.01", "step_sec: 0.01"), ROBOT,
                               key_of(ROBOT, "step_sec"), ("did you mean 'step_s'?",)),
    "override typo": FileCase(LF, replaced(S_LF, "overrides: {map_to_odom_at_start: true}",
                                           "overrides: {map_to_odom_at_begin: true}"),
                              S_LF, "nodes.robot_sim.overrides.map_to_odom_at_begin",
                              ("did you mean 'map_to_odom_at_start'?",)),
    "profile typo": FileCase(LF, replaced(PROFILE, "roles:", "role:"), PROFILE, "role", ("did you mean 'roles'?",),
                             WITH_PROFILE),
    "wifi typo": FileCase(TT, replaced(W_TT, "wall_loss_db: 5.0", "wall_loss: 5.0"), W_TT, "wifi.wall_loss",
                          ("did you mean 'wall_loss_db'?",)),
    # ---- the scenario file
    "empty scenario": FileCase(LF, written(S_LF, "# nothing\n"), S_LF, "", ("empty",)),
    "scenario that is a list": FileCase(LF, written(S_LF, "- name: x\n"), S_LF, "", ("expected a mapping",)),
    "scenario YAML syntax": FileCase(LF, replaced(S_LF, GOAL_LF, "goal: {tag_ids: [C1, C2}"), S_LF, "",
                                     ("not valid YAML", "line 14")),
    "scenario nested 5000 deep": FileCase(LF, replaced(S_LF, "metrics: [tracking]", "metrics: [tracking]\ndeep: "
                                                  + "[" * 5000 + "]" * 5000), S_LF, "", ("nested too deeply",)),
    "no scenario name": FileCase(LF, replaced(S_LF, "name: line_follow_90\n", ""), S_LF, "name", ("missing",)),
    "scenario name a number": FileCase(LF, replaced(S_LF, "name: line_follow_90", "name: 90"), S_LF, "name",
                                       ("non-empty string",)),
    "no world": FileCase(LF, lambda root: (root / W_LF).unlink(), S_LF, "world", ("world file not found", W_LF)),
    "world a folder": FileCase(LF, both(lambda root: (root / W_LF).unlink(), lambda root: (root / W_LF).mkdir()),
                               S_LF, "world", ("is a folder, not a file", W_LF)),
    "world the scenario's folder": FileCase(LF, replaced(S_LF, "world: ../worlds/line_follow.yaml", "world: ."),
                                            S_LF, "world", ("is a folder, not a file", "scenarios")),
    "no map": FileCase(LF, lambda root: (root / M_LF).unlink(), S_LF, "map", ("map file not found", M_LF)),
    "robot x 1e300": FileCase(LF, replaced(S_LF, "x: -5.0", "x: 1.0e+300"), S_LF, "robot.x", ("within ±1e+06",)),
    "robot x NaN": FileCase(LF, replaced(S_LF, "x: -5.0", "x: .nan"), S_LF, "robot.x", ("finite",)),
    "robot y -Inf": FileCase(LF, replaced(S_LF, "y: -5.0", "y: -.inf"), S_LF, "robot.y", ("finite",)),
    "robot x text": FileCase(LF, replaced(S_LF, "x: -5.0", 'x: "west"'), S_LF, "robot.x", ("number", "west")),
    "robot x boolean": FileCase(LF, replaced(S_LF, "x: -5.0", "x: true"), S_LF, "robot.x", ("number",)),
    "robot yaw 1000 degrees": FileCase(LF, replaced(S_LF, "yaw_deg: 90.0", "yaw_deg: 1000.0"), S_LF, "robot.yaw_deg",
                                       ("at most 360",)),
    "no robot y": FileCase(LF, replaced(S_LF, "y: -5.0, ", ""), S_LF, "robot.y", ("missing",)),
    "max_respawns beyond int64": FileCase(LF, replaced(S_LF, "respawn: true}", f"respawn: true, max_respawns: "
                                                                             f"{INT64_OVER}}}"),
                                          S_LF, "nodes.heading_controller.max_respawns", ("at most",)),
    "max_respawns negative": FileCase(LF, replaced(S_LF, "respawn: true}", "respawn: true, max_respawns: -1}"), S_LF,
                                      "nodes.heading_controller.max_respawns", ("at least 0",)),
    "max_respawns a thousand": FileCase(LF, replaced(S_LF, "respawn: true}", "respawn: true, max_respawns: 1000}"),
                                        S_LF, "nodes.heading_controller.max_respawns", ("at most 100",)),
    "max_respawns 1.5": FileCase(LF, replaced(S_LF, "respawn: true}", "respawn: true, max_respawns: 1.5}"), S_LF,
                                 "nodes.heading_controller.max_respawns", ("integer",)),
    "no nodes": FileCase(LF, replaced(S_LF, "nodes: ", "nodes: {}\nx_nodes: "), S_LF, "x_nodes", ("unknown",)),
    "two clock sources": FileCase(LF, replaced(S_LF, "executable: rfid_reader_sim, sim: true,",
                                               "executable: rfid_reader_sim, sim: true, clock_source: true,"),
                                  S_LF, "nodes", ("only one node can be the clock_source",)),
    "node without an executable": FileCase(LF, replaced(S_LF, "package: rfidnav_control, executable: "
                                                              "heading_controller,", "package: rfidnav_control,"),
                                           S_LF, "nodes.heading_controller.package", ("give package and executable",)),
    "unknown package": FileCase(LF, replaced(S_LF, "package: rfidnav_control,", "package: nope_pkg,"), S_LF,
                                "nodes.heading_controller.package", ("unknown package 'nope_pkg'",)),
    "unknown executable": FileCase(LF, replaced(S_LF, "executable: heading_controller", "executable: nope_exe"),
                                   S_LF, "nodes.heading_controller.executable", ("'nope_exe'",)),
    "command that is no program": FileCase(LF, replaced(S_LF, "package: rfidnav_control, executable: "
                                                              "heading_controller",
                                                        "command: nope_driver --port 1"),
                                           S_LF, "nodes.heading_controller.command", ("'nope_driver'",)),
    "process name with a space": FileCase(LF, replaced(S_LF, "process: simulator, params: ../params/reader",
                                                       "process: sim ulator, params: ../params/reader"), S_LF,
                                          "nodes.rfid_reader.process", ("expected a name",)),
    "shared process that respawns": FileCase(LF, replaced(S_LF, "process: simulator, params: ../params/reader",
                                                          "process: simulator, respawn: true, "
                                                          "params: ../params/reader"),
                                             S_LF, "nodes.rfid_reader.process", ("a process of its own",)),
    "parameter file not found": FileCase(LF, lambda root: (root / ROBOT).unlink(), S_LF, "nodes.robot_sim.params",
                                         ("not found",)),
    # A role's own robot map (the fused localizer's tag survey beside paper 004's topological map).
    "role's map not found": FileCase(BR, lambda root: (root / SURVEY).unlink(), S_BR, "nodes.rfid_localizer.map",
                                     ("map file not found",)),
    "role's map with a bad plate": FileCase(BR, replaced(SURVEY, "normal: [0.0, 1.0]}\n  - {id: \"2\"",
                                                                      "normal: [0.0, 0.0]}\n  - {id: \"2\""),
                                            SURVEY, "wall_tags[0].normal", ("must not be zero",)),
    "params a number": FileCase(LF, replaced(S_LF, "params: ../params/flc_tuned.yaml", "params: 5"), S_LF,
                                "nodes.heading_controller.params", ("parameter file path",)),
    "overrides a list": FileCase(LF, replaced(S_LF, "overrides: {map_to_odom_at_start: true}", "overrides: [1]"),
                                 S_LF, "nodes.robot_sim.overrides", ("mapping",)),
    "override out of range": FileCase(LF, replaced(S_LF, "params: ../params/reader_uhf_2ant.yaml}",
                                                   "params: ../params/reader_uhf_2ant.yaml, "
                                                   "overrides: {miss_probability: 1.5}}"),
                                      S_LF, "nodes.rfid_reader.overrides.miss_probability", ("[0, 1)", "1.5")),
    "override of the wrong type": FileCase(LF, replaced(S_LF, "overrides: {map_to_odom_at_start: true}",
                                                        "overrides: {map_to_odom_at_start: 1}"),
                                           S_LF, "nodes.robot_sim.overrides.map_to_odom_at_start", ("true or false",)),
    "override NaN": FileCase(LF, replaced(S_LF, "overrides: {map_to_odom_at_start: true}",
                                          "overrides: {step_s: .nan}"), S_LF, "nodes.robot_sim.overrides.step_s",
                             ("finite",)),
    "override 1e308": FileCase(LF, replaced(S_LF, "overrides: {map_to_odom_at_start: true}",
                                            "overrides: {track_width_m: 1.0e+308}"),
                               S_LF, "nodes.robot_sim.overrides.track_width_m", ("within ±1e+06",)),
    "override integer beyond int64": FileCase(LF, replaced(S_LF, "respawn: true}", "respawn: true, overrides: "
                                                                                 f"{{left_antenna: {INT64_OVER}}}}}"),
                                              S_LF, "nodes.heading_controller.overrides.left_antenna", ("at most",)),
    "action with a space": FileCase(LF, replaced(S_LF, "action: /follow_tag_route", "action: /follow tag"), S_LF,
                                    "mission.action", ("not a valid ROS name", "alphanumerics")),
    "action with //": FileCase(LF, replaced(S_LF, "action: /follow_tag_route", "action: /follow//route"), S_LF,
                               "mission.action", ("not a valid ROS name", "repeated '/'")),
    "action starting with a digit": FileCase(LF, replaced(S_LF, "action: /follow_tag_route", "action: /9route"),
                                             S_LF, "mission.action", ("must not start with a number",)),
    "action nobody serves": FileCase(LF, replaced(S_LF, "action: /follow_tag_route", "action: /follow_tag_rout"),
                                     S_LF, "mission.action", ("serves /follow_tag_route",)),
    "no action": FileCase(LF, replaced(S_LF, "  action: /follow_tag_route\n", ""), S_LF, "mission.action",
                          ("missing",)),
    "action type typo": FileCase(LF, replaced(S_LF, "type: rfidnav_msgs/action/FollowTagRoute",
                                              "type: rfidnav_msgs/action/FollowTagRout"),
                                 S_LF, "mission.type", ("unknown interface type",)),
    "action type that is a message": FileCase(LF, replaced(S_LF, "type: rfidnav_msgs/action/FollowTagRoute",
                                                           "type: rfidnav_msgs/FollowTagRoute"),
                                              S_LF, "mission.type", ("pkg/action/Name",)),
    "action type of no package": FileCase(LF, replaced(S_LF, "type: rfidnav_msgs/action/FollowTagRoute",
                                                       "type: nope_msgs/action/Go"), S_LF, "mission.type",
                                          ("unknown interface type",)),
    "action type the server does not serve": FileCase(LF, replaced(S_LF, "type: rfidnav_msgs/action/FollowTagRoute",
                                                                   "type: rfidnav_msgs/action/NavigateToPoint"),
                                                      S_LF, "mission.type",
                                                      ("serves rfidnav_msgs/action/FollowTagRoute",)),
    "goal field typo": goal(LF, GOAL_LF, "goal: {tag_idz: [C1, C2]}", "tag_idz", "did you mean 'tag_ids'?"),
    "goal tags a string": goal(LF, GOAL_LF, "goal: {tag_ids: C1}", "tag_ids", "non-empty list"),
    "goal tags numbers": goal(LF, GOAL_LF, "goal: {tag_ids: [1, 2]}", "tag_ids", "non-empty list"),
    "goal without tags": goal(LF, GOAL_LF, "goal: {tag_ids: []}", "tag_ids", "non-empty list"),
    "goal tag not in the map": goal(LF, GOAL_LF, "goal: {tag_ids: [C1, C9]}", "C9"),
    "goal tag twice in a row": goal(LF, GOAL_LF, "goal: {tag_ids: [C1, C1, C2]}", "C1 twice in a row"),
    "goal a number": goal(LF, GOAL_LF, "goal: 5", "mapping"),
    "empty goal": goal(LF, GOAL_LF, "goal: {}", "tag_ids: missing"),
    "no goal": FileCase(LF, replaced(S_LF, f"  {GOAL_LF}\n", ""), S_LF, "mission.goal", ("missing",)),
    "goal target NaN": goal(PF, GOAL_PF, "goal: {target: {x: .nan, y: 3.8, z: 0.0}, tolerance_m: 0.0}",
                            "target.x", "finite"),
    "goal target 1e300": goal(PF, GOAL_PF, "goal: {target: {x: 1.0e+300, y: 3.8, z: 0.0}, tolerance_m: 0.0}",
                              "target.x", "within ±1e+06"),
    "goal target z Inf": goal(PF, GOAL_PF, "goal: {target: {x: 4.0, y: 3.8, z: .inf}, tolerance_m: 0.0}",
                              "target.z", "finite"),
    "goal target text": goal(PF, GOAL_PF, "goal: {target: {x: four, y: 3.8, z: 0.0}, tolerance_m: 0.0}",
                             "target", "numbers x and y"),
    "goal target z text": goal(PF, GOAL_PF, "goal: {target: {x: 4.0, y: 3.8, z: high}, tolerance_m: 0.0}",
                               "target.z", "cannot hold 'high'"),
    "goal target field typo": goal(PF, GOAL_PF, "goal: {target: {x: 4.0, y: 3.8, w: 0.0}, tolerance_m: 0.0}",
                                   "target.w", "no such field in Point"),
    "goal target a number": goal(PF, GOAL_PF, "goal: {target: 4.0, tolerance_m: 0.0}", "target", "cannot hold 4.0"),
    "goal without a target": goal(PF, GOAL_PF, "goal: {tolerance_m: 0.0}", "target: missing"),
    "goal tolerance negative": goal(PF, GOAL_PF, "goal: {target: {x: 4.0, y: 3.8, z: 0.0}, tolerance_m: -1.0}",
                                    "tolerance_m", "must not be negative"),
    "goal tolerance NaN": goal(PF, GOAL_PF, "goal: {target: {x: 4.0, y: 3.8, z: 0.0}, tolerance_m: .nan}",
                               "tolerance_m", "finite"),
    "goal outside the tagged area": goal(PF, GOAL_PF, "goal: {target: {x: 40.0, y: 3.8, z: 0.0}, tolerance_m: 0.0}",
                                         "outside the map's deployment_area"),
    "goal node not in the map": goal(BF, "goal: {goal_node: g}", "goal: {goal_node: z}", "'z' is not a node"),
    "goal node a list": goal(BF, "goal: {goal_node: g}", "goal: {goal_node: [g]}", "goal_node"),
    "goal tags on a topological map": goal(BF, "goal: {goal_node: g}", "goal: {tag_ids: ['19']}",
                                           "is not a route map"),
    "timeout 1e308": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout_s: 1.0e+308"), S_LF,
                              "mission.timeout_s", ("within ±1e+06",)),
    "timeout over a day": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout_s: 100000"), S_LF,
                                   "mission.timeout_s", ("at most 86400",)),
    "timeout zero": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout_s: 0"), S_LF, "mission.timeout_s",
                             ("positive",)),
    "timeout negative": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout_s: -5"), S_LF, "mission.timeout_s",
                                 ("positive",)),
    "timeout NaN": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout_s: .nan"), S_LF, "mission.timeout_s",
                            ("finite",)),
    "server no role": FileCase(LF, replaced(S_LF, "timeout_s: 120", "timeout_s: 120\n  server: nobody"), S_LF,
                               "mission.server", ("no role 'nobody'",)),
    "success bound missing": FileCase(LF, replaced(S_LF, "success_within_m: 0.10", "# none"), S_LF,
                                      "mission.success_within_m", ("missing", "how near its goal")),
    "success bound negative": FileCase(LF, replaced(S_LF, "success_within_m: 0.10", "success_within_m: -0.1"), S_LF,
                                       "mission.success_within_m", ("positive",)),
    "success bound NaN": FileCase(LF, replaced(S_LF, "success_within_m: 0.10", "success_within_m: .nan"), S_LF,
                                  "mission.success_within_m", ("finite",)),
    "unknown metric": FileCase(LF, replaced(S_LF, "metrics: [tracking]", "metrics: [speed]"), S_LF, "metrics[0]",
                               ("unknown metric group",)),
    "metrics a string": FileCase(LF, replaced(S_LF, "metrics: [tracking]", "metrics: tracking"), S_LF, "metrics",
                                 ("list",)),
    # ---- worlds
    "world without a name": FileCase(LF, replaced(W_LF, "name: line_follow\n", ""), W_LF, "name", ("missing",)),
    "duplicate tag id": FileCase(LF, replaced(W_LF, "{id: F2,", "{id: C1,"), W_LF, "tags[3].id", ("duplicate",)),
    "tag position 1e300": FileCase(LF, replaced(W_LF, "position: [0.0, 5.0, 3.0]", "position: [0.0, 1.0e+300, 3.0]"),
                                   W_LF, "tags[1].position[1]", ("within ±1e+06",)),
    "tag position NaN": FileCase(LF, replaced(W_LF, "position: [0.0, 5.0, 3.0]", "position: [0.0, .nan, 3.0]"),
                                 W_LF, "tags[1].position[1]", ("finite",)),
    "tag position of two numbers": FileCase(LF, replaced(W_LF, "position: [0.0, 5.0, 3.0]", "position: [0.0, 5.0]"),
                                            W_LF, "tags[1].position", ("expected 3 numbers",)),
    "tag kind unknown": FileCase(LF, replaced(W_LF, "[0.0, 0.0, 0.0], kind: floor}", "[0.0, 0.0, 0.0], kind: wall}"),
                                 W_LF, "tags[2].kind", ("not one of",)),
    "tag phase offset text": FileCase(LF, replaced(W_LF, "{id: C1, position: [0.0, 0.0, 3.0]}",
                                                   "{id: C1, position: [0.0, 0.0, 3.0], phase_offset_rad: half}"),
                                      W_LF, "tags[0].phase_offset_rad", ("number",)),
    "world without tags": FileCase(LF, written(W_LF, "name: line_follow\ntags: []\n"), W_LF, "tags",
                                   ("needs tags",)),
    "wall of three numbers": FileCase(TT, replaced(W_TT, "- [0.0, 0.0, 12.0, 0.0]", "- [0.0, 0.0, 12.0]"), W_TT,
                                      "walls[0]", ("[x1, y1, x2, y2]",)),
    "wall at 1e7 m": FileCase(TT, replaced(W_TT, "- [0.0, 0.0, 12.0, 0.0]", "- [0.0, 0.0, 1.0e+7, 0.0]"), W_TT,
                              "walls[0][2]", ("within ±1e+06",)),
    "walls a mapping": FileCase(TT, replaced(W_TT, "walls:\n", "walls: {}\nx_walls:\n"), W_TT, "x_walls",
                                ("unknown",)),
    "world extent upside down": FileCase(TT, replaced(W_TT, "walls:\n", "extent: [12.0, 0.0, 0.0, 8.0]\nwalls:\n"),
                                         W_TT, "extent", ("max > min", "[12, 0, 0, 8]")),
    "world extent of three numbers": FileCase(TT, replaced(W_TT, "walls:\n", "extent: [0.0, 0.0, 12.0]\nwalls:\n"),
                                              W_TT, "extent", ("expected 4 numbers",)),
    "lattice r = 1e-9": FileCase(PF, replaced(W_PF, "read_range_m: 0.2", "read_range_m: 1.0e-9"), W_PF,
                                 "lattices[0].read_range_m", ("cannot hold",)),
    "lattice r = 20 m": FileCase(PF, replaced(W_PF, "read_range_m: 0.2", "read_range_m: 20.0"), W_PF,
                                 "lattices[0].read_range_m", ("cannot hold",)),
    "lattice r zero": FileCase(PF, replaced(W_PF, "read_range_m: 0.2", "read_range_m: 0.0"), W_PF,
                               "lattices[0].read_range_m", ("positive",)),
    "lattice layout unknown": FileCase(PF, replaced(W_PF, "layout: triangular", "layout: hexagonal"), W_PF,
                                       "lattices[0].layout", ("not one of",)),
    "grid lattice for the partition navigator": FileCase(PF, replaced(W_PF, "layout: triangular", "layout: grid"),
                                                         W_PF, "lattices[0].layout", ("needs a triangular lattice",
                                                                                      "'grid'")),
    "lattice area inverted": FileCase(PF, replaced(W_PF, "area: [0.0, 0.0, 5.0, 5.0]", "area: [5.0, 0.0, 0.0, 5.0]"),
                                      W_PF, "lattices[0].area", ("x_max > x_min",)),
    "lattice area 1e300": FileCase(PF, replaced(W_PF, "area: [0.0, 0.0, 5.0, 5.0]", "area: [0.0, 0.0, 1.0e+300, 5.0]"),
                                   W_PF, "lattices[0].area[2]", ("within ±1e+06",)),
    "tag group of size 0": FileCase(TT, replaced(W_TT, "{id: T1, shape: cross, centre: [3.0, 1.5]}",
                                                 "{id: T1, shape: cross, centre: [3.0, 1.5], size_m: 0.0}"),
                                    W_TT, "tag_groups[0].size_m", ("positive",)),
    "tag group of a million tags": FileCase(TT, replaced(W_TT, "{id: T1, shape: cross, centre: [3.0, 1.5]}",
                                                         "{id: T1, shape: cross, centre: [3.0, 1.5], "
                                                         "tag_spacing_m: 1.0e-6}"),
                                            W_TT, "tag_groups[0].tag_spacing_m", ("more than 2,500",)),
    "tag group shape unknown": FileCase(TT, replaced(W_TT, "{id: T1, shape: cross,", "{id: T1, shape: star,"), W_TT,
                                        "tag_groups[0]", ("shape",)),
    "tag group twice": FileCase(TT, replaced(W_TT, "{id: T2, shape: cross, centre: [6.0, 3.6]}",
                                             "{id: T1, shape: cross, centre: [6.0, 3.6]}"),
                                W_TT, "tag_groups[1].id", ("duplicate tag group 'T1'",)),
    "tag group rotated 1000 degrees": FileCase(TT, replaced(W_TT, "{id: T1, shape: cross, centre: [3.0, 1.5]}",
                                                            "{id: T1, shape: cross, centre: [3.0, 1.5], "
                                                            "rotation_deg: 1000}"),
                                               W_TT, "tag_groups[0].rotation_deg", ("at most 360",)),
    "access point bssid malformed": FileCase(TT, replaced(W_TT, '"02:00:00:00:00:01"', '"02:00:00:00:01"'), W_TT,
                                             "access_points[0]", ("bssid",)),
    "access point twice": FileCase(TT, replaced(W_TT, '"02:00:00:00:00:02"', '"02:00:00:00:00:01"'), W_TT,
                                   "access_points[1].bssid", ("duplicate bssid",)),
    "access point channel 15": FileCase(TT, replaced(W_TT, "channel: 11}", "channel: 15}"), W_TT,
                                        "access_points[2]", ("channel",)),
    "access point of 100 kW": FileCase(TT, replaced(W_TT, "tx_power_dbm: 17.0", "tx_power_dbm: 80000.0"), W_TT,
                                       "access_points[3].tx_power_dbm", ("at most 100",)),
    "wifi path loss negative": FileCase(TT, replaced(W_TT, "path_loss_exponent: 2.0", "path_loss_exponent: -2.0"),
                                        W_TT, "wifi.path_loss_exponent", ("positive",)),
    "wifi shadowing seed negative": FileCase(TT, replaced(W_TT, "shadowing_seed: 3", "shadowing_seed: -3"), W_TT,
                                             "wifi.shadowing_seed", ("at least 0",)),
    "wall tag normal zero": FileCase(BF, replaced(W_BF, '{id: "8", position: [8.8, 9.8], normal: [-1.0, 0.0]}',
                                                  '{id: "8", position: [8.8, 9.8], normal: [0.0, 0.0]}'),
                                     W_BF, "wall_tags[0].normal", ("must not be zero",)),
    "wall tag twice": FileCase(BF, replaced(W_BF, '{id: "9", position: [9.8, 7.2]', '{id: "8", position: [9.8, 7.2]'),
                               W_BF, "wall_tags[1].id", ("duplicate tag id '8'",)),
    "wall tag position NaN": FileCase(BF, replaced(W_BF, '{id: "8", position: [8.8, 9.8]', '{id: "8", position: '
                                                                                           '[.nan, 9.8]'),
                                      W_BF, "wall_tags[0].position[0]", ("finite",)),
    # ---- route maps
    "arrival tag missing from the world": FileCase(LF, replaced(M_LF, "{C1: F1, C2: F2}", "{C1: F1, C2: F9}"), M_LF,
                                                   "arrival_tags.C2", ("'F9'", "not in the world")),
    "ceiling tag missing from the world": FileCase(LF, replaced(M_LF, "{C1: F1, C2: F2}", "{C1: F1, C2: F2, C3: F3}"),
                                                   M_LF, "arrival_tags.C3", ("'C3'", "not in the world")),
    "arrival tag used twice": FileCase(LF, replaced(M_LF, "{C1: F1, C2: F2}", "{C1: F1, C2: F1}"), M_LF,
                                       "arrival_tags.C2", ("already the arrival tag",)),
    "no arrival tags": FileCase(LF, replaced(M_LF, "{C1: F1, C2: F2}", "{}"), M_LF, "arrival_tags", ()),
    "arrival tag a number": FileCase(LF, replaced(M_LF, "{C1: F1, C2: F2}", "{C1: F1, C2: 2}"), M_LF,
                                     "arrival_tags.C2", ("non-empty string",)),
    "deployment area inverted": FileCase(PF, replaced(M_PF, "[0.0, 0.0, 5.0, 5.0]", "[0.0, 5.0, 5.0, 0.0]"), M_PF,
                                         "deployment_area", ("max > min",)),
    "deployment area of three numbers": FileCase(PF, replaced(M_PF, "[0.0, 0.0, 5.0, 5.0]", "[0.0, 0.0, 5.0]"),
                                                 M_PF, "deployment_area", ("expected 4 numbers",)),
    "deployment area NaN": FileCase(PF, replaced(M_PF, "[0.0, 0.0, 5.0, 5.0]", "[0.0, 0.0, .nan, 5.0]"), M_PF,
                                    "deployment_area[2]", ("finite",)),
    "two-tier goal 4 m outside the home": goal(TT, GOAL_TT,
                                               "goal: {target: {x: 16.0, y: 4.0, z: 0.0}, tolerance_m: 0.0}",
                                               "target (16.0, 4.0) is outside the map's extent [0.0, 0.0, 12.0, 8.0]"),
    "map walls a mapping": FileCase(TT, replaced(M_TT, "walls:\n", "walls: {}\nx_walls:\n"), M_TT, "x_walls",
                                    ("unknown",)),
    "map wall of three numbers": FileCase(TT, replaced(M_TT, "- [0.0, 0.0, 12.0, 0.0]", "- [0.0, 0.0, 12.0]"), M_TT,
                                          "walls[0]", ("expected [x1, y1, x2, y2]",)),
    "map wall NaN": FileCase(TT, replaced(M_TT, "- [0.0, 0.0, 12.0, 0.0]", "- [0.0, .nan, 12.0, 0.0]"), M_TT,
                             "walls[0][1]", ()),
    "map extent inverted": FileCase(TT, replaced(M_TT, "extent: [0.0, 0.0, 12.0, 8.0]",
                                                 "extent: [12.0, 0.0, 0.0, 8.0]"), M_TT, "extent", ("max > min",)),
    "radio map missing": FileCase(TT, lambda root: (root / RADIO).unlink(), M_TT, "radio_map", ("no such file",)),
    "map tag group missing from the world": FileCase(TT, replaced(M_TT, "{id: M4, shape: cross",
                                                                  "{id: M5, shape: cross"),
                                                     M_TT, "tag_groups[11].id", ("'M5'", "not in the world")),
    # ---- topological maps
    "unknown compass side": FileCase(BF, replaced(M_BF, "    W: {node: a, tags: [7]}\n  a:",
                                                  "    NW: {node: a, tags: [7]}\n  a:"),
                                     M_BF, "nodes.c.NW", ("unknown direction",)),
    "hallway to no node": FileCase(BF, replaced(M_BF, "N: {node: d, tags: [8]}", "N: {node: dd, tags: [8]}"), M_BF,
                                   "nodes.c.N.node", ("'dd'",)),
    "map tag missing from the world": FileCase(BF, replaced(M_BF, "N: {node: d, tags: [8]}",
                                                            "N: {node: d, tags: [8, 88]}"),
                                               M_BF, "nodes.c.N.tags", ("wall tag '88'", "not in the world")),
    "hallway length negative": FileCase(BF, replaced(M_BF, "N: {node: d, tags: [8]}",
                                                     "N: {node: d, tags: [8], length_m: -8.0}"),
                                        M_BF, "nodes.c.N.length_m", ("positive",)),
    "north 1000 degrees": FileCase(BF, replaced(M_BF, "north_deg: 90", "north_deg: 1000"), M_BF, "north_deg",
                                   ("at most 360",)),
    "tag on two sides": FileCase(BF, replaced(M_BF, "E: {node: h, tags: [9]}", "E: {node: h, tags: [8]}"), M_BF,
                                 "nodes.c.E.tags[0]", ("'8'",)),
    # ---- radio maps
    "radio reading NaN": FileCase(TT, replaced(RADIO, "'02:00:00:00:00:02': -39.79,", "'02:00:00:00:00:02': .nan,"),
                                  RADIO, "fingerprints[0].rss.02:00:00:00:00:02", ("finite",)),
    "radio reading of 1e9 dBm": FileCase(TT, replaced(RADIO, "'02:00:00:00:00:02': -39.79,",
                                                      "'02:00:00:00:00:02': 1.0e+9,"),
                                         RADIO, "fingerprints[0].rss.02:00:00:00:00:02", ("within ±1e+06",)),
    "radio reading of +500 dBm": FileCase(TT, replaced(RADIO, "'02:00:00:00:00:02': -39.79,",
                                                       "'02:00:00:00:00:02': 500.0,"),
                                          RADIO, "fingerprints[0].rss.02:00:00:00:00:02", ("at most 100",)),
    "fingerprint position of one number": FileCase(TT, replaced(RADIO, "- position: [0.5, 0.5]\n",
                                                                "- position: [0.5]\n"),
                                                   RADIO, "fingerprints[0].position", ("expected 2 numbers",)),
    # ---- parameter files (the simulated reader, paper 001's controller, the base)
    "parameter file without its node": FileCase(LF, replaced(READER, "rfid_reader_sim:\n", "reader_sim:\n"), READER,
                                                "rfid_reader_sim", ("no parameters",)),
    "ros__parameters a list": FileCase(LF, written(ROBOT, "robot_sim:\n  ros__parameters: [1, 2]\n"), ROBOT,
                                       "robot_sim.ros__parameters", ("mapping",)),
    "empty parameter file": FileCase(LF, written(ROBOT, "\n"), ROBOT, "", ("empty",)),
    "parameter a mapping": p(ROBOT, "step_s", "{value: 0.01}", "number"),
    "empty frame id": p(READER, "frame_id", "''", "non-empty string"),
    "antenna range zero": p(READER, "antenna_max_range_m", "[12.0, 0.0, 0.10]", "positive", item=1),
    "antenna range negative": p(READER, "antenna_max_range_m", "[12.0, 12.0, -0.10]", "positive", item=2),
    "antenna range of 1 km": p(READER, "antenna_max_range_m", "[1000.0, 12.0, 0.10]", "at most 100", item=0),
    "antenna range beyond the link budget": p(READER, "antenna_max_range_m", "[12.0, 20.0, 0.10]",
                                              "more than the link budget reaches", item=1),
    "antenna half angle negative": p(READER, "antenna_half_angle_deg", "[-85.0, 85.0, 60.0]", "positive", item=0),
    "antenna half angle 200": p(READER, "antenna_half_angle_deg", "[85.0, 200.0, 60.0]", "at most 180", item=1),
    "antenna facing one short": p(READER, "antenna_facing", "[up, up]", "describes 2 antennas",
                                  "antenna_positions"),
    "antenna positions of 8 numbers": p(READER, "antenna_positions", "[0.0, 0.03, 0.30, 0.0, -0.03, 0.30, 0.0, 0.0]",
                                        "3 numbers"),
    "antenna positions one antenna short": p(READER, "antenna_positions", "[0.0, 0.03, 0.30, 0.0, -0.03, 0.30]",
                                             "describes 2 antennas"),
    "antenna facing sideways": p(READER, "antenna_facing", "[up, up, sideways]", "'sideways' is not one of", item=2),
    "antenna position 1e300": p(READER, "antenna_positions", "[0.0, 0.03, 1.0e+300, 0.0, -0.03, 0.30, 0.0, 0.0, 0.05]",
                                "within ±1e+06", item=2),
    "antenna phase offset 10 rad": p(READER, "antenna_phase_offset_rad", "[10.0, 0.0, 0.0]", "in [-6.28319, 6.28319]",
                                     item=0),
    "no channels": p(READER, "channels_mhz", "[]", "at least one frequency"),
    "channel negative": p(READER, "channels_mhz", "[-915.25]", "positive", item=0),
    "miss probability 1": p(READER, "miss_probability", "1.0", "[0, 1)"),
    "reader rate zero": p(READER, "rate_hz", "0.0", "positive"),
    "reader rate 100 kHz": p(READER, "rate_hz", "100000.0", "at most 1000"),
    "hop dwell zero": p(READER, "hop_dwell_s", "0.0", "positive"),
    "phase noise negative": p(READER, "phase_noise_rad_per_m", "-0.02", "at least 0"),
    "sensitivity 500 dBm": p(READER, "sensitivity_dbm", "500.0", "in [-200, 100]"),
    "left antenna -1": p(FLC, "left_antenna", "-1", "in [1, 65535]"),
    "left antenna 0": p(FLC, "left_antenna", "0", "in [1, 65535]"),
    "left antenna 70000": p(FLC, "left_antenna", "70000", "in [1, 65535]"),
    "left antenna beyond int64": p(FLC, "left_antenna", INT64_OVER, "at most 9223372036854775807"),
    "left antenna 2.5": p(FLC, "left_antenna", "2.5", "integer"),
    "floor antenna the reader lacks": FileCase(LF, parameter(FLC, "floor_antenna", "4"), READER,
                                               key_of(READER, "antenna_facing"), ("missing port 4", "floor_antenna")),
    "left and right antenna the same": FileCase(LF, parameter(FLC, "right_antenna", "1"), FLC,
                                                "heading_controller.ros__parameters",
                                                ("left_antenna and right_antenna must differ",)),
    "forward speed 1e308": p(FLC, "forward_speed_mps", "1.0e+308", "within ±1e+06"),
    "forward speed 10 m/s": p(FLC, "forward_speed_mps", "10.0", "at most 5"),
    "forward speed above the base's": p(FLC, "forward_speed_mps", "0.6", "faster than the base drives",
                                        "max_wheel_speed_mps is 0.5"),
    "forward speed zero": p(FLC, "forward_speed_mps", "0.0", "positive"),
    "base slower than the controller": FileCase(LF, parameter(ROBOT, "max_wheel_speed_mps", "0.1"), FLC,
                                                key_of(FLC, "forward_speed_mps"), ("faster than the base drives",)),
    "unheard timeout over a day": p(FLC, "unheard_timeout_s", "100000.0", "at most 86400"),
    "unheard timeout zero": p(FLC, "unheard_timeout_s", "0.0", "positive"),
    "search radius below its spacing": p(FLC, "search_radius_m", "1.0", "less than search_spacing_m"),
    "arrival mode unknown": p(FLC, "arrival", "last_read", "'last_read' is not one of"),
    "filter rounds zero": p(FLC, "filter_rounds", "0", "at least 1"),
    "fuzzy resolution 2": p(FLC, "resolution", "2", "in [3, 1000000]"),
    "phase offset 4 rad": p(FLC, "phase_difference_offset_rad", "4.0", "in [-3.14159, 3.14159]"),
    "yaw rate 100 rad/s": p(FLC, "max_yaw_rate_radps", "100.0", "at most 10"),
    "range rate smoothing 0": p(FLC, "range_rate_smoothing", "0.0", "positive"),
    "turn speed fraction 2": p(FLC, "turn_speed_fraction", "2.0", "in [0, 1]"),
    "fuzzy sets without their points": FileCase(LF, parameter(FLC, "input_set_names", "[neg, zero, pos, big]"), FLC,
                                                key_of(FLC, "input_set_points"), ("4 sets in input_set_names",)),
    "rule of an unknown set": FileCase(LF, parameter(FLC, "rules", "[neg->ccw, zero->zero, big->cw]"), FLC,
                                       "heading_controller.ros__parameters", ("big",)),
    "physics step zero": p(ROBOT, "step_s", "0.0", "positive"),
    "physics step 5 s": p(ROBOT, "step_s", "5.0", "at most 1"),
    "slip negative": p(ROBOT, "odom_slip_std", "-0.1", "in [0, 1]"),
    "wheel scale error 150 %": p(ROBOT, "odom_left_scale_error", "1.5", "in (-1, 1)"),
    "command timeout 1e308": p(ROBOT, "command_timeout_s", "1.0e+308", "within ±1e+06"),
    "footprint zero": p(ROBOT, "footprint_radius_m", "0.0", "positive"),
    "wheel speed 1e308": p(ROBOT, "max_wheel_speed_mps", "1.0e+308", "within ±1e+06"),
    "wheel speed 50 m/s": p(ROBOT, "max_wheel_speed_mps", "50.0", "at most 5"),
    "odometry rate 1 MHz": p(ROBOT, "odom_rate_hz", "1.0e+6", "at most 1000"),
    # ---- paper 003's nodes
    "HF reader round failure 1": p(HF, "round_failure_probability", "1.0", "[0, 1)", scenario=TT),
    "HF reader jitter negative": p(HF, "round_jitter_s", "-0.1", "in [0, 86400]", scenario=TT),
    "navigator floor antenna the reader lacks": FileCase(TT, parameter(TWO_TIER, "floor_antenna", "2"), HF,
                                                         key_of(HF, "antenna_facing"), ("missing port 2",)),
    "search speed above the base's": p(TWO_TIER, "search_speed_mps", "0.9", "faster than the base drives",
                                       scenario=TT),
    "no searches": p(TWO_TIER, "max_searches", "0", "at least 1", scenario=TT),
    "service timeout 1e6": p(TWO_TIER, "service_timeout_s", "1.0e+6", "at most 86400", scenario=TT),
    "read range zero": p(TWO_TIER, "read_range_m", "0.0", "positive", scenario=TT),
    "control rate 1e5": p(TWO_TIER, "control_rate_hz", "1.0e+5", "at most 1000", scenario=TT),
    "matcher k 0": p(SERVER, "k", "0", "in [1, 10000]", scenario=TT),
    "database the root folder": p(SERVER, "database_file", "/", "names a folder, not a file", scenario=TT),
    "database a folder name": p(SERVER, "database_file", "db/", "names a folder, not a file", scenario=TT),
    "database the run folder": p(SERVER, "database_file", ".", "names a folder, not a file", scenario=TT),
    "matcher weighting unknown": p(SERVER, "weighting", "cosine", "'cosine' is not one of", scenario=TT),
    "missing RSS 1e6 dBm": p(SERVER, "missing_rss_dbm", "1.0e+6", "in [-200, 100]", scenario=TT),
    "scan period zero": p(WIFI, "scan_period_s", "0.0", "positive", scenario=TT),
    "scan noise negative": p(WIFI, "scan_noise_sd_db", "-4.0", "in [0, 100]", scenario=TT),
    "compass noise negative": p(COMPASS, "noise_sd_deg", "-1.0", "in [0, 180]", scenario=TT),
    "compass bias 400 degrees": p(COMPASS, "bias_deg", "400.0", "in [-180, 180]", scenario=TT),
    "compass rate zero": p(COMPASS, "rate_hz", "0.0", "positive", scenario=TT),
    # ---- paper 004's nodes
    "wall follower speed above the base's": p(WALL, "speed_mps", "0.9", "faster than the base drives", scenario=BF),
    "wall follower two sonar offsets": FileCase(BF, parameter(WALL, "sonar_offsets_m", "[0.175, 0.1945]"), WALL,
                                                "wall_follower.ros__parameters", ("sonar_topics and sonar_offsets_m",)),
    "wall follower sonar cone 1 rad": p(WALL, "sonar_half_angle_rad", "1.0", "in [0, 0.785398)", scenario=BF),
    "wall follower recovery negative": p(WALL, "recover_after_s", "-2.0", "in [0, 86400]", scenario=BF),
    "opening inside the wall distance": FileCase(BF, parameter(WALL, "opening_threshold_m", "0.5"), WALL,
                                                 "wall_follower.ros__parameters", ("must exceed",)),
    "sonar specular angle zero": p(SONAR, "specular_angle_deg", "0.0", "positive", scenario=BF),
    "sonar with no rays": p(SONAR, "rays_per_beam", "0", "in [1, 1000]", scenario=BF),
    "sonar noise negative": p(SONAR, "noise_sd_m", "-0.01", "at least 0", scenario=BF),
    "route weight unknown": p(EXECUTOR, "weight", "shortest", "'shortest' is not one of", scenario=BF),
    "side reader passage miss 1.5": p(SIDE, "passage_miss_probability", "1.5", "in [0, 1]", scenario=BF),
    "side reader area width zero": p(SIDE, "side_area_width_m", "0.0", "positive", scenario=BF),
    # ---- paper 000's nodes
    "three particles": p(LOCALIZER, "particles", "3", "in [10, 1000000]", scenario=PF),
    "read error probability 0.6": p(LOCALIZER, "read_error_probability", "0.6", "positive and below 0.5",
                                    scenario=PF),
    "localizer method unknown": p(LOCALIZER, "method", "magic", "'magic' is not one of", scenario=PF),
    "localizer antenna the reader lacks": FileCase(PF, parameter(LOCALIZER, "antenna", "3"), LATTICE,
                                                   key_of(LATTICE, "antenna_facing"), ("missing port 3",)),
    "localizer turn threshold zero": p(LOCALIZER, "turn_threshold_rad", "0.0", "positive", scenario=PF),
    "approximation level 0": p(NAVIGATOR, "approximation_level", "0", "in [1, 64]", scenario=PF),
    "deviation check unknown": p(NAVIGATOR, "deviation_check", "never", "'never' is not one of", scenario=PF),
    "path factor 1": p(NAVIGATOR, "max_path_factor", "1.0", "in (1, 1000]", scenario=PF),
    "turn tolerance zero": p(NAVIGATOR, "turn_tolerance_rad", "0.0", "positive", scenario=PF),
    "floor reader range 1 km": p(LATTICE, "antenna_max_range_m", "[1000.0, 0.10]", "at most 100", scenario=PF,
                                 item=0),
    # ---- robot profiles and the drivers' parameter files
    "no such profile": FileCase(LF, lambda root: None, "--robot", "", ("no robot profile", "nope"),
                                ("--robot", "nope")),
    "profile of no roles": FileCase(LF, written(PROFILE, "name: empty\nroles: {}\n"), PROFILE, "roles",
                                    ("at least one role",), WITH_PROFILE),
    "profile role not in the scenario": FileCase(LF, replaced(PROFILE, "  rfid_reader:", "  reader:"), PROFILE,
                                                 "roles.reader", ("no role 'reader'",), WITH_PROFILE),
    "profile that keeps a simulator": FileCase(LF, replaced(PROFILE, "  rfid_reader: {package: rfidnav_drivers, "
                                                                     "executable: llrp_reader, params: "
                                                                     "../params/llrp_reader.yaml}\n", ""),
                                               PROFILE, "roles", ("simulator roles rfid_reader",), WITH_PROFILE),
    "LLRP port 70000": p(LLRP, "port", "70000", "in [1, 65535]", argv=WITH_PROFILE),
    "LLRP antenna port 0": p(LLRP, "antennas", "[0, 1, 2]", "in [1, 65535]", argv=WITH_PROFILE, item=0),
    "LLRP session 5": p(LLRP, "session", "5", "in [0, 3]", argv=WITH_PROFILE),
    "LLRP search mode 9": p(LLRP, "search_mode", "9", "in [-1, 3]", argv=WITH_PROFILE),
    "LLRP transmit power 1 kW": p(LLRP, "tx_power_dbm", "1000.0", "in [-200, 100]", argv=WITH_PROFILE),
    "LLRP without the floor antenna": FileCase(LF, parameter(LLRP, "antennas", "[1, 2]"), LLRP,
                                               key_of(LLRP, "antennas"), ("missing port 3",), WITH_PROFILE),
    "LLRP reconnect bounds swapped": FileCase(LF, parameter(LLRP, "reconnect_max_s", "0.1"), LLRP,
                                              "llrp_reader.ros__parameters", ("reconnect_max_s must be at least",),
                                              WITH_PROFILE),
    "LLRP positions and facings disagree": FileCase(LF, parameter(LLRP, "antenna_facing", "[up, up]"), LLRP,
                                                    "llrp_reader.ros__parameters",
                                                    ("antenna_positions places 3 antennas, antenna_facing 2",),
                                                    WITH_PROFILE),
    "LLRP keepalive zero": p(LLRP, "keepalive_s", "0.0", "positive", argv=WITH_PROFILE),
    "Create faster than its Open Interface": p(BASE, "max_wheel_speed_mps", "0.6", "at most 0.5", argv=WITH_PROFILE),
    "Create baud 12345": p(BASE, "baud", "12345", "12345 is not one of", argv=WITH_PROFILE),
    "Create mode turbo": p(BASE, "mode", "turbo", "'turbo' is not one of", argv=WITH_PROFILE),
    "Create watchdog 1e308": p(BASE, "command_timeout_s", "1.0e+308", "within ±1e+06", argv=WITH_PROFILE),
    "Create slower than the controller": FileCase(LF, parameter(BASE, "max_wheel_speed_mps", "0.1"), FLC,
                                                  key_of(FLC, "forward_speed_mps"), ("faster than the base drives",
                                                                                     "create_base"), WITH_PROFILE),
    # ---- --goal, --params, --swap
    "--goal not YAML": FileCase(LF, lambda root: None, "--goal", "", ("not valid YAML",), ("--goal", "{tag_ids: [C1")),
    "--goal key twice": FileCase(LF, lambda root: None, "--goal", "", ("duplicate key 'tag_ids'",),
                                 ("--goal", "{tag_ids: [C1], tag_ids: [C2]}")),
    "--goal a list": FileCase(LF, lambda root: None, "--goal", "", ("mapping",), ("--goal", "[C1]")),
    "--goal that contains itself": FileCase(LF, lambda root: None, "--goal", "", ("alias *a inside the node",),
                                            ("--goal", "{tag_ids: &a [C1, *a]}")),
    "--goal field typo": FileCase(LF, lambda root: None, "--goal", "mission.goal", ("tag_idz", "did you mean"),
                                  ("--goal", "{tag_idz: [H1]}")),
    "--goal tag not in the map": FileCase(LF, lambda root: None, "--goal", "mission.goal", ("C9",),
                                          ("--goal", "{tag_ids: [C9]}")),
    "--goal target NaN": FileCase(PF, lambda root: None, "--goal", "mission.goal", ("target.y", "finite"),
                                  ("--goal", "{target: {x: 1.0, y: .nan, z: 0.0}}")),
    "--params file missing": FileCase(LF, lambda root: None, "--params", "heading_controller", ("not found",),
                                      ("--params", "heading_controller=ROOT/params/nope.yaml")),
    "--params no such role": FileCase(LF, lambda root: None, "--params", "controller", ("no role 'controller'",),
                                      ("--params", f"controller=ROOT/{FLC}")),
    "--params file not UTF-8": FileCase(LF, not_utf8(FLC), FLC, "", ("not UTF-8",),
                                        ("--params", f"heading_controller=ROOT/{FLC}")),
    "--params another node's file": FileCase(LF, lambda root: None, ROBOT, "heading_controller", ("no parameters",),
                                             ("--params", f"heading_controller=ROOT/{ROBOT}")),
    "--swap unknown package": FileCase(LF, lambda root: None, "--swap", "heading_controller.package",
                                       ("unknown package 'nope_pkg'",), ("--swap", "heading_controller=nope_pkg:x")),
    "--swap no such role": FileCase(LF, lambda root: None, "--swap", "controller", ("no role 'controller'",),
                                    ("--swap", "controller=rfidnav_bag:player")),
    "--swap not a program": FileCase(LF, lambda root: None, "--swap", "heading_controller", ("'nope_driver'",),
                                     ("--swap", "heading_controller=nope_driver --port 1")),
}

# ``./rfidnav VERB ...`` with one option bad: (the command line, the option the line names, words it holds).
# OUT stands for a folder that does not exist yet (nothing may create it), FILE for a file that does, MISSING for a
# file in a folder that does not exist.
OPTION_CASES: dict[str, tuple[tuple[str, ...], str, tuple[str, ...]]] = {
    "run --out a file": (("run", LF, "--out", "FILE"), "--out", ("is a file, not a folder",)),
    "run --out under a file": (("run", LF, "--out", "FILE/runs"), "--out", ("is a file, not a folder",)),
    "run --out under /proc": (("run", LF, "--out", "/proc/rfidnav-runs"), "--out", ("cannot write in /proc",)),
    "run --out under /sys": (("run", LF, "--out", "/sys/rfidnav-runs"), "--out", ("cannot write in /sys",)),
    "run --seed -1": (("run", LF, "--seed", "-1"), "--seed", ("0-9223372036854775807",)),
    "run --seed beyond int64": (("run", LF, "--seed", INT64_OVER), "--seed", ("0-9223372036854775807",)),
    "run --seed text": (("run", LF, "--seed", "one"), "--seed", ("whole number",)),
    "run --rtf 0": (("run", LF, "--rtf", "0"), "--rtf", ("above 0",)),
    "run --rtf -1": (("run", LF, "--rtf", "-1"), "--rtf", ("above 0",)),
    "run --rtf nan": (("run", LF, "--rtf", "nan"), "--rtf", ("above 0",)),
    "run --rtf 1e308": (("run", LF, "--rtf", "1e308"), "--rtf", ("at most 1000",)),
    "run --rtf inf": (("run", LF, "--rtf", "inf"), "--rtf", ("at most 1000",)),
    "run --rtf=-inf": (("run", LF, "--rtf=-inf"), "--rtf", ("at most 1000",)),
    "bench rtf --rtfs 5,inf": (("bench", "rtf", "--rtfs", "5,inf"), "--rtfs", ("at most 1000",)),
    "run --rtf text": (("run", LF, "--rtf", "fast"), "--rtf", ("a number or 'max'",)),
    "run --domain 500": (("run", LF, "--domain", "500"), "--domain", ("0-101",)),
    "run --domain -1": (("run", LF, "--domain", "-1"), "--domain", ("0-101",)),
    "run --max-bag-size 100": (("run", LF, "--max-bag-size", "100"), "--max-bag-size", ("at least 1024",)),
    "run --max-bag-size text": (("run", LF, "--max-bag-size", "1MB"), "--max-bag-size", ("number of bytes",)),
    "run --max-bag-duration -5": (("run", LF, "--max-bag-duration", "-5"), "--max-bag-duration", ("seconds >= 0",)),
    "run --live 70000": (("run", LF, "--live", "70000"), "--live", ("1-65535",)),
    "run --clock fast": (("run", LF, "--clock", "fast"), "--clock", ("invalid choice",)),
    "run --discovery internet": (("run", LF, "--discovery", "internet"), "--discovery", ("invalid choice",)),
    "run --bogus": (("run", LF, "--bogus"), "--bogus", ("unrecognized",)),
    "demo --rtf 0": (("demo", "--rtf", "0"), "--rtf", ("above 0",)),
    "demo --out a file": (("demo", "--out", "FILE"), "--out", ("is a file",)),
    "report --out a file": (("report", "OUT", "--out", "FILE"), "--out", ("is a file",)),
    "replay --rate 0": (("replay", "FILE", "--rate", "0"), "--rate", ("above 0",)),
    "replay --rate nan": (("replay", "FILE", "--rate", "nan"), "--rate", ("above 0",)),
    "replay --rate 1e9": (("replay", "FILE", "--rate", "1e9"), "--rate", ("at most 1000",)),
    "replay --start -1": (("replay", "FILE", "--start", "-1"), "--start", ("from 0",)),
    "replay --start inf": (("replay", "FILE", "--start", "inf"), "--start", ("from 0",)),
    "echo a topic with a space": (("echo", "rfid reads"), "topic", ("not a valid ROS topic name",)),
    "echo a topic with //": (("echo", "/rfid//reads"), "topic", ("repeated '/'",)),
    "replay --topics with a space": (("replay", "FILE", "--topics", "/cmd vel"), "--topics",
                                     ("not a valid ROS topic name",)),
    "echo --count 0": (("echo", "/rfid/reads", "--count", "0"), "--count", ("1-1000000",)),
    "echo --count beyond": (("echo", "/rfid/reads", "--count", INT64_OVER), "--count", ("1-1000000",)),
    "echo --wait 0": (("echo", "/rfid/reads", "--wait", "0"), "--wait", ("above 0",)),
    "echo --timeout -1": (("echo", "/rfid/reads", "--timeout", "-1"), "--timeout", ("above 0",)),
    "echo --timeout nan": (("echo", "/rfid/reads", "--timeout", "nan"), "--timeout", ("above 0",)),
    "echo --timeout a year": (("echo", "/rfid/reads", "--timeout", "3e7"), "--timeout", ("at most 86400",)),
    "view --port 70000": (("view", "FILE", "--port", "70000"), "--port", ("0-65535",)),
    "view --rate 0": (("view", "FILE", "--rate", "0"), "--rate", ("above 0",)),
    "map draw --out in a missing folder": (("map", "draw", "ROOT/maps/building_fig5.yaml", "--out", "MISSING"), "--out",
                                           ("no folder",)),
    "map draw --out a folder": (("map", "draw", "ROOT/maps/building_fig5.yaml", "--out", "ROOT"), "--out",
                                ("is a folder",)),
    "reproduce two_tier --runs 0": (("reproduce", "two_tier", "--runs", "0"), "--runs", ("1-100000",)),
    "reproduce partitions --runs -5": (("reproduce", "partitions", "--runs", "-5"), "--runs", ("1-100000",)),
    "reproduce topological --runs 1e9": (("reproduce", "topological", "--runs", "1e9"), "--runs", ("whole number",)),
    "reproduce topological --runs a billion": (("reproduce", "topological", "--runs", "1000000000"), "--runs",
                                               ("1-100000",)),
    "reproduce flc --seeds 0": (("reproduce", "flc", "--seeds", "0"), "--seeds", ("1-100000",)),
    "reproduce --out a file": (("reproduce", "flc", "--out", "FILE"), "--out", ("is a file",)),
    "reproduce --out under /proc": (("reproduce", "two_tier", "--out", "/proc/rfidnav"), "--out",
                                    ("cannot write in /proc",)),
    "survey --grid 1e-6": (("survey", TT, "--grid", "1e-6", "--out", "ROOT/radio.yaml"), "--grid",
                           ("9.6e+13 points", "more than 100,000")),
    "survey --grid 0": (("survey", TT, "--grid", "0", "--out", "ROOT/radio.yaml"), "--grid", ("above 0",)),
    "survey --grid -1": (("survey", TT, "--grid", "-1", "--out", "ROOT/radio.yaml"), "--grid", ("above 0",)),
    "survey --grid nan": (("survey", TT, "--grid", "nan", "--out", "ROOT/radio.yaml"), "--grid", ("above 0",)),
    "survey --grid inf": (("survey", TT, "--grid", "inf", "--out", "ROOT/radio.yaml"), "--grid", ("above 0",)),
    "survey --grid wider than the floor": (("survey", TT, "--grid", "100", "--out", "ROOT/radio.yaml"), "--grid",
                                           ("no point",)),
    "survey --out in a missing folder": (("survey", TT, "--grid", "1.0", "--out", "MISSING"), "--out", ("no folder",)),
    "survey --out a folder": (("survey", TT, "--grid", "1.0", "--out", "ROOT"), "--out", ("is a folder",)),
    "survey --out under /proc": (("survey", TT, "--grid", "1.0", "--out", "/proc/radio.yaml"), "--out",
                                 ("cannot write in /proc",)),
    "survey --seed -1": (("survey", TT, "--grid", "1.0", "--out", "ROOT/radio.yaml", "--seed", "-1"), "--seed",
                         ("0-9223372036854775807",)),
    "survey of a topological map": (("survey", BF, "--robot", "--out", "FILE"), "maps/building_fig5.yaml",
                                    ("route map",)),
    "survey --robot without landmarks": (("survey", LF, "--robot", "--out", "FILE"), "maps/line_follow.yaml",
                                         ("tag_groups", "landmarks")),
    "survey of a world without access points": (("survey", "hallway", "--grid", "1.0", "--out", "ROOT/radio.yaml"),
                                                "worlds/hallway.yaml", ("access_points", "WiFi")),
    "calibrate flc --out in a missing folder": (("calibrate", "flc", "--out", "MISSING"), "--out", ("no folder",)),
    "calibrate phase-offset --duration 0": (("calibrate", "phase-offset", "--duration", "0"), "--duration",
                                            ("above 0",)),
    "calibrate phase-offset --wait -1": (("calibrate", "phase-offset", "--wait", "-1"), "--wait", ("above 0",)),
    "calibrate phase-offset --min-pairs 0": (("calibrate", "phase-offset", "--min-pairs", "0"), "--min-pairs",
                                             ("1-1000000",)),
    "calibrate phase-offset --params missing": (("calibrate", "phase-offset", "--params", "MISSING"), "--params",
                                                ("no such parameter file",)),
    "calibrate phase-offset --out under /proc": (("calibrate", "phase-offset", "--out", "/proc/flc.yaml"), "--out",
                                                 ("cannot write in /proc",)),
    "bench rtf --seeds 0": (("bench", "rtf", "--seeds", "0"), "--seeds", ("1-100000",)),
    "bench rtf --hogs -1": (("bench", "rtf", "--hogs", "-1"), "--hogs", ("0-64",)),
    "bench rtf --hogs 1000": (("bench", "rtf", "--hogs", "1000"), "--hogs", ("0-64",)),
    "bench rtf --tolerance 0": (("bench", "rtf", "--tolerance", "0"), "--tolerance", ("above 0",)),
    "bench rtf --rtfs 1,0": (("bench", "rtf", "--rtfs", "1,0"), "--rtfs", ("above 0",)),
    "bench rtf --rtfs 1,x": (("bench", "rtf", "--rtfs", "1,x"), "--rtfs", ("a number or 'max'",)),
    "bench rtf --out a file": (("bench", "rtf", "--out", "FILE"), "--out", ("is a file",)),
    "bench planner --plans 0": (("bench", "planner", "--plans", "0"), "--plans", ("1-100000",)),
    "bench partitions --runs 0": (("bench", "partitions", "--runs", "0"), "--runs", ("1-100000",)),
    "bench flc --evaluations 0": (("bench", "flc", "--evaluations", "0"), "--evaluations", ("1-100000",)),
    "reproduce --workers 0": (("reproduce", "partitions", "--workers", "0"), "--workers", ("1-256",)),
    "bench partitions --workers many": (("bench", "partitions", "--workers", "many"), "--workers",
                                        ("whole number",)),
    "reproduce --scheduler without a port": (("reproduce", "flc", "--scheduler", "tcp://head"), "--scheduler",
                                             ("tcp://10.0.0.5:8786",)),
    "calibrate flc --scheduler port 0": (("calibrate", "flc", "--scheduler", "head:0"), "--scheduler",
                                         ("tcp://10.0.0.5:8786",)),
    "reproduce --workers beside --scheduler": (("reproduce", "two_tier", "--workers", "2", "--scheduler",
                                                "tcp://head:8786"), "--scheduler", ("not allowed with",)),
    "unknown verb": (("fly",), "fly", ("invalid choice",)),
}

# What would start a run, a node process or an experiment: each replaced by a tripwire.
TRIPWIRES = ("rfidnav_bringup.orchestrator.Orchestrator", "subprocess.Popen", "rclpy.init",
             "rfidnav_experiments.runners.two_tier.survey", "rfidnav_experiments.calibrate.flc.calibrate_flc",
             "rfidnav_experiments.calibrate.phase_offset.calibrate_phase_offset",
             "rfidnav_experiments.reproduce.two_tier.reproduce_two_tier",
             "rfidnav_experiments.reproduce.partitions.reproduce_partitions",
             "rfidnav_experiments.reproduce.topological.reproduce_topological",
             "rfidnav_experiments.reproduce.flc.reproduce_flc", "rfidnav_experiments.bench.rtf.sweep",
             "rfidnav_bringup.report.draw_map", "rfidnav_bag.bag_view.serve_bag", "rfidnav_bringup.echo.echo",
             "rfidnav_experiments.engine.engine_for")


@pytest.fixture
def nothing_starts(monkeypatch: pytest.MonkeyPatch) -> None:
    # Imported before any tripwire is set: a first import may start processes of its own (matplotlib's font cache
    # runs fc-list on a fresh machine), which are not the run's.
    for target in TRIPWIRES:
        importlib.import_module(target.rpartition(".")[0])
    for target in TRIPWIRES:
        def tripwire(*_args, _target=target, **_kwargs):
            raise AssertionError(f"{_target} was reached: the bad input was not refused before it")
        monkeypatch.setattr(target, tripwire)


def one_line_refusal(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """Run ``./rfidnav ARGV`` in this process; it must exit 2 with exactly one line on stderr and no traceback."""
    try:
        code = cli.main(argv)
    except SystemExit as exit_:     # argparse's refusal
        code = exit_.code
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, err
    assert "Traceback" not in err
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("name", sorted(FILE_CASES))
def test_a_broken_file_or_run_option_is_one_line_naming_file_and_field_and_starts_nothing(
        name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], nothing_starts: None) -> None:
    case = FILE_CASES[name]
    root = copy_config(tmp_path, FILES[case.scenario])
    case.break_it(root)
    out = tmp_path / "runs"
    argv = ["run", str(root / f"scenarios/{case.scenario}.yaml"), "--out", str(out),
            *(arg.replace("ROOT", str(root)) for arg in case.argv)]
    line = one_line_refusal(argv, capsys)
    where = case.file if case.file.startswith("--") else str((root / case.file).resolve())
    assert line.startswith(f"rfidnav run: {where}: "), line
    if case.field:
        assert f"{where}: {case.field}: " in line, line
    for word in case.words:
        assert word in line, line
    assert not out.exists()          # no run folder, nor the folder for them


@pytest.mark.parametrize("name", sorted(OPTION_CASES))
def test_a_bad_option_of_any_verb_is_one_line_naming_it_and_starts_nothing(
        name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], nothing_starts: None) -> None:
    argv, option, words = OPTION_CASES[name]
    root = copy_config(tmp_path, FILES[BF][1:3] + FILES[TT][2:4])
    existing = tmp_path / "existing.yaml"
    existing.write_text("fingerprints: []\n")
    out, missing = tmp_path / "out", tmp_path / "no_folder" / "file.yaml"
    names = {"OUT": str(out), "FILE": str(existing), "MISSING": str(missing), "ROOT": str(root)}
    line = one_line_refusal([re.sub(r"OUT|FILE|MISSING|ROOT", lambda m: names[m.group(0)], arg) for arg in argv],
                            capsys)
    assert line.startswith("rfidnav"), line
    assert option in line, line
    for word in words:
        assert word in line, line
    assert existing.read_text() == "fingerprints: []\n"      # nothing written over
    assert not out.exists() and not missing.parent.exists() and not (root / "radio.yaml").exists()


def test_the_table_covers_every_file_kind_and_well_over_a_hundred_and_eighty_inputs() -> None:
    kinds = {"scenarios", "worlds", "maps", "params", "robots"}
    named = {Path(case.file).parts[0] for case in FILE_CASES.values() if not case.file.startswith("--")}
    assert kinds <= named
    assert any(case.file == RADIO for case in FILE_CASES.values())
    assert any(case.file == M_BF for case in FILE_CASES.values())      # a topological map
    assert len(FILE_CASES) + len(OPTION_CASES) > 300


# ------------------------------------------------------------------------------- through the real command line

REAL_CLI = {
    "goal field typo": ("--goal", "{tag_idz: [H1]}"),
    "action type typo": (),
    "action with a space": (),
    "goal target NaN": (),
    "--out under /proc": ("--out", "/proc/rfidnav-runs"),
}


@pytest.mark.tier("graph")
@pytest.mark.parametrize("name", sorted(REAL_CLI))
def test_the_real_command_line_refuses_in_one_line_before_any_node_runs(name: str, tmp_path: Path) -> None:
    """As issue 17 measured it: these were refused only after 4-7 processes had started, or with a traceback."""
    case = FILE_CASES.get(name)
    scenario = case.scenario if case is not None else LF
    root = copy_config(tmp_path, FILES[scenario])
    if case is not None:
        case.break_it(root)
    out = tmp_path / "runs"
    options = REAL_CLI[name] if "--out" in REAL_CLI[name] else ("--out", str(out), *REAL_CLI[name])
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "run",
                             str(root / f"scenarios/{scenario}.yaml"), *options],
                            capture_output=True, text=True, timeout=60, cwd=WORKSPACE, env=dict(os.environ))
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    assert len(lines) == 1, result.stderr
    assert not out.exists()
