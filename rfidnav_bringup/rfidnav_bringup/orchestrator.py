"""``./rfidnav run``: one mission through the real node graph, every role its own OS process (or its
group's: ``process:`` in the scenario, rfidnav_bringup.container).

Order of events: lease a DDS domain; write each node's resolved parameter file; start the recorder
and wait until it is in the graph; start the nodes; wait until every node is in the graph, the
mission's action server answers and the recorder subscribes to every topic it will record (not the
excluded ones, nor those of a type it cannot store); start the simulation clock and send the goal
(with the stepped clock the goal first, so that it starts at sim time 0 whatever the load), and show
its feedback on one progress line; on result, timeout, a stall or a signal cancel the goal, stop the nodes
(SIGINT, then SIGKILL), stop the recorder last so it finalizes the bag; compute the metrics from the
bag and write summary.json.

Signals: SIGINT (Ctrl-C), SIGTERM and SIGHUP all end a run that way, a second one too (it only says that the run
is already stopping); the exit code is then 128 + the first signal's number. Every node dies with the
orchestrator, even a SIGKILLed one (processes.die_with_parent). While the mission runs, a clock that stops
advancing is reported within seconds, naming the processes that are stopped and what the clock source says it
waits for; a second graph whose nodes take our nodes' names (two runs on one domain) ends the run before they mix.

Clocks (``RunOptions.clock``): ``stepped`` (the default for simulated runs) makes robot_sim wait, at every
publication, for the answers of our nodes of the simulated loop and the recorder (rfidnav_common.stepped_node);
drivers and nodes given as command lines run free beside them. ``free`` keeps the free-running clock at the
RTF. A run without the simulated base (hardware) runs in real time.
"""

from __future__ import annotations

import functools
import json
import math
import os
import shutil
import signal
import sys
import time
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import psutil
import rclpy
import yaml
from rcl_interfaces.msg import Log
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future
from std_srvs.srv import Trigger

from rfidnav_bag.errors import BagError
from rfidnav_bag.recorder_node import recordable_definition
from rfidnav_bringup.errors import NodeExitedError, ReadinessError
from rfidnav_bringup.processes import DomainLease, NodeProcess, child_environment, reach_text
from rfidnav_common.errors import ConfigError, RfidnavError
from rfidnav_common.files import write_atomically
from rfidnav_common.install import resolve_executable
from rfidnav_common.progress import StatusLine
from rfidnav_common.ros import events_executor, fill_message, interface_class
from rfidnav_common.step_ledger import CLOCKS
from rfidnav_common.stepped_node import STEP_ACK_TOPIC
from rfidnav_scenario.metrics import ground_truth_objection
from rfidnav_scenario.scenario import (
    NodeSpec,
    Scenario,
    dump_parameters,
    injected_parameters,
    node_parameters,
)

READY_TIMEOUT_S = 90.0
STOP_GRACE_S = 5.0
RECORDER_ROLE = "recorder"
LIVE_ROLE = "live_view"                  # foxglove_bridge with --live: no participant of the stepped clock
RESEND_ATTEMPTS = 6
RESEND_TIMEOUT_S = 5.0
STEPPING_CLOCK_SOURCE = ("rfidnav_sim", "robot_sim")   # the clock source that can step
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)   # each ends a run as Ctrl-C does
STALL_REPORT_S = 5.0      # wall time without sim-time progress after which the run says who holds it up
STALL_ABORT_S = 60.0      # ... and after which it ends the mission as stalled
GRAPH_CHECK_PERIOD_S = 1.0   # how often the mission loop looks for a second graph in the domain
RESPAWN_GRACE_S = 30.0       # a killed node stays in the graph until its DDS lease ends (Fast DDS: 20 s)


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


@dataclass
class MissionOutcome:
    success: bool = False
    message: str = "not started"
    started_wall: float | None = None
    started_sim_s: float | None = None
    ended_sim_s: float | None = None
    feedback: Any = None
    result: Any = None
    ended_wall: float | None = None
    cpu_at_start: dict[str, float | None] = field(default_factory=dict)
    cpu_at_end: dict[str, float | None] = field(default_factory=dict)


@dataclass
class RunSummary:
    run_dir: Path
    document: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return bool(self.document.get("success"))


def run_id(scenario: str) -> str:
    return f"{datetime.now(UTC).strftime('%Y%m%dT%H%M%SZ')}_{scenario}"


