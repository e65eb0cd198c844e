"""Ground truth of a simulated world (``config/worlds/*.yaml``): tags with positions, walls.

Only simulator nodes and metrics read worlds; navigation nodes know the world only through maps.

Schema::

    name: hallway                      # required
    frame_id: map                      # optional, default map
    tags:                              # ids unique (optional when lattices are given)
      - {id: C1, position: [0.0, 0.0, 3.0]}                 # metres, map frame
      - {id: F1, position: [0.0, 0.0, 0.0], kind: floor}    # kind: ceiling (default) | floor
        # optional per tag: phase_offset_rad (tag's own backscatter phase, default 0)
    walls:                             # optional, line segments [x1, y1, x2, y2] in metres
      - [-1.0, -1.0, -1.0, 10.0]
    lattices:                          # optional, floor tag deployments of paper 000, described not listed
      - {layout: triangular, read_range_m: 0.2, area: [0.0, 0.0, 5.0, 5.0]}
        # layout: grid | triangular | compressed; area: [x_min, y_min, x_max, y_max] in metres. The tags are
        # the lattice vertices whose read disc reaches into the area, tag (0, 0) at the map origin, each
        # with its self-describing EPC (rfidnav_common.tag_lattice); a downward antenna reads them within
        # read_range_m (horizontally), so worlds with hundreds of thousands of tags cost nothing to load.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_common.config import Section, check_number
from rfidnav_common.tag_lattice import Deployment, DeploymentError, make_deployment
from rfidnav_common.errors import ConfigError

TAG_KINDS = ("ceiling", "floor")


@dataclass(frozen=True)
class Tag:
    tag_id: str
    position: tuple[float, float, float]
    kind: str = "ceiling"
    phase_offset_rad: float = 0.0


@dataclass(frozen=True)
class World:
    name: str
    frame_id: str
    tags: tuple[Tag, ...]
    walls: tuple[tuple[float, float, float, float], ...]
    deployments: tuple[Deployment, ...] = ()

    def tag(self, tag_id: str) -> Tag:
        for tag in self.tags:
            if tag.tag_id == tag_id:
                return tag
        raise KeyError(tag_id)

    def tag_positions(self) -> np.ndarray:
        return np.array([tag.position for tag in self.tags], dtype=float).reshape(-1, 3)


def world_from_section(section: Section) -> World:
    section.reject_unknown(("name", "frame_id", "tags", "walls", "lattices", "description"))
    tags: list[Tag] = []
    seen: dict[str, str] = {}
    for tag_section in section.sections("tags", []):
        tag_section.reject_unknown(("id", "position", "kind", "phase_offset_rad"))
        tag_id = tag_section.string("id")
        if tag_id in seen:
            raise tag_section.error("id", f"duplicate tag id '{tag_id}' (also at {seen[tag_id]})")
        seen[tag_id] = tag_section.prefix
        position = tag_section.numbers("position", length=3)
        tags.append(Tag(tag_id=tag_id, position=(position[0], position[1], position[2]),
                        kind=tag_section.string("kind", "ceiling", choices=TAG_KINDS),
                        phase_offset_rad=tag_section.number("phase_offset_rad", 0.0)))
    walls = []
    walls_field = section.field("walls")
    raw_walls = section.raw("walls", [])
    if not isinstance(raw_walls, list):
        raise section.error("walls", "expected a list of [x1, y1, x2, y2]")
    for index, wall in enumerate(raw_walls):
        field = f"{walls_field}[{index}]"
        if not isinstance(wall, list) or len(wall) != 4:
            raise ConfigError(section.source, field, "expected [x1, y1, x2, y2]")
        x1, y1, x2, y2 = (check_number(value, section.source, f"{field}[{i}]") for i, value in enumerate(wall))
        walls.append((x1, y1, x2, y2))
    deployments = tuple(_deployment(entry) for entry in section.sections("lattices", []))
    if not tags and not deployments:
        raise section.error("tags", "a world needs tags or lattices (none given)")
    return World(name=section.string("name"), frame_id=section.string("frame_id", "map"),
                 tags=tuple(tags), walls=tuple(walls), deployments=deployments)


def _deployment(entry: Section) -> Deployment:
    entry.reject_unknown(("layout", "read_range_m", "area"))
    area = entry.numbers("area", length=4)
    try:
        return make_deployment(entry.string("layout"), entry.number("read_range_m"), tuple(area))
    except DeploymentError as error:
        field, _, problem = str(error).partition(": ")
        raise entry.error(field, problem) from None


def load_world(path: Path) -> World:
    """Load and validate a world file; any problem is a ConfigError naming file and field."""
    return world_from_section(Section.from_file(Path(path)))
