"""compass_sim: an e-compass on the simulated robot, publishing /compass (sensor_msgs/Imu, orientation only).

Readings are taken from /sim/ground_truth at ``rate_hz`` (sim time), like the reader: they depend on the
poses and the seed only. Only the orientation is measured; the angular velocity and linear acceleration
covariances are -1 (sensor_msgs/Imu: "not provided"). Roll and pitch are reported as zero with a large
variance: a planar robot's compass gives the heading alone.
"""

from __future__ import annotations

import math
from typing import Any

from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu

from rfidnav_common.frames import MAP_FRAME
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.ros import SENSOR_QOS, declare_parameters, input_drops, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import publish_static_frames
from rfidnav_sim.conversions import ground_truth_pose
from rfidnav_sim.parameters import CompassParameters

UNKNOWN_ANGLE_VARIANCE = math.pi ** 2     # roll and pitch: not measured


class CompassSimNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("compass_sim", **node_options)
        self.params: CompassParameters = declare_parameters(self, CompassParameters)
        self.noise_sd_rad = self.params.model().noise_sd_rad
        self.compass = self.params.sensor()
        self.drops = input_drops(self)
        self.publisher = self.create_publisher(Imu, "compass", SENSOR_QOS)
        publish_static_frames(self, self.params.frames())
        self.create_subscription(Odometry, "sim/ground_truth", self.on_ground_truth, SENSOR_QOS)

    def on_ground_truth(self, msg: Odometry) -> None:
        pose = ground_truth_pose(msg, MAP_FRAME, self.drops)   # the compass needs no world: the map's frame
        if pose is None:
            return
        heading = self.compass.sample(pose, seconds_of(msg.header.stamp))
        if heading is None:
            return
        reading = Imu()
        reading.header.stamp = msg.header.stamp
        reading.header.frame_id = self.params.frame_id
        reading.orientation.x, reading.orientation.y, reading.orientation.z, reading.orientation.w = \
            yaw_to_quaternion(heading)
        reading.orientation_covariance = [UNKNOWN_ANGLE_VARIANCE, 0.0, 0.0, 0.0, UNKNOWN_ANGLE_VARIANCE, 0.0,
                                          0.0, 0.0, max(self.noise_sd_rad ** 2, 1e-12)]
        reading.angular_velocity_covariance[0] = -1.0
        reading.linear_acceleration_covariance[0] = -1.0
        self.publisher.publish(reading)


def main(args: list[str] | None = None) -> int:
    return run_node(CompassSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
