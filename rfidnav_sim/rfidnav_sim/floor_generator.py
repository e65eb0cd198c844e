"""Seeded floors of new layouts for paper 004: a random topological map and the world generated from it.

An evaluation floor should be one nobody has looked at while designing, so it is drawn, not drawn up: the seed
alone decides the layout, and the layout is nothing like the in-tree floors' by construction of anyone's hand.
``generated_floor(seed)`` gives the map (robot knowledge) and the world (``rfidnav_sim.building``'s ground truth
of that map) of the seed's floor; ``python -m rfidnav_sim.floor_generator SEED MAP WORLD`` writes them.

The rules (:class:`LayoutRules`), in the compass frame (East along a row, North along a column):

* junctions on an irregular grid: 3-5 columns and 3-4 rows whose spacings are drawn from 6-14 m (0.5 m steps),
  and about one grid point in seven left without a junction, so rows and columns have gaps;
* hallways only along a row or a column, between consecutive junctions of it (across a missing point: a longer
  hallway), never crossing another: a random spanning tree of these (so every junction is reachable), its
  leaves the floor's mapped dead ends, and a third of the remaining ones opened as loops;
* a junction's side with no hallway is walled, or, one time in four, a ``?`` hallway (the generator's 3 m dead
  end, an unmapped exit), unless it would face another ``?`` too closely;
* the tags as paper 004 places them (section 4, Fig. 4): for every side with a hallway, on the arriving robot's
  left wall 1 m before the junction square (``building``'s placement), one tag, or two (one side in seven),
  numbered from 1 junction by junction;
* compass North along one of the map's axes, drawn (``north_deg`` 0, 90, 180 or 270): the compass labels are the
  map's, whichever way the floor lies in the frame;
* 1.6 m hallways (the paper's passage), ``tag_to_node_m`` 2.0 (the in-tree generated floors' convention).

A drawn map is kept only if it passes ``./rfidnav map check``'s checks (``check_floor_map``: the map's own
rules, then the world generator's); a layout that does not is drawn again from the next attempt of the same
seed (recorded in the map's description), so a seed always gives the same floor.

Pure: numpy and the map and floor code below it; no rclpy, no simulation.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_common.floor_plan import DEAD_END_M, HALLWAY_WIDTH_M, check_floor_map
from rfidnav_common.topological_map import DIRECTIONS, UNKNOWN, TopologicalMap, load_topological_map
from rfidnav_sim.building import DECIMALS, building_floor, write_world
from rfidnav_sim.world import World

TAG_TO_NODE_M = 2.0          # tags 1 m before a 1.6 m hallway's square: 1.8 m before the node, read up to 0.2 m early
MAX_ATTEMPTS = 100
_STEP = {"N": (0, 1), "E": (1, 0), "S": (0, -1), "W": (-1, 0)}      # (column, row) per compass direction


@dataclass(frozen=True)
class LayoutRules:
    """What a drawn floor may be (see the module docstring)."""
    columns: tuple[int, int] = (3, 5)               # inclusive
    rows: tuple[int, int] = (3, 4)
    spacing_m: tuple[float, float] = (6.0, 14.0)    # between neighbouring grid lines, in SPACING_STEP_M steps
    spacing_step_m: float = 0.5
    absent_fraction: float = 0.15                   # grid points with no junction
    loop_fraction: float = 1.0 / 3.0                # of the hallways beyond the spanning tree, opened
    unknown_probability: float = 0.25               # a side with no hallway is a "?" dead end
    two_tags_probability: float = 1.0 / 7.0         # a hallway side carries two tags
    north_choices_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)


RULES = LayoutRules()


@dataclass(frozen=True)
class Layout:
    """A drawn floor before it is a map: the junctions, the hallways and the ``?`` sides."""
    name: str
    north_deg: float
    positions: dict[tuple[int, int], tuple[float, float]]   # (column, row) -> (east, north) [m]
    hallways: tuple[tuple[tuple[int, int], tuple[int, int]], ...]   # (from, to), from west/south of to
    unknown_sides: tuple[tuple[tuple[int, int], str], ...]
    two_tag_sides: tuple[tuple[tuple[int, int], str], ...]
    attempt: int


def node_name(point: tuple[int, int]) -> str:
    """Column letter and row number, as building_large's (A1 is the south-west corner)."""
    return f"{chr(ord('A') + point[0])}{point[1] + 1}"


