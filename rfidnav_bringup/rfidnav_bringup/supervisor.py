"""The processes of a run, by name (a role's, or its group's: rfidnav_bringup.run_plan): started with the recorder
first, checked for an exit (a process that may respawn is restarted, any other exit ends the run), stopped with the
recorder last so that it closes the bag with everything the nodes sent. Pure: no rclpy.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

from rfidnav_bringup.errors import NodeExitedError
from rfidnav_bringup.processes import NodeProcess, stop_together
from rfidnav_bringup.run_plan import RECORDER_ROLE, ProcessPlan

STOP_GRACE_S = 5.0


class Supervisor:
    def __init__(self, say: Callable[[str], None], stopping: Callable[[], bool],
                 respawned: Callable[[str], None]) -> None:
        """``say`` tells of a restart; no process is restarted once ``stopping()``; ``respawned(name)`` is told of
        each restart (its nodes are in the graph twice for a while)."""
        self.say, self.stopping, self.respawned = say, stopping, respawned
        self.processes: dict[str, NodeProcess] = {}

    def add(self, plans: Iterable[ProcessPlan], log_path: Callable[[str], Path], env: dict[str, str],
            lease_fd: int | None = None) -> None:
        for plan in plans:
            self.processes[plan.name] = NodeProcess(plan.name, plan.command, log_path(plan.name), env, plan.respawn,
                                                    plan.max_respawns, lease_fd)

    def start(self, recorder: bool) -> None:
        """Start the recorder (``recorder``), else every other process."""
        for name, process in self.processes.items():
            if (name == RECORDER_ROLE) == recorder:
                process.start()

    def check(self, starting: bool) -> None:
        """Restart an exited process that may respawn; raise NodeExitedError for any other exit, and for every exit
        while the graph is ``starting``."""
        for role, process in self.processes.items():
            code = process.poll()
            if code is None or process.popen is None:
                continue
            if process.respawn and process.restarts < process.max_respawns and not self.stopping():
                self.say(f"\n{role} exited with code {code}; restarting ({process.restarts + 1}/"
                         f"{process.max_respawns})\n{process.last_lines(5)}")
                process.restarts += 1
                self.respawned(role)
                process.start()
                continue
            if starting or not process.respawn:
                process.popen = None if starting else process.popen
                raise NodeExitedError(f"node {role} exited with code {code}; last log lines:\n{process.last_lines()}")

    def last_lines(self) -> str:
        return "\n".join(f"  {role} ({'running' if p.running else f'exit {p.exit_code}'}):\n{p.last_lines(5)}"
                         for role, p in self.processes.items())

    def restarts(self, name: str) -> int:
        return self.processes[name].restarts

    def stop(self) -> None:
        """Every node process at once, then the recorder, with longer to close the bag; a process killed at the end
        of its grace period is said, with where its stacks are."""
        killed = stop_together([p for role, p in self.processes.items() if role != RECORDER_ROLE], STOP_GRACE_S)
        killed += stop_together([p for role, p in self.processes.items() if role == RECORDER_ROLE], 3 * STOP_GRACE_S)
        for process in killed:
            self.say(f"{process.role} did not stop within its grace period and was killed; its threads' stacks "
                     f"are at the end of {process.log_path}")
