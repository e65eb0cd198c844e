"""Floor tag deployments of paper 000: grid and triangular lattices, self-describing tag IDs, partitions.

Lattices (paper 000 sections 3.1, 6.4): tags at the vertices of

* ``grid``: squares of side r*sqrt(2) (each square's circumscribed circle has radius r);
* ``triangular``: Kershner's optimal covering, equilateral triangles of side r*sqrt(3);
* ``compressed``: the same triangles with side 3/2*r (more uniform partitions, paper 000 section 6.4.3).

Triangular coordinates (x^, y^) of a tag count tags from the origin along two axes 60 degrees apart;
equation (1) of paper 000, for any side length s (the paper's s = r*sqrt(3)):

    x = x^ * s + y^ * s / 2,        y = y^ * s * sqrt(3) / 2.

Grid coordinates are plain column and row numbers: x = x^ * s, y = y^ * s. Tag (0, 0) is the map origin,
so every tag's map position follows from its ID alone.

A deployment is a lattice, the tags' read range r and a rectangular area: the tags deployed are the
lattice vertices whose read disc reaches into the area (distance to the rectangle below r). Nothing here
enumerates a deployment: every query (which tags read a point, which tags a segment passes, how many
tags there are) is lattice arithmetic, so a 30 x 30 m field at r = 2 cm (about 870,000 tags) costs no
more than a small one.

Tag IDs (EPC, 96 bits, written as 24 upper-case hex digits as a reader reports them)::

    bits 95..88  header 0xA0 | layout code (1 grid, 2 triangular, 3 compressed)
    bits 87..64  lattice spacing s in micrometres (24 bits: up to 16.7 m)
    bits 63..0   bit-interleaved (Morton) code of the two coordinates

Each coordinate is stored offset-binary in 32 bits (x^ + 2**31), so negative coordinates down to -2**31
are encoded and the Morton code keeps the spatial order of paper 000 section 3.2 across zero. Within
each bit pair the x^ bit is the higher one (interleaving vector x1, y1, x2, y2, ... from the most
significant bit). Spacings are whole micrometres (rounded down, so a lattice never spreads wider than
its covering allows) and an ID therefore decodes to exactly the position the simulator placed it at.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from rfidnav_common.geometry import point_segment_distance

LAYOUTS = ("grid", "triangular", "compressed")
LAYOUT_CODES = {"grid": 1, "triangular": 2, "compressed": 3}
HEADER = 0xA0
COORDINATE_BITS = 32
COORDINATE_BIAS = 1 << (COORDINATE_BITS - 1)
COORDINATE_MIN, COORDINATE_MAX = -COORDINATE_BIAS, COORDINATE_BIAS - 1
SPACING_BITS = 24
SQRT3 = math.sqrt(3.0)

Coordinate = tuple[int, int]


class TagIdError(ValueError):
    """An EPC that is not a lattice tag ID of this scheme."""


class DeploymentError(ValueError):
    """A deployment description that cannot describe a deployment (its message starts with the field)."""


def spacing_for(layout: str, read_range_m: float) -> float:
    """Side of the lattice cell for ``layout`` and read range r, in whole micrometres (rounded down)."""
    factor = {"grid": math.sqrt(2.0), "triangular": SQRT3, "compressed": 1.5}[layout]
    return math.floor(factor * read_range_m * 1e6 + 1e-6) * 1e-6


# ------------------------------------------------------------------------------------------------ IDs

def _spread_bits(value: int) -> int:
    """Insert a zero bit above each of the 32 bits of ``value`` (Morton spreading)."""
    value &= 0xFFFFFFFF
    value = (value | (value << 16)) & 0x0000FFFF0000FFFF
    value = (value | (value << 8)) & 0x00FF00FF00FF00FF
    value = (value | (value << 4)) & 0x0F0F0F0F0F0F0F0F
    value = (value | (value << 2)) & 0x3333333333333333
    value = (value | (value << 1)) & 0x5555555555555555
    return value


def _compact_bits(value: int) -> int:
    value &= 0x5555555555555555
    value = (value | (value >> 1)) & 0x3333333333333333
    value = (value | (value >> 2)) & 0x0F0F0F0F0F0F0F0F
    value = (value | (value >> 4)) & 0x00FF00FF00FF00FF
    value = (value | (value >> 8)) & 0x0000FFFF0000FFFF
    value = (value | (value >> 16)) & 0x00000000FFFFFFFF
    return value


def interleave(x: int, y: int) -> int:
    """Morton code of two signed 32-bit coordinates (offset binary; the x bit above the y bit)."""
    for name, value in (("x", x), ("y", y)):
        if not COORDINATE_MIN <= value <= COORDINATE_MAX:
            raise ValueError(f"{name} coordinate {value} outside [{COORDINATE_MIN}, {COORDINATE_MAX}]")
    return (_spread_bits(x + COORDINATE_BIAS) << 1) | _spread_bits(y + COORDINATE_BIAS)


def deinterleave(code: int) -> Coordinate:
    return _compact_bits(code >> 1) - COORDINATE_BIAS, _compact_bits(code) - COORDINATE_BIAS


def encode_tag_id(layout: str, spacing_m: float, coordinate: Coordinate) -> str:
    """The EPC (24 upper-case hex digits) of the tag at lattice ``coordinate``."""
    spacing_um = round(spacing_m * 1e6)
    if not 0 < spacing_um < (1 << SPACING_BITS):
        raise ValueError(f"spacing {spacing_m} m outside (0, {(1 << SPACING_BITS) * 1e-6:.1f}) m")
    value = ((HEADER | LAYOUT_CODES[layout]) << 88) | (spacing_um << 64) | interleave(*coordinate)
    return f"{value:024X}"


@dataclass(frozen=True)
class DecodedTag:
    layout: str
    spacing_m: float
    coordinate: Coordinate


def decode_tag_id(epc: str) -> DecodedTag:
    """Layout, spacing and lattice coordinate of a tag from its EPC; TagIdError when it is not one of ours."""
    if not isinstance(epc, str) or len(epc) != 24:
        raise TagIdError(f"'{epc}' is not a 96-bit EPC (24 hex digits)")
    try:
        value = int(epc, 16)
    except ValueError:
        raise TagIdError(f"'{epc}' is not hexadecimal") from None
    header = value >> 88
    codes = {code: name for name, code in LAYOUT_CODES.items()}
    if header & 0xF0 != HEADER or header & 0x0F not in codes:
        raise TagIdError(f"'{epc}' does not carry the lattice tag header (0xA1..0xA3)")
    spacing_um = (value >> 64) & ((1 << SPACING_BITS) - 1)
    if spacing_um == 0:
        raise TagIdError(f"'{epc}' encodes a zero lattice spacing")
    return DecodedTag(codes[header & 0x0F], spacing_um * 1e-6, deinterleave(value & ((1 << 64) - 1)))


# -------------------------------------------------------------------------------------------- lattice

@dataclass(frozen=True)
class Lattice:
    """An infinite lattice of tag positions; (0, 0) at the map origin."""
    layout: str
    spacing_m: float

    def __post_init__(self) -> None:
        if self.layout not in LAYOUTS:
            raise DeploymentError(f"layout: '{self.layout}' is not one of {', '.join(LAYOUTS)}")
        if not (math.isfinite(self.spacing_m) and self.spacing_m > 0.0):
            raise DeploymentError(f"spacing: must be a positive number, got {self.spacing_m}")

    @property
    def triangular(self) -> bool:
        return self.layout != "grid"

    @property
    def row_height_m(self) -> float:
        return self.spacing_m * SQRT3 / 2.0 if self.triangular else self.spacing_m

    @property
    def row_shift_m(self) -> float:
        """How far each row is shifted in x from the one below (equation (1): half a side)."""
        return self.spacing_m / 2.0 if self.triangular else 0.0

    def position(self, coordinate: Coordinate) -> tuple[float, float]:
        """Equation (1) (triangular) or the plain grid: the map position of a lattice coordinate."""
        i, j = coordinate
        return i * self.spacing_m + j * self.row_shift_m, j * self.row_height_m

    def positions(self, coordinates: np.ndarray) -> np.ndarray:
        """Vectorized :meth:`position` of an N x 2 integer array."""
        c = np.asarray(coordinates, dtype=float).reshape(-1, 2)
        positions = np.empty_like(c)     # not column_stack: its overhead is most of the cost for a few tags
        positions[:, 0] = c[:, 0] * self.spacing_m + c[:, 1] * self.row_shift_m
        positions[:, 1] = c[:, 1] * self.row_height_m
        return positions

    def tag_id(self, coordinate: Coordinate) -> str:
        return encode_tag_id(self.layout, self.spacing_m, coordinate)

    def row_interval(self, row: int, x_low: float, x_high: float) -> range:
        """Column numbers of row ``row`` whose x lies in [x_low, x_high]."""
        shift = row * self.row_shift_m
        return range(math.ceil((x_low - shift) / self.spacing_m - 1e-12),
                     math.floor((x_high - shift) / self.spacing_m + 1e-12) + 1)

    def within(self, x: float, y: float, radius: float) -> list[Coordinate]:
        """Lattice coordinates within ``radius`` of (x, y) (inclusive), by row arithmetic."""
        found: list[Coordinate] = []
        h = self.row_height_m
        radius_sq = radius * radius
        for row in range(math.ceil((y - radius) / h - 1e-12), math.floor((y + radius) / h + 1e-12) + 1):
            dy = y - row * h
            half_sq = radius_sq - dy * dy
            if half_sq < 0.0:
                continue
            half = math.sqrt(half_sq)
            for column in self.row_interval(row, x - half, x + half):
                px, _ = self.position((column, row))
                if (px - x) ** 2 + dy * dy <= radius_sq:
                    found.append((column, row))
        return found

    def nearest_distance(self, points: np.ndarray) -> np.ndarray:
        """Distance from each point (N x 2) to its nearest lattice vertex."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        h, s = self.row_height_m, self.spacing_m
        best = np.full(len(p), np.inf)
        base = np.floor(p[:, 1] / h)
        for offset in (-1.0, 0.0, 1.0, 2.0):
            row = base + offset
            column = np.round((p[:, 0] - row * self.row_shift_m) / s)
            dx = p[:, 0] - (column * s + row * self.row_shift_m)
            dy = p[:, 1] - row * h
            best = np.minimum(best, np.hypot(dx, dy))
        return best


