"""What a run leaves behind for people and scripts: summary.json (the outcome, with ground truth having the last word
on success, the metrics from the bag, the graph's CPU while the mission ran, each process's exit and restarts) and
its printed form. Pure: no rclpy.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import psutil

from rfidnav_bringup.processes import NodeProcess
from rfidnav_common.errors import RfidnavError
from rfidnav_common.files import write_atomically
from rfidnav_scenario.metrics import ground_truth_objection


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
    robots: dict[str, MissionOutcome] = field(default_factory=dict)    # a run of several robots: each one's

    def robot(self, name: str) -> MissionOutcome:
        """Robot ``name``'s outcome in a run of several (made at the first call)."""
        return self.robots.setdefault(name, MissionOutcome())

    def conclude(self, result: Any, interrupted: bool) -> None:
        """The mission's action ``result`` came: a success if it says so and nothing ended the mission before
        (a signal, a timeout, a stall: the message says which)."""
        self.result = result
        self.success = bool(getattr(result, "success", False)) and not interrupted and self.message == "not started"
        if self.message == "not started":
            self.message = getattr(result, "message", "")

    def conclude_robots(self, interrupted: bool) -> None:
        """A run of several robots: a success when every robot's mission is (and nothing ended the run first); the
        message says each robot's."""
        self.success = all(robot.success for robot in self.robots.values()) and not interrupted and \
            self.message == "not started"
        each = "; ".join(f"{name}: {robot.message}" for name, robot in self.robots.items())
        self.message = each if self.message == "not started" else f"{self.message} ({each})"


@dataclass(frozen=True)
class RunFacts:
    """What summary.json says of the run besides its outcome, in the order it says it."""
    scenario: str
    seed: int
    rtf: str | float                       # run_plan.rtf_text
    clock: dict[str, Any]                  # run_plan.RunPlan.clock_summary
    ros_domain: dict[str, Any] | None      # the domain and DDS partition it ran in; None if it never leased one


@dataclass
class RunSummary:
    run_dir: Path
    document: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return bool(self.document.get("success"))


def cpu_seconds(processes: Mapping[str, NodeProcess]) -> dict[str, float | None]:
    """CPU time so far of each node process and of this orchestrator (the mission's action client)."""
    own = psutil.Process().cpu_times()
    return {**{role: p.cpu_seconds() for role, p in processes.items()},
            "orchestrator": own.user + own.system}


def mission_cpu(outcome: MissionOutcome) -> dict[str, Any] | None:
    """CPU used by the graph while the mission ran, per process and in total, as a percentage of one core.

    A process that exited or restarted during the mission has no figure (it is left out of the total)."""
    if outcome.ended_wall is None or outcome.started_wall is None or not outcome.cpu_at_end:
        return None
    wall_s = outcome.ended_wall - outcome.started_wall
    used: dict[str, float | None] = {}
    for role, end in outcome.cpu_at_end.items():
        start = outcome.cpu_at_start.get(role)
        used[role] = round(end - start, 3) if start is not None and end is not None and end >= start else None
    total = sum(value for value in used.values() if value is not None)
    return {"mission_wall_s": round(wall_s, 3), "cores": psutil.cpu_count(), "process_cpu_s": used,
            "graph_cpu_s": round(total, 3),
            "graph_cpu_percent_of_one_core": round(100.0 * total / wall_s, 1) if wall_s > 0 else None}


