"""The supervisor of a run's processes (rfidnav_bringup.supervisor) alone, with plain Python processes for nodes: the
recorder starts apart from the others and stops last, a process that may respawn is restarted (and its restart told)
until it may not, any other exit ends the run naming the process and its last lines."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import pytest

from rfidnav_bringup import supervisor as supervisor_module
from rfidnav_bringup.errors import NodeExitedError
from rfidnav_bringup.processes import NodeProcess, stop_together
from rfidnav_bringup.run_plan import RECORDER_ROLE, ProcessPlan
from rfidnav_bringup.supervisor import Supervisor
from rfidnav_common.install import resolve_executable
from rfidnav_common.process_signals import STACK_DUMP_SIGNAL

pytestmark = pytest.mark.tier("graph")

EXITS = [sys.executable, "-c", "print('no map'); raise SystemExit(3)"]
RUNS = [sys.executable, "-c", "import time; time.sleep(600)"]
# A node that hangs in its teardown: deaf to SIGINT, its stacks written on STACK_DUMP_SIGNAL as run_node's are.
HANGS = [sys.executable, "-c", f"""
import faulthandler, signal, time
def hang_in_teardown():
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    faulthandler.register({int(STACK_DUMP_SIGNAL)}, all_threads=True)
    print("hanging", "now", flush=True)   # not the text of the command, which the log begins with
    time.sleep(600)
hang_in_teardown()
"""]


def log_says(process: NodeProcess, text: str, timeout_s: float = 60.0) -> bool:
    """Whether ``process``'s log says ``text`` within ``timeout_s`` (while it runs)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and process.running:
        if text in process.log_path.read_text(errors="replace"):
            return True
        time.sleep(0.1)   # polling a file another process writes; nothing else tells
    return text in process.log_path.read_text(errors="replace")


class Supervised:
    def __init__(self, tmp_path: Path, *plans: ProcessPlan, stopping: bool = False) -> None:
        self.said: list[str] = []
        self.respawned: list[str] = []
        self.supervisor = Supervisor(self.said.append, lambda: stopping, self.respawned.append)
        self.supervisor.add(plans, lambda name: tmp_path / f"{name}.log", {})

    def exited(self, name: str) -> None:
        """Wait until the process ``name`` has exited (its restarts included: the one running now)."""
        assert self.supervisor.processes[name].wait(30.0), f"{name} did not exit"

    def __enter__(self) -> Supervisor:
        return self.supervisor

    def __exit__(self, *_exc: object) -> None:
        self.supervisor.stop()


def test_the_recorder_starts_apart_from_the_other_processes(tmp_path: Path) -> None:
    with Supervised(tmp_path, ProcessPlan(RECORDER_ROLE, RUNS), ProcessPlan("heading_controller", RUNS)) as supervisor:
        supervisor.start(recorder=True)
        assert [p.running for p in supervisor.processes.values()] == [True, False]
        supervisor.start(recorder=False)
        assert all(p.running for p in supervisor.processes.values())


