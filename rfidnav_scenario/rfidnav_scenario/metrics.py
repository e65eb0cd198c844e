"""Metrics of a run from ground truth: tag-route tracking (paper 001 section V), partition navigation
(paper 000 section 6.2), two-tier fixes (paper 003) and topological missions (paper 004).

Used both on bags (``./rfidnav report``) and on in-process runs (``./rfidnav reproduce``), so the
figures of the two agree by construction.

* e(t): distance of the ground-truth position from the current desired segment, i.e. the segment
  between the ground projections of the last route tag whose read area the robot has entered and the next
  one, from the moment it (ground truth) enters the first tag's read area until it enters the last tag's;
  signed, positive to the left of the direction of travel. The stretch and its segments are decided by ground
  truth alone (:func:`area_entries`), not by the controller's declared arrivals, so every controller of a
  comparison is scored over the same stretch by the same rule.
* RMSE (eq. 4): sqrt(mean e(t)^2) over equally spaced samples; max |e|. A search for an unheard target (the
  follower's search modes: a turn on the spot and a spiral) follows no segment, and where it found the target the
  robot is metres off the route: the samples from the search's start until the robot enters the next route tag's
  read area (ground truth) are left out, and the searches reported apart: how many, their time and the distance
  driven in them.
* The approach: when the robot entered the first tag's read area, from the mission start; and the time to come
  within 1 cm of the first tag's projection (paper 001 sec. V-A's "within 1 cm").
* Path length from the mission start to the end.

Every mission kind ends at a place (the last route tag, the target point, the goal node) and its scenario declares
how near it the robot must stop (``mission.success_within_m``): a run's metrics say where it stopped
(``final_distance_m``, ``final_error_m``) and whether that is near enough (``success``, :func:`within_bound`).
Every run with ground truth also counts its wall crossings (:func:`wall_crossings`), and ground truth has the last
word on a run its mission's node called a success (:func:`ground_truth_objection`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from rfidnav_common.topological_map import RouteError, TopologicalMap

FIRST_TAG_RADIUS_M = 0.01
# A route tag's read area: where its floor tag is read (the arrival of paper 001's step 8). The shipped reader's floor
# antenna (config/params/reader_uhf_2ant.yaml: 5 cm up, 10 cm slant range, 60 degree half cone) reads a floor tag
# within sqrt(0.10^2 - 0.05^2) = 8.66 cm of it; the in-process runner passes its reader's own radius.
READ_AREA_RADIUS_M = 0.0866
ON_WALL_M = 1e-6           # a sample this close to a wall's line is on it: touching, neither side


@dataclass(frozen=True)
class Trajectory:
    times_s: np.ndarray      # N, increasing
    xy: np.ndarray           # N x 2, map frame

    def between(self, start_s: float, end_s: float) -> Trajectory:
        keep = (self.times_s >= start_s) & (self.times_s <= end_s)
        return Trajectory(self.times_s[keep], self.xy[keep])


def position_errors(truth: Trajectory, times_s: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """A localizer's position error at each of its estimates (``xy``, N x 2, stamped ``times_s``): the distance to
    the ground truth interpolated at the estimate's stamp. Estimates stamped outside the truth's span are left out."""
    times_s, xy = np.asarray(times_s, dtype=float), np.asarray(xy, dtype=float).reshape(-1, 2)
    inside = (times_s >= truth.times_s[0]) & (times_s <= truth.times_s[-1])
    at = times_s[inside]
    true_xy = np.column_stack([np.interp(at, truth.times_s, truth.xy[:, axis]) for axis in (0, 1)])
    return np.hypot(*(xy[inside] - true_xy).T)


def wall_crossings(xy: np.ndarray, walls: np.ndarray) -> int:
    """How many times the track ``xy`` (N x 2, the robot centre's ground truth) crosses one of ``walls`` (W x 4 rows
    x1, y1, x2, y2): from one side of a wall's line to the other through the wall itself.

    Samples within ON_WALL_M of a wall's line are on it and on neither side, so a track that touches a wall or
    stalls against it and comes back crosses nothing, and one that stops on the wall and goes on through crosses
    once. Between two samples on opposite sides the track crossed the line where the step between them meets it,
    or, with samples on the line between them, at those samples: through the wall if that point lies on the wall
    segment (its ends included). A track through the point where two walls meet crosses both."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    crossings = 0
    for x1, y1, x2, y2 in np.asarray(walls, dtype=float).reshape(-1, 4):
        start, direction = np.array([x1, y1]), np.array([x2 - x1, y2 - y1])
        length = float(np.hypot(*direction))
        if length == 0.0 or len(xy) < 2:
            continue
        relative = xy - start
        offset = (direction[0] * relative[:, 1] - direction[1] * relative[:, 0]) / length   # signed distance
        along = relative @ direction / length ** 2                                          # 0..1 on the wall
        side = np.where(np.abs(offset) <= ON_WALL_M, 0, np.sign(offset))
        off_line = np.flatnonzero(side)
        changes = np.flatnonzero(side[off_line[1:]] != side[off_line[:-1]])
        on_wall = np.concatenate(([0], np.cumsum((side == 0) & (along >= 0.0) & (along <= 1.0))))
        for before, after in zip(off_line[changes], off_line[changes + 1]):
            if after > before + 1:       # on the line between: through the wall if one of those points is on it
                crossings += int(on_wall[after] - on_wall[before + 1] > 0)
                continue
            fraction = offset[before] / (offset[before] - offset[after])
            crossings += int(0.0 <= along[before] + fraction * (along[after] - along[before]) <= 1.0)
    return crossings