def lattice_of(decoded: DecodedTag) -> Lattice:
    return Lattice(decoded.layout, decoded.spacing_m)


# ----------------------------------------------------------------------------------------- deployment

@dataclass(frozen=True)
class Deployment:
    """The tags of one lattice whose read discs (radius ``read_range_m``) reach into ``area``."""
    lattice: Lattice
    read_range_m: float
    area: tuple[float, float, float, float]      # x_min, y_min, x_max, y_max [m], map frame
    # Each row's deployed x interval (:meth:`_row_x_range`), as asked for: rounds ask for the same few rows again.
    _row_ranges: dict[int, tuple[float, float] | None] = field(default_factory=dict, init=False, repr=False,
                                                               compare=False)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.read_range_m) and self.read_range_m > 0.0):
            raise DeploymentError(f"read_range_m: must be a positive number, got {self.read_range_m}")
        x_min, y_min, x_max, y_max = self.area
        if not all(math.isfinite(v) for v in self.area):
            raise DeploymentError(f"area: expected finite numbers, got {list(self.area)}")
        if not (x_max > x_min and y_max > y_min):
            raise DeploymentError(f"area: [x_min, y_min, x_max, y_max] must have x_max > x_min and y_max > y_min, "
                                  f"got {list(self.area)}")

    @property
    def width_m(self) -> float:
        return self.area[2] - self.area[0]

    @property
    def height_m(self) -> float:
        return self.area[3] - self.area[1]

    def contains_point(self, x: float, y: float) -> bool:
        x_min, y_min, x_max, y_max = self.area
        return x_min <= x <= x_max and y_min <= y <= y_max

    def _row_x_range(self, row: int) -> tuple[float, float] | None:
        """x interval of the vertices of ``row`` that are deployed (disc reaches into the area)."""
        if row in self._row_ranges:
            return self._row_ranges[row]
        self._row_ranges[row] = row_range = self._compute_row_x_range(row)
        return row_range

    def _compute_row_x_range(self, row: int) -> tuple[float, float] | None:
        x_min, y_min, x_max, y_max = self.area
        y = row * self.lattice.row_height_m
        dy = max(y_min - y, 0.0, y - y_max)
        if dy >= self.read_range_m:
            return None
        half = math.sqrt(self.read_range_m ** 2 - dy * dy)
        return x_min - half, x_max + half

    def is_deployed(self, coordinate: Coordinate) -> bool:
        row_range = self._row_x_range(coordinate[1])
        if row_range is None:
            return False
        x, _ = self.lattice.position(coordinate)
        return row_range[0] < x < row_range[1]

    def rows(self) -> range:
        h = self.lattice.row_height_m
        r = self.read_range_m
        return range(math.floor((self.area[1] - r) / h), math.ceil((self.area[3] + r) / h) + 1)

    def tag_count(self) -> int:
        """Number of tags deployed (row arithmetic, no enumeration)."""
        count = 0
        for row in self.rows():
            row_range = self._row_x_range(row)
            if row_range is not None:
                count += len(self._deployed_columns(row, *row_range))
        return count

    def _deployed_columns(self, row: int, low: float, high: float) -> range:
        columns = self.lattice.row_interval(row, low, high)
        # Open interval: a disc that only touches the area's edge reads nothing inside it.
        shift, s = row * self.lattice.row_shift_m, self.lattice.spacing_m
        start = columns.start + (1 if columns.start * s + shift <= low else 0)
        stop = columns.stop - (1 if (columns.stop - 1) * s + shift >= high else 0)
        return range(start, max(start, stop))

    def coordinates(self) -> np.ndarray:
        """Every deployed coordinate (N x 2): for small deployments, markers and tests only."""
        blocks = []
        for row in self.rows():
            row_range = self._row_x_range(row)
            if row_range is not None:
                columns = np.array(self._deployed_columns(row, *row_range))
                blocks.append(np.column_stack((columns, np.full(len(columns), row))))
        return np.concatenate(blocks).astype(int) if blocks else np.empty((0, 2), dtype=int)

    def tags_reading(self, x: float, y: float) -> list[Coordinate]:
        """The deployed tags whose read disc contains (x, y): the partition there."""
        return [c for c in self.lattice.within(x, y, self.read_range_m) if self.is_deployed(c)]

    def partition_at(self, x: float, y: float) -> frozenset[Coordinate]:
        return frozenset(self.tags_reading(x, y))

    def uncovered(self, points: np.ndarray) -> np.ndarray:
        """The points (N x 2) inside the area that no tag reads (empty for a complete covering)."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        # A point inside the area read by its nearest vertex is read by a deployed tag: that disc reaches in.
        return p[self.lattice.nearest_distance(p) > self.read_range_m * (1.0 + 1e-9)]

    def candidates_near_segment(self, start: tuple[float, float], end: tuple[float, float],
                                radius: float) -> np.ndarray:
        """Deployed coordinates (N x 2) within ``radius`` of the segment start-end, by row arithmetic."""
        (ax, ay), (bx, by) = start, end
        h = self.lattice.row_height_m
        blocks = []
        for row in range(math.floor((min(ay, by) - radius) / h), math.ceil((max(ay, by) + radius) / h) + 1):
            y = row * h
            # x range of the capsule (segment swept by a disc) on this row: project conservatively.
            if ay == by:
                dy = abs(y - ay)
                if dy > radius:
                    continue
                half = math.sqrt(radius * radius - dy * dy)
                low, high = min(ax, bx) - half, max(ax, bx) + half
            else:
                t_low = (y - radius - ay) / (by - ay)
                t_high = (y + radius - ay) / (by - ay)
                t0, t1 = max(0.0, min(t_low, t_high)), min(1.0, max(t_low, t_high))
                if t0 > t1:
                    continue
                xs = (ax + t0 * (bx - ax), ax + t1 * (bx - ax))
                low, high = min(xs) - radius, max(xs) + radius
            row_range = self._row_x_range(row)
            if row_range is None:
                continue
            columns = self._deployed_columns(row, max(low, row_range[0] - 1e-9), min(high, row_range[1] + 1e-9))
            columns = [c for c in columns if self.is_deployed((c, row))]
            if columns:
                blocks.append(np.column_stack((columns, np.full(len(columns), row))))
        if not blocks:
            return np.empty((0, 2), dtype=int)
        candidates = np.concatenate(blocks).astype(int)
        distance = point_segment_distance(self.lattice.positions(candidates), np.array(start, dtype=float),
                                          np.array(end, dtype=float))
        return candidates[distance <= radius]


@dataclass(frozen=True)
class SegmentPiece:
    """A stretch [t_start, t_end] of a segment (fractions of its length) inside one partition."""
    t_start: float
    t_end: float
    tags: frozenset[Coordinate]


def disc_intervals(lattice: Lattice, read_range_m: float, coordinates: np.ndarray, start: np.ndarray,
                   end: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the segment start-end enters and leaves each tag's read disc, as fractions of its length
    clipped to [0, 1], and whether it crosses the disc at all (a tangent does not). The segment walk and
    the planner both use it, so they agree to the last bit."""
    direction = end - start
    relative = start - lattice.positions(coordinates)
    # |a + t d - c|^2 = r^2  ->  t^2 |d|^2 + 2 t d.(a - c) + |a - c|^2 - r^2 = 0
    qa = float(direction @ direction)
    qb = 2.0 * relative @ direction
    qc = np.einsum("ij,ij->i", relative, relative) - read_range_m * read_range_m
    discriminant = qb * qb - 4.0 * qa * qc
    crossed = discriminant > 0.0
    root = np.sqrt(np.where(crossed, discriminant, 0.0))
    t_in = np.clip((-qb - root) / (2.0 * qa), 0.0, 1.0)
    t_out = np.clip((-qb + root) / (2.0 * qa), 0.0, 1.0)
    return t_in, t_out, crossed & (t_out > t_in)


