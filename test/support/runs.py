"""``./rfidnav`` runs from the tests: the CLI in a subprocess (the orchestrator leases its own DDS domain), a
scenario run that must succeed, and what the navigation nodes of a run subscribed to."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import yaml

from rfidnav_bag.bags import read_messages
from rfidnav_bringup.report import load_run
from rfidnav_scenario.metrics import position_errors

WORKSPACE = Path(__file__).resolve().parents[2]


def cli_environment(without: tuple[str, ...] = ()) -> dict[str, str]:
    """This process's environment for a CLI, but ROS_DOMAIN_ID (the orchestrator leases its own domain) and the
    variables ``without`` (the session's partition profile, for a run that names its own)."""
    return {key: value for key, value in os.environ.items() if key not in ("ROS_DOMAIN_ID", *without)}


def run_cli(*args: str, timeout: float = 600, without: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=WORKSPACE, env=cli_environment(without))


def run_scenario(out: Path, scenario: str, *options: str, mission_may_fail: bool = False) -> Path:
    """``./rfidnav run SCENARIO OPTIONS --out OUT``, which must succeed (or, ``mission_may_fail``, end with the
    mission's failure, exit 1: a method that does not always arrive): the one run folder, with the CLI's output kept
    in it as cli.log."""
    result = run_cli("run", scenario, *options, "--out", str(out))
    run = one_run(out, result.stdout + result.stderr)
    run.joinpath("cli.log").write_text(result.stdout + result.stderr)
    assert result.returncode in ((0, 1) if mission_may_fail else (0,)), result.stdout + result.stderr
    return run


def one_run(out: Path, output: str = "") -> Path:
    """The one run folder the CLI made in ``out`` (``output``, the CLI's, says why when there is none or more)."""
    runs = list(out.iterdir())
    assert len(runs) == 1, output or runs
    return runs[0]


def recorded_commands(run: Path, topic: str = "/cmd_vel") -> list[tuple[float, float]]:
    """The run's /cmd_vel (a robot's: /r1/cmd_vel) as the bag recorded it: (linear.x [m/s], angular.z [rad/s]) per
    command, in order."""
    return [(msg.linear.x, msg.angular.z) for _, _, msg in read_messages(run / "bag", [topic])]


def run_summary(run: Path) -> dict:
    """The run's summary.json."""
    return json.loads((run / "summary.json").read_text())


def scenario_document(name: str) -> dict:
    """The shipped scenario ``name`` as a mapping with absolute paths, to be changed and written elsewhere."""
    base = WORKSPACE / "config/scenarios"
    document = yaml.safe_load((base / f"{name}.yaml").read_text())
    for key in ("world", "map"):
        document[key] = str((base / document[key]).resolve())
    for entry in document["nodes"].values():
        if "params" in entry:
            entry["params"] = str((base / entry["params"]).resolve())
    return document


def navigation_subscriptions(run: Path, navigation_nodes: tuple[str, ...]) -> dict[str, set[str]]:
    """Each navigation node's subscriptions once the run's graph was ready (graph.json), after checking that none
    is to a /sim/* topic and that none was given the world file: they know neither ground truth nor world."""
    graph = json.loads((run / "graph.json").read_text())
    subscriptions = {}
    for name in navigation_nodes:
        topics = graph["nodes"][name]["subscriptions"]
        assert not [t for t in topics if t.startswith("/sim/")], (name, topics)
        assert "world_file" not in (run / "params" / f"{name}.yaml").read_text(), name
        subscriptions[name] = set(topics)
    return subscriptions


def pose_errors(run: Path, topic: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """A localizer's PoseWithCovarianceStamped on ``topic`` in the run's bag: each one's position error against the
    ground truth at its stamp, and each one's 6 x 6 covariance."""
    times, xy, covariances = [], [], []
    for _, _, message in read_messages(run / "bag", [topic]):
        times.append(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9)
        xy.append((message.pose.pose.position.x, message.pose.pose.position.y))
        covariances.append(np.asarray(message.pose.covariance).reshape(6, 6))
    return position_errors(load_run(run).ground_truth, np.array(times), np.array(xy)), covariances


def evidence_used(run: Path, topic: str) -> set[str]:
    """Every kind of evidence the fused localizer's LocalizationStatus on ``topic`` named in the run."""
    used: set[str] = set()
    for _, _, status in read_messages(run / "bag", [topic]):
        assert status.method == "fused"
        used.update(status.evidence_used)
    return used


def start_cli(*args: str, without: tuple[str, ...] = ()) -> subprocess.Popen:
    """``./rfidnav ARGS`` started in the background (its own domain lease), output merged into one text pipe."""
    return subprocess.Popen([sys.executable, "-m", "rfidnav_bringup.cli", *args], cwd=WORKSPACE,
                            env=cli_environment(without), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def wait_for_log(out: Path, role: str, text: str, cli: subprocess.Popen, timeout: float = 180) -> None:
    """Wait until the log of ``role`` in the one run folder under ``out`` says ``text`` (the CLI still running)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and cli.poll() is None:
        logs = list(out.glob(f"*/logs/{role}.log"))
        if logs and text in logs[0].read_text():
            return
        time.sleep(0.2)   # polling a file another process writes; no ROS readiness signal reaches here
    raise AssertionError(f"{role}'s log never said {text!r} (CLI exit {cli.poll()})")


def mission_started(out: Path, cli: subprocess.Popen) -> list[psutil.Process]:
    """Wait until heading_controller follows its route; the CLI's node processes then."""
    wait_for_log(out, "heading_controller", "following", cli)
    return psutil.Process(cli.pid).children(recursive=True)


def run_killing_the_controller(out: Path, scenario: str, *options: str, timeout: float = 300) -> tuple[int, str]:
    """``./rfidnav run SCENARIO OPTIONS --out OUT --no-record --quiet`` in which heading_controller is killed
    hard once its log says it follows the route: the CLI's exit code and output."""
    with start_cli("run", scenario, *options, "--out", str(out), "--no-record", "--quiet") as cli:
        victims = [p for p in mission_started(out, cli) if any("heading_controller" in part for part in p.cmdline())]
        assert len(victims) == 1, victims
        victims[0].kill()
        output, _ = cli.communicate(timeout=timeout)
    return cli.returncode, output