def within_bound(final_distance_m: float | None, bound_m: float | None) -> bool | None:
    """Whether a run stopped near enough its goal: ``final_distance_m`` at most the scenario's ``bound_m``
    (``mission.success_within_m``); None when either is unknown (no track, or no criterion declared)."""
    if final_distance_m is None or bound_m is None or math.isnan(final_distance_m):
        return None
    return final_distance_m <= bound_m


def final_distance(metrics: Mapping[str, object]) -> float | None:
    """How far from where its mission ends a run stopped, under whichever name its kind's metrics give it
    (``final_distance_m``: tag routes, topological; ``final_error_m``: partitions, two-tier); None if unknown."""
    return next((value for key in ("final_distance_m", "final_error_m")
                 if isinstance(value := metrics.get(key), float)), None)


def success_verdict(metrics: Mapping[str, object], bound_m: float | None) -> dict[str, object]:
    """The keys a run's metrics gain from its scenario's ``success_within_m`` (``bound_m``): the bound and whether
    the run stopped within it (:func:`within_bound`)."""
    return {"success_within_m": bound_m, "success": within_bound(final_distance(metrics), bound_m)}


def ground_truth_objection(metrics: Mapping[str, object]) -> str | None:
    """Why ground truth says a run its mission's node called a success was none (None: it agrees): the metrics
    say it did not reach the goal (``success`` false: farther than ``success_within_m`` from it), or its track
    crossed a wall (``wall_crossings`` > 0)."""
    objections = []
    if metrics.get("success") is False:
        distance = final_distance(metrics)
        bound = metrics.get("success_within_m")
        objections.append("did not reach the goal (metrics.success false"
                          + (f", {distance:.2f} m from it" if distance is not None else "")
                          + (f", more than the scenario's {bound:g} m" if isinstance(bound, float) else "") + ")")
    crossings = metrics.get("wall_crossings")
    if isinstance(crossings, int) and crossings > 0:
        objections.append(f"made {crossings} wall crossing{'s' if crossings > 1 else ''} (metrics.wall_crossings)")
    return " and ".join(objections) or None


@dataclass(frozen=True)
class TrackingMetrics:
    tracking_rmse_m: float | None           # e(t) over the scored stretch, its searches left out
    tracking_max_abs_m: float | None
    time_to_first_tag_s: float | None
    path_length_m: float
    tags_reached: int                       # the controller's declared arrivals
    approach_s: float | None = None         # entered the first tag's read area (ground truth), from mission start
    scored_s: float | None = None           # the scored stretch's length in time: first read area to the last
    tags_entered: int = 0                   # route tags whose read area the robot entered, in order (ground truth)
    final_distance_m: float | None = None   # where the robot stopped, from the last route tag's projection
    searches: int = 0                       # searches for an unheard target (not tracking: left out of e(t))
    search_s: float = 0.0                   # their time
    search_length_m: float = 0.0            # the distance driven in them

    def as_dict(self) -> dict[str, float | int | None]:
        return dict(self.__dict__)


def in_spans(times_s: np.ndarray, spans: Sequence[tuple[float, float]]) -> np.ndarray:
    """Which of ``times_s`` fall in one of ``spans`` (start, end]: a sample, and the step that ends at it, belong to
    the span when taken after its start and up to its end."""
    times_s = np.asarray(times_s, dtype=float)
    inside = np.zeros(times_s.shape, dtype=bool)
    for start_s, end_s in spans:
        inside |= (times_s > start_s) & (times_s <= end_s)
    return inside


