"""Node processes: resolving ``package executable`` like ``ros2 run``, starting with logs, stopping politely.

Also hands out DDS domain ids: each run holds an exclusive lock on one id for its lifetime, so
concurrent runs (and test sessions) on one machine never hear each other, and passes over an id in which
nodes are already heard (a graph that does not know our locks), so that no foreign node joins a run.
"""

from __future__ import annotations

import fcntl
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import IO

import psutil

from rfidnav_bringup.errors import LaunchError

RUN_DOMAINS = range(51, 102)   # 1-50 are left to test sessions; 0-101 avoid the ephemeral port range


DISCOVERY_WINDOW_S = 1.0   # how long a probe listens for nodes already in a domain (localhost discovery: ~0.1 s)


def nodes_in_domain(domain: int, window_s: float = DISCOVERY_WINDOW_S) -> list[str]:
    """The ROS nodes already in DDS domain ``domain`` on this machine, heard within ``window_s``: a graph that
    ignores our lock files (another checkout, a user's own nodes, a run whose orchestrator was killed).

    Absence cannot be waited for as a condition, so an empty domain costs the whole window; a node is found as
    soon as discovery reports it."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    try:
        probe = Node("rfidnav_domain_probe", context=context, start_parameter_services=False,
                     enable_rosout=False)
        deadline = time.monotonic() + window_s
        found: list[str] = []
        while not found and time.monotonic() < deadline:
            found = [f"{ns.rstrip('/')}/{name}" for name, ns in probe.get_node_names_and_namespaces()
                     if name != probe.get_name()]
            if not found:
                time.sleep(0.05)   # polling the graph cache: discovery fills it in the background
        probe.destroy_node()
        return found
    finally:
        rclpy.try_shutdown(context=context)


class DomainLease:
    """An exclusive ROS_DOMAIN_ID for this process's lifetime (released on close or exit): one whose lock file no
    other run holds and in which no node is heard (:func:`nodes_in_domain`); ``skipped`` says which were passed
    over because of foreign nodes."""

    def __init__(self, candidates: range = RUN_DOMAINS,
                 occupants: Callable[[int], list[str]] = nodes_in_domain) -> None:
        self.handle: IO[str] | None = None
        self.skipped: dict[int, list[str]] = {}
        for domain in candidates:
            handle = open(Path(tempfile.gettempdir()) / f"rfidnav-domain-{domain}.lock", "w")
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                handle.close()
                continue
            found = occupants(domain)
            if found:
                self.skipped[domain] = found
                handle.close()
                continue
            self.handle, self.domain_id = handle, domain
            return
        if len(candidates) == 1:
            raise LaunchError(f"ROS domain {candidates.start} is in use "
                              + (f"by nodes not of this run ({self.describe_skipped()})" if self.skipped
                                 else "by another rfidnav run") + "; choose another with --domain, or leave it out")
        raise LaunchError(f"all ROS domain ids {candidates.start}-{candidates.stop - 1} are in use by other runs"
                          + (f" or by nodes not ours ({self.describe_skipped()})" if self.skipped else ""))

    def describe_skipped(self) -> str:
        return "; ".join(f"domain {domain}: {', '.join(nodes[:3])}{' ...' if len(nodes) > 3 else ''}"
                         for domain, nodes in self.skipped.items())

    def close(self) -> None:
        if self.handle is not None:
            self.handle.close()
            self.handle = None

    def __enter__(self) -> DomainLease:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()


class UnknownExecutableError(LaunchError):
    """``field`` is ``package`` (not installed) or ``executable`` (the package has no such executable)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


def install_prefixes() -> list[Path]:
    """Where installed packages are looked up, as ``ros2 run`` does: each AMENT_PREFIX_PATH entry (a colcon
    install), then this Python's prefix (the workspace's .venv)."""
    return [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p] + [Path(sys.prefix)]


