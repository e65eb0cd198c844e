"""Node tests of partition_navigator: the node constructed in this process on a private rclpy Context, fed
LocalizationStatus and /odom by a probe node on the same executor and given goals through the action, stepped
with ``spin_once`` until a stated condition holds (no sleeps). Each test leases its own DDS domain, as
test_nodes.py does.

The statuses are what partition_localizer (method paper) publishes on a real lattice: the tags of the
partition the robot is in, its centre as the position, and the partitions traversed along the straight
stretch."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from action_msgs.msg import GoalStatus
from action_msgs.srv import CancelGoal
from geometry_msgs.msg import Point, Twist
from nav_msgs.msg import Odometry
from nav_msgs.msg import Path as PathMsg
from rclpy.action import ActionClient
from rclpy.parameter import Parameter

from rfidnav_common.ros import COMMAND_QOS, LATCHED_QOS, SENSOR_QOS, time_msg
from rfidnav_common.tag_lattice import (
    Coordinate,
    decode_tag_id,
    make_deployment,
    partition_centre,
)
from rfidnav_msgs.action import NavigateToPoint
from rfidnav_msgs.msg import LocalizationStatus, PartitionPath
from rfidnav_planning.partition_navigator_node import PartitionNavigatorNode
from rfidnav_sim.conversions import odometry_message
from rfidnav_sim.kinematics import Pose2D
from support.graph import Graph
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("node")

MAP = WORKSPACE / "config/maps/partition_field.yaml"     # deployment_area [0, 0, 5, 5]
WAIT_S = 15.0   # generous for a loaded 2-core machine; each wait normally takes milliseconds
READ_RANGE_M = 0.2
FIELD = make_deployment("triangular", READ_RANGE_M, (0.0, 0.0, 5.0, 5.0))
NODE_NAME = "partition_navigator"
FORWARD_MPS = 0.2        # forward_speed_mps (default)
TURN_RATE = 0.8          # turn_rate_radps (default)
APPROXIMATION_LEVEL = 4  # approximation_level (default)

Partition = frozenset[Coordinate]


def stretch(x: float, y: float, count: int, step_m: float = 0.005) -> list[Partition]:
    """The first ``count`` partitions met driving east (yaw 0) from (x, y), each entered once."""
    partitions: list[Partition] = []
    while len(partitions) < count:
        partition = FIELD.partition_at(x, y)
        if partition and (not partitions or partition != partitions[-1]):
            partitions.append(partition)
        x += step_m
    return partitions


class Harness(Graph):
    """partition_navigator on the partition_field map, with a probe that sends it statuses, odometry and goals
    and collects its /cmd_vel, plans and /rosout."""

    def __init__(self, domain_id: int, **parameters: Any) -> None:
        super().__init__(domain_id)
        # A long silence timeout: a loaded machine must not abort a goal between two of the test's statuses.
        parameters = {"map_file": str(MAP), "unheard_timeout_s": 60.0, **parameters}
        self.node = self.add(PartitionNavigatorNode(context=self.context, parameter_overrides=[
            Parameter(name, value=value) for name, value in parameters.items()]))
        self.commands: list[Twist] = []
        self.paths: list[PathMsg] = []
        self.plans: list[PartitionPath] = []
        self.feedback: list[NavigateToPoint.Feedback] = []
        probe = self.probe
        self.status_pub = probe.create_publisher(LocalizationStatus, "/localization/status", SENSOR_QOS)
        self.odom_pub = probe.create_publisher(Odometry, "/odom", SENSOR_QOS)
        subscriptions = [probe.create_subscription(Twist, "/cmd_vel", self.commands.append, COMMAND_QOS),
                         probe.create_subscription(PathMsg, "/planning/path", self.paths.append, LATCHED_QOS),
                         probe.create_subscription(PartitionPath, "/planning/partitions", self.plans.append,
                                                   LATCHED_QOS)]
        self.client = ActionClient(probe, NavigateToPoint, "/navigate_to_point")
        self.clients.append(self.client)
        self.spin_until(lambda: self.client.server_is_ready() and self.status_pub.get_subscription_count() > 0
                        and self.odom_pub.get_subscription_count() > 0
                        and all(s.get_publisher_count() > 0 for s in subscriptions),
                        "partition_navigator's action server and topics")
        self.stamp_s = 100.0

    def spin_until(self, condition: Callable[[], bool], what: str, timeout_s: float = WAIT_S) -> None:
        super().spin_until(condition, what, timeout_s)

    def logged(self, *words: str) -> list[str]:
        return super().logged(NODE_NAME, *words)

    # ------------------------------------------------------------------------------------------- goals
    def send_goal(self, x: float, y: float, tolerance_m: float = 0.0):
        goal = NavigateToPoint.Goal(target=Point(x=float(x), y=float(y), z=0.0), tolerance_m=float(tolerance_m))
        future = self.client.send_goal_async(goal, feedback_callback=lambda m: self.feedback.append(m.feedback))
        self.spin_until(future.done, f"an answer to the goal ({x}, {y})")
        return future.result()

    def start_goal(self, x: float, y: float):
        """A goal accepted and being navigated to, with the stop the node sends on accepting it received."""
        before = len(self.commands)
        handle = self.send_goal(x, y)
        assert handle.accepted, f"goal ({x}, {y}) rejected: {self.logged('goal rejected')}"
        # Accepted is answered before the node starts navigating; statuses sent before that are ignored.
        self.spin_until(lambda: self.node.goals.active is not None and len(self.commands) > before,
                        "the goal to start, with its stop command")
        assert (self.commands[before].linear.x, self.commands[before].angular.z) == (0.0, 0.0)
        return handle

    # ---------------------------------------------------------------------------------------- inputs
    def status(self, partition: Partition, traversed: int, yaw: float | None = None,
               **bad: float) -> LocalizationStatus:
        """The paper localizer's status in ``partition``; ``yaw`` None: no heading yet; ``bad`` overrides."""
        self.stamp_s += 0.04
        message = LocalizationStatus(method="paper", read_range_m=READ_RANGE_M, partitions_traversed=traversed)
        message.header.stamp = time_msg(self.stamp_s)
        message.header.frame_id = "map"
        message.partition_tag_ids = sorted(FIELD.lattice.tag_id(c) for c in partition)
        message.position_valid = bool(partition)
        if partition:
            message.x, message.y = (float(v) for v in partition_centre(FIELD.lattice, partition))
        if yaw is not None:
            message.orientation_valid = True
            message.yaw_rad, message.yaw_lower_rad, message.yaw_upper_rad = yaw, yaw - 0.1, yaw + 0.1
        for field, value in bad.items():
            setattr(message, field, value)
        return message

    def send_status(self, message: LocalizationStatus) -> Twist:
        """Publish a status and return the /cmd_vel the node answers it with."""
        before = len(self.commands)
        self.status_pub.publish(message)
        self.spin_until(lambda: len(self.commands) > before, f"a /cmd_vel for the status at {self.stamp_s:.2f}")
        return self.commands[before]

    def send_odometry(self, x: float, y: float, yaw: float) -> None:
        self.odom_pub.publish(odometry_message(Pose2D(float(x), float(y), float(yaw)), (0.0, 0.0),
                                               time_msg(self.stamp_s), "odom"))
        self.spin_until(lambda: self.node.odom_pose is not None
                        and self.node.odom_pose[:2] == (x, y)
                        and self.node.odom_pose[2] == pytest.approx(yaw, abs=1e-9), f"the odometry ({x}, {y}, {yaw})")

    def localize(self, partitions: list[Partition]) -> list[Twist]:
        """Drive the localization phase: one status per partition entered, with a heading (east) known from
        the second partition on, as the localizer gives it; the last one is the N-th partition traversed."""
        return [self.send_status(self.status(p, traversed=k, yaw=0.0 if k >= 1 else None))
                for k, p in enumerate(partitions)]


