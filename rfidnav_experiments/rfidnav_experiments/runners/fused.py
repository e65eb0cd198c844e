"""The fused localizer (rfidnav_localization.fused) run beside a paper's own localizer on the same runs: it sees
what the robot's sensors give in each step (the runner's ``observe`` hook), never the truth, and is scored
against the truth together with the paper's estimate (pure, in-process).

Each reader round is one update, built as the rfid_localizer node builds it (``round_evidence``): the round's reads
of every antenna, the compass's latest heading and the location server's latest answer. Several localizers may
ride on one run (:class:`Rider`): the fused one with every kind of evidence, the same filter restricted to one
kind (a single-evidence localizer), one that starts with no idea where the robot is (global localization), one
that is kidnapped (told, confidently, that the robot stands elsewhere, as a wrong /initialpose would).

Per round: the position and heading errors, and the normalised estimation error squared (NEES) of the pose
against the estimate's own covariance -- (x, y, yaw) for the fused filter, (x, y) with the paper's isotropic sd for
the two-tier dead reckoning, whose heading is the compass's and has no sd.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field

import numpy as np
from builtin_interfaces.msg import Time

from rfidnav_common.frames import MAP_FRAME, compose
from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Coordinate
from rfidnav_experiments.runners.partitions import IdealRobot
from rfidnav_experiments.runners.tag_route import RouteRound
from rfidnav_experiments.runners.topological import MissionStep
from rfidnav_experiments.runners.two_tier import (
    COMPASS,
    LOCATE_SETTINGS,
    ODOMETRY_SCALE_ERROR,
    READER,
    WIFI,
    Site,
    StepSeen,
    floor_rig,
    located_scans,
)
from rfidnav_localization.conversions import fused_status_message
from rfidnav_localization.fingerprint import LocateSettings
from rfidnav_localization.fused.filter import Evidence, HeldReadings, Ports, WifiFix, round_evidence
from rfidnav_localization.fused.localizer import FusedEstimate, FusedLocalizer
from rfidnav_localization.partition import LocalizationEstimate, PartitionLocalizer
from rfidnav_planning.conversions import estimate_from_status
from rfidnav_planning.pose_navigation import Pose, PoseNavigator
from rfidnav_scenario.metrics import ground_truth_objection, wall_crossings
from rfidnav_sim.compass_model import CompassModel
from rfidnav_sim.parameters import ReaderParameters
from rfidnav_sim.rig import pose_of

MIN_VARIANCE = 1e-12     # a covariance with a zero variance (a collapsed cloud) is floored, not inverted
# The kinds a rider may be restricted to: the readings of Evidence they keep (their measurements' names,
# rfidnav_localization.fused.kinds).
KINDS = {"floor": "floor_tag_ids", "phase": "phase", "wall": "wall_tag_ids", "wifi": "wifi_fix",
         "compass": "compass_yaw_rad"}
CONVERGED_M = 0.5        # global localization and kidnap recovery: the error below this...
CONVERGED_FOR_S = 5.0    # ...for this long


@dataclass
class Track:
    """A localizer's errors over a run, one entry per round it had an estimate."""
    rounds: int = 0                                  # rounds of the run, estimate or not
    times_s: list[float] = field(default_factory=list)
    position_errors_m: list[float] = field(default_factory=list)
    heading_errors_rad: list[float] = field(default_factory=list)
    heading_times_s: list[float] = field(default_factory=list)   # the round of each heading error
    nees: list[float] = field(default_factory=list)
    nees_dofs: list[int] = field(default_factory=list)    # each NEES's degrees of freedom: 3, or 2 without a heading

    def add(self, time_s: float, position_error: tuple[float, float], heading_error: float | None,
            covariance: np.ndarray) -> None:
        self.times_s.append(time_s)
        self.position_errors_m.append(math.hypot(*position_error))
        self.add_heading(time_s, heading_error)
        error = np.array(position_error if covariance.shape[0] == 2 else (*position_error, heading_error or 0.0))
        covariance = covariance + MIN_VARIANCE * np.eye(len(error))
        self.nees.append(float(error @ np.linalg.solve(covariance, error)))
        self.nees_dofs.append(len(error))

    def add_position(self, time_s: float, position_error: tuple[float, float],
                     heading_error: float | None = None) -> None:
        """An estimate with no covariance to judge it by (no NEES)."""
        self.times_s.append(time_s)
        self.position_errors_m.append(math.hypot(*position_error))
        self.add_heading(time_s, heading_error)

    def add_heading(self, time_s: float, heading_error: float | None) -> None:
        if heading_error is not None:
            self.heading_times_s.append(time_s)
            self.heading_errors_rad.append(heading_error)

    def heading_errors_at(self, times_s: Collection[float]) -> list[float]:
        """The heading errors of the rounds at ``times_s`` (another localizer's heading rounds on the same run: a
        like-for-like comparison with one that reports a heading only some of the time)."""
        return [error for time_s, error in zip(self.heading_times_s, self.heading_errors_rad, strict=True)
                if time_s in times_s]

    @property
    def fix_rate(self) -> float:
        return len(self.position_errors_m) / self.rounds if self.rounds else 0.0

    def settled_after(self, since_s: float) -> float | None:
        """Sim seconds from ``since_s`` until the position error went below CONVERGED_M and stayed there for
        CONVERGED_FOR_S (or to the end of the run, if that came first but after at least one round); None: never."""
        start: float | None = None
        for time_s, error in zip(self.times_s, self.position_errors_m, strict=True):
            if time_s < since_s:
                continue
            if error >= CONVERGED_M:
                start = None
            elif start is None:
                start = time_s
            if start is not None and time_s - start >= CONVERGED_FOR_S:
                return start - since_s
        return start - since_s if start is not None else None


