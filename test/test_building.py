"""Floors of paper 004 built from topological maps (rfidnav_sim.building): walls, openings and left-wall tags, and
the generator's checks, which ``map check`` runs too (rfidnav_common.floor_plan).

Pure-module tests: no ROS. The two-node floor's walls and tag positions are worked out by hand; the generated
worlds are checked for every tag sitting on a wall and no wall doubling or crossing another; each kind of map the
generator refuses is refused by ``map check`` with the same line; in-tree and mutated maps pass ``map check``
exactly when the generator builds them, into sound floors.
"""

from __future__ import annotations

import copy
import itertools
import math
import random
from pathlib import Path

import numpy as np
import pytest
import yaml

from rfidnav_common.errors import ConfigError
from rfidnav_common.floor_plan import check_floor_map
from rfidnav_common.topological_map import TopologicalMap, check_map, load_topological_map
from rfidnav_common.wall_tags import InductionArea, WallTag
from rfidnav_sim.building import Floor, building_floor, main, write_world
from rfidnav_sim.wall_tag_model import WallTagReader
from rfidnav_sim.world import load_world

pytestmark = pytest.mark.tier("unit")

REPO = Path(__file__).resolve().parents[1]
MAPS = ("building_fig5", "building_large", "building_ring")
TWO_NODES = """\
name: two_nodes
north_deg: {north_deg}
nodes:
  a:
    position: {a}
    {side_ab}: {{node: b, tags: [1]}}
  b:
    position: {b}
    {side_ba}: {{node: a, tags: [2, 3]}}
"""


def two_node_map(tmp_path: Path, north_deg: float = 90.0, a: str = "[0.0, 0.0]", b: str = "[8.0, 0.0]",
                 side_ab: str = "E", side_ba: str = "W") -> TopologicalMap:
    path = tmp_path / "two_nodes.yaml"
    path.write_text(TWO_NODES.format(north_deg=north_deg, a=a, b=b, side_ab=side_ab, side_ba=side_ba))
    return load_topological_map(path)


def as_set(walls: np.ndarray) -> set[tuple[float, ...]]:
    """Walls without direction: each segment's endpoints in sorted order, rounded to the micrometre."""
    return {tuple(round(v, 6) + 0.0 for v in min((w[0], w[1]), (w[2], w[3])) + max((w[0], w[1]), (w[2], w[3])))
            for w in walls.tolist()}


def ray_hit_m(walls: np.ndarray, origin: tuple[float, float], heading_rad: float) -> float:
    """Distance along a ray to the nearest wall (inf if none)."""
    direction = np.array([math.cos(heading_rad), math.sin(heading_rad)])
    nearest = math.inf
    for x1, y1, x2, y2 in walls:
        edge = np.array([x2 - x1, y2 - y1])
        denominator = direction[0] * edge[1] - direction[1] * edge[0]
        if abs(denominator) < 1e-12:
            continue
        to_start = np.array([x1 - origin[0], y1 - origin[1]])
        distance = (to_start[0] * edge[1] - to_start[1] * edge[0]) / denominator
        fraction = (to_start[0] * direction[1] - to_start[1] * direction[0]) / denominator
        if distance > 1e-9 and -1e-9 <= fraction <= 1.0 + 1e-9:
            nearest = min(nearest, distance)
    return nearest


def distance_to_segment_m(point: tuple[float, float], wall: np.ndarray) -> float:
    start, end, p = wall[:2], wall[2:], np.asarray(point)
    fraction = np.clip((p - start) @ (end - start) / ((end - start) @ (end - start)), 0.0, 1.0)
    return float(np.linalg.norm(p - (start + fraction * (end - start))))


def test_two_nodes_give_exactly_the_hand_worked_walls(tmp_path: Path) -> None:
    floor = building_floor(two_node_map(tmp_path))
    assert as_set(floor.walls) == {
        (0.8, -0.8, 7.2, -0.8), (0.8, 0.8, 7.2, 0.8),            # the corridor's sides, y = -+0.8
        (-0.8, 0.8, 0.8, 0.8), (-0.8, -0.8, 0.8, -0.8), (-0.8, -0.8, -0.8, 0.8),   # a's square: N, S, W closed
        (7.2, 0.8, 8.8, 0.8), (7.2, -0.8, 8.8, -0.8), (8.8, -0.8, 8.8, 0.8),       # b's square: N, S, E closed
    }
    assert len(floor.walls) == 8


