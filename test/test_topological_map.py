"""The topological map of paper 004 (sections 3-5): reading and checking map files, tags, routes, turns, drawing."""

from __future__ import annotations

import struct
import textwrap
from pathlib import Path
from types import SimpleNamespace

import networkx as nx
import pytest

from rfidnav_bringup.report import draw_map, learned_map
from rfidnav_common.errors import ConfigError, RfidnavError
from rfidnav_common.topological_map import (
    DIRECTIONS,
    UNKNOWN,
    Hallway,
    NextAction,
    Node,
    RouteError,
    TopologicalMap,
    check_map,
    hallway_text,
    load_topological_map,
    next_action,
    parse_hallway_text,
    turn,
)
from rfidnav_scenario.metrics import topological_shortest_m

pytestmark = pytest.mark.tier("unit")

MAPS = Path(__file__).resolve().parents[1] / "config" / "maps"

# The nodes c and d of Fig. 5(b) with their neighbours, on an 8 m grid (North = map +y).
PAPER_NODES = """\
name: paper_c_d
nodes:
  c:
    position: [8.0, 8.0]
    N: {node: d, tags: [8]}
    E: {node: h, tags: [9]}
    S: {node: b, tags: [10]}
    W: {node: a, tags: [7]}
  d:
    position: [8.0, 16.0]
    N: {node: "?", tags: [12]}
    E: {node: e, tags: [13]}
    S: {node: c, tags: [11]}
    W: {node: "-"}
  a: {position: [0.0, 8.0], E: {node: c, tags: [1]}}
  b: {position: [8.0, 0.0], N: {node: c, tags: [4]}}
  e: {position: [16.0, 16.0], W: {node: d, tags: [14]}}
  h: {position: [16.0, 8.0], W: {node: c, tags: [23]}}
"""

# s -> t either East through x (two 10 m hallways) or North-about through y and z (three 2 m hallways).
DETOUR = """\
name: detour
nodes:
  s:
    E: {node: x, tags: [s-from-x], length_m: 10.0}
    N: {node: y, tags: [s-from-y], length_m: 2.0}
  x:
    W: {node: s, tags: [x-from-s]}
    E: {node: t, tags: [x-from-t], length_m: 10.0}
  t:
    W: {node: x, tags: [t-from-x]}
    N: {node: z, tags: [t-from-z]}
  y:
    S: {node: s, tags: [y-from-s]}
    E: {node: z, tags: [y-from-z], length_m: 2.0}
  z:
    W: {node: y, tags: [z-from-y]}
    S: {node: t, tags: [z-from-t], length_m: 2.0}
"""


