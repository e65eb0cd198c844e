"""two_tier_navigator as a node: it waits for a location server that is not up, asks again, and carries on when
the server comes (as after a restart mid-mission); a bad goal is refused; its /survey adds scans to the server."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu

from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS
from rfidnav_localization.fingerprint import Fingerprint
from rfidnav_localization.location_server_node import LocationServerNode
from rfidnav_localization.location_store import LocationStore
from rfidnav_msgs.action import NavigateToPoint, Survey
from rfidnav_msgs.msg import AccessPointRss, WifiScan
from rfidnav_planning.two_tier_navigator_node import TwoTierNavigatorNode
from support.graph import Graph

pytestmark = pytest.mark.tier("node")

RSS = {"02:00:00:00:00:01": -40.0, "02:00:00:00:00:02": -60.0}


@pytest.fixture
def server_files(tmp_path: Path) -> tuple[Path, Path]:
    database = tmp_path / "site.db"
    with LocationStore.open(database, create=True) as store:
        store.add_fingerprints([Fingerprint((1.0, 1.0), RSS, "grid"),
                                Fingerprint((5.0, 5.0), {b: v - 20.0 for b, v in RSS.items()}, "grid")])
    map_file = tmp_path / "home.yaml"
    map_file.write_text("name: home\ntag_groups:\n  - {id: G1, shape: cross, centre: [2.0, 1.0]}\n")
    return database, map_file


def sensors(graph: Graph):
    odom_pub = graph.probe.create_publisher(Odometry, "/odom", SENSOR_QOS)
    compass_pub = graph.probe.create_publisher(Imu, "/compass", SENSOR_QOS)
    scan_pub = graph.probe.create_publisher(WifiScan, "/wifi/scan", SENSOR_QOS)

    def publish() -> None:
        odom = Odometry(child_frame_id="base_link")
        odom.header.frame_id = "odom"
        odom.pose.pose.orientation.w = 1.0
        odom_pub.publish(odom)
        compass = Imu()
        compass.header.frame_id = "compass"
        compass.orientation.x, compass.orientation.y, compass.orientation.z, compass.orientation.w = \
            yaw_to_quaternion(0.0)
        compass_pub.publish(compass)
        scan = WifiScan(access_points=[AccessPointRss(bssid=b, rssi_dbm=v) for b, v in RSS.items()])
        scan.header.frame_id = "base_link"
        scan_pub.publish(scan)
    return publish


def send_goal(graph: Graph, publish: Callable[[], None], feedback: list[str] | None = None) -> list[Twist]:
    """Send the navigator a goal at (2, 1), the sensors published once, and wait for it to be accepted; the
    /cmd_vel commands from then on, and each feedback's phase into ``feedback``."""
    commands: list[Twist] = []
    graph.probe.create_subscription(Twist, "/cmd_vel", commands.append, COMMAND_QOS)
    client = ActionClient(graph.probe, NavigateToPoint, "/navigate_to_point")
    graph.clients.append(client)
    graph.spin_until(client.server_is_ready, "the action server")
    publish()
    goal = NavigateToPoint.Goal()
    goal.target.x, goal.target.y = 2.0, 1.0
    phases = feedback if feedback is not None else []
    sent = client.send_goal_async(goal, feedback_callback=lambda msg: phases.append(msg.feedback.phase))
    graph.spin_until(sent.done, "the goal's acceptance")
    assert sent.result().accepted
    return commands


def test_the_navigator_asks_again_until_the_location_server_answers_then_drives(
        graph: Graph, server_files: tuple[Path, Path]) -> None:
    navigator = graph.add(TwoTierNavigatorNode(context=graph.context, parameter_overrides=[
        Parameter("service_timeout_s", value=0.3)]))
    publish = sensors(graph)
    feedback: list[str] = []
    commands = send_goal(graph, publish, feedback)
    graph.spin_until(lambda: graph.logged("two_tier_navigator", "asking again"), "a retried locate")
    assert set(feedback) <= {"locating"} and all(c.linear.x == 0.0 for c in commands)
    database, map_file = server_files
    graph.add(LocationServerNode(context=graph.context, parameter_overrides=[
        Parameter("database_file", value=str(database)), Parameter("map_file", value=str(map_file)),
        Parameter("k", value=1)]))

    def driving() -> bool:
        publish()
        return any(abs(c.angular.z) > 0.0 or c.linear.x > 0.0 for c in commands)
    graph.spin_until(driving, "the navigator to drive towards the landmark")
    assert "to_landmark" in feedback
    assert navigator.navigator.estimate().position == pytest.approx((1.0, 1.0))   # the server's answer (k = 1)
    assert navigator.navigator.waypoint.group_id == "G1"


def test_a_target_that_is_not_finite_is_refused(graph: Graph) -> None:
    graph.add(TwoTierNavigatorNode(context=graph.context))
    client = ActionClient(graph.probe, NavigateToPoint, "/navigate_to_point")
    graph.clients.append(client)
    graph.spin_until(client.server_is_ready, "the action server")
    goal = NavigateToPoint.Goal()
    goal.target.x = math.nan
    sent = client.send_goal_async(goal)
    graph.spin_until(sent.done, "the goal's answer")
    assert not sent.result().accepted


