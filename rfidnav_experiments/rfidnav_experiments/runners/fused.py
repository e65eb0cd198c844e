"""The fused localizer (rfidnav_localization.fused) run beside a paper's own localizer on the same runs: it sees
what the robot's sensors give in each step (the runner's ``observe`` hook), never the truth, and is scored
against the truth step by step together with the paper's estimate (pure, in-process).

Per step with an estimate: the position and heading errors, and the normalised estimation error squared (NEES)
of the pose against the estimate's own covariance -- (x, y, yaw) for the fused filter, (x, y) with the paper's
isotropic sd for the two-tier dead reckoning, whose heading is the compass's and has no sd.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_experiments.runners.two_tier import StepSeen
from rfidnav_localization.fused.filter import Evidence
from rfidnav_localization.fused.localizer import FusedLocalizer

MIN_VARIANCE = 1e-12     # a covariance with a zero variance (a collapsed cloud) is floored, not inverted


@dataclass
class Track:
    """A localizer's errors over a run, one entry per step it had an estimate."""
    steps: int = 0                                   # steps of the run, estimate or not
    position_errors_m: list[float] = field(default_factory=list)
    heading_errors_rad: list[float] = field(default_factory=list)
    nees: list[float] = field(default_factory=list)
    nees_dof: int = 3

    def add(self, position_error: tuple[float, float], heading_error: float | None, covariance: np.ndarray) -> None:
        self.position_errors_m.append(math.hypot(*position_error))
        if heading_error is not None:
            self.heading_errors_rad.append(heading_error)
        error = np.array(position_error if covariance.shape[0] == 2 else (*position_error, heading_error or 0.0))
        covariance = covariance + MIN_VARIANCE * np.eye(len(error))
        self.nees.append(float(error @ np.linalg.solve(covariance, error)))

    @property
    def fix_rate(self) -> float:
        return len(self.position_errors_m) / self.steps if self.steps else 0.0


class Beside:
    """The fused localizer fed by a two-tier run's steps (paper 003), and both tracks scored."""

    def __init__(self, localizer: FusedLocalizer) -> None:
        self.localizer = localizer
        self.fused = Track(nees_dof=3)
        self.paper = Track(nees_dof=2)

    def __call__(self, seen: StepSeen) -> None:
        self.localizer.on_odometry(seen.odom)
        estimate = self.localizer.on_round(Evidence(floor_tag_ids=seen.floor_reads, wifi_fix=seen.wifi_fix,
                                                    compass_yaw_rad=seen.compass_yaw_rad))
        x, y, yaw = seen.truth
        self.fused.steps += 1
        self.paper.steps += 1
        if estimate is not None:
            pose = estimate.pose
            self.fused.add((pose.x - x, pose.y - y), wrap_angle(pose.yaw - yaw), pose.covariance)
        paper = seen.paper
        if paper.position is not None:
            heading = wrap_angle(paper.yaw - yaw) if paper.yaw is not None else None
            self.paper.add((paper.position[0] - x, paper.position[1] - y), heading,
                           np.eye(2) * max(paper.sd_m, 1e-6) ** 2)
