"""Self-guided navigation of paper 003 (Fig. 2, steps A1-A7) as a decision core without motion or ROS.

The core is fed the robot's sensors one control step at a time (odometry, compass, the floor tags the HF
reader reads) and the location server's answers, and answers with a velocity command and, when it needs
one, a request to the location server. The DDS node turns requests into service calls and commands into
/cmd_vel; the in-process experiments answer from a radio map and drive an idealised robot. Both run this code.

Flow (paper 003 section 3.2):

* A6, tier one: ask the server to locate the latest WiFi scan (metre level); A1: download the tag map around
  that estimate (the landmarks: floor tag groups).
* A7, tier two: drive to the nearest landmark by dead reckoning (odometry distance, compass heading); a tag
  read fixes the position to centimetres. Arriving where the landmark should be without a read starts an
  Archimedean spiral search (rfidnav_control.spiral) sized so the band the reader reads around the group
  must be crossed (ours; the paper sizes the group's outline), at ``search_speed_mps`` (slow enough that a
  polled reader reads every crossing), out to a radius of ``search_radius_sigmas`` times the position's
  standard deviation; an exhausted spiral asks tier one again.
* A2/A3, the route: through intermediate landmarks chosen by geographic forwarding (Fig. 4): the next one is
  the landmark within ``landmark_spacing_m`` of the current position that is nearest to the target, if it is
  nearer to the target than the robot is; the target itself when it is within reach or no landmark helps.
* A5, calibration: after ``calibration_distance_m`` without a fix, tier one checks the dead-reckoned
  position; a deviation over ``deviation_threshold_m`` sends the robot to the landmark nearest the tier-one
  estimate to fix itself again.
* A4, arrival: the dead-reckoned position within the go-to tolerance of the target; a target at a landmark is
  approached from a fix on one of its tags.

Every reader round that reads a new set of known tags is a fix (rfidnav_localization.tag_fix: the robot is within
range of the tags read and out of range of their unread neighbours), on the way too (it is free); unknown tags are
counted and ignored. The reader may be polled (paper 003: every 500-600 ms, some polls failing): a tag the robot passes
between two polls is never seen, and the core only knows what a round reports.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rfidnav_common.errors import ParameterError
from rfidnav_control.go_to import GoToSettings, go_to_command
from rfidnav_control.spiral import SpiralSearch, separation_for_group
from rfidnav_localization.dead_reckoning import TIER_TAG, TIER_WIFI, DeadReckoning, DeadReckoningEstimate, Fix
from rfidnav_localization.tag_fix import TagFix, tag_fix
from rfidnav_planning.wall_paths import Point, WallMap, WallPlanner

LOCATING, MAPPING, TO_LANDMARK, SEARCHING, TO_TARGET, BACKING_OFF, DONE = (
    "locating", "mapping", "to_landmark", "searching", "to_target", "backing_off", "done")
STALL_SPEED_MPS = 0.02        # a command at least this fast that the odometry does not follow is a stall...
STALL_MOVE_M = 1e-4           # ...when a control step's odometry moves less than this (stalled wheels do not count)
BACK_OFF_SPEED_MPS = 0.1
LOCATE, TAG_MAP = "locate", "tag_map"


@dataclass(frozen=True)
class TwoTierSettings:
    landmark_spacing_m: float = 4.0        # geographic forwarding: the tolerable distance to the next landmark
    calibration_distance_m: float = 6.0    # A5: a tier-one check after driving this far without a fix
    deviation_threshold_m: float = 2.0     # A5: re-fix at a landmark when tier one disagrees by more
    tag_map_radius_m: float = 30.0         # A1: the local tag map around the tier-one estimate
    search_radius_sigmas: float = 3.0      # spiral out to this many position standard deviations...
    search_min_radius_m: float = 0.5       # ...but at least this far
    max_searches: int = 10                 # give up after this many exhausted spirals
    # Ours: a polled reader (paper 003: every 500-600 ms) reads a crossing of a tag line only if a poll falls
    # in its read band, 2 sqrt(r^2 - (s/2)^2) = 8.7 cm wide at its narrowest for tags s = 5 cm apart read within
    # r = 5 cm: at 0.14 m/s the polls fall at most 8.4 cm apart, so a crossing is missed only by a failed poll.
    search_speed_mps: float = 0.14
    read_range_m: float = 0.05             # the floor reader's range: a tag fix is this good
    drift_per_m: float = 0.05              # dead reckoning: position sd growth per metre (paper 003: 1 m per 20 m)
    # Ours, with a floor plan in the robot's map (rfidnav_planning.wall_paths): legs keep this far from its walls
    # (the base's 17 cm radius and a margin for dead reckoning)...
    wall_clearance_m: float = 0.30
    waypoint_tolerance_m: float = 0.10     # ...and pass the waypoints round them this near
    search_wall_clearance_m: float = 0.20  # a spiral ends when dead reckoning puts the robot this near a wall or edge
    # Ours: a wall the estimate did not expect (the estimate is off) stalls the wheels. After this many control
    # steps commanding motion the odometry does not follow, the robot backs off and asks tier one where it is...
    stall_steps: int = 10
    back_off_m: float = 0.25
    max_stalls: int = 10                   # ...and gives up after this many stalls
    go_to: GoToSettings = field(default_factory=GoToSettings)

    def validate(self) -> None:
        for name in ("landmark_spacing_m", "calibration_distance_m", "deviation_threshold_m", "tag_map_radius_m",
                     "search_radius_sigmas", "search_min_radius_m", "search_speed_mps", "read_range_m",
                     "wall_clearance_m", "waypoint_tolerance_m", "search_wall_clearance_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(name, f"must be a positive number, got {value}")
        for name in ("max_searches", "stall_steps", "max_stalls"):
            if getattr(self, name) < 1:
                raise ParameterError(name, f"must be at least 1, got {getattr(self, name)}")
        if not (math.isfinite(self.back_off_m) and self.back_off_m >= 0.0):
            raise ParameterError("back_off_m", f"must not be negative, got {self.back_off_m}")
        if not (math.isfinite(self.drift_per_m) and self.drift_per_m >= 0.0):
            raise ParameterError("drift_per_m", f"must not be negative, got {self.drift_per_m}")
        self.go_to.validate()


@dataclass(frozen=True)
class MapTag:
    tag_id: str
    position: tuple[float, float]
    group_id: str
    shape: str


@dataclass(frozen=True)
class Landmark:
    """A tag group as the robot knows it from the tag map."""
    group_id: str
    shape: str
    centre: tuple[float, float]
    size_m: float          # cross bar, circle diameter, triangle side or square side, from the tags' extent

    @classmethod
    def of(cls, tags: list[MapTag]) -> Landmark:
        points = np.array([tag.position for tag in tags], dtype=float)
        extent = float(np.max(np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)))
        size = extent / math.sqrt(2.0) if tags[0].shape == "square" else extent   # a square's extent is its diagonal
        centre = points.mean(axis=0)
        return cls(tags[0].group_id, tags[0].shape, (float(centre[0]), float(centre[1])), size)


@dataclass(frozen=True)
class Request:
    kind: str                               # LOCATE (the latest WiFi scan) or TAG_MAP
    centre: tuple[float, float] = (0.0, 0.0)
    radius_m: float = 0.0


@dataclass(frozen=True)
class Decision:
    phase: str
    command: tuple[float, float]            # (linear m/s, angular rad/s)
    request: Request | None = None
    finished: bool = False
    success: bool = False
    message: str = ""


@dataclass
class Progress:
    fixes: list[Fix] = field(default_factory=list)
    searches: int = 0                       # spirals started
    failed_searches: int = 0
    cut_searches: int = 0                   # of the failed: ended at a known wall or the map's edge
    stalls: int = 0                         # wheels stalled at a wall the estimate did not expect
    search_length_m: float = 0.0            # driven while searching
    tier_one_requests: int = 0
    unknown_tags: int = 0
    visited: list[str] = field(default_factory=list)   # landmarks fixed at, in order


class TwoTierNavigator:
    def __init__(self, settings: TwoTierSettings, floor: WallMap = WallMap()) -> None:
        settings.validate()
        self.settings = settings
        self.floor = floor
        self.planner = None if floor.empty else WallPlanner(floor, settings.wall_clearance_m)
        self.route: list[Point] = []                  # the current leg's waypoints round the walls, its goal last
        self.route_key: tuple[Point, int] | None = None   # (goal, fixes made) the route was planned for
        self.to_target_m: dict[str, float] = {}       # path length from each landmark to the target
        self.last_linear_mps = 0.0                    # the last command's, for the stall check
        self.stalled_steps = 0
        self.back_off_from_m = 0.0
        self.reckoning = DeadReckoning(settings.drift_per_m)
        self.tags: dict[str, MapTag] = {}
        self.landmarks: dict[str, Landmark] = {}
        self.target: tuple[float, float] | None = None
        self.phase = DONE
        self.waypoint: Landmark | None = None
        self.search: SpiralSearch | None = None
        self.search_start_m = 0.0
        self.checked_at_m = 0.0               # odometry distance at the last fix or tier-one check
        self.pending: Request | None = None
        self.fix_reads: frozenset[str] = frozenset()   # the tags the round of the last tag fix read
        self.progress = Progress()
        self.outcome: Decision | None = None

    # ---------------------------------------------------------------------------------------- mission
    def start(self, target: tuple[float, float], known_start: Fix | None = None) -> Decision:
        """Navigate to ``target``: from tier one (A6), or from ``known_start`` when the robot knows where it
        starts (a dock on a landmark: how a robot surveys a site whose radio map is still empty)."""
        refusal = self.refusal(target)
        if refusal is not None:
            raise ValueError(refusal)
        self.target = (float(target[0]), float(target[1]))
        self.route_key, self.to_target_m = None, {}
        self.progress = Progress()
        self.outcome = None
        if known_start is None:
            return self.ask(Request(LOCATE), LOCATING)
        self.fixed(known_start)
        return self.ask(Request(TAG_MAP, known_start.position, self.settings.tag_map_radius_m), MAPPING)

    def refusal(self, target: tuple[float, float]) -> str | None:
        """Why ``target`` cannot be navigated to (not a finite point, outside the map's extent), None if it can."""
        return self.floor.refusal(target)

    def estimate(self) -> DeadReckoningEstimate:
        return self.reckoning.estimate()

    @property
    def travelled_m(self) -> float:
        return self.reckoning.travelled_m

    def fixed(self, fix: Fix) -> None:
        self.reckoning.on_fix(fix)
        self.progress.fixes.append(fix)
        self.checked_at_m = self.travelled_m

    def ask(self, request: Request, phase: str) -> Decision:
        self.phase, self.pending = phase, request
        if request.kind == LOCATE:
            self.progress.tier_one_requests += 1
        return Decision(phase, (0.0, 0.0), request)

    def finish(self, success: bool, message: str) -> Decision:
        self.phase = DONE
        self.outcome = Decision(DONE, (0.0, 0.0), finished=True, success=success, message=message)
        return self.outcome

    # ------------------------------------------------------------------------------ location server
    def on_located(self, position: tuple[float, float] | None, uncertainty_m: float) -> Decision:
        """The answer to LOCATE: a position, or None when the server could not locate (the caller logs why)."""
        self.pending = None
        if position is None:          # e.g. an empty scan: scan again
            return self.ask(Request(LOCATE), self.phase)
        estimate = self.reckoning.estimate()
        if estimate.last_fix is None:           # the first fix: dead reckoning has no position before it
            self.fixed(Fix(position, uncertainty_m, TIER_WIFI))
            return self.ask(Request(TAG_MAP, position, self.settings.tag_map_radius_m), MAPPING)
        deviation = math.dist(position, estimate.position)
        if self.phase in (SEARCHING, BACKING_OFF) or deviation > self.settings.deviation_threshold_m:
            # Tier two failed or dead reckoning drifted: trust tier one and fix at the landmark nearest to it.
            self.fixed(Fix(position, uncertainty_m, TIER_WIFI))
            return self.head_for(self.nearest_landmark(position))
        self.checked_at_m = self.travelled_m        # A5 passed: the position holds; check again later
        return self.resume()

    def on_tag_map(self, tags: list[MapTag]) -> Decision:
        self.pending = None
        groups: dict[str, list[MapTag]] = {}
        for tag in tags:
            self.tags[tag.tag_id] = tag
            groups.setdefault(tag.group_id, []).append(tag)
        self.landmarks.update({group_id: Landmark.of(members) for group_id, members in groups.items()})
        if not self.landmarks:
            return self.finish(False, f"no landmark within {self.settings.tag_map_radius_m:g} m of the tier-one "
                                      "estimate: tier two cannot fix the position")
        return self.head_for(self.nearest_landmark(self.reckoning.position))

    # ------------------------------------------------------------------------------------ control step
    def step(self, odom: tuple[float, float, float], compass_yaw: float | None, tag_ids: list[str]) -> Decision:
        """One control step: the odometry pose, the latest compass heading and the floor tags read."""
        decision = self._step(odom, compass_yaw, tag_ids)
        self.last_linear_mps = decision.command[0]
        return decision

    def _step(self, odom: tuple[float, float, float], compass_yaw: float | None, tag_ids: list[str]) -> Decision:
        if self.outcome is not None:
            return self.outcome
        if compass_yaw is not None:
            self.reckoning.on_compass(compass_yaw)
        before_m = self.travelled_m
        self.reckoning.on_odometry(odom)
        stalled = abs(self.last_linear_mps) >= STALL_SPEED_MPS and self.travelled_m - before_m < STALL_MOVE_M
        self.stalled_steps = self.stalled_steps + 1 if stalled else 0
        if self.stalled_steps >= self.settings.stall_steps and self.phase != BACKING_OFF:
            return self.back_off()
        if self.pending is not None:
            return Decision(self.phase, (0.0, 0.0))          # waiting for the server: stand still
        known = [self.tags[t] for t in dict.fromkeys(tag_ids) if t in self.tags]
        self.progress.unknown_tags += len(set(tag_ids)) - len(known)
        if known:
            decision = self.on_tags(known)
            if decision is not None:
                return decision
        return self.drive()

    def on_tags(self, read: list[MapTag]) -> Decision | None:
        """A fix from one reader round that read the known tags ``read``, unless the last fix read the same ones
        (a reader polled faster than the robot leaves their region would pin the estimate to one point while the
        robot drives on; dead reckoning carries it from the first). At the landmark headed for, the next leg
        starts."""
        read_ids = frozenset(tag.tag_id for tag in read)
        last = self.reckoning.last_fix
        if last is not None and last.tier == TIER_TAG and read_ids == self.fix_reads and self.phase != SEARCHING:
            return None
        self.fix_reads = read_ids
        fix = self.tag_fix(read)
        self.fixed(Fix(fix.position, fix.sd_m, TIER_TAG, fix.tag_id))
        tag = self.tags[fix.tag_id]
        if self.phase == SEARCHING:
            self.progress.search_length_m += self.travelled_m - self.search_start_m
            self.search = None
        if self.phase == SEARCHING or (self.waypoint is not None and tag.group_id == self.waypoint.group_id):
            self.progress.visited.append(tag.group_id)
            if self.target_is(self.landmarks[tag.group_id]):   # the rest of the way from this fix
                self.waypoint, self.phase = None, TO_TARGET
                return self.drive()
            return self.next_leg()
        return None

    def tag_fix(self, read: list[MapTag]) -> TagFix:
        """Where the antenna was at the round that read ``read``: within range of each of them and out of range of
        every other known tag near them (rfidnav_localization.tag_fix)."""
        reach = 2.0 * self.settings.read_range_m
        read_ids = {tag.tag_id for tag in read}
        unread = [tag.position for tag in self.tags.values() if tag.tag_id not in read_ids
                  and any(math.dist(tag.position, seen.position) <= reach for seen in read)]
        return tag_fix([(tag.tag_id, tag.position) for tag in read], unread, self.settings.read_range_m)

    def drive(self) -> Decision:
        estimate = self.reckoning.estimate()
        if estimate.yaw is None:
            return Decision(self.phase, (0.0, 0.0))          # no compass reading yet
        if self.phase == BACKING_OFF:
            if self.travelled_m - self.back_off_from_m < self.settings.back_off_m \
                    and self.stalled_steps < self.settings.stall_steps:
                return Decision(BACKING_OFF, (-BACK_OFF_SPEED_MPS, 0.0))
            self.stalled_steps = 0
            return self.ask(Request(LOCATE), BACKING_OFF)
        if self.phase == SEARCHING:
            command = self.search.command(self.travelled_m - self.search_start_m)
            cut = (command is not None and self.planner is not None
                   and self.planner.clearance(estimate.position) < self.settings.search_wall_clearance_m)
            if command is None or cut:
                progress = self.progress
                progress.failed_searches += 1
                progress.cut_searches += cut
                progress.search_length_m += self.travelled_m - self.search_start_m
                if progress.failed_searches >= self.settings.max_searches:
                    return self.finish(False, f"{progress.failed_searches} spiral searches found no tag "
                                              f"({progress.cut_searches} ended at a wall or the map's edge)")
                return self.ask(Request(LOCATE), SEARCHING)
            return Decision(SEARCHING, command)
        if self.travelled_m - self.checked_at_m > self.settings.calibration_distance_m:
            return self.ask(Request(LOCATE), self.phase)     # A5
        goal = self.waypoint.centre if self.phase == TO_LANDMARK else self.target
        waypoint = self.next_waypoint(estimate.position, goal)
        if waypoint is None:
            return self.finish(False, f"no way round the map's walls from {_text(estimate.position)} to "
                                      f"{_text(goal)}")
        command = go_to_command(estimate.position, estimate.yaw, waypoint, self.settings.go_to)
        if command is not None:
            return Decision(self.phase, command)
        if self.phase == TO_TARGET:
            return self.finish(True, f"arrived within {self.settings.go_to.tolerance_m:g} m of the target "
                                     f"by dead reckoning, {estimate.distance_since_fix_m:.2f} m after the last fix")
        return self.start_search(estimate)

    def back_off(self) -> Decision:
        """The wheels stalled at a wall where the estimate saw none: it is off. Back off and ask tier one (a search
        under way ends unfound)."""
        progress = self.progress
        progress.stalls += 1
        self.stalled_steps = 0
        if self.phase == SEARCHING:
            progress.failed_searches += 1
            progress.search_length_m += self.travelled_m - self.search_start_m
            self.search = None
        if progress.stalls >= self.settings.max_stalls:
            return self.finish(False, f"stalled at a wall {progress.stalls} times: the position estimate keeps "
                                      f"driving the robot into walls")
        self.phase, self.back_off_from_m = BACKING_OFF, self.travelled_m
        return Decision(BACKING_OFF, (-BACK_OFF_SPEED_MPS, 0.0))

    def next_waypoint(self, position: Point, goal: Point) -> Point | None:
        """Where to drive next on the way to ``goal``: the goal itself without a floor plan, else the next waypoint
        of the path round the walls, planned again after every fix (the position it started from has moved); None
        when the walls close every way."""
        if self.planner is None:
            return goal
        key = (goal, len(self.progress.fixes))
        if key != self.route_key:
            route = self.planner.path(position, goal)
            if route is None:
                return None
            self.route, self.route_key = route, key
        while len(self.route) > 1 and math.dist(position, self.route[0]) <= self.settings.waypoint_tolerance_m:
            self.route.pop(0)
        return self.route[0]

    def distance_m(self, start: Point, goal: Point) -> float:
        """How far the robot drives from ``start`` to ``goal``: round the map's walls when it has them."""
        return math.dist(start, goal) if self.planner is None else self.planner.length(start, goal)

    def start_search(self, estimate: DeadReckoningEstimate) -> Decision:
        """A7: the landmark is not where dead reckoning says: spiral out from here until a tag is read."""
        landmark = self.waypoint
        radius = max(self.settings.search_min_radius_m, self.settings.search_radius_sigmas * estimate.sd_m)
        d = separation_for_group(landmark.shape, landmark.size_m, self.settings.read_range_m)
        self.search = SpiralSearch(d, self.settings.search_speed_mps, radius, estimate.position, estimate.yaw)
        self.search_start_m = self.travelled_m
        self.progress.searches += 1
        self.phase = SEARCHING
        return Decision(SEARCHING, self.search.command(0.0))

    # ------------------------------------------------------------------------------------------ route
    def next_leg(self) -> Decision:
        """Geographic forwarding (Fig. 4) from the fix just made."""
        here = self.reckoning.position
        remaining = self.distance_m(here, self.target)
        spacing = self.settings.landmark_spacing_m
        for landmark in self.landmarks.values():
            if landmark.group_id not in self.to_target_m:
                self.to_target_m[landmark.group_id] = self.distance_m(landmark.centre, self.target)
        candidates = [landmark for landmark in self.landmarks.values()
                      if self.to_target_m[landmark.group_id] < remaining - self.settings.read_range_m
                      and landmark.group_id not in self.progress.visited[-1:]
                      and math.dist(here, landmark.centre) <= spacing     # a path is no shorter: planned only
                      and self.distance_m(here, landmark.centre) <= spacing]   # for the landmarks this leaves
        target_landmark = next((mark for mark in self.landmarks.values() if self.target_is(mark)), None)
        if remaining <= spacing or not candidates:
            if target_landmark is not None:
                return self.head_for(target_landmark)
            self.waypoint, self.phase = None, TO_TARGET
            return self.drive()
        return self.head_for(min(candidates, key=lambda landmark: self.to_target_m[landmark.group_id]))

    def head_for(self, landmark: Landmark) -> Decision:
        self.waypoint, self.phase, self.search = landmark, TO_LANDMARK, None
        return self.drive()

    def resume(self) -> Decision:
        self.phase = TO_LANDMARK if self.waypoint is not None else TO_TARGET
        return self.drive()

    def nearest_landmark(self, position: tuple[float, float]) -> Landmark:
        return min(self.landmarks.values(), key=lambda landmark: math.dist(landmark.centre, position))

    def target_is(self, landmark: Landmark) -> bool:
        """The target is this landmark: within half the group's size of its centre."""
        return math.dist(landmark.centre, self.target) <= max(landmark.size_m / 2.0, self.settings.read_range_m)


def _text(point: Point | None) -> str:
    return "nowhere" if point is None else f"({point[0]:.2f}, {point[1]:.2f})"