def flagged_spans(times_s: Sequence[float], flags: Sequence[bool], end_s: float) -> list[tuple[float, float]]:
    """The (start, end) spans of a mode from a stream of (time, in the mode) samples (a controller's feedback or
    commands): each starts at a flagged sample after an unflagged one (or the first) and ends at the next unflagged
    sample, or at ``end_s``."""
    spans: list[tuple[float, float]] = []
    start: float | None = None
    for time_s, flag in zip(times_s, flags):
        if flag and start is None:
            start = float(time_s)
        elif not flag and start is not None:
            spans.append((start, float(time_s)))
            start = None
    if start is not None:
        spans.append((start, float(end_s)))
    return spans


def signed_segment_error(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance from the segment start-end (clamped to it), signed positive on the left of start->end."""
    direction = end - start
    length_sq = float(direction @ direction)
    relative = points - start
    if length_sq == 0.0:
        return np.linalg.norm(relative, axis=1)
    t = np.clip((relative @ direction) / length_sq, 0.0, 1.0)
    distance = np.linalg.norm(relative - t[:, None] * direction, axis=1)
    side = np.sign(direction[0] * relative[:, 1] - direction[1] * relative[:, 0])
    return np.where(side == 0.0, 1.0, side) * distance


def area_entries(trajectory: Trajectory, tag_points: np.ndarray,
                 read_radius_m: float = READ_AREA_RADIUS_M) -> list[float]:
    """When the ground truth entered each route tag's read area (within ``read_radius_m`` of its ground
    projection), in route order: tag k's entry is the first sample inside its area at or after tag k-1's. The list
    ends at the first tag whose area was never entered after its predecessor's."""
    entries: list[float] = []
    after = -math.inf
    for point in np.asarray(tag_points, dtype=float).reshape(-1, 2):
        inside = np.flatnonzero((np.linalg.norm(trajectory.xy - point, axis=1) <= read_radius_m)
                                & (trajectory.times_s >= after))
        if not inside.size:
            break
        after = float(trajectory.times_s[inside[0]])
        entries.append(after)
    return entries


def tracking_error(trajectory: Trajectory, tag_points: np.ndarray,
                   read_radius_m: float = READ_AREA_RADIUS_M) -> Trajectory:
    """e(t) samples (as a Trajectory whose xy[:, 0] is e and xy[:, 1] the segment index) over the stretch ground
    truth decides (:func:`area_entries`): segment k from the entry into tag k's read area up to (not including) the
    entry into tag k+1's, the last segment up to and including the entry into the last area reached: the same
    stretch for every controller, whenever each declares its arrivals."""
    entries = area_entries(trajectory, tag_points, read_radius_m)
    times, errors, segments = [], [], []
    for k in range(len(entries) - 1):
        last = k == len(entries) - 2
        keep = (trajectory.times_s >= entries[k]) & ((trajectory.times_s <= entries[k + 1]) if last
                                                     else (trajectory.times_s < entries[k + 1]))
        times.append(trajectory.times_s[keep])
        errors.append(signed_segment_error(trajectory.xy[keep], tag_points[k], tag_points[k + 1]))
        segments.append(np.full(int(keep.sum()), k, dtype=float))
    if not times:
        return Trajectory(np.empty(0), np.empty((0, 2)))
    return Trajectory(np.concatenate(times), np.column_stack((np.concatenate(errors), np.concatenate(segments))))


