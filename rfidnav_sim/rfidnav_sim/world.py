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
    extent: [-1.0, -1.0, 12.0, 10.0]   # optional, the floor [x_min, y_min, x_max, y_max] in metres (max > min);
                                       # default: the walls' bounding box. A grid survey covers it.
    lattices:                          # optional, floor tag deployments of paper 000, described not listed
      - {layout: triangular, read_range_m: 0.2, area: [0.0, 0.0, 5.0, 5.0]}
        # layout: grid | triangular | compressed; area: [x_min, y_min, x_max, y_max] in metres. The tags are
        # the lattice vertices whose read disc reaches into the area, tag (0, 0) at the map origin, each
        # with its self-describing EPC (rfidnav_common.tag_lattice); a downward antenna reads them within
        # read_range_m (horizontally), so worlds with hundreds of thousands of tags cost nothing to load.
    tag_groups:                        # optional, floor tag groups (paper 003): their tags are floor tags
      - {id: G1, shape: cross, centre: [1.0, 2.0], size_m: 0.30}   # schema: rfidnav_common.robot_map
    wall_tags:                         # optional, tag plates on walls (paper 004), read by side antennas
      - {id: "8", position: [7.2, 9.0], normal: [0.0, -1.0]}   # normal: out of the wall, into the hallway
    access_points:                     # optional, WiFi access points (paper 003), bssids unique
      - {bssid: "02:00:00:00:00:01", ssid: home, position: [1.0, 2.0], tx_power_dbm: 20.0, channel: 6}
    wifi:                              # optional, how this building attenuates WiFi (rfidnav_sim.wifi_model)
      path_loss_exponent: 2.0          # between walls (walls are counted separately)
      wall_loss_db: 5.0                # per wall the straight ray crosses
      shadowing_sd_db: 4.0             # spatially correlated shadowing, fixed for the world...
      shadowing_correlation_m: 2.0     # ...with this correlation length...
      shadowing_seed: 1                # ...and this seed (the building, not the run: fingerprints stay put)
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_common.config import DBM, Section
from rfidnav_common.errors import ConfigError, ParameterError
from rfidnav_common.robot_map import rectangle_of, tag_groups_of, wall_tags_of, walls_of
from rfidnav_common.tag_groups import TagGroup
from rfidnav_common.tag_lattice import Deployment, DeploymentError, make_deployment
from rfidnav_common.wall_tags import WallTag
from rfidnav_sim.wifi_model import AccessPoint, PropagationSettings

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
    tag_groups: tuple[TagGroup, ...] = ()
    wall_tags: tuple[WallTag, ...] = ()
    access_points: tuple[AccessPoint, ...] = ()
    wifi: PropagationSettings = PropagationSettings()   # the building's part; a receiver adds noise, sensitivity
    wifi_seed: int = 1
    extent: tuple[float, float, float, float] | None = None     # declared: x_min, y_min, x_max, y_max
    source: str = ""                                             # the file it was loaded from, for messages

    def tag(self, tag_id: str) -> Tag:
        for tag in self.tags:
            if tag.tag_id == tag_id:
                return tag
        raise KeyError(tag_id)

    def tag_positions(self) -> np.ndarray:
        return np.array([tag.position for tag in self.tags], dtype=float).reshape(-1, 3)

    def wall_segments(self) -> np.ndarray:
        """The walls as an N x 4 array of [x1, y1, x2, y2] rows (N may be 0)."""
        return np.array(self.walls, dtype=float).reshape(-1, 4)


def world_from_section(section: Section) -> World:
    section.reject_unknown(("name", "frame_id", "tags", "walls", "extent", "lattices", "tag_groups", "wall_tags",
                            "access_points", "wifi", "description"))
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
    walls = walls_of(section)
    deployments = tuple(_deployment(entry) for entry in section.sections("lattices", []))
    groups = tag_groups_of(section)
    for group in groups:
        for tag_id, (x, y) in group.tags():
            if tag_id in seen:
                raise section.error("tag_groups",
                                    f"tag group {group.group_id}'s tag id '{tag_id}' is also at {seen[tag_id]}")
            seen[tag_id] = f"tag group {group.group_id}"
            tags.append(Tag(tag_id=tag_id, position=(x, y, 0.0), kind="floor"))
    wall_tags = wall_tags_of(section, seen)
    if not tags and not deployments and not wall_tags:
        raise section.error("tags", "a world needs tags, lattices or wall_tags (none given)")
    wifi, wifi_seed = _wifi(section.section("wifi", {}))
    return World(name=section.string("name"), frame_id=section.string("frame_id", "map"),
                 tags=tuple(tags), walls=tuple(walls), deployments=deployments, tag_groups=groups, wall_tags=wall_tags,
                 access_points=_access_points(section), wifi=wifi, wifi_seed=wifi_seed,
                 extent=rectangle_of(section, "extent"), source=section.source)


def _access_points(section: Section) -> tuple[AccessPoint, ...]:
    access_points: list[AccessPoint] = []
    seen: dict[str, str] = {}
    for entry in section.sections("access_points", []):
        entry.reject_unknown(("bssid", "ssid", "position", "tx_power_dbm", "channel"))
        bssid = entry.string("bssid")
        if bssid.lower() in seen:
            raise entry.error("bssid", f"duplicate bssid '{bssid}' (also at {seen[bssid.lower()]})")
        seen[bssid.lower()] = entry.prefix
        position = entry.numbers("position", length=2)
        ssid = entry.raw("ssid", "")
        if not isinstance(ssid, str):
            raise entry.error("ssid", "expected a string (may be empty: a hidden network)")
        try:
            access_points.append(AccessPoint(bssid, ssid, (position[0], position[1]),
                                             entry.number("tx_power_dbm", 20.0, minimum=DBM.low, maximum=DBM.high),
                                             entry.integer("channel", 6)))
        except ValueError as error:          # the message names the field: "channel: 15 is not ..."
            raise ConfigError(entry.source, entry.prefix, str(error)) from None
    return tuple(access_points)


def _wifi(entry: Section) -> tuple[PropagationSettings, int]:
    names = ("path_loss_exponent", "wall_loss_db", "shadowing_sd_db", "shadowing_correlation_m")
    entry.reject_unknown((*names, "shadowing_seed"))
    defaults = PropagationSettings()
    settings = PropagationSettings(**{name: entry.number(name, getattr(defaults, name)) for name in names})
    try:
        settings.validate()
    except ParameterError as error:
        raise entry.error(error.field, error.problem) from None
    return settings, entry.integer("shadowing_seed", 1, minimum=0)


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
