"""Localization domain objects <-> ROS messages: estimates (PoseWithCovarianceStamped, LocalizationStatus) and
floor tags of the location server (a WiFi scan is read by rfidnav_common.inputs.wifi_rss, checked); the fused
localizer's pose and status, and /initialpose."""

from __future__ import annotations

import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseWithCovarianceStamped

from rfidnav_common import inputs
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_localization.fused.filter import PoseEstimate
from rfidnav_localization.fused.localizer import FusedEstimate
from rfidnav_localization.location_store import TagRecord
from rfidnav_localization.partition import LocalizationEstimate
from rfidnav_msgs.msg import FloorTag, LocalizationStatus

# Yaw variance published while the heading is unknown: no consumer should mistake it for information.
UNKNOWN_YAW_VARIANCE = 1e6
# Row-major indices into the 6 x 6 covariance of (x, y, z, roll, pitch, yaw). z, roll and pitch stay 0:
# the robot drives on the floor plane, so they are known exactly.
XX, XY, YX, YY, YAW_YAW = 0, 1, 6, 7, 35


def pose_message(estimate: LocalizationEstimate, stamp: Time, frame_id: str) -> PoseWithCovarianceStamped:
    """The estimate's pose in ``frame_id``; requires a position. An unknown heading is the identity
    orientation with UNKNOWN_YAW_VARIANCE."""
    if estimate.position is None:
        raise ValueError("an estimate without a position has no pose")
    message = PoseWithCovarianceStamped()
    message.header.stamp = stamp
    message.header.frame_id = frame_id
    pose = message.pose.pose
    pose.position.x, pose.position.y = float(estimate.position[0]), float(estimate.position[1])
    if estimate.yaw is not None:
        x, y, z, w = yaw_to_quaternion(estimate.yaw)
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = x, y, z, w
    covariance = [0.0] * 36
    var_x, cov_xy, var_y = estimate.position_covariance
    covariance[XX], covariance[XY], covariance[YX], covariance[YY] = (float(var_x), float(cov_xy), float(cov_xy),
                                                                      float(var_y))
    covariance[YAW_YAW] = float(estimate.yaw_std ** 2) if estimate.yaw_std is not None else UNKNOWN_YAW_VARIANCE
    message.pose.covariance = covariance
    return message


def status_message(estimate: LocalizationEstimate, stamp: Time, frame_id: str) -> LocalizationStatus:
    """Everything the localizer knows besides the pose; fields without a value yet are 0 with their
    ``*_valid`` flag false."""
    message = LocalizationStatus()
    message.header.stamp = stamp
    message.header.frame_id = frame_id
    message.method = estimate.method
    message.partition_tag_ids = list(estimate.partition_tag_ids)
    message.partitions_traversed = int(estimate.partitions_traversed)
    message.position_valid = estimate.position is not None
    if estimate.position is not None:
        message.x, message.y = float(estimate.position[0]), float(estimate.position[1])
    message.orientation_valid = estimate.yaw is not None
    if estimate.yaw is not None:
        message.yaw_rad = float(estimate.yaw)
        lower, upper = estimate.yaw_bounds
        message.yaw_lower_rad, message.yaw_upper_rad = float(lower), float(upper)
    message.read_range_m = float(estimate.read_range_m) if estimate.read_range_m is not None else 0.0
    message.rejected_tag_ids = list(estimate.rejected_tag_ids)
    message.rogue_count = int(estimate.rogue_count)
    message.undecodable_count = int(estimate.undecodable_count)
    return message


def floor_tag_message(tag: TagRecord) -> FloorTag:
    return FloorTag(tag_id=tag.tag_id, x=float(tag.position[0]), y=float(tag.position[1]), group_id=tag.group_id,
                    shape=tag.shape)


def fused_pose_message(pose: PoseEstimate, stamp: Time, frame_id: str) -> PoseWithCovarianceStamped:
    """The fused filter's pose with the particles' covariance over (x, y, yaw)."""
    message = PoseWithCovarianceStamped()
    message.header.stamp = stamp
    message.header.frame_id = frame_id
    position, orientation = message.pose.pose.position, message.pose.pose.orientation
    position.x, position.y = float(pose.x), float(pose.y)
    orientation.x, orientation.y, orientation.z, orientation.w = yaw_to_quaternion(pose.yaw)
    covariance = [0.0] * 36
    for row, index in enumerate((0, 1, 5)):            # x, y, yaw among (x, y, z, roll, pitch, yaw)
        for column, other in enumerate((0, 1, 5)):
            covariance[6 * index + other] = float(pose.covariance[row, column])
    message.pose.covariance = covariance
    return message


def fused_status_message(estimate: FusedEstimate, stamp: Time, frame_id: str, ignored_count: int) -> LocalizationStatus:
    """The fused localizer's status: the evidence weighed this round and the particles redrawn from it, and the
    lattice tags read (the partition, with their read range), so that the partition navigator can drive on it."""
    pose = estimate.pose
    message = LocalizationStatus(method="fused", position_valid=True, x=float(pose.x), y=float(pose.y),
                                 orientation_valid=True, yaw_rad=float(pose.yaw),
                                 partition_tag_ids=list(estimate.partition_tag_ids),
                                 read_range_m=float(estimate.read_range_m),
                                 evidence_used=list(estimate.update.used),
                                 particles_redrawn=int(estimate.update.injected),
                                 undecodable_count=int(ignored_count))
    message.header.stamp = stamp
    message.header.frame_id = frame_id
    yaw_sd = math.sqrt(max(float(pose.covariance[2, 2]), 0.0))
    message.yaw_lower_rad, message.yaw_upper_rad = float(pose.yaw - 2.0 * yaw_sd), float(pose.yaw + 2.0 * yaw_sd)
    return message


def initial_pose(message: PoseWithCovarianceStamped) -> tuple[tuple[float, float, float], np.ndarray]:
    """(x, y, yaw) and its 3 x 3 covariance from an /initialpose message (checked: finite, a planar pose, a
    covariance that is symmetric positive semi-definite in x, y, yaw)."""
    pose = inputs.planar_pose(message.pose.pose, "pose.pose")
    full = np.asarray(message.pose.covariance, dtype=float).reshape(6, 6)
    covariance = full[np.ix_((0, 1, 5), (0, 1, 5))]
    if not np.all(np.isfinite(covariance)):
        raise inputs.BadInput("pose.covariance: not finite")
    if not np.allclose(covariance, covariance.T) or np.linalg.eigvalsh(covariance).min() < -1e-12:
        raise inputs.BadInput("pose.covariance: x, y, yaw block is not symmetric positive semi-definite")
    return pose, covariance
