"""Robot maps (robot knowledge, ``config/maps/*.yaml``): what a navigation node may know of the world.

They hold no tag positions unless surveyed ones are declared: the paper methods never know where tags are. A map
has any of:

* ``arrival_tags`` (paper 001, step 8): the floor tag that tells the robot it has arrived under each
  ceiling tag;
* ``deployment_area`` (paper 000): the rectangle covered by floor tags. Layout, spacing and read range
  the robot learns from the tags' own IDs; the area lets a navigator refuse a goal off the deployment.
* ``tag_groups`` (paper 003): the location server's tag map, floor tag groups whose tags and positions are
  registered (the paper's landmarks). Worlds describe their groups with the same schema.
* ``radio_map`` (paper 003): a file of WiFi fingerprints (``./rfidnav survey`` writes one) the location server
  starts from when its database holds none; relative to the map file.
* ``walls`` and ``extent`` (paper 003): the home's floor plan as its owner knows it, the walls as segments and the
  rectangle the robot may drive in. The two-tier navigator plans its legs round the walls and keeps its spiral
  searches inside; a goal outside the extent is refused. Without ``extent`` it is the walls' bounding box, then
  the ``deployment_area``.
* ``ceiling_tags``, ``floor_tags`` and ``wall_tags`` (the fused localizer, rfidnav_localization.fused): surveyed
  positions of ceiling tags (paper 001's route tags), of single floor tags (paper 001's arrival tags) and of wall
  tag plates (paper 004's, the world files' schema), as a building's tag survey records them. No paper method
  reads them.

Schema::

    name: hallway
    arrival_tags:          # ceiling tag id -> id of the short-range floor tag under it
      C1: F1
      C2: F2
    deployment_area: [0.0, 0.0, 5.0, 5.0]   # x_min, y_min, x_max, y_max [m], map frame
    tag_groups:            # tags GROUP-00, GROUP-01, ... along the outline (rfidnav_common.tag_groups)
      - {id: G1, shape: cross, centre: [1.0, 2.0], size_m: 0.30, rotation_deg: 0.0, tag_spacing_m: 0.05}
        # shape: cross | circle | triangle | square; size_m: cross bar length, circle diameter, side
    radio_map: two_tier_home_radio_map.yaml
    walls:                 # segments [x1, y1, x2, y2] [m], map frame
      - [0.0, 0.0, 12.0, 0.0]
    extent: [0.0, 0.0, 12.0, 8.0]          # x_min, y_min, x_max, y_max [m]
    ceiling_tags:          # tag id -> [x, y, z] [m], map frame
      C1: [0.0, 0.0, 3.0]
    floor_tags:            # tag id -> [x, y] [m], map frame: single floor tags, outside any tag group
      F1: [0.0, 0.0]
    wall_tags:             # plates on walls; normal: out of the wall into the hallway
      - {id: "8", position: [7.2, 9.0], normal: [0.0, -1.0]}
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from rfidnav_common.config import Section, check_number
from rfidnav_common.errors import ConfigError
from rfidnav_common.tag_groups import TagGroup
from rfidnav_common.wall_tags import WallTag

Wall = tuple[float, float, float, float]          # x1, y1, x2, y2 [m]
Rectangle = tuple[float, float, float, float]     # x_min, y_min, x_max, y_max [m]


@dataclass(frozen=True)
class RouteMap:
    name: str
    arrival_tags: dict[str, str]
    deployment_area: tuple[float, float, float, float] | None = None
    tag_groups: tuple[TagGroup, ...] = ()
    radio_map_file: Path | None = None
    walls: tuple[Wall, ...] = ()
    declared_extent: Rectangle | None = None
    ceiling_tags: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    wall_tags: tuple[WallTag, ...] = ()
    floor_tags: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def extent(self) -> Rectangle | None:
        """Where the robot may be: the declared extent, else the walls' bounding box, else the deployment area."""
        if self.declared_extent is not None:
            return self.declared_extent
        return bounding_box(self.walls) if self.walls else self.deployment_area

    def unknown_tags(self, route: list[str]) -> list[str]:
        return [tag for tag in route if tag not in self.arrival_tags]


