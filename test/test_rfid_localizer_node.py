"""Node tests of rfid_localizer (the fused localizer): the node in this process on a private rclpy Context, fed by
a probe node on the same executor, stepped with ``spin_once`` until a stated condition holds (no sleeps).

The robot map: a 10 x 4 m hallway with a wall tag on its north wall at x = 3 (facing south), and a cross tag
group at (6, 1). Port 1 is the floor antenna, port 2 the side antenna looking left (paper 004's)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu
from tf2_msgs.msg import TFMessage

from rfidnav_common.errors import ConfigError
from rfidnav_common.frames import compose
from rfidnav_common.geometry import quaternion_to_yaw, yaw_to_quaternion
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, time_msg
from rfidnav_common.transforms import TF_QOS
from rfidnav_localization.rfid_localizer_node import RfidLocalizerNode
from rfidnav_msgs.msg import LocalizationStatus, TagReadArray, TagReading
from rfidnav_sim.conversions import odometry_message
from rfidnav_sim.kinematics import Pose2D
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

FLOOR, SIDE = 1, 2
WALL_TAG = "W3"
MAP = """
name: hallway_test
extent: [0.0, 0.0, 10.0, 4.0]
walls:
  - [0.0, 2.0, 10.0, 2.0]
wall_tags:
  - {id: W3, position: [3.0, 2.0], normal: [0.0, -1.0]}
tag_groups:
  - {id: G1, shape: cross, centre: [6.0, 1.0]}
