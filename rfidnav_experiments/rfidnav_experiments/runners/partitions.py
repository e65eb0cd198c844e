"""In-process partition navigation (paper 000 section 6): the localizer, planner and navigator cores of the
DDS nodes driving an idealised robot, as the paper's simulation does, thousands of times a minute.

The robot is a point with a heading that drives straight at constant speed and turns on the spot exactly
as the navigator asks (paper 000 section 6.2 studies the imprecision of partitions, not of motors), at the
navigator node's forward speed and yaw-rate limit (:class:`RobotSpeeds`): the run's travel time charges
every turn, which its path length does not. Its
floor antenna reads at the centre or ``antenna_offset_m`` ahead of it, and sees every partition it
crosses: the simulation walks the antenna's path (a straight line when driving, an arc in 2-degree chords
when turning) partition boundary by partition boundary (:func:`rfidnav_common.tag_lattice.
partitions_along_segment`, exact geometry) and hands the localizer one round on entering each partition
and one every ``round_spacing_m`` of the antenna's path inside it (a reader's inventory rounds).
Odometry is the true motion, optionally with a relative error (``odometry_noise``), expressed in an odom
frame that starts at the start pose.

Only ground truth knows the start pose and the deployment's tags; the localizer sees tag IDs and odometry,
the navigator sees estimates, exactly as over DDS.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from rfidnav_common.tag_lattice import Coordinate, Deployment, StraightWalk, partitions_along_segment
from rfidnav_localization.partition import LocalizationEstimate, LocalizerSettings, PartitionLocalizer
from rfidnav_planning.parameters import PartitionNavigatorParameters
from rfidnav_planning.partition_navigation import FORWARD, ROTATE, Decision, NavigatorSettings, PartitionNavigator
from rfidnav_scenario.metrics import extra_time_cost_pct, travel_time_s

INSIDE_M = 1e-7                 # how far past a boundary the round on entering a partition is taken
TURN_CHORD_RAD = math.radians(2.0)
DEFAULT_ROUND_SPACING_M = 0.02  # at most this far between rounds (a reader's 25 Hz at 0.2 m/s: 8 mm)
# Steps of the first look ahead of a straight drive, doubled at each further look up to the most: a drive between
# two decisions takes a few dozen steps, and a look ahead costs about what its rows of lattice arithmetic do.
WALK_STEPS = 16
MAX_WALK_STEPS = 256


@dataclass(frozen=True)
class RobotSpeeds:
    """How fast the idealised robot drives and turns on the spot: the navigator node's ``forward_speed_mps`` and
    ``turn_rate_radps`` (the DDS node turns at that limit but for its last degrees, where it slows to stop on the
    target heading: not charged here)."""
    speed_mps: float
    turn_rate_radps: float

    @classmethod
    def of(cls, parameters: PartitionNavigatorParameters) -> RobotSpeeds:
        return cls(parameters.forward_speed_mps, parameters.turn_rate_radps)


NODE_DEFAULT_SPEEDS = RobotSpeeds.of(PartitionNavigatorParameters())


@dataclass(frozen=True)
class NavigationRun:
    success: bool
    message: str
    start: tuple[float, float]
    goal: tuple[float, float]
    path_length_m: float
    straight_distance_m: float
    turned_rad: float               # every turn's magnitude, summed
    speeds: RobotSpeeds
    final_position: tuple[float, float]
    replans: int
    partitions_entered: int
    trajectory: np.ndarray          # N x 2, the robot's true positions at each stop, turn and crossing

    @property
    def extra_cost_pct(self) -> float:
        """Paper 000 section 6.2: (l - |SD|) / |SD| in percent."""
        return 100.0 * (self.path_length_m - self.straight_distance_m) / self.straight_distance_m

    @property
    def travel_time_s(self) -> float:
        return travel_time_s(self.path_length_m, self.turned_rad, self.speeds.speed_mps, self.speeds.turn_rate_radps)

    @property
    def extra_time_cost_pct(self) -> float:
        """The extra cost in time, turns charged at the robot's turn rate (:func:`rfidnav_scenario.metrics.
        extra_time_cost_pct`)."""
        return extra_time_cost_pct(self.path_length_m, self.turned_rad, self.straight_distance_m,
                                   self.speeds.speed_mps, self.speeds.turn_rate_radps)

    @property
    def final_error_m(self) -> float:
        return math.dist(self.final_position, self.goal)

    @property
    def extra_cost_to_goal_pct(self) -> float:
        """The extra cost had the robot gone on from where it stopped straight to the goal point: both arrival
        rules stop short of the goal (in its partition, or within the tolerance), which the paper's cost
        counts as saved distance; this one does not."""
        return 100.0 * (self.path_length_m + self.final_error_m - self.straight_distance_m) / self.straight_distance_m


class IdealRobot:
    """True pose, odometry (relative to the start, with an optional relative error), distance driven, angle
    turned and the time both took."""

    def __init__(self, x: float, y: float, yaw: float, odometry_noise: float, rng: np.random.Generator,
                 speeds: RobotSpeeds, antenna_offset_m: float = 0.0) -> None:
        self.x, self.y, self.yaw = x, y, yaw
        self.antenna_offset_m = antenna_offset_m
        self.speeds = speeds
        self.start = (x, y, yaw)
        self.odom = [0.0, 0.0, 0.0]
        self.travelled_m = 0.0
        self.turned_rad = 0.0
        self.time_s = 0.0
        self.noise = odometry_noise
        self.rng = rng
        self.trajectory = [(x, y)]

    def drive(self, distance: float) -> None:
        self.x += distance * math.cos(self.yaw)
        self.y += distance * math.sin(self.yaw)
        self.travelled_m += distance
        self.time_s += distance / self.speeds.speed_mps
        measured = distance * (1.0 + self.noise * self.rng.standard_normal()) if self.noise else distance
        self.odom[0] += measured * math.cos(self.odom[2])
        self.odom[1] += measured * math.sin(self.odom[2])

    def turn(self, angle: float) -> None:
        self.yaw += angle
        self.turned_rad += abs(angle)
        self.time_s += abs(angle) / self.speeds.turn_rate_radps
        self.odom[2] += angle * (1.0 + self.noise * self.rng.standard_normal()) if self.noise else angle
        self.trajectory.append((self.x, self.y))

    def odometry(self) -> tuple[float, float, float]:
        return self.odom[0], self.odom[1], self.odom[2]

    def antenna(self, yaw: float | None = None) -> tuple[float, float]:
        yaw = self.yaw if yaw is None else yaw
        return self.x + self.antenna_offset_m * math.cos(yaw), self.y + self.antenna_offset_m * math.sin(yaw)


# Told of every round: the robot (truth and odometry), the tags read and the localizer's estimate from them.
RoundObserver = Callable[[IdealRobot, list[str], LocalizationEstimate], None]


class PartitionEstimator(Protocol):
    """What the navigator drives on: paper 000's PartitionLocalizer, or another localizer's estimate as the partition
    navigator takes it (runners.fused.FusedPartitions)."""

    def update(self, stamp_s: float, tag_ids: Sequence[str], odom: tuple[float, float, float]) \
            -> LocalizationEstimate: ...


class Rounds:
    """The floor antenna's inventory rounds, each fed to the localizer and its estimate to the navigator. It
    remembers where it last read, so a round after a step that crossed no read circle reuses that partition."""

    def __init__(self, deployment: Deployment, robot: IdealRobot, localizer: PartitionEstimator,
                 navigator: PartitionNavigator, observer: RoundObserver | None = None) -> None:
        self.deployment = deployment
        self.robot = robot
        self.localizer = localizer
        self.navigator = navigator
        self.observer = observer
        self.point: tuple[float, float] | None = None
        self.partition: frozenset[Coordinate] = frozenset()
        self._tag_ids: dict[Coordinate, str] = {}

    def __call__(self, unchanged_since: tuple[float, float] | None = None) -> Decision:
        """One round where the antenna is now; ``unchanged_since``: a point the antenna has come from in a straight
        line crossing no read circle (the partition there is the one here)."""
        antenna = self.robot.antenna()
        if unchanged_since is None or unchanged_since != self.point:
            self.partition = self.deployment.partition_at(*antenna)
        self.point = antenna
        tag_ids = [self._tag_id(c) for c in self.partition]
        estimate = self.localizer.update(self.robot.time_s, tag_ids, self.robot.odometry())
        if self.observer is not None:
            self.observer(self.robot, tag_ids, estimate)
        return self.navigator.on_estimate(estimate, self.robot.travelled_m)

    def _tag_id(self, coordinate: Coordinate) -> str:
        tag_id = self._tag_ids.get(coordinate)
        if tag_id is None:
            tag_id = self._tag_ids[coordinate] = self.deployment.lattice.tag_id(coordinate)
        return tag_id


def run_navigation(deployment: Deployment, start: tuple[float, float, float], goal: tuple[float, float],
                   localizer_settings: LocalizerSettings, navigator_settings: NavigatorSettings,
                   rng: np.random.Generator, round_spacing_m: float | None = None,
                   odometry_noise: float = 0.0, speeds: RobotSpeeds = NODE_DEFAULT_SPEEDS,
                   observer: RoundObserver | None = None, driving: PartitionEstimator | None = None) \
        -> NavigationRun:
    """One navigation from ``start`` (x, y, yaw; ground truth) to ``goal``; the antenna offset is the
    localizer's (the robot is built as the localizer believes), the speeds the navigator node's. ``observer`` is
    told of every round (it draws nothing). The navigator drives on paper 000's localizer with
    ``localizer_settings``, or on ``driving``."""
    robot = IdealRobot(*start, odometry_noise, rng, speeds, localizer_settings.antenna_offset_m)
    navigator = PartitionNavigator(navigator_settings, deployment.area)
    localizer = driving if driving is not None else PartitionLocalizer(localizer_settings, rng)
    observe = Rounds(deployment, robot, localizer, navigator, observer)
    spacing = round_spacing_m or min(deployment.read_range_m / 2.0, DEFAULT_ROUND_SPACING_M)
    decision = navigator.start(goal)
    decision = observe()
    while not decision.finished:
        if decision.motion.kind == ROTATE:
            turn_observing(deployment, robot, decision.motion.rotate_by_rad, observe)
            decision = navigator.rotation_done()
            if decision.motion.kind == FORWARD:
                decision = observe()      # the localizer sees the turn's end in the odometry
            continue
        assert decision.motion.kind == FORWARD
        decision = drive_until_decision(deployment, robot, spacing, observe)
    robot.trajectory.append((robot.x, robot.y))
    state = navigator.state
    return NavigationRun(decision.success, decision.message, (start[0], start[1]), goal, robot.travelled_m,
                         math.dist(start[:2], goal), robot.turned_rad, speeds, (robot.x, robot.y), state.replans,
                         state.partitions_entered, np.array(robot.trajectory))


def turn_observing(deployment: Deployment, robot: IdealRobot, angle: float, observe: Callable[[], Decision]) -> None:
    """Turn on the spot by ``angle``; an antenna off the axis crosses partitions on its arc, each observed
    (the navigator finishes the turn whatever it answers meanwhile)."""
    if robot.antenna_offset_m == 0.0:
        robot.turn(angle)
        return
    chords = max(1, math.ceil(abs(angle) / TURN_CHORD_RAD))
    step = angle / chords
    for _ in range(chords):
        start, end = robot.antenna(), robot.antenna(robot.yaw + step)
        pieces = partitions_along_segment(deployment, start, end)
        turned = 0.0
        for piece in pieces[1:]:
            robot.turn(piece.t_start * step - turned)   # the chord's parameter, as a fraction of the step
            turned = piece.t_start * step
            observe()
        robot.turn(step - turned)


def drive_until_decision(deployment: Deployment, robot: IdealRobot, spacing: float, observe: Rounds) -> Decision:
    """Drive straight, observing on entering each partition and every ``spacing`` inside one, until the
    navigator wants something other than driving on.

    Step by step as a reader's rounds come, each step's crossings found on that step's own segment, so that the
    walk does not depend on how far ahead it was looked at; the tags near the line ahead are found once for
    WALK_STEPS steps or more (:class:`StraightWalk`), and a step that passes no read circle is one round."""
    steps = WALK_STEPS
    while True:
        walk = StraightWalk(deployment, robot.antenna(), robot.yaw, spacing, steps)
        for step in range(steps):
            start = (robot.x, robot.y)
            antenna = robot.antenna()
            if walk.quiet(step):
                robot.drive(spacing)
                decision = observe(unchanged_since=antenna)
            else:
                end = (antenna[0] + spacing * math.cos(robot.yaw), antenna[1] + spacing * math.sin(robot.yaw))
                for piece in walk.pieces(antenna, end)[1:]:
                    robot.drive(piece.t_start * spacing + INSIDE_M - math.dist(start, (robot.x, robot.y)))
                    decision = observe()
                    if decision.motion.kind != FORWARD:
                        robot.trajectory.append((robot.x, robot.y))
                        return decision
                robot.drive(spacing - math.dist(start, (robot.x, robot.y)))
                decision = observe()
            if decision.motion.kind != FORWARD:
                robot.trajectory.append((robot.x, robot.y))
                return decision
        steps = min(2 * steps, MAX_WALK_STEPS)


def random_task(deployment: Deployment, distance_m: float, rng: np.random.Generator,
                margin_m: float = 0.0) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """A random start pose (position uniform in the area, heading uniform) and a goal ``distance_m`` away
    in a uniformly random direction, both inside the area (paper 000 section 6.2)."""
    x_min, y_min, x_max, y_max = deployment.area
    while True:
        sx, sy = rng.uniform(x_min + margin_m, x_max - margin_m), rng.uniform(y_min + margin_m, y_max - margin_m)
        bearing = rng.uniform(-math.pi, math.pi)
        gx, gy = sx + distance_m * math.cos(bearing), sy + distance_m * math.sin(bearing)
        if x_min + margin_m <= gx <= x_max - margin_m and y_min + margin_m <= gy <= y_max - margin_m:
            return (sx, sy, rng.uniform(-math.pi, math.pi)), (gx, gy)
