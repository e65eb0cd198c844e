"""When a simulated sensor samples: every ``period_s`` of sim time, on the ground-truth clock.

Sensor simulators sample on /sim/ground_truth: the first pose at or after each sample's due time is the pose of
that sample. Samples then depend only on the poses and the seed, never on process scheduling, so a run
repeats exactly and a replay sees the same data. A reader's rounds may also be polled (irregular, some failing):
rfidnav_common.polling, of which this is the regular case.
"""

from __future__ import annotations

from rfidnav_common.polling import PollClock, Polling


class GroundTruthSchedule(PollClock):
    """A sample every ``period_s`` on the grid: a poll clock without jitter or failures (it draws nothing)."""

    def __init__(self, period_s: float) -> None:
        super().__init__(Polling(period_s))
