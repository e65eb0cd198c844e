"""Differential-drive robot base: wheel-speed kinematics with limits, and drifting wheel odometry.

The commanded (v, w) becomes left/right wheel speeds, each limited in speed and acceleration, so
the limits act where a real base enforces them. Odometry integrates the same wheel speeds through
slightly wrong wheel radii and track width (the systematic drift that makes dead reckoning fail)
plus random per-step slip.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BaseLimits:
    track_width_m: float = 0.30
    max_wheel_speed_mps: float = 0.5
    max_wheel_accel_mps2: float = 1.0
    command_timeout_s: float = 0.5


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


def unicycle_step(yaw: float, linear_mps: float, angular_radps: float, dt: float) -> tuple[float, float, float]:
    """(dx, dy, dyaw) of an ideal unicycle over ``dt``, moving along the mid-step heading: the robot of the
    in-process runners where the base's wheel limits and motor dynamics do not matter."""
    mid = yaw + 0.5 * angular_radps * dt
    return linear_mps * dt * math.cos(mid), linear_mps * dt * math.sin(mid), angular_radps * dt


class DiffDriveBase:
    """Ground-truth motion and odometry of a differential-drive base, stepped at a fixed dt."""

    def __init__(self, start: Pose2D, limits: BaseLimits, drift: OdometryDrift, rng: np.random.Generator) -> None:
        self.limits = limits
        self.drift = drift
        self.rng = rng
        self.truth = Pose2D(start.x, start.y, start.yaw)
        self.odom = Pose2D()  # odom frame starts at the robot's start pose (REP 105)
        self.left_speed = 0.0
        self.right_speed = 0.0
        self.command = (0.0, 0.0)
        self.command_age_s = math.inf
        self.distance_travelled_m = 0.0

    def set_command(self, linear_mps: float, angular_radps: float) -> None:
        self.command = (linear_mps, angular_radps)
        self.command_age_s = 0.0

    @property
    def velocity(self) -> tuple[float, float]:
        """True (v, w) of the base now."""
        return (0.5 * (self.left_speed + self.right_speed),
                (self.right_speed - self.left_speed) / self.limits.track_width_m)

    def step(self, dt: float) -> None:
        limits = self.limits
        linear, angular = self.command if self.command_age_s <= limits.command_timeout_s else (0.0, 0.0)
        self.command_age_s += dt
        half_track = 0.5 * limits.track_width_m
        targets = (linear - angular * half_track, linear + angular * half_track)
        # Scale both wheels together so a saturated command keeps its curvature.
        peak = max(abs(targets[0]), abs(targets[1]))
        if peak > limits.max_wheel_speed_mps:
            targets = tuple(t * limits.max_wheel_speed_mps / peak for t in targets)
        max_change = limits.max_wheel_accel_mps2 * dt
        left_before, right_before = self.left_speed, self.right_speed
        self.left_speed += float(np.clip(targets[0] - self.left_speed, -max_change, max_change))
        self.right_speed += float(np.clip(targets[1] - self.right_speed, -max_change, max_change))
        left_m = 0.5 * (left_before + self.left_speed) * dt
        right_m = 0.5 * (right_before + self.right_speed) * dt
        self.truth.advance(left_m, right_m, limits.track_width_m)
        self.distance_travelled_m += abs(0.5 * (left_m + right_m))
        drift = self.drift
        slip = self.rng.normal(0.0, drift.slip_std, 2) if drift.slip_std > 0.0 else (0.0, 0.0)
        self.odom.advance(left_m * (1.0 + drift.left_scale_error + slip[0]),
                          right_m * (1.0 + drift.right_scale_error + slip[1]),
                          limits.track_width_m * (1.0 + drift.track_scale_error))