def _crosses(a: tuple[tuple[int, int], tuple[int, int]], b: tuple[tuple[int, int], tuple[int, int]]) -> bool:
    """Whether a row's hallway and a column's cross (both between consecutive junctions of their line)."""
    (horizontal, vertical) = (a, b) if a[0][1] == a[1][1] else (b, a)
    if horizontal[0][1] != horizontal[1][1] or vertical[0][0] != vertical[1][0]:
        return False                                   # two of a kind: on distinct lines, or sharing no span
    column, row = vertical[0][0], horizontal[0][1]
    return (min(horizontal[0][0], horizontal[1][0]) < column < max(horizontal[0][0], horizontal[1][0])
            and min(vertical[0][1], vertical[1][1]) < row < max(vertical[0][1], vertical[1][1]))


def draw_layout(seed: int, attempt: int = 0, rules: LayoutRules = RULES) -> Layout | None:
    """The seed's layout at ``attempt``, or None when its junctions cannot all be joined (a new attempt then)."""
    rng = np.random.default_rng([seed, attempt])
    columns = int(rng.integers(rules.columns[0], rules.columns[1] + 1))
    rows = int(rng.integers(rules.rows[0], rules.rows[1] + 1))
    steps = round((rules.spacing_m[1] - rules.spacing_m[0]) / rules.spacing_step_m)

    def lines(count: int) -> list[float]:
        gaps = rules.spacing_m[0] + rules.spacing_step_m * rng.integers(0, steps + 1, size=count - 1)
        return [0.0, *np.cumsum(gaps).tolist()]

    easts, norths = lines(columns), lines(rows)
    points = [(c, r) for r in range(rows) for c in range(columns)]
    absent = rng.random(len(points)) < rules.absent_fraction
    present = [point for point, gone in zip(points, absent) if not gone]
    candidates: list[tuple[tuple[int, int], tuple[int, int]]] = []
    for r in range(rows):
        line = [point for point in present if point[1] == r]
        candidates += list(zip(line, line[1:]))
    for c in range(columns):
        line = [point for point in present if point[0] == c]
        candidates += list(zip(line, line[1:]))
    order = rng.permutation(len(candidates))
    component = {point: point for point in present}

    def root(point: tuple[int, int]) -> tuple[int, int]:
        while component[point] != point:
            point = component[point]
        return point

    chosen: list[tuple[tuple[int, int], tuple[int, int]]] = []
    rest = []
    for index in order:                                    # Kruskal on a random order: a random spanning tree
        hallway = candidates[int(index)]
        a, b = root(hallway[0]), root(hallway[1])
        if a != b and not any(_crosses(hallway, other) for other in chosen):
            component[a] = b
            chosen.append(hallway)
        else:
            rest.append(hallway)
    if len({root(point) for point in present}) != 1 or len(present) < 4:
        return None
    loops = rng.random(len(rest)) < rules.loop_fraction
    for hallway, opened in zip(rest, loops):
        if opened and not any(_crosses(hallway, other) for other in chosen):
            chosen.append(hallway)
    positions = {point: (easts[point[0]], norths[point[1]]) for point in present}
    joined = {(point, side) for a, b in chosen for point, side in
              ((a, "E" if a[1] == b[1] else "N"), (b, "W" if a[1] == b[1] else "S"))}
    unknown: list[tuple[tuple[int, int], str]] = []
    draws = rng.random(len(present) * len(DIRECTIONS))
    clear_m = 2.0 * (HALLWAY_WIDTH_M / 2.0 + DEAD_END_M) + 0.4    # two facing dead ends with room between
    for (point, side), draw in zip(((p, s) for p in present for s in DIRECTIONS), draws):
        if (point, side) in joined or draw >= rules.unknown_probability:
            continue
        facing = _next_on_line(point, side, positions)
        if facing is not None and (facing, _OPPOSITE[side]) in unknown and \
                math.dist(positions[point], positions[facing]) < clear_m:
            continue
        unknown.append((point, side))
    sides = sorted(joined) + unknown
    twos = rng.random(len(sides)) < rules.two_tags_probability
    north = float(rules.north_choices_deg[int(rng.integers(len(rules.north_choices_deg)))])
    return Layout(f"generated_{seed}", north, positions, tuple(chosen), tuple(unknown),
                  tuple(side for side, two in zip(sides, twos) if two and side in joined), attempt)


_OPPOSITE = {"N": "S", "E": "W", "S": "N", "W": "E"}


def _next_on_line(point: tuple[int, int], side: str, positions: dict[tuple[int, int], tuple[float, float]]) \
        -> tuple[int, int] | None:
    """The nearest junction from ``point`` towards ``side`` on its row or column."""
    dc, dr = _STEP[side]
    ahead = [other for other in positions if (other[0] - point[0]) * dr == (other[1] - point[1]) * dc
             and (other[0] - point[0]) * dc + (other[1] - point[1]) * dr > 0]
    return min(ahead, key=lambda other: math.dist(positions[point], positions[other]), default=None)


