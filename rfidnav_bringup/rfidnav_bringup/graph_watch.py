"""The run's graph as the orchestrator's node sees it: waiting until it is ready (the nodes have joined, the recorder
subscribes to every topic it will record, the participants of the stepped clock are wired), starting the simulation
clock, and while the mission runs watching for a clock that stalls and for a second graph in the domain.

Every wait is a :class:`Waiter`'s: it spins the executor until its condition holds, checking between spins that no
node died and whether the run is stopping, and on timeout names what it waited for and every process's last lines.
"""

from __future__ import annotations

import functools
import json
import time
from collections import Counter
from collections.abc import Callable, Collection, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import psutil
from rcl_interfaces.msg import Log
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.task import Future
from std_srvs.srv import Trigger

from rfidnav_bag.errors import BagError
from rfidnav_bag.recorder_node import recordable_definition
from rfidnav_bringup.errors import NodeExitedError, ReadinessError
from rfidnav_bringup.partition import UNKNOWN_NODE_NAME
from rfidnav_bringup.processes import NodeProcess
from rfidnav_bringup.run_plan import RECORDER_ROLE, ExpectedGraph

READY_TIMEOUT_S = 90.0
RESEND_ATTEMPTS = 6
RESEND_TIMEOUT_S = 5.0
GRAPH_RECHECK_S = 1.0   # a name seen twice is looked at again this much later before the run is stopped
# A publisher of ours shows with no node name only until discovery brings its node's name (well under a second on
# one machine, seconds on a loaded one); one still unnamed after this is outside the run's DDS partition.
KEPT_OUT_AFTER_S = 10.0
# Topics every ROS node publishes (a viewer's, a CLI's): no sign of a foreign publisher of the run's messages.
EVERY_NODE_TOPICS = frozenset({"/rosout", "/parameter_events"})
# Wall time the graph may take after the mission to handle what it lags behind: an observer up to OBSERVER_SLACK
# messages per input (its callbacks, a localizer's 4 ms each, at most a few seconds on a loaded machine).
SETTLE_TIMEOUT_S = 60.0
STALL_REPORT_S = 5.0      # wall time without sim-time progress after which the run says who holds it up
STALL_ABORT_S = 60.0      # ... and after which it ends the mission as stalled
RESPAWN_GRACE_S = 30.0    # a killed node stays in the graph until its DDS lease ends (Fast DDS: 20 s)


@dataclass
class Waiter:
    """Spins ``executor`` until a condition holds."""
    executor: Executor
    check: Callable[[], None]               # between spins: raises NodeExitedError when a node died
    stopping: Callable[[], bool]            # the run is stopping: a wait ends without its condition
    last_lines: Callable[[], str]           # every process's last log lines, for a timeout's message

    def spin_until(self, condition: Callable[[], bool], timeout_s: float, what: str | Callable[[], str]) -> None:
        """Spin until ``condition()`` holds; fail naming ``what`` (a text, or a function giving it at the
        timeout) and any node that died meanwhile."""
        deadline = time.monotonic() + timeout_s
        while not condition():
            self.check()
            if self.stopping():
                return
            if time.monotonic() > deadline:
                waited_for = what() if callable(what) else what
                raise ReadinessError(f"timed out after {timeout_s:.0f} s waiting for {waited_for}\n"
                                     f"{self.last_lines()}")
            self.executor.spin_once(timeout_sec=0.05)


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


