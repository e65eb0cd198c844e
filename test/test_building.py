"""Floors of paper 004 built from topological maps (rfidnav_sim.building): walls, openings and left-wall tags.

Pure-module tests: no ROS. The two-node floor's walls and tag positions are worked out by hand; the generated
Fig. 5 and large worlds are checked for every tag sitting on a wall and no wall doubling or crossing another.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from rfidnav_common.topological_map import TopologicalMap, load_topological_map
from rfidnav_sim.building import building_floor, main, write_world
from rfidnav_sim.wall_tag_model import InductionArea, WallTag, WallTagReader
from rfidnav_sim.world import load_world

pytestmark = pytest.mark.tier("unit")

REPO = Path(__file__).resolve().parents[1]
MAPS = ("building_fig5", "building_large")
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


def test_a_node_without_a_position_is_an_error_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "unplaced.yaml"
    path.write_text("name: unplaced\nnodes:\n  a:\n    position: [0.0, 0.0]\n    E: {node: lost}\n"
                    "  lost:\n    W: {node: a}\n")
    with pytest.raises(ValueError, match="node 'lost' has no position"):
        building_floor(load_topological_map(path))


def test_a_hallway_off_its_compass_line_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="node 'a' side E: the far node is \\+1.000 m off the E line"):
        building_floor(two_node_map(tmp_path, b="[8.0, 1.0]"))


def test_an_unmapped_hallway_is_a_3_m_dead_end_and_a_dash_side_a_wall() -> None:
    walls = building_floor(load_topological_map(REPO / "config/maps/building_fig5.yaml")).walls
    d = (8.0, 16.0)
    assert ray_hit_m(walls, d, math.pi / 2) == pytest.approx(0.8 + 3.0)   # d.N = "?"
    assert ray_hit_m(walls, d, math.pi) == pytest.approx(0.8)             # d.W = "-"
    assert ray_hit_m(walls, d, 0.0) == pytest.approx(8.0 + 0.8 + 3.0)     # d.E = e, then e.E = "?"


@pytest.mark.parametrize("map_name", MAPS)
def test_every_map_tag_is_on_a_wall_facing_into_the_hallway(map_name: str) -> None:
    topological_map = load_topological_map(REPO / f"config/maps/{map_name}.yaml")
    floor = building_floor(topological_map)
    map_tags = {tag for node in topological_map.nodes.values() for hallway in node.hallways.values()
                for tag in hallway.tags}
    assert sorted(tag.tag_id for tag in floor.wall_tags) == sorted(map_tags)
    for tag in floor.wall_tags:
        assert min(distance_to_segment_m(tag.position, wall) for wall in floor.walls) <= 0.05, tag.tag_id
        # A step along the normal lands in open hallway: no wall within 0.5 m along it.
        assert ray_hit_m(floor.walls, tag.position, math.atan2(tag.normal[1], tag.normal[0])) > 0.5, tag.tag_id


@pytest.mark.parametrize("map_name", MAPS)
def test_no_two_walls_overlap_or_cross(map_name: str) -> None:
    walls = building_floor(load_topological_map(REPO / f"config/maps/{map_name}.yaml")).walls
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
            assert min(a1, b1) - max(a0, b0) <= 1e-9, (first, second)    # collinear: touching ends at most
        else:
            t = (offset[0] * s[1] - offset[1] * s[0]) / cross
            u = (offset[0] * r[1] - offset[1] * r[0]) / cross
            assert not (1e-9 < t < 1 - 1e-9 and 1e-9 < u < 1 - 1e-9), (first, second)   # no crossing


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
