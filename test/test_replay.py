"""Replay regression: heading_controller alone against a recorded run's /clock and /rfid/reads.

A run of line_follow_90 (the scenario's flc_tuned controller), started 2 m from the first tag to save time,
is recorded once for the module. Then the player stands in for the simulator roles, publishing only /clock
and /rfid/reads from that bag, and a fresh heading_controller process with the run's own parameter file and
map follows the run's goal; the /cmd_vel it sends is compared with the recorded one.

Why the commands can match exactly, and where they cannot: heading_controller steps on each round's own
stamp (header.stamp), never on its arrival time, and its core is deterministic, so a command is a pure
function of the sequence of rounds the node has processed. Replayed at any rate, over DDS, the same rounds
give bit-identical commands. What scheduling does change is *which* rounds each controller processed:

* the start: the recorded goal was accepted while the reader was already publishing (a round or two before
  it are lost to the recorded controller), whereas playback starts at the bag's first message after the goal
  is accepted; the first commands then differ while the 5-round phase filter and the range-rate average
  fill up (the replay sees one or two more rounds, so the two lists are aligned on their ends: both end on
  the round where the last floor tag is reached -- its first read or the closest approach in its phase --
  a function of the recorded reads alone);
* a round lost under load, by the recorded controller or the recorder, or in the replay (reliable, but the
  publishers and the controller keep the last 100 messages: a process stalled for longer than that loses
  some): the lists shift by one there and the few commands whose filter window holds that round differ.
  Losses in the replay are visible (fewer commands than the bag has rounds), so such a replay is run once
  more; with every round delivered the node must send exactly what its core computes in-process on them.

So the comparison is the longest common subsequence of the two command lists (drift of at most BAND commands
between them), two commands being equal when linear.x and angular.z both agree within TOLERANCE, and it
must cover MIN_MATCHED_FRACTION of the recorded commands. Measured on a busy 2-core machine (load ~4): the
replay matches 100% of ~1150 commands, while a regression changes nearly every command: a 2% lower fuzzy
output gain leaves 0.5% of the commands within the tolerance, the paper's parameter set 0.2% (it also arrives
~100 rounds earlier), another turn_speed_fraction (angular.z unchanged) 0.4%, a 4-round filter 2-3%. The last
test checks that on every run, with the controller's core in-process. Not reliably caught: a change confined
to the creep over the floor tags (approach_speed_fraction alone leaves 83-92% of the commands unchanged), nor
one to the receding-target guard or nominal_round_s, which rarely act on this route.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pytest
import rclpy
import yaml
from geometry_msgs.msg import Twist
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from rfidnav_bag.bags import bag_info, read_messages
from rfidnav_bringup.processes import DomainLease, NodeProcess
from rfidnav_common.config import parameters_from_mapping
from rfidnav_common.install import resolve_executable
from rfidnav_common.robot_map import load_route_map
from rfidnav_control.fuzzy import FuzzyHeadingController
from rfidnav_control.parameters import HeadingControllerParameters
from rfidnav_control.tag_route import TagObservation, TagRouteFollower, observe
from rfidnav_msgs.action import FollowTagRoute
from support.runs import WORKSPACE, recorded_commands

pytestmark = pytest.mark.tier("graph")

SCENARIO = WORKSPACE / "config/scenarios/line_follow_90.yaml"
RECORD_START = {"x": -1.5, "y": -1.5, "yaw_deg": 90.0}   # C1 at 2.1 m, 45 deg to the right
RECORD_RTF = 3.0          # the demo's: a busy 2-core machine keeps the closed loop on time there
PLAYBACK_RATE = 6.0       # bag seconds per wall second: ~8 s for the ~46 s run; 150 rounds/s
TOLERANCE = 1e-6          # [rad/s and m/s]: identical rounds give identical floats; a 5% lower fuzzy gain
                          # moves the median angular.z by ~7e-3 rad/s
BAND = 40                 # most commands by which the two lists may drift apart (lost rounds)
REPLAY_ATTEMPTS = 2       # a replay that lost rounds in transit is run once more
# ~115 of ~1150 commands may differ. The filter filling at the start costs a few; a round lost on either side
# costs about a filter length: ~6 commands, up to ~50 while flc_tuned creeps over a floor tag and averages
# 10x longer (offline, 7 rounds dropped at random leave 90-97%, 10 leave 89-96%). Every changed controller
# tried matches at most 4%, except one that changes only the creep over the floor tags (83-92%).
MIN_MATCHED_FRACTION = 0.90
WAIT_S = 60.0             # process start-up and DDS discovery on a loaded machine
Command = tuple[float, float]   # (linear.x [m/s], angular.z [rad/s])


# ------------------------------------------------------------------------------------------ the recording

def near_start_scenario(folder: Path) -> Path:
    """line_follow_90 from RECORD_START: the turn onto the route, the arrival and the 45 deg corner at C1 and
    the line to C2 in about two thirds of the sim time (the same nodes, parameters, world and map)."""
    document = yaml.safe_load(SCENARIO.read_text())
    document.update(name="line_follow_90_near", robot=RECORD_START,
                    world=str(SCENARIO.parent / document["world"]), map=str(SCENARIO.parent / document["map"]))
    for spec in document["nodes"].values():
        if "params" in spec:
            spec["params"] = str(SCENARIO.parent / spec["params"])
    path = folder / "line_follow_90_near.yaml"
    path.write_text(yaml.safe_dump(document, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("replay_runs")
    env = dict(os.environ)
    env.pop("ROS_DOMAIN_ID", None)   # the orchestrator leases its own domain
    result = subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "run", str(near_start_scenario(out)),
                             "--rtf", str(RECORD_RTF), "--seed", "1", "--out", str(out / "runs"), "--quiet"],
                            capture_output=True, text=True, timeout=600, cwd=WORKSPACE, env=env)
    runs = list((out / "runs").iterdir()) if (out / "runs").is_dir() else []
    assert result.returncode == 0 and len(runs) == 1, result.stdout + result.stderr
    return runs[0]


def recorded_route(run_dir: Path) -> list[str]:
    return list(yaml.safe_load((run_dir / "scenario.yaml").read_text())["mission"]["goal"]["tag_ids"])


# ------------------------------------------------------------------------------------------ the comparison

def matched_commands(recorded: Sequence[Command], replayed: Sequence[Command], tolerance: float = TOLERANCE,
                     band: int = BAND) -> int:
    """Length of the longest common subsequence of two command lists aligned on their ends, two commands being
    equal when both components agree within ``tolerance``; the alignment may drift by at most ``band``.

    Cells outside the band count as 0, so this is a lower bound of the unconstrained subsequence."""
    shift = len(replayed) - len(recorded)
    previous: dict[int, int] = {}
    for i, (linear, angular) in enumerate(recorded, start=1):
        row: dict[int, int] = {}
        for j in range(max(1, i + shift - band), min(len(replayed), i + shift + band) + 1):
            other_linear, other_angular = replayed[j - 1]
            if abs(linear - other_linear) <= tolerance and abs(angular - other_angular) <= tolerance:
                row[j] = previous.get(j - 1, 0) + 1
            else:
                row[j] = max(previous.get(j, 0), row.get(j - 1, 0))
        previous = row
    return max(previous.values(), default=0)


def describe(recorded: Sequence[Command], replayed: Sequence[Command], count: int = 8) -> str:
    """The first commands that differ, with the lists aligned on their ends."""
    shift = len(replayed) - len(recorded)
    rows = [f"{len(recorded)} recorded, {len(replayed)} replayed commands; first differences (end-aligned):"]
    for i, mine in enumerate(recorded):
        theirs = replayed[i + shift] if 0 <= i + shift < len(replayed) else None
        if theirs is None or max(abs(a - b) for a, b in zip(mine, theirs)) > TOLERANCE:
            rows.append(f"  #{i:<5d} recorded {mine}  replayed {theirs}")
            if len(rows) > count:
                break
    return "\n".join(rows)


# ------------------------------------------------------------------------------------------ the DDS replay

class ReplayProbe:
    """The test's side of the replay: a private context with an action client, the player's start service
    and a /cmd_vel subscription."""

    def __init__(self, domain_id: int, processes: list[NodeProcess]) -> None:
        self.processes = processes
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = Node("replay_probe", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.commands: list[Twist] = []
        # Deep enough for seconds of commands should this process stall at 150 rounds/s.
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.cmd_sub = self.node.create_subscription(Twist, "/cmd_vel", self.commands.append, qos)
        self.client = ActionClient(self.node, FollowTagRoute, "/follow_tag_route")
        self.start_client = self.node.create_client(Trigger, "/player/start")

    def spin_until(self, condition: Callable[[], bool], what: str, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while not condition():
            for process in self.processes:
                code = process.poll()
                # The player exits 0 at the end of the bag, which may come before the last result arrives.
                if code is not None and not (process.role == "player" and code == 0):
                    pytest.fail(f"{process.role} exited ({code}) while waiting for {what}:\n{process.last_lines()}")
            if time.monotonic() > deadline:
                logs = "\n".join(f"  {p.role}:\n{p.last_lines(6)}" for p in self.processes)
                pytest.fail(f"timed out after {timeout_s:.0f} s waiting for {what}\n{logs}")
            self.executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        self.executor.shutdown()
        self.client.destroy()   # destroy_node leaves action clients alive
        self.node.destroy_node()
        self.context.try_shutdown()
        self.context.destroy()


@dataclasses.dataclass
class Replay:
    commands: list[Command]
    result: Any


def replay_controller(run_dir: Path, logs: Path, params_file: Path | None = None) -> Replay:
    """heading_controller with the run's parameters (or ``params_file``) and map, fed the run's /clock and
    /rfid/reads."""
    bag = run_dir / "bag"
    params_file = params_file or run_dir / "params" / "heading_controller.yaml"
    lease = DomainLease()
    env = dict(os.environ, ROS_DOMAIN_ID=str(lease.domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0")
    player = NodeProcess("player", resolve_executable("rfidnav_bag", "player") + [
        "--ros-args", "-p", f"bag:={bag}", "-p", 'topics:=["/clock", "/rfid/reads"]',
        "-p", f"rate:={PLAYBACK_RATE}", "-p", "start_paused:=true",
        # Only the controller subscribes to these (the probe runs on the wall clock): playback waits for it.
        "-p", 'wait_for_subscribers:=["/clock", "/rfid/reads"]'], logs / "player.log", env)
    controller = NodeProcess("heading_controller", resolve_executable("rfidnav_control", "heading_controller") + [
        "--ros-args", "--params-file", str(params_file), "-p", f"map_file:={run_dir / 'map.yaml'}",
        "-p", "use_sim_time:=true"], logs / "heading_controller.log", env)
    processes = [player, controller]
    probe = ReplayProbe(lease.domain_id, processes)
    try:
        for process in processes:
            process.start()
        probe.spin_until(lambda: probe.client.server_is_ready() and probe.start_client.service_is_ready()
                         and probe.cmd_sub.get_publisher_count() > 0,
                         "the controller's action server and /cmd_vel, and the player's start service", WAIT_S)
        send = probe.client.send_goal_async(FollowTagRoute.Goal(tag_ids=recorded_route(run_dir)))
        probe.spin_until(send.done, "the goal to be accepted", WAIT_S)
        handle = send.result()
        assert handle.accepted, f"goal rejected:\n{controller.last_lines()}"
        # Only now: the first round must find the goal executing, as the recorded controller's did.
        start = probe.start_client.call_async(Trigger.Request())
        # Fast DDS may drop the response while the player has not yet matched the probe's response reader
        # ("failed to send response (timeout)"); the first command is proof enough that playback started.
        probe.spin_until(lambda: start.done() or bool(probe.commands), "the player to start", WAIT_S)
        result = handle.get_result_async()
        playback_s = bag_info(bag).duration_s / PLAYBACK_RATE
        probe.spin_until(result.done, "the route's result", 3.0 * playback_s + WAIT_S)
        # The stop command follows the last round's (also a stop) and precedes the result, on another topic.
        probe.spin_until(lambda: len(probe.commands) >= 2 and all(
            (c.linear.x, c.angular.z) == (0.0, 0.0) for c in probe.commands[-2:]), "the final stop command", 10.0)
        return Replay([(c.linear.x, c.angular.z) for c in probe.commands], result.result().result)
    finally:
        for process in processes:
            process.stop(5.0)
        probe.close()
        lease.close()


def test_replayed_controller_reproduces_the_recorded_cmd_vel(recorded_run: Path, tmp_path: Path) -> None:
    summary = json.loads((recorded_run / "summary.json").read_text())
    assert summary["success"], summary["message"]
    recorded = recorded_commands(recorded_run)
    rounds, route = recorded_rounds(recorded_run), recorded_route(recorded_run)
    # What the node must send when it gets every round of the bag: its core, in-process, on those rounds.
    ideal = core_commands(rounds, route, run_parameters(recorded_run))
    for attempt in range(1, REPLAY_ATTEMPTS + 1):
        replay = replay_controller(recorded_run, tmp_path / f"attempt_{attempt}")
        # Fewer commands than rounds: the player or the controller stalled for longer than their keep-last
        # queues hold (100 rounds, 0.67 s at 6x) and rounds were lost in transit. That is the machine, not
        # the controller; such a replay says little, so it is run again.
        if len(replay.commands) >= len(ideal):
            break
        warnings.warn(f"replay attempt {attempt} lost {len(ideal) - len(replay.commands)} of {len(ideal)} rounds "
                      "in transit (a process stalled)", stacklevel=1)

    assert replay.result.success, replay.result.message
    # The recorded run reached every tag (its goal succeeded); so must the replay, on the same rounds.
    assert replay.result.tags_reached == len(route), replay.result
    if len(replay.commands) == len(ideal):
        # Every round arrived: the node over DDS is exactly its core (no arrival-time or clock dependence).
        assert matched_commands(ideal, replay.commands) == len(ideal), describe(ideal, replay.commands)
    matched = matched_commands(recorded, replay.commands)
    assert matched >= MIN_MATCHED_FRACTION * len(recorded), (
        f"only {matched} of {len(recorded)} recorded commands replayed within {TOLERANCE:g}\n"
        + describe(recorded, replay.commands) + "\n" + losses(rounds, ideal, replay.commands))


def losses(rounds: list[tuple[float, list[TagObservation]]], ideal: Sequence[Command],
           replayed: Sequence[Command]) -> str:
    """Where rounds went missing, to tell lost messages from a changed controller in a failure message."""
    steps = sorted(b[0] - a[0] for a, b in zip(rounds, rounds[1:]))
    period = steps[len(steps) // 2]
    in_bag = sum(round(step / period) - 1 for step in steps if step > 1.5 * period)
    return (f"the bag misses {in_bag} rounds (lost by the recorder); the replay has {len(ideal) - len(replayed)} "
            f"fewer commands than the bag has rounds (lost in the replay) and matches "
            f"{matched_commands(ideal, replayed)} of the {len(ideal)} commands the core gives on the bag's rounds")


# ------------------------------------------------------------------------------------------ can it fail?

def run_parameters(run_dir: Path, **changes: Any) -> HeadingControllerParameters:
    """The run's resolved heading_controller parameters (without what the orchestrator injects)."""
    values = yaml.safe_load((run_dir / "params" / "heading_controller.yaml").read_text())
    values = values["heading_controller"]["ros__parameters"]
    fields = HeadingControllerParameters.__dataclass_fields__
    values = {key: value for key, value in values.items() if key in fields}
    values.update(map_file=str(run_dir / "map.yaml"), **changes)
    return parameters_from_mapping(HeadingControllerParameters, values, "test")


