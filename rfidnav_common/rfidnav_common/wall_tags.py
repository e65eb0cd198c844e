"""Wall tags (paper 004) and a side antenna's induction area: the geometry the simulated sensor reads by and the
fused localizer weighs by (pure; rfidnav_sim.wall_tag_model has the reader and its misses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UNIT_TOLERANCE = 1e-6


@dataclass(frozen=True)
class WallTag:
    tag_id: str
    position: tuple[float, float]           # on a wall, world frame [m]
    normal: tuple[float, float]             # unit, out of the wall into the hallway the plate faces

    def __post_init__(self) -> None:
        if len(self.position) != 2 or not all(math.isfinite(v) for v in self.position):
            raise ValueError(f"{self.tag_id}: position: {self.position} is not a finite (x, y)")
        if len(self.normal) != 2 or not abs(math.hypot(*self.normal) - 1.0) <= UNIT_TOLERANCE:
            raise ValueError(f"{self.tag_id}: normal: {self.normal} is not a unit (x, y)")


@dataclass(frozen=True)
class InductionArea:
    """Where the sensor reads a tag: a width_m x depth_m rectangle reaching out from the antenna along its bearing.

    The default antenna sits at the platform's centre looking left, so the area reaches 1 m from the robot's
    centre: the paper's "the robot must move along the wall at a distance of less than 1 m".
    """

    position: tuple[float, float] = (0.0, 0.0)     # antenna in base_link [m]
    bearing_rad: float = math.pi / 2.0             # CCW from forward: left, towards the followed wall
    width_m: float = 0.40
    depth_m: float = 1.00

    def __post_init__(self) -> None:
        if len(self.position) != 2 or not all(math.isfinite(v) for v in self.position):
            raise ValueError(f"position: {self.position} is not a finite (x, y)")
        if not math.isfinite(self.bearing_rad):
            raise ValueError(f"bearing_rad: {self.bearing_rad} is not finite")
        for name in ("width_m", "depth_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: {value} is not a finite positive number")


def area_margins(area: InductionArea, states: np.ndarray, tag: WallTag) -> np.ndarray:
    """For robot poses ``states`` (3 x n: x, y, yaw in the map frame), how far ``tag`` lies inside the induction
    area [m]: the distance to its nearest edge, negative outside it; -inf where the plate faces away from the
    antenna (the same test as the simulator's, edges included at 0)."""
    x, y, yaw = states
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    ax, ay = area.position
    antenna_x = x + cos_yaw * ax - sin_yaw * ay
    antenna_y = y + sin_yaw * ax + cos_yaw * ay
    bearing = yaw + area.bearing_rad
    c, s = np.cos(bearing), np.sin(bearing)
    to_tag_x, to_tag_y = tag.position[0] - antenna_x, tag.position[1] - antenna_y
    depth = c * to_tag_x + s * to_tag_y
    across = -s * to_tag_x + c * to_tag_y
    margin = np.minimum(np.minimum(depth, area.depth_m - depth), area.width_m / 2.0 - np.abs(across))
    facing = tag.normal[0] * -to_tag_x + tag.normal[1] * -to_tag_y > 0.0
    return np.where(facing, margin, -np.inf)
