"""Parameters of the navigator nodes (partition_navigator, two_tier_navigator, mission_executor): typed, with
defaults and descriptions, importable without rclpy so the orchestrator and the in-process runner validate parameter
files against the same class. config/params/partition_navigator.yaml, two_tier_navigator.yaml and mission_executor.yaml
document them."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from rfidnav_common.config import (
    AT_LEAST_ONE,
    DURATION_S,
    PORT,
    POSITIVE,
    RATE_HZ,
    READ_RANGE_M,
    SPEED_MPS,
    YAW_RATE_RADPS,
    Limits,
    param,
)
from rfidnav_common.errors import ParameterError
from rfidnav_common.node_registry import CommandsSpeeds, NodeRegistration, ReadsAntennaPorts
from rfidnav_common.topological_map import WEIGHTS
from rfidnav_control.go_to import GoToSettings
from rfidnav_planning.partition_navigation import ARRIVALS, DEVIATION_CHECKS, NavigatorSettings, TurnSettings
from rfidnav_planning.pose_navigation import PoseNavigatorSettings
from rfidnav_planning.two_tier_navigation import TwoTierSettings

TIER_ONE_SERVER = "location_server"   # two_tier_navigator's tier_one_from: the paper's


@dataclass(frozen=True)
class PartitionNavigatorParameters(CommandsSpeeds):
    map_file: str = param("robot map YAML with the deployment_area (where the floor is tagged)", "")
    status_topic: str = param(
        "the LocalizationStatus it drives on: the partition localizer's, or the status_topic of the localizer the "
        "scenario names instead (rfid_localizer's, with the lattice tags it read)", "localization/status")
    approximation_level: int = param("partitions crossed in the localization phase (paper 000: 1-8)", 4,
                                     Limits(1, 64))
    localized_yaw_sd_rad: float = param(
        "also end the localization phase once the heading sd is below this [rad] (0 = paper: N partitions only)", 0.0,
        Limits(0.0, math.pi))
    max_path_factor: float = param("give up after driving this many times the first planned distance (+1 m)", 5.0,
                                   Limits(1.0, 1000.0, low_open=True))
    max_localization_m: float = param(
        "give up localizing after driving this far without a heading estimate [m] (a floor too small for N)", 10.0,
        POSITIVE)
    lost_distance_m: float = param("give up after driving this far without reading a floor tag [m]", 1.0, POSITIVE)
    max_replans: int = param("give up after this many re-plans", 500, Limits(0, 1_000_000))
    deviation_check: str = param(
        "when to re-plan: partition (paper 000: on entering a partition off the plan) or pose (ours: when the "
        "estimate would miss the goal by more than pose_miss_tolerance_r read ranges)", "partition",
        Limits(choices=DEVIATION_CHECKS))
    pose_miss_tolerance_r: float = param("pose check: the allowed miss, in read ranges", 0.25, POSITIVE)
    spin_quarter_turns: int = param(
        "ours: localize first by up to this many quarter turns on the spot (needs the antenna off the axis)", 0,
        Limits(0, 64))
    arrival: str = param("partition (paper 000: in the goal's partition) or position (ours: the estimate near the "
                         "goal)", "partition", Limits(choices=ARRIVALS))
    position_tolerance_r: float = param("position arrival: the estimate within this many read ranges of the goal",
                                        0.25, POSITIVE)
    forward_speed_mps: float = param("speed when driving straight [m/s]", 0.2, SPEED_MPS)
    turn_rate_radps: float = param("largest yaw rate when turning on the spot [rad/s]", 0.8, YAW_RATE_RADPS)
    turn_gain_per_s: float = param("yaw rate per radian still to turn, near the end of a turn [1/s]", 3.0, POSITIVE)
    turn_tolerance_rad: float = param("a turn is done when this close to its target heading [rad]", 0.005,
                                      Limits(0.0, math.pi, low_open=True))
    unheard_timeout_s: float = param("abort when no localization status arrives for this long [s]", 5.0, DURATION_S)

    def validate(self) -> None:
        if not self.map_file:
            raise ParameterError("map_file", "required (the map with the deployment_area)")
        self.settings().validate()

    def commanded_speeds(self) -> dict[str, float]:
        """The forward speeds this node commands, by parameter: the base must be able to drive them."""
        return {"forward_speed_mps": self.forward_speed_mps}

    def settings(self) -> NavigatorSettings:
        # Every navigator setting is a node parameter of the same name.
        return NavigatorSettings(**{field.name: getattr(self, field.name)
                                    for field in dataclasses.fields(NavigatorSettings)})

    def turn_settings(self) -> TurnSettings:
        return TurnSettings(self.turn_rate_radps, self.turn_gain_per_s, self.turn_tolerance_rad)


@dataclass(frozen=True)
class TwoTierNavigatorParameters(ReadsAntennaPorts, CommandsSpeeds):
    """two_tier_navigator (paper 003); config/params/two_tier_navigator.yaml documents them."""


    map_file: str = param("robot map: its walls and extent, when it has them (the tag map comes from the location "
                          "server); 'unused': none", "unused")
    floor_antenna: int = param("reader port of the HF floor antenna that reads the tag groups", 1, PORT)
    control_rate_hz: float = param("control steps per second [Hz, sim time]", 20.0, RATE_HZ)
    service_timeout_s: float = param("a location server call unanswered this long is sent again [s]", 2.0,
                                     DURATION_S)
    map_frame: str = param("frame of the published pose", "map")
    publish_tf: bool = param("publish map -> odom on /tf from each estimate with a heading (REP 105); turn it off "
                             "where another localizer's estimate drives the mission", True)
    tier_one_from: str = param(
        "tier one (A6, and A5's checks): 'location_server' (paper 003: its fingerprint locate of the latest scan), or "
        "ours, the topic of a localizer's pose to take instead (a PoseWithCovarianceStamped in map_frame, e.g. "
        "rfid_localizer's /fused/pose)", TIER_ONE_SERVER)
    landmark_spacing_m: float = param("geographic forwarding: the tolerable distance to the next landmark [m]", 4.0,
                                      POSITIVE)
    calibration_distance_m: float = param("A5: a tier-one check after driving this far without a fix [m]", 6.0,
                                          POSITIVE)
    deviation_threshold_m: float = param("A5: re-fix at a landmark when tier one disagrees by more than this [m]",
                                         2.0, POSITIVE)
    tag_map_radius_m: float = param("A1: the tag map downloaded around the tier-one estimate [m]", 30.0, POSITIVE)
    search_radius_sigmas: float = param("spiral search out to this many position standard deviations", 3.0,
                                        Limits(0.0, 100.0, low_open=True))
    search_min_radius_m: float = param("spiral search out to at least this radius [m]", 0.5, POSITIVE)
    max_searches: int = param("give up after this many spiral searches found nothing", 10, AT_LEAST_ONE)
    search_speed_mps: float = param("speed along the spiral [m/s]: slow enough that the polled HF reader reads "
                                    "every crossing of a tag line", 0.14, SPEED_MPS)
    read_range_m: float = param("the floor reader's range [m]: a tag fix is this good", 0.05, READ_RANGE_M)
    drift_per_m: float = param("dead reckoning: position sd growth per metre driven", 0.05, Limits(0.0, 1.0))
    wall_clearance_m: float = param("ours: legs are planned this far from the map's walls [m]", 0.30, POSITIVE)
    waypoint_tolerance_m: float = param("ours: a waypoint round a wall is passed within this [m]", 0.10, POSITIVE)
    search_wall_clearance_m: float = param(
        "ours: a spiral search ends when dead reckoning puts the robot this near a map wall or its extent's edge [m]",
        0.20, POSITIVE)
    stall_steps: int = param("ours: control steps commanding motion that the odometry does not follow before the "
                             "robot takes itself to be stalled at a wall", 10, AT_LEAST_ONE)
    back_off_m: float = param("ours: how far a stalled robot backs off before asking tier one where it is [m]", 0.25,
                              Limits(0.0, 10.0))
    max_stalls: int = param("ours: give up after stalling at a wall this many times", 10, AT_LEAST_ONE)
    speed_mps: float = param("driving speed [m/s]", 0.2, SPEED_MPS)
    turn_rate_radps: float = param("largest yaw rate [rad/s]", 0.8, YAW_RATE_RADPS)
    heading_gain_per_s: float = param("yaw rate per radian of heading error [1/s]", 2.0, POSITIVE)
    goal_tolerance_m: float = param("go-to: a waypoint or the target is reached within this [m]", 0.02, POSITIVE)

    def validate(self) -> None:
        if self.tier_one_from != TIER_ONE_SERVER and not self.tier_one_from.startswith("/"):
            raise ParameterError("tier_one_from", f"'{self.tier_one_from}' is neither {TIER_ONE_SERVER} nor a topic "
                                                  "(/...)")
        self.settings().validate()

    @property
    def tier_one_pose_topic(self) -> str | None:
        """The localizer's pose topic tier one comes from; None: the location server (paper 003)."""
        return None if self.tier_one_from == TIER_ONE_SERVER else self.tier_one_from

    def antenna_ports_read(self) -> dict[str, int]:
        """The reader ports this node takes reads of, by parameter: the reader must publish each of them."""
        return {"floor_antenna": self.floor_antenna}

    def commanded_speeds(self) -> dict[str, float]:
        """The forward speeds this node commands, by parameter: the base must be able to drive them."""
        return {"speed_mps": self.speed_mps, "search_speed_mps": self.search_speed_mps}

    def settings(self) -> TwoTierSettings:
        go_to = GoToSettings(speed_mps=self.speed_mps, turn_rate_radps=self.turn_rate_radps,
                             heading_gain_per_s=self.heading_gain_per_s, tolerance_m=self.goal_tolerance_m)
        names = {field.name for field in dataclasses.fields(TwoTierSettings)} - {"go_to"}
        return TwoTierSettings(**{name: getattr(self, name) for name in names}, go_to=go_to)


