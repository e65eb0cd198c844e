"""The topological map of paper 004 (sections 3-5): junctions joined by hallways, named by compass points.

The robot knows neither tag positions nor hallway lengths; it follows the left wall until it reads a tag. A tag
tells it which junction it is coming upon and from which side, because each tag is listed under the node and
the compass side it announces (Fig. 5(b)). Routing is a graph search; the turn at a junction follows from the
side the robot came in by and the side the next hallway leaves by. Compass points rather than a clockwise list
of hallways keep the map easy to trace from a floor plan (section 3).

YAML format (``config/maps/*.yaml``, robot knowledge)::

    name: building_fig5
    north_deg: 90            # bearing of compass North in the map frame, degrees CCW from the map x axis
                             # (default 90: North is the map's +y); used for drawing and position checks
    tag_to_node_m: 1.8       # optional (default 0): how far past the point where an arriving robot reads a
                             # node's tag the node's centre lies (the floor's tagging convention); the robot
                             # drives this far on to a goal with no side opening to find its centre by
    nodes:                   # node name -> its sides; every node must be reachable from the first one
      c:
        position: [8.0, 8.0]               # optional, map frame [m]: drawing and default hallway lengths
        N: {node: d, tags: [8]}            # leaving c northwards leads to d; tag 8 is read when
                                           #   ARRIVING at c FROM the north (coming from d)
        E: {node: h, tags: [9], length_m: 8.0}
        S: {node: b, tags: [10]}
        W: {node: a, tags: [7]}
      d:
        N: {node: "?", tags: [12]}         # a hallway whose far end is not mapped yet: never routed through
        E: {node: e, tags: [13]}
        S: {node: c, tags: [11]}
        W: {node: "-"}                     # no hallway; the same as leaving W out, and takes no tags

Rules (``check_map`` lists every break, ``load_topological_map`` raises the first, each naming file and field):

* sides are ``N``, ``E``, ``S``, ``W`` (plus ``position``); a side's fields are ``node`` (a node name, ``?`` or
  ``-``), ``tags`` (default none) and ``length_m`` (positive, optional);
* tag ids are unique over the whole map; they are text, so a YAML number ``8`` is the id ``'8'``;
* every hallway is listed at both ends with opposite sides: ``c.N = d`` requires ``d.S = c``; lengths given at
  both ends agree;
* where both ends have positions, the far end lies within 45 degrees of the side's compass direction, so a
  drawing (and a person reading the map) sees the turns the robot will make, and a ``length_m`` lies within
  ``LENGTH_SLACK`` (10 %, at least 0.5 m) of the straight distance between them;
* every node is reachable from the first through mapped hallways, or it and the first node both lie in parts of
  the map with a ``?`` hallway (the parts may join through unexplored hallways: the mission executor explores
  them).

These are the robot's rules (the scenario loader and the mission executor read maps by them). A map the world
generator builds a floor from keeps ``rfidnav_common.floor_plan``'s too, which ``./rfidnav map check`` adds.

Hallway length for ``route(..., weight="length")``: ``length_m`` from either end, else the straight distance
between the two positions, else 1 m (the topology alone then decides, as with ``weight="edges"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

import networkx as nx

from rfidnav_common.config import Section, type_name
from rfidnav_common.errors import ConfigError, RfidnavError

DIRECTIONS: tuple[str, ...] = ("N", "E", "S", "W")   # clockwise, so one step along the tuple is a right turn
UNKNOWN = "?"
NO_HALLWAY = "-"
WEIGHTS = ("edges", "length")
DEFAULT_NORTH_DEG = 90.0
DEFAULT_LENGTH_M = 1.0

_OPPOSITE = {"N": "S", "E": "W", "S": "N", "W": "E"}
_DEGREES_CCW_FROM_NORTH = {"N": 0.0, "E": -90.0, "S": 180.0, "W": 90.0}
_TURNS = ("straight", "right", "back", "left")        # by clockwise quarter turns from the arrival heading
_SIDE_FIELDS = ("node", "tags", "length_m")
_POSITION_TOLERANCE_DEG = 45.0                        # beyond this a hallway points to another compass side
_LENGTH_TOLERANCE_M = 1e-6
# A length_m given with both positions lies within max(metres, fraction of the distance) of the distance between
# them: positions paced or taken off a plan, a hallway's centre line, never a hallway twice as long.
LENGTH_SLACK = (0.5, 0.10)
_HALLWAY_ARROW = " -> "


class RouteError(RfidnavError, ValueError):
    """No route: an unknown node or tag, or no mapped hallways between start and goal."""


@dataclass(frozen=True)
class Hallway:
    """One side of a node that has a hallway: where it leads, and the tags announcing the node to a robot
    arriving from it."""

    neighbour: str                  # a node name, or UNKNOWN
    tags: tuple[str, ...] = ()
    length_m: float | None = None


@dataclass(frozen=True)
class Node:
    name: str
    hallways: dict[str, Hallway]    # by direction; a side without a hallway is absent
    position: tuple[float, float] | None = None


@dataclass(frozen=True)
class Edge:
    """A hallway between two mapped nodes, listed once: it leaves ``node_a`` by ``side_a`` and enters
    ``node_b`` by ``side_b``."""

    node_a: str
    side_a: str
    node_b: str
    side_b: str
    length_m: float


class NextAction(NamedTuple):
    action: str                     # "left" | "right" | "straight" | "back" | "stop"
    direction: str | None           # compass side to leave the node by; None on "stop"
    node: str                       # the node the tag announced


@dataclass(frozen=True)
class TopologicalMap:
    """A consistent map (build it with ``load_topological_map``, which checks the rules above)."""

    name: str
    nodes: dict[str, Node]
    north_deg: float = DEFAULT_NORTH_DEG
    tag_to_node_m: float = 0.0
    _tag_places: dict[str, tuple[str, str]] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Every read goes through locate_tag, so index the tags once.
        places = {tag: (node.name, side) for node in self.nodes.values()
                  for side, hallway in node.hallways.items() for tag in hallway.tags}
        object.__setattr__(self, "_tag_places", places)

    def locate_tag(self, tag_id: str | int) -> tuple[str, str] | None:
        """The node a tag announces and the side the robot arrived from (tag 9 of Fig. 5: ``('c', 'E')``,
        so the robot is heading West); None for a tag not in the map."""
        return self._tag_places.get(str(tag_id))

    def has_side_opening(self, node: str, arrival_side: str) -> bool:
        """Whether a robot entering ``node`` by ``arrival_side`` passes a hallway on its left or right: only then
        can a wall follower sense the junction (a node with hallways just behind and ahead is a stretch of
        hallway to it)."""
        lateral = set(DIRECTIONS) - {arrival_side, opposite(arrival_side)}
        return any(side in lateral for side in self.nodes[node].hallways)

    def direction_angle_rad(self, direction: str) -> float:
        """The map-frame angle (CCW from the map x axis) of a compass direction."""
        return math.radians(self.north_deg + _DEGREES_CCW_FROM_NORTH[_check_direction(direction)])

    def hallway_length_m(self, node: str, side: str) -> float:
        """Length of the mapped hallway leaving ``node`` by ``side`` (see the module docstring)."""
        known = self.known_length_m(node, side)
        return DEFAULT_LENGTH_M if known is None else known

    def known_length_m(self, node: str, side: str) -> float | None:
        """The hallway's ``length_m`` at either end, else the distance between its ends' positions; None when
        the map gives neither (its length is not known)."""
        hallway = self.nodes[node].hallways[side]
        far_end = self.nodes[hallway.neighbour]
        mirror = far_end.hallways.get(_OPPOSITE[side])
        for length in (hallway.length_m, mirror.length_m if mirror else None):
            if length is not None:
                return length
        here, there = self.nodes[node].position, far_end.position
        if here is not None and there is not None:
            return math.dist(here, there)
        return None

    def with_hallway(self, node_a: str, side_a: str, node_b: str, side_b: str) -> TopologicalMap:
        """A copy in which the ``?`` hallway leaving ``node_a`` by ``side_a`` leads to ``node_b``, entered by
        ``side_b`` (whose ``?`` leads back): a hallway explored (the mission executor learns it)."""
        nodes = dict(self.nodes)
        for name, side, other in ((node_a, side_a, node_b), (node_b, side_b, node_a)):
            hallway = nodes[name].hallways.get(side)
            if hallway is None or hallway.neighbour != UNKNOWN:
                raise RouteError(f"map '{self.name}': {name}.{side} is not a '{UNKNOWN}' hallway to learn")
            nodes[name] = replace(nodes[name], hallways={**nodes[name].hallways,
                                                         side: replace(hallway, neighbour=other)})
        return replace(self, nodes=nodes)

    def edges(self) -> list[Edge]:
        """Every hallway between two mapped nodes, once."""
        found = []
        for node in self.nodes.values():
            for side, hallway in node.hallways.items():
                if hallway.neighbour != UNKNOWN and (node.name, side) < (hallway.neighbour, _OPPOSITE[side]):
                    found.append(Edge(node.name, side, hallway.neighbour, _OPPOSITE[side],
                                      self.hallway_length_m(node.name, side)))
        return found

    def route(self, start: str, goal: str, weight: str = "edges") -> list[str]:
        """The nodes from ``start`` to ``goal`` (both included) along the fewest hallways (``weight="edges"``,
        all the paper's robot knows) or the shortest length (``weight="length"``)."""
        _check_weight(weight)
        for name in (start, goal):
            if name not in self.nodes:
                raise RouteError(f"map '{self.name}': unknown node '{name}' (nodes: {', '.join(self.nodes)})")
        try:
            return nx.shortest_path(self.graph(weight), start, goal, weight="weight")
        except nx.NetworkXNoPath:
            raise RouteError(f"map '{self.name}': no route from '{start}' to '{goal}' through mapped hallways "
                             f"('{UNKNOWN}' hallways are not routable)") from None

    def departure_direction(self, node: str, next_node: str, weight: str = "edges") -> str:
        """The side of ``node`` to leave by for the adjacent ``next_node`` (the cheapest, if several lead
        there)."""
        _check_weight(weight)
        sides = [side for side in DIRECTIONS
                 if side in self.nodes[node].hallways and self.nodes[node].hallways[side].neighbour == next_node]
        if not sides:
            raise RouteError(f"map '{self.name}': no hallway from '{node}' to '{next_node}'")
        return min(sides, key=lambda side: self._weight(node, side, weight))

    def _weight(self, node: str, side: str, weight: str) -> float:
        return 1.0 if weight == "edges" else self.hallway_length_m(node, side)

    def graph(self, weight: str) -> nx.Graph:
        """The mapped hallways as a graph whose edge weights are ``weight`` (the cheapest of parallel hallways)."""
        graph = nx.Graph()
        graph.add_nodes_from(self.nodes)
        for edge in self.edges():
            cost = self._weight(edge.node_a, edge.side_a, weight)
            # Of parallel hallways between the same two nodes only the cheapest can be on a shortest route.
            if not graph.has_edge(edge.node_a, edge.node_b) or graph[edge.node_a][edge.node_b]["weight"] > cost:
                graph.add_edge(edge.node_a, edge.node_b, weight=cost)
        return graph


def hallway_text(node_a: str, side_a: str, node_b: str, side_b: str) -> str:
    """A hallway as text, ``a.N -> c.S`` (leaving ``a`` by its North side, entering ``c`` by its South side):
    how the mission executor reports a learned hallway (NavigateToNode feedback)."""
    return f"{node_a}.{side_a}{_HALLWAY_ARROW}{node_b}.{side_b}"


def parse_hallway_text(text: str) -> tuple[str, str, str, str]:
    """(node_a, side_a, node_b, side_b) of :func:`hallway_text`'s text; ValueError for text of another form."""
    ends = text.split(_HALLWAY_ARROW)
    if len(ends) == 2:
        (node_a, _, side_a), (node_b, _, side_b) = (end.rpartition(".") for end in ends)
        if node_a and node_b and side_a in _OPPOSITE and side_b in _OPPOSITE:
            return node_a, side_a, node_b, side_b
    raise ValueError(f"a hallway reads 'node.side{_HALLWAY_ARROW}node.side' (sides N, E, S, W), got '{text}'")


def opposite(direction: str) -> str:
    return _OPPOSITE[_check_direction(direction)]


def turn(arrival_side: str, departure_direction: str) -> str:
    """The turn at a junction: "left", "right", "straight" or "back" (a U-turn).

    Arriving from side X the robot heads opposite X; it leaves heading ``departure_direction``. Paper 004,
    section 3: arriving at c from the East (tag 9) and leaving North is a right turn."""
    heading = DIRECTIONS.index(opposite(arrival_side))
    quarter_turns = (DIRECTIONS.index(_check_direction(departure_direction)) - heading) % 4
    return _TURNS[quarter_turns]


def next_action(topological_map: TopologicalMap, tag_id: str | int, goal: str,
                weight: str = "edges") -> NextAction:
    """What to do on reading ``tag_id`` on the way to ``goal``: stop there, or turn and leave by a side."""
    located = topological_map.locate_tag(tag_id)
    if located is None:
        raise RouteError(f"map '{topological_map.name}': tag '{tag_id}' is not in the map")
    node, arrival_side = located
    path = topological_map.route(node, goal, weight)
    if len(path) == 1:
        return NextAction("stop", None, node)
    direction = topological_map.departure_direction(node, path[1], weight)
    return NextAction(turn(arrival_side, direction), direction, node)


def load_topological_map(path: Path | str) -> TopologicalMap:
    """Read and check a map file; the first problem is raised as a ConfigError naming file and field."""
    topological_map, problems = read_map(Path(path))
    if topological_map is None:                      # None exactly when there are problems
        raise problems[0]
    return topological_map


def check_map(path: Path | str) -> list[str]:
    """Every problem of a map file, one line each (``file: field: problem``); empty for a good map."""
    return [str(problem) for problem in read_map(Path(path))[1]]


def _check_weight(weight: str) -> None:
    if weight not in WEIGHTS:
        raise ValueError(f"weight must be one of {', '.join(WEIGHTS)}, got '{weight}'")


def _check_direction(direction: str) -> str:
    if direction not in _OPPOSITE:
        raise ValueError(f"a direction is one of {', '.join(DIRECTIONS)}, got '{direction}'")
    return direction


# ---------------------------------------------------------------- reading and checking

def read_map(path: Path) -> tuple[TopologicalMap | None, list[ConfigError]]:
    """The map and every problem by the rules above; the map is None exactly when there are problems."""
    try:
        document = Section.from_file(path)
    except ConfigError as error:
        return None, [error]
    return _Reader(document).read()


class _Reader:
    """Parses a map file, collecting every problem rather than stopping at the first."""

    def __init__(self, document: Section) -> None:
        self.document = document
        self.problems: list[ConfigError] = []
        self.tag_fields: dict[str, str] = {}

    def attempt(self, getter: Any, *args: Any, **kwargs: Any) -> Any:
        try:
            return getter(*args, **kwargs)
        except ConfigError as error:
            self.problems.append(error)
            return None

    def read(self) -> tuple[TopologicalMap | None, list[ConfigError]]:
        document = self.document
        for key in document.keys():
            if key not in ("name", "description", "north_deg", "tag_to_node_m", "nodes"):
                self.problems.append(document.error(str(key), "unknown field (expected one of: description, "
                                                              "name, nodes, north_deg, tag_to_node_m)"))
        name = self.attempt(document.string, "name")
        north_deg = self.attempt(document.number, "north_deg", DEFAULT_NORTH_DEG, minimum=-360.0, maximum=360.0)
        tag_to_node_m = self.attempt(document.number, "tag_to_node_m", 0.0, minimum=0.0)
        nodes_section = self.attempt(document.section, "nodes")
        if nodes_section is None:
            return None, self.problems
        if not nodes_section.keys():
            self.problems.append(document.error("nodes", "the map has no nodes"))
            return None, self.problems
        nodes: dict[str, Node] = {}
        for key in nodes_section.keys():
            node = self.node(nodes_section, key)
            if node is not None:
                nodes[node.name] = node
        names = {key for key in nodes_section.keys() if isinstance(key, str)}
        self.check_hallways(nodes_section, nodes, names, DEFAULT_NORTH_DEG if north_deg is None else north_deg)
        self.check_reachable(nodes_section, nodes)
        if self.problems:
            return None, self.problems
        return TopologicalMap(name=name, nodes=nodes, north_deg=north_deg, tag_to_node_m=tag_to_node_m), []

    def node(self, nodes_section: Section, key: Any) -> Node | None:
        if not isinstance(key, str) or key in (UNKNOWN, NO_HALLWAY):
            self.problems.append(nodes_section.error(str(key), f"a node name must be text other than "
                                                               f"'{UNKNOWN}' and '{NO_HALLWAY}'"))
            return None
        section = self.attempt(nodes_section.section, key)
        if section is None:
            return None
        position = None
        hallways: dict[str, Hallway] = {}
        for side in section.keys():
            if side == "position":
                coordinates = self.attempt(section.numbers, "position", length=2)
                position = None if coordinates is None else (coordinates[0], coordinates[1])
            elif side in _OPPOSITE:
                hallway = self.hallway(section, side)
                if hallway is not None:
                    hallways[side] = hallway
            else:
                self.problems.append(section.error(str(side), "unknown direction (expected N, E, S, W or "
                                                              "position)"))
        return Node(key, {side: hallways[side] for side in DIRECTIONS if side in hallways}, position)

    def hallway(self, node_section: Section, side: str) -> Hallway | None:
        section = self.attempt(node_section.section, side)
        if section is None:
            return None
        for key in section.keys():
            if key not in _SIDE_FIELDS:
                self.problems.append(section.error(str(key), f"unknown field (expected one of: "
                                                             f"{', '.join(_SIDE_FIELDS)})"))
        neighbour = self.attempt(section.string, "node")
        tags = self.tags(section)
        length_m = self.attempt(section.number, "length_m", positive=True) if section.has("length_m") else None
        if neighbour == NO_HALLWAY:
            if tags:
                self.problems.append(section.error("tags", f"'{NO_HALLWAY}' (no hallway) cannot have tags: a "
                                                           "robot never arrives from this side"))
            if section.has("length_m"):
                self.problems.append(section.error("length_m", f"'{NO_HALLWAY}' (no hallway) has no length"))
            return None
        if neighbour is None:
            return None
        return Hallway(neighbour, tags, length_m)

    def tags(self, section: Section) -> tuple[str, ...]:
        items = section.raw("tags", [])
        if not isinstance(items, list):
            self.problems.append(section.error("tags", f"expected a list of tag ids, got {type_name(items)}"))
            return ()
        tags = []
        for index, item in enumerate(items):
            where = f"{section.field('tags')}[{index}]"
            if isinstance(item, bool) or not isinstance(item, (str, int)) or item == "":
                self.problems.append(ConfigError(section.source, where,
                                                 f"expected a tag id (text or integer), got {type_name(item)}"))
                continue
            tag = str(item)
            if tag in self.tag_fields:
                self.problems.append(ConfigError(section.source, where,
                                                 f"duplicate tag '{tag}' (also at {self.tag_fields[tag]})"))
                continue
            self.tag_fields[tag] = where
            tags.append(tag)
        return tuple(tags)

    def check_hallways(self, nodes_section: Section, nodes: dict[str, Node], names: set[str],
                       north_deg: float) -> None:
        source = nodes_section.source
        for node in nodes.values():
            for side, hallway in node.hallways.items():
                where = f"{nodes_section.field(node.name)}.{side}.node"
                if hallway.neighbour == UNKNOWN:
                    continue
                if hallway.neighbour not in names:
                    self.problems.append(ConfigError(source, where,
                                                     f"unknown node '{hallway.neighbour}'"))
                    continue
                far_end = nodes.get(hallway.neighbour)
                if far_end is None:          # its own problem is reported already
                    continue
                back_side = _OPPOSITE[side]
                mirror = far_end.hallways.get(back_side)
                if mirror is None or mirror.neighbour != node.name:
                    found = "missing" if mirror is None else f"'{mirror.neighbour}'"
                    self.problems.append(ConfigError(
                        source, where,
                        f"leads to '{far_end.name}', but {nodes_section.field(far_end.name)}.{back_side}.node is "
                        f"{found} (expected '{node.name}': a hallway is listed at both ends, on opposite sides)"))
                    continue
                if (node.name, side) < (far_end.name, back_side):     # each pair once
                    self.check_pair(nodes_section, node, side, hallway, far_end, mirror, north_deg)

    def check_pair(self, nodes_section: Section, node: Node, side: str, hallway: Hallway, far_end: Node,
                   mirror: Hallway, north_deg: float) -> None:
        source, where = nodes_section.source, f"{nodes_section.field(node.name)}.{side}.node"
        if (hallway.length_m is not None and mirror.length_m is not None
                and abs(hallway.length_m - mirror.length_m) > _LENGTH_TOLERANCE_M):
            self.problems.append(ConfigError(
                source, where, f"length_m {hallway.length_m:g} here but {mirror.length_m:g} at "
                               f"'{far_end.name}'.{_OPPOSITE[side]}: the two ends of a hallway must agree"))
        if node.position is None or far_end.position is None:
            return
        dx, dy = far_end.position[0] - node.position[0], far_end.position[1] - node.position[1]
        if dx == 0.0 and dy == 0.0:
            self.problems.append(ConfigError(source, where, f"'{node.name}' and '{far_end.name}' have the same "
                                                            "position"))
            return
        expected = north_deg + _DEGREES_CCW_FROM_NORTH[side]
        actual = math.degrees(math.atan2(dy, dx))
        off = abs((actual - expected + 180.0) % 360.0 - 180.0)
        if off > _POSITION_TOLERANCE_DEG:
            self.problems.append(ConfigError(
                source, where, f"'{far_end.name}' lies {off:.0f} deg off the {side} of '{node.name}' by their "
                               f"positions (north_deg {north_deg:g}): positions and compass sides disagree"))
        given = [(f"{nodes_section.field(name)}.{name_side}.length_m", end.length_m)
                 for name, name_side, end in ((node.name, side, hallway), (far_end.name, _OPPOSITE[side], mirror))
                 if end.length_m is not None]
        if given:
            field_name, length = given[0]
            distance = math.hypot(dx, dy)
            slack = max(LENGTH_SLACK[0], LENGTH_SLACK[1] * distance)
            if abs(length - distance) > slack:
                self.problems.append(ConfigError(
                    source, field_name, f"{length:g} m, but '{node.name}' and '{far_end.name}' are {distance:.2f} m "
                                        f"apart by their positions: a hallway's length lies within "
                                        f"{LENGTH_SLACK[1]:.0%} (at least {LENGTH_SLACK[0]:g} m) of that distance"))

    def check_reachable(self, nodes_section: Section, nodes: dict[str, Node]) -> None:
        if not nodes:
            return
        graph = nx.Graph()
        graph.add_nodes_from(nodes)
        graph.add_edges_from((node.name, hallway.neighbour) for node in nodes.values()
                             for hallway in node.hallways.values() if hallway.neighbour in nodes)
        first = next(iter(nodes))
        reached = set(nx.node_connected_component(graph, first))

        def explorable(part: set[str]) -> bool:
            return any(hallway.neighbour == UNKNOWN for name in part for hallway in nodes[name].hallways.values())

        if explorable(reached):
            # Parts with a "?" hallway may join the first node's part through unexplored hallways.
            reached.update(name for part in nx.connected_components(graph) if explorable(part) for name in part)
        for name in nodes:
            if name not in reached:
                self.problems.append(nodes_section.error(name, f"not reachable from '{first}' (the first node) "
                                                               f"through mapped hallways nor through '{UNKNOWN}' ones"))
