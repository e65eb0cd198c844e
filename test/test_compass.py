"""The e-compass simulator (paper 003): model statistics, and the node's /compass readings."""

from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu

from rfidnav_common.config import parameters_from_mapping
from rfidnav_common.errors import ConfigError
from rfidnav_common.geometry import quaternion_to_yaw
from rfidnav_common.ros import SENSOR_QOS
from rfidnav_sim.compass_model import CompassModel
from rfidnav_sim.compass_sim_node import CompassSimNode
from rfidnav_sim.parameters import CompassParameters
from support.graph import Graph, ground_truth

pytestmark = pytest.mark.tier("unit")


def test_readings_carry_the_bias_and_the_noise_and_stay_wrapped() -> None:
    model = CompassModel(noise_sd_rad=math.radians(3.0), bias_rad=math.radians(5.0))
    rng = np.random.default_rng(1)
    true_yaw = math.radians(178.0)      # the bias pushes readings across +-pi
    readings = np.array([model.measure(true_yaw, rng) for _ in range(4000)])
    assert np.all((readings > -math.pi) & (readings <= math.pi))
    errors = np.remainder(readings - true_yaw + math.pi, 2.0 * math.pi) - math.pi
    assert math.degrees(errors.mean()) == pytest.approx(5.0, abs=0.2)
    assert math.degrees(errors.std()) == pytest.approx(3.0, rel=0.1)
    assert CompassModel(noise_sd_rad=0.0, bias_rad=0.1).measure(0.2, rng) == pytest.approx(0.3)


@pytest.mark.parametrize("field, value", [("noise_sd_deg", -1.0), ("rate_hz", 0.0), ("bias_deg", math.inf)])
def test_bad_parameters_name_the_field(field: str, value: float) -> None:
    with pytest.raises(ConfigError, match=field.replace("_deg", "")):
        parameters_from_mapping(CompassParameters, {field: value}, "compass_sim.yaml")


@pytest.mark.tier("node")
def test_compass_sim_publishes_the_heading_at_its_rate_on_the_ground_truth_clock(graph: Graph) -> None:
    graph.add(CompassSimNode(context=graph.context, parameter_overrides=[
        Parameter("seed", value=3), Parameter("rate_hz", value=25.0), Parameter("noise_sd_deg", value=0.0),
        Parameter("bias_deg", value=-4.0)]))
    readings: list[Imu] = []
    truth_pub = graph.probe.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
    compass_sub = graph.probe.create_subscription(Imu, "/compass", readings.append, SENSOR_QOS)
    graph.spin_until(lambda: truth_pub.get_subscription_count() > 0 and compass_sub.get_publisher_count() > 0,
                     "compass_sim's topics")
    for k in range(1, 11):                      # ground truth at 50 Hz, readings due at 25 Hz
        truth_pub.publish(ground_truth(1.0, 2.0, 30.0 + k, round(0.02 * k, 2)))
    graph.spin_until(lambda: len(readings) >= 6, "6 readings on /compass")
    stamps = [round(r.header.stamp.sec + r.header.stamp.nanosec * 1e-9, 6) for r in readings]
    assert stamps == [0.02, 0.04, 0.08, 0.12, 0.16, 0.2]
    for reading, stamp in zip(readings, stamps):
        q = reading.orientation
        expected = 30.0 + round(stamp / 0.02) - 4.0
        assert math.degrees(quaternion_to_yaw(q.x, q.y, q.z, q.w)) == pytest.approx(expected)
        assert reading.angular_velocity_covariance[0] == -1.0 and reading.linear_acceleration_covariance[0] == -1.0
        assert reading.orientation_covariance[8] <= 1e-12
