"""Route map (robot knowledge, ``config/maps/*.yaml``): which floor tag tells the robot it has arrived
under each ceiling tag (paper 001, step 8). It holds no positions: the robot never knows where tags are.

Schema::

    name: hallway
    arrival_tags:          # ceiling tag id -> id of the short-range floor tag under it
      C1: F1
      C2: F2
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rfidnav_common.config import Section


@dataclass(frozen=True)
class RouteMap:
    name: str
    arrival_tags: dict[str, str]

    def unknown_tags(self, route: list[str]) -> list[str]:
        return [tag for tag in route if tag not in self.arrival_tags]


def load_route_map(path: Path) -> RouteMap:
    section = Section.from_file(Path(path))
    section.reject_unknown(("name", "description", "arrival_tags"))
    pairs = section.section("arrival_tags")
    arrival: dict[str, str] = {}
    used: dict[str, str] = {}
    for ceiling_tag in pairs.keys():
        if not isinstance(ceiling_tag, str):
            raise pairs.error(str(ceiling_tag), "tag ids must be strings")
        floor_tag = pairs.string(ceiling_tag)
        if floor_tag in used:
            raise pairs.error(ceiling_tag, f"floor tag '{floor_tag}' is already the arrival tag of '{used[floor_tag]}'")
        used[floor_tag] = ceiling_tag
        arrival[ceiling_tag] = floor_tag
    if not arrival:
        raise section.error("arrival_tags", "at least one ceiling tag -> floor tag pair is needed")
    return RouteMap(name=section.string("name"), arrival_tags=arrival)
