"""Ground truth of a paper-004 floor built from its topological map: hallway walls and the wall tags.

Paper 004 gives no floor plan, only the topology (Fig. 4/5), a 1.6 m-wide passage (section 5) and tags pasted on
the LEFT wall near each junction (section 4). The map's node positions are the only geometry we have, so the floor
is derived from them rather than drawn by hand: that keeps the world and the robot's map from drifting apart.

* Each junction is a square of the hallway width centred on its node, open on the sides with a hallway (mapped
  or ``?``) and walled on the others (``-``), so a robot following the left wall turns left there as a wall
  follower would in a real building.
* Each mapped hallway is a corridor of that width along the straight line between its two nodes, which must lie
  on the compass line of the side it leaves by (a corridor at a slant would not meet the square's opening).
* A ``?`` hallway is a corridor ``DEAD_END_M`` long closed at its far end: a dead end the robot can explore and
  turn back from, long enough to hold the tags announcing the junction to a robot coming back.
* Corridor walls stop at the junction squares' corners, so the openings are exactly where hallways join and no
  two walls overlap.
* The tags announcing a node to a robot arriving from one side sit on that robot's left wall, ``tag_setback_m``
  before the junction square (it reads them just before entering the junction, in time to plan the turn), on
  the wall surface and facing into the corridor; several tags of one side are ``TAG_SPACING_M`` apart, the
  first one nearest the junction.

The plan (corridor lengths, tag setbacks) and every check of it are ``rfidnav_common.floor_plan``'s, which
``./rfidnav map check`` runs too: a map it passes is one this module builds. Run
``python -m rfidnav_sim.building MAP WORLD`` to regenerate a world file (``config/worlds/building_*.yaml``); a map
it cannot build is refused with ``map check``'s lines and exit 2.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_common.floor_plan import DEAD_END_M, HALLWAY_WIDTH_M, TAG_SETBACK_M, check_floor_map, plan_floor
from rfidnav_common.topological_map import DIRECTIONS, TopologicalMap, load_topological_map
from rfidnav_common.wall_tags import WallTag

DECIMALS = 9                # coordinates are rounded so that files read 8.0, not 8.000000000000002


@dataclass(frozen=True, eq=False)    # arrays have no single truth value: floors compare by identity
class Floor:
    walls: np.ndarray                   # (N, 4) read-only, segments [x1, y1, x2, y2] in the map frame [m]
    wall_tags: tuple[WallTag, ...]

    def __post_init__(self) -> None:
        walls = np.array(self.walls, dtype=float).reshape(-1, 4)
        walls.setflags(write=False)     # frozen means frozen: nobody edits the ground truth in place
        object.__setattr__(self, "walls", walls)


@dataclass(frozen=True)
class _Side:
    """One side of a junction in the map frame: ``along`` points out of the junction through that side,
    ``across`` is ``along`` turned 90 degrees counter-clockwise."""

    centre: np.ndarray
    along: np.ndarray
    across: np.ndarray

    def point(self, out_m: float, left_m: float) -> np.ndarray:
        return self.centre + out_m * self.along + left_m * self.across

    def segment(self, from_: tuple[float, float], to: tuple[float, float]) -> np.ndarray:
        """The wall from (out, left) ``from_`` to ``to``, both in metres from the node along the side."""
        return np.concatenate([self.point(*from_), self.point(*to)])


def building_floor(topological_map: TopologicalMap, hallway_width_m: float = HALLWAY_WIDTH_M,
                   tag_setback_m: float = TAG_SETBACK_M) -> Floor:
    """The walls and wall tags of the floor the map describes (see the module docstring).

    Raises the first of ``rfidnav_common.floor_plan.plan_floor``'s problems (a ConfigError naming the map and the
    field: a node without a position, a hallway off its compass line, junctions too close for their squares,
    parts of the floor overlapping, tags that do not fit on their corridor's wall): ``map check`` lists them all."""
    plan, problems = plan_floor(topological_map, f"map '{topological_map.name}'", hallway_width_m, tag_setback_m)
    if plan is None:
        raise problems[0]
    half = hallway_width_m / 2.0
    walls: list[np.ndarray] = []
    tags: list[WallTag] = []
    for node in topological_map.nodes.values():
        for direction in DIRECTIONS:
            angle = topological_map.direction_angle_rad(direction)
            along = np.array([math.cos(angle), math.sin(angle)])
            side = _Side(np.array(node.position, dtype=float), along, np.array([-along[1], along[0]]))
            planned = plan.sides[(node.name, direction)]
            if planned.corridor_m is None:
                walls.append(side.segment((half, -half), (half, half)))
                continue
            corridor_m = planned.corridor_m
            if planned.dead_end:
                walls.append(side.segment((half + corridor_m, -half), (half + corridor_m, half)))
            if planned.draws_corridor and corridor_m > 0.0:
                walls.extend(side.segment((half, left), (half + corridor_m, left)) for left in (-half, half))
            tags.extend(_arrival_tag(side, tag_id, half, before_m) for tag_id, before_m in planned.tags_before_m)
    wall_array = np.round(np.array(walls, dtype=float).reshape(-1, 4), DECIMALS) + 0.0   # + 0.0: no -0.0
    return Floor(walls=wall_array, wall_tags=tuple(tags))


