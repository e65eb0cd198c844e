"""The mission executor of paper 004 (sections 3-5): turns from tag reads, missed tags, re-plans, ? hallways."""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest

from rfidnav_common.topological_map import (
    DIRECTIONS,
    UNKNOWN,
    Hallway,
    Node,
    RouteError,
    TopologicalMap,
    load_topological_map,
    opposite,
)
from rfidnav_planning.mission_executor import (
    BACK,
    FOLLOW,
    JUNCTION_CENTRE,
    LEFT,
    NO_OPENING,
    OBSTACLE,
    RIGHT,
    STOP,
    STRAIGHT,
    TURN_DONE,
    TURNS,
    Decision,
    FollowerCommand,
    LearnedEdge,
    MissionExecutor,
)

pytestmark = pytest.mark.tier("unit")

MAPS = Path(__file__).resolve().parents[1] / "config" / "maps"
_QUARTER_TURNS = {STRAIGHT: 0, RIGHT: 1, BACK: 2, LEFT: 3}


@pytest.fixture(scope="module")
def fig5() -> TopologicalMap:
    return load_topological_map(MAPS / "building_fig5.yaml")


@pytest.fixture(scope="module")
def large() -> TopologicalMap:
    return load_topological_map(MAPS / "building_large.yaml")


class Floor:
    """The real floor, replaying what the wall follower and the reader would report: the robot approaches
    ``node`` from ``side``, passes the tag announcing it (unless ``drop`` says the read failed), reaches the
    junction's centre and leaves by the commanded way (straight on without a command), or U-turns at once on
    ``back``. A node with no side opening gives no junction event: the robot passes straight through."""

    def __init__(self, floor: TopologicalMap, node: str, side: str,
                 drop: Callable[[str], bool] = lambda tag: False) -> None:
        self.floor, self.node, self.side, self.drop = floor, node, side, drop
        self.command: str | None = None
        self.tags_read: list[str] = []

    def run(self, executor: MissionExecutor, goal: str, max_junctions: int = 200) -> Decision:
        decision = executor.start(goal)
        for _ in range(max_junctions):
            tag = self.floor.nodes[self.node].hallways[self.side].tags[0]
            if not self.drop(tag):
                self.tags_read.append(tag)
                decision = self.obey(executor.on_tag(tag))
                if decision.finished:
                    return decision
                if self.command == BACK:
                    self.leave(self.side)
                    self.obey(executor.on_junction(TURN_DONE))
                    continue
            if not self.floor.has_side_opening(self.node, self.side):
                if opposite(self.side) in self.floor.nodes[self.node].hallways:
                    self.leave(opposite(self.side))
                    continue
                decision = self.obey(executor.on_junction(OBSTACLE))        # the dead end's wall ahead
                if decision.finished:
                    return decision
                self.leave(self.side)                                        # the follower turns away
                continue
            decision = self.obey(executor.on_junction(JUNCTION_CENTRE))
            if decision.finished:
                return decision
            while True:
                heading = DIRECTIONS.index(opposite(self.side))
                departure = DIRECTIONS[(heading + _QUARTER_TURNS[self.command or STRAIGHT]) % 4]
                if departure in self.floor.nodes[self.node].hallways:
                    break
                decision = self.obey(executor.on_junction(NO_OPENING))
            self.leave(departure)
            self.obey(executor.on_junction(TURN_DONE))
        raise AssertionError(f"no arrival after {max_junctions} junctions")

    def obey(self, decision: Decision) -> Decision:
        if decision.action in TURNS:
            self.command = decision.action
        return decision

    def leave(self, departure: str) -> None:
        neighbour = self.floor.nodes[self.node].hallways[departure].neighbour
        assert neighbour != UNKNOWN, f"the robot left the floor at {self.node}.{departure}"
        self.node, self.side, self.command = neighbour, opposite(departure), None


