"""Scenario files (``config/scenarios/NAME.yaml``): schema, validation and resolution.

A scenario names a world (ground truth, simulator nodes only), a map (robot knowledge), the robot's
start, one OS process per role with its parameters, the mission and the metrics. Loading resolves
every path relative to the scenario file and every node's executable, and validates the world, the
map and every node's parameters against the node's parameter class, so a bad file fails here,
before any process starts.
See README.md, "Scenario files", for the schema.
"""

from __future__ import annotations

import math
import shlex
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from rfidnav_common.config import (
    MAX_DURATION_S,
    Section,
    check_number,
    node_parameter_section,
    parameters_from_mapping,
    type_name,
    typed_values,
)
from rfidnav_common.errors import ConfigError, UnknownExecutableError
from rfidnav_common.install import package_share, resolve_executable
from rfidnav_common.node_registry import (
    NODE_GROUP,
    CommandsSpeeds,
    LimitsSpeed,
    NodeRegistration,
    PublishesAntennaPorts,
    ReadsAntennaPorts,
    registered_node,
)
from rfidnav_common.robot_map import RouteMap, contains, load_route_map, repeated_in_a_row
from rfidnav_common.seeding import robot_seed
from rfidnav_common.topological_map import TopologicalMap, load_topological_map
from rfidnav_localization.radio_map_file import load_radio_map
from rfidnav_planning.partition_planner import lattice_refusal
from rfidnav_sim.parameters import ROBOT_NAME
from rfidnav_sim.rfid_model import reach_m
from rfidnav_sim.world import World, load_world

CONFIG_DIR = package_share("rfidnav_scenario") / "config"   # installed with the package, or linked by set-up
SCENARIO_DIR = CONFIG_DIR / "scenarios"
ROBOT_DIR = CONFIG_DIR / "robots"
SPLIT_PARTS = ("robot", "station")          # the computers of a split run (--part): rfidnav_bringup.run_plan

METRIC_GROUPS = ("tracking", "partition", "two_tier", "topological")
MAX_MISSION_S = MAX_DURATION_S          # mission.timeout_s: one day of sim time (the orchestrator's wall limit follows)
MAX_RESPAWNS = 100
MAX_GOAL_BOUND_M = 1000.0                   # mission.success_within_m: no floor is wider
SIMULATED_READER = ("rfidnav_sim", "rfid_reader_sim")   # reads the world's tags
PARTITION_NAVIGATOR = ("rfidnav_planning", "partition_navigator")   # plans on triangular lattices only
ORCHESTRATOR_NODE = "rfidnav_orchestrator"   # the node that sends the goal (relative action names are its)
# What a goal of each action type must give (the server refuses a goal without it, once everything runs).
REQUIRED_GOAL_FIELDS = {"rfidnav_msgs/action/FollowTagRoute": "tag_ids",
                        "rfidnav_msgs/action/NavigateToNode": "goal_node",
                        "rfidnav_msgs/action/NavigateToPoint": "target"}


@dataclass(frozen=True)
class NodeSpec:
    role: str
    package: str | None
    executable: str | None
    command: tuple[str, ...]                 # what starts the process: the package's executable resolved like
                                             # ``ros2 run``, or the given command line (then package is None)
    name: str | None                         # ROS node name, for the readiness check
    param_files: tuple[Path, ...]
    overrides: dict[str, Any]
    sim: bool                                # simulator: receives the world file
    clock_source: bool                       # publishes /clock; not given use_sim_time
    respawn: bool
    max_respawns: int
    process: str | None = None               # roles with the same name share one OS process (container.py)
    stepped: bool | None = None              # take part in the stepped clock; None: ours of the loop do
    map_file: Path | None = None             # this role's robot map (``map:``); None: the scenario's
    part: str | None = None                  # SPLIT_PARTS: the computer of a split run that starts it (a robot
                                             # profile's ``parts:``); None: rfidnav_bringup.run_plan.part_of's rule
    shared: bool = False                     # with robots: one node for all of them, in the root namespace
    robot: str | None = None                 # with robots: the robot whose node this is (Scenario.instances), its
                                             # namespace; None: the root namespace

    @property
    def node_path(self) -> str | None:
        """The node's name with its namespace, without the leading slash (``r1/wall_follower``); None unnamed."""
        if self.name is None:
            return None
        return f"{self.robot}/{self.name}" if self.robot else self.name

    @property
    def fqn(self) -> str | None:
        """The node's fully qualified name (``/r1/wall_follower``, ``/robot_sim``); None unnamed."""
        return None if self.node_path is None else f"/{self.node_path}"

    @property
    def registration(self) -> NodeRegistration | None:
        """What the node's package registers of it (rfidnav_common.node_registry); None for a command line or a
        node no package registers."""
        return registered_node(self.package, self.executable) if self.package and self.executable else None


@dataclass(frozen=True)
class MissionSpec:
    action: str
    action_type: str
    goal: dict[str, Any]
    timeout_s: float
    server: str | None = None                # role serving the action; None: the first non-simulator role
    # Success by ground truth: the robot stopped at most this far from where the mission ends (the last route
    # tag's ground projection, the target point, the goal node's position) [m]; required when metrics are asked
    # for (rfidnav_scenario.metrics.within_bound).
    success_within_m: float | None = None


@dataclass(frozen=True)
class RobotSpec:
    """One robot of a scenario with ``robots:``: its name (its ROS namespace and tf prefix), start, mission and, with
    a robot profile of its own, its roles as that profile has them."""
    name: str
    start: tuple[float, float, float]        # x [m], y [m], yaw [deg]
    mission: MissionSpec                     # its action as the scenario names it (robot_action resolves it)
    profile: Path | None = None              # its robot profile (``profile:``), over the scenario's roles
    nodes: dict[str, NodeSpec] | None = field(default=None, repr=False)   # its roles with it; None: the scenario's