class Orchestrator:
    def __init__(self, scenario: Scenario, options: RunOptions) -> None:
        self.scenario = scenario
        self.options = options
        self.run_dir = unique_dir(options.out_dir / run_id(scenario.name))
        self.processes: dict[str, NodeProcess] = {}       # by process: a role's name, or its group's
        self.domain: dict[str, Any] | None = None    # the ROS domain it ran in, and the ones it skipped
        self.process_of = {role: spec.process or role for role, spec in scenario.nodes.items()}
        self.outcome = MissionOutcome()
        self.progress = StatusLine(options.quiet)
        self.stop_signal: int | None = None       # the first of STOP_SIGNALS that came
        self.terminal_lost = False                 # SIGHUP on a terminal: nothing more is printed
        self.clock_source_says = ""                # the clock source's last warning on /rosout
        self.clock_source_name = next((spec.name for spec in scenario.nodes.values() if spec.clock_source), None)
        # Nodes of a respawned process, and until when (wall): the dead one stays in the graph until its DDS lease
        # ends, so two of the name are expected for that long.
        self.respawned_until: dict[str, float] = {}
        self.clock, self.clock_note = choose_clock(scenario, options)
        participants = [f"/{spec.name}" for spec in scenario.step_participants()]
        if options.record:
            participants.append(f"/{RECORDER_ROLE}")
        self.stepped_with: tuple[str, ...] | None = tuple(participants) if self.clock == "stepped" else None
        # The answers to the stepped clock are bookkeeping, not data: left out of the bag.
        self.record_exclude = options.record_exclude + ((STEP_ACK_TOPIC,) if self.stepped_with else ())

    # ----------------------------------------------------------------- set-up
    def prepare(self, env: dict[str, str]) -> None:
        self.run_dir.mkdir(parents=True)
        for source, name in ((self.scenario.world_file, "world.yaml"), (self.scenario.map_file, "map.yaml")):
            shutil.copyfile(source, self.run_dir / name)
        document = self.scenario.resolved_document()
        document["run"] = {"seed": self.options.seed, "rtf": rtf_text(self.options.rtf), "clock": self.clock}
        (self.run_dir / "scenario.yaml").write_text(yaml.safe_dump(document, sort_keys=False))
        params_dir = self.run_dir / "params"
        params_dir.mkdir()
        if self.options.record:
            command = resolve_executable("rfidnav_bag", "recorder") + [
                "--ros-args", "-p", f"output_dir:={self.run_dir / 'bag'}",
                "-p", f"stamp_from_clock_topic:={str(self.scenario.simulated).lower()}"]
            if self.stepped_with is not None:
                command += ["-p", "stepped_clock:=true"]
            if self.record_exclude:
                command += ["-p", f"exclude_topics:={json.dumps(list(self.record_exclude))}"]
            if self.options.compress:
                command += ["-p", "compression:=zstd"]
            command += ["-p", f"max_bag_size:={self.options.max_bag_size}",
                        "-p", f"max_bag_duration_s:={float(self.options.max_bag_duration_s)}"]
            self.processes[RECORDER_ROLE] = NodeProcess(RECORDER_ROLE, command, self.log_path(RECORDER_ROLE), env)
        if self.options.live_port is not None:
            command = resolve_executable("rfidnav_bag", "foxglove_bridge") + [
                "--ros-args", "-p", f"port:={self.options.live_port}",
                "-p", f"stamp_from_clock_topic:={str(self.scenario.simulated).lower()}"]
            if self.record_exclude:   # what the recorder leaves out, the viewer does not see either
                command += ["-p", f"exclude_topics:={json.dumps(list(self.record_exclude))}"]
            self.processes[LIVE_ROLE] = NodeProcess(LIVE_ROLE, command, self.log_path(LIVE_ROLE), env)
        groups: dict[str, list[NodeSpec]] = {}
        for role, spec in self.scenario.nodes.items():
            groups.setdefault(self.process_of[role], []).append(spec)
        for key, specs in groups.items():
            if len(specs) == 1 and specs[0].process is None:
                spec = specs[0]
                command = self.node_command(spec, params_dir)
                self.processes[key] = NodeProcess(key, command, self.log_path(key), env, spec.respawn,
                                                  spec.max_respawns)
            else:
                self.processes[key] = NodeProcess(key, self.container_command(specs, params_dir),
                                                  self.log_path(key), env)

    def log_path(self, role: str) -> Path:
        return self.run_dir / "logs" / f"{role}.log"

    def container_command(self, specs: list[NodeSpec], params_dir: Path) -> list[str]:
        """One process for roles that share a ``process``: rfidnav_bringup.container with each node's parameter
        file (keyed by its node name) as a global argument."""
        command = [sys.executable, "-m", "rfidnav_bringup.container"]
        files: list[str] = []
        for spec in specs:
            command += ["--node", f"{spec.package}:{spec.executable}"]
            files += self.node_command(spec, params_dir)[len(spec.command) + 1:]
        return command + ["--ros-args", *files]

    def node_command(self, spec: NodeSpec, params_dir: Path) -> list[str]:
        if spec.package is None and not (spec.stepped or spec.param_files or spec.overrides):
            return list(spec.command)   # a command line as given: it may be no ROS node of ours at all
        command = [*spec.command, "--ros-args"]
        parameters = node_parameters(self.scenario, spec, self.options.seed, self.options.rtf, self.run_dir,
                                     self.stepped_with)
        injected = injected_parameters(self.scenario, spec, self.options.seed, self.options.rtf,
                                       stepped_with=self.stepped_with)
        if parameters is not None and spec.registration is not None:
            node_name = spec.registration.node_name
            values = dict(parameters.__dict__)
            values.update({k: v for k, v in injected.items() if k not in values})
            file = params_dir / f"{spec.role}.yaml"
            file.write_text(dump_parameters(node_name, values))
            return command + ["--params-file", str(file)]
        for file in spec.param_files:
            command += ["--params-file", str(file)]
        for key, value in {**spec.overrides, **injected}.items():
            command += ["-p", f"{key}:={json.dumps(value)}"]
        return command

    # ----------------------------------------------------------------- run
    def run(self) -> RunSummary:
        lease = DomainLease() if self.options.domain is None else DomainLease(range(self.options.domain,
                                                                                    self.options.domain + 1))
        self.domain = {"id": lease.domain_id, "skipped": {str(d): nodes for d, nodes in lease.skipped.items()},
                       "discovery": self.options.discovery}
        env = child_environment(lease.domain_id, self.options.discovery)
        os.environ.update({k: env[k] for k in ("ROS_DOMAIN_ID", "ROS_AUTOMATIC_DISCOVERY_RANGE")})
        context = Context()
        # rclpy's own handlers would shut the context down under the executor (SIGTERM): ours only set a flag.
        rclpy.init(context=context, domain_id=lease.domain_id, signal_handler_options=SignalHandlerOptions.NO)
        node = Node("rfidnav_orchestrator", context=context,
                    parameter_overrides=[rclpy.parameter.Parameter("use_sim_time", value=self.scenario.simulated)])
        node.create_subscription(Log, "/rosout", self.on_log, 100)
        executor = events_executor(context)
        executor.add_node(node)
        previous_handlers = {signum: signal.signal(signum, self.on_stop_signal) for signum in STOP_SIGNALS}
        try:
            self.prepare(env)
            if lease.skipped:
                self.say(f"skipped ROS domains in use by nodes not of this run: {lease.describe_skipped()}",
                         always=True)
            self.say(f"run {self.run_dir.name}: seed {self.options.seed}, RTF {rtf_text(self.options.rtf)}, "
                     f"{self.clock} clock{self.clock_note}")
            self.say(f"graph on {reach_text(lease.domain_id, self.options.discovery)}", always=True)
            self.start_graph(node, executor)
            if not self.interrupted:
                self.fly_mission(node, executor)
        except RfidnavError as error:
            self.outcome.message = str(error)
            self.say(f"error: {error}", always=True)
        finally:
            self.progress.done()
            # Our handlers stay until the bag is closed and the summary written: a second signal must not cut that.
            self.shut_down()
            executor.shutdown()
            node.destroy_node()
            rclpy.try_shutdown(context=context)
            # Destroyed, not only shut down: its DDS participant would stay in the domain (and a sweep running one
            # run after another in this process would find its own last run there).
            context.destroy()
            lease.close()
            summary = self.write_summary()
            for signum, handler in previous_handlers.items():
                signal.signal(signum, handler)
        return summary

    @property
    def interrupted(self) -> bool:
        return self.stop_signal is not None

    @property
    def exit_code(self) -> int:
        """The shell's convention: 128 + the signal that stopped the run, else 0 on success and 1 otherwise."""
        if self.stop_signal is not None:
            return 128 + self.stop_signal
        return 0 if self.outcome.success else 1

    def on_stop_signal(self, signum: int, _frame) -> None:
        if signum == signal.SIGHUP and os.isatty(sys.stdout.fileno()):
            self.terminal_lost = True   # the terminal hung up: printing to it would fail
        if self.stop_signal is not None:
            self.say(f"\n{signal.Signals(signum).name}: already stopping (the nodes stop in order and the bag is "
                     "closed); please wait", always=True)
            return
        self.stop_signal = signum
        name = "Ctrl-C" if signum == signal.SIGINT else signal.Signals(signum).name
        self.outcome.message = f"interrupted ({name})"

    def on_log(self, message: Log) -> None:
        if message.name == self.clock_source_name and message.level >= Log.WARN:
            self.clock_source_says = message.msg

    def say(self, text: str, always: bool = False) -> None:
        if self.terminal_lost or not (always or not self.options.quiet):
            return
        try:
            print(text, flush=True)
        except OSError:   # the output went away (a closed pipe, a terminal gone): the run goes on
            self.terminal_lost = True

    def spin_until(self, executor: Executor, condition, timeout_s: float,
                   what: str | Callable[[], str]) -> None:
        """Spin until ``condition()`` holds; fail naming ``what`` (a text, or a function giving it at the
        timeout) and any node that died meanwhile."""
        deadline = time.monotonic() + timeout_s
        while not condition():
            self.check_processes(starting=True)
            if self.interrupted:
                return
            if time.monotonic() > deadline:
                waited_for = what() if callable(what) else what
                raise ReadinessError(f"timed out after {timeout_s:.0f} s waiting for {waited_for}\n"
                                     f"{self.all_last_lines()}")
            executor.spin_once(timeout_sec=0.05)

    def start_graph(self, node: Node, executor: Executor) -> None:
        if RECORDER_ROLE in self.processes:
            self.processes[RECORDER_ROLE].start()
            self.spin_until(executor, lambda: "recorder" in node.get_node_names(), READY_TIMEOUT_S,
                            "the recorder to join the graph")
        for key, process in self.processes.items():
            if key != RECORDER_ROLE:
                process.start()
        expected = {spec.name for spec in self.scenario.nodes.values() if spec.name}
        self.spin_until(executor, lambda: expected <= set(node.get_node_names()), READY_TIMEOUT_S,
                        f"nodes {', '.join(sorted(expected))} to join the graph")
        port = self.options.live_port
        if LIVE_ROLE in self.processes and port is not None:
            from rfidnav_bag.live_view import DEFAULT_HOST, ws_url  # only with --live: it loads foxglove (~0.25 s)

            self.spin_until(executor, lambda: listens(self.processes[LIVE_ROLE], port), READY_TIMEOUT_S,
                            f"the live view to listen on port {port}")
            self.say(f"live view: {ws_url(DEFAULT_HOST, port)} "
                     "(Foxglove: Open connection -> Foxglove WebSocket)", always=True)
        self.action_type = interface_class(self.scenario.mission.action_type)
        self.client = ActionClient(node, self.action_type, self.scenario.mission.action)
        self.spin_until(executor, self.client.server_is_ready, READY_TIMEOUT_S,
                        f"action server {self.scenario.mission.action}")
        if RECORDER_ROLE in self.processes:
            self.spin_until(executor, lambda: not self.unrecorded_topics(node), READY_TIMEOUT_S,
                            lambda: f"the recorder to subscribe to {', '.join(self.unrecorded_topics(node))}")
        if self.stepped_with is not None:
            self.wait_for_wiring(node, executor)
        self.write_graph(node)
        if self.stepped_with is None:
            self.start_clock(node, executor)

    def wait_for_wiring(self, node: Node, executor: Executor) -> None:
        """Before the goal, which the mission's server answers at once (with the stepped clock, before the clock
        starts): the clock source's ledger has every participant's report and every publisher and subscription of
        theirs matched with the participants on the other side of its topic (``~/wired``). A message sent before
        both sides have matched is lost, and its consumer would hold the clock for ever."""
        clock_role = next(spec for spec in self.scenario.nodes.values() if spec.clock_source and spec.name)
        wired = node.create_client(Trigger, f"/{clock_role.name}/wired")
        answer: dict[str, str] = {}
        pending: list[Future] = []

        def ask() -> bool:
            if pending and pending[0].done():
                result = pending.pop().result()
                if result is not None and result.success:
                    return True
                answer["waiting"] = result.message if result is not None else "no answer"
            if not pending and wired.service_is_ready():
                pending.append(wired.call_async(Trigger.Request()))
            return False

        try:
            self.spin_until(executor, ask, READY_TIMEOUT_S,
                            lambda: f"the participants' publishers and subscriptions to match: "
                                    f"{answer.get('waiting', 'no answer yet from the clock source')}")
        finally:
            node.destroy_client(wired)

    def start_clock(self, node: Node, executor: Executor) -> None:
        clock_roles = [spec for spec in self.scenario.nodes.values() if spec.clock_source and spec.name]
        if clock_roles:
            start = node.create_client(Trigger, f"/{clock_roles[0].name}/start")
            self.spin_until(executor, start.service_is_ready, READY_TIMEOUT_S, "the simulation clock service")
            # ~/start is idempotent: ask again if the request or its answer was lost (Fast DDS can drop a
            # service exchange right after service_is_ready()). The clock running is the answer that counts.
            for attempt in range(RESEND_ATTEMPTS):
                start.call_async(Trigger.Request())
                try:
                    self.spin_until(executor, lambda: node.get_clock().now().nanoseconds > 0, RESEND_TIMEOUT_S,
                                    "the simulation clock to start (the first /clock message)")
                    break
                except NodeExitedError:   # final: asking again would swallow it (its process is forgotten)
                    raise
                except ReadinessError:
                    if attempt == RESEND_ATTEMPTS - 1:
                        raise

    def write_graph(self, node: Node) -> None:
        """graph.json: who publishes and subscribes what once the graph is ready (checked by the tests:
        no navigation node may subscribe to /sim/*)."""
        graph: dict[str, dict[str, list[str]]] = {}
        for name, namespace in node.get_node_names_and_namespaces():
            if name == node.get_name():
                continue
            graph[name] = {
                "subscriptions": sorted(t for t, _ in node.get_subscriber_names_and_types_by_node(name, namespace)),
                "publishers": sorted(t for t, _ in node.get_publisher_names_and_types_by_node(name, namespace))}
        simulators = sorted(spec.name for spec in self.scenario.nodes.values() if spec.sim and spec.name)
        (self.run_dir / "graph.json").write_text(json.dumps({"simulator_nodes": simulators, "nodes": graph},
                                                            indent=2) + "\n")

    def unrecorded_topics(self, node: Node) -> list[str]:
        """Published topics the recorder will record but does not subscribe to yet."""
        published = [(topic, types) for topic, types in node.get_topic_names_and_types()
                     if node.get_publishers_info_by_topic(topic)]
        return [topic for topic in topics_to_record(published, self.record_exclude, recordable_type)
                if not any(info.node_name == "recorder" for info in node.get_subscriptions_info_by_topic(topic))]

    def fly_mission(self, node: Node, executor: Executor) -> None:
        mission = self.scenario.mission
        goal = self.action_type.Goal()
        fill_message(goal, mission.goal, f"{self.scenario.path}: mission.goal")
        self.outcome.started_sim_s = sim_seconds(node)
        self.outcome.started_wall = time.monotonic()
        role = self.mission_role()
        role = self.process_of[role] if role else None
        # Counted before the goal goes out: a server that dies while the clock starts gets the goal again too.
        restarts = self.processes[role].restarts if role else 0
        handle = self.send_goal(executor, goal)
        if handle is None:
            return
        if self.stepped_with is not None:
            self.start_clock(node, executor)
        result_future = handle.get_result_async()
        self.outcome.cpu_at_start = self.cpu_seconds()
        wall_limit = mission.timeout_s / (self.options.rtf if math.isfinite(self.options.rtf) else 1.0) * 3.0 + 60.0
        watch = StallWatch(sim_seconds(node), time.monotonic())
        graph_checked = time.monotonic()
        while not result_future.done():
            executor.spin_once(timeout_sec=0.05)
            now_sim, now = sim_seconds(node), time.monotonic()
            elapsed_sim = now_sim - self.outcome.started_sim_s
            self.check_processes(starting=False)
            if now - graph_checked > GRAPH_CHECK_PERIOD_S:
                graph_checked = now
                self.check_single_graph(node)
            stalled = self.check_stall(watch, now_sim, now)
            if role and self.processes[role].restarts > restarts and not self.interrupted:
                # The goal died with the server: give the respawned one the mission again.
                restarts = self.processes[role].restarts
                self.say(f"\nre-sending the goal to the restarted {role}", always=True)
                handle = self.resend_goal(executor, goal, role)
                if handle is None:
                    return
                result_future = handle.get_result_async()
            if self.interrupted or stalled or elapsed_sim > mission.timeout_s or \
                    time.monotonic() - self.outcome.started_wall > wall_limit:
                if stalled:
                    self.outcome.message = f"stalled: {stalled}"
                elif not self.interrupted:
                    self.outcome.message = f"timeout after {elapsed_sim:.1f} s of sim time"
                cancel = handle.cancel_goal_async()
                deadline = time.monotonic() + 5.0
                while not (cancel.done() and result_future.done()) and time.monotonic() < deadline:
                    executor.spin_once(timeout_sec=0.05)
                break
        self.outcome.ended_sim_s = sim_seconds(node)
        self.outcome.ended_wall = time.monotonic()
        self.outcome.cpu_at_end = self.cpu_seconds()
        if result_future.done():
            result = result_future.result().result
            self.outcome.result = result
            self.outcome.success = bool(getattr(result, "success", False)) and not self.interrupted \
                and self.outcome.message == "not started"
            if self.outcome.message == "not started":
                self.outcome.message = getattr(result, "message", "")

    def check_stall(self, watch: StallWatch, sim_s: float, wall_s: float) -> str:
        """Say once per stall, after STALL_REPORT_S, who holds the clock up; the reason once the stall has lasted
        STALL_ABORT_S (the mission then ends), else "". A run in real time (hardware) has no clock to watch: only
        stopped processes are looked for."""
        if self.scenario.simulated and watch.advanced(sim_s, wall_s):
            return ""
        stuck_s = wall_s - watch.since_wall_s
        if stuck_s < STALL_REPORT_S:
            return ""
        stopped = stopped_processes(self.processes)
        if not self.scenario.simulated and not stopped:
            watch.since_wall_s = wall_s
            return ""
        held = f" ({'; '.join(stopped)})" if stopped else ""
        says = f"; {self.clock_source_says}" if self.clock_source_says else ""
        reason = f"sim time has not advanced for {stuck_s:.0f} s (wall) at {sim_s:.2f} s{held}{says}"
        if not watch.reported:
            watch.reported = True
            self.say(f"\n{reason}", always=True)
        return reason if stuck_s >= STALL_ABORT_S else ""

    def check_single_graph(self, node: Node) -> None:
        """A second graph in our domain (another run forced onto it, an orphan of an older one) shows as a second
        node of one of our names: end the run before the two mix (a ReadinessError)."""
        ours = {f"/{spec.name}" for spec in self.scenario.nodes.values() if spec.name}
        ours |= {f"/{role}" for role in (RECORDER_ROLE, node.get_name())}
        names = [f"{namespace.rstrip('/')}/{name}" for name, namespace in node.get_node_names_and_namespaces()]
        now = time.monotonic()
        twice = sorted(name for name in ours if names.count(name) > 1 and self.respawned_until.get(name, 0.0) < now)
        if twice:
            raise ReadinessError(f"another graph joined ROS domain {self.domain['id'] if self.domain else '?'}: "
                                 f"two nodes named {', '.join(twice)}; the run stops before the two mix")

    def send_goal(self, executor: Executor, goal: Any, timeout_s: float = READY_TIMEOUT_S):
        """The accepted goal's handle; None when interrupted; a ReadinessError when it is rejected or unanswered."""
        send = self.client.send_goal_async(goal, feedback_callback=self.on_feedback)
        self.spin_until(executor, send.done, timeout_s, "the goal to be accepted")
        if self.interrupted:
            return None
        handle = send.result()
        if not handle.accepted:
            role = self.mission_role()
            detail = f"\n{self.processes[self.process_of[role]].last_lines(5)}" if role else ""
            raise ReadinessError(f"goal rejected by {self.scenario.mission.action}{detail}")
        return handle

    def resend_goal(self, executor: Executor, goal: Any, role: str):
        """Send the goal to a respawned server. Until discovery drops the dead server (its DDS lease), the
        client may count it as available and a request can go unanswered: retry a few times."""
        self.spin_until(executor, self.client.server_is_ready, READY_TIMEOUT_S, f"the restarted {role}'s action server")
        for attempt in range(RESEND_ATTEMPTS):
            try:
                return self.send_goal(executor, goal, timeout_s=RESEND_TIMEOUT_S)
            except NodeExitedError:
                raise
            except ReadinessError:
                if attempt == RESEND_ATTEMPTS - 1:
                    raise
        return None

    def on_feedback(self, message) -> None:
        feedback = message.feedback
        self.outcome.feedback = feedback
        fields = feedback.get_fields_and_field_types()
        text = " ".join(f"{name}={format_value(getattr(feedback, name))}" for name in fields)
        milestone = getattr(feedback, "target_index", None) != getattr(self, "last_target_index", None)
        self.last_target_index = getattr(feedback, "target_index", None)
        self.progress.show(f"[{self.scenario.name}] {text}", milestone)

    def cpu_seconds(self) -> dict[str, float | None]:
        """CPU time so far of each node process and of this orchestrator (the mission's action client)."""
        own = psutil.Process().cpu_times()
        return {**{role: p.cpu_seconds() for role, p in self.processes.items()},
                "orchestrator": own.user + own.system}

    def mission_cpu(self) -> dict[str, Any] | None:
        """CPU used by the graph while the mission ran, per process and in total, as a percentage of one core.

        A process that exited or restarted during the mission has no figure (it is left out of the total)."""
        outcome = self.outcome
        if outcome.ended_wall is None or outcome.started_wall is None or not outcome.cpu_at_end:
            return None
        wall_s = outcome.ended_wall - outcome.started_wall
        used = {role: round(end - start, 3) if None not in (start, end) and end >= start else None
                for role in outcome.cpu_at_end
                for start, end in [(outcome.cpu_at_start.get(role), outcome.cpu_at_end[role])]}
        total = sum(value for value in used.values() if value is not None)
        return {"mission_wall_s": round(wall_s, 3), "cores": psutil.cpu_count(), "process_cpu_s": used,
                "graph_cpu_s": round(total, 3),
                "graph_cpu_percent_of_one_core": round(100.0 * total / wall_s, 1) if wall_s > 0 else None}

    def clock_summary(self) -> dict[str, Any]:
        """Which clock ran, and for the stepped clock who it waited for and which roles ran free beside it."""
        summary: dict[str, Any] = {"mode": self.clock}
        if self.stepped_with is not None:
            summary["participants"] = list(self.stepped_with)
            summary["free_running_roles"] = sorted(
                role for role, spec in self.scenario.nodes.items()
                if not spec.clock_source and f"/{spec.name}" not in self.stepped_with)
        return summary

    def mission_role(self) -> str | None:
        """The role serving the mission's action: the scenario's mission.server, else the first non-simulator."""
        if self.scenario.mission.server is not None:
            return self.scenario.mission.server
        return next((role for role, spec in self.scenario.nodes.items() if not spec.sim), None)

    def check_processes(self, starting: bool) -> None:
        for role, process in self.processes.items():
            code = process.poll()
            if code is None or process.popen is None:
                continue
            if process.respawn and process.restarts < process.max_respawns and not self.interrupted:
                self.say(f"\n{role} exited with code {code}; restarting ({process.restarts + 1}/"
                         f"{process.max_respawns})\n{process.last_lines(5)}", always=True)
                process.restarts += 1
                self.respawned_until.update({f"/{self.scenario.nodes[r].name}": time.monotonic() + RESPAWN_GRACE_S
                                             for r, key in self.process_of.items()
                                             if key == role and self.scenario.nodes[r].name})
                process.start()
                continue
            if starting or not process.respawn:
                process.popen = None if starting else process.popen
                raise NodeExitedError(f"node {role} exited with code {code}; last log lines:\n{process.last_lines()}")

    def all_last_lines(self) -> str:
        return "\n".join(f"  {role} ({'running' if p.running else f'exit {p.exit_code}'}):\n{p.last_lines(5)}"
                         for role, p in self.processes.items())

    def shut_down(self) -> None:
        for role, process in self.processes.items():
            if role != RECORDER_ROLE:
                process.stop(STOP_GRACE_S)
        if RECORDER_ROLE in self.processes:
            self.processes[RECORDER_ROLE].stop(3 * STOP_GRACE_S)

    # ----------------------------------------------------------------- results
    def write_summary(self) -> RunSummary:
        from rfidnav_bringup.report import run_metrics

        metrics: dict[str, Any] = {}
        bag = self.run_dir / "bag"
        if (bag / "metadata.yaml").exists():
            try:
                metrics = run_metrics(self.run_dir)
            except RfidnavError as error:
                self.say(f"metrics not computed: {error}", always=True)
        objection = ground_truth_objection(metrics)
        if self.outcome.success and objection is not None:
            # The mission's node can be fooled (a spoofed tag, a wrong map, a leg through a wall); ground truth,
            # which it never sees, has the last word on whether the run succeeded.
            self.outcome.success = False
            self.outcome.message = (f"{self.outcome.message or 'succeeded'}, says the mission's node; but ground "
                                    f"truth {objection}")
        sim_duration = None
        if self.outcome.started_sim_s is not None and self.outcome.ended_sim_s is not None:
            sim_duration = round(self.outcome.ended_sim_s - self.outcome.started_sim_s, 3)
        document = {
            "scenario": self.scenario.name,
            "success": self.outcome.success,
            "message": self.outcome.message,
            "seed": self.options.seed,
            "rtf": rtf_text(self.options.rtf),
            "clock": self.clock_summary(),
            "ros_domain": self.domain,
            "sim_duration_s": sim_duration,
            "wall_duration_s": round((self.outcome.ended_wall or time.monotonic()) - self.outcome.started_wall, 3)
            if self.outcome.started_wall else None,
            "metrics": metrics,
            "cpu": self.mission_cpu(),
            "nodes": {role: {"restarts": p.restarts, "exit_code": p.exit_code} for role, p in self.processes.items()},
            "bag": str(bag if bag.exists() else self.run_dir),
            "run_dir": str(self.run_dir),
        }
        try:
            write_atomically(self.run_dir / "summary.json", json.dumps(document, indent=2) + "\n")
        except OSError as error:   # a full disk, the folder gone: the run's outcome is still printed
            self.say(f"summary.json not written in {self.run_dir}: {error.strerror}", always=True)
        return RunSummary(self.run_dir, document)