def tracking_metrics(trajectory: Trajectory, tag_points: np.ndarray, arrival_times_s: list[float],
                     mission_start_s: float, mission_end_s: float, read_radius_m: float = READ_AREA_RADIUS_M,
                     searching: Sequence[tuple[float, float]] = ()) -> TrackingMetrics:
    """Metrics of one run; ``arrival_times_s[k]`` is when the controller declared route tag k reached (counted as
    tags_reached; the scored stretch is ground truth's, :func:`tracking_error`); ``searching``: the (start, end)
    times of each search for an unheard target (:func:`flagged_spans` of the follower's search modes): e(t) leaves
    out each search and the way back from where it ended, up to the next read-area entry (:func:`area_entries`)."""
    run = trajectory.between(mission_start_s, mission_end_s)
    scored = tracking_error(run, tag_points, read_radius_m=read_radius_m)
    entries = area_entries(run, tag_points, read_radius_m)
    left_out = np.zeros(scored.times_s.shape, dtype=bool)
    for start_s, end_s in searching:
        back_s = next((entry for entry in entries if entry > end_s), math.inf)     # in the next read area again
        left_out |= (scored.times_s > start_s) & (scored.times_s < back_s)
    error = scored.xy[~left_out, 0]
    rmse = float(np.sqrt(np.mean(error ** 2))) if error.size else None
    max_abs = float(np.max(np.abs(error))) if error.size else None
    near_first = np.nonzero(np.linalg.norm(run.xy - tag_points[0], axis=1) <= FIRST_TAG_RADIUS_M)[0]
    time_to_first = float(run.times_s[near_first[0]] - mission_start_s) if near_first.size else None
    steps = np.linalg.norm(np.diff(run.xy, axis=0), axis=1) if len(run.xy) > 1 else np.empty(0)
    return TrackingMetrics(rmse, max_abs, time_to_first, float(steps.sum()), len(arrival_times_s),
                           approach_s=entries[0] - mission_start_s if entries else None,
                           scored_s=entries[-1] - entries[0] if len(entries) > 1 else None,
                           tags_entered=len(entries),
                           final_distance_m=float(np.linalg.norm(run.xy[-1] - tag_points[-1])) if len(run.xy) else None,
                           searches=len(searching), search_s=float(sum(end - start for start, end in searching)),
                           search_length_m=float(steps[in_spans(run.times_s[1:], searching)].sum()))


@dataclass(frozen=True)
class PartitionMetrics:
    """Paper 000 section 6.2: extra navigation cost (l - |SD|) / |SD| with l the distance driven (ground
    truth) and SD the segment from the true start to the goal; where the robot stopped; re-plans."""
    extra_cost_pct: float | None
    final_error_m: float | None
    path_length_m: float
    straight_distance_m: float | None
    replans: int | None

    def as_dict(self) -> dict[str, float | int | None]:
        return dict(self.__dict__)


def partition_metrics(trajectory: Trajectory, mission_start_s: float, mission_end_s: float,
                      goal: tuple[float, float], replans: int | None) -> PartitionMetrics:
    run = trajectory.between(mission_start_s, mission_end_s)
    if len(run.xy) == 0:
        return PartitionMetrics(None, None, 0.0, None, replans)
    path_length = float(np.sum(np.linalg.norm(np.diff(run.xy, axis=0), axis=1))) if len(run.xy) > 1 else 0.0
    straight = float(np.linalg.norm(np.asarray(goal) - run.xy[0]))
    extra = 100.0 * (path_length - straight) / straight if straight > 0.0 else None
    return PartitionMetrics(extra, float(np.linalg.norm(run.xy[-1] - np.asarray(goal))), path_length, straight,
                            replans)


def travel_time_s(path_length_m: float, turned_rad: float, speed_mps: float, turn_rate_radps: float) -> float:
    """How long a robot that drives at ``speed_mps`` and turns on the spot at ``turn_rate_radps`` takes to drive
    ``path_length_m`` and turn through ``turned_rad`` in all (the sum of every turn's magnitude)."""
    return path_length_m / speed_mps + turned_rad / turn_rate_radps


def extra_time_cost_pct(path_length_m: float, turned_rad: float, straight_distance_m: float, speed_mps: float,
                        turn_rate_radps: float) -> float:
    """Paper 000's extra cost in time: (travel time - |SD| / speed) / (|SD| / speed) in percent, against driving
    the straight line at the same speed. A turn on the spot is free in (l - |SD|) / |SD|; here it costs its time,
    so a robot cannot buy its heading with spins the path length does not see."""
    straight_s = straight_distance_m / speed_mps
    return 100.0 * (travel_time_s(path_length_m, turned_rad, speed_mps, turn_rate_radps) - straight_s) / straight_s


@dataclass(frozen=True)
class Fix:
    """A tier-two fix as the navigator reported it (/localization/status): when, which tag, where it thought."""
    time_s: float
    tag_id: str
    estimate: tuple[float, float]


@dataclass(frozen=True)
class TwoTierMetrics:
    """Paper 003: the error of each tier-two fix (the estimate against ground truth at that instant), the
    worst, where the robot stopped, the distance driven, the spiral searches and their length."""
    fix_error_m: list[float]
    fix_error_median_m: float | None
    max_error_m: float | None
    final_error_m: float | None
    path_length_m: float
    searches: int
    search_length_m: float

    def as_dict(self) -> dict[str, float | int | list[float] | None]:
        return dict(self.__dict__)


