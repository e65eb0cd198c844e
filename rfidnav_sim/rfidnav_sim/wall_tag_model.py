"""The 2.45 GHz RFID tag sensor of paper 004 (section 2) reading tag plates on the hallway walls.

Paper 004 pastes each tag (in a 12 cm square plastic plate) on the LEFT wall near a junction, and the robot,
following that wall at about 0.8 m, reads it with a sensor whose induction area is "40 cm wide and 100 cm depth
from the antenna" (Fig. 3). The area is modelled as exactly that rectangle: it starts at the antenna and reaches
``depth_m`` along the antenna's bearing, ``width_m`` across, edges included. Inside it a tag is read when its
face is towards the antenna (a plate on the far side of a wall has its normal pointing away, and the wall is in
the way), unless the read misses. Tag height is ignored: the area is a footprint in the floor plane, as the
paper's sensitivity map is.

Three kinds of misses: ``miss_probability``, independent per tag and round (a tag in reach for ~40 rounds is then
practically never missed for good); ``passage_miss_probability``, drawn once when a tag comes into reach and kept
until it has left it (paper 004's read failure: the robot passes a tag without reading it); and
``unreadable_tags``, never read (a broken or covered plate: forced failures for tests).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from rfidnav_common.wall_tags import InductionArea, WallTag
from rfidnav_sim.nearby import NearbyGrid


class WallTagReader:
    """Which wall tags one antenna reads per inventory round, with the robot at a pose."""

    def __init__(self, area: InductionArea, tags: Sequence[WallTag], miss_probability: float = 0.0,
                 passage_miss_probability: float = 0.0, unreadable_tags: Sequence[str] = ()) -> None:
        for name, value in (("miss_probability", miss_probability),
                            ("passage_miss_probability", passage_miss_probability)):
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name}: {value} is not in [0, 1]")
        ids = [tag.tag_id for tag in tags]
        if len(set(ids)) != len(ids):
            raise ValueError(f"tags: tag_id must be unique, got {ids}")
        unknown = sorted(set(unreadable_tags) - set(ids))
        if unknown:
            raise ValueError(f"unreadable_tags: {', '.join(unknown)} not among the wall tags")
        self.area = area
        self.tags = tuple(tags)
        self.miss_probability = miss_probability
        self.passage_miss_probability = passage_miss_probability
        self.readable = [tag_id not in set(unreadable_tags) for tag_id in ids]
        self.passage_read = [True] * len(self.tags)   # per tag: read on its current passage
        self.was_in_reach: set[int] = set()
        # Only the tags within the area's reach of the robot's centre can be in it (plus a millimetre, over the
        # rounding of the grid's distances): a robot among them tests a few, not the floor's every tag.
        reach_m = math.hypot(*area.position) + math.hypot(area.depth_m, area.width_m / 2.0) + 1e-3
        points = np.array([(*tag.position, *tag.position) for tag in self.tags], dtype=float).reshape(-1, 4)
        self.nearby = NearbyGrid(points, reach_m, lambda indices: indices.tolist())

    def antenna_pose(self, x: float, y: float, yaw: float) -> tuple[float, float, float]:
        """World (x, y, bearing) of the antenna for a robot pose."""
        c, s = math.cos(yaw), math.sin(yaw)
        ax, ay = self.area.position
        return x + c * ax - s * ay, y + s * ax + c * ay, yaw + self.area.bearing_rad

    def reached(self, x: float, y: float, yaw: float) -> list[int]:
        """Indices (ascending) of the tags that lie in the induction area and face the antenna."""
        antenna_x, antenna_y, bearing = self.antenna_pose(x, y, yaw)
        c, s = math.cos(bearing), math.sin(bearing)
        depth_m, half_width_m = self.area.depth_m, self.area.width_m / 2.0
        found = []
        for index in self.nearby.near(x, y):
            tag = self.tags[index]
            to_tag_x, to_tag_y = tag.position[0] - antenna_x, tag.position[1] - antenna_y
            depth = c * to_tag_x + s * to_tag_y                  # along the bearing
            across = -s * to_tag_x + c * to_tag_y
            if (0.0 <= depth <= depth_m and abs(across) <= half_width_m
                    and tag.normal[0] * -to_tag_x + tag.normal[1] * -to_tag_y > 0.0):   # normal . (antenna - tag)
                found.append(index)
        return found

    def in_reach(self, x: float, y: float, yaw: float) -> np.ndarray:
        """Per tag, whether it lies in the induction area and faces the antenna: what a reader without misses reads."""
        reach = np.zeros(len(self.tags), dtype=bool)
        reach[self.reached(x, y, yaw)] = True
        return reach

    def read(self, x: float, y: float, yaw: float, rng: np.random.Generator) -> list[str]:
        """Ids of the tags read in one round with the robot at (x, y, yaw), in tag order."""
        # Draws for every tag, read or not, so the stream consumed does not depend on the pose: per tag, whether
        # this round's read is kept, then whether a passage starting now is read (one draw of 2 n is the stream
        # of two of n, to the bit).
        count = len(self.tags)
        draws = rng.random(2 * count)
        reach = self.reached(x, y, yaw)
        ids = []
        for index in reach:
            if index not in self.was_in_reach:                   # arriving: its passage is decided now
                self.passage_read[index] = bool(draws[count + index] >= self.passage_miss_probability)
            if draws[index] >= self.miss_probability and self.passage_read[index] and self.readable[index]:
                ids.append(self.tags[index].tag_id)
        self.was_in_reach = set(reach)
        return ids
