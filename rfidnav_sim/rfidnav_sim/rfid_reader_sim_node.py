"""rfid_reader_sim: an RFID reader on the simulated robot, publishing /rfid/reads (TagReadArray).

Inventory rounds are driven by /sim/ground_truth: the first pose at or after each round's due time
(``1/rate_hz`` apart in sim time, or polled: ``round_jitter_s`` later at random, rfidnav_common.polling) is the
pose of that round. The reads then depend only on the poses and the seed, never on process scheduling, so a run
repeats exactly and a replay sees the same reads. A failed round (``round_failure_probability``) is published
empty, as a round that read nothing.
"""

from __future__ import annotations

from typing import Any

from nav_msgs.msg import Odometry

from rfidnav_common.ros import SENSOR_QOS, declare_parameters, input_drops, run_node, seconds_of
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import publish_static_frames
from rfidnav_msgs.msg import TagReadArray
from rfidnav_sim.conversions import ground_truth_pose, reads_message
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.world import load_world


class RfidReaderSimNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__("rfid_reader_sim", **node_options)
        self.params: ReaderParameters = declare_parameters(self, ReaderParameters)
        world = load_world(self.params.world_file)
        self.world_frame = world.frame_id
        self.drops = input_drops(self)
        self.reader = self.params.simulated_reader(world, self.params.seed)
        self.reads_pub = self.create_publisher(TagReadArray, "rfid/reads", SENSOR_QOS)
        publish_static_frames(self, self.params.antenna_frames())
        self.create_subscription(Odometry, "sim/ground_truth", self.on_ground_truth, SENSOR_QOS)
        lattice_tags = sum(deployment.tag_count() for deployment in world.deployments)
        self.get_logger().info(f"{len(world.tags)} listed tags, {lattice_tags} lattice floor tags, "
                               f"{len(self.params.antenna_facing)} antennas, "
                               f"a round every {self.polling_text()} s")

    def polling_text(self) -> str:
        polling = self.params.polling()
        if polling.jitter_s == 0.0:
            return f"{polling.interval_s:g}"
        return f"{polling.interval_s:g}-{polling.max_interval_s:g}"

    def on_ground_truth(self, msg: Odometry) -> None:
        pose = ground_truth_pose(msg, self.world_frame, self.drops)
        if pose is None:
            return
        reads = self.reader.sample(pose, seconds_of(msg.header.stamp))
        if reads is None:
            return
        self.reads_pub.publish(reads_message(reads, msg.header.stamp, self.params.frame_id))


def main(args: list[str] | None = None) -> int:
    return run_node(RfidReaderSimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
