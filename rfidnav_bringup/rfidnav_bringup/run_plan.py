"""The plan of a run (pure, no rclpy, no process started): which clock runs and who takes part in it, the run's
folder (copies of the world and map, the resolved scenario, each node's parameter file) and the processes to start
with their command lines: the recorder, the live view, and one process per role or per group of roles that share a
``process:`` (rfidnav_bringup.container).
"""

from __future__ import annotations

import json
import math
import shutil
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import yaml

from rfidnav_common.clock_topics import RESEND_TOPICS
from rfidnav_common.errors import ConfigError
from rfidnav_common.install import resolve_executable
from rfidnav_common.step_ledger import CLOCKS, STEP_ACK_TOPIC
from rfidnav_scenario.scenario import (
    ORCHESTRATOR_NODE,
    SPLIT_PARTS,
    NodeSpec,
    Scenario,
    dump_parameters,
    injected_parameters,
    node_parameters,
)

RECORDER_ROLE = "recorder"
LIVE_ROLE = "live_view"                  # foxglove_bridge with --live: no participant of the stepped clock
LIVE_NODE = "foxglove_bridge"            # its node's name
STEPPING_CLOCK_SOURCE = ("rfidnav_sim", "robot_sim")   # the clock source that can step
PARTS = SPLIT_PARTS                                   # --part: one run's graph split between two computers
ROBOT_PART, STATION_PART = PARTS
ROBOT_PART_ORCHESTRATOR = f"{ORCHESTRATOR_NODE}_robot"   # the robot part's own node, beside the station's
DRIVERS_PACKAGE = "rfidnav_drivers"


@dataclass(frozen=True)
class RunOptions:
    rtf: float = 1.0                         # real-time factor; a ceiling with the stepped clock, inf: none
    clock: str = "stepped"                   # CLOCKS: stepped, or free-running at the RTF
    seed: int = 1
    out_dir: Path = Path("bags")
    record: bool = True
    record_exclude: tuple[str, ...] = ()     # topics the recorder leaves out (its exclude_topics)
    live_port: int | None = None             # serve the graph to Foxglove on this port (--live)
    quiet: bool = False
    domain: int | None = None                # the ROS domain to run in; None: the first free one of RUN_DOMAINS
    discovery: str = "localhost"             # processes.DISCOVERY_RANGES: ROS_AUTOMATIC_DISCOVERY_RANGE of the run
    compress: bool = False                   # zstd chunk compression of the bag's MCAP files
    max_bag_size: int = 0                    # split the bag into files of this many bytes (0: one file)
    max_bag_duration_s: float = 0.0          # split the bag into files of this many seconds of bag time (0: no)
    part: str | None = None                  # PARTS: start only this computer's roles (part_of); None: all
    partition: str | None = None             # the run's DDS partition (both parts of a split run give one name)
    discovery_server: tuple[str, int] | None = None   # (address, port) of a Fast DDS Discovery Server to find it by


@dataclass(frozen=True)
class ProcessPlan:
    """One process to start: ``name`` is a role's name, or its group's."""
    name: str
    command: list[str]
    respawn: bool = False
    max_respawns: int = 0


@dataclass(frozen=True)
class ExpectedGraph:
    """What the run's graph should hold, as the graph watch checks it (rfidnav_bringup.graph_watch)."""
    nodes: frozenset[str]               # the node names of the scenario's roles (without the leading slash)
    simulators: tuple[str, ...]         # the simulator nodes' names, sorted (graph.json)
    clock_source: str | None            # the clock source's node name: its ~/start and ~/wired, its warnings
    simulated: bool                     # sim time runs (else real time: no clock to watch)
    record_exclude: tuple[str, ...]     # the topics the recorder leaves out (not waited for)
    # Other nodes of the run (the live view's), and the roles whose node names the run does not know (a command
    # line without ``name``): with one, no publisher can be told foreign by its node's name.
    helpers: frozenset[str] = frozenset()
    unnamed_roles: tuple[str, ...] = ()
    elsewhere: tuple[str, ...] = ()     # a split run: the node names the other part starts, on the other computer


def part_of(spec: NodeSpec) -> str:
    """Which computer of a split run starts a role: the one its robot profile assigns (``parts:``), else the
    robot's its simulators and drivers (the base, the reader, the sensors: what touches the hardware), the
    station the rest (localizers, planners, the mission's server). The recorder is the station's."""
    if spec.part is not None:
        return spec.part
    return ROBOT_PART if spec.sim or spec.clock_source or spec.package == DRIVERS_PACKAGE else STATION_PART


