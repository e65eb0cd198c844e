"""Go to a point: the motion primitive paper 003's robot uses between landmarks (turn towards the target, then
drive with a proportional heading correction; stop within a tolerance)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from rfidnav_common.errors import ParameterError
from rfidnav_common.geometry import wrap_angle


@dataclass(frozen=True)
class GoToSettings:
    speed_mps: float = 0.2               # paper 001's speed; paper 003's iRobot Create drives up to 0.5 m/s
    turn_rate_radps: float = 0.8         # angular speed limit
    heading_gain_per_s: float = 2.0      # yaw rate per radian of heading error
    turn_in_place_rad: float = math.radians(30.0)   # turn on the spot first when the target is further off
    tolerance_m: float = 0.02            # arrived within this distance

    def validate(self) -> None:
        for name in ("speed_mps", "turn_rate_radps", "heading_gain_per_s", "turn_in_place_rad", "tolerance_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(name, f"must be a positive number, got {value}")


def go_to_command(position: tuple[float, float], yaw: float, target: tuple[float, float],
                  settings: GoToSettings) -> tuple[float, float] | None:
    """(linear, angular) velocity towards ``target`` from the estimated pose; None once within tolerance.

    The linear speed slows in the last few centimetres (no overshoot at the control rate) and is zero while
    the target is more than ``turn_in_place_rad`` off the heading."""
    dx, dy = target[0] - position[0], target[1] - position[1]
    distance = math.hypot(dx, dy)
    if distance <= settings.tolerance_m:
        return None
    error = wrap_angle(math.atan2(dy, dx) - yaw)
    angular = max(-settings.turn_rate_radps, min(settings.turn_rate_radps, settings.heading_gain_per_s * error))
    if abs(error) > settings.turn_in_place_rad:
        return 0.0, angular
    linear = min(settings.speed_mps, distance * settings.heading_gain_per_s) * math.cos(error)
    return linear, angular