def package_share(package: str) -> Path:
    """``<prefix>/share/<package>`` of the first prefix whose ament resource index (REP 122) lists the package:
    a colcon install, or the workspace's .venv where ``./rfidnav setup`` links the sources' share files.
    An unknown package is an :class:`UnknownExecutableError` naming the prefixes searched."""
    prefixes = install_prefixes()
    for prefix in prefixes:
        if (prefix / "share" / "ament_index" / "resource_index" / "packages" / package).is_file():
            return prefix / "share" / package
    raise UnknownExecutableError("package", f"package '{package}' is in no ament index (searched "
                                 f"{', '.join(map(str, prefixes))}); run ./rfidnav setup")


def resolve_executable(package: str, executable: str) -> list[str]:
    """The command for a node executable: ``<prefix>/lib/<package>/<executable>`` on any install prefix
    (a colcon install), else the package's console_scripts entry point (an editable install).
    An unknown package or executable is an :class:`UnknownExecutableError`."""
    for prefix in install_prefixes():
        candidate = prefix / "lib" / package / executable
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return [str(candidate)]
    entry_point = console_script(package, executable)
    script = Path(sys.prefix) / "bin" / executable
    if script.is_file():
        return [str(script)]
    module, function = entry_point.value.split(":")
    return [sys.executable, "-c", f"import sys; from {module} import {function}; sys.exit({function}())"]


def console_script(package: str, executable: str) -> metadata.EntryPoint:
    """The console_scripts entry point ``executable`` of installed package ``package``; an unknown package or
    executable is an :class:`UnknownExecutableError`."""
    try:
        distribution = metadata.distribution(package)
    except metadata.PackageNotFoundError:
        raise UnknownExecutableError("package",
                                     f"unknown package '{package}' (not installed in {sys.prefix})") from None
    scripts = {ep.name: ep for ep in distribution.entry_points if ep.group == "console_scripts"}
    if executable not in scripts:
        raise UnknownExecutableError("executable", f"package '{package}' has no executable '{executable}' "
                                     f"(it has: {', '.join(sorted(scripts)) or 'none'})")
    return scripts[executable]


@dataclass
class NodeProcess:
    role: str
    command: list[str]
    log_path: Path
    env: dict[str, str]
    respawn: bool = False
    max_respawns: int = 0
    restarts: int = 0
    popen: subprocess.Popen | None = field(default=None, repr=False)
    exit_code: int | None = None

    def start(self) -> None:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        log = self.log_path.open("a")
        log.write(f"$ {' '.join(self.command)}\n")
        log.flush()
        try:
            # A session of its own: Ctrl-C in the terminal reaches the orchestrator, which stops nodes in order.
            self.popen = subprocess.Popen(self.command, stdout=log, stderr=subprocess.STDOUT, env=self.env,
                                          start_new_session=True)
        except OSError as error:
            raise LaunchError(f"{self.role}: cannot start '{self.command[0]}': {error.strerror}") from None
        finally:
            log.close()
        self.exit_code = None

    def poll(self) -> int | None:
        if self.popen is not None and self.exit_code is None:
            self.exit_code = self.popen.poll()
        return self.exit_code

    @property
    def running(self) -> bool:
        return self.popen is not None and self.poll() is None

    def signal(self, signum: int) -> None:
        if self.running:
            os.killpg(self.popen.pid, signum)

    def wait(self, timeout_s: float) -> bool:
        if self.popen is None:
            return True
        try:
            self.exit_code = self.popen.wait(timeout=timeout_s)
            return True
        except subprocess.TimeoutExpired:
            return False

    def stop(self, grace_s: float) -> None:
        """SIGINT, then SIGKILL after the grace period."""
        if not self.running:
            return
        self.signal(signal.SIGINT)
        if not self.wait(grace_s):
            self.signal(signal.SIGKILL)
            self.wait(5.0)

    def cpu_seconds(self) -> float | None:
        """User + system CPU time of the running process (None once it has exited)."""
        if not self.running:
            return None
        try:
            times = psutil.Process(self.popen.pid).cpu_times()
        except psutil.Error:
            return None
        return times.user + times.system

    def last_lines(self, count: int = 12) -> str:
        try:
            lines = self.log_path.read_text(errors="replace").splitlines()
        except FileNotFoundError:
            return "(no log)"
        return "\n".join("    " + line for line in lines[-count:])