def robot_action(robot: str | None, action: str) -> str:
    """A mission's action name as robot ``robot``'s server offers it: under its namespace (``/r1/navigate_to_node``)."""
    if robot is None:
        return action
    return f"/{robot}/{action.lstrip('/')}"


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    path: Path
    world_file: Path
    map_file: Path
    robot: tuple[float, float, float]        # x [m], y [m], yaw [deg]
    nodes: dict[str, NodeSpec]
    mission: MissionSpec
    metrics: tuple[str, ...]
    world: World = field(repr=False)
    route_map: RouteMap | None = field(repr=False)          # papers 000, 001, 003
    topological_map: TopologicalMap | None = field(default=None, repr=False)   # paper 004: a map with nodes
    warnings: tuple[str, ...] = ()           # what loading found doubtful but runnable, one line each
    # Several robots in one world (``robots:``): each runs the non-shared roles under its namespace, with its own
    # start and mission; ``robot`` and ``mission`` are then the first robot's. Empty: one robot, the root namespace.
    robots: tuple[RobotSpec, ...] = ()

    def instances(self) -> dict[str, NodeSpec]:
        """The nodes a run starts, by process-unique key: the roles as they are for one robot; with robots, the
        clock source and the shared roles once and every other role once per robot (``r1.wall_follower``, its
        node /r1/wall_follower)."""
        if not self.robots:
            return dict(self.nodes)
        instances: dict[str, NodeSpec] = {}
        for role, spec in self.nodes.items():
            if spec.clock_source or spec.shared:
                instances[role] = spec
                continue
            for robot in self.robots:
                key = f"{robot.name}.{role}"
                instances[key] = replace((robot.nodes or self.nodes)[role], role=key, robot=robot.name)
        return instances

    def missions(self) -> list[tuple[str | None, MissionSpec]]:
        """Each robot's name (None: the one robot of the root namespace) and mission, its action resolved."""
        if not self.robots:
            return [(None, self.mission)]
        return [(robot.name, replace(robot.mission, action=robot_action(robot.name, robot.mission.action)))
                for robot in self.robots]

    def mission_server(self, robot: str | None) -> str | None:
        """The instance (of :meth:`instances`) serving ``robot``'s mission: mission.server's, else the first
        non-simulator role's."""
        role = self.mission.server or next((role for role, spec in self.nodes.items() if not spec.sim), None)
        if role is None or robot is None or self.nodes[role].shared:
            return role
        return f"{robot}.{role}"

    def step_participants(self) -> list[NodeSpec]:
        """The roles a stepped clock waits for: the nodes registered as stepped (rfidnav_common.node_registry), not
        the clock source itself, not a driver, not a node given as a command line (a user's own node, which runs
        free beside them) unless its entry says ``stepped: true`` (it derives
        rfidnav_common.stepped_node.SteppedNode); ``stepped: false`` lets one of ours run free."""
        def takes_part(spec: NodeSpec) -> bool:
            if spec.stepped is not None:
                return spec.stepped
            return spec.registration is not None and spec.registration.stepped
        return [spec for spec in self.instances().values()
                if spec.name and not spec.clock_source and takes_part(spec)]

    @property
    def simulated(self) -> bool:
        """Whether the simulated base runs and owns the clock (sim time); else (drivers on a robot) real time."""
        return any(spec.clock_source for spec in self.nodes.values())

    def resolved_document(self) -> dict[str, Any]:
        """The scenario as run (absolute paths, swaps and parameter files applied), for the run folder."""
        return {
            "name": self.name, "description": self.description, "world": str(self.world_file),
            "map": str(self.map_file),
            "robot": {"x": self.robot[0], "y": self.robot[1], "yaw_deg": self.robot[2]},
            "nodes": {role: {key: value for key, value in {
                "package": spec.package, "executable": spec.executable,
                "command": " ".join(shlex.quote(c) for c in spec.command) if spec.package is None else None,
                "name": spec.name, "params": [str(p) for p in spec.param_files], "overrides": spec.overrides,
                "sim": spec.sim, "clock_source": spec.clock_source, "respawn": spec.respawn,
                "max_respawns": spec.max_respawns, "process": spec.process, "stepped": spec.stepped,
                "shared": spec.shared or None}.items()
                if value not in (None, {}, [])}
                for role, spec in self.nodes.items()},
            "mission": mission_document(self.mission),
            "metrics": list(self.metrics),
            **({"robots": [{"name": robot.name,
                            "robot": {"x": robot.start[0], "y": robot.start[1], "yaw_deg": robot.start[2]},
                            "mission": mission_document(robot.mission),
                            **({"profile": str(robot.profile)} if robot.profile else {})} for robot in self.robots]}
               if self.robots else {}),
        }


def mission_document(mission: MissionSpec) -> dict[str, Any]:
    """A mission as a scenario file gives it."""
    return {key: value for key, value in {
        "action": mission.action, "type": mission.action_type, "server": mission.server, "goal": mission.goal,
        "timeout_s": mission.timeout_s, "success_within_m": mission.success_within_m}.items() if value is not None}


