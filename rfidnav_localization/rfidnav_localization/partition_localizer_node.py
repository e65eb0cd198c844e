"""partition_localizer: /localization/pose and /localization/status from the floor tags read (paper 000).

A thin adapter around PartitionLocalizer: every TagReadArray (one inventory round) becomes one update with
the ids its floor antenna read and the latest /odom pose, and one pose and status stamped with the round's
own stamp. Positions and the read range come from the tag ids themselves, so the node needs no map. Rounds not
in base_link, floor reads no reader reports and /odom messages that are not a pose in odom are dropped and counted
(rfidnav_common.inputs); junk ids are counted by the localizer (LocalizationStatus.undecodable_count). The pose
is published once a tag has been read; the status from the first round on.
"""

from __future__ import annotations

from typing import Any

from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry

from rfidnav_common import inputs
from rfidnav_common.ros import SENSOR_QOS, declare_parameters, input_drops, run_node, seconds_of, sim_clock_seconds
from rfidnav_common.seeding import rng_for
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import FrameBroadcaster
from rfidnav_localization.conversions import pose_message, status_message
from rfidnav_localization.parameters import PartitionLocalizerParameters
from rfidnav_localization.partition import PartitionLocalizer
from rfidnav_msgs.msg import LocalizationStatus, TagReadArray

NODE_NAME = "partition_localizer"
# Before the first /odom the robot is taken to stand at the odometry origin: the position needs no odometry,
# and the heading follows it once it arrives.
ODOMETRY_ORIGIN = (0.0, 0.0, 0.0)


class PartitionLocalizerNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__(NODE_NAME, **node_options)
        self.params: PartitionLocalizerParameters = declare_parameters(self, PartitionLocalizerParameters)
        self.localizer = PartitionLocalizer(self.params.settings(), rng_for(self.params.seed, NODE_NAME))
        self.odom: tuple[float, float, float] | None = None
        self.drops = input_drops(self)
        self.rounds = 0
        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, "localization/pose", SENSOR_QOS)
        self.frames = FrameBroadcaster(self) if self.params.publish_tf else None   # map -> odom
        self.status_pub = self.create_publisher(LocalizationStatus, "localization/status", SENSOR_QOS)
        self.create_subscription(Odometry, "odom", self.on_odometry, SENSOR_QOS)
        self.create_subscription(TagReadArray, "rfid/reads", self.on_reads, SENSOR_QOS)
        self.get_logger().info(f"method {self.params.method}, floor antenna port {self.params.antenna}, "
                               f"publishing in frame '{self.params.map_frame}'")

    def on_odometry(self, msg: Odometry) -> None:
        try:
            self.odom = inputs.odometry_pose(msg)
        except inputs.BadInput as error:
            self.drops.drop("odom", error)

    def on_reads(self, msg: TagReadArray) -> None:
        floor_reads = inputs.round_reads(msg, self.drops, sim_clock_seconds(self), ports=(self.params.antenna,))
        if floor_reads is None:
            return
        tag_ids = [read.tag_id for read in floor_reads]
        if self.odom is None and floor_reads:
            self.get_logger().warning("no /odom yet: taking the robot to stand at the odometry origin",
                                      throttle_duration_sec=5.0)
        undecodable_before, rogue_before = self.localizer.undecodable_count, self.localizer.rogue_count
        # The round's own stamp, not arrival time: the estimate belongs to the moment the tags were read.
        estimate = self.localizer.update(seconds_of(msg.header.stamp), tag_ids, self.odom or ODOMETRY_ORIGIN)
        self.rounds += 1
        if estimate.undecodable_count > undecodable_before:
            self.get_logger().warning(f"ignored tag ids that are not lattice ids of this deployment "
                                      f"({estimate.undecodable_count} so far)", throttle_duration_sec=5.0)
        if estimate.rogue_count > rogue_before:
            self.get_logger().warning(f"rejected rogue tags {', '.join(estimate.rejected_tag_ids)}: too far from "
                                      f"the others read ({estimate.rogue_count} so far)", throttle_duration_sec=5.0)
        if estimate.position is not None:
            self.pose_pub.publish(pose_message(estimate, msg.header.stamp, self.params.map_frame))
            if self.frames is not None and estimate.yaw is not None:
                self.frames.send_map_to_odom(self.params.map_frame, (*estimate.position, estimate.yaw),
                                             self.odom or ODOMETRY_ORIGIN, msg.header.stamp)
        self.status_pub.publish(status_message(estimate, msg.header.stamp, self.params.map_frame))


def main(args: list[str] | None = None) -> int:
    return run_node(PartitionLocalizerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
