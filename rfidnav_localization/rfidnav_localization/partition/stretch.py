"""A straight stretch of the robot's drive, as the odometry tells it: both localization methods take the
heading from the partitions entered along one."""

from __future__ import annotations

from dataclasses import dataclass

from rfidnav_common.tag_lattice import Coordinate


@dataclass
class Stretch:
    """A straight stretch: the partitions entered (in order) and the odometry headings seen during it."""
    start_odom_yaw: float
    partitions: list[frozenset[Coordinate]]
    yaw_change_sum: float = 0.0
    updates: int = 0

    @property
    def mean_odom_yaw(self) -> float:
        return self.start_odom_yaw + (self.yaw_change_sum / self.updates if self.updates else 0.0)