@dataclass(frozen=True)
class PoseNavigatorParameters(CommandsSpeeds):
    """pose_navigator (ours, issue 20): to a point on a localizer's pose; config/params/pose_navigator.yaml."""


    map_file: str = param("robot map: its walls and extent, when it has them; 'unused': none", "unused")
    pose_topic: str = param("the localizer's PoseWithCovarianceStamped (map frame) the robot drives on",
                            "localization/pose")
    map_frame: str = param("frame the poses must be in", "map")
    control_rate_hz: float = param("control steps per second [Hz, sim time]", 20.0, RATE_HZ)
    pose_timeout_s: float = param("a pose older than this is stale: the robot stands still [s]", 1.0, DURATION_S)
    max_position_sd_m: float = param("stand still while the pose's position sd exceeds this [m]", 0.30, POSITIVE)
    replan_jump_m: float = param("plan the way again when the pose moves this much between two steps [m]", 0.30,
                                 POSITIVE)
    wall_clearance_m: float = param("the way keeps this far from the map's walls [m]", 0.30, POSITIVE)
    waypoint_tolerance_m: float = param("a waypoint round a wall is passed within this [m]", 0.10, POSITIVE)
    speed_mps: float = param("driving speed [m/s]", 0.2, SPEED_MPS)
    turn_rate_radps: float = param("largest yaw rate [rad/s]", 0.8, YAW_RATE_RADPS)
    heading_gain_per_s: float = param("yaw rate per radian of heading error [1/s]", 2.0, POSITIVE)
    goal_tolerance_m: float = param("the target is reached within this [m]", 0.05, POSITIVE)

    def validate(self) -> None:
        self.settings().validate()

    def commanded_speeds(self) -> dict[str, float]:
        """The forward speeds this node commands, by parameter: the base must be able to drive them."""
        return {"speed_mps": self.speed_mps}

    def settings(self) -> PoseNavigatorSettings:
        go_to = GoToSettings(speed_mps=self.speed_mps, turn_rate_radps=self.turn_rate_radps,
                             heading_gain_per_s=self.heading_gain_per_s, tolerance_m=self.goal_tolerance_m)
        return PoseNavigatorSettings(go_to, self.wall_clearance_m, self.waypoint_tolerance_m, self.max_position_sd_m,
                                     self.replan_jump_m)


