"""The pose navigator's core (rfidnav_planning.pose_navigation): to a point on a localizer's pose, round the map's
walls, standing still while the pose is missing or too uncertain."""

from __future__ import annotations

import math

import pytest

from rfidnav_planning.pose_navigation import DRIVING, WAITING, Pose, PoseNavigator, PoseNavigatorSettings
from rfidnav_planning.wall_paths import WallMap
from rfidnav_sim.kinematics import unicycle_step

pytestmark = pytest.mark.tier("unit")

# A 6 x 4 m room split by a wall at x = 3 with a door at y 3..4: the way from west to east goes through it.
FLOOR = WallMap(walls=((3.0, 0.0, 3.0, 3.0),), extent=(0.0, 0.0, 6.0, 4.0))
STEP_S = 0.05


def drive(navigator: PoseNavigator, pose: Pose, steps: int = 2000) -> tuple[Pose, list[tuple[float, float]]]:
    """Move the robot by each command, the localizer's pose being the truth; the poses passed through."""
    track = []
    for _ in range(steps):
        step = navigator.step(pose)
        if step.finished:
            assert step.success, step.message
            return pose, track
        dx, dy, dyaw = unicycle_step(pose.yaw, *step.command, STEP_S)
        pose = Pose(pose.x + dx, pose.y + dy, pose.yaw + dyaw, pose.sd_m)
        track.append((pose.x, pose.y))
    raise AssertionError(f"not there after {steps} steps: {pose}")


def test_it_drives_round_the_wall_through_the_door_to_the_target() -> None:
    navigator = PoseNavigator(PoseNavigatorSettings(), FLOOR)
    navigator.start((5.0, 1.0))
    end, track = drive(navigator, Pose(1.0, 1.0, 0.0, 0.05))
    assert math.dist((end.x, end.y), (5.0, 1.0)) <= 0.05
    assert max(y for x, y in track if 2.9 <= x <= 3.1) > 3.0        # through the door, not the wall
    assert navigator.plans == 1


def test_without_a_pose_or_with_an_uncertain_one_it_stands_still() -> None:
    navigator = PoseNavigator(PoseNavigatorSettings(max_position_sd_m=0.3), FLOOR)
    navigator.start((5.0, 1.0))
    assert navigator.step(None).phase == WAITING and navigator.step(None).command == (0.0, 0.0)
    assert navigator.step(Pose(1.0, 1.0, 0.0, 0.5)).command == (0.0, 0.0)
    assert navigator.step(Pose(1.0, 1.0, 0.0, math.nan)).phase == WAITING
    assert navigator.step(Pose(1.0, 1.0, 0.0, 0.1)).phase == DRIVING


def test_a_pose_that_jumps_is_planned_from_again() -> None:
    navigator = PoseNavigator(PoseNavigatorSettings(replan_jump_m=0.3), FLOOR)
    navigator.start((5.0, 1.0))
    navigator.step(Pose(1.0, 1.0, 0.0, 0.05))
    navigator.step(Pose(1.01, 1.0, 0.0, 0.05))
    assert navigator.plans == 1
    navigator.step(Pose(4.0, 3.5, 0.0, 0.05))        # the localizer found the robot on the other side
    assert navigator.plans == 2
    end, _ = drive(navigator, Pose(4.0, 3.5, 0.0, 0.05))
    assert math.dist((end.x, end.y), (5.0, 1.0)) <= 0.05


def test_a_target_outside_the_extent_is_refused_with_the_extent() -> None:
    navigator = PoseNavigator(PoseNavigatorSettings(), FLOOR)
    assert "outside the map's extent" in navigator.refusal((7.0, 1.0))
    with pytest.raises(ValueError, match="not a finite point"):
        navigator.start((math.nan, 1.0))


def test_a_localizers_pose_message_becomes_the_pose_a_navigator_drives_on_and_a_bad_one_is_refused() -> None:
    from geometry_msgs.msg import PoseWithCovarianceStamped

    from rfidnav_common.geometry import yaw_to_quaternion
    from rfidnav_common.inputs import BadInput
    from rfidnav_planning.conversions import pose_from_message

    def message(x: float = 1.0, frame: str = "map", variance_y: float = 0.09) -> PoseWithCovarianceStamped:
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = frame
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, 2.0
        o = msg.pose.pose.orientation
        o.x, o.y, o.z, o.w = yaw_to_quaternion(0.5)
        msg.pose.covariance[0], msg.pose.covariance[7] = 0.04, variance_y
        return msg

    pose = pose_from_message(message(), "map")
    assert (pose.x, pose.y, pose.yaw, pose.sd_m) == pytest.approx((1.0, 2.0, 0.5, 0.3))   # the larger axis's sd
    for bad, words in ((message(x=math.nan), "finite"), (message(frame="odom"), "odom"),
                       (message(variance_y=-1.0), "no variances"), (message(variance_y=math.inf), "no variances")):
        with pytest.raises(BadInput, match=words):
            pose_from_message(bad, "map")