"""


def reading(tag: str, antenna: int, phase_rad: float = 1.0) -> TagReading:
    return TagReading(tag_id=tag, antenna=antenna, rssi_dbm=-50.0, phase_rad=phase_rad, i=math.nan, q=math.nan,
                      frequency_hz=915.25e6)


def yaw_of(q: Any) -> float:
    return quaternion_to_yaw(q.x, q.y, q.z, q.w)


def planar(message: PoseWithCovarianceStamped) -> tuple[float, float, float]:
    pose = message.pose.pose
    return pose.position.x, pose.position.y, yaw_of(pose.orientation)


class Harness(Graph):
    """rfid_localizer with a probe publishing its inputs and collecting its outputs."""

    def __init__(self, domain_id: int, map_file: Path, **parameters: Any) -> None:
        super().__init__(domain_id)
        values = {"map_file": str(map_file), "antenna_positions": [0.0, 0.0, 0.05, 0.0, 0.0, 0.30],
                  "antenna_phase_offset_rad": [0.0, 0.0], "floor_antenna": FLOOR, "wall_antenna": SIDE,
                  "particles": 500, "seed": 5, **parameters,
                  # Stepped, the node counts every message it has handled: the tests wait on those counts.
                  "stepped_clock": True}
        self.node = self.add(RfidLocalizerNode(context=self.context, parameter_overrides=[
            Parameter(name, value=value) for name, value in values.items()]))
        self.poses: list[PoseWithCovarianceStamped] = []
        self.statuses: list[LocalizationStatus] = []
        self.transforms: list[TFMessage] = []
        self.reads_pub = self.probe.create_publisher(TagReadArray, "/rfid/reads", SENSOR_QOS)
        self.odom_pub = self.probe.create_publisher(Odometry, "/odom", SENSOR_QOS)
        self.compass_pub = self.probe.create_publisher(Imu, "/compass", SENSOR_QOS)
        self.initial_pub = self.probe.create_publisher(PoseWithCovarianceStamped, "/initialpose", COMMAND_QOS)
        subscriptions = [self.probe.create_subscription(PoseWithCovarianceStamped, "/localization/pose",
                                                        self.poses.append, SENSOR_QOS),
                         self.probe.create_subscription(LocalizationStatus, "/localization/status",
                                                        self.statuses.append, SENSOR_QOS),
                         self.probe.create_subscription(TFMessage, "/tf", self.transforms.append, TF_QOS)]
        publishers = (self.reads_pub, self.odom_pub, self.compass_pub, self.initial_pub)
        self.spin_until(lambda: all(p.get_subscription_count() > 0 for p in publishers)
                        and all(s.get_publisher_count() > 0 for s in subscriptions), "rfid_localizer's topics")
        self.stamp_s = 100.0

    def send_odometry(self, x: float, y: float, yaw: float) -> None:
        """One /odom message, handled before this returns."""
        before = self.node.consumed_counts["/odom"]
        self.odom_pub.publish(odometry_message(Pose2D(x, y, yaw), (0.0, 0.0), time_msg(self.stamp_s), "odom"))
        self.spin_until(lambda: self.node.consumed_counts["/odom"] > before, "/odom handled")

    def send_compass(self, yaw: float) -> None:
        message = Imu()
        message.header.stamp = time_msg(self.stamp_s)
        message.header.frame_id = "base_link"
        qx, qy, qz, qw = yaw_to_quaternion(yaw)
        message.orientation.x, message.orientation.y, message.orientation.z, message.orientation.w = qx, qy, qz, qw
        before = self.node.consumed_counts["/compass"]
        self.compass_pub.publish(message)
        self.spin_until(lambda: self.node.consumed_counts["/compass"] > before, "/compass handled")

    def send_initial_pose(self, x: float, y: float, yaw: float, variances: tuple[float, float, float],
                          frame_id: str = "map") -> None:
        message = PoseWithCovarianceStamped()
        message.header.stamp = time_msg(self.stamp_s)
        message.header.frame_id = frame_id
        message.pose.pose.position.x, message.pose.pose.position.y = x, y
        o = message.pose.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(yaw)
        covariance = [0.0] * 36
        covariance[0], covariance[7], covariance[35] = variances
        message.pose.covariance = covariance
        before = self.node.consumed_counts["/initialpose"]
        self.initial_pub.publish(message)
        self.spin_until(lambda: self.node.consumed_counts["/initialpose"] > before, "/initialpose handled")

    def send_round(self, readings: list[TagReading]) -> tuple[LocalizationStatus, PoseWithCovarianceStamped]:
        """One inventory round; the status and pose the node answers it with."""
        self.stamp_s += 0.04
        message = TagReadArray(readings=readings)
        message.header.stamp = time_msg(self.stamp_s)
        message.header.frame_id = "base_link"
        statuses, poses = len(self.statuses), len(self.poses)
        self.reads_pub.publish(message)
        self.spin_until(lambda: len(self.statuses) > statuses and len(self.poses) > poses,
                        f"the answer to round {self.stamp_s:.2f}")
        return self.statuses[statuses], self.poses[poses]


@pytest.fixture
def make_harness(domain: int, tmp_path: Path) -> Iterator[Callable[..., Harness]]:
    map_file = tmp_path / "map.yaml"
    map_file.write_text(MAP)
    harnesses: list[Harness] = []

    def make(**parameters: Any) -> Harness:
        harnesses.append(Harness(domain, map_file, **parameters))
        return harnesses[-1]

    yield make
    for harness in harnesses:
        harness.close()


def test_map_to_odom_on_tf_composed_with_the_odometry_pose_is_the_published_pose(make_harness) -> None:
    harness = make_harness(initial_pose=[3.0, 1.2, 0.0])
    harness.send_odometry(1.0, 0.5, 0.3)              # odometry's frame is anywhere: its own start
    status, pose = harness.send_round([reading(WALL_TAG, SIDE)])
    assert status.method == "fused" and list(status.evidence_used) == ["wall_tag"]
    x, y, yaw = planar(pose)
    assert math.hypot(x - 3.0, y - 1.2) < 0.3
    harness.spin_until(lambda: harness.transforms, "map -> odom on /tf")
    transform = harness.transforms[-1].transforms[0]
    assert (transform.header.frame_id, transform.child_frame_id) == ("map", "odom")
    assert transform.header.stamp == time_msg(100.0)            # the odometry's, which the estimate rests on
    t = transform.transform
    map_odom = (t.translation.x, t.translation.y, yaw_of(t.rotation))
    composed = compose(map_odom, (1.0, 0.5, 0.3))
    assert composed[:2] == pytest.approx((x, y), abs=1e-9)
    assert math.remainder(composed[2] - yaw, math.tau) == pytest.approx(0.0, abs=1e-9)
    covariance = list(pose.pose.covariance)
    assert covariance[0] > 0.0 and covariance[7] > 0.0 and covariance[35] > 0.0
    assert covariance[1] == covariance[6] and covariance[5] == covariance[30]


def test_from_an_unknown_start_a_wall_tag_read_and_the_compass_place_the_robot_in_front_of_the_tag(
        make_harness) -> None:
    harness = make_harness()
    harness.send_odometry(0.0, 0.0, 0.0)
    harness.send_compass(0.0)
    status, pose = harness.send_round([reading(WALL_TAG, SIDE)])
    assert list(status.evidence_used) == ["wall_tag", "compass"]
    assert status.particles_redrawn > 0               # the unknown start's particles, redrawn where the read says
    x, y, yaw = planar(pose)
    # Heading +x with the antenna looking left: the tag's induction area puts the robot 0 to 1 m south of it.
    assert abs(x - 3.0) < 0.3 and 1.0 - 0.1 < y < 2.0
    assert abs(yaw) < math.radians(15.0)


def test_an_initial_pose_restarts_the_filter_about_it(make_harness) -> None:
    harness = make_harness(initial_pose=[3.0, 1.2, 0.0])
    harness.send_odometry(0.0, 0.0, 0.0)
    harness.send_initial_pose(6.0, 1.0, math.pi / 2, (0.01, 0.01, 0.001))
    status, pose = harness.send_round([])
    assert list(status.evidence_used) == []           # a round without reads costs nothing
    x, y, yaw = planar(pose)
    assert math.hypot(x - 6.0, y - 1.0) < 0.1 and abs(yaw - math.pi / 2) < 0.1


def test_bad_odometry_unknown_tags_and_a_foreign_initial_pose_are_dropped_counted_and_survived(make_harness) -> None:
    harness = make_harness(initial_pose=[3.0, 1.2, 0.0])
    harness.send_odometry(0.0, 0.0, 0.0)
    harness.send_odometry(math.nan, 0.0, 0.0)
    harness.send_initial_pose(8.0, 3.0, 0.0, (0.01, 0.01, 0.001), frame_id="odom")
    status, pose = harness.send_round([reading("NOT-A-TAG", FLOOR)])
    assert status.undecodable_count == 1
    x, y, _ = planar(pose)
    assert math.isfinite(x) and math.hypot(x - 3.0, y - 1.2) < 0.3     # neither the NaN nor the odom-frame pose
    assert harness.node.drops.counts == {"/odom": 1, "/initialpose": 1}
    harness.spin_until(lambda: harness.logged("rfid_localizer", "NOT-A-TAG"), "the unknown tag's warning")


def test_a_round_and_a_compass_reading_stamped_in_another_era_are_dropped_counted_and_leave_the_clock_alone(
        make_harness) -> None:
    harness = make_harness(initial_pose=[3.0, 1.2, 0.0])
    harness.send_odometry(0.0, 0.0, 0.0)
    harness.stamp_s = float(2 ** 31 - 1)
    harness.send_compass(0.0)
    far = TagReadArray(readings=[reading(WALL_TAG, SIDE)])
    far.header.stamp, far.header.frame_id = time_msg(harness.stamp_s), "base_link"
    before = harness.node.consumed_counts["/rfid/reads"]
    harness.reads_pub.publish(far)
    harness.spin_until(lambda: harness.node.consumed_counts["/rfid/reads"] > before, "the far round handled")
    assert harness.node.drops.counts == {"/compass": 1, "/rfid/reads": 1}
    harness.stamp_s = 100.0
    status, pose = harness.send_round([reading(WALL_TAG, SIDE)])     # the clock still at 100 s: taken
    assert list(status.evidence_used) == ["wall_tag"] and pose.header.stamp == time_msg(100.04)


def test_a_map_that_does_not_say_where_the_robot_may_be_is_one_error_naming_the_map_and_its_extent(
        domain: int, tmp_path: Path) -> None:
    map_file = tmp_path / "ceiling_only.yaml"
    map_file.write_text("name: ceiling_only\nceiling_tags:\n  C1: [1.0, 2.0, 3.0]\n")
    graph = Graph(domain)
    try:
        with pytest.raises(ConfigError, match="map 'ceiling_only': extent: none given"):
            RfidLocalizerNode(context=graph.context, parameter_overrides=[Parameter("map_file", value=str(map_file))])
    finally:
        graph.close()