@dataclass(frozen=True)
class MissionExecutorParameters:
    """mission_executor (paper 004); config/params/mission_executor.yaml documents them."""


    map_file: str = param("topological map YAML (rfidnav_common.topological_map)", "")
    weight: str = param("routes: shortest by hallway lengths (length: length_m, else between positions, else 1 m) "
                        "or fewest hallways (edges)", "length", Limits(choices=WEIGHTS))
    recover_missed_tags: bool = param("ours: a junction passed without its tag is taken to be the node the route "
                                      "expected (false: the paper's loop, which follows on to the next tag)", True)

    def validate(self) -> None:
        if not self.map_file:
            raise ParameterError("map_file", "required (the topological map)")


# The node executables of this package, as the rfidnav.nodes entry points of its setup.py register them
# (rfidnav_common.node_registry), with the actions they serve as (name, type).
NAVIGATE_TO_POINT = ("/navigate_to_point", "rfidnav_msgs/action/NavigateToPoint")
NAVIGATE_TO_NODE = ("/navigate_to_node", "rfidnav_msgs/action/NavigateToNode")
SURVEY = ("/survey", "rfidnav_msgs/action/Survey")
PARTITION_NAVIGATOR = NodeRegistration(
    "partition_navigator", PartitionNavigatorParameters, stepped=True, serves=(NAVIGATE_TO_POINT,))
TWO_TIER_NAVIGATOR = NodeRegistration(
    "two_tier_navigator", TwoTierNavigatorParameters, stepped=True, serves=(NAVIGATE_TO_POINT, SURVEY))
POSE_NAVIGATOR = NodeRegistration("pose_navigator", PoseNavigatorParameters, stepped=True,
                                  serves=(NAVIGATE_TO_POINT,))
MISSION_EXECUTOR = NodeRegistration(
    "mission_executor", MissionExecutorParameters, stepped=True, serves=(NAVIGATE_TO_NODE,))