def write_run_summary(run_dir: Path, facts: RunFacts, outcome: MissionOutcome, processes: Mapping[str, NodeProcess],
                      say: Callable[[str], None], interrupted: bool = False) -> RunSummary:
    """Write ``run_dir``/summary.json and return it; ``outcome`` becomes a failure if ground truth objects.
    ``say`` tells what could not be done (the metrics, the file), which does not end the run. An ``interrupted``
    run (Ctrl-C, SIGTERM) is not scored: its metrics, which read the whole bag (seconds on a loaded machine, where
    the user waits for the prompt), are left to ``./rfidnav report``."""
    metrics: dict[str, Any] = {}
    robots: dict[str, dict[str, Any]] = {}
    bag = run_dir / "bag"
    scored = not interrupted and (bag / "metadata.yaml").exists()
    if interrupted:
        say(f"metrics not computed for an interrupted run: ./rfidnav report {run_dir} computes them")
    if outcome.robots:
        per_robot: dict[str, dict[str, Any]] = {}
        if scored:
            per_robot, metrics = scored_fleet_metrics(run_dir, outcome, say)
        for name, robot in outcome.robots.items():
            robots[name] = {"success": robot.success, "message": robot.message, "metrics": per_robot.get(name, {})}
        if outcome.success and not all(robot.success for robot in outcome.robots.values()):
            outcome.success = False
            outcome.message = "; ".join(f"{name}: {robot.message}" for name, robot in outcome.robots.items())
    elif scored:
        metrics = scored_metrics(run_dir, None, outcome, say)
    sim_duration = None
    if outcome.started_sim_s is not None and outcome.ended_sim_s is not None:
        sim_duration = round(outcome.ended_sim_s - outcome.started_sim_s, 3)
    document = {
        "scenario": facts.scenario,
        "success": outcome.success,
        "message": outcome.message,
        "seed": facts.seed,
        "rtf": facts.rtf,
        "clock": facts.clock,
        "ros_domain": facts.ros_domain,
        "sim_duration_s": sim_duration,
        "wall_duration_s": round((outcome.ended_wall or time.monotonic()) - outcome.started_wall, 3)
        if outcome.started_wall else None,
        "metrics": metrics,
        **({"robots": robots} if robots else {}),
        "cpu": mission_cpu(outcome),
        "nodes": {role: {"restarts": p.restarts, "exit_code": p.exit_code} for role, p in processes.items()},
        "bag": str(bag if bag.exists() else run_dir),
        "run_dir": str(run_dir),
    }
    try:
        write_atomically(run_dir / "summary.json", json.dumps(document, indent=2) + "\n")
    except OSError as error:   # a full disk, the folder gone: the run's outcome is still printed
        say(f"summary.json not written in {run_dir}: {error.strerror}")
    return RunSummary(run_dir, document)


def scored_metrics(run_dir: Path, robot: str | None, outcome: MissionOutcome,
                   say: Callable[[str], None]) -> dict[str, Any]:
    """The run's metrics from its bag, and ground truth's word on ``outcome`` (judge)."""
    from rfidnav_bringup.report import run_metrics

    try:
        metrics = run_metrics(run_dir, robot)
    except RfidnavError as error:
        say(f"metrics not computed: {error}")
        return {}
    judge(outcome, metrics)
    return metrics


def scored_fleet_metrics(run_dir: Path, outcome: MissionOutcome,
                         say: Callable[[str], None]) -> tuple[dict[str, dict[str, Any]], dict[str, Any]]:
    """A run of several robots: each robot's metrics from its topics, ground truth's word on each robot's outcome,
    and what the robots did together (the run's own metrics: how near they came)."""
    from rfidnav_bringup.report import fleet_metrics, load_run

    try:
        per_robot, joint = fleet_metrics([load_run(run_dir, name) for name in outcome.robots])
    except RfidnavError as error:
        say(f"metrics not computed: {error}")
        return {}, {}
    for name, robot in outcome.robots.items():
        judge(robot, per_robot[name])
    return per_robot, joint


def judge(outcome: MissionOutcome, metrics: dict[str, Any]) -> None:
    """Ground truth's word on an outcome its mission's node reported: the node can be fooled (a spoofed tag, a wrong
    map, a leg through a wall); ground truth, which it never sees, has the last word on whether the run succeeded."""
    objection = ground_truth_objection(metrics)
    if outcome.success and objection is not None:
        outcome.success = False
        outcome.message = (f"{outcome.message or 'succeeded'}, says the mission's node; but ground "
                           f"truth {objection}")


def print_summary(summary: RunSummary) -> None:
    document = summary.document
    rows = [("scenario", document["scenario"]), ("success", document["success"]), ("message", document["message"]),
            ("sim duration [s]", document["sim_duration_s"]), ("wall duration [s]", document["wall_duration_s"])]
    rows += [(key, f"{value:.4f}" if isinstance(value, float) else value) for key, value in document["metrics"].items()]
    for name, robot in document.get("robots", {}).items():
        rows += [(f"{name} success", robot["success"]), (f"{name} message", robot["message"])]
        rows += [(f"{name} {key}", f"{value:.4f}" if isinstance(value, float) else value)
                 for key, value in robot["metrics"].items()]
    rows += [(f"node {role}", f"exit {info['exit_code']}, restarts {info['restarts']}")
             for role, info in document["nodes"].items()]
    if cpu := document.get("cpu"):
        rows.append(("graph CPU in mission", f"{cpu['graph_cpu_percent_of_one_core']}% of one core "
                                             f"({cpu['cores']} cores) over {cpu['mission_wall_s']} s"))
    rows += [("bag", document["bag"]), ("summary", str(summary.run_dir / "summary.json"))]
    width = max(len(str(key)) for key, _ in rows)
    for key, value in rows:
        print(f"  {str(key).ljust(width)}  {value}")
