"""The thermometer's parameters and its registration (the rfidnav.nodes entry point of its setup.py)."""

from __future__ import annotations

from dataclasses import dataclass

from rfidnav_common.config import RATE_HZ, SEED, Limits, param
from rfidnav_common.node_registry import NodeRegistration
from rfidnav_common.seeding import rng_for
from rfidnav_sim.rig import ScheduledSensor

ROOM_C = 21.0


@dataclass(frozen=True)
class ThermometerParameters:
    seed: int = param("run seed; the noise stream derives from it", 0, SEED)
    rate_hz: float = param("readings per second [Hz, sim time]", 10.0, RATE_HZ)
    noise_sd_c: float = param("reading noise, standard deviation [degC]", 0.1, Limits(0.0, 10.0))
    work_s: float = param("wall time each reading takes [s]: a slow sensor for the tests", 0.0, Limits(0.0, 1.0))

    def sensor(self) -> ScheduledSensor[float]:
        """The thermometer the node samples and a runner's rig can take: a room's temperature [degC] with noise
        every 1/rate_hz, its stream seeded from ``seed``."""
        return ScheduledSensor(1.0 / self.rate_hz, lambda truth, rng: ROOM_C + float(rng.normal(0.0, self.noise_sd_c)),
                               rng_for(self.seed, "thermometer_sim"))


THERMOMETER_SIM = NodeRegistration("thermometer_sim", ThermometerParameters, stepped=True)
