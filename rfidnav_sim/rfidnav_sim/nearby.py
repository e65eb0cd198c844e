"""Which of a floor's segments lie near a point, in one look-up: a uniform grid whose cells list them.

The sonar casts only at the walls within its reach and the wall-tag reader tests only the tags within its
antenna's (a tag is a segment of length zero); each keeps, per cell, what it works on (a sonar's walls with their
directions worked out; a reader's tag indices), made from the indices of the segments the cell lists the first
time a point falls in it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Generic, TypeVar

import numpy as np

from rfidnav_common.geometry import point_segment_distance

T = TypeVar("T")


class NearbyGrid(Generic[T]):
    """A uniform grid over segments (N x 4 rows x1, y1, x2, y2): each ``cell_m`` square cell holds ``payload``
    of the indices (ascending) of the segments that come within ``reach_m`` of any point in it (within reach of
    its centre plus half its diagonal), made when a point first falls in a cell listing them (a robot's mission
    visits a few of a floor's cells). A point off the grid gets every segment.

    So a search within ``reach_m`` of a point among the cell's segments finds what a search among all of them
    finds: the segments it leaves out are farther from the point than ``reach_m``."""

    def __init__(self, segments: np.ndarray, reach_m: float, payload: Callable[[np.ndarray], T],
                 cell_m: float = 1.0) -> None:
        segments = np.asarray(segments, dtype=float).reshape(-1, 4)
        self.everything = payload(np.arange(len(segments)))
        self.payload = payload
        self.cell_m = cell_m
        self.cells: list[int] = []                  # per cell, which of the index sets it lists
        self.sets: list[np.ndarray] = []            # neighbouring cells mostly list the same segments: one each
        self.made: list[T | None] = []              # the payload of each set, once asked for
        if len(segments) == 0:
            self.origin, self.shape = np.zeros(2), (0, 0)
            return
        low = np.minimum(segments[:, :2], segments[:, 2:]).min(axis=0) - reach_m
        high = np.maximum(segments[:, :2], segments[:, 2:]).max(axis=0) + reach_m
        self.origin = low
        columns, rows = np.ceil((high - low) / cell_m)
        self.shape = (int(columns), int(rows))
        ix, iy = np.meshgrid(np.arange(self.shape[0]), np.arange(self.shape[1]), indexing="ij")
        centres = low + (np.column_stack((ix.ravel(), iy.ravel())) + 0.5) * cell_m
        distances = np.column_stack([point_segment_distance(centres, segment[:2], segment[2:])
                                     for segment in segments])
        within = distances <= reach_m + cell_m / math.sqrt(2.0)                          # cells x segments
        numbers: dict[bytes, int] = {}
        for row in within:
            number = numbers.setdefault(row.tobytes(), len(numbers))
            if number == len(self.sets):
                self.sets.append(np.flatnonzero(row))
                self.made.append(None)
            self.cells.append(number)

    def near(self, x: float, y: float) -> T:
        """What the cell of (x, y) holds: of the segments that may lie within reach of it."""
        i = math.floor((x - self.origin[0]) / self.cell_m)
        j = math.floor((y - self.origin[1]) / self.cell_m)
        if not (0 <= i < self.shape[0] and 0 <= j < self.shape[1]):
            return self.everything
        number = self.cells[i * self.shape[1] + j]
        made = self.made[number]
        if made is None:
            made = self.made[number] = self.payload(self.sets[number])
        return made
