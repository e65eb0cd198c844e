"""Electronic compass (paper 003's e-compass): the robot's true heading plus a constant bias and noise.

A magnetometer heading is off by a bias that stays put for a run (declination not corrected, a robot's own
motors and steel, a calibration off by a few degrees) and jitters from reading to reading. Both are here;
local disturbances near steel furniture are not (a constant bias is what paper 003's calibration step
assumes away when it "calibrates its orientation by its e-compass").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfidnav_common.errors import ParameterError
from rfidnav_common.geometry import wrap_angle


@dataclass(frozen=True)
class CompassModel:
    noise_sd_rad: float = math.radians(2.0)    # reading-to-reading jitter
    bias_rad: float = 0.0                      # constant offset for the whole run

    def validate(self) -> None:
        if not (math.isfinite(self.noise_sd_rad) and self.noise_sd_rad >= 0.0):
            raise ParameterError("noise_sd_rad", f"must be a finite non-negative number, got {self.noise_sd_rad}")
        if not math.isfinite(self.bias_rad):
            raise ParameterError("bias_rad", f"must be finite, got {self.bias_rad}")

    def measure(self, true_yaw: float, rng: np.random.Generator) -> float:
        """A heading reading in (-pi, pi] (map frame: CCW from x, REP 103)."""
        noise = rng.normal(0.0, self.noise_sd_rad) if self.noise_sd_rad > 0.0 else 0.0
        return wrap_angle(true_yaw + self.bias_rad + noise)
