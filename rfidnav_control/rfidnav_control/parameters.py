"""Parameters of the heading_controller and wall_follower nodes: typed, with defaults and descriptions, importable
without rclpy so the orchestrator and the in-process runner validate parameter files against the same class.

Defaults are the faithful paper-001 set; config/params/flc_paper.yaml repeats them and
config/params/flc_tuned.yaml is ours.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from rfidnav_common.config import (
    AT_LEAST_ONE,
    DURATION_S,
    FRACTION,
    MAX_DURATION_S,
    MAX_SPEED_MPS,
    PORT,
    POSITIVE,
    RATE_HZ,
    SPEED_MPS,
    YAW_RATE_RADPS,
    Limits,
    param,
)
from rfidnav_common.errors import ParameterError
from rfidnav_common.node_registry import CommandsSpeeds, NodeRegistration, ReadsAntennaPorts
from rfidnav_control.errors import FuzzySpecError
from rfidnav_control.fuzzy import FuzzyHeadingSpec
from rfidnav_control.tag_route import ARRIVAL_MODES, FollowerSettings
from rfidnav_control.wall_following import WallFollowerSettings

HALF_TURN_RAD = Limits(0.0, math.pi, low_open=True)


@dataclass(frozen=True)
class HeadingControllerParameters(ReadsAntennaPorts, CommandsSpeeds):
    map_file: str = param("route map YAML: the floor tag that marks arrival under each ceiling tag", "")
    forward_speed_mps: float = param("constant forward speed [m/s] (paper 001: 0.2)", 0.2, SPEED_MPS)
    left_antenna: int = param("reader port of the left receiving antenna (phi1)", 1, PORT)
    right_antenna: int = param("reader port of the right receiving antenna (phi2)", 2, PORT)
    floor_antenna: int = param("reader port of the downward antenna that reads floor tags", 3, PORT)
    phase_difference_offset_rad: float = param("calibration: phi1 - phi2 of a tag straight ahead [rad]", 0.0,
                                               Limits(-math.pi, math.pi))
    max_yaw_rate_radps: float = param("largest yaw rate commanded [rad/s]", 2.0, YAW_RATE_RADPS)
    nominal_round_s: float = param("expected time between inventory rounds [s]; bounds the measured one", 0.04,
                                   DURATION_S)
    unheard_timeout_s: float = param("without unheard_search: fail when the target is not heard for this long [s]; "
                                     "with or without it, stop when no inventory round arrives for this long",
                                     10.0, DURATION_S)
    filter_rounds: int = param("circular mean of the last N phase differences (1 = paper: latest only)", 1,
                               AT_LEAST_ONE)
    receding_detection: bool = param("turn when the phase-derived range to the target grows", True)
    receding_rate_mps: float = param("filtered range rate above which the target counts as receding [m/s]", 0.02,
                                     Limits(0.0, MAX_SPEED_MPS))
    range_rate_smoothing: float = param("weight of the newest round in the range-rate average (0, 1]", 0.2,
                                        Limits(0.0, 1.0, low_open=True))
    arrival: str = param("first_read (paper: first read of the floor tag) or closest_approach", "first_read",
                         Limits(choices=ARRIVAL_MODES))
    turn_speed_fraction: float = param("forward speed at the largest yaw rate, as a fraction (1 = constant)", 1.0,
                                       FRACTION)
    approach_speed_fraction: float = param(
        "forward speed once the target's floor tag is heard, as a fraction, so the robot can stop and turn over it "
        "(1 = constant)", 1.0, Limits(0.0, 1.0, low_open=True))
    unheard_search: bool = param(
        "search for a target unheard for search_after_s: a full turn on the spot, then an expanding square spiral "
        "(README \"Reach\"), failing only once it has all passed; false: the paper, straight on until "
        "unheard_timeout_s", True)
    search_after_s: float = param("unheard this long, straight on, before the search begins [s]", 1.0, DURATION_S)
    search_turn_rate_radps: float = param("yaw rate of the search's full turn and the spiral's quarter turns "
                                          "[rad/s]", 1.0, YAW_RATE_RADPS)
    search_spacing_m: float = param("distance between the search spiral's rings [m]; at most twice the reach "
                                    "leaves no gap", 3.0, Limits(0.1, 100.0))
    search_radius_m: float = param("the search spiral's rings reach this far from where the search began [m]", 6.0,
                                   Limits(0.1, 100.0))
    input_range_rad: float = param("universe of the input dphi: [-r, r] [rad]", 3.141592653589793, HALF_TURN_RAD)
    output_range_rad: float = param("universe of the output dtheta: [-r, r] [rad per round]", 0.1, HALF_TURN_RAD)
    input_set_names: list[str] = param("input fuzzy sets", ["neg", "zero", "pos"])
    input_set_points: list[float] = param(
        "4 trapezoid points a<=b<=c<=d per input set, concatenated [rad]",
        [-3.141592653589793, -3.141592653589793, -0.6, 0.0, -0.6, 0.0, 0.0, 0.6, 0.0, 0.6, 3.141592653589793,
         3.141592653589793])
    output_set_names: list[str] = param("output fuzzy sets", ["cw", "zero", "ccw"])
    output_set_points: list[float] = param(
        "4 trapezoid points per output set, concatenated [rad]",
        [-0.1, -0.1, -0.1, 0.0, -0.05, 0.0, 0.0, 0.05, 0.0, 0.1, 0.1, 0.1])
    rules: list[str] = param("rules 'input_set->output_set' (paper 001: neg->ccw, zero->zero, pos->cw)",
                             ["neg->ccw", "zero->zero", "pos->cw"])
    resolution: int = param("samples of each universe in the scikit-fuzzy reference", 2001, Limits(3, 1_000_000))

    def validate(self) -> None:
        if not self.map_file:
            raise ParameterError("map_file", "required (the route map of arrival floor tags)")
        self.follower_settings().validate()
        try:
            self.fuzzy_spec()
        except FuzzySpecError as error:
            # The spec's messages start with the parameter they concern ("rules: ..."), or with a set or a rule
            # ("fuzzy set 'neg': ..."), which no single parameter names.
            name, separator, problem = str(error).partition(": ")
            if separator and name in self.__dataclass_fields__:
                raise ParameterError(name, problem) from None
            raise ParameterError("", str(error)) from None

    def antenna_ports_read(self) -> dict[str, int]:
        """The reader ports this node takes reads of, by parameter: the reader must publish each of them."""
        return {"left_antenna": self.left_antenna, "right_antenna": self.right_antenna,
                "floor_antenna": self.floor_antenna}

    def commanded_speeds(self) -> dict[str, float]:
        """The forward speeds this node commands, by parameter: the base must be able to drive them."""
        return {"forward_speed_mps": self.forward_speed_mps}

    def follower_settings(self) -> FollowerSettings:
        # Every follower setting is a node parameter of the same name.
        return FollowerSettings(**{field.name: getattr(self, field.name)
                                   for field in dataclasses.fields(FollowerSettings)})

    def fuzzy_spec(self) -> FuzzyHeadingSpec:
        return FuzzyHeadingSpec.from_flat(
            self.input_range_rad, self.output_range_rad, self.input_set_names, self.input_set_points,
            self.output_set_names, self.output_set_points, self.rules, self.resolution)


_WALL = WallFollowerSettings()
SONAR_FIELDS = ("front", "front_left", "front_right", "left", "right")   # the follower's Sonar, in this order


@dataclass(frozen=True)
class WallFollowerParameters(CommandsSpeeds):
    """wall_follower (paper 004); config/params/wall_follower.yaml documents them. The follower's settings keep
    its names; the mounting offsets are those of paper 004's layout (rfidnav_sim.sonar_model.PAPER_LAYOUT)."""

    control_rate_hz: float = param("control steps per second [Hz, sim time]", 20.0, RATE_HZ)
    sonar_topics: list[str] = param("Range topics feeding the follower's front, front_left, front_right, left and "
                                    "right readings, in that order",
                                    ["sonar/front", "sonar/front_left_45", "sonar/front_right_45", "sonar/left",
                                     "sonar/right"])
    sonar_offsets_m: list[float] = param(
        "per sonar topic: its mounting position's component along its bearing, added to each reading so that "
        "ranges are from the robot's centre [m]", [0.175, 0.1945, 0.1945, 0.175, 0.175])
    sonar_timeout_s: float = param("stop (and warn) while any sonar has been silent this long [s, sim time]", 0.5,
                                   DURATION_S)
    recover_after_s: float = param("blocked this long, turn away on the spot (or back, in a dead end) [s]", 2.0,
                                   Limits(0.0, MAX_DURATION_S))
    wall_distance_m: float = param("set distance to the left wall [m] (paper 004: 0.8; tags read within 1 m)",
                                   _WALL.wall_distance_m, POSITIVE)
    speed_mps: float = param("forward speed [m/s]", _WALL.speed_mps, SPEED_MPS)
    realign_every_m: float = param("length of a measuring stretch (paper 004: every 1 m) [m]", _WALL.realign_every_m,
                                   POSITIVE)
    stop_distance_m: float = param("emergency stop when the front sonar reads closer [m]", _WALL.stop_distance_m,
                                   POSITIVE)
    diagonal_stop_distance_m: float = param("... or a diagonal one reads closer [m]", _WALL.diagonal_stop_distance_m,
                                            POSITIVE)
    opening_threshold_m: float = param("a side reading beyond this is an opening [m]", _WALL.opening_threshold_m,
                                       POSITIVE)
    junction_half_width_m: float = param("junction centre this far past an edge when no wall resumes [m]",
                                         _WALL.junction_half_width_m, POSITIVE)
    turn_rate_radps: float = param("largest yaw rate [rad/s]", _WALL.turn_rate_radps, YAW_RATE_RADPS)
    heading_gain_per_s: float = param("yaw rate per radian of heading error [1/s]", _WALL.heading_gain_per_s,
                                      POSITIVE)
    distance_gain: float = param("approach angle per metre of distance error [rad/m]", _WALL.distance_gain, POSITIVE)
    max_fit_residual_m: float = param("a stretch's ranges further off their fitted line are no straight wall [m]",
                                      _WALL.max_fit_residual_m, POSITIVE)
    sonar_half_angle_rad: float = param("side sonars' half cone [rad] (paper 004: 25 deg cones)",
                                        _WALL.sonar_half_angle_rad, Limits(0.0, math.pi / 4.0, high_open=True))

    def validate(self) -> None:
        if len(self.sonar_topics) != len(SONAR_FIELDS) or len(self.sonar_offsets_m) != len(SONAR_FIELDS):
            raise ParameterError("", f"sonar_topics and sonar_offsets_m: one each for {', '.join(SONAR_FIELDS)}, "
                                     f"got {len(self.sonar_topics)} and {len(self.sonar_offsets_m)}")
        self.settings().validate()

    def commanded_speeds(self) -> dict[str, float]:
        """The forward speeds this node commands, by parameter: the base must be able to drive them."""
        return {"speed_mps": self.speed_mps}

    def settings(self) -> WallFollowerSettings:
        names = {field.name for field in dataclasses.fields(WallFollowerSettings)} & set(self.__dataclass_fields__)
        return dataclasses.replace(_WALL, **{name: getattr(self, name) for name in names},
                                   recover_after_steps=round(self.recover_after_s * self.control_rate_hz))


# The node executables of this package, as the rfidnav.nodes entry points of its setup.py register them
# (rfidnav_common.node_registry), with the actions they serve as (name, type).
FOLLOW_TAG_ROUTE = ("/follow_tag_route", "rfidnav_msgs/action/FollowTagRoute")
HEADING_CONTROLLER = NodeRegistration(
    "heading_controller", HeadingControllerParameters, stepped=True, serves=(FOLLOW_TAG_ROUTE,))
WALL_FOLLOWER = NodeRegistration("wall_follower", WallFollowerParameters, stepped=True)