def repeated_in_a_row(route: Sequence[str]) -> str | None:
    """Why a route that lists one tag twice in a row is refused (None if it does not). A leg joins two different
    tags: a tag listed again at once would have the follower, just past it, turn back to pass it again, which no
    one means. A tag listed again later is a way back along the same hallway, and is followed as listed."""
    for index, (here, there) in enumerate(zip(route, route[1:])):
        if here == there:
            return (f"{here} twice in a row (positions {index + 1} and {index + 2}): each leg joins two different "
                    "tags")
    return None


def load_route_map(path: Path, radio_map_may_be_missing: bool = False) -> RouteMap:
    """A route map; its ``radio_map`` must exist unless ``radio_map_may_be_missing`` (the survey that writes it)."""
    section = Section.from_file(Path(path))
    section.reject_unknown(("name", "description", "arrival_tags", "deployment_area", "tag_groups", "radio_map",
                            "walls", "extent", "ceiling_tags", "floor_tags", "wall_tags"))
    arrival = _arrival_tags(section) if section.has("arrival_tags") else {}
    area = rectangle_of(section, "deployment_area")
    extent = rectangle_of(section, "extent")
    walls = walls_of(section)
    groups = tag_groups_of(section)
    radio_map = None
    if section.has("radio_map"):
        radio_map = (Path(path).parent / section.string("radio_map")).resolve()
        if not (radio_map.is_file() or radio_map_may_be_missing and not radio_map.exists()):
            raise section.error("radio_map", f"no such file: {radio_map}")
    ceiling_tags = {tag_id: (x, y, z) for tag_id, (x, y, z) in surveyed_tags_of(section, "ceiling_tags", 3).items()}
    floor_tags = {tag_id: (x, y) for tag_id, (x, y) in surveyed_tags_of(section, "floor_tags", 2).items()}
    wall_tags = wall_tags_of(section)
    if not arrival and area is None and not groups and not ceiling_tags and not floor_tags and not wall_tags:
        raise section.error("arrival_tags", "a map needs arrival_tags, a deployment_area, tag_groups, ceiling_tags, "
                                            "floor_tags or wall_tags (none given)")
    return RouteMap(name=section.string("name"), arrival_tags=arrival, deployment_area=area, tag_groups=groups,
                    radio_map_file=radio_map, walls=walls, declared_extent=extent, ceiling_tags=ceiling_tags,
                    wall_tags=wall_tags, floor_tags=floor_tags)


def bounding_box(walls: Sequence[Wall]) -> Rectangle:
    """The smallest rectangle holding every wall (at least one)."""
    xs = [x for wall in walls for x in (wall[0], wall[2])]
    ys = [y for wall in walls for y in (wall[1], wall[3])]
    return min(xs), min(ys), max(xs), max(ys)


def contains(rectangle: Rectangle, x: float, y: float) -> bool:
    """(x, y) lies in the rectangle, its edges included."""
    return rectangle[0] <= x <= rectangle[2] and rectangle[1] <= y <= rectangle[3]


def rectangle_of(section: Section, key: str) -> Rectangle | None:
    """An optional ``[x_min, y_min, x_max, y_max]`` with max > min."""
    if not section.has(key):
        return None
    x_min, y_min, x_max, y_max = section.numbers(key, length=4)
    if not (x_max > x_min and y_max > y_min):
        raise section.error(key, f"expected [x_min, y_min, x_max, y_max] with max > min, got "
                                 f"[{x_min:g}, {y_min:g}, {x_max:g}, {y_max:g}]")
    return x_min, y_min, x_max, y_max