def _arrival_tag(side: _Side, tag_id: str, half: float, before_square_m: float) -> WallTag:
    """A tag read arriving at the node from ``side``: on the arriving robot's left wall.

    That robot heads along ``-along``, so its left is ``-across``: the wall at ``left = -half``, whose face
    looks into the corridor along ``+across``."""
    position = np.round(side.point(half + before_square_m, -half), DECIMALS) + 0.0
    normal = np.round(side.across, DECIMALS) + 0.0
    return WallTag(tag_id, (float(position[0]), float(position[1])), (float(normal[0]), float(normal[1])))


def write_world(floor: Floor, name: str, path: Path | str, header: str = "") -> None:
    """Write the floor as a world file: ``name``, ``walls`` and ``wall_tags`` (``{id, position: [x, y],
    normal: [nx, ny]}``), with ``header`` as leading comment lines."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    lines.append(f"name: {json.dumps(name)}")
    lines.append("walls:" if len(floor.walls) else "walls: []")
    lines.extend(f"  - [{', '.join(_number(v) for v in wall)}]" for wall in floor.walls)
    lines.append("wall_tags:" if floor.wall_tags else "wall_tags: []")
    lines.extend(f"  - {{id: {json.dumps(tag.tag_id)}, position: [{_number(tag.position[0])}, "
                 f"{_number(tag.position[1])}], normal: [{_number(tag.normal[0])}, {_number(tag.normal[1])}]}}"
                 for tag in floor.wall_tags)
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def _number(value: float) -> str:
    return repr(float(value))


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate a world file from a map with the default hallway width and tag setback; a map the generator
    cannot build is refused with every problem, one line each (as ``map check`` lists them), and exit 2."""
    parser = argparse.ArgumentParser(prog="python -m rfidnav_sim.building", description=__doc__.splitlines()[0])
    parser.add_argument("map", help="topological map with node positions (config/maps/*.yaml)")
    parser.add_argument("world", help="world file to write (config/worlds/*.yaml)")
    args = parser.parse_args(argv)
    problems = check_floor_map(args.map)
    if problems:
        print("\n".join(problems), file=sys.stderr)
        return 2
    topological_map = load_topological_map(args.map)
    header = (f"Ground truth of {topological_map.name}: GENERATED by rfidnav_sim.building from the map {args.map}\n"
              f"({HALLWAY_WIDTH_M:g} m-wide hallways, junction squares open where hallways join, '?' hallways "
              f"{DEAD_END_M:g} m dead ends,\nwall tags on the arriving robot's left wall {TAG_SETBACK_M:.1f} m before "
              f"the junction). Do not edit: regenerate with\n  python -m rfidnav_sim.building {args.map} {args.world}")
    write_world(building_floor(topological_map), topological_map.name, args.world, header)
    return 0


if __name__ == "__main__":
    sys.exit(main())
