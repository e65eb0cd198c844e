"""The partition path planner of paper 000 (section 5.1, Algorithm 1): a straight segment as partitions.

An agent that can only tell which partition it is in (the set of tags it reads) follows the segment from
``start`` to ``goal`` as the sequence of partitions the segment passes. Algorithm 1 finds that sequence
by a walk over the triangles of the triangular tag lattice, much as Bresenham's algorithm walks pixels.

Facts the walk rests on (both triangular layouts: Kershner side r*sqrt(3) and compressed side 1.5*r):
a point inside a lattice triangle is read only by that triangle's three vertices (every other tag is at
least side*sqrt(3)/2 > r away), so the partitions along a stretch of segment are formed by the vertices
of the triangles that stretch crosses and by no other tag. A read circle crosses only edges incident to
its own tag, so every entry or exit point of a disc lies in a triangle that has that tag as a vertex.

Terms (section 5.1): the neighbourhood N(C) of a tag C is the hexagon of its six triangles; the hexant
of the current tag C is the triangle (C, D1, D2) of N(C) through whose far edge D1-D2 the segment leaves
N(C); D1 and D2 are the decision tags; the next common vertex NCV is the vertex beyond that edge and the
next common triangle NCT is (NCV, D1, D2).

Correspondence to Algorithm 1 (line numbers of the paper):

* 1.9   PL <- empty; C_1 <- the vertex of the start triangle opposite the edge the segment leaves it by
        (when the start is on a tag, that tag: the start triangle is then the tag's hexant).
* 1.10  loop until the goal's triangle has been processed (the paper's "C_i != End", for any goal point).
* 1.11, 1.41  each iteration's local tags are C, the vertices of the triangles of N(C) the segment
        crosses up to the hexant (usually just the hexant's D1, D2), and NCV; tags whose read disc the
        segment misses are purged (section 5.1.4). When the segment crosses several triangles of N(C)
        before leaving it, their vertices are neighbours of C and local too, so no partition is skipped.
* 1.12-1.40, 1.42-1.43  the case analysis ("DixE in Range(Ci)", "Di1E < Di2E", "NCViE in Range(...)",
        "TnisE in Range(NCVi)", "whichever Pse leaves last") only decides in which order the segment
        enters and leaves the local discs. Here it is resolved fully generally: the entry and exit
        parameters of every local disc along the segment are computed exactly (a quadratic per disc,
        vectorized once for the whole segment), sorted, and swept; every change of the set of discs
        containing the segment appends a partition. This covers every case of the paper's analysis and
        the ones it leaves implicit (e.g. a decision tag entered and left again inside C's disc).
* 1.44  C_{i+1} <- the decision tag closest to the segment; the next iteration continues with the
        triangles after the NCT.

Consecutive equal partitions are merged and stretches shorter than 1e-9 m (tangencies) dropped, with
the same sweep as ``tag_lattice.partitions_along_segment``, so the plan equals that exact geometric walk
(except for ties within a nanometre of a stretch boundary, which arbitrary segments do not produce).

Cost: nothing enumerates the deployment. The crossed triangles come from the crossings of the
segment with the lattice's three line families (vectorized), and only their vertices are examined:
O(length / side) work for a segment, independent of the size of the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rfidnav_common.geometry import point_segment_distance
from rfidnav_common.tag_lattice import Coordinate, Deployment, Lattice, disc_intervals, partition_centre
from rfidnav_planning.errors import PlanningError

Point = tuple[float, float]
Partition = frozenset[Coordinate]

# Stretches shorter than this are tangencies, not partitions (as in tag_lattice.partitions_along_segment).
MINIMUM_STRETCH_M = 1e-9

# Sweep events: at equal parameters exits sort before entries, as in partitions_along_segment.
EXIT, ENTRY = 0, 1

_KEY_SHIFT = 1 << 32          # coordinate (i, j) -> one int64: i * 2**32 + (j + 2**31)
_KEY_BIAS = 1 << 31


@dataclass(frozen=True)
class PartitionPlan:
    """The partitions a straight segment from ``start`` to ``goal`` passes, in order."""
    start: Point
    goal: Point
    partitions: tuple[Partition, ...]
    _index: dict[Partition, int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        index: dict[Partition, int] = {}
        for position, partition in enumerate(self.partitions):
            index.setdefault(partition, position)     # a partition the segment revisits: its first visit
        object.__setattr__(self, "_index", index)

    def centres(self, lattice: Lattice) -> list[Point]:
        """Each partition's location: the mean position of its tags (paper 000 section 4.1)."""
        return [partition_centre(lattice, partition) for partition in self.partitions]

    def index_of(self, partition: Partition) -> int | None:
        """Position of ``partition`` in the plan (its first occurrence), None when off the plan."""
        return self._index.get(partition)

    def __len__(self) -> int:
        return len(self.partitions)


# -------------------------------------------------------------------------------- segment geometry

