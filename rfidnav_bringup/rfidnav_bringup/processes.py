"""Node processes: starting with logs, stopping politely, and
never outliving the process that started them (Linux's parent-death signal).

Also hands out DDS domain ids: each run holds an exclusive lock on one id for its lifetime, and so do the node
processes it starts (they inherit the lock's descriptor), so concurrent runs (and test sessions) on one machine never
hear each other, even while a killed run's nodes are still stopping. A graph that does not know our locks is kept
out of a run by the run's DDS partition (partition.py); a lease for a replay, which has none, passes over an id in
which nodes are already heard.
"""

from __future__ import annotations

import ctypes
import errno
import fcntl
import os
import signal
import stat
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import psutil

from rfidnav_bringup.discovery_server import client_environment
from rfidnav_bringup.errors import LaunchError
from rfidnav_bringup.partition import PROFILES_VARIABLE, RunPartition
from rfidnav_common.process_signals import STACK_DUMP_SIGNAL

RUN_DOMAINS = range(51, 102)   # 1-50 are left to test sessions; 0-101 avoid the ephemeral port range
# The domain locks live in one folder per user under /tmp, not $TMPDIR: two runs with different TMPDIRs must still
# see each other's locks.
LOCK_ROOT = Path("/tmp")
# What a child receives when the process that started it dies, however it dies (SIGKILL included): the signal a
# node treats as Ctrl-C, so that it stops the base, closes its bag or ends as on a normal stop. It comes once per thread
# of the dying parent (Linux reparents a child from thread to thread): nodes take repeats calmly (ros.stop_requested).
PARENT_DEATH_SIGNAL = signal.SIGINT
_PR_SET_PDEATHSIG = 1   # linux/prctl.h
_SIG_DFL = 0            # signal.h
_LIBC = ctypes.CDLL(None, use_errno=True)
_LIBC.signal.argtypes = (ctypes.c_int, ctypes.c_void_p)
_LIBC.signal.restype = ctypes.c_void_p


# --discovery: a run's nodes find each other on this machine only (the default: two runs, or a run and a robot on
# the network, never mix), or across the subnet (a robot's drivers on another machine, a viewer on a laptop).
DISCOVERY_RANGES = {"localhost": "LOCALHOST", "subnet": "SUBNET"}


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
        self.handle: int | None = None
        self.skipped: dict[int, list[str]] = {}
        folder = lock_folder()
        for domain in candidates:
            handle = open_lock_file(folder / f"domain-{domain}.lock")
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(handle)
                continue
            found = occupants(domain)
            if found:
                self.skipped[domain] = found
                os.close(handle)
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
            os.close(self.handle)
            self.handle = None

    def __enter__(self) -> DomainLease:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()


class SharedDomain:
    """The ROS domain a split run's two parts name (--part, --domain): not leased, since the other part's
    orchestrator joins it too, on another computer or on this one; the run's DDS partition keeps others out."""

    handle = None

    def __init__(self, domain_id: int) -> None:
        self.domain_id = domain_id
        self.skipped: dict[int, list[str]] = {}

    def close(self) -> None:
        """Nothing is held."""


def lock_folder(root: Path = LOCK_ROOT) -> Path:
    """``/tmp/rfidnav-<uid>``, this user's folder of domain locks: created private (0700); refused when it is a
    symbolic link or another user's (someone could otherwise point our lock files at a file of ours)."""
    folder = root / f"rfidnav-{os.getuid()}"
    try:
        folder.mkdir(mode=0o700)
    except FileExistsError:
        pass
    except OSError as error:
        raise LaunchError(f"cannot create the domain lock folder {folder}: {error.strerror}") from None
    info = os.lstat(folder)
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid() or info.st_mode & 0o022:
        raise LaunchError(f"the domain lock folder {folder} is not a private folder of this user (a symbolic link, "
                          "another user's, or writable by others); remove it")
    return folder


def open_lock_file(path: Path) -> int:
    """A descriptor of the lock file ``path``, created owner-only if missing; never through a symbolic link and
    never truncating (a lock file holds nothing: only its lock counts)."""
    try:
        return os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
    except OSError as error:
        reason = "it is a symbolic link" if error.errno == errno.ELOOP else error.strerror
        raise LaunchError(f"cannot open the domain lock {path}: {reason}") from None


def die_with_parent(parent_pid: int) -> Callable[[], None]:
    """A ``preexec_fn`` that makes the child receive PARENT_DEATH_SIGNAL when ``parent_pid`` dies (or has died
    already, between the fork and this call), and take it: its disposition back to the default, for an ignored
    signal stays ignored across exec, and a background job of a non-interactive shell (``./rfidnav run ... &`` in a
    script, a CI job) starts with SIGINT ignored, so its children's Python never installs its Ctrl-C handler and
    the stop never reaches them. It only makes system calls: a preexec_fn must not take locks that another thread
    of the parent may have held at the fork."""
    def set_parent_death_signal() -> None:
        _LIBC.signal(int(PARENT_DEATH_SIGNAL), _SIG_DFL)
        _LIBC.prctl(_PR_SET_PDEATHSIG, int(PARENT_DEATH_SIGNAL), 0, 0, 0)
        if os.getppid() != parent_pid:
            os.kill(os.getpid(), PARENT_DEATH_SIGNAL)
    return set_parent_death_signal


