"""What every reproduction shares: progress on stderr, figures saved alike, plain-text tables, means of maybe
nothing."""

from __future__ import annotations

import multiprocessing
import statistics
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

WORKERS = 2                             # the target machine has two cores


def progress(line: str, final: bool) -> None:
    # One overwritten line on a terminal; in a log only the final line, not hundreds.
    if sys.stderr.isatty():
        print(f"\r\033[K{line}", end="\n" if final else "", file=sys.stderr, flush=True)
    elif final:
        print(line, file=sys.stderr, flush=True)


def save(figure: plt.Figure, path: Path, dpi: int) -> Path:
    """Lay out, write and close a reproduction's figure."""
    figure.tight_layout()
    figure.savefig(path, dpi=dpi)
    plt.close(figure)
    return path


def mean_or_none(values: list[float]) -> float | None:
    return statistics.fmean(values) if values else None


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    widths = [max(len(cell) for cell in column) for column in zip(header, *rows)]
    line = lambda cells: "  ".join(cell.ljust(width) for cell, width in zip(cells, widths)).rstrip()  # noqa: E731
    return [line(header), line(["-" * width for width in widths]), *(line(row) for row in rows)]


def run_pool(function: Callable[[Any], Any], jobs: Iterable[Any], label: str) -> list[Any]:
    """``function`` over ``jobs`` on both cores, in completion order, with a progress line headed ``label``.

    forkserver, not fork: the caller may hold DDS threads (the test suite's own rclpy contexts), and a forked
    copy of those can hang; the server imports the function's module once and forks the workers from it."""
    jobs = list(jobs)
    results = []
    started = time.monotonic()
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([function.__module__])
    with context.Pool(WORKERS) as pool:
        for done, result in enumerate(pool.imap_unordered(function, jobs, chunksize=4), start=1):
            results.append(result)
            if done % 20 == 0 or done == len(jobs):
                progress(f"{label}: {done}/{len(jobs)}", final=False)
    progress(f"{label}: {len(jobs)} in {time.monotonic() - started:.0f} s", final=True)
    return results
