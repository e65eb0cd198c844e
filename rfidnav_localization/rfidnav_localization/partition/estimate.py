"""What the partition localizer is told (its settings) and what it tells (its estimate)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from rfidnav_common.errors import ParameterError
from rfidnav_common.tag_lattice import Coordinate, Lattice

METHODS = ("paper", "filter")
YawEstimate = tuple[float, tuple[float, float], float]   # yaw, (lower, upper) bounds, standard deviation [rad]


@dataclass(frozen=True)
class LocalizerSettings:
    method: str = "paper"                    # "paper" | "filter"
    turn_threshold_rad: float = 0.05         # odometry heading change that ends a straight stretch
    particles: int = 500
    motion_noise_fraction: float = 0.02      # odometry translation/rotation noise, relative
    motion_noise_floor_m: float = 0.001      # translation noise added to every step that moves [m]
    motion_noise_yaw_rad_per_m: float = 0.02  # heading noise per metre travelled (wheel slip) [rad/m]
    boundary_softness_m: float = 0.004       # width of the soft read/no-read edge of a disc in the filter's likelihood
    read_error_probability: float = 0.01     # filter: chance a tag's read/no-read contradicts the geometry
    rogue_distance_factor: float = 2.0       # tags read together lie within factor * r of each other
    antenna_offset_m: float = 0.0            # floor antenna ahead of the rotation axis (filter only; see below)
    # The tagged area from the robot map, when known: the filter then expects no read of a lattice vertex
    # outside the deployment (there is no tag there). Positions still come from the ids alone.
    deployment_area: tuple[float, float, float, float] | None = None

    def validate(self) -> None:
        if self.method not in METHODS:
            raise ParameterError("method", f"'{self.method}' is not one of {', '.join(METHODS)}")
        if self.particles < 10:
            raise ParameterError("particles", f"at least 10 needed, got {self.particles}")
        for name in ("turn_threshold_rad", "boundary_softness_m", "rogue_distance_factor"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(name, f"must be a positive number, got {value}")
        for name in ("motion_noise_fraction", "motion_noise_floor_m", "motion_noise_yaw_rad_per_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(name, f"must be a non-negative number, got {value}")
        if not 0.0 < self.read_error_probability < 0.5:
            raise ParameterError("read_error_probability", f"must lie in (0, 0.5), got {self.read_error_probability}")
        if not math.isfinite(self.antenna_offset_m) or (self.method == "paper" and self.antenna_offset_m != 0.0):
            raise ParameterError("antenna_offset_m", "the paper method reads at the rotation axis (0); the filter "
                                                     f"takes any finite offset, got {self.antenna_offset_m}")


@dataclass(frozen=True)
class LocalizationEstimate:
    stamp_s: float
    method: str
    partition: frozenset[Coordinate]          # accepted tags' lattice coordinates (empty: nothing read this round)
    partition_tag_ids: tuple[str, ...]        # sorted
    partition_changed: bool                   # this update entered a partition other than the last one seen
    partitions_traversed: int                 # partition changes since the current straight stretch began
    position: tuple[float, float] | None      # map frame [m]; None before any valid tag
    position_covariance: tuple[float, float, float]   # (var_x, cov_xy, var_y) [m^2]
    yaw: float | None                         # [rad] in (-pi, pi]; None until estimable
    yaw_bounds: tuple[float, float] | None    # (lower, upper) [rad], lower <= yaw <= upper, may leave (-pi, pi]
    yaw_std: float | None                     # [rad]
    read_range_m: float | None
    lattice: Lattice | None
    rejected_tag_ids: tuple[str, ...]         # rogue tags rejected this round, sorted
    rogue_count: int                          # rogue reads rejected since start (or reset)
    undecodable_count: int                    # ids ignored since start: not lattice ids, or another lattice
    filter_reinitialisations: int = 0         # times the particle filter lost track and restarted

