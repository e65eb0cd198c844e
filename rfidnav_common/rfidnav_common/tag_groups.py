"""Floor RFID tag groups of paper 003 (Sec. 3.3, Fig. 6): tags laid along the outline of a small shape.

A robot that only roughly knows where it is (tier-one, fingerprinting) finds its exact position by driving a
spiral until its short-range reader (13.56 MHz, about 5 cm) reads a floor tag. A single tag is a needle in a
haystack; a group of tags along a cross, circle, triangle or square outline is a target the spiral cannot slip
past (see :mod:`rfidnav_control.spiral` for which shape is guaranteed to be crossed, and where).

Sizes (``size_m``): cross, the arm-to-arm length of each of its two perpendicular bars (the prototype's
30 x 30 cm cross has 0.30); circle, the diameter; triangle, the side of the equilateral triangle; square, the
side. ``rotation_rad`` turns the group CCW about its centre (the centroid for the triangle).

Tags sit on the outline, split into straight pieces (cross: the four arms from the centre; triangle and square:
the sides) or the whole circle. Each piece gets the whole number of equal gaps closest to ``tag_spacing_m``, so
the spacing is even along every piece and corners and the cross's centre carry exactly one tag. A reader of
range r reads every point of the outline when the spacing is at most 2r (the farthest outline point from a tag
is half a gap away): then any path crossing the outline reads a tag.

Pure module: no ROS; positions are metres in the frame the group is deployed in.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

SHAPES = ("cross", "circle", "triangle", "square")
HF_READ_RANGE_M = 0.05
"""Read range of the prototype's 13.56 MHz reader (paper 003 Sec. 4.1: "about 5 cm")."""
CIRCLE_POLYGON_SIDES = 256
"""Sides of the polygon standing for a circle outline; it strays at most R (1 - cos(pi/256)) < 1e-4 R inward."""

_PERIMETER_OVER_SIZE = {"cross": 2.0, "circle": math.pi, "triangle": 3.0, "square": 4.0}


def paper_size_for_separation(shape: str, separation_m: float) -> float:
    """The paper's size of ``shape`` for a spiral whose turns are ``separation_m`` (= 2 pi d) apart.

    Paper 003 takes a circle of diameter 2 pi d as the basis and gives the other shapes the same tag-line length
    (2 pi^2 d): cross bars pi^2 d, triangle side 2 pi^2 d / 3, square side pi^2 d / 2. Only the circle and, away
    from the spiral origin, the cross are then sure to be crossed; ``rfidnav_control.spiral.separation_for_group``
    sizes the spiral for any shape.
    """
    _check_shape(shape)
    return math.pi * separation_m / _PERIMETER_OVER_SIZE[shape]


def minimum_width(shape: str, size_m: float) -> float:
    """Smallest width of the group over all directions: the narrowest band of parallel lines it can hide in.

    A spiral far from its origin looks locally like parallel lines, so this width decides whether a group can
    sit between two turns. Cross: L / sqrt(2) (its projection on a direction is max(L|cos|, L|sin|) and, the
    cross being connected, an interval); circle: the diameter; triangle: its height; square: its side.
    """
    _check_shape(shape)
    factor = {"cross": math.sqrt(0.5), "circle": 1.0, "triangle": math.sqrt(3.0) / 2.0, "square": 1.0}[shape]
    return factor * size_m


def tags_in_range(tag_positions: np.ndarray, x: float, y: float, read_range_m: float) -> np.ndarray:
    """Indices (ascending) of the rows of ``tag_positions`` (N x 2) within ``read_range_m`` of (x, y)."""
    positions = np.asarray(tag_positions, dtype=float).reshape(-1, 2)
    return np.flatnonzero(np.hypot(positions[:, 0] - x, positions[:, 1] - y) <= read_range_m)


def _check_shape(shape: Any) -> None:
    if shape not in SHAPES:
        raise ValueError(f"shape: expected one of {', '.join(SHAPES)}, got {shape!r}")