@pytest.fixture
def harness(domain: int) -> Iterator[Harness]:
    harness = Harness(domain)
    try:
        yield harness
    finally:
        harness.close()


def motion(command: Twist) -> tuple[float, float]:
    return command.linear.x, command.angular.z


START_X, START_Y = 0.5, 0.55    # the localization stretch starts here, heading east
GOAL = (2.0, 1.3)
ODOM_AT_PLAN = (0.9, 0.0)       # odometry (its own frame) when the plan is made, 0.9 m from its origin


def localize_and_turn(harness: Harness) -> tuple[Any, PartitionPath, float]:
    """Accept GOAL, localize across N partitions and start turning towards the goal; returns the client's goal
    handle, the plan and the odometry heading the turn is to end on."""
    handle = harness.start_goal(*GOAL)
    harness.send_odometry(0.0, 0.0, 0.0)
    partitions = stretch(START_X, START_Y, APPROXIMATION_LEVEL + 1)
    commands = harness.localize(partitions[:-1])
    assert [motion(c) for c in commands] == [(pytest.approx(FORWARD_MPS), 0.0)] * APPROXIMATION_LEVEL, \
        "fewer than N partitions traversed: drive straight on, even with a heading"
    assert not harness.paths and not harness.plans, "planned before the localization phase ended"
    assert harness.node.goals.active.phase == "localizing"

    harness.send_odometry(*ODOM_AT_PLAN, 0.0)
    last = harness.status(partitions[-1], traversed=APPROXIMATION_LEVEL, yaw=0.0)
    turn = harness.send_status(last)
    harness.spin_until(lambda: harness.paths and harness.plans, "the plan on /planning/path and /planning/partitions")
    plan, path = harness.plans[-1], harness.paths[-1]
    assert plan.partitions, "an empty plan"
    assert (plan.goal.x, plan.goal.y) == GOAL
    assert (plan.start.x, plan.start.y) == (last.x, last.y), "planned from the estimate (inside the area)"
    assert plan.replans == 0 and plan.header.frame_id == "map" and path.header.frame_id == "map"
    assert [(p.pose.position.x, p.pose.position.y) for p in path.poses] == [(p.centre.x, p.centre.y)
                                                                            for p in plan.partitions]
    assert list(plan.partitions[0].tag_ids) == list(last.partition_tag_ids), "the plan starts where the robot is"
    assert set(plan.partitions[-1].tag_ids) == {FIELD.lattice.tag_id(c) for c in FIELD.partition_at(*GOAL)}

    # The goal lies north-east of the estimate, the robot heads east: turn left (CCW) on the spot.
    bearing = math.atan2(GOAL[1] - last.y, GOAL[0] - last.x)
    assert 0.3 < bearing < 1.5
    assert turn.linear.x == 0.0 and turn.angular.z == pytest.approx(min(TURN_RATE, 3.0 * bearing)), motion(turn)
    assert harness.node.navigator.state.phase == "rotating"
    return handle, plan, bearing