def start_child(command: list[str], lease_fd: int | None = None, **popen_options: Any) -> subprocess.Popen:
    """``subprocess.Popen(command)`` in a session of its own (Ctrl-C in the terminal reaches only its parent, which
    stops it in order) that dies with its parent (die_with_parent).

    ``lease_fd``, a DomainLease's descriptor, is inherited: the domain's lock is an flock, held while any process
    has the descriptor open, so the domain stays leased until the child has ended too. A killed orchestrator's
    nodes take seconds to stop (the recorder closes its bag); a run leasing the domain in those seconds would meet
    them, and a probe of the domain on a loaded machine can miss them."""
    return subprocess.Popen(command, start_new_session=True, preexec_fn=die_with_parent(os.getpid()),
                            pass_fds=() if lease_fd is None else (lease_fd,), **popen_options)


def reach_text(domain_id: int, discovery: str, partition: RunPartition | None = None,
               discovery_server: tuple[str, int] | None = None) -> str:
    """How another shell (or machine) joins the running graph: its domain, its DDS partition's profile and the
    discovery server it is found through, if any."""
    where = "this machine only" if discovery == "localhost" else "this subnet"
    variables = f"ROS_DOMAIN_ID={domain_id} ROS_AUTOMATIC_DISCOVERY_RANGE={DISCOVERY_RANGES[discovery]}"
    if partition is not None:
        variables += f" {PROFILES_VARIABLE}={partition.profiles_file}"
        where += f", DDS partition {partition.name}"
    if discovery_server is not None:
        variables += " " + " ".join(f"{k}={v}" for k, v in client_environment(*discovery_server).items())
        where += f", discovery server {discovery_server[0]}:{discovery_server[1]}"
    return f"{variables} ({where}); to join it: {variables} ./rfidnav echo /odom"


def child_environment(domain_id: int, discovery: str = "localhost") -> dict[str, str]:
    env = dict(os.environ)
    env.update(ROS_DOMAIN_ID=str(domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE=DISCOVERY_RANGES[discovery],
               PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0")
    env.setdefault("AMENT_PREFIX_PATH", sys.prefix)
    return env


def run_supervised(command: list[str], env: dict[str, str], lease_fd: int | None = None) -> int:
    """Run one child to its end (start_child, holding ``lease_fd``), passing any of SIGINT, SIGTERM and SIGHUP on to
    it as SIGINT (its Ctrl-C), and return its exit code, or 128 + the first signal that came (the shell's
    convention)."""
    first: list[int] = []
    child = start_child(command, lease_fd, env=env)

    def pass_on(signum: int, _frame: object) -> None:
        first.append(signum)
        if child.poll() is None:
            os.killpg(child.pid, signal.SIGINT)

    stop_signals = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    previous = {signum: signal.signal(signum, pass_on) for signum in stop_signals}
    try:
        code = child.wait()
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 128 + first[0] if first else code


@dataclass
class NodeProcess:
    role: str
    command: list[str]
    log_path: Path
    env: dict[str, str]
    respawn: bool = False
    max_respawns: int = 0
    lease_fd: int | None = None      # the run's DomainLease descriptor, held by the child too (start_child)
    restarts: int = 0
    popen: subprocess.Popen | None = field(default=None, repr=False)
    exit_code: int | None = None

    def start(self) -> None:
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        log = self.log_path.open("a")
        log.write(f"$ {' '.join(self.command)}\n")
        log.flush()
        try:
            self.popen = start_child(self.command, self.lease_fd, stdout=log, stderr=subprocess.STDOUT, env=self.env)
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
        """SIGINT (and SIGCONT, so that a stopped process can act on it), then SIGKILL after the grace period."""
        stop_together([self], grace_s)

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


STACK_DUMP_WAIT_S = 0.5    # faulthandler writes the stacks from its signal handler, at once


def stop_together(processes: Iterable[NodeProcess], grace_s: float) -> list[NodeProcess]:
    """Stop ``processes`` at once: SIGINT (and SIGCONT, so that a stopped process can act on it) to every one, then
    to those still running when the shared grace period is over, STACK_DUMP_SIGNAL (a node's stacks into its log)
    and SIGKILL; those killed are returned. One at a time, a run's Ctrl-C took the sum
    of its processes' exits, which a loaded machine stretches past a user's patience."""
    running = [process for process in processes if process.running]
    for process in running:
        process.signal(signal.SIGINT)
        process.signal(signal.SIGCONT)
    deadline = time.monotonic() + grace_s
    killed = []
    for process in running:
        if not process.wait(max(0.0, deadline - time.monotonic())):
            # An rfidnav node writes every thread's stack to its log on STACK_DUMP_SIGNAL (run_node): where it hung.
            process.signal(STACK_DUMP_SIGNAL)
            process.wait(STACK_DUMP_WAIT_S)
            process.signal(signal.SIGKILL)
            process.wait(5.0)
            killed.append(process)
    return killed


@contextmanager
def cpu_hogs(count: int) -> Iterator[None]:
    """``count`` busy-loop processes for the duration (the issue's ``python3 -c 'while 1: pass'``), ended by PID."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()
