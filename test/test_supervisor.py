"""The supervisor of a run's processes (rfidnav_bringup.supervisor) alone, with plain Python processes for nodes: the
recorder starts apart from the others and stops last, a process that may respawn is restarted (and its restart told)
until it may not, any other exit ends the run naming the process and its last lines."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from rfidnav_bringup import supervisor as supervisor_module
from rfidnav_bringup.errors import NodeExitedError
from rfidnav_bringup.run_plan import RECORDER_ROLE, ProcessPlan
from rfidnav_bringup.supervisor import Supervisor

pytestmark = pytest.mark.tier("graph")

EXITS = [sys.executable, "-c", "print('no map'); raise SystemExit(3)"]
RUNS = [sys.executable, "-c", "import time; time.sleep(600)"]


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
                        lambda processes, grace_s: stopped.append(([p.role for p in processes], grace_s)))
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
