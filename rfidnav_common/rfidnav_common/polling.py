"""When a reader reads: inventory rounds on a fixed grid of sim time, or polled over a slow link.

Paper 003's robot polls its 13.56 MHz reader over RS-232 at 19,200 bps (Sec. 4.1, item 1): a reply comes
500-600 ms after the request, and the robot drives on meanwhile, so a tag passed between two polls is never
read. Some polls fail (Sec. 4.1, item 3: the reader's negotiation with a tag can fail; the paper gives no
rate): a failed poll reads nothing at all.

:class:`PollClock` is that timing, shared by everything that simulates a reader: the rfid_reader_sim node, the
in-process runners and the spiral-search statistics (rfidnav_control.spiral). With ``jitter_s`` 0 the rounds
keep a fixed grid of ``interval_s`` (the UHF readers of papers 000, 001 and 004: a round every 40 ms); with
``jitter_s`` > 0 each poll comes ``interval_s`` plus a uniform 0..``jitter_s`` after the one before, and the
first at a uniform phase (a reader is not polled in step with the mission's start). A clock without jitter and
without failures draws nothing from its generator.

Pure module: no ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfidnav_common.errors import ParameterError


def next_on_grid(now_s: float, period_s: float) -> float:
    """The first multiple of ``period_s`` after ``now_s`` (a sample taken at ``now_s`` is the one due then)."""
    return (math.floor(now_s / period_s + 1e-6) + 1) * period_s


@dataclass(frozen=True)
class Polling:
    interval_s: float                   # the shortest time between two rounds
    jitter_s: float = 0.0               # each round comes a uniform 0..jitter_s later than interval_s
    failure_probability: float = 0.0    # a round that reads nothing, whatever is in range

    def validate(self) -> None:
        if not (math.isfinite(self.interval_s) and self.interval_s > 0.0):
            raise ParameterError("interval_s", f"must be a positive number of seconds, got {self.interval_s}")
        if not (math.isfinite(self.jitter_s) and self.jitter_s >= 0.0):
            raise ParameterError("jitter_s", f"must be a finite number of seconds >= 0, got {self.jitter_s}")
        if not 0.0 <= self.failure_probability < 1.0:
            raise ParameterError("failure_probability", f"must be in [0, 1), got {self.failure_probability}")

    @property
    def max_interval_s(self) -> float:
        return self.interval_s + self.jitter_s


class PollClock:
    """The rounds of one reader: :meth:`due` at each simulation step, then :meth:`reads` once for each round."""

    def __init__(self, polling: Polling, rng: np.random.Generator | None = None) -> None:
        """``rng`` may be None only for a clock that draws nothing (no jitter, no failures)."""
        polling.validate()
        if rng is None and (polling.jitter_s > 0.0 or polling.failure_probability > 0.0):
            raise ValueError("a poll clock with jitter or failures needs a random generator")
        self.polling = polling
        self.rng = rng
        self.next_poll_s = 0.0
        if polling.jitter_s > 0.0:
            self.next_poll_s = float(self.generator().uniform(0.0, polling.max_interval_s))

    def generator(self) -> np.random.Generator:
        assert self.rng is not None         # __init__ refuses a clock that would draw without one
        return self.rng

    def due(self, now_s: float) -> bool:
        """Whether a round is due at ``now_s`` (the first step at or after its time); if so the next one is
        scheduled: on the grid, or an interval after this one for a polled reader (a request waits for the
        reply before it)."""
        if now_s + 1e-9 < self.next_poll_s:
            return False
        if self.polling.jitter_s == 0.0:
            self.next_poll_s = next_on_grid(now_s, self.polling.interval_s)
        else:
            self.next_poll_s = now_s + self.polling.interval_s + float(self.generator().uniform(0.0,
                                                                                              self.polling.jitter_s))
        return True

    def reads(self) -> bool:
        """Whether the round just due reads (False: a failed poll). Draw it for every round, read or not, so
        that runs on the same seed see the same failures at the same rounds."""
        p = self.polling.failure_probability
        return p == 0.0 or bool(self.generator().random() >= p)