def test_a_goal_outside_the_deployment_is_rejected_and_logged_one_inside_accepted(harness: Harness) -> None:
    handle = harness.send_goal(6.0, 2.0)
    assert not handle.accepted, "a goal 1 m east of the tagged area was accepted"
    harness.spin_until(lambda: harness.logged("goal rejected", "outside the deployment"),
                       "partition_navigator to log why (6, 2) was rejected")
    assert "(6.000, 2.000)" in harness.logged("outside the deployment")[0]
    assert harness.node.goals.active is None
    handle = harness.send_goal(-0.01, 4.0)
    assert not handle.accepted, "a goal just west of the tagged area was accepted"
    # Still serving: a goal inside (here on the area's edge) is accepted and navigated to.
    handle = harness.start_goal(5.0, 2.5)
    assert harness.node.goals.active.handle.goal_id == handle.goal_id
    assert harness.node.navigator.state.goal == (5.0, 2.5)


def test_localizes_over_n_partitions_then_plans_turns_and_drives_on(harness: Harness) -> None:
    _, _, bearing = localize_and_turn(harness)
    # Half way round: still turning the same way, no forward motion.
    before = len(harness.commands)
    harness.send_odometry(*ODOM_AT_PLAN, bearing / 2.0)
    harness.spin_until(lambda: len(harness.commands) > before, "a turn command for the odometry half way round")
    half = harness.commands[before]
    assert half.linear.x == 0.0 and 0.0 < half.angular.z <= TURN_RATE, motion(half)
    # The odometry heading reaches the bearing: the turn is done, drive along the plan.
    before = len(harness.commands)
    harness.send_odometry(*ODOM_AT_PLAN, bearing)
    harness.spin_until(lambda: len(harness.commands) > before, "a command once the turn is done")
    assert motion(harness.commands[before]) == (pytest.approx(FORWARD_MPS), 0.0)
    assert harness.node.goals.active.phase == "following" and harness.node.goals.active.turn.target_yaw is None
    # One feedback per status: the N + 1 partitions entered, none re-planned, the goal ever nearer.
    harness.spin_until(lambda: len(harness.feedback) >= APPROXIMATION_LEVEL + 1, "feedback for every status")
    assert [f.partitions_traversed for f in harness.feedback] == list(range(1, APPROXIMATION_LEVEL + 2))
    # Localizing for N statuses; the status that plans starts the turn, so its feedback says rotating.
    assert [(f.phase, f.replans) for f in harness.feedback] == \
        [("localizing", 0)] * APPROXIMATION_LEVEL + [("rotating", 0)]
    distances = [f.distance_to_goal_m for f in harness.feedback]
    assert distances == sorted(distances, reverse=True) and distances[-1] > 0.0, distances


