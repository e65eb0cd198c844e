"""Driving to a point on a localizer's pose (ours, issue 20): the navigator for a robot whose position comes from
a localizer node -- the fused localizer, or any that publishes a pose with covariance -- as a Nav2 controller takes
AMCL's. It plans the way round the robot map's walls (rfidnav_planning.wall_paths, paper 003's planner), drives it
waypoint by waypoint (rfidnav_control.go_to) and stands still while the pose is unknown, stale or less certain
than ``max_position_sd_m``; it plans again when the pose jumps (a localizer that found the robot elsewhere).

Pure module: no ROS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rfidnav_common.errors import ParameterError
from rfidnav_control.go_to import GoToSettings, go_to_command
from rfidnav_planning.wall_paths import Point, WallMap, WallPlanner

WAITING, DRIVING, DONE = "waiting_for_pose", "driving", "done"


@dataclass(frozen=True)
class PoseNavigatorSettings:
    go_to: GoToSettings = GoToSettings()
    wall_clearance_m: float = 0.30        # the way keeps this far from the map's walls
    waypoint_tolerance_m: float = 0.10    # a waypoint round a wall is passed within this
    max_position_sd_m: float = 0.30       # stand still while the pose is less certain than this
    replan_jump_m: float = 0.30           # plan again when the pose moves this much between two steps

    def validate(self) -> None:
        self.go_to.validate()
        for name in ("wall_clearance_m", "waypoint_tolerance_m", "max_position_sd_m", "replan_jump_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(name, f"must be a positive number, got {value}")


@dataclass(frozen=True)
class Pose:
    """A localizer's estimate: position and heading in the map frame, and the position's standard deviation."""
    x: float
    y: float
    yaw: float
    sd_m: float

    @classmethod
    def of_variances(cls, x: float, y: float, yaw: float, variance_x: float, variance_y: float) -> Pose:
        """The pose with its position's sd taken as the larger axis's: the node from a PoseWithCovariance's
        diagonal, the in-process runner from the estimate's covariance alike."""
        return cls(x, y, yaw, math.sqrt(max(variance_x, variance_y)))


@dataclass(frozen=True)
class Step:
    phase: str
    command: tuple[float, float]          # linear [m/s], angular [rad/s]
    finished: bool = False
    success: bool = False
    message: str = ""


class PoseNavigator:
    def __init__(self, settings: PoseNavigatorSettings, floor: WallMap = WallMap()) -> None:
        settings.validate()
        self.settings = settings
        self.floor = floor
        self.planner = None if floor.empty else WallPlanner(floor, settings.wall_clearance_m)
        self.target: Point | None = None
        self.route: list[Point] = []
        self.last: Pose | None = None
        self.plans = 0

    def refusal(self, target: Point) -> str | None:
        return self.floor.refusal(target)

    def start(self, target: Point) -> None:
        refusal = self.refusal(target)
        if refusal is not None:
            raise ValueError(refusal)
        self.target = (float(target[0]), float(target[1]))
        self.route, self.last, self.plans = [], None, 0

    def step(self, pose: Pose | None) -> Step:
        """One control step on the latest pose (None: none, or a stale one)."""
        if self.target is None:
            return Step(DONE, (0.0, 0.0), True, False, "no target")
        if pose is None or not pose.sd_m <= self.settings.max_position_sd_m:
            return Step(WAITING, (0.0, 0.0))
        position = (pose.x, pose.y)
        if not self.route or self.last is None or math.dist(position, (self.last.x, self.last.y)) > \
                self.settings.replan_jump_m:
            route = self.planner.path(position, self.target) if self.planner is not None else [self.target]
            if route is None:
                return Step(DONE, (0.0, 0.0), True, False,
                            f"no way round the map's walls from ({pose.x:.2f}, {pose.y:.2f}) to the target")
            self.route = list(route)
            self.plans += 1
        self.last = pose
        while len(self.route) > 1 and math.dist(position, self.route[0]) <= self.settings.waypoint_tolerance_m:
            self.route.pop(0)
        command = go_to_command(position, pose.yaw, self.route[0], self.settings.go_to)
        if command is None:
            return Step(DONE, (0.0, 0.0), True, True, f"arrived within {self.settings.go_to.tolerance_m:g} m of the "
                                                       f"target by the localizer's pose (sd {pose.sd_m:.3f} m)")
        return Step(DRIVING, command)
