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

A run split between two computers (``RunOptions.part``, docs/running.md "One run on two computers"): the station's
orchestrator does all of the above for its roles and waits for the robot's; the robot's starts its roles (the
simulators and drivers, run_plan.part_of) in the same named domain and partition and keeps them running until the
station's orchestrator has left the graph.

Clocks (``RunOptions.clock``): ``stepped`` (the default for simulated runs) makes robot_sim wait, at every
publication, for the answers of our nodes of the simulated loop and the recorder (rfidnav_common.stepped_node);
drivers and nodes given as command lines run free beside them. ``free`` keeps the free-running clock at the
RTF. A run without the simulated base (hardware) runs in real time.

The Orchestrator coordinates (the domain, the context, the signals, the order of events, the mission's end); its
parts can each be used and tested alone, all in rfidnav_bringup: the run plan (run_plan: the clock, the run's folder,
the processes and their command lines; no rclpy), the supervisor (supervisor: starting, restarting and stopping the
processes), the graph watch (graph_watch: readiness, wiring, the clock start, stalls, a second graph), the mission
client (mission_client: the goal, its feedback, cancel, re-sending it to a respawned server) and the summary
(summary: summary.json, CPU accounting, its printed form).
"""

from __future__ import annotations

import functools
import math
import os
import signal
import sys
import time
from dataclasses import dataclass
from typing import Any

import rclpy
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from rfidnav_bringup.discovery_server import client_environment
from rfidnav_bringup.errors import LaunchError
from rfidnav_bringup.graph_watch import GraphWatch, StallWatch, Waiter
from rfidnav_bringup.mission_client import MissionClient
from rfidnav_bringup.partition import join_process_partition
from rfidnav_bringup.processes import (
    RUN_DOMAINS,
    DomainLease,
    NodeProcess,
    SharedDomain,
    child_environment,
    lock_folder,
    reach_text,
)
from rfidnav_bringup.run_plan import (
    LIVE_ROLE,
    RECORDER_ROLE,
    ROBOT_PART,
    ROBOT_PART_ORCHESTRATOR,
    RunOptions,
    RunPlan,
    rtf_text,
    run_id,
    unique_dir,
)
from rfidnav_bringup.summary import MissionOutcome, RunFacts, RunSummary, cpu_seconds, write_run_summary
from rfidnav_bringup.supervisor import Supervisor
from rfidnav_common.errors import RfidnavError
from rfidnav_common.process_signals import STOP_SIGNALS
from rfidnav_common.progress import StatusLine
from rfidnav_common.ros import events_executor, interface_class
from rfidnav_scenario.scenario import ORCHESTRATOR_NODE, MissionSpec, Scenario

GRAPH_CHECK_PERIOD_S = 1.0   # how often the mission loop looks for a second graph in the domain


@dataclass
class Flight:
    """One robot's mission in a run: its client, the process serving it and how it ended."""
    robot: str | None                # None: the one robot of a run without robots
    spec: MissionSpec                # its action resolved under the robot's namespace
    client: MissionClient
    server: str | None               # the process serving it
    outcome: MissionOutcome          # the run's, or the robot's in it
    goal: Any = None
    restarts: int = 0                # its server's restarts when the goal was last sent
    cancelled: bool = False          # its own timeout cancelled it


class Orchestrator:
    def __init__(self, scenario: Scenario, options: RunOptions) -> None:
        self.scenario = scenario
        self.options = options
        self.plan = RunPlan(scenario, options, unique_dir(options.out_dir / run_id(scenario.name)))
        self.run_dir = self.plan.run_dir
        self.say_now = functools.partial(self.say, always=True)   # what is said even with --quiet
        self.supervisor = Supervisor(self.say_now, lambda: self.interrupted, self.respawned)
        self.domain: dict[str, Any] | None = None    # the ROS domain and DDS partition it ran in
        self.watch: GraphWatch                        # from run(), once the orchestrator's node is in the domain
        self.outcome = MissionOutcome()
        self.progress = StatusLine(options.quiet)
        self.stop_signal: int | None = None       # the first of STOP_SIGNALS that came
        self.terminal_lost = False                 # SIGHUP on a terminal: nothing more is printed

    @property
    def processes(self) -> dict[str, NodeProcess]:
        return self.supervisor.processes

    def prepare(self, env: dict[str, str], lease_fd: int | None = None) -> None:
        self.supervisor.add(self.plan.write(), self.plan.log_path, env, lease_fd)

    def run(self) -> RunSummary:
        # First, before any DDS participant of this process: the partition that keeps foreign nodes out of the run.
        # A domain is then leased by its lock alone: a node in it that ignores our locks (a killed run's orphan,
        # another graph) cannot reach a partition of the run's own, so there is nothing to listen for. A partition
        # the caller chose may be shared (a test session's runs): then nodes already in the domain, in it, are
        # listened for as before.
        partition = join_process_partition(lock_folder(), self.options.partition)
        if self.options.part is not None and not partition.chosen_by_caller:
            raise LaunchError("--part: a split run's two parts meet in one DDS partition: give it with --partition "
                              "NAME, the same on both computers")
        candidates = RUN_DOMAINS if self.options.domain is None else range(self.options.domain,
                                                                           self.options.domain + 1)
        if self.options.part is not None:      # the other part's orchestrator joins the same domain
            lease: DomainLease | SharedDomain = SharedDomain(candidates.start)
        elif partition.chosen_by_caller:
            lease = DomainLease(candidates)
        else:
            lease = DomainLease(candidates, occupants=lambda _domain: [])
        self.domain = {"id": lease.domain_id, "partition": partition.name, "discovery": self.options.discovery}
        if lease.skipped:       # only in a caller's partition, whose other users may be in a domain
            self.domain["skipped"] = {str(d): nodes for d, nodes in lease.skipped.items()}
        env = child_environment(lease.domain_id, self.options.discovery)
        if self.options.discovery_server is not None:
            env.update(client_environment(*self.options.discovery_server))
        # This process's own participant, made next, finds the graph as its nodes do.
        os.environ.update({k: v for k, v in env.items() if k.startswith("ROS_")})
        context = Context()
        # rclpy's own handlers would shut the context down under the executor (SIGTERM): ours only set a flag.
        rclpy.init(context=context, domain_id=lease.domain_id, signal_handler_options=SignalHandlerOptions.NO)
        node = Node(ROBOT_PART_ORCHESTRATOR if self.options.part == ROBOT_PART else ORCHESTRATOR_NODE,
                    context=context,
                    parameter_overrides=[rclpy.parameter.Parameter("use_sim_time", value=self.scenario.simulated)])
        executor = events_executor(context)
        executor.add_node(node)
        waiter = Waiter(executor, functools.partial(self.supervisor.check, starting=True), lambda: self.interrupted,
                        self.supervisor.last_lines)
        self.watch = GraphWatch(node, waiter, self.plan.expected_graph(), lease.domain_id, self.say_now)
        previous_handlers = {signum: signal.signal(signum, self.on_stop_signal) for signum in STOP_SIGNALS}
        try:
            self.prepare(env, lease.handle)
            self.say(f"run {self.run_dir.name}: seed {self.options.seed}, RTF {rtf_text(self.options.rtf)}, "
                     f"{self.plan.clock} clock{self.plan.clock_note}")
            reach = reach_text(lease.domain_id, self.options.discovery, partition, self.options.discovery_server)
            self.say(f"graph on {reach}", always=True)
            if self.options.part == ROBOT_PART:
                self.serve_robot_part()
            else:
                flights = self.start_graph(node)
                if not self.interrupted:
                    self.fly_mission(flights)
        except RfidnavError as error:
            self.outcome.message = str(error)
            self.say(f"error: {error}", always=True)
        finally:
            self.progress.done()
            # Our handlers stay until the bag is closed and the summary written: a second signal must not cut that.
            self.supervisor.stop()
            executor.shutdown()
            # The mission's action client holds the node's handle and the node holds the client, a cycle: without
            # this, destroy_node leaves the node, and the context its DDS participant, until the garbage collector
            # breaks the cycle, and the next run in this process (bench rtf, a sweep) meets /rfidnav_orchestrator.
            for waitable in list(node.waitables):
                if isinstance(waitable, ActionClient):
                    waitable.destroy()
            node.destroy_node()
            rclpy.try_shutdown(context=context)
            # Destroyed, not only shut down: its DDS participant would stay in the domain.
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

    def say(self, text: str, always: bool = False) -> None:
        if self.terminal_lost or not (always or not self.options.quiet):
            return
        try:
            print(text, flush=True)
        except OSError:   # the output went away (a closed pipe, a terminal gone): the run goes on
            self.terminal_lost = True

    def start_graph(self, node: Node) -> list[Flight]:
        """Start the processes and wait until the graph is ready for the goals; each robot's mission with the
        client that will send its goal."""
        watch = self.watch
        if RECORDER_ROLE in self.processes:
            self.supervisor.start(recorder=True)
            watch.wait_for_nodes({RECORDER_ROLE}, "the recorder to join the graph")
        self.supervisor.start(recorder=False)
        expected = watch.expected.nodes
        watch.wait_for_nodes(expected, f"nodes {', '.join(sorted(expected))} to join the graph")
        if LIVE_ROLE in self.processes and self.options.live_port is not None:
            watch.wait_for_live_view(self.processes[LIVE_ROLE], self.options.live_port)
        flights = []
        for robot, spec in self.scenario.missions():
            label = f"{self.scenario.name}/{robot}" if robot else self.scenario.name
            client = MissionClient(node, interface_class(spec.action_type), spec.action, watch.waiter, self.progress,
                                   label, functools.partial(self.rejection_detail, robot))
            client.wait_for_server(f"action server {spec.action}")
            flights.append(Flight(robot, spec, client, self.plan.mission_process(robot),
                                  self.outcome if robot is None else self.outcome.robot(robot)))
        if RECORDER_ROLE in self.processes:
            watch.wait_for_recording()
        if self.plan.stepped_with is not None:
            watch.wait_for_wiring()
        watch.write_graph(self.run_dir / "graph.json")
        if self.plan.stepped_with is None:
            watch.start_clock()
        return flights

    def serve_robot_part(self) -> None:
        """The robot's computer of a split run (--part robot): start its roles, wait until the whole graph is up
        (the station's roles too), and keep its roles running while the station's orchestrator flies the mission,
        steps the clock and closes the bag; until that orchestrator has left the graph, or a signal."""
        watch = self.watch
        self.supervisor.start(recorder=False)
        expected = watch.expected.nodes
        watch.wait_for_nodes({*expected, ORCHESTRATOR_NODE},
                             f"nodes {', '.join(sorted(expected))} and the station's orchestrator to join the graph")
        self.say("robot part: its roles run; the station's orchestrator flies the mission", always=True)
        self.outcome.started_wall = time.monotonic()
        self.outcome.cpu_at_start = cpu_seconds(self.processes)
        stall = StallWatch(watch.sim_seconds(), time.monotonic())
        while not self.interrupted and ORCHESTRATOR_NODE in watch.node.get_node_names():
            watch.waiter.executor.spin_once(timeout_sec=0.05)
            self.supervisor.check(starting=False)
            if watch.sim_seconds() > 0.0:     # once the station has started the clock; a stall is said, not acted on
                watch.check_stall(stall, watch.sim_seconds(), time.monotonic(), self.processes)
        self.outcome.ended_wall = time.monotonic()
        self.outcome.cpu_at_end = cpu_seconds(self.processes)
        if not self.interrupted:
            # Its run ended, or its DDS lease did (20 s without a word: the link to it is down for good).
            self.outcome.success, self.outcome.message = True, "the station's orchestrator left the graph"

    def fly_mission(self, flights: list[Flight]) -> None:
        """Send every robot's goal, start the clock and follow the missions until each has its result (or the run
        ends: a signal, a stall, the wall limit; a robot's own timeout cancels its goal alone)."""
        watch = self.watch
        for flight in flights:
            where = f"{self.scenario.path}: " + (f"robots[{flight.robot}].mission.goal" if flight.robot
                                                 else "mission.goal")
            flight.goal = flight.client.goal(flight.spec.goal, where)
        self.outcome.started_sim_s = watch.sim_seconds()
        self.outcome.started_wall = time.monotonic()
        for flight in flights:
            # Counted before the goal goes out: a server that dies while the clock starts gets the goal again too.
            flight.restarts = self.supervisor.restarts(flight.server) if flight.server else 0
            if not flight.client.send(flight.goal):
                return
        if self.plan.stepped_with is not None:
            watch.start_clock()
        self.outcome.cpu_at_start = cpu_seconds(self.processes)
        timeout_s = max(flight.spec.timeout_s for flight in flights)
        wall_limit = timeout_s / (self.options.rtf if math.isfinite(self.options.rtf) else 1.0) * 3.0 + 60.0
        stall = StallWatch(watch.sim_seconds(), time.monotonic())
        graph_checked = time.monotonic()
        while not all(flight.client.done for flight in flights):
            watch.waiter.executor.spin_once(timeout_sec=0.05)
            now_sim, now = watch.sim_seconds(), time.monotonic()
            elapsed_sim = now_sim - self.outcome.started_sim_s
            self.supervisor.check(starting=False)
            if now - graph_checked > GRAPH_CHECK_PERIOD_S:
                graph_checked = now
                for flight in flights:
                    flight.client.ask_result_again()
                watch.check_single_graph()
            stalled = watch.check_stall(stall, now_sim, now, self.processes)
            for flight in flights:
                if flight.client.done:
                    continue
                server = flight.server
                if server and self.supervisor.restarts(server) > flight.restarts and not self.interrupted:
                    # The goal died with the server: give the respawned one the mission again.
                    flight.restarts = self.supervisor.restarts(server)
                    self.say(f"\nre-sending the goal to the restarted {server}", always=True)
                    if not flight.client.resend(flight.goal, server):
                        return
                if flight.robot is not None and elapsed_sim > flight.spec.timeout_s and not flight.cancelled:
                    flight.outcome.message = f"timeout after {elapsed_sim:.1f} s of sim time"
                    flight.cancelled = True
                    flight.client.cancel()
            if self.interrupted or stalled or elapsed_sim > timeout_s or \
                    time.monotonic() - self.outcome.started_wall > wall_limit:
                if stalled:
                    self.outcome.message = f"stalled: {stalled}"
                elif not self.interrupted:
                    self.outcome.message = f"timeout after {elapsed_sim:.1f} s of sim time"
                for flight in flights:
                    if not flight.client.done and not flight.cancelled:
                        if flight.robot is not None:
                            flight.outcome.message = self.outcome.message
                        flight.client.cancel(wait=not self.interrupted)
                break
        done = all(flight.client.done for flight in flights)
        if done and self.plan.stepped_with is not None:
            watch.settle()    # the observers' last outputs (they may lag the loop) reach the bag
        self.outcome.ended_sim_s = watch.sim_seconds()
        self.outcome.ended_wall = time.monotonic()
        self.outcome.cpu_at_end = cpu_seconds(self.processes)
        for flight in flights:
            flight.outcome.feedback = flight.client.feedback
            if flight.client.done:
                flight.outcome.conclude(flight.client.result(), self.interrupted)
        if self.outcome.robots:
            self.outcome.conclude_robots(self.interrupted)

    def respawned(self, process: str) -> None:
        self.watch.respawned(self.plan.node_names_of(process))

    def rejection_detail(self, robot: str | None = None) -> str:
        """The last lines of ``robot``'s mission's server, for a rejected goal."""
        server = self.plan.mission_process(robot)
        return f"\n{self.processes[server].last_lines(5)}" if server else ""

    def write_summary(self) -> RunSummary:
        if self.domain is not None and hasattr(self, "watch"):
            self.domain["kept_out"] = self.watch.kept_out_counts()
        facts = RunFacts(self.scenario.name, self.options.seed, rtf_text(self.options.rtf),
                         self.plan.clock_summary(), self.domain)
        return write_run_summary(self.run_dir, facts, self.outcome, self.processes, self.say_now, self.interrupted)