def _finite(value: Any) -> bool:
    # bool is an int subclass; True as a size is a YAML slip, not the number 1.
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class TagGroup:
    """One tag group on the floor; validated on construction (:meth:`validate`)."""

    group_id: str
    shape: str
    centre: tuple[float, float]
    size_m: float = 0.30
    rotation_rad: float = 0.0
    tag_spacing_m: float = 0.05

    def __post_init__(self) -> None:
        self.validate()
        object.__setattr__(self, "centre", (float(self.centre[0]), float(self.centre[1])))

    def validate(self) -> None:
        """Raise ValueError naming the first field that cannot describe a group."""
        if not isinstance(self.group_id, str) or not self.group_id.strip():
            raise ValueError(f"group_id: expected a non-empty string, got {self.group_id!r}")
        where = f"tag group {self.group_id!r}"
        if self.shape not in SHAPES:
            raise ValueError(f"{where}: shape: expected one of {', '.join(SHAPES)}, got {self.shape!r}")
        centre = self.centre
        if isinstance(centre, (str, bytes)) or not hasattr(centre, "__len__") or len(centre) != 2 \
                or not all(_finite(c) for c in centre):
            raise ValueError(f"{where}: centre: expected two finite numbers (x, y), got {centre!r}")
        for name in ("size_m", "tag_spacing_m"):
            value = getattr(self, name)
            if not _finite(value) or value <= 0.0:
                raise ValueError(f"{where}: {name}: expected a positive finite number, got {value!r}")
        if not _finite(self.rotation_rad):
            raise ValueError(f"{where}: rotation_rad: expected a finite number, got {self.rotation_rad!r}")

    def _to_world(self, local: np.ndarray) -> np.ndarray:
        c, s = math.cos(self.rotation_rad), math.sin(self.rotation_rad)
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.centre)

    def _corners(self) -> np.ndarray:
        """Polygon corners (CCW, local frame) of the triangle (apex on +y) or the square (axis-aligned)."""
        if self.shape == "triangle":
            angles = math.pi / 2.0 + 2.0 * math.pi * np.arange(3) / 3.0
            return self.size_m / math.sqrt(3.0) * np.column_stack([np.cos(angles), np.sin(angles)])
        half = self.size_m / 2.0
        return np.array([[half, half], [-half, half], [-half, -half], [half, -half]])

    def outline_segments(self) -> list[np.ndarray]:
        """The outline as polyline pieces (each K x 2, world frame): cross arms from the centre, polygon sides,
        or the circle as a closed :data:`CIRCLE_POLYGON_SIDES`-gon (first vertex repeated last)."""
        if self.shape == "circle":
            angles = 2.0 * math.pi * np.arange(CIRCLE_POLYGON_SIDES + 1) / CIRCLE_POLYGON_SIDES
            ring = self.size_m / 2.0 * np.column_stack([np.cos(angles), np.sin(angles)])
            return [self._to_world(ring)]
        if self.shape == "cross":
            half = self.size_m / 2.0
            ends = half * np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
            return [self._to_world(np.array([[0.0, 0.0], end])) for end in ends]
        corners = self._corners()
        return [self._to_world(np.array([corners[i], corners[(i + 1) % len(corners)]]))
                for i in range(len(corners))]

    def _gaps(self, length_m: float) -> int:
        return max(1, round(length_m / self.tag_spacing_m))

    def tag_positions(self) -> np.ndarray:
        """Tag positions (N x 2, world frame) in id order."""
        if self.shape == "circle":
            count = self._gaps(math.pi * self.size_m)
            angles = 2.0 * math.pi * np.arange(count) / count
            local = self.size_m / 2.0 * np.column_stack([np.cos(angles), np.sin(angles)])
            return self._to_world(local)
        points = []
        if self.shape == "cross":
            # The centre once, then each arm from its first gap out to its tip.
            points.append(np.zeros((1, 2)))
            half = self.size_m / 2.0
            gaps = self._gaps(half)
            steps = half * np.arange(1, gaps + 1) / gaps
            for direction in ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)):
                points.append(steps[:, None] * np.asarray(direction))
        else:
            # Each side from its start corner up to, not including, the next corner (the next side's start).
            corners = self._corners()
            gaps = self._gaps(self.size_m)
            fractions = np.arange(gaps) / gaps
            for i in range(len(corners)):
                start, end = corners[i], corners[(i + 1) % len(corners)]
                points.append(start + fractions[:, None] * (end - start))
        return self._to_world(np.vstack(points))

    def tags(self) -> list[tuple[str, tuple[float, float]]]:
        """(tag id, (x, y)) of every tag; ids are ``f"{group_id}-{k:02d}"`` in :meth:`tag_positions` order."""
        return [(f"{self.group_id}-{k:02d}", (float(x), float(y)))
                for k, (x, y) in enumerate(self.tag_positions())]
