"""Partition localization of paper 000 (sections 3-4), and a particle filter over the same observations.

Observations: one inventory round of the downward floor antenna (the tag ids read, in any order, possibly
repeated or junk) and the odometry pose at that time. Every tag id describes itself
(rfidnav_common.tag_lattice): the layout, the lattice spacing and the tag's lattice coordinate, hence its map
position and also the read range r (grid s = r*sqrt2, triangular s = r*sqrt3, compressed s = 1.5 r), so no
map file is needed. r is derived from the spacing, which the ids carry in whole micrometres rounded down:
it is at most a micrometre short of the deployment's r.

Paper method ("paper"):

* Location (sec. 4.1): the mean position of the tags read (the partition centre). Its covariance is the
  second moment, about that centre, of the partition's region (the points that read exactly those tags),
  so a consumer knows how far off the centre the robot may be.
* Orientation (sec. 4.2): while the robot drives straight it records the partitions it enters. The boundary
  between consecutive partitions A and B lies on the read circles of the tags whose membership differs;
  the points of those circles at which every other tag reads as it does in both A and B are the crossing
  points (the paper's "common vertices" of polygonal partitions, here the exact circular arcs and their end
  vertices). Start set: the crossing points between the first two partitions; end set: between the last
  two (with only two partitions the start set is the first partition's region, whose extreme directions
  lie on its boundary). The heading of a straight traversal is the direction of a segment from a start
  point to an end point, so the bounds are the smallest and largest such direction and the estimate is
  their mean. yaw_std is a quarter of the bounds' width (half-width / 2).
* Straight stretches: the odometry tells when the robot rotates. Once its heading has changed by more than
  ``turn_threshold_rad`` since the stretch began, a new stretch starts at the current partition and the
  heading is carried through the turn as the previous estimate plus the odometry's heading change (widened
  by the odometry's relative rotation error). Within a stretch the estimate is whichever is narrower of
  the carried bounds and the stretch's own partition bounds: right after a turn the region-to-boundary
  bound of the first partition change is often wider than what the robot already knew, and a partition
  bound is preferred only once it is tighter. The first stretch has nothing carried (the paper's case).

Particle filter ("filter", beyond the paper): particles over (x, y, yaw) of the robot's centre in the map
frame. The floor antenna may read ``antenna_offset_m`` ahead of the rotation axis: then a turn on the spot
sweeps it over partition boundaries and reveals the heading without driving anywhere (the navigator's spin
localization); the paper method keeps the antenna on the axis. Particles are initialised with their antennas
uniformly in the first partition's region and a uniform yaw, predicted with the odometry increment in the
robot frame (noise relative to the motion plus floors), weighted by a soft read model
P(read | d) = eps + (1 - 2 eps) * sigmoid((r - d) / softness) for each tag of the observed partition (read)
and for each tag near the particles that was not read, resampled (systematic, with a little roughening)
when the effective sample size falls below half. ``eps`` (``read_error_probability``) bounds what one
missed or spurious read can cost. A partition change that no particle explains (too few particles where
the robot is, typically while the heading is unknown) redraws the worst fifth of the particles (sensor
resetting): as poses that explain this crossing and an earlier one together (the odometry's displacement
between them fitted onto the two crossing arcs, which fixes the heading: see ``_paired_proposals``), or,
without an earlier crossing far enough away, on this crossing's arc headed within the paper's bounds when
the stretch has them. When no particle has explained the recent rounds (the best one keeps contradicting tags: a
kidnapped robot, or persistently bad reads) the filter re-initialises from the current partition, counts
it, and starts a new stretch (the heading is unknown again). An empty round is a prediction step only
(the robot moved; a missed round says nothing about where).

Both methods:

* Every id is decoded; undecodable ids are ignored and counted. The first round with decodable tags fixes
  the lattice (its most common lattice, ties to the smallest id); tags of another lattice are ignored and
  counted as undecodable, as the robot cannot place them in its frame.
* Rogue tags: the tags read together in one round lie within ``rogue_distance_factor`` * r of each other
  (2 r for a true partition: every tag is within r of the reader). The largest mutually consistent group is
  kept (ties: the group containing the tag closest to the previous estimate, or the smallest id before any
  estimate); the others are rejected and reported, so a single bad or mis-programmed tag cannot throw the
  robot across the room. A rogue tag read alone is not caught here.
* An empty round keeps the previous partition's estimate (partition empty), as the robot may be between
  reads or outside the deployment; the heading follows the odometry.
* ``partitions_traversed`` counts the partition changes since the current stretch began (the first
  partition counts 0), so a navigator's "localization phase of N partitions" works for both methods.
  ``partition_changed`` compares with the last non-empty partition (an empty round is a missed read, not a
  partition), and is true for the first partition ever seen.

Geometry (regions, crossing arcs) depends only on a partition's shape, as the lattice is invariant under
its own translations: it is computed once per shape and cached, so an update costs microseconds after the
first few.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from functools import lru_cache, partial
from typing import Callable, Sequence

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Coordinate, DecodedTag, Deployment, Lattice, TagIdError, decode_tag_id

METHODS = ("paper", "filter")
SPACING_PER_READ_RANGE = {"grid": math.sqrt(2.0), "triangular": math.sqrt(3.0), "compressed": 1.5}

Shape = tuple[Coordinate, ...]   # a partition's coordinates relative to its anchor (its smallest), sorted
YawEstimate = tuple[float, tuple[float, float], float]   # yaw, (lower, upper) bounds, standard deviation [rad]

CIRCLE_SAMPLES = 180             # points per read circle when sampling arcs (2 degrees)
REGION_GRID = 80                 # cells per axis of the grid that measures a region's moments
ON_CIRCLE_TOLERANCE = 1e-7       # relative to r: a point this close to a read circle counts as on it
# A region that no point satisfies (reads that contradict the disc geometry: a missed or an over-range read)
# is relaxed step by step: (factor on r for the tags read, whether the tags not read must stay unread).
REGION_RELAXATIONS = ((1.0, True), (1.0, False), (1.1, False), (1.25, False), (1.5, False), (2.0, False))
ROUGHENING = 0.2                 # Gordon et al.'s K: jitter = K * spread * N^(-1/3) per dimension
# The filter re-initialises when its best particle's recent evidence amounts to this many contradicted tags:
# its round log-likelihood summed with weights COLLAPSE_MEMORY^age. Two contradictions a round trip it on
# the second round, one a round on the fourth; an isolated missed or spurious read never does.
COLLAPSE_CONTRADICTIONS = 2.5
COLLAPSE_MEMORY = 0.7
# Sensor resetting: when no particle gives a partition crossing a likelihood above 1/4 (at a crossing the
# true pose gives each changed tag at least about 1/2), the worst fifth of the particles are redrawn on it.
RESET_LOG_LIKELIHOOD = math.log(0.25)
RESET_FRACTION = 0.2
# Paired proposals (see PartitionLocalizer._paired_proposals): the crossings remembered since the filter
# started (about a turn on the spot at r = 2 cm), the shortest odometry baseline paired with, in r, and how
# many of the longest baselines the proposals spread over (one bad crossing cannot capture them all).
CROSSING_MEMORY = 64
PAIR_MIN_BASELINE_R = 1.0
PAIR_CHOICES = 8
DECODE_CACHE_LIMIT = 200_000
BOUNDS_CACHE_LIMIT = 200_000     # orientation bounds kept per lattice (keyed by shapes and their offset)


def read_range_of(lattice: Lattice) -> float:
    """The tags' read range r implied by the lattice's layout and spacing [m].

    The ids carry the spacing floor(factor * r) in whole micrometres, which leaves r within an interval
    narrower than a micrometre: the whole number of micrometres in it when there is one (a deployment's r
    as configured), else the interval's lower end."""
    factor = SPACING_PER_READ_RANGE[lattice.layout]
    spacing_um = round(lattice.spacing_m * 1e6)
    whole_um = math.ceil(spacing_um / factor - 1e-9)
    if math.floor(factor * whole_um + 1e-6) == spacing_um:
        return whole_um / 1e6
    return lattice.spacing_m / factor