@dataclass
class Rider:
    """One fused localizer on the run: the evidence ``kinds`` it is given (all by default); started at
    ``joins_at_s`` (before, it hears nothing: a localizer started mid-mission with no idea where the robot is); and
    a kidnap at ``kidnap_at_s``: it is told, with a 10 cm / 0.05 rad sd, that the robot stands half the floor's
    ``extent`` away in x and in y (wrapped round inside it) and faces the other way (:func:`kidnapped`)."""
    localizer: FusedLocalizer
    kinds: Collection[str] = tuple(KINDS)
    kidnap_at_s: float | None = None
    extent: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0)
    joins_at_s: float = 0.0
    track: Track = field(default_factory=Track)
    last: FusedEstimate | None = None        # its latest estimate

    def tier_one(self) -> tuple[tuple[float, float], float] | None:
        """Its latest estimate as the two-tier navigator takes tier one from it (two_tier_navigator's
        ``tier_one_from``): the position and its sd as pose_from_message makes them of the pose message."""
        if self.last is None:
            return None
        pose = self.last.pose
        sd_m = Pose.of_variances(pose.x, pose.y, pose.yaw, pose.covariance[0, 0], pose.covariance[1, 1]).sd_m
        return (pose.x, pose.y), sd_m

    def evidence(self, evidence: Evidence) -> Evidence:
        """``evidence`` without the readings of the kinds this rider is not given."""
        return evidence.without([name for kind, name in KINDS.items() if kind not in self.kinds])

    def moved(self, time_s: float, odom: tuple[float, float, float], truth: tuple[float, float, float]) -> bool:
        """The odometry at ``time_s``, and the kidnap when it is due (the harness, not the localizer, knows the
        ``truth`` it is made from); False before the rider has joined."""
        if time_s < self.joins_at_s:
            return False
        self.localizer.on_odometry(odom)
        if self.kidnap_at_s is not None and time_s >= self.kidnap_at_s:
            self.kidnap_at_s = None
            self.localizer.set_pose(*kidnapped(truth, self.extent), np.diag([0.01, 0.01, 0.0025]))
        return True

    def update(self, time_s: float, evidence: Evidence, truth: tuple[float, float, float]) -> FusedEstimate | None:
        """One round's evidence (of the kinds it is given), its estimate scored against ``truth``."""
        estimate = self.last = self.localizer.on_round(self.evidence(evidence))
        self.track.rounds += 1
        if estimate is not None:
            pose = estimate.pose
            self.track.add(time_s, (pose.x - truth[0], pose.y - truth[1]), wrap_angle(pose.yaw - truth[2]),
                           pose.covariance)
        return estimate


def kidnapped(truth: tuple[float, float, float], extent: tuple[float, float, float, float]) \
        -> tuple[float, float, float]:
    """A pose half the extent away from ``truth`` in x and in y (wrapped round inside it), facing the other way: as
    far off as the floor allows wherever the robot is."""
    x_min, y_min, x_max, y_max = extent
    width, height = x_max - x_min, y_max - y_min
    return (x_min + (truth[0] - x_min + width / 2.0) % width, y_min + (truth[1] - y_min + height / 2.0) % height,
            truth[2] + math.pi)


