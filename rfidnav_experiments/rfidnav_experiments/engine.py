"""The engine of every in-process experiment: Dask's distributed scheduler, on a local cluster of this machine's
cores by default, or on an existing cluster (``--scheduler ADDRESS``).

Each navigation, mission or batch of them is one task, named by its batch and a digest of its job
(:func:`rfidnav_experiments.task_rows.task_key`); the job carries its seed, and every random stream of the task is
drawn from that seed and the job's identity (``rng_for``), so a task gives the same result on whichever worker runs
it: the results are bit-identical on 1 worker, N workers or a cluster. They come back in job order whatever order
they finish in, so no figure depends on which worker was faster.

A worker lost mid-run (killed, out of memory, its machine gone) has its tasks run again on the others by the
scheduler, up to ``distributed.scheduler.allowed-failures`` times per task (3) before the run fails naming the task;
the nanny of a local cluster starts a new worker in its place. A task that raises fails the run at once with its
job named: the code is deterministic, a retry would raise again.

Results are written to the experiment's tasks file (:class:`rfidnav_experiments.task_rows.TaskRows`) as they arrive,
so an interrupted reproduction resumes without redoing finished tasks, and the figures are always computed from
the decoded rows, resumed or not.
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rfidnav_common.errors import RfidnavError
from rfidnav_common.progress import progress
from rfidnav_experiments.task_rows import Header, TaskRows, code_fingerprint, decode, encode, task_key

CONNECT_TIMEOUT_S = 30.0        # for an existing cluster's scheduler to answer
WORKER_WAIT_S = 120.0           # for an existing cluster to have one worker


class EngineError(RfidnavError):
    """The cluster could not be reached or used, or a task failed (its job named)."""


def machine_cores() -> int:
    """The cores this process may run on (a container's or taskset's share, not the host's count)."""
    return len(os.sched_getaffinity(0))


@dataclass(frozen=True)
class EngineOptions:
    workers: int | None = None          # local worker processes; None: machine_cores()
    scheduler: str | None = None        # an existing cluster's scheduler (tcp://host:8786); then workers is unused
    tasks_file: Path | None = None      # where results are streamed; None: kept in memory only
    resume: bool = False                # take the tasks file's finished tasks instead of running them again
    experiment: str = ""                # the tasks file's header: what ran ...
    arguments: dict[str, Any] = field(default_factory=dict)   # ... with which arguments


def run_encoded(function: Callable[[Any], Any], job: Any) -> Any:
    """What a worker runs: the task, its result encoded (plain JSON data travels between machines and into the
    tasks file unchanged)."""
    return encode(function(job))


class Engine:
    """A Dask client for the length of a command: ``with Engine(options) as engine: engine.map(f, jobs, label)``."""

    def __init__(self, options: EngineOptions) -> None:
        self.options = options
        self.cluster: Any = None
        self.client: Any = None
        self.rows: TaskRows | None = None
        self.header: Header | None = None
        self.resumed = 0                # tasks taken from the tasks file instead of run

    def __enter__(self) -> Engine:
        try:
            self.start()
        except BaseException:
            self.close()        # what did start (a cluster, a connection), stopped in order
            raise
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def start(self) -> None:
        from distributed import Client, LocalCluster

        fingerprint = code_fingerprint()
        if self.options.scheduler:
            try:
                self.client = Client(self.options.scheduler, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError) as error:
                raise EngineError(f"--scheduler {self.options.scheduler}: no scheduler answered within "
                                  f"{CONNECT_TIMEOUT_S:.0f} s ({error})") from None
            try:
                self.client.wait_for_workers(1, timeout=WORKER_WAIT_S)
            except TimeoutError:
                raise EngineError(f"--scheduler {self.options.scheduler}: the cluster has no worker after "
                                  f"{WORKER_WAIT_S:.0f} s (start them with `dask worker "
                                  f"{self.options.scheduler} --nthreads 1`)") from None
        else:
            workers = self.options.workers or machine_cores()
            # One thread per worker process: the tasks are pure Python and numpy, which the GIL serialises.
            # No dashboard (it needs bokeh), and its HTTP server on any free port: two commands never collide.
            self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                                        scheduler_port=0, dashboard_address=":0", scheduler_kwargs={"dashboard": False},
                                        silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
        foreign = {worker: code for worker, code in self.client.run(code_fingerprint).items() if code != fingerprint}
        if foreign:
            worker, code = next(iter(foreign.items()))
            raise EngineError(f"worker {worker} runs other code or configuration (fingerprint {code}, here "
                              f"{fingerprint}; {len(foreign)} such worker(s)): install the same rfidnav commit on "
                              "every worker")
        self.header = Header(self.options.experiment, self.options.arguments, fingerprint)
        where = self.options.scheduler or "a local cluster"
        print(f"engine: {where}, {self.workers()} worker(s)", file=sys.stderr)

    def workers(self) -> int:
        return len(self.client.scheduler_info(n_workers=-1)["workers"]) if self.client is not None else 0

    def close(self) -> None:
        if self.rows is not None:
            self.rows.close()
            self.rows = None
        if self.client is not None:
            self.client.close()
            self.client = None
        if self.cluster is not None:
            self.cluster.close()
            self.cluster = None

    def map(self, function: Callable[[Any], Any], jobs: Iterable[Any], label: str) -> list[Any]:
        """``function`` over ``jobs``, one task each, in job order, with a progress line headed ``label``; the
        tasks the tasks file already holds (on ``--resume``) are taken from it, not run."""
        from distributed import as_completed

        if self.rows is None and self.options.tasks_file is not None and self.header is not None:
            # Opened with the first tasks, so that an experiment refusing its arguments leaves no file behind.
            self.rows = TaskRows(self.options.tasks_file, self.header, self.options.resume)
        jobs = list(jobs)
        keys = [task_key(label, job) for job in jobs]
        results: dict[str, Any] = dict(self.rows.finished_in(label)) if self.rows is not None else {}
        pending = {key: job for key, job in zip(keys, jobs) if key not in results}
        tasks = len(set(keys))
        taken = tasks - len(pending)
        self.resumed += taken
        if taken:
            print(f"{label}: {taken} of {tasks} tasks taken from {self.options.tasks_file}", file=sys.stderr)
        with progress(label, tasks) as advance:
            advance(taken)
            futures = self.client.map(run_encoded, [function] * len(pending), list(pending.values()),
                                      key=list(pending), pure=False)
            try:
                for future in as_completed(futures):
                    data = self._result_of(future, pending)
                    if self.rows is not None:
                        self.rows.append(label, future.key, pending[future.key], data)
                    results[future.key] = decode(data)
                    advance(1)
            finally:
                self.client.cancel(futures)
        return [results[key] for key in keys]

    def _result_of(self, future: Any, pending: dict[str, Any]) -> Any:
        from distributed.scheduler import KilledWorker

        try:
            return future.result()
        except KilledWorker:
            raise EngineError(f"task {future.key} (job {pending[future.key]!r}) lost its worker on every try "
                              "(distributed.scheduler.allowed-failures): it may be what kills them") from None
        except Exception as error:   # noqa: BLE001 - a task's own failure, re-raised naming its job
            raise EngineError(f"task {future.key} (job {pending[future.key]!r}) failed: "
                              f"{type(error).__name__}: {error}") from error


_active: list[Engine] = []


@contextmanager
def engine_for(options: EngineOptions) -> Iterator[Engine]:
    """The engine of one command; :func:`run_tasks` inside it runs on it."""
    with Engine(options) as engine:
        _active.append(engine)
        try:
            yield engine
        finally:
            _active.pop()


def engine_workers() -> int:
    """The workers of the command's engine now (a cluster's may come and go); 0 outside a command."""
    return _active[-1].workers() if _active else 0


def run_tasks(function: Callable[[Any], Any], jobs: Iterable[Any], label: str) -> list[Any]:
    """``function`` over ``jobs`` on the command's engine (:func:`engine_for`), or, called outside a command (a
    test, a notebook), on a local cluster of this machine's cores for this call."""
    if _active:
        return _active[-1].map(function, jobs, label)
    with Engine(EngineOptions()) as engine:
        return engine.map(function, jobs, label)