@dataclass
class StallWatch:
    """When sim time last advanced (wall clock), and whether the present stall has been reported."""
    sim_s: float
    since_wall_s: float
    reported: bool = False

    def advanced(self, sim_s: float, wall_s: float) -> bool:
        if sim_s > self.sim_s:
            self.sim_s, self.since_wall_s, self.reported = sim_s, wall_s, False
            return True
        return False


def stopped_processes(processes: dict[str, NodeProcess]) -> list[str]:
    """'ROLE is stopped (pid N)' for every running process the OS has stopped (SIGSTOP, a debugger)."""
    found = []
    for role, process in processes.items():
        if process.running and process.popen is not None:
            try:
                status = psutil.Process(process.popen.pid).status()
            except psutil.Error:
                continue
            if status in (psutil.STATUS_STOPPED, psutil.STATUS_TRACING_STOP):
                found.append(f"{role} is stopped (pid {process.popen.pid})")
    return found


def topics_to_record(published: Iterable[tuple[str, list[str]]], exclude: Collection[str],
                     recordable: Callable[[str], bool]) -> list[str]:
    """Which published topics (name, types) the recorder records: the ones not excluded whose type it can
    store (it records a topic's first type), as recorder_node.RecorderNode.discover and add_topic decide."""
    return sorted(topic for topic, types in published if topic not in exclude and types and recordable(types[0]))