def test_the_recorder_stops_after_every_other_process(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    stopped: list[tuple[list[str], float]] = []
    monkeypatch.setattr(supervisor_module, "stop_together",
                        lambda processes, grace_s: stopped.append(([p.role for p in processes], grace_s)) or [])
    supervised = Supervised(tmp_path, *(ProcessPlan(name, RUNS) for name in (RECORDER_ROLE, "simulator", "controller")))
    supervised.supervisor.stop()
    assert [roles for roles, _ in stopped] == [["simulator", "controller"], [RECORDER_ROLE]]   # the nodes together
    assert stopped[-1][1] > stopped[0][1]   # the recorder has longer to close the bag


def test_while_the_graph_starts_a_respawning_process_is_restarted_and_its_last_exit_ends_the_run(
        tmp_path: Path) -> None:
    supervised = Supervised(tmp_path, ProcessPlan("heading_controller", EXITS, respawn=True, max_respawns=1))
    with supervised as supervisor:
        supervisor.start(recorder=False)
        supervised.exited("heading_controller")
        supervisor.check(starting=True)
        assert supervisor.restarts("heading_controller") == 1
        supervised.exited("heading_controller")
        with pytest.raises(NodeExitedError, match="node heading_controller exited with code 3; last log lines:\n"
                                                  "(.*\n)* +no map$"):
            supervisor.check(starting=True)
        supervisor.check(starting=True)   # told once: the exited process is forgotten


def test_a_respawning_process_is_restarted_until_its_respawns_are_spent(tmp_path: Path) -> None:
    supervised = Supervised(tmp_path, ProcessPlan("heading_controller", EXITS, respawn=True, max_respawns=2))
    with supervised as supervisor:
        supervisor.start(recorder=False)
        for restart in (1, 2):
            supervised.exited("heading_controller")
            supervisor.check(starting=False)
            assert supervisor.restarts("heading_controller") == restart
        assert supervised.respawned == ["heading_controller", "heading_controller"]
        assert supervised.said[0].startswith("\nheading_controller exited with code 3; restarting (1/2)\n")
        supervised.exited("heading_controller")
        supervisor.check(starting=False)   # spent: the run goes on without it
        assert supervisor.restarts("heading_controller") == 2 and len(supervised.said) == 2


def test_no_process_is_restarted_once_the_run_stops(tmp_path: Path) -> None:
    supervised = Supervised(tmp_path, ProcessPlan("heading_controller", EXITS, respawn=True, max_respawns=2),
                            stopping=True)
    with supervised as supervisor:
        supervisor.start(recorder=False)
        supervised.exited("heading_controller")
        supervisor.check(starting=False)
        assert supervisor.restarts("heading_controller") == 0 and supervised.respawned == []


@pytest.mark.parametrize("starting", [True, False])
def test_an_exit_of_a_process_that_may_not_respawn_ends_the_run_naming_it(tmp_path: Path, starting: bool) -> None:
    supervised = Supervised(tmp_path, ProcessPlan("simulator", EXITS))
    with supervised as supervisor:
        supervisor.start(recorder=False)
        supervised.exited("simulator")
        with pytest.raises(NodeExitedError,
                           match="node simulator exited with code 3; last log lines:\n(.*\n)* +no map$"):
            supervisor.check(starting=starting)
        assert "simulator (exit 3):" in supervisor.last_lines()


def test_a_process_that_does_not_stop_in_its_grace_period_is_killed_and_said_with_its_stack_in_its_log(
        tmp_path: Path) -> None:
    supervised = Supervised(tmp_path, ProcessPlan("mission_executor", HANGS))
    supervised.supervisor.start(recorder=False)
    process = supervised.supervisor.processes["mission_executor"]
    assert log_says(process, "hanging now"), process.log_path.read_text()
    supervised.supervisor.stop()
    assert process.exit_code == -signal.SIGKILL
    assert supervised.said == [f"mission_executor did not stop within its grace period and was killed; its threads' "
                               f"stacks are at the end of {process.log_path}"]
    log = process.log_path.read_text()
    assert "(most recent call first)" in log and "in hang_in_teardown" in log, log


@pytest.mark.tier("graph")
def test_a_node_writes_its_threads_stacks_to_its_log_on_the_stack_dump_signal_and_runs_on(
        domain: int, tmp_path: Path) -> None:
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0")
    process = NodeProcess("wall_follower", resolve_executable("rfidnav_control", "wall_follower"),
                          tmp_path / "wall_follower.log", env)
    process.start()
    try:
        assert log_says(process, "idle until commanded"), process.log_path.read_text()
        process.signal(STACK_DUMP_SIGNAL)
        assert log_says(process, "in spin_until_shutdown"), process.log_path.read_text()
        assert process.running
    finally:
        stop_together([process], grace_s=30.0)
    assert process.exit_code == 0, process.log_path.read_text()
