"""The thermometer's parameters and its registration (the rfidnav.nodes entry point of its setup.py)."""

from __future__ import annotations

from dataclasses import dataclass

from rfidnav_common.config import RATE_HZ, SEED, Limits, param
from rfidnav_common.node_registry import NodeRegistration


@dataclass(frozen=True)
class ThermometerParameters:
    seed: int = param("run seed; the noise stream derives from it", 0, SEED)
    rate_hz: float = param("readings per second [Hz, sim time]", 10.0, RATE_HZ)
    noise_sd_c: float = param("reading noise, standard deviation [degC]", 0.1, Limits(0.0, 10.0))
    work_s: float = param("wall time each reading takes [s]: a slow sensor for the tests", 0.0, Limits(0.0, 1.0))


THERMOMETER_SIM = NodeRegistration("thermometer_sim", ThermometerParameters, stepped=True)