@dataclass(frozen=True)
class _Walk:
    """The lattice triangles a segment crosses and the read discs of their vertices.

    Tags are numbered 0..n-1 here; every list below is indexed by that number or by triangle order."""
    entries: list[float]                  # parameter t where the segment enters each triangle, then 1.0
    triangles: list[tuple[int, int, int]]  # the three tags of each crossed triangle, in crossing order
    coordinates: list[Coordinate]         # lattice coordinate of each tag
    t_in: list[float]                     # where the segment enters the tag's disc (clipped to [0, 1])
    t_out: list[float]                    # where it leaves it
    crossed: list[bool]                   # False: the segment misses the disc (purged, section 5.1.4)
    distance_m: list[float]               # distance from the tag to the segment (line 1.44)


def _crossing_parameters(first: float, last: float) -> np.ndarray:
    """Parameters t in (0, 1) where a lattice coordinate going linearly from ``first`` to ``last`` is an
    integer: the segment's crossings with one family of lattice lines."""
    if first == last:
        return np.empty(0)
    low, high = min(first, last), max(first, last)
    integers = np.arange(math.floor(low) + 1, math.ceil(high), dtype=float)
    return np.clip((integers - first) / (last - first), 0.0, 1.0)


def _triangle_vertices(lattice: Lattice, points: np.ndarray) -> np.ndarray:
    """The three lattice coordinates (N x 3 x 2) of the triangle containing each point (N x 2)."""
    v = points[:, 1] / lattice.row_height_m
    u = points[:, 0] / lattice.spacing_m - v / 2.0
    i, j = np.floor(u), np.floor(v)
    upward = (u - i) + (v - j) < 1.0
    # Upward triangle: (i, j), (i+1, j), (i, j+1); downward: (i+1, j), (i, j+1), (i+1, j+1).
    corner = np.where(upward, 0.0, 1.0)
    vertices = np.stack([np.column_stack((i + corner, j)),
                         np.column_stack((i, j + 1.0)),
                         np.column_stack((i + 1.0, j + corner))], axis=1)
    return vertices.astype(np.int64)


