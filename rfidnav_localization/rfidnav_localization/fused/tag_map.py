"""What the fused localizer knows of the building: where each kind of tag is, the radio map, where the robot may be.

A robot map declares what it has (rfidnav_common.robot_map): ``tag_groups`` (their tags' positions follow from
each group's shape), ``deployment_area`` (a lattice of self-describing floor tags: a tag's id gives its position,
so the lattice is learned from the first id read), ``ceiling_tags``, ``floor_tags`` (single ones, outside any
group) and ``wall_tags`` (surveyed positions), a ``radio_map`` and the ``extent``. A kind the map does not declare
is evidence the localizer ignores.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import Rectangle, RouteMap
from rfidnav_common.tag_lattice import Deployment, TagIdError, decode_tag_id, lattice_of
from rfidnav_common.wall_tags import WallTag
from rfidnav_localization.fingerprint import RadioMap
from rfidnav_localization.partition.geometry import read_range_of


@dataclass
class FusedMap:
    extent: Rectangle
    floor_tags: dict[str, tuple[float, float]] = field(default_factory=dict)     # tag groups' and single ones
    ceiling_tags: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    wall_tags: dict[str, WallTag] = field(default_factory=dict)
    deployment_area: Rectangle | None = None
    radio_map: RadioMap | None = None
    # The lattice of the floor tags' ids, once one was read inside the deployment area (ids say layout and range).
    deployment: Deployment | None = None

    def __post_init__(self) -> None:
        ids = list(self.floor_tags)
        self._floor_ids = ids
        self._floor_positions = np.array([self.floor_tags[i] for i in ids], dtype=float).reshape(-1, 2)
        self._floor_tree = cKDTree(self._floor_positions) if ids else None

    @classmethod
    def of_route_map(cls, route_map: RouteMap, radio_map: RadioMap | None = None) -> FusedMap:
        extent = route_map.extent
        if extent is None:
            raise ConfigError(f"map '{route_map.name}'", "extent", "none given, and no walls or deployment_area to "
                                                                   "take it from: where may the robot be?")
        floor = {tag_id: position for group in route_map.tag_groups for tag_id, position in group.tags()}
        floor.update(route_map.floor_tags)
        return cls(extent=extent, floor_tags=floor, ceiling_tags=dict(route_map.ceiling_tags),
                   wall_tags={tag.tag_id: tag for tag in route_map.wall_tags},
                   deployment_area=route_map.deployment_area, radio_map=radio_map)

    def lattice_position(self, tag_id: str) -> tuple[tuple[float, float], float] | None:
        """(position, read range) of a lattice floor tag from its id, None for an id that is no lattice tag of
        this map (no deployment area, another lattice than the one learned, or not a lattice id at all)."""
        if self.deployment_area is None:
            return None
        try:
            decoded = decode_tag_id(tag_id)
        except TagIdError:
            return None
        lattice = lattice_of(decoded)
        if self.deployment is None:
            self.deployment = Deployment(lattice, read_range_of(lattice), self.deployment_area)
        elif lattice != self.deployment.lattice:
            return None
        return lattice.position(decoded.coordinate), self.deployment.read_range_m

    def floor_tags_near(self, x: float, y: float, radius: float) -> list[tuple[str, tuple[float, float]]]:
        """The tag groups' tags within ``radius`` of (x, y)."""
        if self._floor_tree is None:
            return []
        indices = sorted(self._floor_tree.query_ball_point((x, y), radius))
        return [(self._floor_ids[i], self.floor_tags[self._floor_ids[i]]) for i in indices]