def test_the_papers_run_from_tag_23_to_tag_19(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    assert executor.start("g").action == FOLLOW
    assert executor.on_tag(23).action == RIGHT                  # at h from the West, leaving South
    assert executor.state.expected_node == "g" and executor.state.expected_side == "N"
    assert executor.on_junction(JUNCTION_CENTRE).action == RIGHT
    assert executor.on_junction(TURN_DONE).action == FOLLOW
    done = executor.on_tag("19")
    assert (done.action, done.finished, done.success) == (STOP, True, True)
    assert executor.state.nodes_visited == ["h", "g"]
    assert executor.state.last_tag == "19" and executor.state.current_node == "g"
    assert executor.state.arrival_side == "N" and executor.state.replans == 0


def test_the_papers_example_tag_9_at_c_from_the_east_to_d_is_a_right_turn(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("d")
    decision = executor.on_tag(9)
    assert decision.action == RIGHT and not decision.finished
    assert (executor.state.current_node, executor.state.arrival_side) == ("c", "E")
    assert (executor.state.expected_node, executor.state.expected_side) == ("d", "S")


@pytest.mark.parametrize("tags, goal, actions, visited", [
    (["1", "7", "23", "17"], "f", [BACK, STRAIGHT, STRAIGHT, STOP], ["a", "c", "h", "f"]),
    (["20", "25", "17"], "f", [LEFT, RIGHT, STOP], ["g", "h", "f"]),
    (["13", "8", "1"], "a", [LEFT, RIGHT, STOP], ["d", "c", "a"]),
])
def test_every_action_of_a_scripted_route(fig5: TopologicalMap, tags: list[str], goal: str, actions: list[str],
                                          visited: list[str]) -> None:
    executor = MissionExecutor(fig5)
    executor.start(goal)
    for tag, action in zip(tags, actions):
        decision = executor.on_tag(tag)
        assert decision.action == action, (tag, decision.message)
        if action in (LEFT, RIGHT, STRAIGHT):
            assert executor.on_tag(tag) == Decision(action)                      # a re-read changes nothing
            assert executor.on_junction(JUNCTION_CENTRE).action == action       # made at the junction ahead
        executor.on_junction(TURN_DONE)
    assert decision.finished and decision.success
    assert executor.state.nodes_visited == visited
    assert executor.state.tags_missed == executor.state.replans == 0


def test_the_floor_replay_agrees_with_the_script(fig5: TopologicalMap) -> None:
    floor = Floor(fig5, "a", "E")
    assert floor.run(MissionExecutor(fig5), "f").success
    assert floor.tags_read == ["1", "7", "23", "17"]


def test_an_unknown_tag_is_ignored(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    assert executor.on_tag("999").action == FOLLOW                # not localized yet
    assert executor.on_tag(23).action == RIGHT
    assert executor.on_tag("998").action == RIGHT                 # the turn ahead still stands
    assert executor.state.unknown_tags == 2 and executor.state.last_tag == "23"
    assert executor.on_junction(JUNCTION_CENTRE).action == RIGHT
    assert executor.on_tag(19).success


def test_a_junction_before_any_tag_is_followed_through(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    assert executor.on_junction(JUNCTION_CENTRE).action == FOLLOW
    assert executor.state.tags_missed == 0 and executor.state.current_node is None


def test_a_missed_tag_keeps_the_routes_expectation(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("f")
    assert executor.on_tag(20).action == LEFT                     # g from the West, leaving North for h
    assert executor.on_junction(JUNCTION_CENTRE).action == LEFT
    executor.on_junction(TURN_DONE)
    # tag 25 (h from the South) is not read: the junction centre comes without it
    assumed = executor.on_junction(JUNCTION_CENTRE)
    assert assumed.action == RIGHT and "missed" in assumed.message
    assert executor.state.tags_missed == 1
    assert (executor.state.current_node, executor.state.arrival_side) == ("h", "S")
    assert (executor.state.expected_node, executor.state.expected_side) == ("f", "W")
    executor.on_junction(TURN_DONE)
    done = executor.on_tag(17)                                    # the next tag confirms the assumption
    assert done.success and executor.state.replans == 0
    assert executor.state.nodes_visited == ["g", "h", "f"]


def test_with_odometry_a_junction_well_short_of_the_expected_node_is_an_opening_not_on_the_map(
        fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("f")
    executor.on_odometry(0.0, 0.0)
    assert executor.on_tag(20).action == LEFT                     # 2 m before g; h is 2 + 8 m on
    executor.on_odometry(2.0, 0.0)
    assert executor.on_junction(JUNCTION_CENTRE).action == LEFT   # g's centre: the turn the tag decided
    executor.on_junction(TURN_DONE)
    executor.on_odometry(2.0, 3.0)                                # 5 m of the 10: a door on the left
    door = executor.on_junction(JUNCTION_CENTRE)
    assert door.action == FOLLOW and "opening not on the map" in door.message
    assert executor.state.tags_missed == 0 and executor.state.expected_node == "h"
    executor.on_odometry(2.0, 7.2)                                # 9.2 m: within the 1 m margin of h
    assumed = executor.on_junction(JUNCTION_CENTRE)
    assert assumed.action == RIGHT and "missed" in assumed.message
    assert executor.state.tags_missed == 1


def test_without_odometry_every_junction_may_be_the_expected_node(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("f")
    executor.on_tag(20)
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_junction(TURN_DONE)
    assert "missed" in executor.on_junction(JUNCTION_CENTRE).message


def test_a_missed_goal_tag_stops_at_the_goal_junction(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    executor.on_tag(23)
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_junction(TURN_DONE)
    done = executor.on_junction(JUNCTION_CENTRE)
    assert (done.action, done.success, executor.state.tags_missed) == (STOP, True, 1)
    assert executor.on_tag(19) == done and executor.on_junction(JUNCTION_CENTRE) == done    # finished stays


def test_a_wrong_node_counts_a_replan_and_still_reaches_the_goal(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    assert executor.on_tag(23).action == RIGHT
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_junction(TURN_DONE)
    # the robot went straight on instead and reads f's tag from the West: off the route
    assert executor.on_tag(17).action == BACK                     # back to h
    assert executor.state.replans == 1
    assert (executor.state.expected_node, executor.state.expected_side) == ("h", "E")
    executor.on_junction(TURN_DONE)
    assert executor.on_tag(24).action == LEFT                     # h from the East, leaving South
    executor.on_junction(JUNCTION_CENTRE)
    assert executor.on_tag(19).success
    assert executor.state.replans == 1 and executor.state.nodes_visited == ["h", "f", "h", "g"]


def test_a_wrong_assumption_after_a_missed_tag_is_corrected_by_the_next_tag(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("f")
    executor.on_tag(20)                                            # g from the West: left, for h
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_junction(TURN_DONE)
    executor.on_junction(JUNCTION_CENTRE)                          # assumed h (from the South): right, for f
    executor.on_junction(TURN_DONE)
    assert executor.on_tag(14).action == RIGHT                     # really at e from the West: re-localized
    assert executor.state.replans == 1 and executor.state.tags_missed == 1


def test_no_opening_takes_the_junction_for_one_off_the_map(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    executor.on_tag(23)
    assert executor.on_junction(JUNCTION_CENTRE).action == RIGHT
    assert executor.on_junction(NO_OPENING).action == STRAIGHT     # a doorway before h: the right turn waits
    assert executor.on_junction(JUNCTION_CENTRE).action == RIGHT   # h itself
    assert executor.on_junction(NO_OPENING).action == STRAIGHT
    assert executor.on_junction(NO_OPENING).action == BACK         # blocked straight on too: lost
    assert executor.state.replans == 3 and executor.state.expected_node is None
    assert executor.on_junction(JUNCTION_CENTRE).action == FOLLOW
    assert executor.on_tag(24).action == LEFT                      # the next tag re-localizes
    assert executor.on_tag(19).success


# The true floor: a -- b along the bottom, c -- d above, and a hallway a.N -- c.S joining them.
TRUE_FLOOR = """\
name: explore
nodes:
  a:
    E: {node: b, tags: [1]}
    N: {node: c, tags: [2]}
  b:
    W: {node: a, tags: [3]}
  c:
    S: {node: a, tags: [4]}
    E: {node: d, tags: [5]}
  d:
    W: {node: c, tags: [6]}
"""


def forget(floor: TopologicalMap, node: str, side: str) -> TopologicalMap:
    """The floor with one hallway unmapped at both ends (``?``). Built in code: a checked map file has every
    node connected through mapped hallways, so no goal in it ever needs a ``?`` hallway."""
    far_end, far_side = floor.nodes[node].hallways[side].neighbour, opposite(side)
    nodes = dict(floor.nodes)
    for name, name_side in ((node, side), (far_end, far_side)):
        hallways = dict(nodes[name].hallways)
        hallways[name_side] = replace(hallways[name_side], neighbour=UNKNOWN)
        nodes[name] = replace(nodes[name], hallways=hallways)
    return TopologicalMap(floor.name, nodes, floor.north_deg)


@pytest.fixture
def true_floor(tmp_path: Path) -> TopologicalMap:
    path = tmp_path / "explore.yaml"
    path.write_text(TRUE_FLOOR)
    return load_topological_map(path)


def test_a_question_mark_hallway_is_explored_and_learned(true_floor: TopologicalMap) -> None:
    known = forget(true_floor, "a", "N")
    with pytest.raises(RouteError):
        known.route("a", "d")
    executor = MissionExecutor(known)
    executor.start("d")
    assert executor.on_tag(1).action == RIGHT                      # a from the East: into its ? side (North)
    assert executor.state.expected_node is None
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_junction(TURN_DONE)
    assert executor.on_tag(4).action == RIGHT                      # c from the South: learned, then East for d
    assert executor.state.learned_edges == (LearnedEdge("a", "N", "c", "S"),)
    assert executor.map.route("a", "d") == ["a", "c", "d"]
    assert known.nodes["a"].hallways["N"].neighbour == UNKNOWN     # the given map is not changed
    executor.on_junction(JUNCTION_CENTRE)
    assert executor.on_tag(6).success
    assert executor.state.nodes_visited == ["a", "c", "d"]

    executor.start("a")                                            # the next mission routes through it
    assert executor.on_tag(5).action == LEFT                       # c from the East: left, South for a
    assert executor.state.expected_node == "a" and executor.state.expected_side == "N"
    assert executor.state.learned_edges == executor.learned


def test_a_question_mark_hallway_is_found_from_afar_on_the_true_floor(true_floor: TopologicalMap) -> None:
    executor = MissionExecutor(forget(true_floor, "a", "N"))
    floor = Floor(true_floor, "b", "W")                            # at b from the West, away from the ? side
    assert floor.run(executor, "d").success
    assert floor.tags_read == ["3", "1", "4", "6"]
    assert executor.state.nodes_visited == ["b", "a", "c", "d"]
    assert executor.learned == (LearnedEdge("a", "N", "c", "S"),)


def test_an_explored_hallway_whose_far_end_tag_is_missed_is_tried_again(true_floor: TopologicalMap) -> None:
    executor = MissionExecutor(forget(true_floor, "a", "N"))
    reads = {"4": 0}

    def drop(tag: str) -> bool:                  # tag 4 (c from the South) fails the first time only
        reads[tag] = reads.get(tag, 0) + 1
        return tag == "4" and reads[tag] == 1

    floor = Floor(true_floor, "a", "E", drop)
    assert floor.run(executor, "d").success
    # lost at c: straight on and then back are blocked or taken, the robot returns to a and reads tag 2;
    # the hallway north is still unexplored, so it turns back into it and reads tag 4 this time
    assert floor.tags_read == ["1", "2", "4", "6"]
    assert executor.learned == (LearnedEdge("a", "N", "c", "S"),)
    assert executor.state.replans == 2                              # the two no_opening at c


def test_a_far_end_mapped_otherwise_is_not_learned(true_floor: TopologicalMap) -> None:
    # Only a.N is unmapped in the robot's map; its far end c.S is mapped (to b, wrongly): nothing to learn.
    known = forget(true_floor, "a", "N")
    nodes = dict(known.nodes)
    nodes["c"] = replace(nodes["c"], hallways={**nodes["c"].hallways,
                                               "S": replace(nodes["c"].hallways["S"], neighbour="b")})
    executor = MissionExecutor(TopologicalMap("wrong", nodes))
    executor.start("d")
    assert executor.on_tag(1).action == RIGHT                       # into the ? hallway north
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_tag(4)
    assert executor.learned == () and executor.explored == {("a", "N")}


def test_a_question_mark_hallway_that_is_a_dead_end_is_recorded_as_one_not_as_a_hallway_to_itself(
        true_floor: TopologicalMap) -> None:
    executor = MissionExecutor(forget(true_floor, "a", "N"))
    executor.start("d")
    assert executor.on_tag(1).action == RIGHT                       # into a's ? hallway north
    executor.on_junction(JUNCTION_CENTRE)
    executor.on_junction(TURN_DONE)
    executor.on_junction(OBSTACLE)                                  # its end wall: the follower turns back
    back_at_a = executor.on_tag(2)                                  # a, arriving from that ? side
    assert executor.dead_ends == executor.state.dead_ends == (("a", "N"),)
    assert executor.learned == () and executor.explored == {("a", "N")}
    assert executor.map.nodes["a"].hallways["N"].neighbour == UNKNOWN
    # No ? hallway left to try from a (c's lies beyond the one just found closed): an honest failure.
    assert (back_at_a.action, back_at_a.finished, back_at_a.success) == (STOP, True, False)
    assert executor.state.nodes_visited == ["a", "a"]


def test_a_goal_beyond_the_map_without_question_marks_fails() -> None:
    # Built directly (the map check would refuse a floor whose nodes are not all connected).
    split = TopologicalMap("split", {"a": Node("a", {"E": Hallway("b", ("1",))}),
                                     "b": Node("b", {"W": Hallway("a", ("2",))}),
                                     "c": Node("c", {})})
    executor = MissionExecutor(split)
    executor.start("c")
    failed = executor.on_tag(2)
    assert (failed.action, failed.finished, failed.success) == (STOP, True, False)
    assert "no mapped route" in failed.message


def test_bad_goals_events_and_weights_are_refused(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    with pytest.raises(RouteError):
        executor.start("nowhere")
    with pytest.raises(RuntimeError):
        executor.on_tag(1)
    executor.start("g")
    with pytest.raises(ValueError):
        executor.on_junction("teleported")
    with pytest.raises(ValueError):
        MissionExecutor(fig5, weight="time")


def assert_shortest(floor: TopologicalMap, visited: list[str], start: str, goal: str) -> None:
    """``visited`` is a route from start to goal along hallways, as short as the map's (ties may differ)."""
    assert visited[0] == start and visited[-1] == goal
    assert len(visited) == len(floor.route(start, goal)), " ".join(visited)
    for here, there in zip(visited, visited[1:]):
        floor.departure_direction(here, there)                     # RouteError if not adjacent


def _random_missions(large: TopologicalMap, seed: int) -> list[tuple[str, str, str, str]]:
    rng = random.Random(seed)
    starts = [(tag, node.name, side) for node in large.nodes.values() for side, hallway in node.hallways.items()
              if hallway.neighbour != UNKNOWN for tag in hallway.tags]
    missions = []
    while len(missions) < 100:
        tag, node, side = rng.choice(starts)
        goal = rng.choice(list(large.nodes))
        if goal != node:
            missions.append((tag, node, side, goal))
    return missions


def test_a_perfect_oracle_reaches_every_goal_by_the_shortest_route(large: TopologicalMap) -> None:
    for tag, node, side, goal in _random_missions(large, seed=4):
        executor = MissionExecutor(large)
        floor = Floor(large, node, side)
        assert floor.run(executor, goal).success, (tag, goal)
        assert_shortest(large, executor.state.nodes_visited, node, goal)
        assert executor.state.tags_missed == executor.state.replans == 0


def test_a_fifth_of_the_tags_dropped_still_reaches_every_goal(large: TopologicalMap) -> None:
    rng = random.Random(7)
    missed = overshoots = 0
    for tag, node, side, goal in _random_missions(large, seed=5):
        executor = MissionExecutor(large)
        first = True

        def drop(read: str) -> bool:
            nonlocal first
            if first:                       # the start tag is read: the robot must localize somewhere
                first = False
                return False
            return rng.random() < 0.2

        floor = Floor(large, node, side, drop)
        assert floor.run(executor, goal).success, (tag, goal)
        visited = executor.state.nodes_visited
        while len(visited) > 2 and visited[-3] == visited[-1] == goal:
            # A goal with no junction to sense, its tag missed: driven past to the next junction and back.
            assert not large.has_side_opening(goal, executor.state.arrival_side)
            visited, overshoots = visited[:-2], overshoots + 1
        assert_shortest(large, visited, node, goal)
        assert executor.state.replans == 0
        missed += executor.state.tags_missed
    assert missed > 20 and overshoots > 0


# ------------------------------------------------ nodes without a junction to sense (building_large: B1, E3)

def test_a_node_without_side_openings_is_passed_straight_through(large: TopologicalMap) -> None:
    executor = MissionExecutor(large)
    executor.start("C1")
    assert executor.on_tag(103).action == STRAIGHT             # at A1 from the West, leaving East
    # B1 (hallways East and West only) gives no junction event: the route's expectation is C1 beyond it.
    assert (executor.state.expected_node, executor.state.expected_side) == ("C1", "W")
    assert executor.on_junction(JUNCTION_CENTRE).action == STRAIGHT
    passing = executor.on_tag(105)                             # B1's tag: straight on is following, no command
    assert passing.action == FOLLOW and "no junction to sense" in passing.message
    done = executor.on_tag(107)
    assert (done.action, done.success, done.drive_on_m) == (STOP, True, 2.0 * large.tag_to_node_m)
    assert executor.state.nodes_visited == ["A1", "B1", "C1"] and executor.state.replans == 0


def leaving_a1_eastwards(large: TopologicalMap, goal: str) -> MissionExecutor:
    """A mission to ``goal`` whose robot read A1's tag 103 (arriving from the West) and crossed A1 straight on."""
    executor = MissionExecutor(large)
    executor.start(goal)
    executor.on_tag(103)
    executor.on_junction(JUNCTION_CENTRE)
    return executor


def test_a_missed_tag_of_a_node_passed_through_loses_nothing(large: TopologicalMap) -> None:
    executor = leaving_a1_eastwards(large, "C1")
    assert executor.on_tag(107).success                        # B1's tag 105 missed
    assert executor.state.nodes_visited == ["A1", "B1", "C1"] and executor.state.replans == 0


def test_a_goal_without_a_junction_whose_tag_is_missed_is_driven_past_and_back_to(large: TopologicalMap) -> None:
    executor = leaving_a1_eastwards(large, "B1")
    back = executor.on_junction(JUNCTION_CENTRE)               # B1's tag missed: this junction is C1, beyond it
    assert back.action == BACK and executor.state.current_node == "C1"
    assert executor.state.tags_missed == 1
    done = executor.on_tag(104)                                # B1 from the East, on the way back
    assert (done.action, done.success, done.drive_on_m) == (STOP, True, large.tag_to_node_m)
    assert executor.state.nodes_visited == ["A1", "B1", "C1", "B1"] and executor.state.replans == 0


def test_a_dead_end_goal_whose_tag_is_missed_is_reached_at_its_wall(large: TopologicalMap) -> None:
    executor = MissionExecutor(large)
    executor.start("E3")
    assert executor.on_tag(124).action == STRAIGHT             # at E2 from the South, leaving North for E3
    assert executor.on_junction(OBSTACLE).action == FOLLOW     # an obstacle before E2's junction: nothing new
    assert executor.state.awaiting == STRAIGHT
    executor.on_junction(JUNCTION_CENTRE)
    done = executor.on_junction(OBSTACLE)                      # E3's tag 138 missed: the dead end's wall
    assert (done.action, done.success, done.drive_on_m) == (STOP, True, 0.0)
    assert executor.state.nodes_visited == ["E2", "E3"] and executor.state.tags_missed == 1


def test_a_dead_end_goal_whose_tag_is_missed_stops_where_the_odometry_says_it_is(large: TopologicalMap) -> None:
    executor = MissionExecutor(large)
    executor.start("E3")
    executor.on_odometry(0.0, 0.0)
    assert executor.on_tag(124).action == STRAIGHT             # at E2 from the South, leaving North for E3
    to_e3 = large.tag_to_node_m + large.hallway_length_m("E2", "N")
    executor.on_junction(JUNCTION_CENTRE)
    for step in range(1, 200):                                 # E3's tag 138 missed: driving on, 10 cm a step
        driven = step * 0.1
        decision = executor.on_odometry(driven, 0.0)
        if decision is not None:
            break
    assert driven == pytest.approx(to_e3, abs=0.1 + 1e-9)      # not before the map's distance, nor after it
    assert (decision.action, decision.success, decision.drive_on_m) == (STOP, True, 0.0)
    assert executor.follower_command(decision) == FollowerCommand(STOP, 0.0)
    assert executor.state.nodes_visited == ["E2", "E3"] and executor.state.tags_missed == 1
    assert executor.on_odometry(driven + 0.1, 0.0) is None     # decided once


def test_the_odometry_decides_nothing_on_the_way_to_a_goal_with_a_junction(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    executor.on_odometry(0.0, 0.0)
    executor.on_tag(23)                                        # h from the West, right for g: g has a junction
    assert all(executor.on_odometry(step * 0.5, 0.0) is None for step in range(1, 100))
    assert executor.state.outcome is None


def test_after_a_u_turn_at_a_tag_the_next_junction_is_expected_nearer_not_farther() -> None:
    # At F's tag (arriving from D, 2 m before the dead end) the way to A is back East: D lies 8 - 2 m ahead.
    ring = load_topological_map(MAPS / "building_ring.yaml")
    executor = MissionExecutor(ring)
    executor.start("A")
    executor.on_odometry(0.0, 0.0)
    assert executor.on_tag(15).action == BACK
    assert executor.state.leg_expected_m == pytest.approx(ring.hallway_length_m("F", "E") - ring.tag_to_node_m)
    executor.on_junction(TURN_DONE)
    executor.on_odometry(6.0, 0.0)
    at_d = executor.on_junction(JUNCTION_CENTRE)                   # D's tag 14 missed: this junction is D
    assert at_d.action == RIGHT and executor.state.current_node == "D" and executor.state.tags_missed == 1


def test_another_tag_of_the_same_side_is_the_same_read_not_another_u_turn() -> None:
    ring = load_topological_map(MAPS / "building_ring.yaml")       # C's West side carries tags 9 and 10
    executor = MissionExecutor(ring)
    executor.start("D")
    (back,) = executor.on_reads(["9"])                             # C from the West: D lies back West
    assert executor.follower_command(back) == FollowerCommand(BACK)
    turning = executor.on_reads(["10", "9", "10"])                 # both tags read on and off while turning
    assert [executor.follower_command(decision) for decision in turning] == [None, None, None]
    assert executor.state.nodes_visited == ["C"] and executor.state.last_tag == "9"


def test_reads_are_new_only_when_the_tag_changes_and_a_stop_is_commanded_once(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5)
    executor.start("g")
    first = executor.on_reads(["23", "23"])                    # one round reporting tag 23 twice
    assert [d.action for d in first] == [RIGHT] and executor.on_reads(["23"]) == []
    assert executor.follower_command(first[0]) == FollowerCommand(RIGHT)
    at_h = executor.on_junction(JUNCTION_CENTRE)
    assert at_h.action == RIGHT and executor.follower_command(at_h) is None   # the follower has it from the tag
    assert executor.follower_command(executor.on_junction(TURN_DONE)) is None       # follow: nothing to command
    (done,) = executor.on_reads([19])
    assert executor.follower_command(done) == FollowerCommand(STOP, fig5.tag_to_node_m * 2.0)
    assert executor.on_junction(JUNCTION_CENTRE) == done       # the outcome stands, and is not commanded again
    assert executor.follower_command(done) is None


def test_the_papers_loop_follows_on_past_a_missed_tag_until_the_next_one(fig5: TopologicalMap) -> None:
    executor = MissionExecutor(fig5, recover_missed_tags=False)
    executor.start("f")
    assert executor.on_tag("7").action == STRAIGHT             # at c from the West, leaving East for h
    executor.on_junction(JUNCTION_CENTRE)
    passed = executor.on_junction(JUNCTION_CENTRE)             # h's tag 23 missed: the baseline cannot know it
    assert passed.action == FOLLOW and executor.state.tags_missed == 0
    assert executor.state.nodes_visited == ["c"]
    assert executor.on_tag("17").success                       # f's tag, read: it still arrives