class Beside:
    """Fused localizers fed by a two-tier run's steps (paper 003), and their tracks and the paper's scored."""

    def __init__(self, riders: dict[str, Rider], ports: Ports) -> None:
        self.riders = riders
        self.ports = ports
        self.paper = Track()
        self.wifi_fixes: HeldReadings[WifiFix] = HeldReadings()

    def __call__(self, seen: StepSeen) -> None:
        riders = [rider for rider in self.riders.values() if rider.moved(seen.time_s, seen.odom, seen.truth)]
        if seen.wifi_fix is not None:
            self.wifi_fixes.hold(seen.wifi_fix, seen.time_s)
        if seen.round_reads is None:
            return                                             # the node updates once per reader round
        wifi_fix = self.wifi_fixes.take(seen.time_s)
        evidence = round_evidence(seen.round_reads, self.ports, wifi_fix, seen.compass_yaw_rad)
        x, y, yaw = seen.truth
        for rider in riders:
            rider.update(seen.time_s, evidence, seen.truth)
        self.paper.rounds += 1
        paper = seen.paper
        if paper.position is not None:
            heading = wrap_angle(paper.yaw - yaw) if paper.yaw is not None else None
            self.paper.add(seen.time_s, (paper.position[0] - x, paper.position[1] - y), heading,
                           np.eye(2) * max(paper.sd_m, 1e-6) ** 2)


class PartitionBeside:
    """Fused localizers fed by a paper 000 navigation's rounds (rfidnav_experiments.runners.partitions: the floor
    antenna's tags and the odometry), and their tracks and the partition localizer's scored."""

    def __init__(self, riders: dict[str, Rider]) -> None:
        self.riders = riders
        self.paper = Track()

    def __call__(self, robot: IdealRobot, tag_ids: list[str], estimate: LocalizationEstimate) -> None:
        time_s, truth = robot.time_s, (robot.x, robot.y, robot.yaw)
        for rider in self.riders.values():
            if rider.moved(time_s, robot.odometry(), truth):
                rider.update(time_s, Evidence(floor_tag_ids=tag_ids), truth)
        self.paper.rounds += 1
        if estimate.position is None:
            return
        var_x, cov_xy, var_y = estimate.position_covariance
        error = (estimate.position[0] - truth[0], estimate.position[1] - truth[1])
        if estimate.yaw is None or estimate.yaw_std is None:
            self.paper.add(time_s, error, None, np.array([[var_x, cov_xy], [cov_xy, var_y]]))
        else:
            covariance = np.array([[var_x, cov_xy, 0.0], [cov_xy, var_y, 0.0], [0.0, 0.0, estimate.yaw_std ** 2]])
            self.paper.add(time_s, error, wrap_angle(estimate.yaw - truth[2]), covariance)


class TopologicalBeside:
    """Fused localizers fed by a paper 004 mission's control steps (rfidnav_experiments.runners.topological: the side
    antenna's wall tags and the odometry; the robot has no other sensor the fused filter weighs), scored with the
    executor's own idea of where the robot is: the position of the node it believes it is at (it has no metric
    estimate, so no NEES)."""

    def __init__(self, riders: dict[str, Rider], wall_port: int, node_positions: dict[str, tuple[float, float]]) \
            -> None:
        self.riders = riders
        self.wall_port = wall_port
        self.node_positions = node_positions
        self.paper = Track()

    def __call__(self, step: MissionStep) -> None:
        x, y, _ = step.truth
        evidence = Evidence(wall_tag_ids=[(self.wall_port, tag_id) for tag_id in step.wall_reads])
        for rider in self.riders.values():
            if rider.moved(step.time_s, step.odom, step.truth):
                rider.update(step.time_s, evidence, step.truth)
        self.paper.rounds += 1
        node = self.node_positions.get(step.current_node or "")
        if node is not None:
            self.paper.add_position(step.time_s, (node[0] - x, node[1] - y))


class RouteBeside:
    """Fused localizers fed by a paper 001 route's reader rounds (rfidnav_experiments.runners.tag_route: the two
    receiving antennas under the ceiling tags, the floor antenna over the arrival tags, the odometry; the robot has
    no compass). Paper 001's follower keeps no pose: what the robot knows of where it is without the fused
    localizer is its wheel odometry from the known ``start``, scored as the paper's (no covariance, so no NEES)."""

    def __init__(self, riders: dict[str, Rider], ports: Ports, start: tuple[float, float, float]) -> None:
        self.riders = riders
        self.ports = ports
        self.start = start
        self.paper = Track()

    def __call__(self, seen: RouteRound) -> None:
        evidence = round_evidence(seen.reads, self.ports, None, None)
        for rider in self.riders.values():
            if rider.moved(seen.time_s, seen.odom, seen.truth):
                rider.update(seen.time_s, evidence, seen.truth)
        self.paper.rounds += 1
        x, y, yaw = compose(self.start, seen.odom)
        self.paper.add_position(seen.time_s, (x - seen.truth[0], y - seen.truth[1]), wrap_angle(yaw - seen.truth[2]))


