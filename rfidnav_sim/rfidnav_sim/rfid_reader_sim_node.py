"""rfid_reader_sim: a UHF RFID reader on the simulated robot, publishing /rfid/reads (TagReadArray).

Inventory rounds are driven by /sim/ground_truth: the first pose at or after each round's due time
(``1/rate_hz`` apart in sim time) is the pose of that round. The reads then depend only on the poses
and the seed, never on process scheduling, so a run repeats exactly and a replay sees the same reads.
"""

from __future__ import annotations

from typing import Any

from nav_msgs.msg import Odometry
from rclpy.node import Node

from rfidnav_common.ros import SENSOR_QOS, declare_parameters, odometry_pose, run_node, seconds_of
from rfidnav_common.seeding import rng_for
from rfidnav_msgs.msg import TagReadArray
from rfidnav_sim.conversions import reads_message
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.rfid_model import ReaderSimulator
from rfidnav_sim.schedule import GroundTruthSchedule
from rfidnav_sim.world import load_world


class RfidReaderSimNode(Node):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("rfid_reader_sim", **node_options)
        self.params: ReaderParameters = declare_parameters(self, ReaderParameters)
        world = load_world(self.params.world_file)
        self.simulator = ReaderSimulator.for_world(self.params.reader_model(), world,
                                                   rng_for(self.params.seed, "rfid_reader_sim"))
        self.schedule = GroundTruthSchedule(1.0 / self.params.rate_hz)
        self.reads_pub = self.create_publisher(TagReadArray, "/rfid/reads", SENSOR_QOS)
        self.create_subscription(Odometry, "/sim/ground_truth", self.on_ground_truth, SENSOR_QOS)
        lattice_tags = sum(deployment.tag_count() for deployment in world.deployments)
        self.get_logger().info(f"{len(world.tags)} listed tags, {lattice_tags} lattice floor tags, "
                               f"{len(self.params.antenna_facing)} antennas, "
                               f"{self.params.rate_hz:g} rounds/s")

    def on_ground_truth(self, msg: Odometry) -> None:
        now_s = seconds_of(msg.header.stamp)
        if not self.schedule.due(now_s):
            return
        reads = self.simulator.inventory(*odometry_pose(msg), now_s)
        self.reads_pub.publish(reads_message(reads, msg.header.stamp, self.params.frame_id))


def main(args: list[str] | None = None) -> int:
    return run_node(RfidReaderSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