def test_given_a_localizers_pose_topic_tier_one_is_that_localizers_pose_and_not_the_location_servers_locate(
        graph: Graph, server_files: tuple[Path, Path]) -> None:
    database, map_file = server_files
    graph.add(LocationServerNode(context=graph.context, parameter_overrides=[
        Parameter("database_file", value=str(database)), Parameter("map_file", value=str(map_file)),
        Parameter("k", value=1)]))
    navigator = graph.add(TwoTierNavigatorNode(context=graph.context, parameter_overrides=[
        Parameter("tier_one_from", value="/fused/pose")]))
    publish = sensors(graph)
    pose_pub = graph.probe.create_publisher(PoseWithCovarianceStamped, "/fused/pose", SENSOR_QOS)
    commands = send_goal(graph, publish)
    # No pose yet: it waits for one standing still, though the location server could answer the scan.
    graph.spin_until(lambda: navigator.call is not None, "the navigator's tier-one request")
    publish()
    assert navigator.navigator.estimate().position is None and not commands
    pose = PoseWithCovarianceStamped()
    pose.header.frame_id = "map"
    pose.pose.pose.position.x, pose.pose.pose.position.y = 3.0, 1.5
    pose.pose.pose.orientation.w = 1.0
    pose.pose.covariance[0] = pose.pose.covariance[7] = 0.04

    def driving() -> bool:
        publish()
        pose_pub.publish(pose)
        return any(abs(c.angular.z) > 0.0 or c.linear.x > 0.0 for c in commands)
    graph.spin_until(driving, "the navigator to drive towards the landmark")
    fix = navigator.navigator.progress.fixes[0]
    assert fix.position == pytest.approx((3.0, 1.5)) and fix.sd_m == pytest.approx(0.2)   # not the server's (1, 1)
    assert navigator.navigator.waypoint.group_id == "G1"


def test_a_survey_and_a_navigation_exclude_each_other_and_the_survey_adds_scans_where_the_robot_believes(
        graph: Graph, tmp_path: Path) -> None:
    """Docked on G1 (a known start: a tag fix), the first scan after the survey starts is due at once and goes to
    the location server at the dock; a navigation goal meanwhile is refused; cancelled, the survey ends."""
    map_file = tmp_path / "home.yaml"
    map_file.write_text("name: home\ntag_groups:\n  - {id: G1, shape: cross, centre: [2.0, 1.0]}\n"
                        "  - {id: G2, shape: cross, centre: [6.0, 1.0]}\n")
    navigator = graph.add(TwoTierNavigatorNode(context=graph.context, parameter_overrides=[
        Parameter("map_file", value=str(map_file))]))
    server = graph.add(LocationServerNode(context=graph.context, parameter_overrides=[
        Parameter("database_file", value=str(tmp_path / "survey.db")), Parameter("create_database", value=True),
        Parameter("map_file", value=str(map_file))]))
    publish = sensors(graph)
    survey = ActionClient(graph.probe, Survey, "/survey")
    navigation = ActionClient(graph.probe, NavigateToPoint, "/navigate_to_point")
    graph.clients += [survey, navigation]
    graph.spin_until(lambda: survey.server_is_ready() and navigation.server_is_ready(), "both action servers")
    rejected = survey.send_goal_async(Survey.Goal(dock="G1", landmarks=["G9"]))
    graph.spin_until(rejected.done, "the bad survey's answer")
    assert not rejected.result().accepted
    graph.spin_until(lambda: graph.logged("two_tier_navigator", "no tag group 'G9' in the map"), "the refusal's log")
    sent = survey.send_goal_async(Survey.Goal(dock="G1", landmarks=[], spacing_m=0.5))
    graph.spin_until(sent.done, "the survey's acceptance")
    assert sent.result().accepted
    goal = NavigateToPoint.Goal()
    goal.target.x, goal.target.y = 6.0, 1.0
    refused = navigation.send_goal_async(goal)
    graph.spin_until(refused.done, "the navigation's answer")
    assert not refused.result().accepted
    graph.spin_until(lambda: graph.logged("two_tier_navigator", "a survey is running"), "the refusal's log")

    def added() -> bool:
        publish()
        return len(server.radio_map) > 0
    graph.spin_until(added, "a survey scan in the radio map")
    (fingerprint,) = server.radio_map.fingerprints
    assert fingerprint.position == pytest.approx((2.0, 1.0)) and fingerprint.source == "survey"
    assert dict(fingerprint.rss) == RSS
    assert navigator.survey_goals.running.leg.landmark == "G2"
    cancelled = sent.result().cancel_goal_async()
    graph.spin_until(cancelled.done, "the cancel's answer")
    result = sent.result().get_result_async()
    graph.spin_until(result.done, "the survey's result")
    assert result.result().result.fingerprints_added == 1 and result.result().result.landmarks_reached == 0
