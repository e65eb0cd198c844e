"""thermometer_sim: /temperature (sensor_msgs/Temperature) at ``rate_hz`` of sim time, sampled on
/sim/ground_truth like compass_sim; each reading may take ``work_s`` of wall time (a slow sensor)."""

from __future__ import annotations

import time
from typing import Any

from nav_msgs.msg import Odometry
from sensor_msgs.msg import Temperature

from rfidnav_common import inputs
from rfidnav_common.frames import MAP_FRAME
from rfidnav_common.ros import SENSOR_QOS, declare_parameters, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_sim.conversions import ground_truth_pose
from rfidnav_thermometer.parameters import ThermometerParameters


class ThermometerSimNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("thermometer_sim", **node_options)
        self.params: ThermometerParameters = declare_parameters(self, ThermometerParameters)
        self.thermometer = self.params.sensor()
        self.drops = inputs.Drops(self.get_logger().warning)
        self.publisher = self.create_publisher(Temperature, "/temperature", SENSOR_QOS)
        self.create_subscription(Odometry, "/sim/ground_truth", self.on_ground_truth, SENSOR_QOS)

    def on_ground_truth(self, msg: Odometry) -> None:
        pose = ground_truth_pose(msg, MAP_FRAME, self.drops)
        celsius = None if pose is None else self.thermometer.sample(pose, seconds_of(msg.header.stamp))
        if celsius is None:
            return
        time.sleep(self.params.work_s)   # the slowness the tests ask for, not a wait for anything
        reading = Temperature()
        reading.header.stamp = msg.header.stamp
        reading.header.frame_id = "base_link"
        reading.temperature = celsius
        reading.variance = self.params.noise_sd_c ** 2
        self.publisher.publish(reading)


def main(args: list[str] | None = None) -> int:
    return run_node(ThermometerSimNode, args)