def test_entering_the_goal_partition_succeeds_and_stops(harness: Harness) -> None:
    handle, plan, bearing = localize_and_turn(harness)
    result_future = handle.get_result_async()
    before = len(harness.commands)
    harness.send_odometry(*ODOM_AT_PLAN, bearing)
    harness.spin_until(lambda: len(harness.commands) > before, "the command after the turn")
    # Follow the plan partition by partition (the localizer starts a new straight stretch after the turn).
    following = [frozenset(decode_tag_id(t).coordinate for t in p.tag_ids) for p in plan.partitions]
    assert len(following) >= 3, "a plan too short to follow before arriving"
    for k, partition in enumerate(following[1:-1], start=1):
        command = harness.send_status(harness.status(partition, traversed=k, yaw=bearing))
        assert motion(command) == (pytest.approx(FORWARD_MPS), 0.0), f"plan partition {k}: {motion(command)}"
    assert not result_future.done()
    stop = harness.send_status(harness.status(following[-1], traversed=len(following) - 1, yaw=bearing))
    assert motion(stop) == (0.0, 0.0), "no stop on arriving"
    harness.spin_until(result_future.done, "the result after entering the goal's partition")
    answer = result_future.result()
    assert answer.status == GoalStatus.STATUS_SUCCEEDED
    result = answer.result
    assert result.success and "arrived" in result.message, result.message
    assert result.replans == 0
    # N + 1 partitions localizing (the first one read counts as entered), then the plan's after its first.
    assert result.partitions_traversed == (APPROXIMATION_LEVEL + 1) + (len(following) - 1)
    assert result.path_length_m == pytest.approx(math.dist((0.0, 0.0), ODOM_AT_PLAN))
    assert harness.node.goals.active is None and not harness.plans[-1].replans
    assert len(harness.plans) == 1, "re-planned while following the plan"
    # Done: a new goal is accepted.
    harness.start_goal(*GOAL)