@dataclass
class GraphWatch:
    node: Node                              # the orchestrator's node: the graph as it sees it
    waiter: Waiter
    expected: ExpectedGraph
    domain_id: int
    say: Callable[[str], None]              # what the run tells at once (a stall)
    clock_source_says: str = ""             # the clock source's last warning on /rosout
    # Nodes of a respawned process, and until when (wall): the dead one stays in the graph until its DDS lease
    # ends, so two of the name are expected for that long.
    respawned_until: dict[str, float] = field(default_factory=dict)
    seen_twice: set[str] = field(default_factory=set)    # our names the last check saw twice
    # Publishers with no node name, by endpoint GID: (topic, when first seen, wall). One still unnamed after
    # KEPT_OUT_AFTER_S is outside the run's DDS partition: kept out, counted for the summary.
    unnamed_since: dict[tuple[int, ...], tuple[str, float]] = field(default_factory=dict)
    kept_out: dict[tuple[int, ...], str] = field(default_factory=dict)
    # Publishers seen with a node name: ours. A participant of ours found again after its DDS lease ended (a paused
    # process) shows its endpoints, same GIDs, nameless for a while: they are not outside the partition.
    named: set[tuple[int, ...]] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.node.create_subscription(Log, "/rosout", self.on_log, 100)

    def on_log(self, message: Log) -> None:
        if message.name == self.expected.clock_source and message.level >= Log.WARN:
            self.clock_source_says = message.msg

    def sim_seconds(self) -> float:
        return self.node.get_clock().now().nanoseconds * 1e-9

    # ----------------------------------------------------------------- readiness
    def wait_for_nodes(self, names: Collection[str], what: str) -> None:
        """Until every one of ``names`` (with its namespace, no leading slash: ``r1/wall_follower``) is in the graph."""
        self.waiter.spin_until(lambda: set(names) <= set(self.node_paths()), READY_TIMEOUT_S, what)

    def node_paths(self) -> list[str]:
        """The graph's nodes, each with its namespace and without the leading slash (``robot_sim``,
        ``r1/wall_follower``), once per node found."""
        return [f"{namespace.rstrip('/')}/{name}".lstrip("/")
                for name, namespace in self.node.get_node_names_and_namespaces()]

    def wait_for_live_view(self, process: NodeProcess, port: int) -> None:
        """Wait until the live view (``process``) listens on ``port``, then say where to connect."""
        from rfidnav_bag.live_view import DEFAULT_HOST, ws_url  # only with --live: it loads foxglove (~0.25 s)

        self.waiter.spin_until(lambda: listens(process, port), READY_TIMEOUT_S,
                               f"the live view to listen on port {port}")
        self.say(f"live view: {ws_url(DEFAULT_HOST, port)} (Foxglove: Open connection -> Foxglove WebSocket)")

    def wait_for_recording(self) -> None:
        self.waiter.spin_until(lambda: not self.unrecorded_topics(), READY_TIMEOUT_S,
                               lambda: f"the recorder to subscribe to {', '.join(self.unrecorded_topics())}")

    def unrecorded_topics(self) -> list[str]:
        """Published topics the recorder will record but does not subscribe to yet."""
        node = self.node
        published = [(topic, types) for topic, types in node.get_topic_names_and_types()
                     if node.get_publishers_info_by_topic(topic)]
        return [topic for topic in topics_to_record(published, self.expected.record_exclude, recordable_type)
                if not any(info.node_name == RECORDER_ROLE for info in node.get_subscriptions_info_by_topic(topic))]

    def wait_for_wiring(self) -> None:
        """Before the goal, which the mission's server answers at once (with the stepped clock, before the clock
        starts): the clock source's ledger has every participant's report and every publisher and subscription of
        theirs matched with the participants on the other side of its topic (``~/wired``). A message sent before
        both sides have matched is lost, and its consumer would hold the clock for ever."""
        self.ask_clock_source("wired", READY_TIMEOUT_S, "the participants' publishers and subscriptions to match")

    def settle(self) -> None:
        """After the mission, with the stepped clock: stop the clock and wait until every participant has handled
        everything published (``~/settle``), the observers' and the recorder's slack included, so that what they
        publish of the mission's last steps is in the bag whatever the machine's load."""
        self.ask_clock_source("settle", SETTLE_TIMEOUT_S, "every participant to handle the mission's last messages")

    def ask_clock_source(self, service: str, timeout_s: float, what: str) -> None:
        """Call the clock source's Trigger ``service`` until it answers success (its message says what it waits
        for meanwhile). A call unanswered for RESEND_TIMEOUT_S is made again: Fast DDS can lose a service
        exchange (as ~/start's, below), and one lost answer would otherwise hold the run until ``timeout_s``. The
        services only report, so asking twice changes nothing."""
        client = self.node.create_client(Trigger, f"/{self.expected.clock_source}/{service}")
        answer: dict[str, str] = {}
        pending: list[tuple[Future, float]] = []

        def ask() -> bool:
            if pending and pending[0][0].done():
                result = pending.pop()[0].result()
                if result is not None and result.success:
                    return True
                answer["waiting"] = result.message if result is not None else "no answer"
            elif pending and time.monotonic() - pending[0][1] > RESEND_TIMEOUT_S:
                client.remove_pending_request(pending.pop()[0])
            if not pending and client.service_is_ready():
                pending.append((client.call_async(Trigger.Request()), time.monotonic()))
            return False

        try:
            self.waiter.spin_until(ask, timeout_s,
                                   lambda: f"{what}: {answer.get('waiting', 'no answer yet from the clock source')}")
        finally:
            self.node.destroy_client(client)

    def start_clock(self) -> None:
        if self.expected.clock_source is None:
            return
        start = self.node.create_client(Trigger, f"/{self.expected.clock_source}/start")
        self.waiter.spin_until(start.service_is_ready, READY_TIMEOUT_S, "the simulation clock service")
        # ~/start is idempotent: ask again if the request or its answer was lost (Fast DDS can drop a
        # service exchange right after service_is_ready()). The clock running is the answer that counts.
        for attempt in range(RESEND_ATTEMPTS):
            start.call_async(Trigger.Request())
            try:
                self.waiter.spin_until(lambda: self.node.get_clock().now().nanoseconds > 0, RESEND_TIMEOUT_S,
                                       "the simulation clock to start (the first /clock message)")
                break
            except NodeExitedError:   # final: asking again would swallow it (its process is forgotten)
                raise
            except ReadinessError:
                if attempt == RESEND_ATTEMPTS - 1:
                    raise

    def write_graph(self, path: Path) -> None:
        """graph.json: who publishes and subscribes what once the graph is ready (checked by the tests:
        no navigation node may subscribe to /sim/*)."""
        node = self.node
        graph: dict[str, dict[str, list[str]]] = {}
        for name, namespace in node.get_node_names_and_namespaces():
            if name == node.get_name():
                continue
            graph[f"{namespace.rstrip('/')}/{name}".lstrip("/")] = {
                "subscriptions": sorted(t for t, _ in node.get_subscriber_names_and_types_by_node(name, namespace)),
                "publishers": sorted(t for t, _ in node.get_publisher_names_and_types_by_node(name, namespace))}
        path.write_text(json.dumps({"simulator_nodes": list(self.expected.simulators), "nodes": graph},
                                   indent=2) + "\n")

    # ----------------------------------------------------------------- while the mission runs
    def respawned(self, names: Iterable[str]) -> None:
        """``names`` (with their leading slash) were restarted: two of each are expected for RESPAWN_GRACE_S."""
        self.respawned_until.update({name: time.monotonic() + RESPAWN_GRACE_S for name in names})

    def check_stall(self, watch: StallWatch, sim_s: float, wall_s: float,
                    processes: Mapping[str, NodeProcess]) -> str:
        """Say once per stall, after STALL_REPORT_S, who holds the clock up; the reason once the stall has lasted
        STALL_ABORT_S (the mission then ends), else "". A run in real time (hardware) has no clock to watch: only
        stopped processes are looked for."""
        if self.expected.simulated and watch.advanced(sim_s, wall_s):
            return ""
        stuck_s = wall_s - watch.since_wall_s
        if stuck_s < STALL_REPORT_S:
            return ""
        stopped = stopped_processes(processes)
        if not self.expected.simulated and not stopped:
            watch.since_wall_s = wall_s
            return ""
        if stopped:
            held = f" ({'; '.join(stopped)})"
        elif self.expected.elsewhere:     # a split run: the rest of the graph is out of sight
            held = (f" (nothing stopped here; {', '.join(self.expected.elsewhere)} run on the other computer: is the "
                    "link to it down?)")
        else:
            held = ""
        says = f"; {self.clock_source_says}" if self.clock_source_says else ""
        reason = f"sim time has not advanced for {stuck_s:.0f} s (wall) at {sim_s:.2f} s{held}{says}"
        if not watch.reported:
            watch.reported = True
            self.say(f"\n{reason}")
        return reason if stuck_s >= STALL_ABORT_S else ""

    def check_single_graph(self) -> None:
        """A second graph in our domain (another run forced onto it, an orphan of an older one) shows as a second
        node of one of our names, a foreign one (a tester's injector, a teleop) as a publisher of a node not ours on
        one of the domain's topics: end the run before the two mix (a ReadinessError naming them). With a role
        whose node name the run does not know (a command line without ``name``), no publisher is called foreign."""
        ours = self.our_names()
        names = [f"/{path}" for path in self.node_paths()]
        now = time.monotonic()
        twice = {name for name in ours if names.count(name) > 1 and self.respawned_until.get(name, 0.0) < now}
        # Seen twice at two checks in a row: discovery can show one node twice for a moment when a participant's
        # lease ends and it is found again (a process paused, a loaded machine); a second graph stays.
        confirmed, self.seen_twice = sorted(twice & self.seen_twice), twice
        if confirmed:
            raise ReadinessError(f"another graph joined ROS domain {self.domain_id}: "
                                 f"two nodes named {', '.join(confirmed)}; the run stops before the two mix")
        # With a role of unknown name, a publisher of a name not ours may be the run's: none is called foreign, but
        # the publishers its partition keeps out are counted all the same.
        foreign = self.foreign_publishers(ours)
        if foreign and not self.expected.unnamed_roles:
            raise ReadinessError(f"a publisher not of this run joined ROS domain {self.domain_id}: "
                                 f"{'; '.join(foreign)}; the run stops before its messages mix with the run's")

    def check_single_graph_now(self) -> None:
        """:meth:`check_single_graph`, a second time after GRAPH_RECHECK_S when a name shows twice (before the goal:
        an orphan must not be sent it)."""
        self.check_single_graph()
        if self.seen_twice:
            until = time.monotonic() + GRAPH_RECHECK_S
            self.waiter.spin_until(lambda: time.monotonic() >= until, 2 * GRAPH_RECHECK_S + READY_TIMEOUT_S,
                                   "a second look at the graph")
            self.check_single_graph()

    def our_names(self) -> set[str]:
        """The run's node names, with their leading slash: the scenario's, its helpers', the recorder's and the
        orchestrator's."""
        return {f"/{name}" for name in (*self.expected.nodes, *self.expected.helpers, RECORDER_ROLE,
                                         self.node.get_name())}

    def foreign_publishers(self, ours: Collection[str]) -> list[str]:
        """'NODE on TOPIC' for each publisher of a node not ``ours`` on a topic of the domain, but the ones every
        node has (/rosout, /parameter_events), and but endpoints whose node DDS has not named: a node outside the
        run's DDS partition, which cannot reach the run (counted by :meth:`note_unnamed`), or one of ours for the
        moment before its name is discovered."""
        node = self.node
        found = set()
        unnamed = {}
        for topic, _ in node.get_topic_names_and_types():
            if topic in EVERY_NODE_TOPICS:
                continue
            for info in node.get_publishers_info_by_topic(topic):
                name = f"{info.node_namespace.rstrip('/')}/{info.node_name}"
                if info.node_name == UNKNOWN_NODE_NAME:
                    unnamed[tuple(info.endpoint_gid)] = topic
                    continue
                self.named.add(tuple(info.endpoint_gid))
                if name not in ours:
                    found.add(f"{name} on {topic}")
        self.note_unnamed(unnamed, time.monotonic())
        return sorted(found)

    def note_unnamed(self, unnamed: Mapping[tuple[int, ...], str], now: float) -> None:
        """Publishers with no node name now (GID: topic): one unnamed for KEPT_OUT_AFTER_S is kept out, said once."""
        self.unnamed_since = {gid: self.unnamed_since.get(gid, (topic, now)) for gid, topic in unnamed.items()
                              if gid not in self.named}
        for gid, (topic, since) in self.unnamed_since.items():
            if now - since >= KEPT_OUT_AFTER_S and gid not in self.kept_out:
                self.kept_out[gid] = topic
                self.say(f"\na publisher on {topic} not of this run is in ROS domain {self.domain_id}: kept out by "
                         "the run's DDS partition")

    def kept_out_counts(self) -> dict[str, int]:
        """Publishers outside the run's partition seen in its domain, by topic (none of their messages came in)."""
        return dict(sorted(Counter(self.kept_out.values()).items()))


def stopped_processes(processes: Mapping[str, NodeProcess]) -> list[str]:
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