def write_map(tmp_path: Path, text: str, name: str = "map.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


@pytest.fixture
def paper_map(tmp_path: Path) -> TopologicalMap:
    return load_topological_map(write_map(tmp_path, PAPER_NODES))


# ---------------------------------------------------------------- parsing

def test_parses_the_paper_node_records(paper_map: TopologicalMap) -> None:
    assert paper_map.name == "paper_c_d"
    assert paper_map.north_deg == 90.0
    assert list(paper_map.nodes) == ["c", "d", "a", "b", "e", "h"]
    c, d = paper_map.nodes["c"], paper_map.nodes["d"]
    assert c.position == (8.0, 8.0)
    assert c.hallways == {"N": Hallway("d", ("8",)), "E": Hallway("h", ("9",)), "S": Hallway("b", ("10",)),
                          "W": Hallway("a", ("7",))}
    assert d.hallways == {"N": Hallway(UNKNOWN, ("12",)), "E": Hallway("e", ("13",)), "S": Hallway("c", ("11",))}
    assert "W" not in d.hallways                       # "-": no hallway
    # '?' hallways are not edges; each mapped hallway is listed once.
    assert {(e.node_a, e.side_a, e.node_b, e.side_b) for e in paper_map.edges()} == {
        ("c", "N", "d", "S"), ("a", "E", "c", "W"), ("b", "N", "c", "S"), ("c", "E", "h", "W"),
        ("d", "E", "e", "W")}


def test_north_reference_and_side_fields(tmp_path: Path) -> None:
    # North along the map's +x: d, to the North of c, has the larger x.
    path = write_map(tmp_path, """\
        name: rotated
        north_deg: 0
        tag_to_node_m: 1.5
        description: a two-node map with North along map x
        nodes:
          c: {position: [0.0, 0.0], N: {node: d, tags: [A, 7], length_m: 4.5}}
          d: {position: [5.0, 0.0], S: {node: c}}
        """)
    rotated = load_topological_map(path)
    assert rotated.north_deg == 0.0 and rotated.tag_to_node_m == 1.5
    assert rotated.nodes["c"].hallways["N"] == Hallway("d", ("A", "7"), 4.5)
    assert rotated.nodes["d"].hallways["S"] == Hallway("c", (), None)
    assert rotated.hallway_length_m("d", "S") == 4.5  # the length given at the other end
    assert check_map(path) == []


# ---------------------------------------------------------------- check_map: every problem, file and field

def broken(tmp_path: Path, old: str, new: str) -> Path:
    text = PAPER_NODES.replace(old, new)
    assert text != PAPER_NODES, f"'{old}' not in the map"
    return write_map(tmp_path, text, "broken.yaml")


def case(old: str, new: str, field: str, problem: str, *, name: str, also: tuple[str, ...] = ()) -> object:
    """Replace ``old`` by ``new`` in the paper map: the break is reported first, at ``field``; ``also`` are the
    fields where its consequences are reported."""
    return pytest.param(old, new, field, problem, also, id=name)


BROKEN = [
    case("E: {node: e, tags: [13]}", "E: {node: e, tags: [9]}",
         "nodes.d.E.tags[0]", "duplicate tag '9' (also at nodes.c.E.tags[0])", name="duplicate-tag"),
    case("S: {node: c, tags: [11]}", "S: {node: '-'}",
         "nodes.c.N.node", "leads to 'd', but nodes.d.S.node is missing", name="not-mirrored"),
    case("b: {position: [8.0, 0.0], N: {node: c, tags: [4]}}",
         "b: {position: [8.0, 0.0], N: {node: e, tags: [4]}}",
         "nodes.c.S.node", "leads to 'b', but nodes.b.N.node is 'e'", name="mirrored-elsewhere",
         also=("nodes.b.N.node",)),      # e.S does not lead back to b either
    case("W: {node: a, tags: [7]}", "W: {node: q, tags: [7]}",
         "nodes.c.W.node", "unknown node 'q'", name="unknown-node",
         also=("nodes.a.E.node",)),      # c.W no longer leads back to a
    case('W: {node: "-"}', 'NE: {node: "-"}',
         "nodes.d.NE", "unknown direction", name="unknown-direction"),
    case('W: {node: "-"}', 'W: {node: "-", tags: [99]}',
         "nodes.d.W.tags", "'-' (no hallway) cannot have tags", name="no-hallway-with-tags"),
    case("h: {position: [16.0, 8.0], W: {node: c, tags: [23]}}",
         "h: {position: [16.0, 8.0], W: {node: c, tags: [23]}}\n  k: {position: [30.0, 8.0]}",
         "nodes.k", "not reachable from 'c'", name="unreachable"),
    case("e: {position: [16.0, 16.0]", "e: {position: [8.0, 24.0]",
         "nodes.d.E.node", "'e' lies 90 deg off the E of 'd'", name="position-off-compass"),
    case("a: {position: [0.0, 8.0]", "a: {position: [0.0, 8.0, 1.0]",
         "nodes.a.position", "expected 2 numbers, got 3", name="bad-position"),
    case("a: {position: [0.0, 8.0], E: {node: c, tags: [1]}}",
         "a: {position: [0.0, 8.0], E: {node: c, tags: [1], length_m: -2}}",
         "nodes.a.E.length_m", "must be positive", name="negative-length"),
    case("b: {position: [8.0, 0.0], N: {node: c, tags: [4]}}",
         "b: {position: [8.0, 0.0], N: {node: c, tags: 4}}",
         "nodes.b.N.tags", "expected a list of tag ids", name="tags-not-a-list"),
    case("N: {node: d, tags: [8]}", "N: {node: d, tags: [8], lenght_m: 3}",
         "nodes.c.N.lenght_m", "unknown field", name="unknown-side-field"),
    case("name: paper_c_d", "name: paper_c_d\nnorth: 90",
         "north", "unknown field", name="unknown-top-field"),
    case("name: paper_c_d", "name: paper_c_d\ntag_to_node_m: -1",
         "tag_to_node_m", "at least 0", name="negative-tag-to-node"),
]


@pytest.mark.parametrize("old, new, field, problem, also", BROKEN)
def test_check_map_names_file_and_field(tmp_path: Path, old: str, new: str, field: str, problem: str,
                                        also: tuple[str, ...]) -> None:
    path = broken(tmp_path, old, new)
    problems = check_map(path)
    assert [line.split(": ")[1] for line in problems] == [field, *also], problems
    assert problems[0].startswith(f"{path}: {field}: ")
    assert problem in problems[0]
    with pytest.raises(ConfigError) as raised:
        load_topological_map(path)
    assert (raised.value.source, raised.value.field) == (str(path), field)


def test_a_node_only_reachable_through_question_marks_is_allowed(tmp_path: Path) -> None:
    # d has a "?" hallway North; k has one West: they may join through hallways not yet explored.
    path = broken(tmp_path, "h: {position: [16.0, 8.0], W: {node: c, tags: [23]}}",
                  "h: {position: [16.0, 8.0], W: {node: c, tags: [23]}}\n  k: {position: [30.0, 8.0], "
                  "W: {node: '?', tags: [99]}}")
    assert check_map(path) == []


def test_length_mismatch_is_reported_once(tmp_path: Path) -> None:
    path = broken(tmp_path, "a: {position: [0.0, 8.0], E: {node: c, tags: [1]}}",
                  "a: {position: [0.0, 8.0], E: {node: c, tags: [1], length_m: 8.4}}")
    path.write_text(path.read_text().replace("W: {node: a, tags: [7]}", "W: {node: a, tags: [7], length_m: 8.0}"))
    assert check_map(path) == [f"{path}: nodes.a.E.node: length_m 8.4 here but 8 at 'c'.W: the two ends of a "
                               "hallway must agree"]


@pytest.mark.parametrize("length_m, accepted", [(8.0, True), (8.79, True), (7.21, True), (8.81, False),
                                                (7.19, False), (25.0, False)])
def test_a_length_lies_within_a_tenth_of_the_distance_between_the_positions(tmp_path: Path, length_m: float,
                                                                            accepted: bool) -> None:
    path = broken(tmp_path, "a: {position: [0.0, 8.0], E: {node: c, tags: [1]}}",
                  f"a: {{position: [0.0, 8.0], E: {{node: c, tags: [1], length_m: {length_m}}}}}")
    problems = check_map(path)
    assert problems == ([] if accepted else [
        f"{path}: nodes.a.E.length_m: {length_m:g} m, but 'a' and 'c' are 8.00 m apart by their positions: a "
        "hallway's length lies within 10% (at least 0.5 m) of that distance"])


def test_a_short_hallways_length_may_be_off_by_half_a_metre(tmp_path: Path) -> None:
    text = PAPER_NODES.replace("a: {position: [0.0, 8.0], E: {node: c, tags: [1]}}",
                               "a: {position: [6.0, 8.0], E: {node: c, tags: [1], length_m: 2.45}}")
    assert check_map(write_map(tmp_path, text)) == []                 # 2 m apart: 0.5 m, not 10 %, applies
    assert len(check_map(write_map(tmp_path, text.replace("2.45", "2.55")))) == 1


def test_check_map_lists_every_problem_and_load_raises_the_first(tmp_path: Path) -> None:
    text = (PAPER_NODES.replace("E: {node: e, tags: [13]}", "E: {node: e, tags: [9]}")
            .replace("W: {node: a, tags: [7]}", "W: {node: q, tags: [7]}")
            .replace('W: {node: "-"}', 'X: {node: "-"}'))
    path = write_map(tmp_path, text)
    problems = check_map(path)
    fields = [line.split(": ")[1] for line in problems]
    assert sorted(fields) == ["nodes.a.E.node", "nodes.c.W.node", "nodes.d.E.tags[0]", "nodes.d.X"]
    with pytest.raises(ConfigError) as raised:
        load_topological_map(path)
    assert str(raised.value) == problems[0]


@pytest.mark.parametrize("text, field, problem", [
    ("", "", "file is empty"),
    ("name: empty\nnodes: {}\n", "nodes", "the map has no nodes"),
    ("name: empty\n", "nodes", "missing required field"),
    ("name: [broken\n", "", "not valid YAML"),
], ids=["empty-file", "no-nodes", "nodes-missing", "bad-yaml"])
def test_empty_or_unreadable_map(tmp_path: Path, text: str, field: str, problem: str) -> None:
    path = write_map(tmp_path, text)
    problems = check_map(path)
    assert len(problems) == 1
    assert problems[0].startswith(f"{path}: {field + ': ' if field else ''}")
    assert problem in problems[0]


def test_missing_file(tmp_path: Path) -> None:
    assert check_map(tmp_path / "nowhere.yaml") == [f"{tmp_path / 'nowhere.yaml'}: file not found"]


# ---------------------------------------------------------------- tags

def test_locate_tag_gives_node_and_arrival_side(paper_map: TopologicalMap) -> None:
    assert paper_map.locate_tag("9") == ("c", "E")   # the paper: tag 9 -> coming into c from the East
    assert paper_map.locate_tag(9) == ("c", "E")     # a YAML number is the same id as its text
    assert paper_map.locate_tag("11") == ("d", "S")
    assert paper_map.locate_tag("12") == ("d", "N")  # on the '?' side
    assert paper_map.locate_tag("99") is None


# ---------------------------------------------------------------- routes

def test_route_by_edges_and_by_length(tmp_path: Path) -> None:
    detour = load_topological_map(write_map(tmp_path, DETOUR))
    assert detour.route("s", "t") == ["s", "x", "t"]                          # 2 hallways (20 m)
    assert detour.route("s", "t", weight="length") == ["s", "y", "z", "t"]    # 3 hallways (6 m)
    assert detour.route("t", "s", weight="length") == ["t", "z", "y", "s"]
    assert detour.route("s", "s") == ["s"]


def test_a_hallway_as_text_reads_back_and_is_learned_at_both_ends(paper_map: TopologicalMap) -> None:
    assert hallway_text("d", "N", "x.1", "S") == "d.N -> x.1.S"
    assert parse_hallway_text("d.N -> x.1.S") == ("d", "N", "x.1", "S")      # a node name may hold a dot
    for bad in ("d.N", "d.N -> x", "d.Q -> e.W", ".N -> e.W"):
        with pytest.raises(ValueError):
            parse_hallway_text(bad)
    # d's North is "?": joined to a new node's South it is routable, in a copy.
    nodes = {**paper_map.nodes, "x": Node("x", {"S": Hallway(UNKNOWN, ("99",))}, (8.0, 24.0))}
    with_x = TopologicalMap("with_x", nodes)
    learned = with_x.with_hallway("d", "N", "x", "S")
    assert learned.route("c", "x") == ["c", "d", "x"]
    assert learned.nodes["x"].hallways["S"] == Hallway("d", ("99",))
    assert with_x.nodes["d"].hallways["N"].neighbour == UNKNOWN
    with pytest.raises(RouteError, match="d.E is not a '[?]' hallway"):
        with_x.with_hallway("d", "E", "x", "S")


def test_a_report_measures_the_shortest_path_on_the_map_the_executor_learned(tmp_path: Path) -> None:
    # A goal beyond "?" hallways has no shortest path on the given map; on the learned one (the executor's
    # last feedback over DDS) it has, as the in-process runner measures it.
    text = PAPER_NODES + '  x: {position: [8.0, 24.0], S: {node: "?", tags: [99]}}\n'
    path = write_map(tmp_path, text)
    feedback = SimpleNamespace(learned_hallways=["d.N -> x.S"])
    with pytest.raises(RouteError):
        topological_shortest_m(load_topological_map(path), (8.0, 6.0), "c", "S", "x")
    learned = learned_map(path, feedback)
    assert topological_shortest_m(learned, (8.0, 6.0), "c", "S", "x") == pytest.approx(2.0 + 16.0)
    assert learned_map(path, SimpleNamespace()).nodes["d"].hallways["N"].neighbour == UNKNOWN   # an older bag


def test_hallway_length_from_length_positions_or_one_metre(paper_map: TopologicalMap) -> None:
    assert paper_map.hallway_length_m("c", "N") == pytest.approx(8.0)           # from the positions
    no_positions = TopologicalMap("bare", {"p": Node("p", {"E": Hallway("q", ("1",))}),
                                           "q": Node("q", {"W": Hallway("p", ("2",))})})
    assert no_positions.hallway_length_m("p", "E") == 1.0


def test_unknown_hallways_are_not_routable(paper_map: TopologicalMap) -> None:
    assert paper_map.route("a", "e") == ["a", "c", "d", "e"]
    lone = TopologicalMap("lone", {"p": Node("p", {"N": Hallway(UNKNOWN, ("1",))}),
                                   "q": Node("q", {"S": Hallway(UNKNOWN, ("2",))})})
    with pytest.raises(RouteError, match="no route from 'p' to 'q'"):
        lone.route("p", "q")


def test_route_errors_name_the_node(paper_map: TopologicalMap) -> None:
    with pytest.raises(ValueError, match="unknown node 'zz'"):
        paper_map.route("a", "zz")
    with pytest.raises(RfidnavError, match="unknown node 'yy'"):
        paper_map.route("yy", "a")
    with pytest.raises(ValueError, match="weight"):
        paper_map.route("a", "d", weight="time")


# ---------------------------------------------------------------- turns

# (arrival side, departure direction) -> turn. Arriving from the North the robot heads South: leaving South is
# straight on, West is to its right, East to its left, North back where it came from.
TURNS = {
    ("N", "N"): "back", ("N", "E"): "left", ("N", "S"): "straight", ("N", "W"): "right",
    ("E", "N"): "right", ("E", "E"): "back", ("E", "S"): "left", ("E", "W"): "straight",
    ("S", "N"): "straight", ("S", "E"): "right", ("S", "S"): "back", ("S", "W"): "left",
    ("W", "N"): "left", ("W", "E"): "straight", ("W", "S"): "right", ("W", "W"): "back",
}


def test_side_openings_are_what_a_wall_follower_can_sense(paper_map: TopologicalMap) -> None:
    # c has hallways on all four sides; h only to the West: entered from there, it has no side opening.
    assert all(paper_map.has_side_opening("c", side) for side in DIRECTIONS)
    assert not paper_map.has_side_opening("h", "W")
    assert paper_map.tag_to_node_m == 0.0                     # by default the robot stops at the goal's tag


def test_turn_table_covers_every_pair() -> None:
    assert set(TURNS) == {(a, d) for a in DIRECTIONS for d in DIRECTIONS}


@pytest.mark.parametrize("arrival, departure", sorted(TURNS))
def test_turn(arrival: str, departure: str) -> None:
    assert turn(arrival, departure) == TURNS[(arrival, departure)]


def test_turn_rejects_a_non_direction() -> None:
    with pytest.raises(ValueError, match="'NE'"):
        turn("NE", "N")


def test_paper_turn_example(paper_map: TopologicalMap) -> None:
    # Section 3: tag 9 -> at c from the East; the next sub-goal d is North of c: turn right, leave North.
    assert turn("E", "N") == "right"
    assert next_action(paper_map, "9", "d") == NextAction("right", "N", "c")
    assert next_action(paper_map, "9", "a") == NextAction("straight", "W", "c")
    assert next_action(paper_map, "9", "h") == NextAction("back", "E", "c")


def test_next_action_stops_at_the_goal(paper_map: TopologicalMap) -> None:
    assert next_action(paper_map, "11", "d") == NextAction("stop", None, "d")
    assert next_action(paper_map, 12, "d") == NextAction("stop", None, "d")


def test_next_action_unknown_tag(paper_map: TopologicalMap) -> None:
    with pytest.raises(RouteError, match="tag '99'"):
        next_action(paper_map, "99", "d")


# ---------------------------------------------------------------- drawing

def png_size(path: Path) -> tuple[int, int]:
    header = path.read_bytes()[:24]
    assert header[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", header[16:24])


def test_draw_map_writes_a_png(paper_map: TopologicalMap, tmp_path: Path) -> None:
    path = tmp_path / "map.png"
    draw_map(paper_map, path)
    width, height = png_size(path)
    assert width >= 800 and height >= 600
    assert path.stat().st_size > 20_000              # more than an empty canvas


def test_draw_map_without_positions(tmp_path: Path) -> None:
    path = tmp_path / "detour.png"
    draw_map(load_topological_map(write_map(tmp_path, DETOUR)), path)
    assert png_size(path)[0] >= 800
    assert path.stat().st_size > 20_000


def test_draw_map_where_compass_steps_stack_nodes(tmp_path: Path) -> None:
    # One step per hallway puts s (p, N, E, S) and t (p, E) on one spot: the spring layout takes over.
    stacked = load_topological_map(write_map(tmp_path, """\
        name: stacked
        nodes:
          p: {N: {node: q, tags: [1]}, E: {node: t, tags: [2]}}
          q: {S: {node: p, tags: [3]}, E: {node: r, tags: [4]}}
          r: {W: {node: q, tags: [5]}, S: {node: s, tags: [6]}}
          s: {N: {node: r, tags: [7]}}
          t: {W: {node: p, tags: [8]}}
        """))
    path = tmp_path / "stacked.png"
    draw_map(stacked, path)
    assert path.stat().st_size > 20_000


# ---------------------------------------------------------------- the maps in config/maps

def test_fig5_map_is_clean_and_replays_the_papers_examples() -> None:
    path = MAPS / "building_fig5.yaml"
    assert check_map(path) == []
    fig5 = load_topological_map(path)
    assert sorted(fig5.nodes) == list("abcdefgh")
    c = fig5.nodes["c"].hallways
    assert {side: (c[side].neighbour, c[side].tags) for side in c} == {
        "N": ("d", ("8",)), "E": ("h", ("9",)), "S": ("b", ("10",)), "W": ("a", ("7",))}
    d = fig5.nodes["d"].hallways
    assert {side: (d[side].neighbour, d[side].tags) for side in d} == {
        "N": ("?", ("12",)), "E": ("e", ("13",)), "S": ("c", ("11",))}
    assert next_action(fig5, "9", "d") == NextAction("right", "N", "c")
    # Section 5: from tag 23 a right turn, about 8 m of hallway, then tag 19.
    action = next_action(fig5, "23", "g")
    assert action.action == "right"
    assert fig5.nodes[action.node].hallways[action.direction].neighbour == "g"
    assert fig5.locate_tag("19")[0] == "g"
    assert fig5.hallway_length_m(action.node, action.direction) == pytest.approx(8.0)


def test_large_map_is_clean_and_big_enough() -> None:
    path = MAPS / "building_large.yaml"
    assert check_map(path) == []
    large = load_topological_map(path)
    graph = nx.Graph((edge.node_a, edge.node_b) for edge in large.edges())
    assert len(large.nodes) >= 20
    assert len(nx.cycle_basis(graph)) >= 3
    assert all(node.position is not None for node in large.nodes.values())
    assert all(hallway.length_m is not None for node in large.nodes.values() for hallway in node.hallways.values()
               if hallway.neighbour != UNKNOWN)
    assert large.route("A1", "E5", weight="length")[-1] == "E5"


@pytest.mark.tier("graph")
def test_the_map_verbs_check_and_draw_with_exit_codes(tmp_path: Path) -> None:
    import subprocess
    import sys

    workspace = Path(__file__).resolve().parents[1]

    def cli(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "rfidnav_bringup.cli", "map", *args], capture_output=True,
                              text=True, cwd=workspace, timeout=120)

    good = cli("check", str(workspace / "config/maps/building_fig5.yaml"))
    assert good.returncode == 0 and "no problems" in good.stdout
    broken = tmp_path / "broken.yaml"
    broken.write_text("name: x\nnodes:\n  a: {N: {node: b, tags: [1]}}\n  b: {S: {node: c, tags: [1]}}\n")
    bad = cli("check", str(broken))
    assert bad.returncode == 2
    assert len(bad.stderr.strip().splitlines()) == 3 and "duplicate tag '1'" in bad.stderr
    # The evaluation floor was drawn by hand (B - F runs 20 degrees off South): the generator could not build it,
    # so map check refuses it, and checks it by the map's own rules with --robot-only.
    drawn_by_hand = str(workspace / "config/maps/building_eval.yaml")
    generator_rules = cli("check", drawn_by_hand)
    assert generator_rules.returncode == 2
    assert generator_rules.stderr.splitlines() == [f"{drawn_by_hand}: nodes.B.S.node: the far node is +2.736 m off "
                                                   "the S line; the world generator runs hallways straight along "
                                                   "their compass direction"]
    assert cli("check", "--robot-only", drawn_by_hand).returncode == 0
    png = tmp_path / "fig5.png"
    drawn = cli("draw", str(workspace / "config/maps/building_fig5.yaml"), "--out", str(png))
    assert drawn.returncode == 0 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert cli("draw", str(broken)).returncode == 2