def map_text(layout: Layout, seed: int) -> str:
    """The layout as a topological map file (``config/maps`` format)."""
    north = math.radians(layout.north_deg)
    north_axis = (math.cos(north), math.sin(north))
    east_axis = (math.sin(north), -math.cos(north))        # North turned 90 degrees clockwise

    def frame(east: float, north_m: float) -> str:
        x = round(east * east_axis[0] + north_m * north_axis[0], DECIMALS) + 0.0
        y = round(east * east_axis[1] + north_m * north_axis[1], DECIMALS) + 0.0
        return f"[{x!r}, {y!r}]"

    neighbours: dict[tuple[tuple[int, int], str], tuple[int, int]] = {}
    for a, b in layout.hallways:
        along_row = a[1] == b[1]
        neighbours[(a, "E" if along_row else "N")] = b
        neighbours[(b, "W" if along_row else "S")] = a
    unknown = set(layout.unknown_sides)
    twos = set(layout.two_tag_sides)
    lines = [f"# {layout.name}: GENERATED by rfidnav_sim.floor_generator from seed {seed} (attempt "
             f"{layout.attempt}); nobody drew it.",
             f"# {len(layout.positions)} junctions, {len(layout.hallways)} hallways, {len(unknown)} '?' dead ends; "
             "North is the map's "
             f"{ {0.0: '+x', 90.0: '+y', 180.0: '-x', 270.0: '-y'}.get(layout.north_deg, 'bearing')}.",
             f"name: {json.dumps(layout.name)}",
             f"description: {json.dumps(f'generated floor, seed {seed}, attempt {layout.attempt}')}",
             f"north_deg: {layout.north_deg:g}",
             f"tag_to_node_m: {TAG_TO_NODE_M:g}",
             "nodes:"]
    tag = 0
    for point in sorted(layout.positions, key=lambda p: (p[1], p[0])):
        lines += [f"  {node_name(point)}:", f"    position: {frame(*layout.positions[point])}"]
        for side in DIRECTIONS:
            if (point, side) in neighbours:
                far = node_name(neighbours[(point, side)])
            elif (point, side) in unknown:
                far = UNKNOWN
            else:
                continue
            count = 2 if (point, side) in twos else 1
            tags = ", ".join(str(tag + k + 1) for k in range(count))
            tag += count
            lines.append(f"    {side}: {{node: {json.dumps(far)}, tags: [{tags}]}}")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class GeneratedFloor:
    seed: int
    map_text: str
    topological_map: TopologicalMap
    world: World


def _checked_map(text: str) -> tuple[TopologicalMap | None, list[str]]:
    """The map a text holds and ``map check``'s problems with it (the same function, on a file)."""
    with tempfile.TemporaryDirectory(prefix="rfidnav_floor_") as directory:
        path = Path(directory) / "map.yaml"
        path.write_text(text, encoding="utf-8")
        problems = check_floor_map(path)
        return (None if problems else load_topological_map(path)), problems


@functools.lru_cache(maxsize=16)
def generated_floor(seed: int, rules: LayoutRules = RULES) -> GeneratedFloor:
    """The seed's floor: its map and the world built from it (the first attempt that passes ``map check``)."""
    for attempt in range(MAX_ATTEMPTS):
        layout = draw_layout(seed, attempt, rules)
        if layout is None:
            continue
        text = map_text(layout, seed)
        topological_map, problems = _checked_map(text)
        if topological_map is None:
            continue
        floor = building_floor(topological_map)
        walls = tuple((float(x1), float(y1), float(x2), float(y2)) for x1, y1, x2, y2 in floor.walls)
        world = World(layout.name, "map", (), walls,
                      wall_tags=floor.wall_tags, source=f"generated floor of seed {seed}")
        return GeneratedFloor(seed, text, topological_map, world)
    raise ValueError(f"seed {seed}: no layout of {MAX_ATTEMPTS} attempts passes map check")


def write_floor(seed: int, map_path: Path | str, world_path: Path | str) -> None:
    """Write the seed's map and world files (the world as ``python -m rfidnav_sim.building`` writes it)."""
    floor = generated_floor(seed)
    Path(map_path).write_text(floor.map_text, encoding="utf-8")
    built = building_floor(floor.topological_map)
    write_world(built, floor.topological_map.name, world_path,
                f"Ground truth of {floor.topological_map.name}: GENERATED by rfidnav_sim.building from the map "
                f"{map_path}\n(rfidnav_sim.floor_generator, seed {seed}). Do not edit: regenerate with\n"
                f"  python -m rfidnav_sim.floor_generator {seed} {map_path} {world_path}")


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rfidnav_sim.floor_generator",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("seed", type=int)
    parser.add_argument("map", help="topological map file to write")
    parser.add_argument("world", help="world file to write")
    args = parser.parse_args(argv)
    write_floor(args.seed, args.map, args.world)
    return 0


if __name__ == "__main__":
    sys.exit(main())
