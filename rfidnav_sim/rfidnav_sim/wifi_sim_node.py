"""wifi_sim: the robot's WiFi interface in a simulated building, publishing /wifi/scan (WifiScan).

The building (access points, walls, path loss, the shadowing fixed per world) comes from the world file;
the receiver (noise, sensitivity) from this node's parameters. Scans are driven by /sim/ground_truth: the
first pose at or after each scan's due time (``scan_period_s`` apart in sim time) is where the scan is
taken, so scans depend on the poses and the seed only, as the RFID reader's rounds do.
"""

from __future__ import annotations

from typing import Any

from nav_msgs.msg import Odometry

from rfidnav_common.ros import SENSOR_QOS, declare_parameters, input_drops, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_msgs.msg import WifiScan
from rfidnav_sim.conversions import ground_truth_pose, wifi_scan_message
from rfidnav_sim.parameters import WifiSimParameters
from rfidnav_sim.world import load_world


class WifiSimNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("wifi_sim", **node_options)
        self.params: WifiSimParameters = declare_parameters(self, WifiSimParameters)
        world = load_world(self.params.world_file)
        self.world_frame = world.frame_id
        self.drops = input_drops(self)
        self.receiver = self.params.sensor(world)
        self.publisher = self.create_publisher(WifiScan, "wifi/scan", SENSOR_QOS)
        self.create_subscription(Odometry, "sim/ground_truth", self.on_ground_truth, SENSOR_QOS)
        self.get_logger().info(f"{len(world.access_points)} access points, {len(world.walls)} walls, "
                               f"a scan every {self.params.scan_period_s:g} s")

    def on_ground_truth(self, msg: Odometry) -> None:
        pose = ground_truth_pose(msg, self.world_frame, self.drops)
        if pose is None:
            return
        readings = self.receiver.sample(pose, seconds_of(msg.header.stamp))
        if readings is None:
            return
        self.publisher.publish(wifi_scan_message(readings, msg.header.stamp, self.params.frame_id,
                                                 self.params.interface))


def main(args: list[str] | None = None) -> int:
    return run_node(WifiSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
