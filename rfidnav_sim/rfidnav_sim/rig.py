"""The simulation rig: a world's base and its sensors, stepped in one process without DDS.

Each sensor here is an object with ``sample(truth, now_s)`` (a reading, or None when none is due), the same object
a simulator node wraps where the two simulate alike (the reader of rfid_reader_sim, built by its parameters class
from the world and the run's seed), so a node and an in-process runner draw the same readings from the same
streams at the same sim times. The rig steps the base ``step_s`` at a time and takes a ground-truth sample every
``steps_per_sample`` steps (robot_sim's ``odom_rate_hz``, where the nodes sample: /sim/ground_truth; a runner's
control rate), applies each command a set delay after it was given (the DDS latency a runner may model), and keeps
the true track for the metrics. A runner is then an adapter between the rig and its paper's core: it takes each
:class:`Sample`, hands the readings to the core and the core's command back to :meth:`Rig.command`.

Sim time is counted in whole steps (``steps * step_s``), as robot_sim's clock counts it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

import numpy as np

from rfidnav_sim.schedule import GroundTruthSchedule

Reading = TypeVar("Reading")
BaseT = TypeVar("BaseT", bound="Base")
TruePose = tuple[float, float, float]      # x [m], y [m], yaw [rad] in the world's frame: ground truth


class Sensor(Protocol):
    """What a simulator node and the rig ask of a simulated sensor."""

    def sample(self, truth: TruePose, now_s: float) -> Any | None:
        """The reading at ``now_s`` with the robot at ``truth`` (the first ground-truth pose at or after it is
        due), None when no reading is due."""
        ...


class PlanarPose(Protocol):
    @property
    def x(self) -> float: ...

    @property
    def y(self) -> float: ...

    @property
    def yaw(self) -> float: ...


class Base(Protocol):
    """A simulated base: robot_sim's (rfidnav_sim.kinematics.DiffDriveBase) or an idealised one."""

    @property
    def truth(self) -> PlanarPose: ...

    @property
    def odom(self) -> PlanarPose: ...

    def set_command(self, linear_mps: float, angular_radps: float) -> None: ...

    def step(self, dt: float) -> object: ...


class ScheduledSensor(Generic[Reading]):
    """A sensor that reads every ``period_s`` of sim time on the grid: ``measure(truth, rng)`` draws each reading
    from ``rng`` (compass_sim, wifi_sim, sonar_sim: the node's own stream)."""

    def __init__(self, period_s: float, measure: Callable[[TruePose, np.random.Generator], Reading],
                 rng: np.random.Generator) -> None:
        self.schedule = GroundTruthSchedule(period_s)
        self.measure = measure
        self.rng = rng

    def sample(self, truth: TruePose, now_s: float) -> Reading | None:
        if not self.schedule.due(now_s):
            return None
        return self.measure(truth, self.rng)


def pose_of(pose: PlanarPose) -> TruePose:
    return (pose.x, pose.y, pose.yaw)


@dataclass(frozen=True)
class Sample:
    """One ground-truth sample of the rig: the sim time, the true and the odometry pose, and the readings of the
    sensors that had one due (by name, in the rig's order)."""
    time_s: float
    truth: TruePose
    odom: TruePose
    readings: Mapping[str, Any]


def steps_per_sample(step_s: float, sample_rate_hz: float) -> int:
    """Base steps between two samples at ``sample_rate_hz`` (at least one), as robot_sim counts them."""
    return max(1, round(1.0 / (sample_rate_hz * step_s)))


class Rig(Generic[BaseT]):
    """``base`` among ``sensors`` (sampled in their order: sensors that share a generator draw in that order),
    stepped ``step_s`` at a time with a ground-truth sample every ``sample_every`` steps."""

    def __init__(self, base: BaseT, step_s: float, sample_every: int, sensors: Mapping[str, Sensor],
                 command_delay_s: float = 0.0) -> None:
        self.base = base
        self.step_s = step_s
        self.sample_every = sample_every
        self.sensors = dict(sensors)
        self.command_delay_s = command_delay_s
        self.steps = 0
        self.pending: deque[tuple[float, tuple[float, float]]] = deque()
        self.times = [0.0]
        self.positions = [(base.truth.x, base.truth.y)]

    @property
    def now_s(self) -> float:
        return self.steps * self.step_s

    def command(self, linear_mps: float, angular_radps: float, given_s: float) -> None:
        """A command given at ``given_s``: the base takes it ``command_delay_s`` later, at the first step then."""
        self.pending.append((given_s + self.command_delay_s, (linear_mps, angular_radps)))

    def advance(self) -> Sample:
        """Step to the next ground-truth sample and sample there."""
        self.step()
        return self.sample()

    def step(self) -> None:
        """Step to the next ground-truth sample, applying each command once it is due, and note the true
        position there (the sensors are not sampled: see :meth:`sample`)."""
        for _ in range(self.sample_every):
            while self.pending and self.pending[0][0] <= self.now_s + 1e-9:
                self.base.set_command(*self.pending.popleft()[1])
            self.base.step(self.step_s)
            self.steps += 1
        truth = self.base.truth
        self.times.append(self.now_s)
        self.positions.append((truth.x, truth.y))

    def sample(self) -> Sample:
        """The sensors' readings now (each sensor decides whether one is due), without stepping."""
        now, truth = self.now_s, pose_of(self.base.truth)
        readings = {name: reading for name, sensor in self.sensors.items()
                    if (reading := sensor.sample(truth, now)) is not None}
        return Sample(now, truth, pose_of(self.base.odom), readings)

    def track(self) -> tuple[np.ndarray, np.ndarray]:
        """The true track so far, one position per sample: the times [s] and the positions (x, y) [m], from 0."""
        return np.array(self.times), np.array(self.positions)