class RunPlan:
    def __init__(self, scenario: Scenario, options: RunOptions, run_dir: Path) -> None:
        self.scenario = scenario
        self.options = options
        self.run_dir = run_dir
        if options.part is not None and options.part not in PARTS:
            raise ConfigError("--part", "", f"unknown part '{options.part}' (known: {', '.join(PARTS)})")
        # The nodes the run starts (a role once, or once per robot: Scenario.instances), and those this computer
        # starts: all of them, or its part's (the others run on the other computer).
        self.nodes = scenario.instances()
        self.roles = tuple(role for role, spec in self.nodes.items()
                           if options.part is None or part_of(spec) == options.part)
        self.starts_recorder = options.record and options.part != ROBOT_PART
        self.process_of = {role: spec.process or role for role, spec in self.nodes.items()}
        for process in {self.process_of[role] for role in self.roles}:
            split = sorted(role for role, key in self.process_of.items() if key == process and role not in self.roles)
            if split:
                raise ConfigError(str(scenario.path), f"nodes.{split[0]}.process",
                                  f"'{process}' holds roles of both parts of a split run (--part {options.part})")
        self.clock, self.clock_note = choose_clock(scenario, options)
        participants = [spec.fqn for spec in scenario.step_participants() if spec.fqn]
        if options.record:
            participants.append(f"/{RECORDER_ROLE}")
        self.stepped_with: tuple[str, ...] | None = tuple(participants) if self.clock == "stepped" else None
        # The answers to the stepped clock are bookkeeping, not data: left out of the bag.
        self.record_exclude = options.record_exclude + ((STEP_ACK_TOPIC, *RESEND_TOPICS) if self.stepped_with else ())

    def write(self) -> Iterator[ProcessPlan]:
        """Write the run's folder and yield the processes to start, in order: the recorder, the live view, the
        roles' processes (each node's parameter file is written as its process is planned)."""
        self.run_dir.mkdir(parents=True)
        for source, name in ((self.scenario.world_file, "world.yaml"), (self.scenario.map_file, "map.yaml")):
            shutil.copyfile(source, self.run_dir / name)
        document = self.scenario.resolved_document()
        document["run"] = {"seed": self.options.seed, "rtf": rtf_text(self.options.rtf), "clock": self.clock}
        (self.run_dir / "scenario.yaml").write_text(yaml.safe_dump(document, sort_keys=False))
        params_dir = self.run_dir / "params"
        params_dir.mkdir()
        if self.starts_recorder:
            yield ProcessPlan(RECORDER_ROLE, self.recorder_command())
        if self.options.live_port is not None:
            yield ProcessPlan(LIVE_ROLE, self.live_view_command(self.options.live_port))
        groups: dict[str, list[NodeSpec]] = {}
        for role in self.roles:
            groups.setdefault(self.process_of[role], []).append(self.nodes[role])
        for key, specs in groups.items():
            if len(specs) == 1 and specs[0].process is None:
                spec = specs[0]
                yield ProcessPlan(key, self.node_command(spec, params_dir), spec.respawn, spec.max_respawns)
            else:
                yield ProcessPlan(key, self.container_command(specs, params_dir))

    def log_path(self, role: str) -> Path:
        return self.run_dir / "logs" / f"{role}.log"

    def recorder_command(self) -> list[str]:
        command = resolve_executable("rfidnav_bag", "recorder") + [
            "--ros-args", "-p", f"output_dir:={self.run_dir / 'bag'}",
            "-p", f"stamp_from_clock_topic:={str(self.scenario.simulated).lower()}"]
        if self.stepped_with is not None:
            command += ["-p", "stepped_clock:=true"]
        if self.record_exclude:
            command += ["-p", f"exclude_topics:={json.dumps(list(self.record_exclude))}"]
        if self.options.compress:
            command += ["-p", "compression:=zstd"]
        return command + ["-p", f"max_bag_size:={self.options.max_bag_size}",
                          "-p", f"max_bag_duration_s:={float(self.options.max_bag_duration_s)}"]

    def live_view_command(self, port: int) -> list[str]:
        command = resolve_executable("rfidnav_bag", "foxglove_bridge") + [
            "--ros-args", "-p", f"port:={port}",
            "-p", f"stamp_from_clock_topic:={str(self.scenario.simulated).lower()}"]
        if self.record_exclude:   # what the recorder leaves out, the viewer does not see either
            command += ["-p", f"exclude_topics:={json.dumps(list(self.record_exclude))}"]
        return command

    def container_command(self, specs: list[NodeSpec], params_dir: Path) -> list[str]:
        """One process for roles that share a ``process``: rfidnav_bringup.container with each node's parameter
        file (keyed by its node name) as a global argument."""
        command = [sys.executable, "-m", "rfidnav_bringup.container"]
        files: list[str] = []
        for spec in specs:
            command += ["--node", f"{spec.package}:{spec.executable}" + (f"@/{spec.robot}" if spec.robot else "")]
            files += self.parameter_arguments(spec, params_dir)
        return command + ["--ros-args", *files]

    def node_command(self, spec: NodeSpec, params_dir: Path) -> list[str]:
        if spec.package is None and not (spec.stepped or spec.param_files or spec.overrides):
            return list(spec.command)   # a command line as given: it may be no ROS node of ours at all
        namespace = ["-r", f"__ns:=/{spec.robot}"] if spec.robot else []
        return [*spec.command, "--ros-args", *namespace, *self.parameter_arguments(spec, params_dir)]

    def parameter_arguments(self, spec: NodeSpec, params_dir: Path) -> list[str]:
        """The ROS arguments that give ``spec``'s node its parameters: its resolved file (written here), or its
        files and overrides for a node no package registers."""
        parameters = node_parameters(self.scenario, spec, self.options.seed, self.options.rtf, self.run_dir,
                                     self.stepped_with)
        injected = injected_parameters(self.scenario, spec, self.options.seed, self.options.rtf,
                                       stepped_with=self.stepped_with)
        if parameters is not None and spec.registration is not None:
            # Keyed by the fully qualified name under a robot's namespace: its file must not reach the other robots'
            # nodes of that name (in one container, or by the rule that a key without a namespace is the root's).
            node_name = spec.registration.node_name
            if spec.robot:
                node_name = f"/{spec.robot}/{node_name}"
            values = dict(parameters.__dict__)
            values.update({k: v for k, v in injected.items() if k not in values})
            file = params_dir / f"{spec.role}.yaml"
            file.write_text(dump_parameters(node_name, values))
            return ["--params-file", str(file)]
        command: list[str] = []
        for file in spec.param_files:
            command += ["--params-file", str(file)]
        for key, value in {**spec.overrides, **injected}.items():
            command += ["-p", f"{key}:={json.dumps(value)}"]
        return command

    def expected_graph(self) -> ExpectedGraph:
        nodes = self.nodes.values()
        return ExpectedGraph(
            nodes=frozenset(spec.node_path for spec in nodes if spec.node_path),
            simulators=tuple(sorted(spec.node_path for spec in nodes if spec.sim and spec.node_path)),
            clock_source=next((spec.name for spec in nodes if spec.clock_source), None),
            simulated=self.scenario.simulated, record_exclude=self.record_exclude,
            helpers=frozenset({LIVE_NODE} if self.options.live_port is not None else ())
            | frozenset({ORCHESTRATOR_NODE, ROBOT_PART_ORCHESTRATOR} if self.options.part is not None else ()),
            unnamed_roles=tuple(sorted(spec.role for spec in nodes if not spec.name)),
            elsewhere=tuple(sorted({spec.node_path for role, spec in self.nodes.items()
                                    if spec.node_path and role not in self.roles}
                                   | ({RECORDER_ROLE} if self.options.record and not self.starts_recorder
                                      else set()))))

    def clock_summary(self) -> dict[str, Any]:
        """Which clock ran, and for the stepped clock who it waited for and which roles ran free beside it."""
        summary: dict[str, Any] = {"mode": self.clock}
        if self.stepped_with is not None:
            summary["participants"] = list(self.stepped_with)
            summary["free_running_roles"] = sorted(
                role for role, spec in self.nodes.items()
                if not spec.clock_source and spec.fqn not in self.stepped_with)
        return summary

    def mission_process(self, robot: str | None = None) -> str | None:
        """The process serving ``robot``'s mission (None: the one robot's): the one of the scenario's
        mission.server, else of the first non-simulator role."""
        instance = self.scenario.mission_server(robot)
        return self.process_of[instance] if instance else None

    def node_names_of(self, process: str) -> list[str]:
        """The fully qualified node names of the roles that ``process`` runs."""
        return [fqn for role, key in self.process_of.items() if key == process and (fqn := self.nodes[role].fqn)]


