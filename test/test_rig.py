"""The simulation rig (rfidnav_sim.rig): commands reach the base after their delay, sensors are sampled at their
own rates in their order, time counts whole steps, and the in-process runners and the simulator nodes draw the
same readings from a sensor built by the same parameters class. Pure-module tests."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rfidnav_sim.kinematics import IdealUnicycle, Pose2D
from rfidnav_sim.parameters import CompassParameters
from rfidnav_sim.rig import Rig, ScheduledSensor, steps_per_sample

pytestmark = pytest.mark.tier("unit")

NO_WALLS = np.zeros((0, 4))


class Recorder:
    """A base that remembers the command of each step."""

    def __init__(self) -> None:
        self.truth = Pose2D()
        self.odom = Pose2D()
        self.command = (0.0, 0.0)
        self.commands: list[tuple[float, float]] = []

    def set_command(self, linear_mps: float, angular_radps: float) -> None:
        self.command = (linear_mps, angular_radps)

    def step(self, dt: float) -> None:
        self.commands.append(self.command)
        self.truth.x += self.command[0] * dt


def test_a_command_reaches_the_base_at_the_first_step_its_delay_has_passed() -> None:
    base = Recorder()
    rig = Rig(base, 0.01, 2, {}, command_delay_s=0.03)
    rig.command(0.2, 0.0, given_s=0.0)
    for _ in range(3):
        rig.advance()
    assert base.commands == [(0.0, 0.0)] * 3 + [(0.2, 0.0)] * 3
    assert rig.now_s == pytest.approx(0.06)
    times, positions = rig.track()
    assert times.tolist() == pytest.approx([0.0, 0.02, 0.04, 0.06])
    assert positions[-1, 0] == pytest.approx(0.2 * 0.03)


def test_sim_time_counts_whole_steps_not_a_running_sum() -> None:
    rig = Rig(Recorder(), 0.01, 1, {})
    for _ in range(1000):
        rig.step()
    assert rig.now_s == 1000 * 0.01           # a running sum of 0.01 drifts off 10.0 in the last bits


def test_scheduled_sensors_read_at_their_own_rates_in_the_rigs_order_from_one_generator() -> None:
    rng = np.random.default_rng(4)
    drawn: list[str] = []

    def measure(name: str):
        def read(truth, draw):
            drawn.append(name)
            return draw.random()
        return read

    rig = Rig(Recorder(), 0.01, 5, {"fast": ScheduledSensor(0.05, measure("fast"), rng),
                                    "slow": ScheduledSensor(0.2, measure("slow"), rng)})
    samples = [rig.advance() for _ in range(8)]           # at 0.05, 0.10, ... 0.40 s
    # the slow one at its first sample (its first is due at 0), then on its grid: 0.2 and 0.4 s
    assert [sorted(sample.readings) for sample in samples] == \
        [["fast", "slow"], ["fast"], ["fast"], ["fast", "slow"], ["fast"], ["fast"], ["fast"], ["fast", "slow"]]
    assert drawn[:3] == ["fast", "slow", "fast"]
    again = np.random.default_rng(4)
    assert [value for sample in samples for value in sample.readings.values()] == \
        [again.random() for _ in range(len(drawn))]


def test_the_sample_at_start_reads_every_sensor_due_at_time_zero_without_stepping() -> None:
    rig = Rig(Recorder(), 0.01, 5, {"compass": ScheduledSensor(0.05, lambda truth, draw: truth[2],
                                                                np.random.default_rng(0))})
    sample = rig.sample()
    assert sample.time_s == 0.0 and sample.readings == {"compass": 0.0} and rig.steps == 0


def test_the_compass_the_node_samples_is_the_one_its_parameters_build_for_the_rig() -> None:
    parameters = CompassParameters(seed=7, rate_hz=10.0, noise_sd_deg=2.0)
    node_compass, rig_compass = parameters.sensor(), parameters.sensor()
    truth = (0.0, 0.0, 0.5)
    node = [node_compass.sample(truth, k * 0.02) for k in range(50)]
    rig = Rig(Recorder(), 0.01, 2, {"compass": rig_compass})
    rig.base.truth.yaw = 0.5
    readings = [rig.sample().readings.get("compass")] + [rig.advance().readings.get("compass") for _ in range(49)]
    assert readings == node and sum(reading is not None for reading in node) == 10


def test_the_ideal_unicycle_stalls_at_a_wall_counts_the_bump_and_its_odometry_runs_long() -> None:
    wall = np.array([[1.0, -1.0, 1.0, 1.0]])
    robot = IdealUnicycle((0.0, 0.0, 0.0), wall, 0.17, odometry_scale_error=0.05)
    rig = Rig(robot, 0.05, 1, {})
    rig.command(0.5, 0.0, 0.0)
    for _ in range(80):
        rig.advance()
    assert robot.truth.x == pytest.approx(1.0 - 0.17, abs=0.03) and robot.bumps > 0
    assert robot.distance_travelled_m == pytest.approx(robot.truth.x)
    assert robot.odom.x == pytest.approx(1.05 * robot.truth.x)
    assert math.isclose(robot.truth.yaw, 0.0)


def test_steps_per_sample_is_robot_sims_count() -> None:
    assert steps_per_sample(0.01, 50.0) == 2 and steps_per_sample(0.01, 20.0) == 5 and steps_per_sample(0.1, 50.0) == 1
