"""Partition geometry of paper 000 (sections 4.1-4.2): regions, crossing arcs and orientation bounds.

A partition is the set of tags read together; its region is the set of points that read exactly those tags
(within r of each tag read, beyond r of every other). The boundary between consecutive partitions A and B lies
on the read circles of the tags whose membership differs; the points of those circles at which every other tag
reads as it does in both A and B are the crossing points (the paper's "common vertices" of polygonal
partitions, here the exact circular arcs and their end vertices). The heading of a straight traversal is the
direction of a segment from a start crossing to an end crossing (:func:`orientation_bounds`).

Every tag id describes itself (rfidnav_common.tag_lattice), so the read range follows from the lattice
(grid s = r*sqrt2, triangular s = r*sqrt3, compressed s = 1.5 r: :func:`read_range_of`).

Geometry depends only on a partition's shape, as the lattice is invariant under its own translations: it is
computed once per shape and cached, so an update costs microseconds after the first few.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Coordinate, Lattice

SPACING_PER_READ_RANGE = {"grid": math.sqrt(2.0), "triangular": math.sqrt(3.0), "compressed": 1.5}

Shape = tuple[Coordinate, ...]   # a partition's coordinates relative to its anchor (its smallest), sorted

CIRCLE_SAMPLES = 180             # points per read circle when sampling arcs (2 degrees)
REGION_GRID = 80                 # cells per axis of the grid that measures a region's moments
ON_CIRCLE_TOLERANCE = 1e-7       # relative to r: a point this close to a read circle counts as on it
# A region that no point satisfies (reads that contradict the disc geometry: a missed or an over-range read)
# is relaxed step by step: (factor on r for the tags read, whether the tags not read must stay unread).
REGION_RELAXATIONS = ((1.0, True), (1.0, False), (1.1, False), (1.25, False), (1.5, False), (2.0, False))
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
        # all shifted together: cache by their shapes relative to the first partition's anchor, and compute them
        # there too, so that the bounds are the same to the bit whichever traversal of that shape came first (a
        # worker's earlier tasks must not change a later task's result).
        relevant = (*partitions[:2], *partitions[-2:]) if len(partitions) >= 3 else tuple(partitions)
        anchor = min(partitions[0])
        key = tuple(frozenset((i - anchor[0], j - anchor[1]) for i, j in p) for p in relevant)
        if key not in self._bounds:
            if len(self._bounds) >= BOUNDS_CACHE_LIMIT:
                self._bounds.clear()
            self._bounds[key] = self._make_bounds(key[0], key[1], key[-2], key[-1], len(partitions))
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

