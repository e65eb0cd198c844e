"""Task functions for the engine's tests, importable by the workers of a local cluster (they inherit this process's
sys.path): a task that kills its own worker once, and one that logs each run and can be made to fail."""

from __future__ import annotations

import os
import signal
from pathlib import Path


def square_killing_its_worker_once(job: tuple[str, int, int]) -> int:
    """``value`` squared; the task ``value == victim`` kills its worker process (SIGKILL, mid-task) the first time
    it runs, leaving a marker with the killed worker's pid."""
    folder, value, victim = job
    marker = Path(folder) / "killed"
    if value == victim and not marker.exists():
        marker.write_text(str(os.getpid()))
        os.kill(os.getpid(), signal.SIGKILL)
    return value * value


def logged_square(job: tuple[str, int]) -> int:
    """``value`` squared, one line in the folder's log per run; while the folder holds a file ``fail-VALUE`` the task
    of that value raises instead."""
    folder, value = job
    with (Path(folder) / "log").open("a") as log:
        log.write(f"{value}\n")
    if (Path(folder) / f"fail-{value}").exists():
        raise RuntimeError(f"told to fail at {value}")
    return value * value