def partitions_along_segment(deployment: Deployment, start: tuple[float, float], end: tuple[float, float],
                             candidates: np.ndarray | None = None) -> list[SegmentPiece]:
    """The partitions the segment start-end passes, in order, found geometrically: every tag's read disc
    the segment crosses gives the parameter interval it is read on; between consecutive interval ends the
    set of tags read is constant. Stretches shorter than a nanometre (tangencies) are dropped; an empty
    ``tags`` is a stretch no tag reads (outside the deployment). ``candidates``, when given, must be what
    ``deployment.candidates_near_segment(start, end, r)`` returns, in its order (:class:`StraightWalk` finds
    them without the lattice arithmetic)."""
    r = deployment.read_range_m
    if candidates is None:
        candidates = deployment.candidates_near_segment(start, end, r)
    a, b = np.array(start, dtype=float), np.array(end, dtype=float)
    direction = b - a
    length = float(np.linalg.norm(direction))
    if length == 0.0:
        return [SegmentPiece(0.0, 0.0, deployment.partition_at(*start))]
    t_in, t_out, hit = disc_intervals(deployment.lattice, r, candidates, a, b)
    coords = [(int(i), int(j)) for i, j in candidates[hit]]
    t_in, t_out = t_in[hit], t_out[hit]
    # Sweep the interval ends in order, keeping the set of tags read; exits before entries at a tie.
    events = sorted([(float(t), 1, c) for t, c in zip(t_in, coords)]
                    + [(float(t), 0, c) for t, c in zip(t_out, coords)])
    minimum = 1e-9 / length
    pieces: list[SegmentPiece] = []
    active: set[Coordinate] = set()
    position = 0.0
    index = 0
    while index <= len(events):
        t_next = events[index][0] if index < len(events) else 1.0
        if t_next - position >= minimum:
            tags = frozenset(active)
            if pieces and pieces[-1].tags == tags:
                pieces[-1] = SegmentPiece(pieces[-1].t_start, t_next, tags)
            else:
                pieces.append(SegmentPiece(position, t_next, tags))
            position = t_next
        if index == len(events):
            break
        # Apply every event within a nanometre of t_next together (a vertex shared by several circles).
        while index < len(events) and events[index][0] - t_next < minimum:
            _, entering, coordinate = events[index]
            if entering:
                active.add(coordinate)
            else:
                active.discard(coordinate)
            index += 1
    return pieces