@dataclass(frozen=True)
class LocalizerSettings:
    method: str = "paper"                    # "paper" | "filter"
    turn_threshold_rad: float = 0.05         # odometry heading change that ends a straight stretch
    particles: int = 500
    motion_noise_fraction: float = 0.02      # odometry translation/rotation noise, relative
    motion_noise_floor_m: float = 0.001      # translation noise added to every step that moves [m]
    motion_noise_yaw_rad_per_m: float = 0.02  # heading noise per metre travelled (wheel slip) [rad/m]
    boundary_softness_m: float = 0.004       # width of the soft read/no-read edge of a disc in the filter's likelihood
    read_error_probability: float = 0.01     # filter: chance a tag's read/no-read contradicts the geometry
    rogue_distance_factor: float = 2.0       # tags read together lie within factor * r of each other
    antenna_offset_m: float = 0.0            # floor antenna ahead of the rotation axis (filter only; see below)
    # The tagged area from the robot map, when known: the filter then expects no read of a lattice vertex
    # outside the deployment (there is no tag there). Positions still come from the ids alone.
    deployment_area: tuple[float, float, float, float] | None = None

    def validate(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method: '{self.method}' is not one of {', '.join(METHODS)}")
        if self.particles < 10:
            raise ValueError(f"particles: at least 10 needed, got {self.particles}")
        for name in ("turn_threshold_rad", "boundary_softness_m", "rogue_distance_factor"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: must be a positive number, got {value}")
        for name in ("motion_noise_fraction", "motion_noise_floor_m", "motion_noise_yaw_rad_per_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name}: must be a non-negative number, got {value}")
        if not 0.0 < self.read_error_probability < 0.5:
            raise ValueError(f"read_error_probability: must lie in (0, 0.5), got {self.read_error_probability}")
        if not math.isfinite(self.antenna_offset_m) or (self.method == "paper" and self.antenna_offset_m != 0.0):
            raise ValueError("antenna_offset_m: the paper method reads at the rotation axis (0); the filter takes "
                             f"any finite offset, got {self.antenna_offset_m}")


@dataclass(frozen=True)
class LocalizationEstimate:
    stamp_s: float
    method: str
    partition: frozenset[Coordinate]          # accepted tags' lattice coordinates (empty: nothing read this round)
    partition_tag_ids: tuple[str, ...]        # sorted
    partition_changed: bool                   # this update entered a partition other than the last one seen
    partitions_traversed: int                 # partition changes since the current straight stretch began
    position: tuple[float, float] | None      # map frame [m]; None before any valid tag
    position_covariance: tuple[float, float, float]   # (var_x, cov_xy, var_y) [m^2]
    yaw: float | None                         # [rad] in (-pi, pi]; None until estimable
    yaw_bounds: tuple[float, float] | None    # (lower, upper) [rad], lower <= yaw <= upper, may leave (-pi, pi]
    yaw_std: float | None                     # [rad]
    read_range_m: float | None
    lattice: Lattice | None
    rejected_tag_ids: tuple[str, ...]         # rogue tags rejected this round, sorted
    rogue_count: int                          # rogue reads rejected since start (or reset)
    undecodable_count: int                    # ids ignored since start: not lattice ids, or another lattice
    filter_reinitialisations: int = 0         # times the particle filter lost track and restarted


# ------------------------------------------------------------------------------------------- geometry

def _circle_points(centres: np.ndarray, radius: float) -> np.ndarray:
    """CIRCLE_SAMPLES points on each circle: (len(centres) * CIRCLE_SAMPLES) x 2."""
    angles = np.linspace(0.0, 2.0 * math.pi, CIRCLE_SAMPLES, endpoint=False)
    ring = radius * np.column_stack((np.cos(angles), np.sin(angles)))
    return (centres[:, None, :] + ring[None, :, :]).reshape(-1, 2)


def _circle_intersections(centres: np.ndarray, radius: float) -> np.ndarray:
    """Every intersection point of every pair of the equal circles around ``centres``."""
    points = []
    for k in range(len(centres)):
        for m in range(k + 1, len(centres)):
            chord = centres[m] - centres[k]
            distance = float(np.hypot(*chord))
            if 0.0 < distance <= 2.0 * radius:
                middle = centres[k] + chord / 2.0
                half = math.sqrt(max(radius * radius - distance * distance / 4.0, 0.0))
                normal = np.array((-chord[1], chord[0])) / distance
                points.extend((middle + half * normal, middle - half * normal))
    return np.array(points).reshape(-1, 2)


def _satisfies(points: np.ndarray, inside: np.ndarray, inside_radius: float, outside: np.ndarray,
               radius: float) -> np.ndarray:
    """Which points are within ``inside_radius`` of every ``inside`` centre and at least ``radius`` from every
    ``outside`` centre, a point on a circle counting as both (so arc ends and vertices qualify)."""
    tolerance = ON_CIRCLE_TOLERANCE * radius
    keep = np.ones(len(points), dtype=bool)
    for centres, limit, within in ((inside, inside_radius, True), (outside, radius, False)):
        if len(centres):
            distance = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=2)
            keep &= np.all(distance <= limit + tolerance if within else distance >= limit - tolerance, axis=1)
    return keep


@dataclass(frozen=True)
class Region:
    """The region of a partition, relative to its anchor tag: the points within ``inside_radius`` of every
    ``inside`` tag and beyond r of every ``outside`` tag: exactly the partition unless its reads contradict
    the disc geometry (see REGION_RELAXATIONS)."""
    inside: np.ndarray
    inside_radius: float
    outside: np.ndarray
    read_range_m: float
    box: tuple[float, float, float, float]   # x_min, y_min, x_max, y_max of the region (a cell wider)
    centroid: np.ndarray                     # mean point of the region
    covariance: np.ndarray                   # 2 x 2, uniform over the region, about its centroid
    boundary: np.ndarray                     # points on its boundary arcs and their vertices

    def contains(self, points: np.ndarray) -> np.ndarray:
        keep = np.ones(len(points), dtype=bool)
        for centre in self.inside:
            keep &= np.sum((points - centre) ** 2, axis=1) <= self.inside_radius ** 2
        for centre in self.outside:
            keep &= np.sum((points - centre) ** 2, axis=1) > self.read_range_m ** 2
        return keep

    def sample(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` points uniform in the region (rejection sampling in its box)."""
        x_min, y_min, x_max, y_max = self.box
        found: list[np.ndarray] = []
        total = 0
        while total < count:
            proposals = rng.uniform((x_min, y_min), (x_max, y_max), size=(4 * count, 2))
            accepted = proposals[self.contains(proposals)]
            found.append(accepted)
            total += len(accepted)
        return np.concatenate(found)[:count]


def _grid(box: tuple[float, float, float, float]) -> tuple[np.ndarray, float, float]:
    x_min, y_min, x_max, y_max = box
    cell_x, cell_y = (x_max - x_min) / REGION_GRID, (y_max - y_min) / REGION_GRID
    xs = x_min + (np.arange(REGION_GRID) + 0.5) * cell_x
    ys = y_min + (np.arange(REGION_GRID) + 0.5) * cell_y
    gx, gy = np.meshgrid(xs, ys)
    return np.column_stack((gx.ravel(), gy.ravel())), cell_x, cell_y


def _build_region(inside: np.ndarray, inside_radius: float, outside: np.ndarray, r: float) -> Region | None:
    """Measure the region on a grid (refined once around what it finds); None when the grid finds nothing."""
    box = (float(np.max(inside[:, 0])) - inside_radius, float(np.max(inside[:, 1])) - inside_radius,
           float(np.min(inside[:, 0])) + inside_radius, float(np.min(inside[:, 1])) + inside_radius)
    if box[2] <= box[0] or box[3] <= box[1]:
        return None
    probe = Region(inside, inside_radius, outside, r, box, np.zeros(2), np.zeros((2, 2)), np.zeros((0, 2)))
    for _ in range(2):
        points, cell_x, cell_y = _grid(box)
        points = points[probe.contains(points)]
        if not len(points):
            return None
        # Refine to the box of what was found, one cell wider on each side, for resolution and sampling.
        box = (float(points[:, 0].min()) - cell_x, float(points[:, 1].min()) - cell_y,
               float(points[:, 0].max()) + cell_x, float(points[:, 1].max()) + cell_y)
    centroid = points.mean(axis=0)
    # Each grid point stands for its cell: add the cell's own spread (uniform: width^2 / 12).
    covariance = np.cov(points.T, bias=True).reshape(2, 2) + np.diag((cell_x ** 2 / 12.0, cell_y ** 2 / 12.0))
    # Relaxed regions (inside_radius != r) have no outside tags, so all circles of one region share a radius.
    circles, radius = (np.concatenate((inside, outside)), r) if len(outside) else (inside, inside_radius)
    candidates = np.concatenate((_circle_points(circles, radius), _circle_intersections(circles, radius)))
    boundary = candidates[_satisfies(candidates, inside, inside_radius, outside, r)]
    return Region(inside, inside_radius, outside, r, box, centroid, covariance, boundary)


class PartitionGeometry:
    """Regions and crossing arcs of the partitions of one lattice and read range, cached per shape."""

    def __init__(self, lattice: Lattice, read_range_m: float) -> None:
        self.lattice = lattice
        self.read_range_m = read_range_m
        self._regions: dict[Shape, Region] = {}
        self._locations: dict[Shape, tuple[tuple[float, float], tuple[float, float, float]]] = {}
        self._crossings: dict[tuple[frozenset[Coordinate], frozenset[Coordinate]], np.ndarray | None] = {}
        self._bounds: dict[tuple[frozenset[Coordinate], ...], tuple[float, float] | None] = {}

    @staticmethod
    def anchored(coordinates: frozenset[Coordinate] | set[Coordinate]) -> tuple[Coordinate, Shape]:
        if not coordinates:
            raise ValueError("an empty partition has no geometry")
        anchor = min(coordinates)
        return anchor, tuple(sorted((i - anchor[0], j - anchor[1]) for i, j in coordinates))

    def _near(self, centres: np.ndarray, radius: float) -> set[Coordinate]:
        found: set[Coordinate] = set()
        for x, y in centres:
            found.update(self.lattice.within(float(x), float(y), radius))
        return found

    def location(self, partition: frozenset[Coordinate]) -> tuple[tuple[float, float], tuple[float, float, float]]:
        """Paper 000 sec. 4.1: the mean of the tags' positions; with the second moment of the partition's region
        about it, (var_x, cov_xy, var_y)."""
        anchor, shape = self.anchored(partition)
        if shape not in self._locations:
            region = self.region(partition)[1]
            tag_mean = self.lattice.positions(np.array(shape)).mean(axis=0)
            bias = region.centroid - tag_mean
            moment = region.covariance + np.outer(bias, bias)
            self._locations[shape] = ((float(tag_mean[0]), float(tag_mean[1])),
                                      (float(moment[0, 0]), float(moment[0, 1]), float(moment[1, 1])))
        (x, y), covariance = self._locations[shape]
        anchor_x, anchor_y = self.lattice.position(anchor)
        return (anchor_x + x, anchor_y + y), covariance

    def region(self, partition: frozenset[Coordinate]) -> tuple[np.ndarray, Region]:
        """(anchor position, region relative to it) of a partition."""
        anchor, shape = self.anchored(partition)
        region = self._regions.get(shape)
        if region is None:
            region = self._regions[shape] = self._make_region(shape)
        return np.array(self.lattice.position(anchor)), region

    def _make_region(self, shape: Shape) -> Region:
        r = self.read_range_m
        inside = self.lattice.positions(np.array(shape))
        centroid = inside.mean(axis=0)
        # Every point of the region is within r of the tags' centroid (a convex combination of points within
        # r), so only tags within 2 r of it can read there.
        others = sorted(self._near(centroid[None, :], 2.0 * r * (1.0 + 1e-9)) - set(shape))
        outside = self.lattice.positions(np.array(others)) if others else np.zeros((0, 2))
        for factor, exclusive in REGION_RELAXATIONS:
            region = _build_region(inside, factor * r, outside if exclusive else np.zeros((0, 2)), r)
            if region is not None:
                return region
        # Tags too far apart to share a point (a rogue factor above 4): the disc around their centroid.
        return _build_region(centroid[None, :], r, np.zeros((0, 2)), r)

    def crossing_arc(self, before: frozenset[Coordinate], after: frozenset[Coordinate]) -> np.ndarray | None:
        """Points (map frame) where a robot going from partition ``before`` into ``after`` can cross: on the
        circle of a tag whose membership differs, where every tag in both reads and every other tag does not
        (tags that differ too are left free: a partition skipped between two rounds only widens the set).
        None when there is no such point: the partitions do not touch (contradictory reads, a kidnapping)."""
        anchor, _ = self.anchored(before | after)
        shifted_before = frozenset((i - anchor[0], j - anchor[1]) for i, j in before)
        shifted_after = frozenset((i - anchor[0], j - anchor[1]) for i, j in after)
        key = (shifted_before, shifted_after)
        if key not in self._crossings:
            self._crossings[key] = self._make_crossing(shifted_before, shifted_after)
        points = self._crossings[key]
        return None if points is None else np.array(self.lattice.position(anchor)) + points

    def crossing_points(self, before: frozenset[Coordinate], after: frozenset[Coordinate]) -> np.ndarray:
        """The crossing arc, or for partitions that do not touch, both regions' boundaries."""
        arc = self.crossing_arc(before, after)
        if arc is None:
            return np.concatenate([origin + region.boundary for origin, region in (self.region(before),
                                                                                   self.region(after))])
        return arc

    def orientation_bounds(self, partitions: Sequence[frozenset[Coordinate]]) -> tuple[float, float] | None:
        """See the module function :func:`orientation_bounds` (at least 2 partitions)."""
        # Only the first two and the last two partitions matter, and directions do not change when they are
        # all shifted together: cache by their shapes relative to the first partition's anchor.
        relevant = (*partitions[:2], *partitions[-2:]) if len(partitions) >= 3 else tuple(partitions)
        anchor = min(partitions[0])
        key = tuple(frozenset((i - anchor[0], j - anchor[1]) for i, j in p) for p in relevant)
        if key not in self._bounds:
            if len(self._bounds) >= BOUNDS_CACHE_LIMIT:
                self._bounds.clear()
            self._bounds[key] = self._make_bounds(partitions[0], partitions[1], partitions[-2], partitions[-1],
                                                  len(partitions))
        return self._bounds[key]

    def _make_bounds(self, first: frozenset[Coordinate], second: frozenset[Coordinate],
                     second_last: frozenset[Coordinate], last: frozenset[Coordinate],
                     count: int) -> tuple[float, float] | None:
        r = self.read_range_m
        ends = self.crossing_points(second_last, last)
        first_origin, first_region = self.region(first)
        if count == 2:
            return direction_bounds(first_origin + first_region.boundary, ends, r)
        starts = self.crossing_points(first, second)
        bounds = direction_bounds(starts, ends, r)
        if bounds is not None:
            return bounds
        # The first and the last crossing are one point: the robot passed a lattice vertex through the
        # partitions between (degenerate, point-sized partitions). The line came from the first partition
        # and went on into the last one.
        last_origin, last_region = self.region(last)
        return direction_bounds(np.concatenate((first_origin + first_region.boundary, starts)),
                                np.concatenate((ends, last_origin + last_region.boundary)), r)

    def _make_crossing(self, before: frozenset[Coordinate], after: frozenset[Coordinate]) -> np.ndarray | None:
        r = self.read_range_m
        differing = sorted(before ^ after)
        common = sorted(before & after)
        circles = self.lattice.positions(np.array(differing))
        others = sorted(self._near(circles, 2.0 * r * (1.0 + 1e-9)) - before - after)
        inside = self.lattice.positions(np.array(common)) if common else np.zeros((0, 2))
        outside = self.lattice.positions(np.array(others)) if others else np.zeros((0, 2))
        candidates = np.concatenate((_circle_points(circles, r),
                                     _circle_intersections(np.concatenate((circles, inside, outside)), r)))
        # An intersection point qualifies only on a differing tag's circle.
        on_differing = np.min(np.abs(np.linalg.norm(candidates[:, None, :] - circles[None, :, :], axis=2) - r),
                              axis=1) <= ON_CIRCLE_TOLERANCE * r
        points = candidates[on_differing & _satisfies(candidates, inside, r, outside, r)]
        return points if len(points) else None


@lru_cache(maxsize=16)
def partition_geometry(lattice: Lattice, read_range_m: float) -> PartitionGeometry:
    return PartitionGeometry(lattice, read_range_m)


def direction_bounds(starts: np.ndarray, ends: np.ndarray, scale: float) -> tuple[float, float] | None:
    """Smallest and largest direction of a segment from a start point to an end point: (lower, upper) with
    lower in (-pi, pi] and upper >= lower; None when every pair coincides (closer than 1e-9 * ``scale``)."""
    vectors = (ends[None, :, :] - starts[:, None, :]).reshape(-1, 2)
    vectors = vectors[np.einsum("ij,ij->i", vectors, vectors) > (1e-9 * scale) ** 2]
    if not len(vectors):
        return None
    mean = vectors.mean(axis=0)
    norm = math.hypot(mean[0], mean[1])
    # Fast path: directions within a half-turn form a cone that contains their mean vector, so measured
    # from it they neither wrap nor span pi.
    if norm > 0.0:
        reference = math.atan2(mean[1], mean[0])
        ux, uy = mean / norm
        along = vectors @ np.array((ux, uy))
        across = vectors @ np.array((-uy, ux))
        if along.min() > 0.0:
            # Within a quarter-turn of the mean, tan(angle from it) = across / along is monotonic.
            ratio = across / along
            low, high = math.atan(float(ratio.min())), math.atan(float(ratio.max()))
        else:
            relative = np.arctan2(across, along)
            low, high = float(relative.min()), float(relative.max())
        if high - low < math.pi:
            lower = wrap_angle(reference + low)
            return lower, lower + (high - low)
    # Wide spread: the bounds are the ends of the complement of the largest gap between directions.
    ordered = np.sort(np.arctan2(vectors[:, 1], vectors[:, 0]))
    gaps = np.diff(np.append(ordered, ordered[0] + 2.0 * math.pi))
    widest = int(np.argmax(gaps))
    lower = wrap_angle(float(ordered[(widest + 1) % len(ordered)]))
    return lower, lower + 2.0 * math.pi - float(gaps[widest])


def orientation_bounds(lattice: Lattice, read_range_m: float,
                       partitions: Sequence[frozenset[Coordinate]]) -> tuple[float, float] | None:
    """Paper 000 sec. 4.2 for a straight traversal through ``partitions`` in order (consecutive entries
    differ, none empty): bounds (lower, upper) on its heading [rad], lower in (-pi, pi], upper >= lower;
    None with fewer than 2 partitions."""
    if len(partitions) < 2:
        return None
    return partition_geometry(lattice, read_range_m).orientation_bounds(partitions)


# ------------------------------------------------------------------------------------------ rogue tags

def _maximum_cliques(adjacent: list[set[int]]) -> list[set[int]]:
    """Every largest set of mutually adjacent vertices (Bron-Kerbosch with pivoting; rounds read few tags)."""
    best: list[set[int]] = []

    def extend(clique: set[int], candidates: set[int], excluded: set[int]) -> None:
        nonlocal best
        if not candidates and not excluded:
            if not best or len(clique) > len(best[0]):
                best = [clique]
            elif len(clique) == len(best[0]):
                best.append(clique)
            return
        pivot = max(candidates | excluded, key=lambda v: len(adjacent[v] & candidates))
        for vertex in list(candidates - adjacent[pivot]):
            extend(clique | {vertex}, candidates & adjacent[vertex], excluded & adjacent[vertex])
            candidates = candidates - {vertex}
            excluded = excluded | {vertex}

    extend(set(), set(range(len(adjacent))), set())
    return best


def consistent_group(positions: Sequence[tuple[float, float]], limit_m: float,
                     previous: tuple[float, float] | None) -> list[int]:
    """Indices of the largest group of points (in the caller's tie-break order) within ``limit_m`` of each
    other; ties go to the group holding the point closest to ``previous`` (else the earliest point)."""
    count = len(positions)
    limit = limit_m * (1.0 + 1e-9)
    # Plain Python: a round reads a handful of tags, for which numpy's call overhead dominates.
    adjacent = [{m for m in range(count) if m != k and math.dist(positions[k], positions[m]) <= limit}
                for k in range(count)]
    if all(len(neighbours) == count - 1 for neighbours in adjacent):
        return list(range(count))
    groups = _maximum_cliques(adjacent)
    if previous is not None:
        chosen = min(groups, key=lambda group: min(math.dist(positions[k], previous) for k in group))
    else:
        chosen = min(groups, key=min)
    return sorted(chosen)


# ---------------------------------------------------------------------------------------- the localizer

@dataclass(frozen=True)
class _Crossing:
    """A partition boundary crossed: where in the map (the crossing arc) and where in the odometry frame
    (the antenna at the round before and at the round that saw the new partition: it crossed in between)."""
    arc: np.ndarray
    antenna_before: np.ndarray
    antenna_after: np.ndarray

    def antenna_at(self, fractions: np.ndarray) -> np.ndarray:
        """Odometry-frame antenna positions (count x 2) at these fractions of the round's motion."""
        return self.antenna_before + fractions[:, None] * (self.antenna_after - self.antenna_before)


@dataclass
class _Stretch:
    """A straight stretch: the partitions entered (in order) and the odometry headings seen during it."""
    start_odom_yaw: float
    partitions: list[frozenset[Coordinate]]
    yaw_change_sum: float = 0.0
    updates: int = 0

    @property
    def mean_odom_yaw(self) -> float:
        return self.start_odom_yaw + (self.yaw_change_sum / self.updates if self.updates else 0.0)


@dataclass(frozen=True)
class _Heading:
    """A heading belief held relative to the odometry (map yaw = odometry yaw + offset), so it follows turns."""
    offset: float        # [rad]
    half_width: float    # half the width of the bounds [rad]

    def widened(self, by: float) -> _Heading:
        return replace(self, half_width=min(self.half_width + by, math.pi))


@dataclass(frozen=True)
class _Observation:
    partition: frozenset[Coordinate]
    tag_ids: tuple[str, ...]
    rejected_ids: tuple[str, ...]
    rejected: frozenset[Coordinate]     # read but rejected: neither evidence of reading nor of not reading


class ParticleFilter:
    """Particles over (x, y, yaw) in the map frame, with normalised weights. Headings are not wrapped: every
    use of them is circular (sin, cos)."""

    def __init__(self, settings: LocalizerSettings, rng: np.random.Generator) -> None:
        self.settings = settings
        self.rng = rng
        self.states = np.zeros((3, settings.particles))   # rows x, y, yaw: contiguous per coordinate
        self.weights = np.full(settings.particles, 1.0 / settings.particles)
        self.evidence = 0.0   # the best particle's recent log-likelihood (see COLLAPSE_MEMORY)
        self._antennas: np.ndarray | None = None
        self.resets = 0       # sensor resettings (see weigh)

    def initialise(self, origin: np.ndarray, region: Region) -> None:
        """Antennas uniform in the partition's region, headings uniform; the centres behind the antennas."""
        count = self.settings.particles
        self.states[:2] = (origin + region.sample(self.rng, count)).T
        self.states[2] = self.rng.uniform(-math.pi, math.pi, count)
        self.states[:2] -= self.settings.antenna_offset_m * np.vstack((np.cos(self.states[2]), np.sin(self.states[2])))
        self._antennas = None
        self.weights.fill(1.0 / count)
        self.evidence = 0.0

    def predict(self, forward: float, lateral: float, rotation: float) -> None:
        """Move every particle by the odometry increment (robot frame of the previous pose), with noise."""
        distance = math.hypot(forward, lateral)
        if distance == 0.0 and rotation == 0.0:
            return   # standing still: odometry adds no uncertainty
        s = self.settings
        translation_sd = s.motion_noise_fraction * distance + s.motion_noise_floor_m
        rotation_sd = s.motion_noise_fraction * abs(rotation) + s.motion_noise_yaw_rad_per_m * distance
        noise = self.rng.standard_normal((3, self.states.shape[1]))
        dx = forward + translation_sd * noise[0]
        dy = lateral + translation_sd * noise[1]
        x, y, yaw = self.states
        cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
        x += cos_yaw * dx - sin_yaw * dy
        y += sin_yaw * dx + cos_yaw * dy
        yaw += rotation + rotation_sd * noise[2]
        self._antennas = None

    def antenna(self, states: np.ndarray) -> np.ndarray:
        """Where each state's floor antenna reads (2 x count): ``antenna_offset_m`` ahead of the robot's centre."""
        offset = self.settings.antenna_offset_m
        if offset == 0.0:
            return states[:2]
        return states[:2] + offset * np.vstack((np.cos(states[2]), np.sin(states[2])))

    def antennas(self) -> np.ndarray:
        """The particles' antennas, computed once per change of the states (several uses a round)."""
        if self._antennas is None:
            self._antennas = self.antenna(self.states)
        return self._antennas

    def bounding_circle(self) -> tuple[float, float, float]:
        """(x, y, radius) of a circle holding every particle's antenna: the centre and half-diagonal of their box."""
        antennas = self.antennas()
        low, high = antennas.min(axis=1), antennas.max(axis=1)
        centre = (low + high) / 2.0
        return float(centre[0]), float(centre[1]), float(np.hypot(*(high - low)) / 2.0)

    def log_likelihood(self, antennas: np.ndarray, read: np.ndarray, unread: np.ndarray,
                       read_range_m: float) -> np.ndarray:
        """log P(this round's reads | particle) for antennas (2 x count) under the soft read model."""
        s = self.settings
        tags = np.concatenate((read, unread))
        sign = np.concatenate((np.ones(len(read)), -np.ones(len(unread))))
        dx = antennas[0][:, None] - tags[:, 0]
        dy = antennas[1][:, None] - tags[:, 1]
        distance = np.sqrt(dx * dx + dy * dy)    # not np.hypot: its overflow care costs twice the rest here
        margin = sign * ((read_range_m - distance) / s.boundary_softness_m)
        # log(eps + (1 - 2 eps) * sigmoid(margin)); tanh keeps the sigmoid from overflowing.
        eps = s.read_error_probability
        return np.log(eps + (1.0 - 2.0 * eps) * 0.5 * (1.0 + np.tanh(0.5 * margin))).sum(axis=1)

    def weigh(self, read: np.ndarray, unread: np.ndarray, read_range_m: float,
              proposals: Callable[[int], np.ndarray] | None = None) -> bool:
        """Bayes update with the soft read model; False (weights untouched) when no particle has explained the
        recent rounds.

        ``proposals(count)`` (3 x count states consistent with this round) is for a partition boundary just
        crossed: when no particle explains the crossing (starvation: too few particles where the robot is,
        typically while the heading is still unknown), the worst RESET_FRACTION are replaced by proposals
        (sensor resetting, Lenser and Veloso 2000). A filter that tracks well is left alone."""
        eps = self.settings.read_error_probability
        log_likelihood = self.log_likelihood(self.antennas(), read, unread, read_range_m)
        if proposals is not None and log_likelihood.max() < RESET_LOG_LIKELIHOOD:
            count = round(RESET_FRACTION * len(self.weights))
            worst = np.argpartition(log_likelihood, count)[:count]
            self.states[:, worst] = proposals(count)
            self._antennas = None
            self.weights[worst] = 1.0 / len(self.weights)
            log_likelihood[worst] = self.log_likelihood(self.antennas()[:, worst], read, unread, read_range_m)
            self.resets += 1
        best = float(log_likelihood.max())
        self.evidence = COLLAPSE_MEMORY * self.evidence + best
        if self.evidence < COLLAPSE_CONTRADICTIONS * math.log(eps):
            return False
        weights = self.weights * np.exp(log_likelihood - best)
        self.weights = weights / weights.sum()
        if 1.0 / float(self.weights @ self.weights) < 0.5 * len(self.weights):
            self.resample()
        return True

    def resample(self) -> None:
        """Systematic resampling, then roughening (Gordon et al. 1993) so duplicates spread apart again."""
        count = len(self.weights)
        positions = (self.rng.random() + np.arange(count)) / count
        cumulative = np.cumsum(self.weights)
        cumulative[-1] = 1.0
        self.states = self.states[:, np.searchsorted(cumulative, positions)]
        yaw = self.states[2]
        yaw_mean = math.atan2(np.sin(yaw).mean(), np.cos(yaw).mean())
        yaw_offsets = np.remainder(yaw - yaw_mean + math.pi, 2.0 * math.pi) - math.pi
        spread = np.array((np.ptp(self.states[0]), np.ptp(self.states[1]), np.ptp(yaw_offsets)))
        self.states += self.rng.standard_normal((3, count)) * (ROUGHENING * count ** (-1.0 / 3.0) * spread)[:, None]
        self._antennas = None
        self.weights.fill(1.0 / count)

    def estimate(self) -> tuple[tuple[float, float], tuple[float, float, float], float, float]:
        """(position, (var_x, cov_xy, var_y), circular mean yaw, circular sd of yaw)."""
        w = self.weights
        x, y, yaw = self.states
        mean_x, mean_y = float(w @ x), float(w @ y)
        dx, dy = x - mean_x, y - mean_y
        sin_mean, cos_mean = float(w @ np.sin(yaw)), float(w @ np.cos(yaw))
        resultant = min(math.hypot(sin_mean, cos_mean), 1.0)
        yaw_sd = math.sqrt(-2.0 * math.log(resultant)) if resultant > 1e-12 else math.pi
        return ((mean_x, mean_y), (float(w @ (dx * dx)), float(w @ (dx * dy)), float(w @ (dy * dy))),
                wrap_angle(math.atan2(sin_mean, cos_mean)), yaw_sd)


class PartitionLocalizer:
    """Localization from the partitions read, by the paper's method or a particle filter (module docstring)."""

    def __init__(self, settings: LocalizerSettings, rng: np.random.Generator) -> None:
        settings.validate()
        self.settings = settings
        self.rng = rng
        self._decoded: dict[str, DecodedTag | None] = {}
        self.reset()

    def reset(self) -> None:
        """Forget everything observed (the lattice too); settings and the random stream go on."""
        self.lattice: Lattice | None = None
        self.read_range_m: float | None = None
        self._geometry: PartitionGeometry | None = None
        self._deployment: Deployment | None = None
        self._last_partition: frozenset[Coordinate] = frozenset()
        self._last_odom: tuple[float, float, float] | None = None
        self._stretch: _Stretch | None = None
        self._position: tuple[float, float] | None = None
        self._covariance = (0.0, 0.0, 0.0)
        self._heading: _Heading | None = None      # paper: the estimate in force
        self._carried: _Heading | None = None      # paper: the estimate carried into the current stretch
        self._filter: ParticleFilter | None = None
        self._changes_since_filter_start = 0
        self._crossings: deque[_Crossing] = deque(maxlen=CROSSING_MEMORY)   # filter: since it started
        self.rogue_count = 0
        self.undecodable_count = 0
        self.filter_reinitialisations = 0

    # ------------------------------------------------------------------------------ observation

    def _decode(self, tag_id: str) -> DecodedTag | None:
        if tag_id not in self._decoded:
            if len(self._decoded) >= DECODE_CACHE_LIMIT:
                self._decoded.clear()
            try:
                self._decoded[tag_id] = decode_tag_id(tag_id)
            except TagIdError:
                self._decoded[tag_id] = None
        return self._decoded[tag_id]

    def _observe(self, tag_ids: Sequence[str]) -> _Observation:
        decoded: list[tuple[str, DecodedTag]] = []
        for tag_id in sorted(set(tag_ids)):    # a tag may be reported several times in one round
            tag = self._decode(tag_id)
            if tag is None:
                self.undecodable_count += 1
            else:
                decoded.append((tag_id, tag))
        if self.lattice is None and decoded:
            counts: dict[tuple[str, float], int] = {}
            for _, tag in decoded:
                counts[(tag.layout, tag.spacing_m)] = counts.get((tag.layout, tag.spacing_m), 0) + 1
            layout, spacing = max(counts, key=lambda key: counts[key])   # first maximum: the smallest id's
            self.lattice = Lattice(layout, spacing)
            self.read_range_m = read_range_of(self.lattice)
            self._geometry = partition_geometry(self.lattice, self.read_range_m)
            area = self.settings.deployment_area
            self._deployment = Deployment(self.lattice, self.read_range_m, area) if area is not None else None
        by_coordinate: dict[Coordinate, str] = {}
        for tag_id, tag in decoded:
            if (tag.layout, tag.spacing_m) != (self.lattice.layout, self.lattice.spacing_m):
                self.undecodable_count += 1
            else:
                by_coordinate.setdefault(tag.coordinate, tag_id)
        if not by_coordinate:
            return _Observation(frozenset(), (), (), frozenset())
        coordinates = list(by_coordinate)
        positions = [self.lattice.position(c) for c in coordinates]
        kept = consistent_group(positions, self.settings.rogue_distance_factor * self.read_range_m, self._position)
        kept_set = set(kept)
        rejected = [c for k, c in enumerate(coordinates) if k not in kept_set]
        self.rogue_count += len(rejected)
        return _Observation(frozenset(coordinates[k] for k in kept),
                            tuple(sorted(by_coordinate[coordinates[k]] for k in kept)),
                            tuple(sorted(by_coordinate[c] for c in rejected)), frozenset(rejected))

    # ------------------------------------------------------------------------------------ update

    def update(self, stamp_s: float, tag_ids: Sequence[str], odom: tuple[float, float, float]) -> LocalizationEstimate:
        """One inventory round: the floor tag ids read and the odometry pose (x, y, yaw) at that time."""
        if not all(math.isfinite(value) for value in odom):
            raise ValueError(f"odom: expected finite (x, y, yaw), got {odom}")
        observation = self._observe(tag_ids)
        partition = observation.partition
        changed = bool(partition) and partition != self._last_partition
        odom_rotation = wrap_angle(odom[2] - self._last_odom[2]) if self._last_odom is not None else 0.0
        turned = self._advance_stretch(partition, odom[2])
        if self.settings.method == "paper":
            yaw = self._paper_update(partition, changed, turned, odom, odom_rotation)
        else:
            yaw = self._filter_update(observation, changed, odom)
        if partition:
            self._last_partition = partition
        self._last_odom = odom
        yaw_value, yaw_bounds, yaw_std = yaw if yaw is not None else (None, None, None)
        return LocalizationEstimate(
            stamp_s=stamp_s, method=self.settings.method, partition=partition,
            partition_tag_ids=observation.tag_ids, partition_changed=changed,
            partitions_traversed=max(len(self._stretch.partitions) - 1, 0),
            position=self._position, position_covariance=self._covariance,
            yaw=yaw_value, yaw_bounds=yaw_bounds, yaw_std=yaw_std,
            read_range_m=self.read_range_m, lattice=self.lattice, rejected_tag_ids=observation.rejected_ids,
            rogue_count=self.rogue_count, undecodable_count=self.undecodable_count,
            filter_reinitialisations=self.filter_reinitialisations)

    def _advance_stretch(self, partition: frozenset[Coordinate], odom_yaw: float) -> bool:
        """Record the partition in the current straight stretch; True when the odometry says the robot has
        turned, in which case a new stretch starts here."""
        stretch = self._stretch
        turned = False
        if stretch is None:
            stretch = self._stretch = _Stretch(odom_yaw, [])
        else:
            change = wrap_angle(odom_yaw - stretch.start_odom_yaw)
            if abs(change) > self.settings.turn_threshold_rad:
                stretch = self._stretch = _Stretch(odom_yaw, [])
                turned = True
            else:
                stretch.yaw_change_sum += change
                stretch.updates += 1
        if partition and (not stretch.partitions or stretch.partitions[-1] != partition):
            stretch.partitions.append(partition)
        return turned

    @staticmethod
    def _reported_yaw(heading: _Heading, odom_yaw: float) -> YawEstimate:
        yaw = wrap_angle(odom_yaw + heading.offset)
        return yaw, (yaw - heading.half_width, yaw + heading.half_width), heading.half_width / 2.0

    # ------------------------------------------------------------------------------ paper method

    def _paper_update(self, partition: frozenset[Coordinate], changed: bool, turned: bool,
                      odom: tuple[float, float, float], odom_rotation: float) -> YawEstimate | None:
        if partition:
            self._position, self._covariance = self._geometry.location(partition)
        widening = self.settings.motion_noise_fraction * abs(odom_rotation)
        if self._heading is not None:
            self._heading = self._heading.widened(widening)
        if self._carried is not None:
            self._carried = self._carried.widened(widening)
        if turned:
            self._carried = self._heading
        stretch = self._stretch
        if changed and len(stretch.partitions) >= 2:
            bounds = orientation_bounds(self.lattice, self.read_range_m, stretch.partitions)
            if bounds is not None:
                lower, upper = bounds
                candidate = _Heading(wrap_angle((lower + upper) / 2.0 - stretch.mean_odom_yaw), (upper - lower) / 2.0)
                carried = self._carried
                self._heading = candidate if carried is None or candidate.half_width <= carried.half_width else carried
        return self._reported_yaw(self._heading, odom[2]) if self._heading is not None else None

    # ---------------------------------------------------------------------------- particle filter

    def _start_filter(self, partition: frozenset[Coordinate], odom_yaw: float) -> None:
        if self._filter is None:
            self._filter = ParticleFilter(self.settings, self.rng)
        self._filter.initialise(*self._geometry.region(partition))
        self._changes_since_filter_start = 0
        self._crossings.clear()
        self._stretch = _Stretch(odom_yaw, [partition])

    def _filter_update(self, observation: _Observation, changed: bool,
                       odom: tuple[float, float, float]) -> YawEstimate | None:
        partition = observation.partition
        particle_filter = self._filter
        if particle_filter is None:
            if not partition:
                return None
            self._start_filter(partition, odom[2])
        else:
            previous = self._last_odom
            dx, dy = odom[0] - previous[0], odom[1] - previous[1]
            cos_yaw, sin_yaw = math.cos(previous[2]), math.sin(previous[2])
            particle_filter.predict(cos_yaw * dx + sin_yaw * dy, -sin_yaw * dx + cos_yaw * dy,
                                    wrap_angle(odom[2] - previous[2]))
            if partition:
                proposals = None
                if changed:
                    self._changes_since_filter_start += 1
                    arc = self._geometry.crossing_arc(self._last_partition, partition)
                    if arc is not None:
                        crossing = _Crossing(arc, self._odom_antenna(previous), self._odom_antenna(odom))
                        proposals = partial(self._crossing_proposals, crossing, math.hypot(dx, dy), odom)
                        self._crossings.append(crossing)
                read, unread = self._filter_tags(partition, observation.rejected)
                if not particle_filter.weigh(read, unread, self.read_range_m, proposals):
                    self.filter_reinitialisations += 1
                    self._start_filter(partition, odom[2])
        position, covariance, yaw, yaw_sd = self._filter.estimate()
        self._position, self._covariance = position, covariance
        if self._changes_since_filter_start == 0:
            return None    # a uniform heading has no meaningful mean until a partition boundary is crossed
        return yaw, (yaw - 2.0 * yaw_sd, yaw + 2.0 * yaw_sd), yaw_sd

    def _odom_antenna(self, odom: tuple[float, float, float]) -> np.ndarray:
        offset = self.settings.antenna_offset_m
        return np.array((odom[0] + offset * math.cos(odom[2]), odom[1] + offset * math.sin(odom[2])))

    def _crossing_proposals(self, crossing: _Crossing, step_m: float, odom: tuple[float, float, float],
                            count: int) -> np.ndarray:
        """States (3 x count) of a robot that has just crossed ``crossing``: paired with earlier crossings where
        it can be, the rest from this crossing alone."""
        paired = self._paired_proposals(crossing, odom, count)
        if paired.shape[1] == count:
            return paired
        single = self._single_crossing_proposals(crossing.arc, step_m, odom[2], count - paired.shape[1])
        return np.hstack((paired, single))

    def _paired_proposals(self, crossing: _Crossing, odom: tuple[float, float, float], count: int) -> np.ndarray:
        """Up to ``count`` states (3 x n) that explain this crossing and an earlier one together.

        The odometry knows the antenna's displacement between the two crossings in its own frame; the map
        frame differs from it by a rotation and a translation only. So a point p_then on the earlier arc and
        a point p_now on this arc at the odometry's distance from it fix the whole pose: the rotation turns
        the odometry's displacement onto p_now - p_then. Sampling p_then along its arc leaves one degree of
        freedom where a single crossing leaves two (a point on the arc and any heading), which is what finds
        the heading of a robot turning on the spot: its antenna's crossings lie up to twice the antenna
        offset apart. Crossings are paired with the ones furthest away by odometry (a longer baseline
        gives a finer heading), at least PAIR_MIN_BASELINE_R * r."""
        earlier = list(self._crossings)
        if not earlier:
            return np.zeros((3, 0))
        baselines = np.array([math.dist(c.antenna_after, crossing.antenna_after) for c in earlier])
        usable = np.flatnonzero(baselines >= PAIR_MIN_BASELINE_R * self.read_range_m)
        if not len(usable):
            return np.zeros((3, 0))
        chosen = usable[np.argsort(baselines[usable])[-PAIR_CHOICES:]]
        picks = self.rng.choice(chosen, size=count)
        rng = self.rng
        now_odom = crossing.antenna_at(rng.random(count))
        then_odom = np.empty((count, 2))
        then_map = np.empty((count, 2))
        for index in np.unique(picks):
            rows = np.flatnonzero(picks == index)
            then = earlier[index]
            then_odom[rows] = then.antenna_at(rng.random(len(rows)))
            then_map[rows] = then.arc[rng.integers(len(then.arc), size=len(rows))]
        baseline = np.linalg.norm(now_odom - then_odom, axis=1)
        # Points of this arc at the baseline's distance from p_then, within the arc's sampling step.
        arc = crossing.arc
        mismatch = np.abs(np.linalg.norm(arc[None, :, :] - then_map[:, None, :], axis=2) - baseline[:, None])
        tolerance = 2.0 * math.pi / CIRCLE_SAMPLES * self.read_range_m
        keys = np.where(mismatch <= tolerance, rng.random(mismatch.shape), -1.0)
        found = keys.max(axis=1) >= 0.0
        now_map = arc[keys.argmax(axis=1)[found]]
        then_map, then_odom, now_odom = then_map[found], then_odom[found], now_odom[found]
        map_chord, odom_chord = now_map - then_map, now_odom - then_odom
        rotation = np.arctan2(map_chord[:, 1], map_chord[:, 0]) - np.arctan2(odom_chord[:, 1], odom_chord[:, 0])
        # The robot's centre now, carried from the odometry frame into the map by that rotation about p_now.
        from_antenna = np.array(odom[:2]) - now_odom
        cos_r, sin_r = np.cos(rotation), np.sin(rotation)
        x = now_map[:, 0] + cos_r * from_antenna[:, 0] - sin_r * from_antenna[:, 1]
        y = now_map[:, 1] + sin_r * from_antenna[:, 0] + cos_r * from_antenna[:, 1]
        return np.vstack((x, y, odom[2] + rotation))

    def _single_crossing_proposals(self, arc: np.ndarray, step_m: float, odom_yaw: float, count: int) -> np.ndarray:
        """States (3 x count) of a robot that crossed ``arc`` during its last step of ``step_m``: the heading
        within the paper's bounds for the current stretch when it has them (turned by the odometry since),
        else any."""
        stretch = self._stretch
        bounds = orientation_bounds(self.lattice, self.read_range_m, stretch.partitions) \
            if len(stretch.partitions) >= 3 else None
        if bounds is not None:
            yaw = self.rng.uniform(*bounds, count) + wrap_angle(odom_yaw - stretch.mean_odom_yaw)
        else:
            yaw = self.rng.uniform(-math.pi, math.pi, count)
        crossed = arc[self.rng.integers(len(arc), size=count)]
        travelled = self.rng.uniform(0.0, step_m, count) - self.settings.antenna_offset_m   # the arc is the antenna's
        return np.vstack((crossed[:, 0] + travelled * np.cos(yaw), crossed[:, 1] + travelled * np.sin(yaw), yaw))

    def _filter_tags(self, partition: frozenset[Coordinate],
                     rejected: frozenset[Coordinate]) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the tags read and of the tags near the particles that were not read."""
        r = self.read_range_m
        x, y, spread = self._filter.bounding_circle()
        # Any tag within r (plus the soft edge) of any particle could have been read. A cloud wider than a few r
        # is lost anyway (the collapse test will restart it): its far side is left out to bound the cost.
        radius = r + min(spread, 4.0 * r) + 4.0 * self.settings.boundary_softness_m
        nearby = [c for c in self.lattice.within(x, y, radius) if c not in partition and c not in rejected
                  and (self._deployment is None or self._deployment.is_deployed(c))]
        read = self.lattice.positions(np.array(sorted(partition)))
        unread = self.lattice.positions(np.array(nearby)) if nearby else np.zeros((0, 2))
        return read, unread