@functools.cache
def recordable_type(msgtype: str) -> bool:
    """Whether the recorder can record ``msgtype`` (the check its add_topic makes)."""
    try:
        recordable_definition(msgtype)
    except BagError:
        return False
    return True


def listens(process: NodeProcess, port: int) -> bool:
    """Whether ``process`` has a TCP socket listening on ``port`` (asked of the OS: no connection is made)."""
    if not process.running or process.popen is None:
        return False
    try:
        sockets = psutil.Process(process.popen.pid).net_connections(kind="tcp")
    except psutil.Error:
        return False
    return any(s.status == psutil.CONN_LISTEN and s.laddr and s.laddr.port == port for s in sockets)


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


def sim_seconds(node: Node) -> float:
    return node.get_clock().now().nanoseconds * 1e-9


def format_value(value: Any) -> str:
    return f"{value:+.3f}" if isinstance(value, float) else str(value)


def unique_dir(path: Path) -> Path:
    candidate, index = path, 1
    while candidate.exists():
        index += 1
        candidate = path.with_name(f"{path.name}_{index}")
    return candidate


def print_summary(summary: RunSummary) -> None:
    document = summary.document
    rows = [("scenario", document["scenario"]), ("success", document["success"]), ("message", document["message"]),
            ("sim duration [s]", document["sim_duration_s"]), ("wall duration [s]", document["wall_duration_s"])]
    rows += [(key, f"{value:.4f}" if isinstance(value, float) else value) for key, value in document["metrics"].items()]
    rows += [(f"node {role}", f"exit {info['exit_code']}, restarts {info['restarts']}")
             for role, info in document["nodes"].items()]
    if cpu := document.get("cpu"):
        rows.append(("graph CPU in mission", f"{cpu['graph_cpu_percent_of_one_core']}% of one core "
                                             f"({cpu['cores']} cores) over {cpu['mission_wall_s']} s"))
    rows += [("bag", document["bag"]), ("summary", str(summary.run_dir / "summary.json"))]
    width = max(len(str(key)) for key, _ in rows)
    for key, value in rows:
        print(f"  {str(key).ljust(width)}  {value}")