def recorded_rounds(run_dir: Path) -> list[tuple[float, list[TagObservation]]]:
    """(stamp, valid reads) of every recorded inventory round."""
    return [(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9,
             [o for o in (observe(r) for r in msg.readings) if o is not None])
            for _, _, msg in read_messages(run_dir / "bag", ["/rfid/reads"])]


def core_commands(rounds: list[tuple[float, list[TagObservation]]], route: list[str],
                  params: HeadingControllerParameters) -> list[Command]:
    """What heading_controller commands on the recorded rounds, computed in-process with its core."""
    follower = TagRouteFollower(params.follower_settings(), FuzzyHeadingController(params.fuzzy_spec()),
                                load_route_map(Path(params.map_file)).arrival_tags)
    follower.start(route, 0.0)
    commands: list[Command] = []
    for stamp_s, reads in rounds:
        command = follower.step(stamp_s, reads)
        commands.append((command.linear_mps, command.angular_radps))
        if follower.finished:
            return commands + [(0.0, 0.0)]   # the node's stop when the route ends
    return commands


def nudged(fraction: float, step: float) -> float:
    """Another value of a fraction in [0, 1]."""
    return fraction + step if fraction + step <= 1.0 else fraction - step


def test_the_comparison_catches_a_changed_controller(recorded_run: Path) -> None:
    """The tolerance and fraction above, applied to the recorded rounds run through the controller's core with
    the run's parameters (must match) and with changed ones (must not)."""
    recorded = recorded_commands(recorded_run)
    rounds, route = recorded_rounds(recorded_run), recorded_route(recorded_run)
    same = core_commands(rounds, route, run_parameters(recorded_run))
    assert matched_commands(recorded, same) >= MIN_MATCHED_FRACTION * len(recorded), describe(recorded, same)

    tuned = run_parameters(recorded_run)
    paper_file = yaml.safe_load((WORKSPACE / "config/params/flc_paper.yaml").read_text())
    paper = run_parameters(recorded_run, **paper_file["heading_controller"]["ros__parameters"])
    changed = {
        "flc_paper parameters": paper,
        "fuzzy output gain x0.9": dataclasses.replace(
            tuned, output_set_points=[0.9 * p for p in tuned.output_set_points]),
        "turn_speed_fraction (angular.z unchanged)": dataclasses.replace(
            tuned, turn_speed_fraction=nudged(tuned.turn_speed_fraction, 0.2)),
        "filter_rounds +1": dataclasses.replace(tuned, filter_rounds=tuned.filter_rounds + 1),
    }
    for name, params in changed.items():
        commands = core_commands(rounds, route, params)
        fraction = matched_commands(recorded, commands) / len(recorded)
        # Typically below 4%; more only in a run with long stretches of commands no parameter changes
        # (receding turns at the yaw-rate limit, unheard rounds).
        assert fraction < MIN_MATCHED_FRACTION, f"{name}: {fraction:.1%} of the commands still match"