class FusedPartitions:
    """The fused localizer as paper 000's partition navigator drives on it (runners.partitions.PartitionEstimator):
    each round's floor tags and odometry in, its estimate out as the navigator node takes it from rfid_localizer's
    status over DDS: through the same two conversions (fused_status_message, then estimate_from_status), so the
    in-process runs and the DDS graph cannot drift apart. ``last``: the fused estimate with its covariance."""

    def __init__(self, localizer: FusedLocalizer) -> None:
        self.localizer = localizer
        self.last: FusedEstimate | None = None
        self.partition: frozenset[Coordinate] | None = None

    def update(self, stamp_s: float, tag_ids: Sequence[str], odom: tuple[float, float, float]) -> LocalizationEstimate:
        self.localizer.on_odometry(odom)
        self.last = self.localizer.on_round(Evidence(floor_tag_ids=tag_ids))
        assert self.last is not None                # only before the first odometry
        status = fused_status_message(self.last, Time(), MAP_FRAME, 0)
        estimate = estimate_from_status(status, stamp_s, self.partition)
        self.partition = estimate.partition or self.partition
        return estimate


class PartitionDriving:
    """Scores a partition navigation driven by the fused localizer (FusedPartitions): its track, and paper 000's
    localizer beside it on the same rounds (``paper``, fed the same tags and odometry, driving nothing)."""

    def __init__(self, driving: FusedPartitions, paper: PartitionLocalizer) -> None:
        self.driving = driving
        self.paper_localizer = paper
        self.fused = Track()
        self.beside = PartitionBeside({})

    def __call__(self, robot: IdealRobot, tag_ids: list[str], estimate: LocalizationEstimate) -> None:
        truth = (robot.x, robot.y, robot.yaw)
        self.fused.rounds += 1
        if self.driving.last is not None:
            pose = self.driving.last.pose
            self.fused.add(robot.time_s, (pose.x - truth[0], pose.y - truth[1]), wrap_angle(pose.yaw - truth[2]),
                           pose.covariance)
        self.beside(robot, tag_ids, self.paper_localizer.update(robot.time_s, tag_ids, robot.odometry()))


@dataclass(frozen=True)
class DrivingRun:
    success: bool                      # arrived by the fused pose, and no wall crossed
    message: str
    final_error_m: float               # true distance from the target at the end
    duration_s: float
    wall_crossings: int


def drive_on_fused(site: Site, start: tuple[float, float, float], target: tuple[float, float], rider: Rider,
                   ports: Ports, navigator: PoseNavigator, reader_parameters: ReaderParameters,
                   rng: np.random.Generator, reader_seed: int, step_s: float, scan_period_s: float,
                   max_time_s: float, odometry_scale_error: float = ODOMETRY_SCALE_ERROR,
                   compass: CompassModel = COMPASS, locate: LocateSettings = LOCATE_SETTINGS) -> DrivingRun:
    """pose_navigator driving on the fused localizer's pose, in-process: the graph of ``mixed_floor_fused`` (the
    simulated base, reader, WiFi and compass; the location server; rfid_localizer; pose_navigator) stepped in one
    loop at the navigator's control rate. As the node does, the localizer weighs each reader round with the
    compass's latest heading and the location server's answer to the latest scan (one every ``scan_period_s``);
    the navigator steers by its latest estimate. ``rider`` carries the localizer and scores it against the truth."""
    reader = reader_parameters.simulated_reader(site.world, reader_seed)
    rig = floor_rig(site, start, odometry_scale_error, step_s,
                    {WIFI: located_scans(site, scan_period_s, rng, locate), READER: reader})
    navigator.start(target)
    pose: Pose | None = None
    wifi_fixes: HeldReadings[WifiFix] = HeldReadings()
    robot = rig.base
    rider.moved(0.0, pose_of(robot.odom), pose_of(robot.truth))
    step = navigator.step(pose)
    while not step.finished and rig.now_s < max_time_s:
        rig.command(*step.command, rig.now_s)
        seen = rig.advance()
        time_s, truth = seen.time_s, seen.truth
        rider.moved(time_s, seen.odom, truth)
        located = seen.readings.get(WIFI)
        if located is not None and located.result is not None:
            wifi_fixes.hold((located.result.position, located.result.uncertainty_m), time_s)
        due = seen.readings.get(READER)
        if due is not None:
            # the compass's heading at the round (rfid_localizer weighs each round with the latest one)
            estimate = rider.update(time_s, round_evidence(due, ports, wifi_fixes.take(time_s),
                                                           compass.measure(truth[2], rng)), truth)
            if estimate is not None:
                covariance = estimate.pose.covariance
                pose = Pose.of_variances(estimate.pose.x, estimate.pose.y, estimate.pose.yaw, covariance[0, 0],
                                         covariance[1, 1])
        step = navigator.step(pose)
    crossings = wall_crossings(rig.track()[1], site.world.wall_segments())
    message = step.message if step.finished else f"timed out after {max_time_s:g} s"
    objection = ground_truth_objection({"wall_crossings": crossings})
    if objection is not None:
        message += f"; but it {objection}"
    final = pose_of(robot.truth)
    return DrivingRun(step.success and objection is None, message, math.dist(final[:2], target), rig.now_s, crossings)