def test_the_corridor_is_open_from_a_to_b_s_far_wall(tmp_path: Path) -> None:
    walls = building_floor(two_node_map(tmp_path)).walls
    assert ray_hit_m(walls, (0.0, 0.0), 0.0) == pytest.approx(8.8)        # a's E side and b's W side are open
    assert ray_hit_m(walls, (8.0, 0.0), math.pi) == pytest.approx(8.8)    # back to a's closed W side
    assert ray_hit_m(walls, (4.0, 0.0), math.pi / 2) == pytest.approx(0.8)


def test_the_tag_announcing_b_from_the_west_is_on_the_left_wall_before_the_junction(tmp_path: Path) -> None:
    tags = {tag.tag_id: tag for tag in building_floor(two_node_map(tmp_path)).wall_tags}
    assert set(tags) == {"1", "2", "3"}
    # Arriving at b heading East: the left wall is the north wall y = +0.8; b's square starts at x = 7.2.
    assert tags["2"].position == pytest.approx((7.2 - 1.0, 0.8))
    assert tags["2"].normal == pytest.approx((0.0, -1.0))                 # into the corridor
    assert tags["3"].position == pytest.approx((7.2 - 1.3, 0.8))          # the second tag 0.3 m further back
    # Arriving at a heading West: the left wall is the south wall; a's square ends at x = 0.8.
    assert tags["1"].position == pytest.approx((0.8 + 1.0, -0.8))
    assert tags["1"].normal == pytest.approx((0.0, 1.0))


def test_the_robot_following_the_left_wall_at_0_8_m_reads_the_tag_of_the_junction_ahead(tmp_path: Path) -> None:
    reader = WallTagReader(InductionArea(), building_floor(two_node_map(tmp_path)).wall_tags)
    heading_east_at_tag_2 = reader.in_reach(6.2, 0.0, 0.0)
    assert [tag.tag_id for tag, read in zip(reader.tags, heading_east_at_tag_2) if read] == ["2"]
    assert not reader.in_reach(1.8, 0.0, 0.0).any()                       # tag 1 is on the right: not this way
    assert [tag.tag_id for tag, read in zip(reader.tags, reader.in_reach(1.8, 0.0, math.pi)) if read] == ["1"]


def test_compass_directions_follow_north_deg(tmp_path: Path) -> None:
    # North along the map's +x: b lies 8 m North of a, and the robot heading North has its left wall at y = +0.8.
    floor = building_floor(two_node_map(tmp_path, north_deg=0.0, side_ab="N", side_ba="S"))
    assert (0.8, -0.8, 7.2, -0.8) in as_set(floor.walls)
    tags = {tag.tag_id: tag for tag in floor.wall_tags}
    assert tags["2"].position == pytest.approx((6.2, 0.8))
    assert tags["2"].normal == pytest.approx((0.0, -1.0))


def test_an_unmapped_hallway_is_a_3_m_dead_end_and_a_dash_side_a_wall() -> None:
    walls = building_floor(load_topological_map(REPO / "config/maps/building_fig5.yaml")).walls
    d = (8.0, 16.0)
    assert ray_hit_m(walls, d, math.pi / 2) == pytest.approx(0.8 + 3.0)   # d.N = "?"
    assert ray_hit_m(walls, d, math.pi) == pytest.approx(0.8)             # d.W = "-"
    assert ray_hit_m(walls, d, 0.0) == pytest.approx(8.0 + 0.8 + 3.0)     # d.E = e, then e.E = "?"


def tags_off_their_walls(topological_map: TopologicalMap, floor: Floor) -> list[str]:
    """The map's tags missing from the floor, not on a wall, or facing a wall within 0.5 m (not into a hallway)."""
    map_tags = sorted(tag for node in topological_map.nodes.values() for hallway in node.hallways.values()
                      for tag in hallway.tags)
    bad = sorted(set(map_tags) ^ {tag.tag_id for tag in floor.wall_tags})
    for tag in floor.wall_tags:
        if (min(distance_to_segment_m(tag.position, wall) for wall in floor.walls) > 0.05
                or ray_hit_m(floor.walls, tag.position, math.atan2(tag.normal[1], tag.normal[0])) <= 0.5):
            bad.append(tag.tag_id)
    return bad


