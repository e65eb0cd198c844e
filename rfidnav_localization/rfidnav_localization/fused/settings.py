"""The fused filter's settings (pure): its motion noise, the parameters of each kind of evidence's model, and when
it resamples and redraws particles. RfidLocalizerParameters.settings makes them of rfid_localizer's parameters."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rfidnav_common.errors import ParameterError
from rfidnav_common.wall_tags import InductionArea
from rfidnav_localization.fused.models import CompassModel, FloorModel, PhaseDifferenceModel, WifiModel


@dataclass(frozen=True)
class FusedSettings:
    particles: int = 1000
    odometry_noise_m: float = 0.05                # sd of the distance error over a metre travelled (a random walk) [m]
    turn_noise_fraction: float = 0.05             # sd of a turn's error, relative
    heading_noise_rad: float = 0.02               # sd of the heading drift over a metre travelled (wheel slip) [rad]
    floor: FloorModel = FloorModel((0.0, 0.0))
    tag_group_read_range_m: float = 0.05          # the floor antenna's reach over a tag group's tags [m]
    phase: PhaseDifferenceModel | None = None     # None: no pair of receiving antennas
    wall_areas: dict[int, InductionArea] = field(default_factory=dict)   # side antenna port -> induction area
    wall_softness_m: float = 0.02
    wifi: WifiModel = WifiModel()
    wifi_min_travel_m: float = 2.0
    compass: CompassModel = CompassModel()
    compass_bias_sd_rad: float = math.radians(4.0)   # prior of the compass's constant bias
    odometry_scale_sd: float = 0.05                  # prior of the odometry's distance scale, about 1
    odometry_scale_walk: float = 0.005               # its random walk [per sqrt(m) travelled]
    compass_bias_walk_rad: float = math.radians(0.5)   # the compass bias's random walk [rad per sqrt(m)]
    eps: float = 0.01
    reset_threshold: float = 0.1                  # the average likelihood below which particles are redrawn
    resample_threshold: float = 0.5               # resample when the effective sample size falls below this share

    def validate(self) -> None:
        if self.particles < 10:
            raise ParameterError("particles", f"at least 10 needed, got {self.particles}")
        for name in ("odometry_noise_m", "turn_noise_fraction", "heading_noise_rad",
                     "wifi_min_travel_m", "compass_bias_sd_rad", "odometry_scale_sd", "odometry_scale_walk",
                     "compass_bias_walk_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(name, f"must be a non-negative number, got {value}")
        if not 0.0 <= self.reset_threshold < 1.0:
            raise ParameterError("reset_threshold", f"must lie in [0, 1), got {self.reset_threshold}")
        if not 0.0 < self.resample_threshold <= 1.0:
            raise ParameterError("resample_threshold", f"must lie in (0, 1], got {self.resample_threshold}")
