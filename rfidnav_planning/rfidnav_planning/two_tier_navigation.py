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

LOCATING, MAPPING, TO_LANDMARK, SEARCHING, TO_TARGET, DONE = (
    "locating", "mapping", "to_landmark", "searching", "to_target", "done")
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
    go_to: GoToSettings = field(default_factory=GoToSettings)

    def validate(self) -> None:
        for name in ("landmark_spacing_m", "calibration_distance_m", "deviation_threshold_m", "tag_map_radius_m",
                     "search_radius_sigmas", "search_min_radius_m", "search_speed_mps", "read_range_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ParameterError(name, f"must be a positive number, got {value}")
        if self.max_searches < 1:
            raise ParameterError("max_searches", f"must be at least 1, got {self.max_searches}")
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
    search_length_m: float = 0.0            # driven while searching
    tier_one_requests: int = 0
    unknown_tags: int = 0
    visited: list[str] = field(default_factory=list)   # landmarks fixed at, in order


class TwoTierNavigator:
    def __init__(self, settings: TwoTierSettings) -> None:
        settings.validate()
        self.settings = settings
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
        if not all(math.isfinite(v) for v in target):
            raise ValueError(f"target ({target[0]}, {target[1]}) is not a finite point")
        self.target = (float(target[0]), float(target[1]))
        self.progress = Progress()
        self.outcome = None
        if known_start is None:
            return self.ask(Request(LOCATE), LOCATING)
        self.fixed(known_start)
        return self.ask(Request(TAG_MAP, known_start.position, self.settings.tag_map_radius_m), MAPPING)

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
        if self.phase == SEARCHING or deviation > self.settings.deviation_threshold_m:
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
        if self.outcome is not None:
            return self.outcome
        if compass_yaw is not None:
            self.reckoning.on_compass(compass_yaw)
        self.reckoning.on_odometry(odom)
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
        if self.phase == SEARCHING:
            command = self.search.command(self.travelled_m - self.search_start_m)
            if command is None:
                self.progress.failed_searches += 1
                self.progress.search_length_m += self.travelled_m - self.search_start_m
                if self.progress.failed_searches >= self.settings.max_searches:
                    return self.finish(False, f"{self.progress.failed_searches} spiral searches found no tag")
                return self.ask(Request(LOCATE), SEARCHING)
            return Decision(SEARCHING, command)
        if self.travelled_m - self.checked_at_m > self.settings.calibration_distance_m:
            return self.ask(Request(LOCATE), self.phase)     # A5
        goal = self.waypoint.centre if self.phase == TO_LANDMARK else self.target
        command = go_to_command(estimate.position, estimate.yaw, goal, self.settings.go_to)
        if command is not None:
            return Decision(self.phase, command)
        if self.phase == TO_TARGET:
            return self.finish(True, f"arrived within {self.settings.go_to.tolerance_m:g} m of the target "
                                     f"by dead reckoning, {estimate.distance_since_fix_m:.2f} m after the last fix")
        return self.start_search(estimate)

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
        remaining = math.dist(here, self.target)
        spacing = self.settings.landmark_spacing_m
        candidates = [landmark for landmark in self.landmarks.values()
                      if math.dist(here, landmark.centre) <= spacing
                      and math.dist(landmark.centre, self.target) < remaining - self.settings.read_range_m
                      and landmark.group_id not in self.progress.visited[-1:]]
        target_landmark = next((mark for mark in self.landmarks.values() if self.target_is(mark)), None)
        if remaining <= spacing or not candidates:
            if target_landmark is not None:
                return self.head_for(target_landmark)
            self.waypoint, self.phase = None, TO_TARGET
            return self.drive()
        return self.head_for(min(candidates, key=lambda landmark: math.dist(landmark.centre, self.target)))

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
