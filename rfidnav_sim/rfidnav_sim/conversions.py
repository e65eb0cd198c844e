"""Simulator domain objects <-> ROS messages."""

from __future__ import annotations

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point
from nav_msgs.msg import Odometry
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from rfidnav_common import inputs
from rfidnav_common.base_safety import BaseEventRecord
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.tag_lattice import Deployment
from rfidnav_msgs.msg import AccessPointRss, BaseEvent, TagReadArray, TagReading, WifiScan
from rfidnav_sim.kinematics import Pose2D
from rfidnav_sim.rfid_model import Read
from rfidnav_sim.wifi_model import RssReading
from rfidnav_sim.world import World

TAG_COLOURS = {"ceiling": ColorRGBA(r=1.0, g=0.55, b=0.0, a=1.0), "floor": ColorRGBA(r=0.1, g=0.4, b=1.0, a=1.0)}


def base_event_message(event: BaseEventRecord, stamp: Time) -> BaseEvent:
    msg = BaseEvent(event=event.event, active=event.active, action=event.action)
    msg.header.stamp = stamp
    msg.header.frame_id = "base_link"
    return msg


def ground_truth_pose(msg: Odometry, frame_id: str, drops: inputs.Drops) -> tuple[float, float, float] | None:
    """(x, y, yaw) of a /sim/ground_truth message in the world's ``frame_id``; None, dropped and counted, when it is
    in another frame or not a pose (rfidnav_common.inputs)."""
    try:
        return inputs.odometry_pose(msg, frame_id)
    except inputs.BadInput as error:
        drops.drop("/sim/ground_truth", error)
        return None


def odometry_message(pose: Pose2D, velocity: tuple[float, float], stamp: Time, frame_id: str) -> Odometry:
    msg = Odometry()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.child_frame_id = "base_link"
    msg.pose.pose.position.x = pose.x
    msg.pose.pose.position.y = pose.y
    x, y, z, w = yaw_to_quaternion(pose.yaw)
    msg.pose.pose.orientation.x, msg.pose.pose.orientation.y = x, y
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = z, w
    msg.twist.twist.linear.x = float(velocity[0])
    msg.twist.twist.angular.z = float(velocity[1])
    return msg


def reads_message(reads: list[Read], stamp: Time, frame_id: str) -> TagReadArray:
    msg = TagReadArray()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.readings = [TagReading(stamp=stamp, tag_id=read.tag_id, antenna=read.antenna, rssi_dbm=read.rssi_dbm,
                               phase_rad=read.phase_rad, i=read.i, q=read.q, frequency_hz=read.frequency_hz)
                    for read in reads]
    return msg


def wifi_scan_message(readings: list[RssReading], stamp: Time, frame_id: str, interface: str) -> WifiScan:
    msg = WifiScan()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.interface = interface
    msg.access_points = [AccessPointRss(bssid=r.bssid.lower(), ssid=r.ssid, channel=r.channel,
                                        frequency_hz=r.frequency_hz, rssi_dbm=r.rssi_dbm) for r in readings]
    return msg


def world_markers(world: World, stamp: Time) -> MarkerArray:
    """Tags as discs with their ids, walls as one line list: enough to see a run in Foxglove."""
    markers: list[Marker] = []
    for index, tag in enumerate(world.tags):
        disc = Marker(ns="tags", id=index, type=Marker.CYLINDER, action=Marker.ADD)
        disc.header.frame_id, disc.header.stamp = world.frame_id, stamp
        disc.pose.position.x, disc.pose.position.y, disc.pose.position.z = tag.position
        disc.pose.orientation.w = 1.0
        disc.scale.x = disc.scale.y = 0.12
        disc.scale.z = 0.01
        disc.color = TAG_COLOURS[tag.kind]
        label = Marker(ns="tag_ids", id=index, type=Marker.TEXT_VIEW_FACING, action=Marker.ADD, text=tag.tag_id)
        label.header = disc.header
        label.pose.position.x, label.pose.position.y = tag.position[0], tag.position[1]
        label.pose.position.z = tag.position[2] + 0.15
        label.pose.orientation.w = 1.0
        label.scale.z = 0.15
        label.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
        markers += [disc, label]
    if world.walls:
        walls = Marker(ns="walls", id=0, type=Marker.LINE_LIST, action=Marker.ADD)
        walls.header.frame_id, walls.header.stamp = world.frame_id, stamp
        walls.pose.orientation.w = 1.0
        walls.scale.x = 0.05
        walls.color = ColorRGBA(r=0.7, g=0.7, b=0.7, a=1.0)
        for x1, y1, x2, y2 in world.walls:
            walls.points += [Point(x=x1, y=y1, z=0.0), Point(x=x2, y=y2, z=0.0)]
        markers.append(walls)
    for index, deployment in enumerate(world.deployments):
        markers += deployment_markers(deployment, index, world.frame_id, stamp)
    return MarkerArray(markers=markers)


MAX_LATTICE_POINTS = 20_000   # a viewer draws a few thousand points at ease, not 870,000


def deployment_markers(deployment: Deployment, index: int, frame_id: str, stamp: Time) -> list[Marker]:
    """The deployment's area as an outline and, when not too many, its tags as points."""
    outline = Marker(ns="lattice_areas", id=index, type=Marker.LINE_STRIP, action=Marker.ADD)
    outline.header.frame_id, outline.header.stamp = frame_id, stamp
    outline.pose.orientation.w = 1.0
    outline.scale.x = 0.02
    outline.color = TAG_COLOURS["floor"]
    x_min, y_min, x_max, y_max = deployment.area
    outline.points = [Point(x=x, y=y, z=0.0) for x, y in
                      ((x_min, y_min), (x_max, y_min), (x_max, y_max), (x_min, y_max), (x_min, y_min))]
    if deployment.tag_count() > MAX_LATTICE_POINTS:
        return [outline]
    points = Marker(ns="lattice_tags", id=index, type=Marker.POINTS, action=Marker.ADD)
    points.header = outline.header
    points.pose.orientation.w = 1.0
    points.scale.x = points.scale.y = min(0.05, deployment.read_range_m / 2.0)
    points.color = TAG_COLOURS["floor"]
    points.points = [Point(x=float(x), y=float(y), z=0.0)
                     for x, y in deployment.lattice.positions(deployment.coordinates())]
    return [outline, points]