@pytest.mark.parametrize("bad", [{"x": math.nan}, {"yaw_rad": math.nan}, {"yaw_upper_rad": math.inf}])
def test_a_status_with_non_finite_values_is_ignored_and_survived(harness: Harness, bad: dict[str, float]) -> None:
    handle = harness.start_goal(*GOAL)
    node = harness.node
    partitions = stretch(START_X, START_Y, 3)
    assert motion(harness.send_status(harness.status(partitions[0], 0))) == (pytest.approx(FORWARD_MPS), 0.0)
    state = node.navigator.state
    assert state.partitions_entered == 1
    # A new partition, but a non-finite value in the status: nothing of it is taken.
    heard = node.goals.active.last_heard_s
    harness.status_pub.publish(harness.status(partitions[1], 1, yaw=0.0, **bad))
    harness.spin_until(lambda: node.goals.active.last_heard_s != heard, "the bad status to arrive")
    harness.spin_until(lambda: harness.logged("/localization/status: dropped", "not finite"),
                       "the warning about the bad status on /rosout")
    assert state.partitions_entered == 1 and state.last_estimate.partition == partitions[0]
    assert node.goals.active.previous_partition == partitions[0]
    # Still navigating the same goal: the next good status counts the partition and drives on.
    command = harness.send_status(harness.status(partitions[1], 1, yaw=0.0))
    assert motion(command) == (pytest.approx(FORWARD_MPS), 0.0)
    assert state.partitions_entered == 2 and state.last_estimate.partition == partitions[1]
    assert node.goals.active is not None and node.goals.active.handle.goal_id == handle.goal_id
    assert all(math.isfinite(v) for c in harness.commands for v in motion(c))


def test_cancelling_the_goal_ends_it_as_canceled_and_stops(harness: Harness) -> None:
    handle = harness.start_goal(*GOAL)
    result_future = handle.get_result_async()
    partitions = stretch(START_X, START_Y, 2)
    for k, partition in enumerate(partitions):
        assert motion(harness.send_status(harness.status(partition, k))) == (pytest.approx(FORWARD_MPS), 0.0)
    before = len(harness.commands)
    cancel = handle.cancel_goal_async()
    harness.spin_until(cancel.done, "the answer to the cancel request")
    assert cancel.result().return_code == CancelGoal.Response.ERROR_NONE
    assert [g.goal_id for g in cancel.result().goals_canceling] == [handle.goal_id]
    harness.spin_until(result_future.done, "the result of the cancelled goal")
    answer = result_future.result()
    assert answer.status == GoalStatus.STATUS_CANCELED, answer.status
    assert not answer.result.success and "cancel" in answer.result.message, answer.result.message
    assert answer.result.partitions_traversed == 2
    harness.spin_until(lambda: len(harness.commands) > before, "the stop command on cancelling")
    assert motion(harness.commands[-1]) == (0.0, 0.0)
    assert harness.node.goals.active is None and harness.node.navigator.state.outcome is not None
    harness.start_goal(*GOAL)


def test_a_plan_made_before_any_odometry_still_turns_towards_the_goal(harness: Harness) -> None:
    """With no /odom yet when the plan is made, the node stops and keeps the turn pending; the first /odom starts
    it (once it dropped the turn and followed the plan on its old heading)."""
    harness.start_goal(*GOAL)
    partitions = stretch(START_X, START_Y, APPROXIMATION_LEVEL + 1)
    harness.localize(partitions[:-1])
    last = harness.status(partitions[-1], traversed=APPROXIMATION_LEVEL, yaw=0.0)
    before = len(harness.commands)
    harness.status_pub.publish(last)
    harness.spin_until(lambda: harness.plans, "the plan")
    harness.send_odometry(*ODOM_AT_PLAN, 0.0)
    command = harness.send_status(harness.status(partitions[-1], traversed=APPROXIMATION_LEVEL, yaw=0.0))
    moves = [motion(c) for c in harness.commands[before:]]
    assert command.angular.z > 0.0 and command.linear.x == 0.0, f"never turned towards the goal: {moves}"