def two_tier_metrics(trajectory: Trajectory, mission_start_s: float, mission_end_s: float, target: tuple[float, float],
                     fixes: list[Fix], searching: list[tuple[float, float]]) -> TwoTierMetrics:
    """``searching``: the (start, end) times of each spiral search, from the mission's feedback."""
    run = trajectory.between(mission_start_s, mission_end_s)
    if len(run.xy) == 0:
        return TwoTierMetrics([], None, None, None, 0.0, len(searching), 0.0)
    errors = []
    for fix in fixes:
        truth = (np.interp(fix.time_s, run.times_s, run.xy[:, 0]), np.interp(fix.time_s, run.times_s, run.xy[:, 1]))
        errors.append(float(np.hypot(fix.estimate[0] - truth[0], fix.estimate[1] - truth[1])))
    steps = np.linalg.norm(np.diff(run.xy, axis=0), axis=1)
    return TwoTierMetrics(errors, float(np.median(errors)) if errors else None, max(errors, default=None),
                          float(np.linalg.norm(run.xy[-1] - np.asarray(target))), float(steps.sum()),
                          len(searching), float(steps[in_spans(run.times_s[1:], searching)].sum()))


# Topological missions (paper 004): the robot has arrived when the executor says so AND it stopped this close to
# the goal node's position (a junction's centre; a 1.6 m hallway's half width plus a margin): the building
# scenarios' success_within_m, and the topological reproduction's.
GOAL_RADIUS_M = 0.5


@dataclass(frozen=True)
class TopologicalMetrics:
    path_length_m: float           # driven (ground truth), mission start to end
    shortest_path_m: float | None  # see topological_shortest_m
    path_over_shortest: float | None
    final_distance_m: float        # from the goal node's position
    tags_missed: int | None        # the executor's counts
    replans: int | None

    def as_dict(self) -> dict[str, float | int | None]:
        return dict(self.__dict__)


def topological_shortest_m(topological_map: TopologicalMap, start_xy: tuple[float, float], first_node: str,
                           arrival_side: str, goal_node: str) -> float:
    """What a robot that knew where it started would at least drive: it starts in the hallway entering
    ``first_node`` (the first node it localized at) by ``arrival_side``, so straight to either end of that
    hallway, then the shortest route by hallway length from there. RouteError if neither end has a route."""
    ends = [first_node]
    behind = topological_map.nodes[first_node].hallways[arrival_side].neighbour
    if behind in topological_map.nodes:
        ends.append(behind)
    lengths = []
    for end in ends:
        try:
            route = topological_map.route(end, goal_node, weight="length")
        except RouteError:
            continue
        along = sum(topological_map.hallway_length_m(a, topological_map.departure_direction(a, b, "length"))
                    for a, b in zip(route, route[1:]))
        lengths.append(math.dist(start_xy, topological_map.nodes[end].position) + along)
    if not lengths:
        raise RouteError(f"map '{topological_map.name}': no route to '{goal_node}' from either end of the hallway "
                         f"entering '{first_node}' by {arrival_side}")
    return min(lengths)


def topological_metrics(trajectory: Trajectory, mission_start_s: float, mission_end_s: float,
                        topological_map: TopologicalMap, goal_node: str,
                        first_arrival: tuple[str, str] | None, tags_missed: int | None,
                        replans: int | None) -> TopologicalMetrics:
    """``first_arrival``: the (node, arrival side) the robot first localized at (None: it never did)."""
    run = trajectory.between(mission_start_s, mission_end_s)
    goal_xy = np.asarray(topological_map.nodes[goal_node].position)
    if len(run.xy) == 0:
        return TopologicalMetrics(0.0, None, None, math.nan, tags_missed, replans)
    path = float(np.linalg.norm(np.diff(run.xy, axis=0), axis=1).sum())
    final = float(np.linalg.norm(run.xy[-1] - goal_xy))
    try:
        shortest = (topological_shortest_m(topological_map, tuple(run.xy[0]), *first_arrival, goal_node)
                    if first_arrival is not None else None)
    except RouteError:
        shortest = None            # the goal lies beyond "?" hallways of the given map: no shortest route known
    return TopologicalMetrics(path, shortest,
                              path / shortest if shortest else None, final, tags_missed, replans)
