"""sonar_sim (paper 004): one Range per rangefinder per sweep, from the world's walls, on the ground-truth clock."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import Range

from rfidnav_common.ros import SENSOR_QOS
from rfidnav_sim.sonar_model import PAPER_LAYOUT
from rfidnav_sim.sonar_sim_node import SonarSimNode
from support.graph import Graph, ground_truth

pytestmark = pytest.mark.tier("node")


def test_every_rangefinder_publishes_its_range_once_a_sweep(graph: Graph, tmp_path: Path) -> None:
    world = tmp_path / "hallway.yaml"       # a 1.6 m hallway along +x, closed 3 m ahead
    world.write_text("name: hallway\nwall_tags: [{id: T, position: [1, 1.6], normal: [0, -1]}]\n"
                     "walls: [[-5, 0, 3, 0], [-5, 1.6, 3, 1.6], [3, 0, 3, 1.6]]\n")
    graph.add(SonarSimNode(context=graph.context, parameter_overrides=[
        Parameter("world_file", value=str(world)), Parameter("noise_sd_m", value=0.0),
        Parameter("noise_fraction", value=0.0), Parameter("rate_hz", value=10.0)]))
    ranges: dict[str, list[Range]] = {r.name: [] for r in PAPER_LAYOUT}
    for name, received in ranges.items():
        graph.probe.create_subscription(Range, f"/sonar/{name}", received.append, SENSOR_QOS)
    truth_pub = graph.probe.create_publisher(Odometry, "/sim/ground_truth", SENSOR_QOS)
    graph.spin_until(lambda: truth_pub.get_subscription_count() > 0, "sonar_sim's subscription")
    for k in range(1, 11):                  # 0.2 s at 50 Hz: sweeps at 0.02 and 0.1 s (then 0.2)
        truth_pub.publish(ground_truth(0.0, 0.8, 0.0, round(0.02 * k, 2)))
    graph.spin_until(lambda: all(len(r) >= 2 for r in ranges.values()), "two sweeps on every /sonar topic")
    left = ranges["left"][0]
    assert left.radiation_type == Range.ULTRASOUND and left.header.frame_id == "sonar_left"
    assert left.range == pytest.approx(0.8 - 0.175, abs=1e-6)          # mounted at the robot's left edge
    # The end wall 2.825 m ahead; the cone's edge rays (12.5 deg) would meet the side walls only at 3.70 m.
    assert ranges["front"][0].range == pytest.approx(3.0 - 0.175, abs=1e-6)
    assert [round(r.header.stamp.sec + r.header.stamp.nanosec * 1e-9, 6) for r in ranges["right"][:2]] == [0.02, 0.1]
    assert all(math.isfinite(r[0].range) for r in ranges.values())