def choose_clock(scenario: Scenario, options: RunOptions) -> tuple[str, str]:
    """The clock that runs (stepped, free or real time) and, when it is not the one asked for, why."""
    if options.clock not in CLOCKS:
        raise ConfigError("--clock", "", f"unknown clock '{options.clock}' (known: {', '.join(CLOCKS)})")
    if not scenario.simulated:
        return "real time", " (no simulated base: hardware)"
    source = next(spec for spec in scenario.nodes.values() if spec.clock_source)
    if options.clock == "stepped" and (source.package, source.executable) != STEPPING_CLOCK_SOURCE:
        return "free", f" (the clock source {source.role} cannot step)"
    if options.clock == "free" and not math.isfinite(options.rtf):
        raise ConfigError("--rtf", "", "max needs the stepped clock (the free-running clock keeps a fixed RTF)")
    return options.clock, ""


def rtf_text(rtf: float) -> str | float:
    return rtf if math.isfinite(rtf) else "max"


def run_id(scenario: str) -> str:
    return f"{datetime.now(UTC).strftime('%Y%m%dT%H%M%SZ')}_{scenario}"


def unique_dir(path: Path) -> Path:
    candidate, index = path, 1
    while candidate.exists():
        index += 1
        candidate = path.with_name(f"{path.name}_{index}")
    return candidate