def crossing_walls(walls: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Pairs of walls that cross, or lie on one line and overlap (touching ends are allowed)."""
    found = []
    for first, second in itertools.combinations(walls, 2):
        p, r = first[:2], first[2:] - first[:2]
        q, s = second[:2], second[2:] - second[:2]
        cross = r[0] * s[1] - r[1] * s[0]
        offset = q - p
        if abs(cross) < 1e-9:
            if abs(offset[0] * r[1] - offset[1] * r[0]) > 1e-9:
                continue                                                  # parallel, on different lines
            unit = r / np.linalg.norm(r)
            a0, a1 = sorted((0.0, float(r @ unit)))
            b0, b1 = sorted((float(offset @ unit), float((offset + s) @ unit)))
            if min(a1, b1) - max(a0, b0) > 1e-9:                          # collinear: touching ends at most
                found.append((first, second))
        else:
            t = (offset[0] * s[1] - offset[1] * s[0]) / cross
            u = (offset[0] * r[1] - offset[1] * r[0]) / cross
            if 1e-9 < t < 1 - 1e-9 and 1e-9 < u < 1 - 1e-9:
                found.append((first, second))
    return found


@pytest.mark.parametrize("map_name", MAPS)
def test_every_map_tag_is_on_a_wall_facing_into_the_hallway(map_name: str) -> None:
    topological_map = load_topological_map(REPO / f"config/maps/{map_name}.yaml")
    assert tags_off_their_walls(topological_map, building_floor(topological_map)) == []


@pytest.mark.parametrize("map_name", MAPS)
def test_no_two_walls_overlap_or_cross(map_name: str) -> None:
    assert crossing_walls(building_floor(load_topological_map(REPO / f"config/maps/{map_name}.yaml")).walls) == []


# A three-junction L (a -- b east, a -- c north) with a "?" hallway west of a, on an 8 m grid.
L_FLOOR = """\
name: l_floor
nodes:
  a:
    position: [0.0, 0.0]
    E: {node: b, tags: [1]}
    N: {node: c, tags: [2]}
    W: {node: "?", tags: [3]}
  b:
    position: [8.0, 0.0]
    W: {node: a, tags: [4]}
  c:
    position: [0.0, 8.0]
    S: {node: a, tags: [5]}
"""


def refused(old: str, new: str, field: str, problem: str, robot_rule: bool = False, *, name: str) -> object:
    return pytest.param(old, new, field, problem, robot_rule, id=name)


GENERATOR_REFUSALS = [
    refused("  b:\n    position: [8.0, 0.0]\n", "  b:\n", "nodes.b.position", "missing: the world generator builds",
            name="node-without-position"),
    refused("[8.0, 0.0]", "[8.0, 1.0]", "nodes.a.E.node", "the far node is +1.000 m off the E line",
            name="hallway-off-its-compass-line"),
    refused("[8.0, 0.0]", "[1.2, 0.0]", "nodes.a.E.node", "1.200 m away, closer than the hallway width 1.6 m",
            name="nodes-closer-than-a-hallway-width"),
    refused("[0.0, 8.0]", "[0.0, 2.0]", "nodes.a.N.tags[0]",
            "tag '2' would be 1.00 m before the junction (tags 1 m before it, 0.3 m apart), beyond the 0.40 m "
            "corridor",
            name="a-tag-beyond-a-short-corridor"),
    refused("W: {node: \"?\", tags: [3]}", "W: {node: \"?\", tags: [3, 30, 31, 32, 33, 34, 35, 36]}",
            "nodes.a.W.tags[7]", "tag '36' would be 3.10 m before the junction",
            name="more-tags-than-a-dead-end-holds"),
    refused("  c:\n    position: [0.0, 8.0]\n    S: {node: a, tags: [5]}\n",
            "  c:\n    position: [0.0, 8.0]\n    S: {node: a, tags: [5]}\n    E: {node: d, tags: [50]}\n"
            "  d:\n    position: [4.0, 8.0]\n    W: {node: c, tags: [51]}\n    S: {node: e, tags: [52]}\n"
            "  e:\n    position: [4.0, -4.0]\n    N: {node: d, tags: [53]}\n    W: {node: '?'}\n",
            "nodes.a.E.node", "the hallway a.E (b) overlaps the hallway d.S (e)", name="hallways-that-cross"),
    refused("  c:\n", "  x:\n    position: [4.0, 0.0]\n    N: {node: '?', tags: [60]}\n  c:\n", "nodes.x.position",
            "the junction of 'x' overlaps the hallway a.E (b)", name="a-junction-on-a-hallway"),
    refused("E: {node: b, tags: [1]}", "E: {node: b, tags: [1], length_m: 25.0}", "nodes.a.E.length_m",
            "25 m, but 'a' and 'b' are 8.00 m apart by their positions", robot_rule=True,
            name="length-far-from-the-node-distance"),
    refused("W: {node: a, tags: [4]}", "W: {node: a, tags: [4], length_m: 7.0}", "nodes.b.W.length_m",
            "within 10% (at least 0.5 m) of that distance", robot_rule=True, name="length-shorter-than-the-distance"),
]


@pytest.mark.parametrize("old, new, field, problem, robot_rule", GENERATOR_REFUSALS)
def test_the_generator_and_map_check_refuse_a_map_with_the_same_line(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                                   old: str, new: str, field: str, problem: str,
                                                                   robot_rule: bool) -> None:
    assert old in L_FLOOR
    path = tmp_path / "broken.yaml"
    path.write_text(L_FLOOR.replace(old, new, 1))
    problems = check_floor_map(path)
    assert problems and problems[0].startswith(f"{path}: {field}: "), problems
    assert problem in problems[0]
    # The map's own rules (what the robot needs) pass it unless the break is theirs: the generator's are extra.
    assert bool(check_map(path)) == robot_rule
    world = tmp_path / "world.yaml"
    assert main([str(path), str(world)]) == 2
    assert capsys.readouterr().err.splitlines() == problems      # the same lines, no traceback
    assert not world.exists()


def test_the_l_floor_itself_is_built(tmp_path: Path) -> None:
    path = tmp_path / "l_floor.yaml"
    path.write_text(L_FLOOR)
    assert check_floor_map(path) == [] and main([str(path), str(tmp_path / "world.yaml")]) == 0


def mutants(count: int, seed: int) -> list[tuple[str, dict]]:
    """``count`` seeded one-change variants of the in-tree generated maps: a node moved (along a grid line, off
    it, onto another's junction), a position removed, tags added to a side, a length given."""
    rng = random.Random(seed)
    bases = {name: yaml.safe_load((REPO / f"config/maps/{name}.yaml").read_text()) for name in MAPS}
    made = []
    for index in range(count):
        name = rng.choice(MAPS)
        document = copy.deepcopy(bases[name])
        nodes = document["nodes"]
        node = rng.choice(sorted(nodes))
        sides = [side for side in ("N", "E", "S", "W") if side in nodes[node] and nodes[node][side]["node"] != "-"]
        kind = rng.choice(("move", "slide", "add", "unplace", "tags", "length"))
        mapped = [side for side in sides if nodes[node][side]["node"] != "?"]
        if kind == "move":
            axis = rng.randrange(2)
            nodes[node]["position"][axis] += rng.choice((-9.0, -6.0, -1.0, -0.5, 0.3, 1.0, 4.0, 7.0, 12.0))
        elif kind == "slide":
            # A node at the end of one mapped hallway (the others "?"), moved along it: nearer, farther, onto
            # or past its neighbour; its hallway's length no longer given.
            ends = [name for name in sorted(nodes) if sum(
                nodes[name].get(side, {}).get("node", "-") not in ("-", "?") for side in ("N", "E", "S", "W")) == 1]
            node = rng.choice(ends)
            side = next(side for side in ("N", "E", "S", "W")
                        if nodes[node].get(side, {}).get("node", "-") not in ("-", "?"))
            nodes[node][side].pop("length_m", None)
            nodes[nodes[node][side]["node"]][{"N": "S", "E": "W", "S": "N", "W": "E"}[side]].pop("length_m", None)
            axis = 1 if (side in ("N", "S")) == (document.get("north_deg", 90) % 180 == 90) else 0
            nodes[node]["position"][axis] += rng.choice((-7.0, -6.5, -3.0, 2.0, 5.0))
        elif kind == "add":
            # A new junction with one "?" hallway somewhere on the floor: in free space, or on a hallway.
            x, y = (rng.choice([p[axis] for p in (n["position"] for n in nodes.values())]) + rng.choice(
                (-4.0, -2.0, 0.0, 3.0, 4.0)) for axis in (0, 1))
            nodes[f"new{index}"] = {"position": [x, y], rng.choice(("N", "E", "S", "W")): {"node": "?"}}
        elif kind == "unplace":
            del nodes[node]["position"]
        elif kind == "tags" and sides:
            side = rng.choice(sides)
            nodes[node][side]["tags"] = [*nodes[node][side].get("tags", []),
                                         *(f"extra{index}_{k}" for k in range(rng.randrange(1, 25)))]
        elif kind == "length" and mapped:
            side = rng.choice(mapped)
            far = nodes[nodes[node][side]["node"]]["position"]
            distance = math.dist(nodes[node]["position"], far)
            nodes[node][side]["length_m"] = round(distance * rng.choice((0.5, 0.93, 1.0, 1.04, 1.3, 3.0)), 3)
        made.append((f"{name}_{index}_{kind}", document))
    return made


def test_map_check_passes_exactly_the_maps_the_generator_builds_into_a_sound_floor(tmp_path: Path) -> None:
    paths = [REPO / f"config/maps/{name}.yaml" for name in (*MAPS, "building_eval")]
    for label, document in mutants(80, seed=18):
        path = tmp_path / f"{label}.yaml"
        path.write_text(yaml.safe_dump(document))
        paths.append(path)
    outcomes = []
    for path in paths:
        passes = check_floor_map(path) == []
        try:
            topological_map = load_topological_map(path)
            floor = building_floor(topological_map)
        except ConfigError:
            floor = None
        assert passes == (floor is not None), (path.name, check_floor_map(path))
        if floor is not None:
            assert tags_off_their_walls(topological_map, floor) == [], path.name
            assert crossing_walls(floor.walls) == [], path.name
        outcomes.append(passes)
    assert 10 <= sum(outcomes) <= len(outcomes) - 10        # the mutants pass and fail: the test can fail


def test_write_world_writes_name_walls_and_wall_tags(tmp_path: Path) -> None:
    floor = building_floor(two_node_map(tmp_path))
    write_world(floor, "two_nodes", tmp_path / "world.yaml", header="ground truth\nline two")
    text = (tmp_path / "world.yaml").read_text()
    assert text.startswith("# ground truth\n# line two\n")
    world = yaml.safe_load(text)
    assert world["name"] == "two_nodes"
    assert as_set(np.array(world["walls"])) == as_set(floor.walls)
    assert [WallTag(t["id"], tuple(t["position"]), tuple(t["normal"])) for t in world["wall_tags"]] == \
        list(floor.wall_tags)


@pytest.mark.parametrize("map_name", MAPS)
def test_the_committed_worlds_are_what_the_generator_writes(map_name: str, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(REPO)
    world = f"config/worlds/{map_name}.yaml"
    main([f"config/maps/{map_name}.yaml", world.replace("config/worlds", str(tmp_path))])
    generated = (tmp_path / f"{map_name}.yaml").read_text()
    assert generated.replace(str(tmp_path), "config/worlds") == (REPO / world).read_text(), \
        f"regenerate with: python -m rfidnav_sim.building config/maps/{map_name}.yaml {world}"


@pytest.mark.parametrize("map_name", MAPS)
def test_the_world_loader_reads_the_committed_worlds_as_generated(map_name: str) -> None:
    floor = building_floor(load_topological_map(REPO / f"config/maps/{map_name}.yaml"))
    world = load_world(REPO / f"config/worlds/{map_name}.yaml")
    assert world.name == map_name
    assert as_set(np.array(world.walls)) == as_set(floor.walls)
    assert world.wall_tags == floor.wall_tags
