"""When a simulated sensor samples: every ``period_s`` of sim time, on the ground-truth clock.

Sensor simulators sample on /sim/ground_truth: the first pose at or after each sample's due time is the pose of
that sample. Samples then depend only on the poses and the seed, never on process scheduling, so a run
repeats exactly and a replay sees the same data.
"""

from __future__ import annotations

import math


class GroundTruthSchedule:
    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self.next_due_s = 0.0

    def due(self, now_s: float) -> bool:
        """Whether a sample is due at ``now_s``; if so, the next one is scheduled on the period's grid."""
        if now_s + 1e-9 < self.next_due_s:
            return False
        self.next_due_s = (math.floor(now_s / self.period_s + 1e-6) + 1) * self.period_s
        return True
