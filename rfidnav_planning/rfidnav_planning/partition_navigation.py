"""Navigation in an RFID-enabled space (paper 000 section 5.2), as a decision core without motion or ROS.

The navigator decides; something else moves the robot. It is fed one localization estimate per
inventory round (or per partition crossing in the in-process experiments) and answers with a motion:
drive straight on, rotate on the spot by an angle, or stop. The DDS node turns these into /cmd_vel
(rotations closed on odometry by :class:`TurnOnTheSpot`); the experiment runner applies them to an idealised
robot, which turns exactly. Both run exactly this code.

Phases (paper 000 sections 5.2 and 6.3):

1. ``localizing``: drive straight across N partitions (N = the approximation level, 1-8) so the
   localizer can bound the heading from the partitions traversed;
2. ``rotating``: turn towards the goal by (bearing to the goal from the estimated location) minus the
   estimated heading;
3. ``following``: drive straight along the planned partition path (Algorithm 1). Entering the goal's
   partition ends the navigation (success). Entering a partition that is not on the plan is a
   deviation: ``replanning`` re-estimates the heading from the partitions traversed (the localizer's
   current estimate), plans again from the estimated location, rotates, and goes on. The two partitions
   either side of the boundary where the robot last turned are no deviation (see
   :meth:`PartitionNavigator.unexpected`).
4. Leaving the tagged floor (no tag read after some were), the robot turns back while localizing and
   re-plans while following.

The goal's partition is the set of tags that read the goal point; the robot computes it from the
lattice the tags describe (layout and spacing in every ID), not from a map of tag positions.

Ours, beside the particle filter (config/params/partition_navigator_filter_paper_robot.yaml on the paper's robot,
partition_navigator_filter.yaml with a second antenna ahead of the axis), settings change:
``spin_quarter_turns`` (the latter only) localizes by turning on the spot first (an antenna ahead of the rotation
axis sweeps partition boundaries, so the heading is learnt without driving in an unknown direction; the turns cost
time the path length does not show); ``deviation_check: pose`` re-plans when the pose estimate would miss the
goal rather than on every partition off the plan; ``arrival: position`` stops when the estimated centre is
near the goal rather than when the antenna reads the goal's partition.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rfidnav_common.errors import ParameterError
from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Coordinate, Deployment, Lattice
from rfidnav_localization.partition import LocalizationEstimate
from rfidnav_planning.errors import PlanningError
from rfidnav_planning.partition_planner import PartitionPlan, plan_partition_path

LOCALIZING, ROTATING, FOLLOWING, REPLANNING, DONE = "localizing", "rotating", "following", "replanning", "done"
FORWARD, ROTATE, STOP = "forward", "rotate", "stop"
DEVIATION_CHECKS = ("partition", "pose")
ARRIVALS = ("partition", "position")


@dataclass(frozen=True)
class NavigatorSettings:
    approximation_level: int = 4           # N: partitions crossed in the localization phase (paper 000: 1..8)
    localized_yaw_sd_rad: float = 0.0      # > 0: also end the localization phase once the heading's sd is below this
    max_path_factor: float = 5.0           # give up after driving this many times the first planned distance (+ 1 m)
    max_localization_m: float = 10.0       # give up localizing after driving this far without a heading estimate
    lost_distance_m: float = 1.0           # give up after driving this far without reading any tag
    max_replans: int = 500
    deviation_check: str = "partition"     # partition (paper: a partition off the plan) or pose (ours, see deviated)
    pose_miss_tolerance_r: float = 0.25    # pose check: re-plan when the estimate would miss the goal by this x r
    spin_quarter_turns: int = 0            # ours: localize first by up to this many quarter turns on the spot
    arrival: str = "partition"             # partition (paper: in the goal's partition) or position (ours, see arrived)
    position_tolerance_r: float = 0.25     # position arrival: the estimate within this x r of the goal

    def validate(self) -> None:
        if not 1 <= self.approximation_level <= 64:
            raise ParameterError("approximation_level", f"must be in 1..64, got {self.approximation_level}")
        if self.localized_yaw_sd_rad < 0.0:
            raise ParameterError("localized_yaw_sd_rad", "must not be negative")
        if self.max_localization_m <= 0.0:
            raise ParameterError("max_localization_m", f"must be positive, got {self.max_localization_m}")
        if self.max_path_factor <= 1.0:
            raise ParameterError("max_path_factor", f"must be above 1, got {self.max_path_factor}")
        if self.lost_distance_m <= 0.0:
            raise ParameterError("lost_distance_m", f"must be positive, got {self.lost_distance_m}")
        if self.max_replans < 0:
            raise ParameterError("max_replans", "must not be negative")
        if self.deviation_check not in DEVIATION_CHECKS:
            raise ParameterError("deviation_check",
                                 f"'{self.deviation_check}' is not one of {', '.join(DEVIATION_CHECKS)}")
        if self.pose_miss_tolerance_r <= 0.0:
            raise ParameterError("pose_miss_tolerance_r", f"must be positive, got {self.pose_miss_tolerance_r}")
        if self.spin_quarter_turns < 0:
            raise ParameterError("spin_quarter_turns", f"must not be negative, got {self.spin_quarter_turns}")
        if self.arrival not in ARRIVALS:
            raise ParameterError("arrival", f"'{self.arrival}' is not one of {', '.join(ARRIVALS)}")
        if self.position_tolerance_r <= 0.0:
            raise ParameterError("position_tolerance_r", f"must be positive, got {self.position_tolerance_r}")


@dataclass(frozen=True)
class Motion:
    kind: str                              # forward | rotate | stop
    rotate_by_rad: float = 0.0             # for rotate: CCW positive, relative to the current heading


@dataclass(frozen=True)
class Decision:
    phase: str
    motion: Motion
    new_plan: PartitionPlan | None = None  # set when this decision (re)planned
    finished: bool = False
    success: bool = False
    message: str = ""


@dataclass
class NavigationState:
    goal: tuple[float, float]
    tolerance_m: float
    phase: str = LOCALIZING
    resume_phase: str = FOLLOWING            # the phase a turn on the spot leads to
    off_deployment: bool = False             # reading no tags since it last turned back
    current_partition: frozenset[Coordinate] | None = None
    previous_partition: frozenset[Coordinate] | None = None
    tolerated: frozenset[frozenset[Coordinate]] = frozenset()   # off-plan partitions that are no deviation
    quarter_turns: int = 0                   # spin localization turns made
    last_estimate: LocalizationEstimate | None = None
    plan: PartitionPlan | None = None
    goal_partition: frozenset[Coordinate] | None = None
    lattice: Lattice | None = None           # learnt from the tag IDs
    replans: int = 0
    partitions_entered: int = 0
    last_read_travel_m: float = 0.0
    path_limit_m: float = math.inf
    outcome: Decision | None = None


@dataclass(frozen=True)
class TurnSettings:
    max_rate_radps: float                  # the largest yaw rate
    gain_per_s: float                      # yaw rate per radian still to turn, near the end of a turn
    tolerance_rad: float                   # a turn is done this close to its target heading


class TurnOnTheSpot:
    """A rotation the navigator asked for, closed on the odometry heading: a yaw rate proportional to the
    angle still to turn (capped, so it slows down only near the end) until within the tolerance. A turn asked
    for before any heading is known starts from the first one."""

    def __init__(self, settings: TurnSettings) -> None:
        self.settings = settings
        self.target_yaw: float | None = None   # the odometry heading to reach
        self.pending_rad: float | None = None  # the angle of a turn that waits for a heading to start from

    @property
    def turning(self) -> bool:
        return self.target_yaw is not None or self.pending_rad is not None

    def start(self, angle: float, yaw: float | None) -> None:
        """Turn by ``angle`` (CCW positive) from the odometry heading ``yaw``, or from the first one if None."""
        if yaw is None:
            self.pending_rad = angle
        else:
            self.target_yaw = wrap_angle(yaw + angle)

    def yaw_rate(self, yaw: float) -> float | None:
        """The yaw rate [rad/s] to command at odometry heading ``yaw``, or None: the turn is done (tell the
        navigator, :meth:`PartitionNavigator.rotation_done`)."""
        if self.pending_rad is not None:
            self.target_yaw, self.pending_rad = wrap_angle(yaw + self.pending_rad), None
        remaining = wrap_angle(self.target_yaw - yaw)
        if abs(remaining) <= self.settings.tolerance_rad:
            self.target_yaw = None
            return None
        limit = self.settings.max_rate_radps
        return max(-limit, min(limit, self.settings.gain_per_s * remaining))


class GoalRejected(ValueError):
    """A goal the navigator cannot accept; the message says why."""


class PartitionNavigator:
    def __init__(self, settings: NavigatorSettings, deployment_area: tuple[float, float, float, float]) -> None:
        settings.validate()
        self.settings = settings
        self.area = deployment_area
        self.state: NavigationState | None = None

    # ------------------------------------------------------------------------------------- goals
    def check_goal(self, goal: tuple[float, float], tolerance_m: float) -> None:
        x_min, y_min, x_max, y_max = self.area
        if not all(math.isfinite(v) for v in (*goal, tolerance_m)):
            raise GoalRejected(f"goal ({goal[0]}, {goal[1]}) or tolerance {tolerance_m} is not a finite number")
        if tolerance_m < 0.0:
            raise GoalRejected(f"tolerance {tolerance_m} m is negative")
        if not (x_min <= goal[0] <= x_max and y_min <= goal[1] <= y_max):
            raise GoalRejected(f"goal ({goal[0]:.3f}, {goal[1]:.3f}) is outside the deployment "
                               f"[{x_min:g}, {x_max:g}] x [{y_min:g}, {y_max:g}] m")

    def start(self, goal: tuple[float, float], tolerance_m: float = 0.0) -> Decision:
        self.check_goal(goal, tolerance_m)
        self.state = NavigationState(goal=(float(goal[0]), float(goal[1])), tolerance_m=tolerance_m)
        return Decision(LOCALIZING, Motion(FORWARD))

    @property
    def active(self) -> bool:
        return self.state is not None and self.state.outcome is None

    # ----------------------------------------------------------------------------------- decisions
    def on_estimate(self, estimate: LocalizationEstimate, travelled_m: float) -> Decision:
        """One localization estimate; ``travelled_m`` is the distance driven since the start (odometry)."""
        state = self.state
        if state is None or state.outcome is not None:
            raise RuntimeError("on_estimate without an active goal")
        if estimate.partition:
            state.last_read_travel_m = travelled_m
            state.off_deployment = False
            if estimate.partition_changed:
                state.partitions_entered += 1
                state.previous_partition, state.current_partition = state.current_partition, estimate.partition
        elif travelled_m - state.last_read_travel_m > self.settings.lost_distance_m:
            return self.finish(False, f"lost: no floor tag read over the last {self.settings.lost_distance_m:g} m "
                                      "(off the deployment?)")
        state.last_estimate = estimate
        if state.plan is None and travelled_m > self.settings.max_localization_m:
            # Each edge of the tagged floor turns the robot back and restarts its straight stretch: a floor too
            # small for N partitions in a line would keep it localizing for ever.
            return self.finish(False, f"could not localize: no heading after driving {travelled_m:.1f} m "
                                      f"(N = {self.settings.approximation_level} partitions in a straight line)")
        if travelled_m > state.path_limit_m:
            return self.finish(False, f"gave up after driving {travelled_m:.2f} m "
                                      f"({self.settings.max_path_factor:g} x the planned distance)")
        if state.phase == ROTATING:
            return Decision(ROTATING, Motion(ROTATE, 0.0))     # the rotation in progress finishes first
        if estimate.position is None:      # nothing read yet
            return self.localize(estimate) if state.phase == LOCALIZING else Decision(state.phase, Motion(FORWARD))
        if state.goal_partition is None and estimate.lattice is not None:
            state.lattice = estimate.lattice
            state.goal_partition = self.deployment(estimate).partition_at(*state.goal)
        if not estimate.partition and (state.phase == LOCALIZING or self.settings.deviation_check == "partition"):
            # With a pose estimate, following, an empty round is only an antenna past the tagged floor's edge.
            return self.left_deployment(estimate)
        if self.arrived(estimate):
            where = "in the goal's partition" if self.settings.arrival == "partition" else "at the goal"
            return self.finish(True, f"arrived {where} after {state.replans} re-plans")
        if state.phase == LOCALIZING:
            return self.localize(estimate)
        # following
        if self.lost_heading(estimate):
            state.replans += 1
            state.phase, state.quarter_turns = LOCALIZING, 0
            return self.localize(estimate)
        # The paper checks on entering a partition; a pose estimate can be checked every round.
        check = estimate.partition_changed or self.settings.deviation_check == "pose"
        if check and self.deviated(estimate):
            if state.replans >= self.settings.max_replans:
                return self.finish(False, f"gave up after {state.replans} re-plans")
            state.replans += 1
            return self.plan_and_turn(estimate, REPLANNING)
        return Decision(FOLLOWING, Motion(FORWARD))

    def left_deployment(self, estimate: LocalizationEstimate) -> Decision:
        """No tag read after some were: the robot drove off the tagged floor. Localizing, it turns back and
        starts the straight stretch again; following, it re-plans from its last estimate."""
        state = self.state
        if state.off_deployment:
            return Decision(state.phase, Motion(FORWARD))     # already turned back: drive on to the tags
        state.off_deployment = True
        if state.phase == LOCALIZING or estimate.yaw is None:
            state.phase, state.resume_phase = ROTATING, LOCALIZING
            return Decision(LOCALIZING, Motion(ROTATE, math.pi))
        state.replans += 1
        return self.plan_and_turn(estimate, REPLANNING)

    def localize(self, estimate: LocalizationEstimate) -> Decision:
        """Localization phase: done once localized; else turn a quarter on the spot while spins are left (an
        antenna off the rotation axis sweeps partition boundaries), else drive straight on (paper 000)."""
        state = self.state
        if estimate.partition and self.localized(estimate):
            return self.plan_and_turn(estimate, LOCALIZING)
        if state.quarter_turns < self.settings.spin_quarter_turns:
            state.quarter_turns += 1
            state.phase, state.resume_phase = ROTATING, LOCALIZING
            return Decision(LOCALIZING, Motion(ROTATE, math.pi / 2.0))
        state.phase = LOCALIZING
        return Decision(LOCALIZING, Motion(FORWARD))

    def rotation_done(self) -> Decision:
        """The robot has turned as asked: go on localizing (with the estimate seen while turning), or drive
        along the plan."""
        state = self.state
        if state is None or state.outcome is not None:
            raise RuntimeError("rotation_done without an active goal")
        state.phase, state.resume_phase = state.resume_phase, FOLLOWING
        if state.phase == LOCALIZING and state.last_estimate is not None:
            return self.localize(state.last_estimate)
        return Decision(state.phase, Motion(FORWARD))

    def cancel(self, message: str = "cancelled") -> Decision:
        return self.finish(False, message)

    # ------------------------------------------------------------------------------------- helpers
    def localized(self, estimate: LocalizationEstimate) -> bool:
        if estimate.yaw is None:
            return False
        if estimate.partitions_traversed >= self.settings.approximation_level:
            return True
        sd_limit = self.settings.localized_yaw_sd_rad
        return sd_limit > 0.0 and estimate.yaw_std is not None and estimate.yaw_std <= sd_limit

    def arrived(self, estimate: LocalizationEstimate) -> bool:
        """``partition`` (paper 000): the robot reads the goal's partition. ``position`` (ours, for an estimate
        finer than a partition, e.g. with the antenna off the axis, where the partition read is not the
        centre's): the estimated centre lies within ``position_tolerance_r`` read ranges of the goal."""
        state = self.state
        if self.settings.arrival == "position":
            if estimate.yaw is None:
                return False
            tolerance = max(state.tolerance_m, self.settings.position_tolerance_r * estimate.read_range_m)
            ahead, aside = self.goal_offset(estimate)
            # Within tolerance, or passing it now: the goal just behind and within tolerance to the side
            # (rounds come a few millimetres apart, more than a fine tolerance).
            return math.hypot(ahead, aside) <= tolerance or (ahead <= 0.0 and abs(aside) <= tolerance
                                                              and state.phase == FOLLOWING)
        if state.goal_partition is not None and estimate.partition == state.goal_partition:
            return True
        if state.tolerance_m > 0.0 and estimate.position is not None:
            return math.dist(estimate.position, state.goal) <= state.tolerance_m
        return False

    def deviated(self, estimate: LocalizationEstimate) -> bool:
        """Time to re-plan. ``partition`` (paper 000 section 5.2): the robot entered a partition off the plan.
        ``pose`` (ours, for an estimate that is more than a partition, such as the particle filter's): the
        estimated heading would miss the goal by more than ``pose_miss_tolerance_r`` read ranges, and is off
        the bearing to the goal by more than twice its own sd (turning on noise gains nothing)."""
        if self.settings.deviation_check == "partition":
            return self.unexpected(estimate.partition)
        if estimate.yaw is None:
            return False
        ahead, aside = self.goal_offset(estimate)
        error = math.atan2(aside, ahead)
        miss = abs(aside) if ahead > 0.0 else math.hypot(ahead, aside)
        significant = estimate.yaw_std is None or abs(error) > 2.0 * estimate.yaw_std
        return miss > self.settings.pose_miss_tolerance_r * estimate.read_range_m and significant

    def lost_heading(self, estimate: LocalizationEstimate) -> bool:
        """Pose mode: the estimate no longer knows the heading (a filter that re-initialised, e.g. at the edge
        of the tagged floor), so following it would drive anywhere: localize again."""
        limit = self.settings.localized_yaw_sd_rad
        if self.settings.deviation_check != "pose" or limit <= 0.0:
            return False
        return estimate.yaw is None or (estimate.yaw_std is not None and estimate.yaw_std > 2.0 * limit)

    def goal_offset(self, estimate: LocalizationEstimate) -> tuple[float, float]:
        """The goal in the estimated robot frame: (ahead, to the left) [m]."""
        dx, dy = self.state.goal[0] - estimate.position[0], self.state.goal[1] - estimate.position[1]
        cos_yaw, sin_yaw = math.cos(estimate.yaw), math.sin(estimate.yaw)
        return cos_yaw * dx + sin_yaw * dy, -sin_yaw * dx + cos_yaw * dy

    def unexpected(self, partition: frozenset[Coordinate]) -> bool:
        """Off the plan. The partitions on both sides of the boundary where the robot last turned count as on
        it: the robot turns where it entered a partition, so driving off it may first cross back that
        boundary, and calling that a deviation re-plans on the spot forever."""
        state = self.state
        return state.plan is not None and state.plan.index_of(partition) is None and partition not in state.tolerated

    def deployment(self, estimate: LocalizationEstimate) -> Deployment:
        """The deployment as the robot knows it: lattice and r from the tag IDs, area from the map."""
        return Deployment(estimate.lattice, estimate.read_range_m, self.area)

    def plan_and_turn(self, estimate: LocalizationEstimate, phase: str) -> Decision:
        state = self.state
        start = self.clamped(estimate.position)
        try:
            plan = plan_partition_path(self.deployment(estimate), start, state.goal)
        except PlanningError as error:      # e.g. a grid deployment: Algorithm 1 needs triangles
            return self.finish(False, f"cannot plan: {error}")
        state.plan = plan
        state.tolerated = frozenset(p for p in (state.current_partition, state.previous_partition) if p)
        if state.path_limit_m == math.inf:
            state.path_limit_m = self.settings.max_path_factor * math.dist(start, state.goal) + 1.0
        bearing = math.atan2(state.goal[1] - start[1], state.goal[0] - start[0])
        state.phase = ROTATING
        return Decision(phase, Motion(ROTATE, wrap_angle(bearing - estimate.yaw)), new_plan=plan)

    def clamped(self, position: tuple[float, float]) -> tuple[float, float]:
        """A partition centre can lie just outside the area (edge tags): plan from the nearest point inside."""
        x_min, y_min, x_max, y_max = self.area
        return min(max(position[0], x_min), x_max), min(max(position[1], y_min), y_max)

    def finish(self, success: bool, message: str) -> Decision:
        state = self.state
        state.phase = DONE
        state.outcome = Decision(DONE, Motion(STOP), finished=True, success=success, message=message)
        return state.outcome
