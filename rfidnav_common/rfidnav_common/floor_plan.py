"""The floor a topological map describes, as the world generator (``rfidnav_sim.building``) builds it, and every
check that building makes: one source for both, so ``./rfidnav map check`` refuses exactly the maps the generator
refuses, with the same line (file, field, problem) for each.

Paper 004 gives the topology and a 1.6 m passage, not a floor plan; the generator derives the floor from the node
positions (the conventions, in the compass frame ``north_deg`` sets):

* each junction is a square of the hallway width centred on its node;
* each mapped hallway is a straight corridor of that width between its two nodes' squares, so the far node must
  lie ON the compass line of the side the hallway leaves by (within ``ALIGNMENT_TOLERANCE_M``; the map's own
  rule allows 45 degrees, for drawing) and at least a hallway width away (else the squares overlap);
* a ``?`` hallway is a corridor ``DEAD_END_M`` long closed at its far end;
* no two of these (squares, corridors) overlap: a corridor may not run through another junction or hallway;
* the tags announcing a node to a robot arriving from a side sit ``tag_setback_m`` before its junction square,
  ``TAG_SPACING_M`` apart, and must fit on that side's corridor.

Every node needs a position. A map of a floor drawn by hand (``building_eval``: corridors of several widths, a
hallway 20 degrees off square) is robot knowledge only: the generator's rules do not apply to it, and
``map check --robot-only`` checks it by the map's own rules (``rfidnav_common.topological_map``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from rfidnav_common.errors import ConfigError
from rfidnav_common.topological_map import DIRECTIONS, UNKNOWN, TopologicalMap, opposite, read_map

HALLWAY_WIDTH_M = 1.6       # paper 004, section 5: a 1.6 m-wide passage
TAG_SETBACK_M = 1.0         # tags this far before the junction square (read in time to plan the turn)
DEAD_END_M = 3.0            # corridor length of a "?" hallway beyond its junction square
TAG_SPACING_M = 0.3         # between the tags of one arrival side, along the wall
ALIGNMENT_TOLERANCE_M = 1e-6


@dataclass(frozen=True)
class SidePlan:
    """One side of a junction on the floor."""

    corridor_m: float | None                # None: walled ('-'); else the corridor's length beyond the square
    draws_corridor: bool = False            # this end draws the corridor's walls (a mapped hallway once; '?')
    dead_end: bool = False                  # a '?' hallway: closed DEAD_END_M beyond the square
    tags_before_m: tuple[tuple[str, float], ...] = ()   # (tag id, metres before the junction square)


@dataclass(frozen=True)
class FloorPlan:
    sides: dict[tuple[str, str], SidePlan]  # by (node, direction), every node and direction


@dataclass(frozen=True)
class _Part:
    """A junction square or a corridor as a box in the compass frame (east, north), for the overlap check."""

    field: str
    what: str
    east: tuple[float, float]
    north: tuple[float, float]

    def overlaps(self, other: _Part) -> bool:
        return all(min(a[1], b[1]) - max(a[0], b[0]) > ALIGNMENT_TOLERANCE_M
                   for a, b in ((self.east, other.east), (self.north, other.north)))


def plan_floor(topological_map: TopologicalMap, source: str, hallway_width_m: float = HALLWAY_WIDTH_M,
               tag_setback_m: float = TAG_SETBACK_M) -> tuple[FloorPlan | None, list[ConfigError]]:
    """The floor's plan and every reason the generator cannot build it (``source`` names the map file in each
    problem); the plan is None exactly when there are problems. ValueError for a width or setback that is no
    length (the caller's, not the map's)."""
    if not (math.isfinite(hallway_width_m) and hallway_width_m > 0.0):
        raise ValueError(f"hallway_width_m: {hallway_width_m} is not a finite positive number")
    if not (math.isfinite(tag_setback_m) and tag_setback_m >= 0.0):
        raise ValueError(f"tag_setback_m: {tag_setback_m} is not a finite non-negative number")
    problems = [ConfigError(source, f"nodes.{node.name}.position",
                            "missing: the world generator builds a floor from the positions of all nodes (the "
                            "map of a floor drawn by hand needs none: check it with map check --robot-only)")
                for node in topological_map.nodes.values() if node.position is None]
    if problems:
        return None, problems
    half = hallway_width_m / 2.0
    compass = {name: _compass(topological_map, node.position)          # type: ignore[arg-type]
               for name, node in topological_map.nodes.items()}
    parts = [_Part(f"nodes.{name}.position", f"the junction of '{name}'", (east - half, east + half),
                   (north - half, north + half)) for name, (east, north) in compass.items()]
    sides: dict[tuple[str, str], SidePlan] = {}
    for node in topological_map.nodes.values():
        for direction in DIRECTIONS:
            hallway = node.hallways.get(direction)
            if hallway is None:
                sides[(node.name, direction)] = SidePlan(None)
                continue
            where = f"nodes.{node.name}.{direction}"
            if hallway.neighbour == UNKNOWN:
                corridor_m: float | None = DEAD_END_M
                draws = True
            else:
                # A mapped hallway's corridor is drawn, and its problem reported, from one end: the one listed
                # first, as in ``edges``.
                draws = (node.name, direction) < (hallway.neighbour, opposite(direction))
                corridor_m, problem = _corridor_m(compass[node.name], compass[hallway.neighbour], direction,
                                                  hallway_width_m)
                if problem and draws:
                    problems.append(ConfigError(source, f"{where}.node", problem))
            if corridor_m is None:
                continue
            if draws and corridor_m > 0.0:
                parts.append(_corridor_part(compass[node.name], direction, half, corridor_m, f"{where}.node",
                                            f"the hallway {node.name}.{direction} ({hallway.neighbour})"))
            tags = []
            for index, tag_id in enumerate(hallway.tags):
                before_m = tag_setback_m + index * TAG_SPACING_M
                if before_m > corridor_m + ALIGNMENT_TOLERANCE_M:
                    problems.append(ConfigError(
                        source, f"{where}.tags[{index}]",
                        f"tag '{tag_id}' would be {before_m:.2f} m before the junction (tags {tag_setback_m:g} m "
                        f"before it, {TAG_SPACING_M:g} m apart), beyond the {corridor_m:.2f} m corridor"))
                tags.append((tag_id, before_m))
            sides[(node.name, direction)] = SidePlan(corridor_m, draws, hallway.neighbour == UNKNOWN, tuple(tags))
    for index, part in enumerate(parts):
        for other in parts[index + 1:]:
            if part.overlaps(other):
                problems.append(ConfigError(source, part.field, f"{part.what} overlaps {other.what} on the "
                                                                f"floor ({hallway_width_m:g} m-wide hallways)"))
    if problems:
        return None, problems
    return FloorPlan(sides), []


def check_floor_map(path: Path | str) -> list[str]:
    """Every problem of a map file as a generated floor's map, one line each: the map's own rules
    (``check_map``), then, if it keeps them, the generator's (``plan_floor``, default width and setback)."""
    topological_map, problems = read_map(Path(path))
    if topological_map is not None:
        problems = plan_floor(topological_map, str(path))[1]
    return [str(problem) for problem in problems]


