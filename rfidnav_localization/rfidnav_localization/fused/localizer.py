"""The fused localizer over time (pure): odometry poses in, a map-frame pose with covariance out. The node
(rfid_localizer) and the in-process runners feed it alike.

The odometry arrives as poses in the odom frame; the filter is moved by the increment since the last one, in the
robot frame (so the odom frame's drift never enters). With no start given, the first round with evidence starts
global localization; ``/initialpose`` (:meth:`FusedLocalizer.set_pose`) restarts about a given pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfidnav_localization.fused.filter import FusedFilter, PoseEstimate, Update
from rfidnav_localization.fused.kinds import FloorTags
from rfidnav_localization.fused.measurement import Evidence
from rfidnav_localization.fused.settings import FusedSettings
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.motion_model import odometry_increment

Pose2D = tuple[float, float, float]


@dataclass(frozen=True)
class FusedEstimate:
    pose: PoseEstimate
    odom: Pose2D                 # the odometry pose the estimate is for: map -> odom follows from the two
    update: Update
    # The lattice floor tags read this round (paper 000's partition) and the lattice's read range r from the ids (0
    # before one was read): what the partition navigator needs besides the pose to drive on this estimate.
    partition_tag_ids: tuple[str, ...] = ()
    read_range_m: float = 0.0


class FusedLocalizer:
    def __init__(self, settings: FusedSettings, fused_map: FusedMap, rng: np.random.Generator) -> None:
        self.filter = FusedFilter(settings, fused_map, rng)
        self.odom: Pose2D | None = None

    def on_odometry(self, odom: Pose2D) -> None:
        """The latest wheel odometry pose (odom frame): the particles move by the increment since the last."""
        previous, self.odom = self.odom, odom
        if previous is None or not self.filter.initialised:
            return
        self.filter.predict(*odometry_increment(previous, odom))

    def set_pose(self, x: float, y: float, yaw: float, covariance: np.ndarray) -> None:
        """Restart about a pose (``/initialpose``); a 3 x 3 covariance over (x, y, yaw)."""
        self.filter.initialise_at(x, y, yaw, covariance)

    def on_round(self, evidence: Evidence) -> FusedEstimate | None:
        """Weigh one round's evidence; the estimate, None before odometry or while nothing has started it."""
        if self.odom is None:
            return None
        if not self.filter.initialised:
            self.filter.initialise_global()
        update = self.filter.update(evidence)
        fused_map = self.filter.map
        partition = tuple(tag_id for tag_id in evidence.get(FloorTags.name, ())
                          if fused_map.lattice_position(tag_id) is not None)
        read_range_m = fused_map.deployment.read_range_m if fused_map.deployment is not None else 0.0
        return FusedEstimate(self.filter.estimate(), self.odom, update, partition, read_range_m)
