"""Node tests of partition_localizer: the node constructed in this process on a private rclpy Context, fed by
a probe node on the same executor, stepped with ``spin_once`` until a stated condition holds (no sleeps).
Each test leases its own DDS domain, as test_nodes.py does."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter

from rfidnav_common.geometry import quaternion_to_yaw
from rfidnav_common.ros import SENSOR_QOS, time_msg
from rfidnav_common.tag_lattice import make_deployment
from rfidnav_localization.conversions import UNKNOWN_YAW_VARIANCE
from rfidnav_localization.partition_localizer_node import PartitionLocalizerNode
from rfidnav_msgs.msg import LocalizationStatus, TagReadArray, TagReading
from rfidnav_sim.conversions import odometry_message
from rfidnav_sim.kinematics import Pose2D
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

WAIT_S = 10.0   # generous for a loaded machine; each wait normally takes milliseconds
FLOOR_ANTENNA = 1                # the default port of the floor antenna (reader_floor_lattice.yaml)
FIELD = make_deployment("triangular", 0.02, (-1.0, -1.0, 1.0, 1.0))


def tag_id(coordinate: tuple[int, int]) -> str:
    return FIELD.lattice.tag_id(coordinate)


def reading(tag: str, antenna: int = FLOOR_ANTENNA, **bad: float) -> TagReading:
    read = TagReading(tag_id=tag, antenna=antenna, rssi_dbm=-50.0, phase_rad=1.0, i=math.cos(1.0), q=math.sin(1.0),
                      frequency_hz=915.25e6)
    for field, value in bad.items():
        setattr(read, field, value)
    return read


class Harness(Graph):
    """partition_localizer with a probe publishing /odom and /rfid/reads and collecting its outputs."""

    def __init__(self, domain_id: int, **parameters: Any) -> None:
        super().__init__(domain_id)
        self.node = self.add(PartitionLocalizerNode(context=self.context, parameter_overrides=[
            Parameter(name, value=value) for name, value in parameters.items()]))
        self.poses: list[PoseWithCovarianceStamped] = []
        self.statuses: list[LocalizationStatus] = []
        self.reads_pub = self.probe.create_publisher(TagReadArray, "/rfid/reads", SENSOR_QOS)
        self.odom_pub = self.probe.create_publisher(Odometry, "/odom", SENSOR_QOS)
        subscriptions = [self.probe.create_subscription(PoseWithCovarianceStamped, "/localization/pose",
                                                        self.poses.append, SENSOR_QOS),
                         self.probe.create_subscription(LocalizationStatus, "/localization/status",
                                                        self.statuses.append, SENSOR_QOS)]
        self.spin_until(lambda: self.reads_pub.get_subscription_count() > 0
                        and self.odom_pub.get_subscription_count() > 0
                        and all(s.get_publisher_count() > 0 for s in subscriptions), "partition_localizer's topics")
        self.stamp_s = 100.0

    def send_odometry(self, x: float, y: float, yaw: float) -> None:
        self.odom_pub.publish(odometry_message(Pose2D(x, y, yaw), (0.0, 0.0), time_msg(self.stamp_s), "odom"))

    def send_round(self, readings: list[TagReading]) -> LocalizationStatus:
        """Publish one inventory round and return the status the node answers it with."""
        self.stamp_s += 0.04
        message = TagReadArray(readings=readings)
        message.header.stamp = time_msg(self.stamp_s)
        message.header.frame_id = "base_link"
        before = len(self.statuses)
        self.reads_pub.publish(message)
        self.spin_until(lambda: len(self.statuses) > before, f"the status of round {self.stamp_s:.2f}")
        return self.statuses[before]


@pytest.fixture
def make_harness(domain: int) -> Iterator[Callable[..., Harness]]:
    harnesses: list[Harness] = []

    def make(**parameters: Any) -> Harness:
        harnesses.append(Harness(domain, **parameters))
        return harnesses[-1]

    yield make
    for harness in harnesses:
        harness.close()


def stamp_s(message: Any) -> float:
    return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9


@pytest.mark.parametrize("method", ["paper", "filter"])
def test_a_round_of_lattice_tags_gives_a_pose_and_a_status_stamped_with_the_round(make_harness, method: str) -> None:
    harness = make_harness(method=method, seed=3)
    status = harness.send_round([])
    assert not status.position_valid and not status.orientation_valid and status.method == method
    assert not harness.poses, "no pose before any tag was read"

    partition = FIELD.partition_at(0.017, 0.001)
    assert len(partition) == 2
    ids = sorted(tag_id(c) for c in partition)
    far_away = tag_id((40, 40))    # read by another antenna than the one listened to: ignored
    status = harness.send_round([reading(ids[0]), reading(far_away, antenna=2), reading(ids[1]), reading(ids[0])])
    harness.spin_until(lambda: harness.poses, "a pose")
    pose = harness.poses[-1]
    assert stamp_s(pose) == pytest.approx(harness.stamp_s, abs=1e-9) and stamp_s(status) == stamp_s(pose)
    assert pose.header.frame_id == "map" and status.header.frame_id == "map"
    centre = FIELD.lattice.positions(np.array(sorted(partition))).mean(axis=0)
    x, y = pose.pose.pose.position.x, pose.pose.pose.position.y
    if method == "paper":
        assert (x, y) == pytest.approx(tuple(centre), abs=1e-12)
    else:   # the particles' mean lies in the partition, within r of its tags
        assert all(math.dist((x, y), FIELD.lattice.position(c)) <= FIELD.read_range_m for c in partition)
    assert (status.x, status.y) == (x, y)
    covariance = pose.pose.covariance
    assert covariance[0] > 0.0 and covariance[7] > 0.0 and covariance[1] == covariance[6]
    assert covariance[35] == UNKNOWN_YAW_VARIANCE
    orientation = pose.pose.pose.orientation
    assert (orientation.x, orientation.y, orientation.z, orientation.w) == (0.0, 0.0, 0.0, 1.0)
    assert list(status.partition_tag_ids) == ids
    assert status.position_valid and not status.orientation_valid
    assert status.read_range_m == pytest.approx(0.02, abs=1e-12)
    assert (status.rogue_count, status.undecodable_count, status.partitions_traversed) == (0, 0, 0)


def test_a_straight_drive_gives_a_heading_that_follows_the_odometry(make_harness) -> None:
    harness = make_harness()
    heading = 0.3
    x, y = 0.001, 0.003
    for step in range(60):
        harness.send_odometry(step * 0.002, 0.0, 0.0)
        harness.spin_until(lambda step=step: harness.node.odom is not None and harness.node.odom[0] == step * 0.002,
                           "the odometry to arrive")
        status = harness.send_round([reading(tag_id(c)) for c in FIELD.partition_at(x, y)])
        x, y = x + 0.002 * math.cos(heading), y + 0.002 * math.sin(heading)
    assert status.orientation_valid and status.partitions_traversed >= 3
    assert status.yaw_lower_rad <= status.yaw_rad <= status.yaw_upper_rad
    assert abs(math.remainder(status.yaw_rad - heading, 2.0 * math.pi)) < 0.5
    # A turn in odometry turns the published heading with it.
    harness.send_odometry(0.12, 0.0, 1.0)
    harness.spin_until(lambda: harness.node.odom[2] == pytest.approx(1.0), "the turned odometry")
    turned = harness.send_round([reading(tag_id(c)) for c in FIELD.partition_at(x, y)])
    assert turned.partitions_traversed == 0
    assert math.remainder(turned.yaw_rad - status.yaw_rad, 2.0 * math.pi) == pytest.approx(1.0)
    harness.spin_until(lambda: harness.poses and stamp_s(harness.poses[-1]) == stamp_s(turned), "the turned pose")
    orientation = harness.poses[-1].pose.pose.orientation
    published_yaw = quaternion_to_yaw(orientation.x, orientation.y, orientation.z, orientation.w)
    assert published_yaw == pytest.approx(turned.yaw_rad)


def test_non_finite_reads_junk_ids_and_bad_odometry_are_dropped_counted_and_survived(make_harness) -> None:
    harness = make_harness()
    node = harness.node
    good = tag_id((0, 0))
    other = tag_id((1, 0))
    status = harness.send_round([reading(good), reading(other, rssi_dbm=math.inf), reading(other, i=math.inf),
                                 reading("NOT-A-TAG"), reading("E2801160600002054E7C1B64"),
                                 reading(good, antenna=2, q=math.nan)])   # not the floor antenna: not counted
    assert node.drops.dropped("/rfid/reads") == 2
    assert status.undecodable_count == 2 and list(status.partition_tag_ids) == [good]
    assert (status.x, status.y) == pytest.approx(FIELD.lattice.position((0, 0)), abs=1e-12)

    harness.send_odometry(math.nan, 0.0, 0.0)
    harness.spin_until(lambda: node.drops.dropped("/odom") == 1, "the bad odometry to be dropped")
    assert node.odom is None

    # A rogue tag read with the true one (one against one: the one near the estimate stays).
    rogue = tag_id((30, -30))
    status = harness.send_round([reading(rogue), reading(good)])
    assert list(status.rejected_tag_ids) == [rogue] and status.rogue_count == 1
    assert list(status.partition_tag_ids) == [good]

    # Still alive and localizing after all of it.
    status = harness.send_round([reading(other, phase_rad=math.inf)])
    assert node.drops.dropped("/rfid/reads") == 3 and not list(status.partition_tag_ids) and status.position_valid
    status = harness.send_round([reading(other)])
    assert list(status.partition_tag_ids) == [other]
    assert (status.x, status.y) == pytest.approx(FIELD.lattice.position((1, 0)), abs=1e-12)
    assert node.rounds == 4
