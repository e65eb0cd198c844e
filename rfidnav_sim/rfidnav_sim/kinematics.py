"""Differential-drive robot base: wheel-speed kinematics with limits, and drifting wheel odometry.

The commanded (v, w) becomes left/right wheel speeds, each limited in speed and acceleration, so
the limits act where a real base enforces them. Odometry integrates the same wheel speeds through
slightly wrong wheel radii and track width (the systematic drift that makes dead reckoning fail)
plus random per-step slip.

Walls are obstacles: the base is a disc of ``footprint_radius_m``, and a step that would take it closer to a
wall than that is not made (the wheels stall: neither the true pose nor the odometry moves). A wall touched in
the front half presses the bumper on that side (both when it is within BOTH_BUMPERS_RAD of straight ahead), and
the base then does what the Create driver does (rfidnav_common.base_safety): it stops, refuses forward motion
while the bumper is pressed, and reports each press and release as a /base/event record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfidnav_common.base_safety import BUMP_LEFT, BUMP_RIGHT, CONDITIONS, BaseEventRecord, ConditionTracker, gate_motion
from rfidnav_common.geometry import nearest_on_segments
from rfidnav_sim.nearby import NearbyGrid

CONTACT_MARGIN_M = 0.005        # a wall this much beyond the footprint still presses the bumper (no flicker)
BOTH_BUMPERS_RAD = math.radians(20.0)   # a wall this close to straight ahead presses both bumpers
# The walls the base's contact checks look at: those a 1 m cell lists within this of it (rfidnav_sim.nearby). A
# check needs the nearest wall only when it is within the footprint and a step of it; beyond this, the clearance
# taken as this distance only makes the next check come sooner.
NEAR_WALLS_M = 1.0
SLIP_BATCH = 256                # odometry slip draws fetched at a time (the generator is the odometry's alone)


@dataclass(frozen=True)
class BaseLimits:
    track_width_m: float = 0.30
    max_wheel_speed_mps: float = 0.5
    max_wheel_accel_mps2: float = 1.0
    command_timeout_s: float = 0.5
    footprint_radius_m: float = 0.17    # a round base (Create 2: 34 cm across); what touches the walls


@dataclass(frozen=True)
class OdometryDrift:
    """Odometry reports each wheel's travel times (1 + scale error) and integrates with the track width
    times (1 + track error); ``slip_std`` adds a random relative error to each wheel's travel every step."""

    left_scale_error: float = 0.0
    right_scale_error: float = 0.0
    track_scale_error: float = 0.0
    slip_std: float = 0.0


@dataclass
class Pose2D:
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0

    def advance(self, left_m: float, right_m: float, track_width_m: float) -> None:
        """Move by the given wheel travels (exact arc integration, so the step size does not bias it)."""
        distance = 0.5 * (left_m + right_m)
        turn = (right_m - left_m) / track_width_m
        if abs(turn) < 1e-12:
            self.x += distance * math.cos(self.yaw)
            self.y += distance * math.sin(self.yaw)
        else:
            radius = distance / turn
            self.x += radius * (math.sin(self.yaw + turn) - math.sin(self.yaw))
            self.y -= radius * (math.cos(self.yaw + turn) - math.cos(self.yaw))
        self.yaw = math.remainder(self.yaw + turn, 2.0 * math.pi)


def moves_into_wall(walls: np.ndarray, before: tuple[float, float], after: tuple[float, float],
                    footprint_radius_m: float) -> bool:
    """Whether moving a round base of ``footprint_radius_m`` from ``before`` to ``after`` takes it into one of
    ``walls`` (N x 4, N >= 1): closer than its radius and closer than it was (moving away from a wall it already
    overlaps is allowed: that is how a robot put down too close gets free)."""
    distance, _ = nearest_on_segments(after, walls)
    return distance < footprint_radius_m and distance < nearest_on_segments(before, walls)[0]


# A wall as the base's contact checks use it: start (x, y), direction (dx, dy) to its end, squared length.
WallRow = tuple[float, float, float, float, float]


