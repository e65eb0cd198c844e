"""Progress of a long command on stderr, with rich: every verb that runs over a few seconds shows one.

On a terminal it is rich's live bar (done / total, elapsed, time left). In a log (CI, ``> file``) a live bar
would be hundreds of redraws or nothing until the end, so the same task prints one plain line at every tenth
of the way and when it ends. Standard output stays free for the figures (``--json``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.status import Status

LOG_STEPS = 10            # in a log: a line at every tenth of the way


def _console() -> Console:
    return Console(stderr=True, highlight=False)


@contextmanager
def progress(label: str, total: int) -> Iterator[Callable[[int], None]]:
    """``with progress("reproduce flc", 120) as advance: ... advance(1)``: ``label`` and how far of ``total``."""
    console = _console()
    if console.is_terminal:
        with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      TextColumn("left"), TimeRemainingColumn(), console=console, transient=False) as bar:
            task = bar.add_task(label, total=total)

            def advance_bar(steps: int = 1) -> None:
                bar.advance(task, steps)

            yield advance_bar
        return
    done = 0
    logged = 0

    def advance(steps: int = 1) -> None:
        nonlocal done, logged
        done += steps
        tenth = done * LOG_STEPS // max(total, 1)
        if tenth > logged and done < total:
            logged = tenth
            console.print(f"{label}: {done}/{total}")

    started = time.monotonic()
    yield advance
    console.print(f"{label}: {done}/{total} in {time.monotonic() - started:.0f} s")


@contextmanager
def stage(label: str) -> Iterator[None]:
    """A step without a count (one benchmark, one survey): a spinner on a terminal, a line in a log; then how long
    it took."""
    console = _console()
    started = time.monotonic()
    if console.is_terminal:
        with console.status(label):
            yield
    else:
        console.print(f"{label} ...")
        yield
    console.print(f"{label}: done in {time.monotonic() - started:.0f} s")


class StatusLine:
    """A line that keeps changing while something runs (a mission's feedback): rich's status on a terminal,
    redrawn at most ``refresh_per_second``; in a log only the milestones, one plain line each."""

    def __init__(self, quiet: bool = False) -> None:
        self.console = _console()
        self.quiet = quiet
        self.status: Status | None = None

    def show(self, text: str, milestone: bool = False) -> None:
        if self.quiet:
            return
        if not self.console.is_terminal:
            if milestone:
                self.console.print(text)
            return
        if self.status is None:
            self.status = self.console.status(text)
            self.status.start()
        else:
            self.status.update(text)

    def done(self) -> None:
        if self.status is not None:
            self.status.stop()
            self.status = None
