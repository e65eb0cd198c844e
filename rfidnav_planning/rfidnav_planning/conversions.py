"""Planning domain objects <-> ROS messages: localization status and poses in, plans out."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import Path

from rfidnav_common import inputs
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.tag_lattice import Coordinate, Lattice, TagIdError, decode_tag_id, partition_centre
from rfidnav_localization.partition import LocalizationEstimate
from rfidnav_msgs.msg import LocalizationStatus, Partition, PartitionPath
from rfidnav_planning.partition_planner import PartitionPlan
from rfidnav_planning.pose_navigation import Pose


def estimate_from_status(msg: LocalizationStatus, stamp_s: float,
                         previous_partition: frozenset[Coordinate] | None) -> LocalizationEstimate:
    """The localizer's estimate as the navigator core takes it; the lattice comes from the tag IDs again.

    The status names tags the localizer accepted, so they decode; one that does not is left out. A position
    beyond any map, a heading or bound that is not finite or turns away, a read range that is no distance: BadInput
    (rfidnav_common.inputs), whatever the valid flags say."""
    x, y = inputs.point(msg.x, msg.y, "status")
    # A heading and its bounds, which may reach past +-pi (a bound is the heading -+ a spread), but not by turns.
    yaw, lower, upper = (inputs.bounded(getattr(msg, name), name, -2.0 * math.tau, 2.0 * math.tau, "rad")
                         for name in ("yaw_rad", "yaw_lower_rad", "yaw_upper_rad"))
    read_range_m = inputs.length(msg.read_range_m, "read_range_m")
    lattice: Lattice | None = None
    partition: set[Coordinate] = set()
    for tag_id in msg.partition_tag_ids:
        try:
            decoded = decode_tag_id(tag_id)
        except TagIdError:
            continue
        lattice = lattice or Lattice(decoded.layout, decoded.spacing_m)
        partition.add(decoded.coordinate)
    frozen = frozenset(partition)
    bounds = (lower, upper) if msg.orientation_valid else None
    return LocalizationEstimate(
        stamp_s=stamp_s, method=msg.method, partition=frozen, partition_tag_ids=tuple(msg.partition_tag_ids),
        partition_changed=bool(frozen) and frozen != previous_partition,
        partitions_traversed=msg.partitions_traversed,
        position=(x, y) if msg.position_valid else None, position_covariance=(0.0, 0.0, 0.0),
        yaw=yaw if msg.orientation_valid else None, yaw_bounds=bounds,
        yaw_std=(bounds[1] - bounds[0]) / 4.0 if bounds else None,
        read_range_m=read_range_m if read_range_m > 0.0 else None, lattice=lattice,
        rejected_tag_ids=tuple(msg.rejected_tag_ids), rogue_count=msg.rogue_count,
        undecodable_count=msg.undecodable_count)


def pose_from_message(msg: PoseWithCovarianceStamped, map_frame: str) -> Pose:
    """A localizer's pose as a navigator drives on it: in ``map_frame``, planar, its position's sd from the
    covariance's diagonal (Pose.of_variances); BadInput (rfidnav_common.inputs) for anything else."""
    inputs.frame(msg.header.frame_id, map_frame)
    x, y, yaw = inputs.planar_pose(msg.pose.pose, "pose.pose")
    variance_x, variance_y = msg.pose.covariance[0], msg.pose.covariance[7]
    if not (math.isfinite(variance_x) and math.isfinite(variance_y)) or min(variance_x, variance_y) < 0.0:
        raise inputs.BadInput(f"pose.covariance: position variances {variance_x}, {variance_y} are no variances")
    return Pose.of_variances(x, y, yaw, variance_x, variance_y)


def plan_messages(plan: PartitionPlan, lattice: Lattice, replans: int, stamp: Time,
                  frame_id: str) -> tuple[Path, PartitionPath]:
    """/planning/path (the partition centres, headed along the segment) and /planning/partitions."""
    heading = math.atan2(plan.goal[1] - plan.start[1], plan.goal[0] - plan.start[0])
    qx, qy, qz, qw = yaw_to_quaternion(heading)
    path = Path()
    path.header.stamp, path.header.frame_id = stamp, frame_id
    partitions = PartitionPath()
    partitions.header = path.header
    partitions.start = Point(x=float(plan.start[0]), y=float(plan.start[1]), z=0.0)
    partitions.goal = Point(x=float(plan.goal[0]), y=float(plan.goal[1]), z=0.0)
    partitions.replans = replans
    for tags in plan.partitions:
        x, y = partition_centre(lattice, tags)
        pose = PoseStamped()
        pose.header = path.header
        pose.pose.position.x, pose.pose.position.y = x, y
        pose.pose.orientation.x, pose.pose.orientation.y = qx, qy
        pose.pose.orientation.z, pose.pose.orientation.w = qz, qw
        path.poses.append(pose)
        partitions.partitions.append(Partition(tag_ids=sorted(lattice.tag_id(c) for c in tags),
                                               centre=Point(x=x, y=y, z=0.0)))
    return path, partitions


def point_goal_refusal(goal: Any, refusal: Callable[[tuple[float, float]], str | None]) -> str | None:
    """Why a NavigateToPoint goal is refused: a target that is no point within any map, or the navigator's own
    ``refusal`` of it (outside the robot map's extent); None to accept it."""
    try:
        target = inputs.point(goal.target.x, goal.target.y, "target")
    except inputs.BadInput as error:
        return str(error)
    return refusal(target)
