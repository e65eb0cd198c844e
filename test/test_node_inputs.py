"""The fuzz set of the nodes' inputs: every input topic, service and action goal of every node of the simulated
graphs, fed extreme values (+-1e308, 1.7e308, NaN, +-inf, -0.0, the largest integers a field holds, empty arrays, a
wrong frame id, unknown tag ids), one case at a time, to one node that must stay up through all of its cases.

Each case states what the node does with it: DROP (counted in the node's ``drops`` for that input), CLAMP (counted
as clamped), ACCEPT (used, nothing counted), REFUSE (a service answers success false, a goal is rejected) or ANSWER
(a service answers). The node runs with the stepped clock, so a case is over when the node has handled its message
(its consumed count moves: no sleeps). At the end every float the node published is finite. create_base's
/cmd_vel cases are in test_create_base.py (it needs the fake Create).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import Imu, Range

from rfidnav_bringup.processes import NodeProcess
from rfidnav_common.geometry import yaw_to_quaternion
from rfidnav_common.goal_server import SingleGoalServer
from rfidnav_common.install import resolve_executable
from rfidnav_common.ros import COMMAND_QOS, SENSOR_QOS, time_msg
from rfidnav_common.stepped_node import STEPPED_CLOCK_PARAMETER
from rfidnav_control.heading_controller_node import HeadingControllerNode
from rfidnav_control.wall_follower_node import WallFollowerNode
from rfidnav_localization.fingerprint import Fingerprint
from rfidnav_localization.location_server_node import LocationServerNode
from rfidnav_localization.location_store import LocationStore
from rfidnav_localization.partition_localizer_node import PartitionLocalizerNode
from rfidnav_msgs.action import FollowTagRoute, NavigateToNode, NavigateToPoint, Survey
from rfidnav_msgs.msg import (
    AccessPointRss,
    LocalizationStatus,
    TagReadArray,
    TagReading,
    WallFollowerCommand,
    WallFollowerEvent,
    WifiScan,
)
from rfidnav_msgs.srv import AddFingerprint, GetTagMap, Locate
from rfidnav_planning.mission_executor_node import MissionExecutorNode
from rfidnav_planning.partition_navigator_node import PartitionNavigatorNode
from rfidnav_planning.two_tier_navigator_node import TwoTierNavigatorNode
from rfidnav_sim.compass_sim_node import CompassSimNode
from rfidnav_sim.rfid_reader_sim_node import RfidReaderSimNode
from rfidnav_sim.robot_sim_node import RobotSimNode
from rfidnav_sim.sonar_sim_node import SonarSimNode
from rfidnav_sim.wifi_sim_node import WifiSimNode
from support.graph import Graph
from support.runs import WORKSPACE

pytestmark = pytest.mark.tier("node")

DROP, CLAMP, ACCEPT, REFUSE, ANSWER = "drop", "clamp", "accept", "refuse", "answer"
NAN, INF = math.nan, math.inf
HUGE = (("1e308", 1e308), ("-1e308", -1e308), ("1.7e308", 1.7e308))
NON_FINITE = (("nan", NAN), ("inf", INF), ("-inf", -INF))
EXTREMES = HUGE + NON_FINITE
FLOAT32_HUGE = (("3.4e38", 3.4e38), ("-3.4e38", -3.4e38))    # a float32 field (Range.range) holds no more
UINT16_MAX, UINT32_MAX = 2 ** 16 - 1, 2 ** 32 - 1
CONFIG = WORKSPACE / "config"


# ------------------------------------------------------------------------------------------------ the table

@dataclass(frozen=True)
class Case:
    label: str
    mutate: Callable[[Any], None]
    expect: str


def setting(path: str, value: Any) -> Callable[[Any], None]:
    """Set the field at ``path`` (``readings[0].phase_rad``, ``pose.pose.position.x``) of a message."""
    steps = re.findall(r"[a-z_]+|\[\d+\]", path)

    def mutate(message: Any) -> None:
        target = message
        for step in steps[:-1]:
            target = target[int(step[1:-1])] if step.startswith("[") else getattr(target, step)
        last = steps[-1]
        if last.startswith("["):
            target[int(last[1:-1])] = value
        else:
            setattr(target, last, value)
    return mutate


def cases(path: str, values: tuple[tuple[str, Any], ...], expect: str) -> list[Case]:
    return [Case(f"{path}={label}", setting(path, value), expect) for label, value in values]


def numbers(path: str, huge: str = DROP, non_finite: str = DROP) -> list[Case]:
    """A float field at its extremes: +-1e308 and 1.7e308 (``huge``), NaN and +-inf (``non_finite``), -0.0."""
    return cases(path, HUGE, huge) + cases(path, NON_FINITE, non_finite) + cases(path, (("-0.0", -0.0),), ACCEPT)


def frames(path: str = "header.frame_id") -> list[Case]:
    return cases(path, (("''", ""), ("'elsewhere'", "elsewhere")), DROP)


def unchanged(_message: Any) -> None:
    """The good message itself: the node must still take it after everything before."""


GOOD = Case("good", unchanged, ACCEPT)


@dataclass
class TopicInput:
    topic: str
    make: Callable[[], Any]          # a good message
    cases: list[Case]
    qos: Any = field(default_factory=lambda: SENSOR_QOS)


@dataclass
class ServiceInput:
    name: str
    service: type
    make: Callable[[], Any]          # a good request
    cases: list[Case]


@dataclass
class GoalInput:
    action: str
    action_type: type
    make: Callable[[], Any]          # a good goal (accepted)
    cases: list[Case]


@dataclass
class NodeSpec:
    name: str
    make: Callable[[Graph, Path], Node]
    inputs: list[TopicInput | ServiceInput | GoalInput]
    outputs: list[tuple[str, type]] = field(default_factory=list)
    setup: Callable[[Graph, Node], Any] | None = None   # a goal running, so that inputs reach the core: its handle
    infinite_allowed: tuple[str, ...] = ()               # output fields where +-inf means something (REP 117)


# ------------------------------------------------------------------------------------------------ messages

def framed(message: Any, frame_id: str) -> Any:
    """``message`` with its header in ``frame_id``."""
    message.header.frame_id = frame_id
    return message


def odometry(frame_id: str = "odom", x: float = 0.5, y: float = 0.6, yaw: float = 0.3) -> Odometry:
    msg = framed(Odometry(child_frame_id="base_link"), frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
    q = msg.pose.pose.orientation
    q.x, q.y, q.z, q.w = yaw_to_quaternion(yaw)
    return msg


def odometry_cases() -> list[Case]:
    return (numbers("pose.pose.position.x") + numbers("pose.pose.position.y")
            + cases("pose.pose.orientation.z", HUGE + NON_FINITE, DROP)
            + [Case("orientation=0,0,0,0", lambda m: setattr(m.pose.pose.orientation, "w", 0.0), DROP)]
            + frames() + frames("child_frame_id") + [GOOD])


def read(tag_id: str, antenna: int, phase: float = 1.0) -> TagReading:
    return TagReading(tag_id=tag_id, antenna=antenna, rssi_dbm=-55.0, phase_rad=phase, i=math.cos(phase),
                      q=math.sin(phase), frequency_hz=915.25e6)


def reads(*readings: TagReading) -> TagReadArray:
    return framed(TagReadArray(readings=list(readings)), "base_link")


def read_cases(tag: str = "readings[0]", unknown_tag: str = "ZZ-UNKNOWN", one_port: bool = False,
               needs: tuple[str, ...] = (), stamp_as_time: bool = False) -> list[Case]:
    """What a read can carry: phases of any size are wrapped (no I/Q: the phase is taken), I/Q of any size give a
    phase; the rest has a physical range. NaN is "not reported" (the LLRP driver's convention): dropped by a node
    that ``needs`` that measurement, taken by the others. A node that reads ``one_port`` ignores a read of port 0
    as another's. A node that takes the round's stamp as time (``stamp_as_time``) drops a far one."""
    def unreported(name: str) -> str:
        return DROP if name in needs else ACCEPT

    no_iq = [Case(f"{tag}.phase_rad={label} (no I/Q)",
                  lambda m, value=value: (setting(f"{tag}.i", 0.0)(m), setting(f"{tag}.q", 0.0)(m),
                                          setting(f"{tag}.phase_rad", value)(m)), ACCEPT) for label, value in HUGE]
    no_phase = Case(f"{tag}.i/q/phase_rad=nan (not reported)",
                    lambda m: [setting(f"{tag}.{name}", NAN)(m) for name in ("i", "q", "phase_rad")],
                    unreported("phase_rad"))
    infinite = (("inf", INF), ("-inf", -INF))
    return (no_iq + [no_phase] + cases(f"{tag}.phase_rad", infinite, DROP)
            + cases(f"{tag}.phase_rad", (("nan (I/Q given)", NAN),), ACCEPT)
            + numbers(f"{tag}.i", huge=ACCEPT) + numbers(f"{tag}.q", huge=ACCEPT)
            + cases(f"{tag}.rssi_dbm", HUGE + infinite + (("+200", 200.0),), DROP)
            + cases(f"{tag}.rssi_dbm", (("nan", NAN),), unreported("rssi_dbm"))
            + cases(f"{tag}.frequency_hz", HUGE + infinite + (("0", 0.0), ("-915e6", -915e6)), DROP)
            + cases(f"{tag}.frequency_hz", (("nan", NAN),), unreported("frequency_hz"))
            + cases(f"{tag}.antenna", (("0", 0),), ACCEPT if one_port else DROP)
            + cases(f"{tag}.antenna", (("65535", UINT16_MAX),), ACCEPT)
            + cases(f"{tag}.tag_id", (("''", ""),), DROP) + cases(f"{tag}.tag_id", (("unknown", unknown_tag),), ACCEPT)
            + [Case("readings=[]", lambda m: setattr(m, "readings", []), ACCEPT)] + frames()
            + far_stamps(DROP if stamp_as_time else ACCEPT) + [GOOD])


def far_stamps(far: str = DROP) -> list[Case]:
    """A stamp from another era (2^31 - 1 s aborted a route, issue 34) or a minute and more off the node's clock
    (which the fuzzer keeps at each message's nominal stamp): dropped and counted by a node that takes it as time
    (``far``: ACCEPT for one that does not). A stamp within the minute is taken (a lagging graph)."""
    def shifted(seconds: float) -> Callable[[Any], None]:
        def mutate(message: Any) -> None:
            message.header.stamp = time_msg(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9 + seconds)
        return mutate
    return [Case("header.stamp=2^31-1 s", lambda m: setattr(m.header, "stamp", Time(sec=2 ** 31 - 1)), far),
            Case("header.stamp=+61 s", shifted(61.0), far),
            Case("header.stamp=+30 s", shifted(30.0), ACCEPT)]


def scan(frame_id: str = "base_link", rss: tuple[float, ...] = (-40.0, -60.0)) -> WifiScan:
    return framed(WifiScan(interface="fuzz", access_points=[
        AccessPointRss(bssid=f"02:00:00:00:00:0{i + 1}", channel=6, frequency_hz=2.437e9, rssi_dbm=value)
        for i, value in enumerate(rss)]), frame_id)


def scan_cases(taken: str) -> list[Case]:
    """A scan's fields: dropped (refused and counted by a service), or ``taken`` (ACCEPT on a topic, ANSWER by a
    service) where the node does not use the field."""
    return (cases("access_points[0].rssi_dbm", EXTREMES + (("+200", 200.0),), DROP)
            + cases("access_points[0].bssid", (("''", ""),), DROP)
            + cases("access_points[1].bssid", (("the first's", "02:00:00:00:00:01"),), DROP)   # one AP listed twice
            + cases("access_points[0].channel", (("65535", UINT16_MAX),), taken)
            + cases("access_points[0].frequency_hz", HUGE + NON_FINITE, taken)
            + cases("header.frame_id", (("''", ""), ("'map'", "map")), DROP))


def in_scan(scan_cases: list[Case]) -> list[Case]:
    """Cases of a scan applied to the scan of a service request."""
    return [Case(f"scan.{case.label}", lambda m, case=case: case.mutate(m.scan), case.expect) for case in scan_cases]


def compass(frame_id: str = "compass") -> Imu:
    msg = framed(Imu(), frame_id)
    q = msg.orientation
    q.x, q.y, q.z, q.w = yaw_to_quaternion(0.2)
    msg.orientation_covariance[8] = 0.01
    return msg


def status(frame_id: str = "map") -> LocalizationStatus:
    return framed(LocalizationStatus(method="paper", position_valid=True, x=0.5, y=0.6, orientation_valid=True,
                                     yaw_rad=0.0, yaw_lower_rad=-0.1, yaw_upper_rad=0.1, read_range_m=0.1), frame_id)


def follower_report(state: str = "following", event: str = "") -> WallFollowerEvent:
    msg = framed(WallFollowerEvent(event=event, state=state), "odom")
    msg.odom_pose.x, msg.odom_pose.y = 0.5, 0.5
    return msg


def twist(linear: float = 0.1, angular: float = 0.2) -> Twist:
    msg = Twist()
    msg.linear.x, msg.angular.z = linear, angular
    return msg


def target(x: float, y: float, tolerance_m: float = 0.0) -> NavigateToPoint.Goal:
    goal = NavigateToPoint.Goal(tolerance_m=tolerance_m)
    goal.target.x, goal.target.y = x, y
    return goal


def range_reading(name: str) -> Range:
    return framed(Range(radiation_type=Range.ULTRASOUND, min_range=0.02, max_range=5.0, range=1.0), f"sonar_{name}")


# ------------------------------------------------------------------------------------------------ the nodes

def stepped(**parameters: Any) -> list[Parameter]:
    return [Parameter(STEPPED_CLOCK_PARAMETER, value=True),
            *(Parameter(name, value=value) for name, value in parameters.items())]


def location_database(tmp_path: Path) -> Path:
    database = tmp_path / "site.db"
    with LocationStore.open(database, create=True) as store:
        store.add_fingerprints([Fingerprint((float(x), float(y)), {"02:00:00:00:00:01": -40.0 - 3 * x,
                                                                   "02:00:00:00:00:02": -60.0 + 2 * y}, "grid")
                                for x in range(4) for y in range(4)])
    return database


def home_map(tmp_path: Path) -> Path:
    path = tmp_path / "home.yaml"
    path.write_text("name: home\ntag_groups:\n  - {id: G1, shape: cross, centre: [2.0, 1.0]}\n")
    return path


def start_goal(action: str, action_type: type, goal: Any) -> Callable[[Graph, Node], Any]:
    """A setup that starts ``goal`` and returns its handle."""
    def setup(graph: Graph, _node: Node) -> Any:
        client = ActionClient(graph.probe, action_type, action)
        graph.clients.append(client)
        graph.spin_until(client.server_is_ready, f"{action}'s server")
        sent = client.send_goal_async(goal)
        graph.spin_until(sent.done, f"the answer to the goal on {action}")
        assert sent.result().accepted, f"the setup goal on {action} was rejected"
        return sent.result()
    return setup


def goal_cases(path_values: list[tuple[str, tuple[tuple[str, Any], ...], str]]) -> list[Case]:
    return [case for path, values, expect in path_values for case in cases(path, values, expect)]


POINT_GOAL_CASES = goal_cases([("target.x", EXTREMES, REFUSE), ("target.y", EXTREMES, REFUSE)])
POINT_GOAL_TAKEN = goal_cases([("target.x", (("-0.0", -0.0),), ACCEPT)])     # last: one goal at a time
# The robot's survey (two_tier_navigator's /survey): a spacing that is no positive distance, a landmark the map
# does not have; 0 takes the default spacing, 1e308 is a survey that never scans.
SURVEY_GOAL_CASES = goal_cases([("spacing_m", NON_FINITE + (("-1e308", -1e308), ("-0.5", -0.5)), REFUSE),
                                ("spacing_m", (("0 (the default)", 0.0), ("1e308", 1e308)), ACCEPT)]) + [
    Case("dock=ZZ", setting("dock", "ZZ"), REFUSE),
    Case("landmarks=[ZZ]", setting("landmarks", ["ZZ"]), REFUSE),
    Case("landmarks=['']", setting("landmarks", [""]), REFUSE),
    Case("landmarks=[T1] (only the dock)", setting("landmarks", ["T1"]), ACCEPT)]

SPECS = [
    NodeSpec("heading_controller", lambda graph, _tmp: HeadingControllerNode(
        context=graph.context, parameter_overrides=stepped(map_file=str(CONFIG / "maps/line_follow.yaml"))),
        [TopicInput("/rfid/reads", lambda: reads(read("C1", 1, 1.2), read("C1", 2, 1.0)),
                    read_cases(needs=("phase_rad", "frequency_hz"), stamp_as_time=True)),
         GoalInput("/follow_tag_route", FollowTagRoute, lambda: FollowTagRoute.Goal(tag_ids=["C1"]), [
             Case("tag_ids=[]", setting("tag_ids", []), REFUSE),
             Case("tag_ids=[unknown]", setting("tag_ids", ["ZZ"]), REFUSE),
             Case("tag_ids=['']", setting("tag_ids", [""]), REFUSE)])],
        [("/cmd_vel", Twist)],
        setup=start_goal("/follow_tag_route", FollowTagRoute, FollowTagRoute.Goal(tag_ids=["C1", "C2"]))),
    NodeSpec("partition_localizer", lambda graph, _tmp: PartitionLocalizerNode(
        context=graph.context, parameter_overrides=stepped()),
        [TopicInput("/odom", odometry, odometry_cases()),
         TopicInput("/rfid/reads", lambda: reads(read("ZZ", 1), read("ZZ", 1)),
                    read_cases(one_port=True, stamp_as_time=True))],
        [("/localization/pose", PoseWithCovarianceStamped), ("/localization/status", LocalizationStatus)]),
    NodeSpec("partition_navigator", lambda graph, _tmp: PartitionNavigatorNode(
        context=graph.context, parameter_overrides=stepped(map_file=str(CONFIG / "maps/partition_field.yaml"),
                                                           unheard_timeout_s=600.0)),
        [TopicInput("/odom", odometry, odometry_cases()),
         TopicInput("/localization/status", status,
                    numbers("x") + numbers("y") + numbers("yaw_rad") + numbers("yaw_lower_rad")
                    + numbers("yaw_upper_rad") + numbers("read_range_m")
                    + cases("partitions_traversed", (("4294967295", UINT32_MAX),), ACCEPT)
                    + cases("partition_tag_ids", (("[unknown]", ["ZZ"]),), ACCEPT) + frames() + far_stamps()
                    + [GOOD]),
         GoalInput("/navigate_to_point", NavigateToPoint, lambda: target(2.0, 1.3),
                   POINT_GOAL_CASES + goal_cases([("tolerance_m", EXTREMES + (("-1", -1.0),), REFUSE)])
                   + POINT_GOAL_TAKEN)],
        [("/cmd_vel", Twist)],
        setup=start_goal("/navigate_to_point", NavigateToPoint, target(2.0, 1.3))),
    NodeSpec("two_tier_navigator", lambda graph, _tmp: TwoTierNavigatorNode(
        context=graph.context, parameter_overrides=stepped(map_file=str(CONFIG / "maps/two_tier_home.yaml"))),
        [TopicInput("/odom", odometry, odometry_cases()),
         TopicInput("/compass", compass,
                    cases("orientation.w", EXTREMES + (("0 (all zero)", 0.0),), DROP)
                    + [Case("orientation=0,0,0,0", lambda m: (setattr(m.orientation, "z", 0.0),
                                                              setattr(m.orientation, "w", 0.0)), DROP)]
                    + cases("orientation_covariance[8]", EXTREMES, ACCEPT)
                    + cases("header.frame_id", (("base_link", "base_link"),), ACCEPT) + frames() + [GOOD]),
         TopicInput("/rfid/reads", lambda: reads(read("ZZ", 1)), read_cases(one_port=True)),
         TopicInput("/wifi/scan", scan, scan_cases(ACCEPT) + [
             Case("access_points=[]", lambda m: setattr(m, "access_points", []), ACCEPT), GOOD]),
         GoalInput("/navigate_to_point", NavigateToPoint, lambda: target(2.0, 1.0),
                   POINT_GOAL_CASES + POINT_GOAL_TAKEN),
         GoalInput("/survey", Survey, lambda: Survey.Goal(dock="T1", spacing_m=0.5), SURVEY_GOAL_CASES)],
        [("/cmd_vel", Twist), ("/localization/pose", PoseWithCovarianceStamped),
         ("/localization/status", LocalizationStatus)],
        setup=start_goal("/navigate_to_point", NavigateToPoint, target(2.0, 1.0))),
    NodeSpec("mission_executor", lambda graph, _tmp: MissionExecutorNode(
        context=graph.context, parameter_overrides=stepped(map_file=str(CONFIG / "maps/building_fig5.yaml"))),
        [TopicInput("/rfid/reads", lambda: reads(read("ZZ", 1)), read_cases(), COMMAND_QOS),
         TopicInput("/wall_follower/event", lambda: follower_report(event="junction_entered"),
                    numbers("odom_pose.x") + numbers("odom_pose.y") + frames()
                    + cases("event", (("unknown", "sideways"),), ACCEPT) + [GOOD], COMMAND_QOS),
         TopicInput("/wall_follower/state", follower_report,
                    numbers("odom_pose.x") + numbers("odom_pose.y") + frames() + [GOOD], COMMAND_QOS),
         GoalInput("/navigate_to_node", NavigateToNode, lambda: NavigateToNode.Goal(goal_node="g"), [
             Case("goal_node=unknown", setting("goal_node", "nowhere"), REFUSE),
             Case("goal_node=''", setting("goal_node", ""), REFUSE)])],
        [("/wall_follower/command", WallFollowerCommand)],
        setup=start_goal("/navigate_to_node", NavigateToNode, NavigateToNode.Goal(goal_node="g"))),
    NodeSpec("wall_follower", lambda graph, _tmp: WallFollowerNode(
        context=graph.context, parameter_overrides=stepped()),
        [TopicInput("/odom", odometry, odometry_cases()),
         *(TopicInput(f"/sonar/{name}", lambda name=name: range_reading(name),
                      cases("range", FLOAT32_HUGE + (("nan", NAN), ("-1", -1.0)), DROP)
                      + cases("range", (("inf", INF), ("-inf", -INF), ("-0.0", -0.0)), ACCEPT)
                      + frames() + [GOOD])
           for name in ("front", "front_left_45", "front_right_45", "left", "right")),
         TopicInput("/wall_follower/command", lambda: WallFollowerCommand(action="follow"),
                    [Case("action=unknown", setting("action", "sideways"), DROP),
                     Case("action=''", setting("action", ""), DROP), GOOD]
                    + [Case(f"stop_within_m={label}", lambda m, value=value: (
                        setattr(m, "action", "stop"), setattr(m, "stop_within_m", value)), DROP)
                       for label, value in EXTREMES + (("-1", -1.0),)], COMMAND_QOS)],
        [("/cmd_vel", Twist), ("/wall_follower/event", WallFollowerEvent),
         ("/wall_follower/state", WallFollowerEvent)]),
    NodeSpec("location_server", lambda graph, tmp: LocationServerNode(
        context=graph.context, parameter_overrides=stepped(database_file=str(location_database(tmp)),
                                                           map_file=str(home_map(tmp)), k=1)),
        [ServiceInput("/location_server/locate", Locate, lambda: Locate.Request(scan=scan()),
                      in_scan(scan_cases(ANSWER)) + [
            Case("access_points=[]", lambda m: setattr(m.scan, "access_points", []), REFUSE),
            Case("every bssid unknown", lambda m: [setattr(ap, "bssid", "aa:aa:aa:aa:aa:aa")
                                                   for ap in m.scan.access_points], REFUSE)]),
         ServiceInput("/location_server/tag_map", GetTagMap, lambda: GetTagMap.Request(x=2.0, y=1.0, radius_m=0.5),
                      [*cases("x", EXTREMES, DROP), *cases("y", EXTREMES, DROP),
                       *cases("radius_m", EXTREMES + (("0", 0.0), ("-1", -1.0)), DROP)]),
         ServiceInput("/location_server/add_fingerprint", AddFingerprint,
                      lambda: AddFingerprint.Request(x=1.5, y=1.5, source="survey", scan=scan()),
                      [*cases("x", EXTREMES + (("1e5 (off the map)", 1e5), ("-20 (off the map)", -20.0)), DROP),
                       *cases("y", EXTREMES, DROP), *cases("source", (("unknown", "guess"),), DROP),
                       Case("access_points=[]", lambda m: setattr(m.scan, "access_points", []), DROP),
                       *in_scan(scan_cases(ANSWER))])]),
    NodeSpec("robot_sim", lambda graph, _tmp: RobotSimNode(
        context=graph.context, parameter_overrides=stepped(world_file=str(CONFIG / "worlds/line_follow.yaml"),
                                                           start_paused=True)),
        [TopicInput("/cmd_vel", twist, numbers("linear.x", huge=CLAMP) + numbers("angular.z", huge=CLAMP)
                    + cases("linear.x", (("0.6 (beyond 0.5)", 0.6),), CLAMP) + [GOOD], COMMAND_QOS)]),
    NodeSpec("rfid_reader_sim", lambda graph, _tmp: RfidReaderSimNode(
        context=graph.context, parameter_overrides=stepped(world_file=str(CONFIG / "worlds/line_follow.yaml"))),
        [TopicInput("/sim/ground_truth", lambda: odometry("map"), odometry_cases())], [("/rfid/reads", TagReadArray)]),
    NodeSpec("compass_sim", lambda graph, _tmp: CompassSimNode(context=graph.context, parameter_overrides=stepped()),
             [TopicInput("/sim/ground_truth", lambda: odometry("map"), odometry_cases())], [("/compass", Imu)]),
    NodeSpec("sonar_sim", lambda graph, _tmp: SonarSimNode(
        context=graph.context, parameter_overrides=stepped(world_file=str(CONFIG / "worlds/building_fig5.yaml"))),
        [TopicInput("/sim/ground_truth", lambda: odometry("map"), odometry_cases())], [("/sonar/front", Range)],
        infinite_allowed=(".range",)),     # no echo (+inf) or closer than the minimum (-inf), REP 117
    NodeSpec("wifi_sim", lambda graph, _tmp: WifiSimNode(
        context=graph.context, parameter_overrides=stepped(world_file=str(CONFIG / "worlds/two_tier_home.yaml"))),
        [TopicInput("/sim/ground_truth", lambda: odometry("map"), odometry_cases())], [("/wifi/scan", WifiScan)]),
]


def case_count() -> int:
    return sum(len(spec_input.cases) for spec in SPECS for spec_input in spec.inputs)


# ------------------------------------------------------------------------------------------------ running it

def floats(message: Any, where: str = "") -> list[tuple[str, float]]:
    """Every float in a message, with its path."""
    found: list[tuple[str, float]] = []
    if isinstance(message, float):
        return [(where, message)]
    if isinstance(message, (list, tuple)) or type(message).__name__ == "array":
        for index, item in enumerate(message):
            found += floats(item, f"{where}[{index}]")
        return found
    if hasattr(message, "get_fields_and_field_types"):
        for name in message.get_fields_and_field_types():
            found += floats(getattr(message, name), f"{where}.{name}")
    return found


class Fuzzer:
    def __init__(self, graph: Graph, spec: NodeSpec, tmp_path: Path) -> None:
        self.graph, self.spec = graph, spec
        self.node = graph.add(spec.make(graph, tmp_path))
        self.outputs: list[tuple[str, Any]] = []
        for topic, message_type in spec.outputs:
            graph.probe.create_subscription(message_type, topic,
                                            lambda m, topic=topic: self.outputs.append((topic, m)), COMMAND_QOS)
        self.stamp_s = 1.0
        self.failures: list[str] = []
        self.setup_goal: Any = None
        self.set_up = spec.setup is None

    def run(self) -> int:
        for spec_input in self.spec.inputs:
            if isinstance(spec_input, TopicInput):
                self.topic(spec_input)
            elif isinstance(spec_input, ServiceInput):
                self.service(spec_input)
            else:
                self.goal(spec_input)
        return sum(len(spec_input.cases) for spec_input in self.spec.inputs)

    def counts(self, where: str) -> tuple[int, int]:
        return self.node.drops.dropped(where), self.node.drops.clamped(where)

    def check(self, where: str, case: Case, before: tuple[int, int], refused: bool | None = None) -> None:
        """DROP: counted (and, by a service, refused); CLAMP: counted as clamped; ACCEPT: nothing counted;
        REFUSE: a service refused it; ANSWER: a service answered it."""
        dropped, clamped = (now - then for now, then in zip(self.counts(where), before))
        got = {DROP: dropped > 0 and not clamped and refused is not False, CLAMP: clamped > 0 and not dropped,
               ACCEPT: not dropped and not clamped, REFUSE: bool(refused),
               ANSWER: refused is False and not dropped}[case.expect]
        if not got:
            self.failures.append(f"{self.spec.name} {where} {case.label}: expected {case.expect}, got "
                                 f"{dropped} dropped, {clamped} clamped" + ("" if refused is None else
                                                                            f", refused {refused}"))

    def topic(self, spec_input: TopicInput) -> None:
        publisher = self.graph.probe.create_publisher(type(spec_input.make()), spec_input.topic, spec_input.qos)
        resolved = self.node.resolve_topic_name(spec_input.topic)
        self.graph.spin_until(lambda: publisher.get_subscription_count() > 0, f"{self.spec.name} on {resolved}")
        if not self.set_up and self.spec.setup is not None:
            self.setup_goal, self.set_up = self.spec.setup(self.graph, self.node), True
        for case in spec_input.cases:
            message = spec_input.make()
            if hasattr(message, "header"):
                self.stamp_s += 0.05
                message.header.stamp = time_msg(self.stamp_s)
                self.node.advance_time(round(self.stamp_s * 1e9))     # the node's clock at the nominal stamp
            case.mutate(message)
            before, handled = self.counts(spec_input.topic), self.node.consumed_counts[resolved]
            publisher.publish(message)
            self.graph.spin_until(lambda handled=handled: self.node.consumed_counts[resolved] > handled,
                                  f"{self.spec.name} to handle {spec_input.topic} {case.label}")
            self.check(spec_input.topic, case, before)
            self.stamp_s = max(self.stamp_s, self.node.sim_time_ns * 1e-9)    # a stamp taken moved the clock on

    def service(self, spec_input: ServiceInput) -> None:
        client = self.graph.probe.create_client(spec_input.service, spec_input.name)
        self.graph.spin_until(client.service_is_ready, f"{spec_input.name} to be ready")
        good = self.call(client, spec_input.make())
        assert good.success, f"{spec_input.name}: the good request failed: {good.message}"
        for case in spec_input.cases:
            request = spec_input.make()
            case.mutate(request)
            before = self.counts(spec_input.name)
            answer = self.call(client, request)
            self.check(spec_input.name, case, before, refused=not answer.success)
            if not answer.success and not answer.message:
                self.failures.append(f"{self.spec.name} {spec_input.name} {case.label}: refused without a reason")
            self.outputs.append((spec_input.name, answer))

    def call(self, client: Any, request: Any) -> Any:
        future = client.call_async(request)
        self.graph.spin_until(future.done, f"the answer of {client.srv_name}")
        return future.result()

    def goal(self, spec_input: GoalInput) -> None:
        client = ActionClient(self.graph.probe, spec_input.action_type, spec_input.action)
        self.graph.clients.append(client)
        self.graph.spin_until(client.server_is_ready, f"{spec_input.action}'s server")
        if self.setup_goal is not None:        # one goal at a time: the setup's would make every goal "busy"
            self.cancel(self.setup_goal, "the setup goal")
        for case in spec_input.cases:
            goal = spec_input.make()
            case.mutate(goal)
            sent = client.send_goal_async(goal)
            self.graph.spin_until(sent.done, f"the answer to {spec_input.action} {case.label}")
            accepted = sent.result().accepted
            if accepted != (case.expect == ACCEPT):
                self.failures.append(f"{self.spec.name} {spec_input.action} {case.label}: "
                                     f"{'accepted' if accepted else 'rejected'}, expected {case.expect}")
            if accepted:
                self.cancel(sent.result(), f"{spec_input.action} {case.label}")

    def cancel(self, handle: Any, what: str) -> None:
        """Cancel a goal and wait for its end: the stepped node supervises on its sim time, moved on here."""
        cancel = handle.cancel_goal_async()

        def ended() -> bool:
            self.stamp_s += 0.1
            self.node.advance_time(round(self.stamp_s * 1e9))
            return cancel.done() and all(server.active is None for server in vars(self.node).values()
                                         if isinstance(server, SingleGoalServer))
        self.graph.spin_until(ended, f"the cancel of {what}")


@pytest.mark.parametrize("spec", SPECS, ids=[spec.name for spec in SPECS])
def test_every_input_of_the_node_at_its_extremes_is_dropped_clamped_or_refused_and_the_node_stays_up(
        graph: Graph, tmp_path: Path, spec: NodeSpec) -> None:
    fuzzer = Fuzzer(graph, spec, tmp_path)
    ran = fuzzer.run()
    assert ran >= 10 and not fuzzer.failures, "\n".join(fuzzer.failures)
    # Still up and still serving: the rclpy node answers, its last good inputs were taken (GOOD cases above).
    assert fuzzer.node.context.ok()
    bad = [f"{topic}{path} = {value}" for topic, message in fuzzer.outputs for path, value in floats(message)
           if not (math.isfinite(value) or (math.isinf(value) and path in spec.infinite_allowed))]
    assert not bad, f"{spec.name} published non-finite values: {bad[:10]}"


def test_the_fuzz_set_covers_every_node_of_the_simulated_graphs() -> None:
    assert {spec.name for spec in SPECS} == {
        "heading_controller", "partition_localizer", "partition_navigator", "two_tier_navigator", "mission_executor",
        "wall_follower", "location_server", "robot_sim", "rfid_reader_sim", "compass_sim", "sonar_sim", "wifi_sim"}
    assert case_count() >= 400, case_count()


# ------------------------------------------------------------------------------------------------ across processes

@pytest.mark.tier("graph")
def test_the_inputs_that_crashed_nodes_leave_their_processes_up_over_dds(graph: Graph, domain: int,
                                                                         tmp_path: Path) -> None:
    """Issue 17's crashes, each node in a process of its own: phases of +-1e308 to heading_controller, a /cmd_vel of
    1.7e308 to robot_sim (its pose turned NaN for good), an /odom of 1e308 to two_tier_navigator."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", PYTHONUNBUFFERED="1",
               RCUTILS_COLORIZED_OUTPUT="0")
    processes = [
        NodeProcess("heading_controller", resolve_executable("rfidnav_control", "heading_controller") + [
            "--ros-args", "-p", f"map_file:={CONFIG / 'maps/line_follow.yaml'}"], tmp_path / "controller.log", env),
        NodeProcess("robot_sim", resolve_executable("rfidnav_sim", "robot_sim") + [
            "--ros-args", "-p", f"world_file:={CONFIG / 'worlds/line_follow.yaml'}", "-p", "rtf:=5.0"],
            tmp_path / "robot_sim.log", env),
        NodeProcess("two_tier_navigator", resolve_executable("rfidnav_planning", "two_tier_navigator"),
                    tmp_path / "navigator.log", env)]
    probe = graph.probe
    reads_pub = probe.create_publisher(TagReadArray, "/rfid/reads", SENSOR_QOS)
    cmd_pub = probe.create_publisher(Twist, "/cmd_vel", COMMAND_QOS)
    odom_pub = probe.create_publisher(Odometry, "/odom", SENSOR_QOS)
    commands: list[Twist] = []
    truth: list[Odometry] = []
    probe.create_subscription(Twist, "/cmd_vel", commands.append, COMMAND_QOS)
    probe.create_subscription(Odometry, "/sim/ground_truth", truth.append, SENSOR_QOS)
    route = ActionClient(probe, FollowTagRoute, "/follow_tag_route")
    navigation = ActionClient(probe, NavigateToPoint, "/navigate_to_point")
    graph.clients += [route, navigation]
    try:
        for process in processes:
            process.start()
        graph.spin_until(lambda: route.server_is_ready() and navigation.server_is_ready() and bool(truth)
                         and reads_pub.get_subscription_count() >= 2 and cmd_pub.get_subscription_count() >= 1
                         and odom_pub.get_subscription_count() >= 1, "the three nodes' topics and actions", 60.0)
        sent = route.send_goal_async(FollowTagRoute.Goal(tag_ids=["C1"]))
        graph.spin_until(sent.done, "the route goal's answer", 30.0)
        assert sent.result().accepted
        for huge in (1e308, -1e308, 1.7e308):
            message = reads(read("C1", 1), read("C1", 2))
            for reading in message.readings:
                reading.i = reading.q = 0.0
                reading.phase_rad = huge
            before = len(commands)
            reads_pub.publish(message)
            graph.spin_until(lambda before=before: len(commands) > before, f"the controller's answer to {huge}", 30.0)
        cmd_pub.publish(twist(1.7e308, 1.7e308))
        odom_pub.publish(odometry(x=1e308, y=1e308))
        count = len(truth)
        graph.spin_until(lambda: len(truth) > count + 25, "half a second more of ground truth", 30.0)
        assert all(process.running for process in processes), [
            (process.role, process.poll(), process.log_path.read_text()[-2000:]) for process in processes]
        assert all(math.isfinite(v) for c in commands for v in (c.linear.x, c.angular.z))
        pose = truth[-1].pose.pose.position
        assert math.isfinite(pose.x) and math.isfinite(pose.y) and math.hypot(pose.x, pose.y) < 5.0
        for process, words in ((processes[1], "/cmd_vel: clamped"), (processes[2], "/odom: dropped")):
            graph.spin_until(lambda process=process, words=words: words in process.log_path.read_text(),
                             f"{process.role}'s warning", 30.0)
    finally:
        for process in processes:
            process.stop(5.0)
