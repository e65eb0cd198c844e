"""two_tier_navigator: action server /navigate_to_point for paper 003's two-tier navigation.

A thin adapter around TwoTierNavigator. A timer at ``control_rate_hz`` (sim time) steps the core with each
floor round read on the HF antenna since the last step (at the /odom pose it was read at), then with the latest
/odom pose, both with the latest /compass heading,
and publishes its velocity command on /cmd_vel, the dead-reckoned pose on /localization/pose and the tier of
the last fix on /localization/status. When the core asks the location server something, the latest
/wifi/scan goes to /location_server/locate, or the tag-map query to /location_server/tag_map; an unanswered
call (a server restarting, say) is sent again after ``service_timeout_s`` while the robot stands still. Given a
topic in ``tier_one_from`` the navigator takes tier one from the localizer the scenario names instead (its latest pose
and the pose's sd, e.g. rfid_localizer's fused estimate), waiting standing still for its first.
One goal at a time and cancel (checked at each control step): rfidnav_common.goal_server.

Action server /survey (rfidnav_msgs/Survey): the robot's own survey (paper 003's automatic radio map
construction, rfidnav_planning.two_tier_survey): docked on a landmark of ``map_file``, a leg of two-tier navigation
to each landmark in turn; each /wifi/scan that comes while a scan is due (every ``spacing_m`` driven while the
position is fresh from a tag fix) goes to /location_server/add_fingerprint at the position the robot believes.
A navigation goal is refused while a survey runs, and a survey while a navigation runs.

Every input is checked (rfidnav_common.inputs) and what fails is dropped and counted with a throttled warning:
/odom not a pose in odom, a compass reading not in its frame (compass or base_link) or not a rotation, a round or
a scan not in base_link, floor reads no reader reports, a scan with an RSS outside the physical range; a goal
beyond any map, or outside the extent of the robot map's floor plan, is refused; a location server answer with a
position beyond any map is taken as a failed locate, and its tags beyond any map are left out.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Pose2D, PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.task import Future
from sensor_msgs.msg import Imu

from rfidnav_common import inputs
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.goal_server import ActiveGoal, GoalOutcome, SingleGoalServer
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, declare_parameters, input_drops, run_node, twist
from rfidnav_common.stepped_node import SteppedNode
from rfidnav_common.transforms import FrameBroadcaster
from rfidnav_msgs.action import NavigateToPoint, Survey
from rfidnav_msgs.msg import LocalizationStatus, TagReadArray, WifiScan
from rfidnav_msgs.srv import AddFingerprint, GetTagMap, Locate
from rfidnav_planning.conversions import point_goal_refusal, pose_from_message
from rfidnav_planning.parameters import TwoTierNavigatorParameters
from rfidnav_planning.pose_navigation import Pose
from rfidnav_planning.two_tier_navigation import LOCATE, Decision, MapTag, Request, TwoTierNavigator
from rfidnav_planning.two_tier_survey import SURVEY_SPACING_M, RobotSurvey, SurveyLeg, SurveyRule
from rfidnav_planning.wall_paths import WallMap

UNKNOWN_YAW_VARIANCE = 1e6    # [rad^2] on the pose when no heading, or none with a known noise, was read


@dataclass
class SurveyGoal(ActiveGoal):
    plan: RobotSurvey
    rule: SurveyRule
    leg: SurveyLeg
    started_at_m: float                                     # odometry distance when the survey started
    fingerprints_added: int = 0
    failed_legs: list[str] = field(default_factory=list)   # "landmark: why", for the result's message


@dataclass
class PendingCall:
    request: Request
    sent_s: float | None = None              # None: not sent yet (no scan, or the service is not up)
    future: Future | None = None


class TwoTierNavigatorNode(SteppedNode):
    def __init__(self, **node_options: Any) -> None:
        super().__init__("two_tier_navigator", **node_options)
        self.params: TwoTierNavigatorParameters = declare_parameters(self, TwoTierNavigatorParameters)
        map_file = self.params.map_file
        self.robot_map = None if map_file == "unused" else load_route_map(Path(map_file))
        floor = WallMap() if self.robot_map is None else WallMap.of(self.robot_map)
        self.navigator = TwoTierNavigator(self.params.settings(), floor)
        self.call: PendingCall | None = None
        self.drops = input_drops(self)
        self.odom: tuple[float, float, float] | None = None
        self.odom_stamp = Time()
        self.compass_yaw: float | None = None
        self.compass_yaw_variance = UNKNOWN_YAW_VARIANCE    # from each /compass reading, where it gives one
        self.scan: WifiScan | None = None
        self.tier_one_pose: Pose | None = None       # the latest from tier_one_from, when it names a topic
        self.reads: list[tuple[tuple[float, float, float], list[str]]] = []   # (odometry then, tag ids)
        self.cmd_pub = self.create_publisher(Twist, "cmd_vel", COMMAND_QOS)
        self.pose_pub = self.create_publisher(PoseWithCovarianceStamped, "localization/pose", SENSOR_QOS)
        self.frames = FrameBroadcaster(self) if self.params.publish_tf else None   # map -> odom
        self.status_pub = self.create_publisher(LocalizationStatus, "localization/status", SENSOR_QOS)
        self.create_subscription(Odometry, "odom", self.on_odom, SENSOR_QOS)
        self.create_subscription(Imu, "compass", self.on_compass, SENSOR_QOS)
        self.create_subscription(TagReadArray, "rfid/reads", self.on_reads, SENSOR_QOS)
        self.create_subscription(WifiScan, "wifi/scan", self.on_scan, SENSOR_QOS)
        tier_one_topic = self.params.tier_one_pose_topic
        if tier_one_topic is not None:
            self.create_subscription(PoseWithCovarianceStamped, tier_one_topic, self.on_tier_one_pose, SENSOR_QOS)
            self.get_logger().info(f"tier one from the poses of {tier_one_topic}")
        self.locate_client = self.create_client(Locate, "/location_server/locate")
        self.tag_map_client = self.create_client(GetTagMap, "/location_server/tag_map")
        self.add_fingerprint_client = self.create_client(AddFingerprint, "/location_server/add_fingerprint")
        # Cancel is checked by control_step, before the core steps: no command follows a cancel request.
        self.goals: SingleGoalServer[ActiveGoal] = SingleGoalServer(
            self, NavigateToPoint, "navigate_to_point", what="navigation", busy="another goal is being navigated to",
            check=self.refusal, new_goal=ActiveGoal, started=self.on_started, result=self.result, stop=self.stop,
            supervise_period_s=None)
        self.survey_goals: SingleGoalServer[SurveyGoal] = SingleGoalServer(
            self, Survey, "survey", what="survey", busy="another survey is running", check=self.survey_refusal,
            new_goal=self.new_survey, started=self.on_survey_started, result=self.survey_result, stop=self.stop,
            supervise_period_s=None)
        self.create_timer(1.0 / self.params.control_rate_hz, self.control_step)

    def destroy_node(self) -> None:
        self.goals.destroy()
        self.survey_goals.destroy()
        super().destroy_node()

    @property
    def serving(self) -> SingleGoalServer[Any] | None:
        """The goal server whose goal is accepted and not yet reported: the navigation's or the survey's."""
        return next((server for server in (self.goals, self.survey_goals) if server.active is not None), None)

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # ------------------------------------------------------------------------------------ sensing
    def on_odom(self, msg: Odometry) -> None:
        try:
            self.odom, self.odom_stamp = inputs.odometry_pose(msg), msg.header.stamp
        except inputs.BadInput as error:
            self.drops.drop("odom", error)

    def on_compass(self, msg: Imu) -> None:
        try:
            self.compass_yaw = inputs.compass_heading(msg)
        except inputs.BadInput as error:
            self.drops.drop("compass", error)
            return
        # sensor_msgs/Imu: the heading's variance is orientation_covariance[8]; -1 in [0] or 0 mean unknown.
        variance = msg.orientation_covariance[8]
        known = msg.orientation_covariance[0] != -1.0 and math.isfinite(variance) and variance > 0.0
        self.compass_yaw_variance = float(variance) if known else UNKNOWN_YAW_VARIANCE

    def on_reads(self, msg: TagReadArray) -> None:
        """Keep the round with the odometry pose it was read at: the control step comes up to a period later,
        1 cm further at 0.2 m/s, which a fix taken at the step's pose would add to its error."""
        floor_reads = inputs.round_reads(msg, self.drops, ports=(self.params.floor_antenna,))
        tag_ids = [read.tag_id for read in floor_reads or ()]
        if tag_ids and self.odom is not None:
            self.reads.append((self.odom, tag_ids))

    def on_scan(self, msg: WifiScan) -> None:
        """The latest scan, for the next locate; one the location server would refuse is dropped here."""
        try:
            inputs.scan_rss(msg)
        except inputs.BadInput as error:
            self.drops.drop("wifi/scan", error)
            return
        self.scan = msg
        survey = self.survey_goals.running
        if survey is not None and self.navigator.outcome is None:
            self.survey_scan(survey, msg)

    def on_tier_one_pose(self, msg: PoseWithCovarianceStamped) -> None:
        try:
            self.tier_one_pose = pose_from_message(msg, self.params.map_frame)
        except inputs.BadInput as error:
            self.drops.drop(self.params.tier_one_from, error)

    # -------------------------------------------------------------------------------------- goals
    def refusal(self, goal: NavigateToPoint.Goal) -> str | None:
        if self.survey_goals.active is not None:
            return "a survey is running"
        return point_goal_refusal(goal, self.navigator.refusal)

    def on_started(self, goal: ActiveGoal) -> None:
        target = goal.handle.request.target
        self.get_logger().info(f"navigating to ({target.x:.3f}, {target.y:.3f})")
        self.apply(self.navigator.start((target.x, target.y)))

    def stop(self) -> None:
        self.call = None
        self.drive(0.0, 0.0)

    def result(self, _goal: ActiveGoal, success: bool, message: str) -> NavigateToPoint.Result:
        progress = self.navigator.progress
        return NavigateToPoint.Result(
            success=success, message=message, path_length_m=float(self.navigator.travelled_m),
            searches=progress.searches, search_length_m=float(progress.search_length_m),
            tag_fixes=sum(1 for fix in progress.fixes if fix.tag_id), tier_one_requests=progress.tier_one_requests)

    # ------------------------------------------------------------------------------------- survey
    def survey_of(self, goal: Survey.Goal) -> tuple[RobotSurvey, SurveyRule]:
        """The goal's plan and scan rule (a ValueError saying what is wrong with it); 0 spacing: the default."""
        tag_groups = () if self.robot_map is None else self.robot_map.tag_groups
        return (RobotSurvey(tag_groups, goal.dock, list(goal.landmarks)),
                SurveyRule(goal.spacing_m or SURVEY_SPACING_M))

    def survey_refusal(self, goal: Survey.Goal) -> str | None:
        if self.goals.active is not None:
            return "a navigation is running"
        if self.robot_map is None:
            return "no robot map (map_file): the survey drives to its landmarks"
        try:
            plan, _ = self.survey_of(goal)
        except ValueError as error:
            return str(error)
        return next((refusal for group in plan.route if (refusal := self.navigator.refusal(group.centre))), None)

    def new_survey(self, handle: Any) -> SurveyGoal:
        plan, rule = self.survey_of(handle.request)
        return SurveyGoal(handle, plan, rule, plan.first_leg(), self.navigator.travelled_m)

    def on_survey_started(self, survey: SurveyGoal) -> None:
        self.get_logger().info(f"surveying: docked on {survey.plan.dock}, {len(survey.plan.route)} landmarks "
                               f"({', '.join(group.group_id for group in survey.plan.route)}), a scan every "
                               f"{survey.rule.spacing_m:g} m within {survey.rule.fresh_m:g} m of a tag fix")
        self.start_leg(survey, survey.leg)

    def start_leg(self, survey: SurveyGoal, leg: SurveyLeg) -> None:
        survey.leg, survey.rule = leg, SurveyRule(survey.rule.spacing_m, survey.rule.fresh_m)
        start = "from the dock" if leg.index == 0 else "from there" if leg.known_start else "from tier one"
        self.get_logger().info(f"survey leg {leg.index + 1}/{len(survey.plan.route)}: to {leg.landmark} {start}")
        self.apply(self.navigator.start(leg.target, leg.known_start))

    def leg_ended(self, survey: SurveyGoal, decision: Decision) -> None:
        """The leg's navigation ended: on to the next landmark, or the survey's end."""
        leg = survey.leg
        if not decision.success:
            survey.failed_legs.append(f"{leg.landmark}: {decision.message}")
            self.get_logger().warning(f"survey leg to {leg.landmark} failed: {decision.message}")
        following = survey.plan.leg_ended(decision.success)
        if following is not None:
            self.start_leg(survey, following)
            return
        plan = survey.plan
        message = (f"{len(plan.reached)} of {len(plan.route)} landmarks reached, {survey.fingerprints_added} "
                   f"fingerprints added" + "".join(f"; {failure}" for failure in survey.failed_legs))
        self.survey_goals.conclude(GoalOutcome.of(plan.complete), message)

    def survey_scan(self, survey: SurveyGoal, scan: WifiScan) -> None:
        """``scan`` joins the radio map at the believed position when one is due."""
        position = survey.rule.due(self.navigator.estimate(), self.navigator.travelled_m)
        if position is None or not scan.access_points or not self.add_fingerprint_client.service_is_ready():
            return
        request = AddFingerprint.Request(x=float(position[0]), y=float(position[1]), source="survey", scan=scan)
        self.call_service(self.add_fingerprint_client, request, functools.partial(self.on_added, survey))

    def on_added(self, survey: SurveyGoal, future: Future) -> None:
        if future.cancelled():
            return
        response = future.result()
        if response.success:
            survey.fingerprints_added += 1
        else:
            self.drops.drop("/location_server/add_fingerprint", response.message)

    def survey_result(self, survey: SurveyGoal, success: bool, message: str) -> Survey.Result:
        return Survey.Result(success=success, message=message, landmarks_reached=len(survey.plan.reached),
                             legs=len(survey.plan.legs), fingerprints_added=survey.fingerprints_added,
                             path_length_m=float(self.navigator.travelled_m - survey.started_at_m))

    # ------------------------------------------------------------------------------------ control
    def control_step(self) -> None:
        server = self.serving
        if server is None or server.supervise() is None:
            return
        if self.call is not None:
            self.serve(self.call)
        elif self.odom is not None:
            rounds, self.reads = self.reads, []
            for odom, tag_ids in rounds:       # each round at its own pose; then on to the current one
                decision = self.navigator.step(odom, self.compass_yaw, tag_ids)
                if decision.finished or decision.request is not None:
                    self.apply(decision)
                    break
            else:
                self.apply(self.navigator.step(self.odom, self.compass_yaw, []))
        self.publish_estimate()

    def apply(self, decision: Decision) -> None:
        if decision.finished:
            survey = self.survey_goals.running
            if survey is not None:
                self.leg_ended(survey, decision)
            else:
                self.goals.conclude(GoalOutcome.of(decision.success), decision.message)
            return
        if decision.request is not None:
            self.call = PendingCall(decision.request)
            self.serve(self.call)
            if self.call is None or self.call.request is not decision.request:
                return                         # answered at once (tier one from a pose): its decision is applied
        self.drive(*decision.command)
        self.publish_feedback(decision.phase)

    def serve(self, call: PendingCall) -> None:
        """Send the call if it is not out, or again once it has gone unanswered for ``service_timeout_s``; a locate
        with a topic in ``tier_one_from`` is answered by that localizer's latest pose once there is one."""
        if call.request.kind == LOCATE and self.params.tier_one_pose_topic is not None:
            pose = self.tier_one_pose
            if pose is not None:
                self.call = None
                self.apply(self.navigator.on_located((pose.x, pose.y), pose.sd_m))
            return
        if call.sent_s is not None and self.now_s() - call.sent_s < self.params.service_timeout_s:
            return
        if call.sent_s is not None:
            self.get_logger().warning(f"location server: no answer to {call.request.kind} in "
                                      f"{self.params.service_timeout_s:g} s, asking again")
        client = self.locate_client if call.request.kind == LOCATE else self.tag_map_client
        if not client.service_is_ready() or (call.request.kind == LOCATE and self.scan is None):
            call.sent_s = self.now_s()          # try again after the timeout
            return
        if call.request.kind == LOCATE:
            request = Locate.Request(scan=self.scan)
        else:
            request = GetTagMap.Request(x=float(call.request.centre[0]), y=float(call.request.centre[1]),
                                        radius_m=float(call.request.radius_m))
        call.sent_s = self.now_s()
        call.future = self.call_service(client, request, functools.partial(self.on_answer, call))

    def on_answer(self, call: PendingCall, future: Future) -> None:
        if self.call is not call or self.serving is None or future.cancelled():
            return                               # a stale answer (re-sent, or the goal ended), or none: sent again
        self.call = None
        response = future.result()
        if call.request.kind == LOCATE:
            position, uncertainty_m = None, 0.0
            if response.success:
                try:
                    position = inputs.point(response.x, response.y, "position")
                    uncertainty_m = inputs.length(response.uncertainty_m, "uncertainty_m")
                except inputs.BadInput as error:
                    position = None
                    self.drops.drop("/location_server/locate", f"answer taken as a failure: {error}")
            else:
                self.get_logger().warning(f"tier one failed: {response.message}")
            decision = self.navigator.on_located(position, uncertainty_m)
        else:
            decision = self.navigator.on_tag_map(self.map_tags(response.tags))
        self.apply(decision)

    def map_tags(self, tags: list[Any]) -> list[MapTag]:
        """The tag map's answer, without tags beyond any map (dropped and counted)."""
        kept = []
        for index, tag in enumerate(tags):
            try:
                kept.append(MapTag(tag.tag_id, inputs.point(tag.x, tag.y, f"tags[{index}]"), tag.group_id, tag.shape))
            except inputs.BadInput as error:
                self.drops.drop("/location_server/tag_map", error)
        return kept

    # ------------------------------------------------------------------------------------- output
    def drive(self, linear: float, angular: float) -> None:
        self.cmd_pub.publish(twist(linear, angular))

    def publish_feedback(self, phase: str) -> None:
        estimate = self.navigator.estimate()
        pose = None if estimate.position is None else Pose2D(
            x=float(estimate.position[0]), y=float(estimate.position[1]), theta=float(estimate.yaw or 0.0))
        survey = self.survey_goals.running
        if survey is not None:
            feedback = Survey.Feedback(leg=survey.leg.index, landmark=survey.leg.landmark, phase=phase,
                                       fingerprints_added=survey.fingerprints_added)
            if pose is not None:
                feedback.estimated_pose = pose
            self.survey_goals.publish_feedback(feedback)
            return
        feedback = NavigateToPoint.Feedback(phase=phase)
        if estimate.position is not None:
            feedback.estimated_pose = pose
            feedback.distance_to_goal_m = float(math.dist(estimate.position, self.navigator.target))
        self.goals.publish_feedback(feedback)

    def publish_estimate(self) -> None:
        estimate = self.navigator.estimate()
        if estimate.position is None:
            return
        stamp = self.get_clock().now().to_msg()
        pose = PoseWithCovarianceStamped()
        pose.header.stamp, pose.header.frame_id = stamp, self.params.map_frame
        pose.pose.pose.position.x, pose.pose.pose.position.y = map(float, estimate.position)
        x, y, z, w = yaw_to_quaternion(estimate.yaw or 0.0)
        orientation = pose.pose.pose.orientation
        orientation.x, orientation.y, orientation.z, orientation.w = x, y, z, w
        variance = float(estimate.sd_m ** 2)
        pose.pose.covariance[0] = pose.pose.covariance[7] = variance
        pose.pose.covariance[35] = UNKNOWN_YAW_VARIANCE if estimate.yaw is None else self.compass_yaw_variance
        self.pose_pub.publish(pose)
        if self.frames is not None and estimate.yaw is not None and self.odom is not None:
            # Stamped with the odometry it rests on: the step timer fires before the /odom that passed its due
            # time is handled, so "now" is up to one odometry period later than the pose the estimate is for.
            self.frames.send_map_to_odom(self.params.map_frame, (*map(float, estimate.position), estimate.yaw),
                                         self.odom, self.odom_stamp)
        fix = estimate.last_fix
        status = LocalizationStatus(method="two_tier", position_valid=True, x=pose.pose.pose.position.x,
                                    y=pose.pose.pose.position.y, orientation_valid=estimate.yaw is not None,
                                    yaw_rad=float(estimate.yaw or 0.0), read_range_m=self.params.read_range_m,
                                    last_fix_tier=fix.tier if fix else 0, last_fix_tag_id=fix.tag_id if fix else "",
                                    distance_since_fix_m=float(estimate.distance_since_fix_m))
        status.header = pose.header
        status.yaw_lower_rad = status.yaw_upper_rad = status.yaw_rad
        self.status_pub.publish(status)


def main(args: list[str] | None = None) -> int:
    return run_node(TwoTierNavigatorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
