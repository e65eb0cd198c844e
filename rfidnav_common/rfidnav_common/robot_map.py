"""Robot maps (robot knowledge, ``config/maps/*.yaml``): what a navigation node may know of the world.

They hold no tag positions: the robot never knows where tags are. A map has any of:

* ``arrival_tags`` (paper 001, step 8): the floor tag that tells the robot it has arrived under each
  ceiling tag;
* ``deployment_area`` (paper 000): the rectangle covered by floor tags. Layout, spacing and read range
  the robot learns from the tags' own IDs; the area lets a navigator refuse a goal off the deployment.

Schema::

    name: hallway
    arrival_tags:          # ceiling tag id -> id of the short-range floor tag under it
      C1: F1
      C2: F2
    deployment_area: [0.0, 0.0, 5.0, 5.0]   # x_min, y_min, x_max, y_max [m], map frame
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from rfidnav_common.config import Section


@dataclass(frozen=True)
class RouteMap:
    name: str
    arrival_tags: dict[str, str]
    deployment_area: tuple[float, float, float, float] | None = None

    def unknown_tags(self, route: list[str]) -> list[str]:
        return [tag for tag in route if tag not in self.arrival_tags]


def load_route_map(path: Path) -> RouteMap:
    section = Section.from_file(Path(path))
    section.reject_unknown(("name", "description", "arrival_tags", "deployment_area"))
    arrival = _arrival_tags(section) if section.has("arrival_tags") else {}
    area = None
    if section.has("deployment_area"):
        x_min, y_min, x_max, y_max = section.numbers("deployment_area", length=4)
        if not (x_max > x_min and y_max > y_min):
            raise section.error("deployment_area", "expected [x_min, y_min, x_max, y_max] with max > min")
        area = (x_min, y_min, x_max, y_max)
    if not arrival and area is None:
        raise section.error("arrival_tags", "a map needs arrival_tags or a deployment_area (none given)")
    return RouteMap(name=section.string("name"), arrival_tags=arrival, deployment_area=area)


def _arrival_tags(section: Section) -> dict[str, str]:
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
    return arrival