def wall_rows(walls: np.ndarray) -> list[WallRow]:
    return [(x1, y1, x2 - x1, y2 - y1, (x2 - x1) * (x2 - x1) + (y2 - y1) * (y2 - y1))
            for x1, y1, x2, y2 in walls.tolist()]


def nearest_wall(x: float, y: float, rows: list[WallRow]) -> tuple[float, float, float]:
    """(distance, closest x, closest y) of the nearest of ``rows`` to (x, y), the first among equals: the arithmetic
    of rfidnav_common.geometry.nearest_on_segments to the bit, in plain floats (a handful of walls: numpy's calls
    would cost more than the sums)."""
    best, best_x, best_y = math.inf, math.nan, math.nan
    for x1, y1, dx, dy, length_sq in rows:
        t = ((x - x1) * dx + (y - y1) * dy) / (length_sq if length_sq > 0.0 else 1.0)
        t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
        closest_x, closest_y = x1 + t * dx, y1 + t * dy
        ex, ey = closest_x - x, closest_y - y
        distance = math.sqrt(ex * ex + ey * ey)
        if distance < best:
            best, best_x, best_y = distance, closest_x, closest_y
    return best, best_x, best_y


def unicycle_step(yaw: float, linear_mps: float, angular_radps: float, dt: float) -> tuple[float, float, float]:
    """(dx, dy, dyaw) of an ideal unicycle over ``dt``, moving along the mid-step heading: the robot of the
    in-process runners where the base's wheel limits and motor dynamics do not matter."""
    mid = yaw + 0.5 * angular_radps * dt
    return linear_mps * dt * math.cos(mid), linear_mps * dt * math.sin(mid), angular_radps * dt


class IdealUnicycle:
    """The idealised base of paper 003's in-process runs: an ideal unicycle (:func:`unicycle_step`, no wheel limits
    or motor dynamics) whose steps into a wall are not made (robot_sim's round base stalls there; each such step
    is counted in ``bumps``), and its wheel odometry: the same motion with the distance off by
    ``odometry_scale_error``. Its yaw is not wrapped."""

    def __init__(self, start: tuple[float, float, float], walls: np.ndarray, footprint_radius_m: float,
                 odometry_scale_error: float) -> None:
        self.truth = Pose2D(*start)
        self.odom = Pose2D()
        self.walls = walls
        self.footprint_radius_m = footprint_radius_m
        self.odometry_scale_error = odometry_scale_error
        self.command = (0.0, 0.0)
        self.bumps = 0
        self.distance_travelled_m = 0.0

    def set_command(self, linear_mps: float, angular_radps: float) -> None:
        self.command = (linear_mps, angular_radps)

    def step(self, dt: float) -> None:
        """Drive ``dt`` at the command (against a wall it only turns)."""
        linear, angular = self.command
        truth = self.truth
        dx, dy, dyaw = unicycle_step(truth.yaw, linear, angular, dt)
        if len(self.walls) and moves_into_wall(self.walls, (truth.x, truth.y), (truth.x + dx, truth.y + dy),
                                               self.footprint_radius_m):
            self.bumps += 1
            linear = dx = dy = 0.0
        truth.x, truth.y, truth.yaw = truth.x + dx, truth.y + dy, truth.yaw + dyaw
        self.distance_travelled_m += abs(linear) * dt
        odom = self.odom
        dx, dy, dyaw = unicycle_step(odom.yaw, linear * (1.0 + self.odometry_scale_error), angular, dt)
        odom.x, odom.y, odom.yaw = odom.x + dx, odom.y + dy, odom.yaw + dyaw