def _compass(topological_map: TopologicalMap, position: tuple[float, float]) -> tuple[float, float]:
    """A map-frame position as (east, north) metres."""
    north = topological_map.direction_angle_rad("N")
    east = topological_map.direction_angle_rad("E")
    return (position[0] * math.cos(east) + position[1] * math.sin(east),
            position[0] * math.cos(north) + position[1] * math.sin(north))


_STEP = {"N": (0.0, 1.0), "E": (1.0, 0.0), "S": (0.0, -1.0), "W": (-1.0, 0.0)}   # (east, north) per direction


def _corridor_m(here: tuple[float, float], there: tuple[float, float], direction: str,
                hallway_width_m: float) -> tuple[float | None, str]:
    """The corridor's length between the two junction squares and "", or None and the problem when the far node
    is off the side's compass line or closer than a hallway width."""
    step = _STEP[direction]
    offset = (there[0] - here[0], there[1] - here[1])
    out_m = offset[0] * step[0] + offset[1] * step[1]
    off_line_m = offset[1] * step[0] - offset[0] * step[1]     # to the left of the direction
    if abs(off_line_m) > ALIGNMENT_TOLERANCE_M:
        return None, (f"the far node is {off_line_m:+.3f} m off the {direction} line; the world generator runs "
                      "hallways straight along their compass direction")
    if out_m < hallway_width_m - ALIGNMENT_TOLERANCE_M:
        return None, (f"the far node is {out_m:.3f} m away, closer than the hallway width {hallway_width_m:g} m, "
                      "so the junction squares overlap")
    return max(out_m - hallway_width_m, 0.0), ""


def _corridor_part(here: tuple[float, float], direction: str, half: float, corridor_m: float, field: str,
                   what: str) -> _Part:
    step = _STEP[direction]
    ends = [here[axis] + step[axis] * out for axis in (0, 1) for out in (half, half + corridor_m)]
    east = (min(ends[0], ends[1]), max(ends[0], ends[1])) if step[0] else (here[0] - half, here[0] + half)
    north = (min(ends[2], ends[3]), max(ends[2], ends[3])) if step[1] else (here[1] - half, here[1] + half)
    return _Part(field, what, east, north)
