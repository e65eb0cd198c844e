"""Backscatter phase physics shared by the reader simulator and the controllers."""

from __future__ import annotations

import math

import numpy as np

SPEED_OF_LIGHT_MPS = 299_792_458.0
TWO_PI = 2.0 * math.pi


def wavelength_m(frequency_hz: float) -> float:
    return SPEED_OF_LIGHT_MPS / frequency_hz


def round_trip_phase(distance_m, frequency_hz: float, offset_rad=0.0):
    """Phase [0, 2*pi) of a backscatter link of one-way length ``distance_m``: 4*pi*d/lambda + offset."""
    return np.mod(4.0 * np.pi * np.asarray(distance_m) / wavelength_m(frequency_hz) + offset_rad, TWO_PI)


def range_change_m(phase_change_rad: float, frequency_hz: float) -> float:
    """One-way range change that changes the round-trip phase by ``phase_change_rad``."""
    return phase_change_rad * wavelength_m(frequency_hz) / (4.0 * math.pi)