def scenario_path(name_or_path: str) -> Path:
    """A scenario given by name (config/scenarios/NAME.yaml) or by path."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        return candidate
    return SCENARIO_DIR / f"{name_or_path}.yaml"


def profile_path(name_or_path: str) -> Path:
    """A robot profile given by name (config/robots/NAME.yaml) or by path."""
    candidate = Path(name_or_path)
    if candidate.suffix in (".yaml", ".yml") or candidate.exists():
        return candidate
    return ROBOT_DIR / f"{name_or_path}.yaml"


@dataclass(frozen=True)
class RobotProfile:
    """A robot profile (``config/robots/NAME.yaml``): the roles it runs differently (role -> its node entry, the
    scenario's node schema, paths relative to the profile) and the computer of a split run (``--part``) that
    starts a role where the default rule does not fit (role -> one of SPLIT_PARTS)."""

    path: Path
    roles: dict[str, Section]
    parts: dict[str, str]


def robot_profile(name_or_path: str) -> RobotProfile:
    """The robot profile ``name_or_path``, checked; a missing file is one error naming it."""
    path = profile_path(name_or_path).resolve()
    if not path.is_file():
        known = ", ".join(sorted(p.stem for p in ROBOT_DIR.glob("*.yaml")))
        raise ConfigError("--robot", "", f"no robot profile '{name_or_path}' ({path} does not exist; known: {known})")
    section = Section.from_file(path)
    section.reject_unknown(("name", "description", "roles", "parts"))
    roles = section.section("roles", {})
    parts = section.section("parts", {})
    if not roles.keys() and not parts.keys():
        raise section.error("roles", "a profile replaces at least one role or assigns one to a part (parts:)")
    for role in parts.keys():
        if parts.raw(role, None) not in SPLIT_PARTS:
            raise parts.error(role, f"expected the part of a split run that starts it: one of {', '.join(SPLIT_PARTS)}")
    return RobotProfile(path, {role: roles.section(role) for role in roles.keys()},
                        {role: parts.string(role) for role in parts.keys()})


def _with_profile(nodes: dict[str, NodeSpec], profile_name: str, scenario_file: Path) -> dict[str, NodeSpec]:
    """The scenario's roles with the profile's drivers in place and their parts assigned. Without the simulated
    base (the clock source) the run is in real time, and no simulator role may remain: nothing would publish its
    ground truth."""
    profile = robot_profile(profile_name)
    nodes = dict(nodes)
    for key, named in (("roles", profile.roles), ("parts", profile.parts)):
        for role in named:
            if role not in nodes:
                raise ConfigError(str(profile.path), f"{key}.{role}",
                                  f"no role '{role}' in {scenario_file.name} (roles: {', '.join(nodes)})")
    for role, entry in profile.roles.items():
        nodes[role] = _node_spec(role, entry, profile.path.parent)
    for role, part in profile.parts.items():
        nodes[role] = replace(nodes[role], part=part)
    if not any(spec.clock_source for spec in nodes.values()):
        left = [role for role, spec in nodes.items() if spec.sim]
        if left:
            raise ConfigError(str(profile.path), "roles",
                              f"replaces the simulated base but not the simulator roles {', '.join(left)} of "
                              f"{scenario_file.name}: they need its ground truth (add a driver for each)")
    return nodes


def load_scenario(name_or_path: str, swaps: dict[str, str] | None = None,
                  param_files: dict[str, Path] | None = None, goal: dict[str, Any] | None = None,
                  robot_profile_name: str | None = None, radio_map_may_be_missing: bool = False) -> Scenario:
    """Load, apply ``--robot``, ``--swap``, ``--params`` and ``--goal``, and validate everything the run will
    use (but a radio map not surveyed yet, with ``radio_map_may_be_missing``: ``./rfidnav survey`` writes it)."""
    path = scenario_path(name_or_path).resolve()
    section = Section.from_file(path)
    section.reject_unknown(("name", "description", "world", "map", "robot", "robots", "nodes", "mission", "metrics"))
    base = path.parent
    world_file = _referenced_file(section, "world", section.string("world"), base, "world")
    map_file = _referenced_file(section, "map", section.string("map"), base, "map")
    nodes = {role: _node_spec(role, section.section("nodes").section(role), base)
             for role in section.section("nodes").keys()}
    if not nodes:
        raise section.error("nodes", "at least one node is needed")
    if robot_profile_name is not None:
        nodes = _with_profile(nodes, robot_profile_name, path)
    for role, replacement in (swaps or {}).items():
        if role not in nodes:
            raise ConfigError("--swap", role, f"no role '{role}' in {path.name} (roles: {', '.join(nodes)})")
        nodes[role] = _swapped(nodes[role], replacement)
    for role, file in (param_files or {}).items():
        if role not in nodes:
            raise ConfigError("--params", role, f"no role '{role}' in {path.name} (roles: {', '.join(nodes)})")
        if not Path(file).is_file():
            raise ConfigError("--params", role, f"parameter file not found: {Path(file).resolve()}")
        nodes[role] = replace(nodes[role], param_files=(Path(file).resolve(),))
    if sum(spec.clock_source for spec in nodes.values()) > 1:
        raise section.error("nodes", "only one node can be the clock_source")
    for role, spec in nodes.items():
        if spec.process is not None and spec.process in nodes and nodes[spec.process].process != spec.process:
            raise section.error(f"nodes.{role}.process", f"'{spec.process}' is the name of another role's process")
    mission_file = section.section("mission")
    mission_file.reject_unknown(MISSION_KEYS)
    metrics = section.strings("metrics", [])
    for index, metric in enumerate(metrics):
        if metric not in METRIC_GROUPS:
            raise ConfigError(str(path), f"metrics[{index}]", f"unknown metric group '{metric}' "
                              f"(known: {', '.join(METRIC_GROUPS)})")
    if metrics and not mission_file.has("success_within_m"):
        raise mission_file.error("success_within_m", "missing: a scenario scored by ground truth (metrics: "
                                 f"{', '.join(metrics)}) states how near its goal the robot must stop to succeed [m]")
    if section.has("robots"):
        listed = _robots(section, mission_file, nodes, goal)
        robots = tuple(robot for robot, _ in listed)
        start, mission = robots[0].start, robots[0].mission
        missions = [(robot.start, robot.mission, own, own) for robot, own in listed]
    else:
        for role, spec in nodes.items():
            if spec.shared:
                raise section.error(f"nodes.{role}.shared", "a role shared by robots needs a scenario of several "
                                                            "robots (robots:)")
        robot = section.section("robot")
        robot.reject_unknown(("x", "y", "yaw_deg"))
        start = (robot.number("x"), robot.number("y"), robot.number("yaw_deg", 0.0, minimum=-360.0, maximum=360.0))
        mission_section = mission_file
        if goal is None:
            if not isinstance(mission_file.raw("goal"), dict):
                raise mission_file.error("goal", "expected a mapping of goal fields")
        else:
            mission_section = Section({**mission_file.data, "goal": goal}, "--goal", "mission")
        mission = _mission_spec(mission_section)
        robots = ()
        missions = [(start, mission, mission_file, mission_section)]
    scenario = Scenario(
        name=section.string("name"), description=section.string("description", ""), path=path,
        world_file=world_file, map_file=map_file, robot=start, nodes=nodes, mission=mission,
        metrics=tuple(metrics), world=load_world(world_file), robots=robots,
        **_robot_map(map_file, radio_map_may_be_missing))
    if scenario.mission.server is not None and scenario.mission.server not in nodes:
        raise mission_file.error("server", f"no role '{scenario.mission.server}' (roles: {', '.join(nodes)})")
    for start, mission, declared, goal_section in missions:
        _check_mission(replace(scenario, robot=start, mission=mission), declared, goal_section)
    _check_map_in_world(scenario)
    _check_partition_lattices(scenario)
    parameters = {role: node_parameters(scenario, spec, seed=0, rtf=1.0) for role, spec in scenario.nodes.items()}
    for member in scenario.robots:     # a robot's own profile's roles, checked as the scenario's are
        for role, spec in (member.nodes or {}).items():
            if spec != scenario.nodes[role]:
                node_parameters(scenario, spec, seed=0, rtf=1.0)
    _check_antenna_ports(scenario, parameters)
    _check_speeds(scenario, parameters)
    return replace(scenario, warnings=route_reach_warnings(scenario, parameters))


MISSION_KEYS = ("action", "type", "server", "goal", "timeout_s", "success_within_m")


def _mission_spec(mission: Section) -> MissionSpec:
    """A mission entry (the scenario's, or a robot's over it); its goal is checked by _check_mission."""
    goal = mission.raw("goal")
    if not isinstance(goal, dict):
        raise mission.error("goal", "expected a mapping of goal fields")
    return MissionSpec(mission.string("action"), mission.string("type"), goal,
                       mission.number("timeout_s", 600.0, positive=True, maximum=MAX_MISSION_S),
                       mission.raw("server", None),
                       mission.number("success_within_m", positive=True, maximum=MAX_GOAL_BOUND_M)
                       if mission.has("success_within_m") else None)


def _robots(section: Section, mission_file: Section, nodes: dict[str, NodeSpec],
            goal: dict[str, Any] | None) -> list[tuple[RobotSpec, Section]]:
    """The robots of a scenario with ``robots:`` (each a name, a start and a mission), each with its mission's
    entry: the scenario's mission with the robot's own fields over it, named at the robot's entry."""
    if goal is not None:
        raise ConfigError("--goal", "", f"{section.source} has several robots: each gives its goal in its entry "
                                        "(robots[i].mission.goal)")
    if section.has("robot"):
        raise section.error("robot", "with robots:, each robot gives its start in its entry (robots[i].robot)")
    if any(spec.sim and spec.shared for spec in nodes.values()):
        role = next(role for role, spec in nodes.items() if spec.sim and spec.shared)
        raise section.error(f"nodes.{role}.shared", "a simulator role simulates one robot's sensor: it runs per "
                                                     "robot (robot_sim, the clock source, simulates them all)")
    entries = section.sections("robots")
    if not entries:
        raise section.error("robots", "expected a list of robots (name, robot, mission)")
    robots: list[tuple[RobotSpec, Section]] = []
    for entry in entries:
        entry.reject_unknown(("name", "robot", "mission", "profile"))
        name = entry.string("name")
        if not ROBOT_NAME.fullmatch(name):
            raise entry.error("name", f"'{name}' is no robot name: its ROS namespace, a letter then letters, digits "
                                      "or _")
        if name in {robot.name for robot, _ in robots}:
            raise entry.error("name", f"robot '{name}' is listed twice")
        start = entry.section("robot")
        start.reject_unknown(("x", "y", "yaw_deg"))
        own = entry.section("mission")
        own.reject_unknown(MISSION_KEYS)
        mission = Section({**mission_file.data, **own.data}, own.source, own.prefix)
        profile, robot_nodes = _robot_profile(entry, nodes, Path(section.source)) if entry.has("profile") else \
            (None, None)
        robots.append((RobotSpec(name, (start.number("x"), start.number("y"),
                                        start.number("yaw_deg", 0.0, minimum=-360.0, maximum=360.0)),
                                 _mission_spec(mission), profile, robot_nodes), mission))
    return robots


def _robot_profile(entry: Section, nodes: dict[str, NodeSpec],
                   scenario_file: Path) -> tuple[Path, dict[str, NodeSpec]]:
    """A robot's own profile (``robots[i].profile``) over the scenario's roles: it may replace that robot's roles
    (a real reader on one robot of a simulated pair) and assign them to a part of a split run, but not the world's
    simulated base nor a role the robots share."""
    try:
        robot_nodes = _with_profile(nodes, entry.string("profile"), scenario_file)
    except ConfigError as error:     # named at the robot's entry; a problem inside the profile names its file too
        raise entry.error("profile", error.problem if error.source == "--robot" else str(error)) from None
    for role, spec in nodes.items():
        if (spec.clock_source or spec.shared) and robot_nodes[role] != spec:
            what = "simulates every robot of the world" if spec.clock_source else "is shared by the robots"
            raise entry.error("profile", f"replaces {role}, which {what}: a robot's profile changes its own roles "
                                         "only")
    return robot_profile(entry.string("profile")).path, robot_nodes


def _check_mission(scenario: Scenario, declared: Section, mission: Section) -> None:
    """Everything a mission (the scenario's, or one robot's in ``scenario`` as that robot sees it) must be:
    ``declared`` names its action and server, ``mission`` its goal (``--goal``'s, when given)."""
    goal_class = _check_action(scenario, declared)
    _check_server(scenario, declared)
    _check_goal_numbers(scenario.mission.goal, mission, "")
    _check_route(scenario, mission)
    _check_goal_area(scenario, mission)
    _check_goal_node(scenario, mission)
    _check_goal(scenario, goal_class, mission)


def _referenced_file(section: Section, key: str, relative: str, base: Path, what: str) -> Path:
    """The file a scenario field names (relative to the scenario's folder), refused at that field if it is none:
    ``world: .`` names a folder, and the line must say which field of which scenario did."""
    path = (base / relative).resolve()
    if not path.is_file():
        problem = "is a folder, not a file" if path.is_dir() else "not found"
        raise section.error(key, f"{what} file {problem}: {path}")
    return path


def _node_spec(role: str, entry: Section, base: Path) -> NodeSpec:
    entry.reject_unknown(("package", "executable", "command", "name", "params", "overrides", "sim",
                          "clock_source", "respawn", "max_respawns", "process", "stepped", "map", "shared"))
    if entry.has("command"):
        package = executable = None
        command = _program(tuple(shlex.split(entry.string("command"))), entry.source, entry.field("command"))
    elif entry.has("package") and entry.has("executable"):
        package, executable = entry.string("package"), entry.string("executable")
        command = _resolved(package, executable, entry.source, entry.prefix)
    else:
        raise entry.error("package", "give package and executable, or a command")
    params = entry.raw("params", [])
    params = [params] if isinstance(params, str) else params
    if not isinstance(params, list) or not all(isinstance(p, str) for p in params):
        raise entry.error("params", "expected a parameter file path or a list of them")
    files = tuple(_referenced_file(entry, "params", p, base, "parameter") for p in params)
    overrides = entry.raw("overrides", {})
    if not isinstance(overrides, dict):
        raise entry.error("overrides", "expected a mapping of parameter names to values")
    map_file = _referenced_file(entry, "map", entry.string("map"), base, "map") if entry.has("map") else None
    if map_file is not None:
        _robot_map(map_file)           # a bad map is the scenario's error, before any process starts
    process = entry.raw("process", None)
    if process is not None:
        if not isinstance(process, str) or not process.isidentifier():
            raise entry.error("process", "expected a name (letters, digits, _) shared by the roles of one process")
        if package is None or registered_node(package, executable) is None:
            raise entry.error("process", "only registered nodes (package and executable) can share a process")
        if entry.boolean("respawn", False):
            raise entry.error("process", "a role that respawns needs a process of its own")
    sim = entry.boolean("sim", False)
    if sim and not entry.has("stepped"):
        registration = registered_node(package, executable) if package is not None else None
        if registration is None or not registration.stepped:
            what = (f"{package}:{executable} is registered as not stepped" if registration is not None else
                    f"no {NODE_GROUP} entry point registers {package}:{executable}" if package is not None else
                    "a command line is not registered")
            raise entry.error("sim", f"a simulator must take part in the stepped clock, but {what}: it would run "
                                     "off the simulated clock and its runs would not repeat (register it as stepped, "
                                     "docs/extending.md, or say stepped: true or false)")
    return NodeSpec(
        role=role, package=package, executable=executable, command=command,
        name=entry.string("name", executable) if package is not None else entry.raw("name", None),
        param_files=files, overrides=dict(overrides), sim=sim,
        clock_source=entry.boolean("clock_source", False), respawn=entry.boolean("respawn", False),
        max_respawns=entry.integer("max_respawns", 3, minimum=0, maximum=MAX_RESPAWNS), process=process,
        stepped=entry.boolean("stepped", False) if entry.has("stepped") else None, map_file=map_file,
        shared=entry.boolean("shared", False))


def _swapped(spec: NodeSpec, replacement: str) -> NodeSpec:
    """``pkg:executable`` keeps the role's parameters; anything else is a raw command line."""
    if ":" in replacement and " " not in replacement:
        package, executable = replacement.split(":", 1)
        command = _resolved(package, executable, "--swap", spec.role)
        return replace(spec, package=package, executable=executable, command=command, name=executable,
                       process=None, stepped=None)
    command = _program(tuple(shlex.split(replacement)), "--swap", spec.role)
    return replace(spec, package=None, executable=None, command=command, name=None, param_files=(), overrides={},
                   process=None, stepped=None)


def _resolved(package: str, executable: str, source: str, prefix: str) -> tuple[str, ...]:
    """The command of a package's executable; an unknown one is an error naming ``prefix``.package/.executable."""
    try:
        return tuple(resolve_executable(package, executable))
    except UnknownExecutableError as error:
        raise ConfigError(source, f"{prefix}.{error.field}", str(error)) from None


def _program(command: tuple[str, ...], source: str, field: str) -> tuple[str, ...]:
    """A command line whose program exists (a path, or a name on PATH)."""
    if not command:
        raise ConfigError(source, field, "empty command")
    if shutil.which(command[0]) is None:
        raise ConfigError(source, field, f"no program '{command[0]}' (not an executable file, not on PATH)")
    return command


def _robot_map(map_file: Path, radio_map_may_be_missing: bool = False) -> dict[str, Any]:
    """The scenario's map: a topological map (paper 004) if it has ``nodes``, else a route map, with the radio map
    it names read (the location server starts from it). With ``radio_map_may_be_missing`` (``./rfidnav survey``
    writes that file) a radio map not written yet is left unread, its path kept."""
    if Section.from_file(map_file).has("nodes"):
        return {"route_map": None, "topological_map": load_topological_map(map_file)}
    route_map = load_route_map(map_file, radio_map_may_be_missing=radio_map_may_be_missing)
    if route_map.radio_map_file is not None and route_map.radio_map_file.exists():
        load_radio_map(route_map.radio_map_file)
    return {"route_map": route_map}


def _check_action(scenario: Scenario, mission: Section) -> type:
    """The action name is a valid ROS name and the type an installed action; its Goal class."""
    from rfidnav_common.ros import interface_class, topic_name_problem  # here, not at the top: they load rclpy

    problem = topic_name_problem(scenario.mission.action, ORCHESTRATOR_NODE)
    if problem is not None:
        raise mission.error("action", f"'{scenario.mission.action}' is not a valid ROS name: {problem}")
    action_type = scenario.mission.action_type
    if action_type.count("/") != 2 or action_type.split("/")[1] != "action":
        raise mission.error("type", f"expected an action type like pkg/action/Name, got '{action_type}'")
    try:
        action = interface_class(action_type)
    except ConfigError as error:
        raise mission.error("type", f"'{action_type}': {error.problem}") from None
    return action.Goal


def _expanded(name: str) -> str:
    """An action name as the orchestrator's node resolves it (``follow_tag_route`` is ``/follow_tag_route``)."""
    from rclpy.expand_topic_name import expand_topic_name

    return expand_topic_name(name, ORCHESTRATOR_NODE, "/")


def _check_goal(scenario: Scenario, goal_class: type, mission: Section) -> None:
    """The goal fills the action's Goal message as the orchestrator will send it (its fields, their types and
    ranges) and gives what its action needs."""
    from rfidnav_common.ros import fill_message

    goal = scenario.mission.goal
    try:
        fill_message(goal_class(check_fields=True), goal, "goal")
    except ConfigError as error:       # error.source: "goal", or "goal.target" for a field of a nested message
        where = ".".join((*error.source.split(".")[1:], error.field))
        raise mission.error("goal", f"{where}: {error.problem}") from None
    required = REQUIRED_GOAL_FIELDS.get(scenario.mission.action_type)
    if required is not None and required not in goal:
        raise mission.error("goal", f"{required}: missing ({scenario.mission.action_type} needs it)")
    tolerance = goal.get("tolerance_m", 0.0)
    if isinstance(tolerance, (int, float)) and tolerance < 0.0:
        raise mission.error("goal", f"tolerance_m: must not be negative, got {tolerance}")


def _check_goal_numbers(values: Any, mission: Section, where: str) -> None:
    """Every number of a goal (nested mappings and lists included) finite and within MAX_MAGNITUDE."""
    if isinstance(values, dict):
        for key, value in values.items():
            _check_goal_numbers(value, mission, f"{where}.{key}" if where else str(key))
    elif isinstance(values, list):
        for index, value in enumerate(values):
            _check_goal_numbers(value, mission, f"{where}[{index}]")
    elif isinstance(values, (int, float)) and not isinstance(values, bool):
        try:
            check_number(values, mission.source, where)
        except ConfigError as error:
            raise mission.error("goal", f"{error.field}: {error.problem}") from None


def _check_map_in_world(scenario: Scenario) -> None:
    """With the simulated reader (which reads the world's tags), every tag the map names is in the world: a route's
    ceiling and arrival floor tags, a tag group, a topological map's wall tags. One error names the map's field."""
    if SIMULATED_READER not in {(spec.package, spec.executable) for spec in scenario.nodes.values()}:
        return
    world, source, where = scenario.world, str(scenario.map_file), f"not in the world {scenario.world_file}"
    if scenario.route_map is not None:
        tags = {tag.tag_id for tag in world.tags}
        for ceiling, floor in scenario.route_map.arrival_tags.items():
            for tag in (ceiling, floor):
                if tag not in tags:
                    raise ConfigError(source, f"arrival_tags.{ceiling}", f"tag '{tag}' is {where}")
        groups = {group.group_id for group in world.tag_groups}
        for index, group in enumerate(scenario.route_map.tag_groups):
            if group.group_id not in groups:
                raise ConfigError(source, f"tag_groups[{index}].id", f"tag group '{group.group_id}' is {where}")
    if scenario.topological_map is not None:
        wall_tags = {tag.tag_id for tag in world.wall_tags}
        for name, node in scenario.topological_map.nodes.items():
            for side, hallway in node.hallways.items():
                missing = [tag for tag in hallway.tags if tag not in wall_tags]
                if missing:
                    raise ConfigError(source, f"nodes.{name}.{side}.tags", f"wall tag '{missing[0]}' is {where}")


def route_reach_warnings(scenario: Scenario, parameters: dict[str, Any]) -> tuple[str, ...]:
    """With the simulated reader, one warning per leg of the goal's route (``tag_ids``, positions from the world)
    whose next tag is farther away horizontally than the reader's receiving antennas reach at that tag's height
    (rfidnav_sim.rfid_model.reach_m, from the reader's link budget): the heading controller will not hear it from
    the previous tag and has to search for it (or, without unheard_search, fails)."""
    route = scenario.mission.goal.get("tag_ids")
    readers = [(role, parameters[role]) for role, spec in scenario.nodes.items()
               if (spec.package, spec.executable) == SIMULATED_READER]
    if not isinstance(route, list) or not readers:
        return ()
    role, reader = readers[0]
    model = reader.reader_model()
    receiving = [antenna for antenna in model.antennas if antenna.facing_up and antenna.side_bearing_rad is None]
    listed = {tag.tag_id: tag.position for tag in scenario.world.tags}
    warnings = []
    for here, there in zip(route, route[1:]):
        if here not in listed or there not in listed or not receiving:
            continue
        (x1, y1, _), (x2, y2, z2) = listed[here], listed[there]
        reach = min(reach_m(model, antenna, z2) for antenna in receiving)
        leg = math.hypot(x2 - x1, y2 - y1)
        if leg > reach:
            warnings.append(f"{scenario.path}: mission.goal.tag_ids: the leg {here} -> {there} is {leg:.1f} m, "
                            f"beyond the reach of the reader '{role}' for a tag {z2:g} m up ({reach:.2f} m, from "
                            f"its link budget): the heading controller has to search for {there}")
    return tuple(warnings)


def _check_goal_node(scenario: Scenario, mission: Section) -> None:
    """A node goal (paper 004) must name a node of the scenario's topological map."""
    node = scenario.mission.goal.get("goal_node")
    if node is None:
        return
    if not isinstance(node, str):
        raise mission.error("goal", f"goal_node: expected a node name, got {type_name(node)}")
    topological_map = scenario.topological_map
    if topological_map is None:
        raise mission.error("goal", f"goal_node: the map {scenario.map_file} is not a topological map")
    if node not in topological_map.nodes:
        raise mission.error("goal", f"goal_node: '{node}' is not a node of {scenario.map_file} "
                                    f"(nodes: {', '.join(topological_map.nodes)})")


def _check_route(scenario: Scenario, mission: Section) -> None:
    tag_ids = scenario.mission.goal.get("tag_ids")
    if tag_ids is None:
        return
    if scenario.route_map is None:
        raise mission.error("goal", f"tag_ids: the map {scenario.map_file} is not a route map")
    if not isinstance(tag_ids, list) or not tag_ids or not all(isinstance(t, str) for t in tag_ids):
        raise mission.error("goal", "tag_ids: expected a non-empty list of tag ids")
    unknown = scenario.route_map.unknown_tags(tag_ids)
    if unknown:
        raise mission.error("goal", f"tag_ids: {', '.join(unknown)} not in the route map {scenario.map_file}")
    if repeated := repeated_in_a_row(tag_ids):
        raise mission.error("goal", f"tag_ids: {repeated}")


def _check_goal_area(scenario: Scenario, mission: Section) -> None:
    """A point goal must lie in the map's extent (paper 000: the tagged area; paper 003: the home's floor plan):
    the navigator would refuse it."""
    target, route_map = scenario.mission.goal.get("target"), scenario.route_map
    area = route_map.extent if route_map is not None else None
    if not isinstance(target, dict) or route_map is None or area is None:
        return
    x, y = target.get("x"), target.get("y")
    if not (isinstance(x, (int, float)) and isinstance(y, (int, float))) or isinstance(x, bool) or isinstance(y, bool):
        raise mission.error("goal", "target: expected numbers x and y")
    if not contains(area, x, y):
        what = "deployment_area" if area == route_map.deployment_area else "extent"
        raise mission.error("goal", f"target ({x}, {y}) is outside the map's {what} {list(area)}")


def _check_antenna_ports(scenario: Scenario, parameters: dict[str, Any]) -> None:
    """Every antenna port a node takes reads of (``antenna_ports_read()`` of its parameters: heading_controller's
    left, right and floor antennas, ...) is one a reader of the scenario publishes on /rfid/reads
    (``published_antenna_ports()``: the LLRP driver's ``antennas``, the simulator's antennas). One error names the
    reader's file and key, the ports it lacks and, for each, the node, parameter and file that asked for it.

    Not checked: a reader told to inventory every port it has (``antennas: []``: known only once it runs), and a
    scenario with a role we do not know (a command line: it may publish reads too)."""
    if any(value is None for value in parameters.values()):
        return
    readers = {role: value.published_antenna_ports() for role, value in parameters.items()
               if isinstance(value, PublishesAntennaPorts)}
    if not readers or any(not ports for _, ports in readers.values()):
        return
    published = {port for _, ports in readers.values() for port in ports}
    wanted = [(role, name, port) for role, value in parameters.items() if isinstance(value, ReadsAntennaPorts)
              for name, port in value.antenna_ports_read().items() if port not in published]
    if not wanted:
        return
    missing = sorted({port for _, _, port in wanted})
    uses = "; ".join(f"{scenario.nodes[role].name or role}'s {name} = {port} ({_origin(scenario, role, name)})"
                     for role, name, port in wanted)
    if len(readers) == 1:
        (role, (field_name, ports)), = readers.items()
        source, key = _origin_key(scenario, role, field_name)
        what = f"reads come from ports {', '.join(map(str, ports))} only"
    else:
        source, key = str(scenario.path), "nodes"
        what = "the readers " + ", ".join(f"{role} ({', '.join(map(str, ports))})"
                                          for role, (_, ports) in readers.items()) + " publish no other ports"
    raise ConfigError(source, key, f"{what}, but {uses}: missing port{'s' if len(missing) > 1 else ''} "
                                   f"{', '.join(map(str, missing))} (add {'them' if len(missing) > 1 else 'it'} to "
                                   f"the reader's ports, or point the node at a port the reader has)")


def _check_speeds(scenario: Scenario, parameters: dict[str, Any]) -> None:
    """No node commands a forward speed above what the base drives (``speed_limit()`` of the base's parameters:
    robot_sim's or create_base's ``max_wheel_speed_mps``); one error names the node's parameter and the base's."""
    limits = [(role, value.speed_limit()) for role, value in parameters.items() if isinstance(value, LimitsSpeed)]
    if len(limits) != 1:
        return
    (base_role, (limit_name, limit)), = limits
    for role, value in parameters.items():
        for name, speed in (value.commanded_speeds().items() if isinstance(value, CommandsSpeeds) else ()):
            if speed > limit:
                source, key = _origin_key(scenario, role, name)
                raise ConfigError(source, key, f"{speed:g} m/s is faster than the base drives: {base_role}'s "
                                               f"{limit_name} is {limit:g} "
                                               f"({_origin(scenario, base_role, limit_name)})")


def _check_server(scenario: Scenario, mission: Section) -> None:
    """The role serving the mission (mission.server, else the first non-simulator role), when it is one of our
    action servers (its registration's ``serves``), serves the mission's action name, with its type."""
    role = scenario.mission.server or next((role for role, spec in scenario.nodes.items() if not spec.sim), None)
    spec = scenario.nodes.get(role or "")
    served = dict(spec.registration.serves) if spec is not None and spec.registration is not None else {}
    if role is None or not served:
        return
    node = scenario.nodes[role].name or role
    action_type = served.get(_expanded(scenario.mission.action))
    if action_type is None:
        raise mission.error("action", f"{node} (role {role}) serves {', '.join(served)}, not {scenario.mission.action}")
    if scenario.mission.action_type != action_type:
        raise mission.error("type", f"{node} (role {role}) serves {action_type}, not {scenario.mission.action_type}")


def _check_partition_lattices(scenario: Scenario) -> None:
    """A partition navigator (paper 000) walks the triangles of a triangular lattice: a simulated world whose floor
    deployment it cannot plan on (a grid) is refused here, naming the world's field, not once the robot has
    started and read its first tag."""
    roles = {(spec.package, spec.executable) for spec in scenario.nodes.values()}
    if PARTITION_NAVIGATOR not in roles or SIMULATED_READER not in roles:   # real tags: known once read
        return
    for index, deployment in enumerate(scenario.world.deployments):
        refusal = lattice_refusal(deployment)
        if refusal is not None:
            raise ConfigError(str(scenario.world_file), f"lattices[{index}].layout", refusal)


def _origin_key(scenario: Scenario, role: str, name: str) -> tuple[str, str]:
    """Where parameter ``name`` of ``role`` is set: (file, key) of the last file or the scenario overrides that
    set it; for a default, the role's last parameter file (where to set it), else the scenario's entry."""
    spec = scenario.nodes[role]
    if name in spec.overrides:
        return str(scenario.path), f"nodes.{role}.overrides.{name}"
    assert spec.registration is not None, role   # only registered nodes have parameters checked
    node_name = spec.registration.node_name
    for file in reversed(spec.param_files):
        section = node_parameter_section(file, node_name)
        if section.has(name):
            return section.source, section.field(name)
    if spec.param_files:
        return str(spec.param_files[-1]), f"{node_name}.ros__parameters.{name} (not set: the default)"
    return str(scenario.path), f"nodes.{role} (no parameter file: {name} is the default)"


def _origin(scenario: Scenario, role: str, name: str) -> str:
    source, key = _origin_key(scenario, role, name)
    return f"{source}: {key}"


def injected_parameters(scenario: Scenario, spec: NodeSpec, seed: int, rtf: float,
                        run_dir: Path | None = None, stepped_with: tuple[str, ...] | None = None) -> dict[str, Any]:
    """What the orchestrator gives each node on top of its files: the world only to simulator nodes, the run's
    folder to nodes that declare ``run_dir`` (where they keep files, e.g. the location server's database).

    ``stepped_with``: the stepped clock's participants (fully qualified node names), None for the free-running
    clock. A participant takes its time from the stamps it handles; every other node runs with use_sim_time.
    ``rtf`` may be ``math.inf`` (as fast as the stepped graph answers): the clock source takes it as it is."""
    injected: dict[str, Any] = {"seed": robot_seed(seed, spec.robot) if spec.robot else seed}
    if run_dir is not None:
        injected["run_dir"] = str(run_dir)
    participant = stepped_with is not None and spec.fqn is not None and spec.fqn in stepped_with
    if participant:
        injected["stepped_clock"] = True
    elif not spec.clock_source and scenario.simulated:
        injected["use_sim_time"] = True
    if spec.sim:
        injected["world_file"] = str(scenario.world_file)
    else:
        injected["map_file"] = str(spec.map_file or scenario.map_file)
    if spec.clock_source:
        x, y, yaw_deg = scenario.robot
        injected.update(start_x=x, start_y=y, start_yaw_deg=yaw_deg, rtf=float(rtf),
                        start_paused=True)
        if scenario.robots:
            injected.update(robots=[robot.name for robot in scenario.robots],
                            robot_starts=[float(value) for robot in scenario.robots for value in robot.start])
        if stepped_with is not None:
            injected.update(stepped_clock=True, step_participants=list(stepped_with))
    return injected


def node_parameters(scenario: Scenario, spec: NodeSpec, seed: int, rtf: float,
                    run_dir: Path | None = None, stepped_with: tuple[str, ...] | None = None) -> Any | None:
    """Validate a registered node's parameter files, overrides and injected values; None for nodes no package
    registers.

    Later files override earlier ones and the scenario's overrides override the files; a bad value is reported
    against the file (or the overrides) it came from."""
    registration = spec.registration
    if registration is None:
        return None
    node_name, cls = registration.node_name, registration.parameters
    values: dict[str, Any] = {}
    origins: dict[str, tuple[str, str]] = {}
    layers = [node_parameter_section(file, node_name) for file in spec.param_files]
    layers.append(Section(spec.overrides, str(scenario.path), f"nodes.{spec.role}.overrides"))
    for layer in layers:
        layer_values = typed_values(cls, layer.data, layer.source, layer.prefix)
        values.update(layer_values)
        origins.update(dict.fromkeys(layer_values, (layer.source, layer.prefix)))
    declared = {name for name in cls.__dataclass_fields__}
    values.update({k: v for k, v in injected_parameters(scenario, spec, seed, rtf, run_dir, stepped_with).items()
                   if k in declared})
    # A problem no single value explains: the one file that gave values, else the scenario entry naming them.
    given = set(origins.values())
    source, prefix = given.pop() if len(given) == 1 else (str(scenario.path), f"nodes.{spec.role}")
    return parameters_from_mapping(cls, values, source, prefix, origins)


def dump_parameters(node_name: str, values: dict[str, Any]) -> str:
    """A ROS 2 parameter file for ``node_name``."""
    return yaml.safe_dump({node_name: {"ros__parameters": values}}, sort_keys=True)