class DiffDriveBase:
    """Ground-truth motion and odometry of a differential-drive base, stepped at a fixed dt."""

    def __init__(self, start: Pose2D, limits: BaseLimits, drift: OdometryDrift, rng: np.random.Generator,
                 walls: np.ndarray | None = None) -> None:
        self.limits = limits
        self.walls = np.zeros((0, 4)) if walls is None else np.asarray(walls, dtype=float).reshape(-1, 4)
        walls_array = self.walls
        self.near_walls = NearbyGrid(walls_array, NEAR_WALLS_M, lambda indices: wall_rows(walls_array[indices]))
        self.bumpers = ConditionTracker()
        self.bumped = False             # either bumper pressed (the tracker's, kept here: asked every step)
        self.bumps = 0                  # presses so far (either bumper)
        # How far the base may move before a wall could be within CONTACT_MARGIN_M of its footprint: the distance
        # to the walls changes by no more than the distance moved, so until then no wall needs looking at.
        self.clearance_m = 0.0
        self.drift = drift
        self.rng = rng
        self.slips: list[float] = []    # slip draws fetched, and the next one's index
        self.slip_index = 0
        self.truth = Pose2D(start.x, start.y, start.yaw)
        self.odom = Pose2D()  # odom frame starts at the robot's start pose (REP 105)
        self.left_speed = 0.0
        self.right_speed = 0.0
        self.command = (0.0, 0.0)
        self.command_age_s = math.inf
        self.distance_travelled_m = 0.0
        # The other robots of its world (rfidnav_sim.fleet): round bases it stops at as at a wall.
        self.others: list[DiffDriveBase] = []

    def set_command(self, linear_mps: float, angular_radps: float) -> None:
        """The commanded (v, w); finite, else a ValueError (a NaN would make the pose NaN for good). Beyond the
        wheel limits is allowed: the wheels saturate (step), as a real base's do."""
        if not (math.isfinite(linear_mps) and math.isfinite(angular_radps)):
            raise ValueError(f"set_command: ({linear_mps}, {angular_radps}) is not a finite velocity")
        self.command = (linear_mps, angular_radps)
        self.command_age_s = 0.0

    @property
    def velocity(self) -> tuple[float, float]:
        """True (v, w) of the base now."""
        return (0.5 * (self.left_speed + self.right_speed),
                (self.right_speed - self.left_speed) / self.limits.track_width_m)

    def step(self, dt: float) -> list[BaseEventRecord]:
        """Advance ``dt``; the /base/event records of bumpers pressed or released in this step."""
        limits = self.limits
        linear, angular = self.command if self.command_age_s <= limits.command_timeout_s else (0.0, 0.0)
        linear, angular = gate_motion(linear, angular, bumped=self.bumped, halted=False)
        self.command_age_s += dt
        half_track = 0.5 * limits.track_width_m
        left_target, right_target = linear - angular * half_track, linear + angular * half_track
        # Scale both wheels together so a saturated command keeps its curvature.
        peak = max(abs(left_target), abs(right_target))
        if peak > limits.max_wheel_speed_mps:
            left_target = left_target * limits.max_wheel_speed_mps / peak
            right_target = right_target * limits.max_wheel_speed_mps / peak
        max_change = limits.max_wheel_accel_mps2 * dt
        left_before, right_before = self.left_speed, self.right_speed
        self.left_speed += min(max(left_target - left_before, -max_change), max_change)
        self.right_speed += min(max(right_target - right_before, -max_change), max_change)
        left_m = 0.5 * (left_before + self.left_speed) * dt
        right_m = 0.5 * (right_before + self.right_speed) * dt
        truth = self.truth
        x, y, yaw = truth.x, truth.y, truth.yaw
        truth.advance(left_m, right_m, limits.track_width_m)
        events: list[BaseEventRecord] = []
        moved = math.hypot(truth.x - x, truth.y - y)
        if self.others:
            # Other robots move on their own, so no clearance holds: the nearest obstacle, wall or robot, every step.
            distance, closest_x, closest_y = self.nearest_obstacle(truth.x, truth.y)
            if distance < limits.footprint_radius_m:
                before = self.nearest_obstacle(x, y)
                if distance < before[0]:
                    truth.x, truth.y, truth.yaw, self.left_speed, self.right_speed = x, y, yaw, 0.0, 0.0
                    left_m = right_m = 0.0
                    distance, closest_x, closest_y = before
            events = self.update_bumpers(min(distance, NEAR_WALLS_M), (closest_x, closest_y))
        elif len(self.walls) and (self.bumped or moved >= self.clearance_m):
            # The walls listed near the step's end, in the floor's order: every wall within NEAR_WALLS_M of it, so
            # the nearest one (and its index among equals) when it matters, as among all the walls.
            near = self.near_walls.near(truth.x, truth.y)
            distance, closest_x, closest_y = nearest_wall(truth.x, truth.y, near)
            # Into a wall (moves_into_wall): closer than the footprint's radius and closer than before.
            if distance < limits.footprint_radius_m:
                before = nearest_wall(x, y, near)
                if distance < before[0]:
                    # The wheels stall against the wall: the step is not made, and the encoders do not count it.
                    truth.x, truth.y, truth.yaw, self.left_speed, self.right_speed = x, y, yaw, 0.0, 0.0
                    left_m = right_m = 0.0
                    distance, closest_x, closest_y = before
            distance = min(distance, NEAR_WALLS_M)
            point = (closest_x, closest_y)
            self.clearance_m = distance - limits.footprint_radius_m - CONTACT_MARGIN_M
            events = self.update_bumpers(distance, point)
        else:
            self.clearance_m -= moved
        self.distance_travelled_m += abs(0.5 * (left_m + right_m))
        drift = self.drift
        left_slip, right_slip = self.slip() if drift.slip_std > 0.0 else (0.0, 0.0)
        self.odom.advance(left_m * (1.0 + drift.left_scale_error + left_slip),
                          right_m * (1.0 + drift.right_scale_error + right_slip),
                          limits.track_width_m * (1.0 + drift.track_scale_error))
        return events

    def nearest_obstacle(self, x: float, y: float) -> tuple[float, float, float]:
        """(distance, closest x, closest y) of the nearest wall near (x, y) or other robot's footprint edge."""
        best = nearest_wall(x, y, self.near_walls.near(x, y)) if len(self.walls) else (math.inf, math.nan, math.nan)
        for other in self.others:
            there = other.truth
            dx, dy = x - there.x, y - there.y
            centres = math.hypot(dx, dy)
            radius = other.limits.footprint_radius_m
            if centres - radius < best[0]:
                towards = (dx / centres, dy / centres) if centres > 0.0 else (1.0, 0.0)
                best = (centres - radius, there.x + radius * towards[0], there.y + radius * towards[1])
        return best

    def slip(self) -> tuple[float, float]:
        """This step's (left, right) slip: the next two of the generator's normal draws, fetched SLIP_BATCH
        steps at a time (one draw of 2 n is the stream of n draws of 2, to the bit; far cheaper)."""
        if self.slip_index == len(self.slips):
            self.slips, self.slip_index = self.rng.normal(0.0, self.drift.slip_std, 2 * SLIP_BATCH).tolist(), 0
        index = self.slip_index
        self.slip_index = index + 2
        return self.slips[index], self.slips[index + 1]

    def update_bumpers(self, distance: float, point: tuple[float, float]) -> list[BaseEventRecord]:
        """The bumpers' edges with the nearest wall ``distance`` away at ``point``: pressed where it touches the
        front half (moving away from a wall the base already overlaps is allowed: that is how a robot placed
        too close gets free)."""
        pressed = dict.fromkeys(CONDITIONS, False)
        if distance <= self.limits.footprint_radius_m + CONTACT_MARGIN_M:
            bearing = math.remainder(math.atan2(point[1] - self.truth.y, point[0] - self.truth.x)
                                     - self.truth.yaw, 2.0 * math.pi)
            if abs(bearing) < math.pi / 2.0:          # the bumper covers the front half
                pressed[BUMP_LEFT] = bearing > -BOTH_BUMPERS_RAD
                pressed[BUMP_RIGHT] = bearing < BOTH_BUMPERS_RAD
        events = self.bumpers.events(pressed)
        self.bumped = self.bumpers.bumped
        if any(event.active for event in events):
            # The Create driver stops the base on a press; a new command is needed to move again.
            self.command, self.left_speed, self.right_speed = (0.0, 0.0), 0.0, 0.0
            self.bumps += 1
        return events
