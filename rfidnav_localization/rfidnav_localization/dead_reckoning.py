"""Dead reckoning between fixes, as paper 003's robot moves: distance from the wheel odometry, direction from
the e-compass, position anchored at the last fix (tier one: a WiFi fingerprint; tier two: a floor tag).

The odometry's own heading drifts without bound (wheel slip, an uneven load: paper 003 measured about 1 m of
error per 20 m with 1 kg on board), so only the distance it reports is used; the compass gives the heading
in the map frame, off by its bias and jitter but without drift. The position's standard deviation grows from
the fix's by ``drift_per_m`` for every metre driven, so a navigator can tell when a calibration is due.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

TIER_NONE, TIER_WIFI, TIER_TAG = 0, 1, 2


@dataclass(frozen=True)
class Fix:
    position: tuple[float, float]       # map frame [m]
    sd_m: float                         # standard deviation of the fix [m]
    tier: int                           # TIER_WIFI or TIER_TAG
    tag_id: str = ""                    # the tag read (tier two)


@dataclass(frozen=True)
class DeadReckoningEstimate:
    position: tuple[float, float] | None     # None before the first fix
    yaw: float | None                        # the compass heading (map frame), None before the first reading
    sd_m: float                              # position standard deviation [m]
    last_fix: Fix | None
    distance_since_fix_m: float


class DeadReckoning:
    def __init__(self, drift_per_m: float = 0.05) -> None:
        if not (math.isfinite(drift_per_m) and drift_per_m >= 0.0):
            raise ValueError(f"drift_per_m: must be a finite non-negative number, got {drift_per_m}")
        self.drift_per_m = drift_per_m
        self.position: tuple[float, float] | None = None
        self.yaw: float | None = None
        self.last_fix: Fix | None = None
        self.distance_since_fix_m = 0.0
        self.travelled_m = 0.0                  # odometry distance since the start, either way
        self._last_odom: tuple[float, float, float] | None = None

    def on_compass(self, yaw: float) -> None:
        if not math.isfinite(yaw):
            raise ValueError(f"compass: heading {yaw} is not finite")
        self.yaw = yaw

    def on_odometry(self, odom: tuple[float, float, float]) -> None:
        """An odometry pose (x, y, yaw in its own frame): the signed distance driven since the last one moves
        the estimate along the compass heading."""
        if not all(math.isfinite(value) for value in odom):
            raise ValueError(f"odometry: expected finite (x, y, yaw), got {odom}")
        previous, self._last_odom = self._last_odom, odom
        if previous is None:
            return
        dx, dy = odom[0] - previous[0], odom[1] - previous[1]
        forward = dx * math.cos(previous[2]) + dy * math.sin(previous[2])   # reversing counts negative
        self.distance_since_fix_m += abs(forward)
        self.travelled_m += abs(forward)
        if self.position is not None and self.yaw is not None:
            self.position = (self.position[0] + forward * math.cos(self.yaw),
                             self.position[1] + forward * math.sin(self.yaw))

    def on_fix(self, fix: Fix) -> None:
        self.position = fix.position
        self.last_fix = fix
        self.distance_since_fix_m = 0.0

    def estimate(self) -> DeadReckoningEstimate:
        fix_sd = self.last_fix.sd_m if self.last_fix is not None else math.inf
        return DeadReckoningEstimate(self.position, self.yaw, fix_sd + self.drift_per_m * self.distance_since_fix_m,
                                     self.last_fix, self.distance_since_fix_m)