def walls_of(section: Section) -> tuple[Wall, ...]:
    """The optional ``walls`` list of a map or world file: segments ``[x1, y1, x2, y2]`` of finite numbers."""
    raw_walls = section.raw("walls", [])
    if not isinstance(raw_walls, list):
        raise section.error("walls", "expected a list of [x1, y1, x2, y2]")
    walls = []
    for index, wall in enumerate(raw_walls):
        field = f"{section.field('walls')}[{index}]"
        if not isinstance(wall, list) or len(wall) != 4:
            raise ConfigError(section.source, field, "expected [x1, y1, x2, y2]")
        x1, y1, x2, y2 = (check_number(value, section.source, f"{field}[{i}]") for i, value in enumerate(wall))
        walls.append((x1, y1, x2, y2))
    return tuple(walls)


MAX_TAGS_PER_SIDE = 2500      # a tag group's size over its tag spacing: no group of more than ~10,000 tags


def tag_groups_of(section: Section) -> tuple[TagGroup, ...]:
    """The ``tag_groups`` list of a map or world file (schema above); group ids unique."""
    groups: list[TagGroup] = []
    seen: dict[str, str] = {}
    for entry in section.sections("tag_groups", []):
        entry.reject_unknown(("id", "shape", "centre", "size_m", "rotation_deg", "tag_spacing_m"))
        group_id = entry.string("id")
        if group_id in seen:
            raise entry.error("id", f"duplicate tag group '{group_id}' (also at {seen[group_id]})")
        seen[group_id] = entry.prefix
        centre = entry.numbers("centre", length=2)
        size_m = entry.number("size_m", 0.30, positive=True)
        spacing_m = entry.number("tag_spacing_m", 0.05, positive=True)
        if size_m / spacing_m > MAX_TAGS_PER_SIDE:
            raise entry.error("tag_spacing_m", f"a tag every {spacing_m:g} m of a {size_m:g} m group is "
                                               f"{size_m / spacing_m:.3g} tags a side, more than {MAX_TAGS_PER_SIDE:,}")
        try:
            groups.append(TagGroup(group_id, entry.string("shape"), (centre[0], centre[1]), size_m,
                                   math.radians(entry.number("rotation_deg", 0.0, minimum=-360.0, maximum=360.0)),
                                   spacing_m))
        except ValueError as error:          # the message names the field: "... size_m: expected ..."
            raise ConfigError(entry.source, entry.prefix, str(error)) from None
    return tuple(groups)


def wall_tags_of(section: Section, seen: dict[str, str] | None = None) -> tuple[WallTag, ...]:
    """The optional ``wall_tags`` list of a map or world file; ids unique among the file's tags (``seen``: id ->
    where, of the tags met before)."""
    seen = {} if seen is None else seen
    wall_tags = []
    for entry in section.sections("wall_tags", []):
        entry.reject_unknown(("id", "position", "normal"))
        raw_id = entry.raw("id")
        tag_id = str(raw_id) if isinstance(raw_id, (str, int)) and not isinstance(raw_id, bool) else entry.string("id")
        if tag_id in seen:
            raise entry.error("id", f"duplicate tag id '{tag_id}' (also at {seen[tag_id]})")
        seen[tag_id] = entry.prefix
        position = entry.numbers("position", length=2)
        nx, ny = entry.numbers("normal", length=2)
        length = (nx * nx + ny * ny) ** 0.5
        if length == 0.0:
            raise entry.error("normal", "must not be zero (it points out of the wall into the hallway)")
        wall_tags.append(WallTag(tag_id, (position[0], position[1]), (nx / length, ny / length)))
    return tuple(wall_tags)


def surveyed_tags_of(section: Section, key: str, dimensions: int) -> dict[str, tuple[float, ...]]:
    """A map's optional surveyed tags under ``key``: tag id -> its position, ``dimensions`` numbers [m], map frame."""
    if not section.has(key):
        return {}
    entries = section.section(key)
    tags = {}
    for tag_id in entries.keys():
        if not isinstance(tag_id, str):
            raise entries.error(str(tag_id), "tag ids must be strings")
        tags[tag_id] = tuple(entries.numbers(tag_id, length=dimensions))
    return tags


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