def _crossed_triangles(lattice: Lattice, start: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Entry parameters (M + 1, ending with 1.0) and vertices (M x 3 x 2) of the triangles crossed."""
    def lattice_uvw(point: np.ndarray) -> tuple[float, float, float]:
        v = point[1] / lattice.row_height_m
        u = point[0] / lattice.spacing_m - v / 2.0
        return u, v, u + v          # the three line families: u, v and u + v integer
    boundaries = np.sort(np.concatenate([[0.0, 1.0]] + [
        _crossing_parameters(first, last) for first, last in zip(lattice_uvw(start), lattice_uvw(goal))]))
    # Zero-length gaps are the segment passing exactly through a tag (or starting or ending on one).
    positive = boundaries[1:] > boundaries[:-1]
    entries = np.append(boundaries[:-1][positive], 1.0)
    middles = (boundaries[:-1][positive] + boundaries[1:][positive]) / 2.0
    return entries, _triangle_vertices(lattice, start + middles[:, None] * (goal - start))


def _walk(deployment: Deployment, start: np.ndarray, goal: np.ndarray) -> _Walk:
    """Everything the iterations need, computed in vectorized form once per segment."""
    lattice = deployment.lattice
    entries, vertices = _crossed_triangles(lattice, start, goal)
    keys = vertices[:, :, 0] * _KEY_SHIFT + (vertices[:, :, 1] + _KEY_BIAS)
    unique_keys, tag_of_vertex = np.unique(keys.ravel(), return_inverse=True)
    coordinates = np.column_stack((unique_keys // _KEY_SHIFT, unique_keys % _KEY_SHIFT - _KEY_BIAS))
    t_in, t_out, crossed = disc_intervals(lattice, deployment.read_range_m, coordinates, start, goal)
    return _Walk(entries=entries.tolist(),
                 triangles=[tuple(tags) for tags in tag_of_vertex.reshape(-1, 3).tolist()],
                 coordinates=[(int(i), int(j)) for i, j in coordinates.tolist()],
                 t_in=t_in.tolist(), t_out=t_out.tolist(), crossed=crossed.tolist(),
                 distance_m=point_segment_distance(lattice.positions(coordinates), start, goal).tolist())


# -------------------------------------------------------------------------------------------- sweep

class _PartitionSweep:
    """Appends the partition the segment is in each time the set of discs containing it changes.

    Identical to the sweep of partitions_along_segment, fed one iteration's events at a time: events
    within ``minimum`` of each other apply together, and a stretch shorter than ``minimum`` adds nothing."""

    def __init__(self, minimum: float) -> None:
        self.minimum = minimum
        self.position = 0.0
        self.active: set[Coordinate] = set()
        self.partitions: list[Partition] = []

    def _reach(self, t: float) -> None:
        if t - self.position >= self.minimum:
            partition = frozenset(self.active)
            if not self.partitions or self.partitions[-1] != partition:
                self.partitions.append(partition)
            self.position = t

    def feed(self, events: list[tuple[float, int, Coordinate]]) -> None:
        """Consume events (t, EXIT or ENTRY, tag) sorted by t."""
        index = 0
        while index < len(events):
            t_next = events[index][0]
            self._reach(t_next)
            while index < len(events) and events[index][0] - t_next < self.minimum:
                _, kind, tag = events[index]
                if kind == ENTRY:
                    self.active.add(tag)
                else:
                    self.active.discard(tag)
                index += 1

    def finish(self) -> tuple[Partition, ...]:
        self._reach(1.0)
        return tuple(self.partitions)


# ------------------------------------------------------------------------------------- Algorithm 1

def _first_current_tag(walk: _Walk) -> int:
    """Line 1.9: the start triangle's vertex opposite the edge the segment leaves by (the start tag
    itself when the segment starts on a tag, since it then leaves through that tag's far edge)."""
    first = walk.triangles[0]
    if len(walk.triangles) == 1:
        return min(first, key=lambda tag: walk.distance_m[tag])
    opposite = [tag for tag in first if tag not in walk.triangles[1]]
    return opposite[0] if opposite else first[0]


def _hexant_index(walk: _Walk, current: int, from_index: int) -> int:
    """Index of the hexant: the last of the consecutive triangles from ``from_index`` that have the
    current tag as a vertex (the segment leaves N(current) through that triangle's far edge)."""
    index = from_index
    while index + 1 < len(walk.triangles) and current in walk.triangles[index + 1]:
        index += 1
    return index


def _local_events(walk: _Walk, local_tags: set[int], t_from: float, t_to: float) -> list[tuple[float, int, Coordinate]]:
    """Lines 1.11-1.43 resolved: where the segment enters and leaves the local discs it crosses, within
    this iteration's stretch [t_from, t_to), in order along the segment."""
    events = []
    for tag in local_tags:
        if not walk.crossed[tag]:
            continue            # purged: the segment misses this tag's disc
        coordinate = walk.coordinates[tag]
        if t_from <= walk.t_in[tag] < t_to:
            events.append((walk.t_in[tag], ENTRY, coordinate))
        if t_from <= walk.t_out[tag] < t_to:
            events.append((walk.t_out[tag], EXIT, coordinate))
    events.sort()
    return events


def plan_partition_path(deployment: Deployment, start: Point, goal: Point) -> PartitionPlan:
    """Algorithm 1 of paper 000: the partitions the segment start-goal passes, in order.

    PlanningError when the deployment is not a triangular lattice or start or goal lies outside its area."""
    _check_request(deployment, start, goal)
    start_point = (float(start[0]), float(start[1]))
    goal_point = (float(goal[0]), float(goal[1]))
    a, b = np.array(start_point), np.array(goal_point)
    length_m = float(np.linalg.norm(b - a))
    if length_m == 0.0:
        return PartitionPlan(start_point, goal_point, (deployment.partition_at(*start_point),))
    walk = _walk(deployment, a, b)
    sweep = _PartitionSweep(MINIMUM_STRETCH_M / length_m)
    last_triangle = len(walk.triangles) - 1
    current = _first_current_tag(walk)
    next_triangle = 0                          # the first triangle no iteration has processed yet
    while next_triangle <= last_triangle:      # line 1.10: until the goal's triangle is done
        hexant = _hexant_index(walk, current, max(next_triangle - 1, 0))
        nct = min(hexant + 1, last_triangle)   # the next common triangle (the goal's, at the end)
        # Local tags: C, the vertices of the triangles of N(C) not yet processed (D1, D2 among them) and
        # NCV. Every disc boundary point lies in a triangle of its own tag, so taking the local discs'
        # events inside this iteration's stretch takes each event of the segment exactly once.
        local_tags = {tag for index in range(next_triangle, nct + 1) for tag in walk.triangles[index]}
        local_tags.add(current)
        t_to = walk.entries[nct + 1] if nct < last_triangle else math.inf
        sweep.feed(_local_events(walk, local_tags, walk.entries[next_triangle], t_to))
        next_triangle = nct + 1
        if nct > hexant:                       # line 1.44: the decision tag closest to the segment
            decision_tags = [tag for tag in walk.triangles[hexant] if tag in walk.triangles[nct]]
            current = min(decision_tags, key=lambda tag: walk.distance_m[tag])
    return PartitionPlan(start_point, goal_point, sweep.finish())


def lattice_refusal(deployment: Deployment) -> str | None:
    """Why Algorithm 1 cannot plan on ``deployment`` (it walks lattice triangles: a grid has none); None when it
    can. The scenario check refuses such a world before any process starts with the same words."""
    if deployment.lattice.triangular:
        return None
    return (f"partition path planning needs a triangular lattice (layouts 'triangular' or 'compressed'); the "
            f"deployment is a '{deployment.lattice.layout}' lattice")


def _check_request(deployment: Deployment, start: Point, goal: Point) -> None:
    refusal = lattice_refusal(deployment)
    if refusal is not None:
        raise PlanningError(refusal)
    for name, point in (("start", start), ("goal", goal)):
        if not deployment.contains_point(float(point[0]), float(point[1])):
            raise PlanningError(f"{name} ({point[0]}, {point[1]}) lies outside the deployment area "
                                f"[x_min, y_min, x_max, y_max] = {list(deployment.area)}")
