"""rfid_localizer: the fused localizer (beyond the papers) as AMCL is for a laser -- a pose with covariance and
map -> odom from every kind of tag evidence the robot map declares, WiFi fixes, the compass and the odometry.

A thin adapter around FusedLocalizer (rfidnav_localization.fused). /odom moves the particles; every /rfid/reads
round is one update with what it holds -- the floor antenna's tags (lattice or tag-group tags), the side
antenna's wall tags, the phase difference of each ceiling tag heard on both receiving antennas -- together with
the /compass heading and the location server's latest answer to a /wifi/scan that arrived since the last round.
Each update publishes the pose (``pose_topic``), map -> odom on /tf and LocalizationStatus with the evidence
weighed. ``initial_pose_topic`` (/initialpose, as AMCL and RViz use it) restarts the filter about a pose.

Every input is checked (rfidnav_common.inputs); what fails is dropped and counted with a throttled warning: /odom
that is not a pose in odom, a round not in base_link or with reads no reader reports, a compass reading not in
its frame, a scan not in base_link, an /initialpose not in the map frame or with a covariance that is none. A
tag id the map does not know is ignored and counted (LocalizationStatus.undecodable_count).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.task import Future
from sensor_msgs.msg import Imu

from rfidnav_common import inputs
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.ros import (
    COMMAND_QOS,
    SENSOR_QOS,
    declare_parameters,
    input_drops,
    run_node,
    seconds_of,
    sim_clock_seconds,
    stamp_seconds,
)
from rfidnav_common.seeding import rng_for
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import FrameBroadcaster
from rfidnav_localization.conversions import fused_pose_message, fused_status_message, initial_pose
from rfidnav_localization.fused.filter import HeldReadings, round_evidence
from rfidnav_localization.fused.kinds import WifiFix
from rfidnav_localization.fused.localizer import FusedLocalizer
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.parameters import RfidLocalizerParameters
from rfidnav_msgs.msg import LocalizationStatus, TagReadArray, WifiScan
from rfidnav_msgs.srv import Locate

NODE_NAME = "rfid_localizer"


class RfidLocalizerNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        """``node_options``: keyword arguments of rclpy's Node (``context``, ``parameter_overrides``), for tests."""
        super().__init__(NODE_NAME, **node_options)
        self.params: RfidLocalizerParameters = declare_parameters(self, RfidLocalizerParameters)
        p = self.params
        fused_map = FusedMap.of_route_map(load_route_map(Path(p.map_file)))
        self.localizer = FusedLocalizer(p.settings(), fused_map, rng_for(p.seed, NODE_NAME))
        self.ports = p.ports()
        if p.initial_pose:
            x, y, yaw = p.initial_pose
            self.localizer.set_pose(x, y, yaw, np.diag(np.square(p.initial_sd)))
        self.drops = input_drops(self)
        self.compass_yaws: HeldReadings[float] = HeldReadings()
        self.odom_stamp = Time()
        self.wifi_fixes: HeldReadings[WifiFix] = HeldReadings()
        self.locating: Future | None = None
        self.ignored_count = 0
        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, p.pose_topic, SENSOR_QOS)
        self.status_pub = self.create_publisher(LocalizationStatus, p.status_topic, SENSOR_QOS)
        self.frames = FrameBroadcaster(self) if p.publish_tf else None
        self.create_subscription(Odometry, "odom", self.on_odometry, SENSOR_QOS)
        self.create_subscription(TagReadArray, "rfid/reads", self.on_reads, SENSOR_QOS)
        # /initialpose is a command, sent once: reliable, as RViz publishes it.
        self.create_subscription(PoseWithCovarianceStamped, p.initial_pose_topic, self.on_initial_pose, COMMAND_QOS)
        if p.use_compass:
            self.create_subscription(Imu, "compass", self.on_compass, SENSOR_QOS)
        self.locate_client = None
        if p.use_wifi:
            self.locate_client = self.create_client(Locate, p.locate_service)
            self.create_subscription(WifiScan, "wifi/scan", self.on_scan, SENSOR_QOS)
        declared = [kind for kind, present in (("floor tags", bool(fused_map.floor_tags) or
                                                 fused_map.deployment_area is not None),
                                                ("ceiling tags", bool(fused_map.ceiling_tags)),
                                                ("wall tags", bool(fused_map.wall_tags)),
                                                ("wifi", p.use_wifi), ("compass", p.use_compass)) if present]
        start = f"known start {p.initial_pose}" if p.initial_pose else "unknown start (global localization)"
        self.get_logger().info(f"{p.particles} particles over {', '.join(declared) or 'odometry alone'}; {start}")

    # ---------------------------------------------------------------------------------------------- inputs
    def on_odometry(self, msg: Odometry) -> None:
        try:
            odom = inputs.odometry_pose(msg)
        except inputs.BadInput as error:
            self.drops.drop("odom", error)
            return
        self.localizer.on_odometry(odom)
        self.odom_stamp = msg.header.stamp

    def on_compass(self, msg: Imu) -> None:
        try:
            self.compass_yaws.hold(inputs.compass_heading(msg), stamp_seconds(self, msg.header.stamp))
        except inputs.BadInput as error:
            self.drops.drop("compass", error)

    def on_scan(self, msg: WifiScan) -> None:
        """Locate the scan unless a call is out (scans come faster than fixes are weighed, by wifi_min_travel_m)."""
        try:
            inputs.scan_rss(msg)
            scan_time_s = stamp_seconds(self, msg.header.stamp)
        except inputs.BadInput as error:
            self.drops.drop("wifi/scan", error)
            return
        if self.locating is not None or self.locate_client is None or not self.locate_client.service_is_ready():
            return
        self.locating = self.call_service(self.locate_client, Locate.Request(scan=msg),
                                          lambda future: self.on_located(future, scan_time_s))

    def on_located(self, future: Future, scan_time_s: float) -> None:
        self.locating = None
        response = future.result()                  # None when cancelled unanswered (the stepped clock's hold)
        if response is None or not response.success:
            return
        try:
            self.wifi_fixes.hold((inputs.point(response.x, response.y, "position"),
                                  inputs.length(response.uncertainty_m, "uncertainty_m")), scan_time_s)
        except inputs.BadInput as error:
            self.drops.drop(self.params.locate_service, f"answer ignored: {error}")

    def on_initial_pose(self, msg: PoseWithCovarianceStamped) -> None:
        try:
            inputs.frame(msg.header.frame_id, self.params.map_frame)
            (x, y, yaw), covariance = initial_pose(msg)
        except inputs.BadInput as error:
            self.drops.drop(self.params.initial_pose_topic, error)
            return
        self.localizer.set_pose(x, y, yaw, covariance)
        self.get_logger().info(f"restarted about ({x:.2f}, {y:.2f}, {yaw:.2f} rad) from "
                               f"{self.params.initial_pose_topic}")

    def on_reads(self, msg: TagReadArray) -> None:
        p = self.params
        reads = inputs.round_reads(msg, self.drops, sim_clock_seconds(self), ports=set(p.antenna_ports_read().values()))
        if reads is None:
            return
        round_time_s = seconds_of(msg.header.stamp)
        evidence = round_evidence(reads, self.ports, self.wifi_fixes.take(round_time_s),
                                  self.compass_yaws.take(round_time_s))
        estimate = self.localizer.on_round(evidence)
        if estimate is None:
            self.get_logger().warning("no /odom yet: nothing to localize", throttle_duration_sec=5.0)
            return
        if estimate.update.ignored_tag_ids:
            self.ignored_count += len(estimate.update.ignored_tag_ids)
            self.get_logger().warning("ignored tags the map does not know: "
                                      f"{', '.join(estimate.update.ignored_tag_ids)} ({self.ignored_count} so far)",
                                      throttle_duration_sec=5.0)
        stamp = msg.header.stamp
        self.pose_pub.publish(fused_pose_message(estimate.pose, stamp, p.map_frame))
        if self.frames is not None:
            # Stamped with the odometry the estimate rests on (it may be a step older than the round): composed with
            # odom -> base_link at that stamp, map -> odom gives the estimate.
            self.frames.send_map_to_odom(p.map_frame, (estimate.pose.x, estimate.pose.y, estimate.pose.yaw),
                                         estimate.odom, self.odom_stamp)
        self.status_pub.publish(fused_status_message(estimate, stamp, p.map_frame, self.ignored_count))


def main(args: list[str] | None = None) -> int:
    return run_node(RfidLocalizerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