# A stretch of a straight walk no read circle comes within this of crosses none (to float error, many times over).
CLEAR_OF_CIRCLES_M = 1e-6
# A tag this close to a step's read distance is left to candidates_near_segment's own arithmetic to include or not.
BORDERLINE_M = 1e-9


class StraightWalk:
    """The deployed tags near a straight line walked in equal steps, found once, so that each step's partitions
    cost no lattice arithmetic (the in-process robot walks a few centimetres between inventory rounds).

    :meth:`quiet` tells the steps that pass no read circle (their partition is the one at their start), and
    :meth:`pieces` is ``partitions_along_segment`` on a step, to the last bit: it hands it the very candidates
    ``candidates_near_segment`` would find, in their order, since the interval arithmetic's dot products round
    differently with the array they are taken in."""

    def __init__(self, deployment: Deployment, origin: tuple[float, float], heading: float, step_m: float,
                 steps: int) -> None:
        self.deployment = deployment
        self.origin = origin
        self.direction = (math.cos(heading), math.sin(heading))
        r, margin = deployment.read_range_m, CLEAR_OF_CIRCLES_M
        ux, uy = self.direction
        length = step_m * steps
        coordinates = deployment.candidates_near_segment(
            (origin[0] - margin * ux, origin[1] - margin * uy),
            (origin[0] + (length + margin) * ux, origin[1] + (length + margin) * uy), r + 2.0 * margin)
        positions = deployment.lattice.positions(coordinates)
        relative = positions - np.array(origin)
        along = relative[:, 0] * ux + relative[:, 1] * uy
        across = np.abs(relative[:, 1] * ux - relative[:, 0] * uy)
        order = np.argsort(along, kind="stable")
        self._coordinates_list = [(int(i), int(j)) for i, j in coordinates[order].tolist()]
        self._positions_list = positions[order].tolist()
        self._along = along[order].tolist()
        # Where the line comes within ``margin`` of a read circle: |s - along| in [inner, outer] around each tag.
        outer = np.sqrt(np.maximum((r + margin) ** 2 - across ** 2, 0.0))
        inner = np.sqrt(np.maximum((r - margin) ** 2 - across ** 2, 0.0))
        near = across <= r + margin
        low = np.concatenate((along - outer, along + inner))[np.concatenate((near, near))]
        high = np.concatenate((along - inner, along + outer))[np.concatenate((near, near))]
        # Steps k overlapping [low, high] (with a nanometre to spare): k * step <= high, (k + 1) * step >= low.
        first = np.clip(np.ceil((low - BORDERLINE_M) / step_m - 1.0), 0, steps).astype(int)
        last = np.clip(np.floor((high + BORDERLINE_M) / step_m), -1, steps - 1).astype(int)
        marks = np.zeros(steps + 1, dtype=int)
        spans = first <= last
        np.add.at(marks, first[spans], 1)
        np.add.at(marks, last[spans] + 1, -1)
        self._quiet = (np.cumsum(marks[:-1]) == 0).tolist()

    def quiet(self, step: int) -> bool:
        """Whether step ``step`` (from step * step_m to (step + 1) * step_m along the line) stays clear of every
        read circle by CLEAR_OF_CIRCLES_M: the partition is the same all along it, and
        ``partitions_along_segment`` on it gives one piece."""
        return self._quiet[step]

    def pieces(self, start: tuple[float, float], end: tuple[float, float]) -> list[SegmentPiece]:
        """``partitions_along_segment(deployment, start, end)`` for a step start-end of this walk."""
        r = self.deployment.read_range_m
        ux, uy = self.direction
        reach = r + 2.0 * CLEAR_OF_CIRCLES_M
        s_start = (start[0] - self.origin[0]) * ux + (start[1] - self.origin[1]) * uy
        s_end = (end[0] - self.origin[0]) * ux + (end[1] - self.origin[1]) * uy
        low = bisect.bisect_left(self._along, min(s_start, s_end) - reach)
        high = bisect.bisect_right(self._along, max(s_start, s_end) + reach)
        (ax, ay), (bx, by) = start, end
        dx, dy = bx - ax, by - ay
        length_sq = dx * dx + dy * dy
        within: list[tuple[int, int]] = []
        # A handful of tags: plain Python. Their distance to the step decides only far from r, where any rounding
        # agrees with candidates_near_segment's.
        for (i, j), (px, py) in zip(self._coordinates_list[low:high], self._positions_list[low:high]):
            t = min(max(((px - ax) * dx + (py - ay) * dy) / length_sq, 0.0), 1.0)
            distance = math.hypot(px - (ax + t * dx), py - (ay + t * dy))
            if abs(distance - r) <= BORDERLINE_M:
                return partitions_along_segment(self.deployment, start, end)
            if distance <= r:
                within.append((j, i))
        within.sort()                                   # candidates_near_segment's order: rows, then columns
        coordinates = np.array([(i, j) for j, i in within], dtype=np.int64).reshape(-1, 2)
        return partitions_along_segment(self.deployment, start, end, coordinates)


def partition_centre(lattice: Lattice, tags: Iterable[Coordinate]) -> tuple[float, float]:
    """Paper 000 section 4.1: a partition's location is the mean position of its tags."""
    positions = lattice.positions(np.array(list(tags), dtype=float).reshape(-1, 2))
    if len(positions) == 0:
        raise ValueError("an empty partition has no location")
    mean = positions.mean(axis=0)
    return float(mean[0]), float(mean[1])


def make_deployment(layout: str, read_range_m: float, area: tuple[float, float, float, float]) -> Deployment:
    """A deployment of ``layout`` for read range r over ``area``; DeploymentError on a bad description, naming the
    field of the description (layout, read_range_m, area) that its tag ids cannot hold."""
    if layout not in LAYOUTS:
        raise DeploymentError(f"layout: '{layout}' is not one of {', '.join(LAYOUTS)}")
    if not (isinstance(read_range_m, (int, float)) and math.isfinite(read_range_m) and read_range_m > 0.0):
        raise DeploymentError(f"read_range_m: must be a positive number, got {read_range_m}")
    spacing_m = spacing_for(layout, read_range_m)
    largest_m = ((1 << SPACING_BITS) - 1) * 1e-6
    if not 0.0 < spacing_m <= largest_m:
        lowest, highest = (bound / spacing_for(layout, 1.0) for bound in (1e-6, largest_m))
        raise DeploymentError(f"read_range_m: {read_range_m:g} m gives a {layout} spacing of {spacing_m * 1e6:.0f} "
                              f"um, which the tag ids (whole micrometres, {SPACING_BITS} bits) cannot hold: "
                              f"{lowest:.2g}-{highest:.3g} m")
    reach = max(abs(float(v)) for v in area) + read_range_m
    if math.isfinite(reach) and reach / spacing_m >= COORDINATE_BIAS:
        raise DeploymentError(f"area: reaches {reach:g} m from the origin, beyond the {COORDINATE_BITS}-bit lattice "
                              f"coordinates of the tag ids at a {spacing_m:g} m spacing "
                              f"({COORDINATE_BIAS * spacing_m:.3g} m)")
    return Deployment(Lattice(layout, spacing_m), float(read_range_m), tuple(float(v) for v in area))
