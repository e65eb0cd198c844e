"""Mission execution on the topological map of paper 004 (sections 3-5), as a decision core without ROS.

The robot follows the left wall (rfidnav_control.wall_following) and reads the tags on it. The executor is fed
those reads and the wall follower's events and answers what to command: a turn (``left``, ``right``,
``straight``, ``back``) for ``WallFollower.command_turn``, ``follow`` (no command: keep following the wall, and
drive straight on at a junction), or ``stop``. The mission_executor node turns the answers into commands and
the NavigateToNode action's feedback and result; the tests script the reads and events. Both run this code.

The paper's loop (section 3): a tag names the node being approached and the side the robot arrives from; the
route from there to the goal names the side to leave by; arrival and departure give the turn (arriving at c
from the East and leaving North is a right turn). The tag is read just before the junction, so the turn it
decides is queued and made at the junction's centre; a ``back`` is a U-turn made at once, in the hallway.
Reading the goal's tag stops the robot. Until the first tag the robot does not know where it is and follows.

Beyond the paper, the stop (ours): the paper stops where the goal's tag is read, ~2 m before the junction. The
``stop`` decision carries ``drive_on_m``: the wall follower drives on to the junction's centre, which it senses,
but at most twice the map's ``tag_to_node_m``; a goal with no side opening has no centre to sense, and the robot
drives ``tag_to_node_m`` on. Such a node (hallways only behind and ahead) is passed without a junction event
anywhere else too: going straight through it is ``follow``, and an expectation skips over it (below).

Beyond the paper (ours):

* A missed tag. Every decision leaves an expectation: the next node and the side the robot arrives from.
  A junction centre reached with no decision waiting for it means the tag announcing that junction was not
  read; the executor then ASSUMES the robot is at the expected node, arriving from the expected side, and
  decides there as if the tag had been read (stopping if it is the goal). The assumption holds as long as
  hallways have no untagged junctions the map does not know; the next tag read re-localizes the robot and,
  if the assumption was wrong, counts a re-plan and plans from where the robot really is. Without an
  expectation (before the first tag, or after being lost) the robot follows on. Nodes on the route with no
  side opening give no junction event, so the expectation is the first node after them that does (or the goal).
* A dead-end goal whose tag is missed. Its only sign is the end wall, and the wall follower stops for that
  ``stop_distance_m`` from it: past the node's centre by half a hallway width less that (0.4 m on a 1.6 m
  hallway, at the edge of the success radius; beyond it on a wider one). So, fed the odometry and where the map
  knows the hallway's length, the executor takes the robot to be at the dead end once it has driven the map's
  distance to it and stops there (as ``tag_to_node_m`` stops it on a read tag: a node with no side opening is
  found by distance); the wall is the sign only when it comes first (a map length longer than the hallway).
* An opening the map does not have (a door, a gap in a wall) looks like a junction to the wall follower. Fed
  the odometry (:meth:`on_odometry`) and where the map knows the hallways' lengths, the executor takes a
  junction centre (or a dead end's wall) for the expected node only once the robot has come within
  EARLY_MARGIN of the distance to it (from the tag read, or the junction centre, that set the expectation);
  a junction well before that is an opening not on the map, followed straight on (after a U-turn at a tag the
  distance starts ``tag_to_node_m`` along the hallway left by, not before the node). The margin allows for map
  lengths taken between node positions (junction widths, tags a little nearer or farther than
  ``tag_to_node_m``) and for odometry drift, not for a floor's particular doors.
* Off the route. Every tag plans again from its node, so a tag of an unexpected node (a missed turn, a wrong
  assumption) needs nothing special; it is counted as a re-plan when an expectation existed and was wrong.
* ``no_opening``: the junction cannot be left the way decided, so it is taken to be an opening the map does
  not have (a doorway, an alcove) before the decided node: the decided turn waits for the next junction and
  the robot goes straight on. If straight on is blocked too (a dead end), the robot turns back and is lost
  until the next tag. Each ``no_opening`` counts as a re-plan.
* ``?`` hallways. When no mapped route reaches the goal, the robot heads for the nearest node (fewest
  hallways) with an unexplored ``?`` side and leaves by it. The next tag names the far end: if its arrival
  side is ``?`` too, the hallway is learned at both ends (the executor's own copy of the map; the given map
  is not changed) and routed through from then on. A far end mapped otherwise leaves the hallway unlearned
  and marked explored, so it is not tried again; a tag of the node it left, from the ``?`` side, means the
  hallway was a dead end the robot turned back from: it is recorded as a dead end (``dead_ends``) and marked
  explored, not learned as a hallway back to the node itself. A missed tag at the far end leaves the robot lost
  (it follows until the next tag) and the hallway unexplored, so a later decision may try it again.

Tags are read many times while the robot passes; a repeat of the last tag, or another tag of the same node and
side (a side may carry several), before the next junction centre (or after a U-turn next to it) is the same
read and changes nothing.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace

from rfidnav_common.topological_map import (
    DIRECTIONS,
    UNKNOWN,
    WEIGHTS,
    RouteError,
    TopologicalMap,
    hallway_text,
    opposite,
    turn,
)

LEFT, RIGHT, STRAIGHT, BACK, STOP, FOLLOW = "left", "right", "straight", "back", "stop", "follow"
TURNS = (LEFT, RIGHT, STRAIGHT, BACK)                 # the actions WallFollower.command_turn takes
JUNCTION_ENTERED, JUNCTION_CENTRE, TURN_DONE = "junction_entered", "junction_centre", "turn_done"
NO_OPENING, OBSTACLE = "no_opening", "obstacle"
EVENTS = (JUNCTION_ENTERED, JUNCTION_CENTRE, TURN_DONE, NO_OPENING, OBSTACLE)
# A junction is the expected node only within max(metres, fraction of the distance) short of it (see above).
EARLY_MARGIN = (1.0, 0.10)


@dataclass(frozen=True)
class Decision:
    action: str                     # left | right | straight | back (command them) | stop | follow (no command)
    finished: bool = False
    success: bool = False
    message: str = ""
    drive_on_m: float = 0.0         # on stop: at most this far on to the goal's centre (WallFollower.command_stop)
    commanded_already: bool = False  # the turn a tag decided, now due at its junction: the follower has it


@dataclass(frozen=True)
class FollowerCommand:
    """What a decision asks of the wall follower: ``left``, ``right``, ``straight``, ``back`` (its command_turn)
    or ``stop`` (its command_stop, at most ``within_m`` on)."""
    action: str
    within_m: float = 0.0


@dataclass(frozen=True)
class LearnedEdge:
    """A ``?`` hallway found to leave ``node_a`` by ``side_a`` and enter ``node_b`` by ``side_b``."""

    node_a: str
    side_a: str
    node_b: str
    side_b: str

    def text(self) -> str:
        return hallway_text(self.node_a, self.side_a, self.node_b, self.side_b)


@dataclass
class MissionState:
    goal: str
    current_node: str | None = None         # where the robot was last localized (by a tag or an assumption)
    arrival_side: str | None = None
    last_tag: str | None = None
    last_place: tuple[str, str] | None = None   # the (node, arrival side) last_tag announces
    expected_node: str | None = None        # the next node the route leads to, and the side it is entered by
    expected_side: str | None = None
    passing: tuple[tuple[str, str], ...] = ()   # (node, arrival side) passed on the way, without a junction
    nodes_visited: list[str] = field(default_factory=list)
    first_arrival: tuple[str, str] | None = None    # (node, side) of the first localization
    tags_missed: int = 0
    unknown_tags: int = 0
    replans: int = 0
    learned_edges: tuple[LearnedEdge, ...] = ()
    dead_ends: tuple[tuple[str, str], ...] = ()     # (node, side) of ? hallways found to be dead ends
    awaiting: str | None = None             # the turn decided by a tag, for the junction just ahead
    exploring: tuple[str, str] | None = None    # the (node, side) of the ? hallway being driven along
    junction_since_tag: bool = True         # False while a repeat of last_tag is still the same read
    commanded: str | None = None            # the last turn answered, to know what no_opening refused
    outcome: Decision | None = None
    last_read: str | None = None            # the last tag id the reader reported (see on_reads)
    stop_commanded: bool = False
    leg_from_m: float = 0.0                 # odometry distance where the expectation was set
    leg_expected_m: float | None = None     # ... and the map's distance from there to the expected node


class MissionExecutor:
    def __init__(self, topological_map: TopologicalMap, weight: str = "edges",
                 recover_missed_tags: bool = True) -> None:
        """``recover_missed_tags=False`` is the paper's loop, the baseline: a junction with no tag read is
        followed straight on (or round a corner) and only the next tag read re-localizes the robot."""
        if weight not in WEIGHTS:
            raise ValueError(f"weight must be one of {', '.join(WEIGHTS)}, got '{weight}'")
        self.recover_missed_tags = recover_missed_tags
        self.map = topological_map          # replaced by a copy with each learned hallway
        self.weight = weight
        self.learned: tuple[LearnedEdge, ...] = ()
        self.dead_ends: tuple[tuple[str, str], ...] = ()
        self.explored: set[tuple[str, str]] = set()   # ? sides tried without learning them
        self.state: MissionState | None = None
        self.odometry_m: float | None = None          # distance driven by odometry, once on_odometry is fed
        self.last_odometry: tuple[float, float] | None = None

    # ---------------------------------------------------------------------------------------- inputs
    def start(self, goal_node: str) -> Decision:
        """Begin a mission to ``goal_node`` (RouteError for a node not in the map). What was learned on earlier
        missions is kept; where the robot is is not: the first tag localizes it."""
        if goal_node not in self.map.nodes:
            raise RouteError(f"map '{self.map.name}': unknown goal node '{goal_node}' "
                             f"(nodes: {', '.join(self.map.nodes)})")
        self.state = MissionState(goal=goal_node, learned_edges=self.learned, dead_ends=self.dead_ends)
        return Decision(FOLLOW, message=f"to '{goal_node}': following the wall until a tag is read")

    def on_tag(self, tag_id: str | int) -> Decision:
        """A wall tag read: localize, learn an explored hallway, and decide the turn at the junction ahead."""
        state = self._mission()
        tag = str(tag_id)
        if state.outcome is not None:
            return state.outcome
        located = self.map.locate_tag(tag)
        if located is None:
            state.unknown_tags += 1
            return replace(self._current(), message=f"tag {tag} is not in the map: ignored")
        if located == state.last_place and not state.junction_since_tag:
            return self._current()
        node, side = located
        state.last_tag, state.last_place, state.junction_since_tag = tag, located, False
        if state.exploring is not None:
            self._learn(state.exploring, node, side)
        elif state.expected_node is not None:
            ahead = self._ahead()
            if (node, side) in ahead:
                self._passed(ahead[:ahead.index((node, side))])
            else:
                state.replans += 1
        decision = self._arrive(node, side, f"tag {tag}", at_centre=False)
        state.awaiting = decision.action if decision.action in (LEFT, RIGHT, STRAIGHT) else None
        return decision

    def on_odometry(self, x: float, y: float) -> Decision | None:
        """The odometry position (any fixed frame): the distance driven adds up between calls. A decision only
        when the distance says the robot is at a dead-end goal whose tag was missed (see the module docstring)."""
        if self.last_odometry is not None:
            self.odometry_m = (self.odometry_m or 0.0) + math.dist(self.last_odometry, (x, y))
        self.last_odometry = (x, y)
        state = self.state
        if (state is None or state.outcome is not None or not self.recover_missed_tags
                or state.expected_node != state.goal or not self._dead_end_expected()
                or state.leg_expected_m is None or self.odometry_m is None
                or self.odometry_m - state.leg_from_m < state.leg_expected_m):
            return None
        return self._assume_arrival("missed tag, assumed by the odometry distance to the dead end")

    def on_reads(self, tag_ids: Iterable[str | int]) -> list[Decision]:
        """One inventory round's tag ids: a reader reports a tag every round while it is in reach, so only a tag
        other than the last one reported is a new read for :meth:`on_tag`; the decisions, in order."""
        state = self._mission()
        decisions = []
        for tag in map(str, tag_ids):
            if tag != state.last_read:
                state.last_read = tag
                decisions.append(self.on_tag(tag))
        return decisions

    def follower_command(self, decision: Decision) -> FollowerCommand | None:
        """The wall follower's command for ``decision``: its turn, or the stop (once: the outcome is repeated to
        every later input), or None (follow; or the turn a tag decided, due now at its junction: the follower
        was given it with the tag, and giving it again could reach the follower after it has turned, leaving it
        queued for the next junction)."""
        state = self._mission()
        if decision.action in TURNS and not decision.commanded_already:
            return FollowerCommand(decision.action)
        if decision.action == STOP and not state.stop_commanded:
            state.stop_commanded = True
            return FollowerCommand(STOP, decision.drive_on_m)
        return None

    def on_junction(self, event: str) -> Decision:
        """A wall follower event. ``junction_centre``: make the turn the last tag decided or, with none waiting,
        a tag was missed (see the module docstring); ``no_opening``: the decided way is blocked; ``obstacle``
        where the route expects a dead end with no decision waiting: its tag was missed and the robot is there;
        the others (``junction_entered``, ``turn_done``, which the wall follower handles) change nothing."""
        if event not in EVENTS:
            raise ValueError(f"on_junction: '{event}' is not one of {', '.join(EVENTS)}")
        state = self._mission()
        if state.outcome is not None:
            return state.outcome
        if event == JUNCTION_CENTRE:
            return self._junction_centre()
        if event == NO_OPENING:
            return self._no_opening()
        if event == OBSTACLE and self.recover_missed_tags and state.awaiting is None and self._dead_end_expected():
            early = self._too_early()
            if early:
                return Decision(FOLLOW, message=f"a wall {early}")
            return self._assume_arrival("missed tag, assumed by the route at the dead end's wall")
        return Decision(FOLLOW)

    def _dead_end_expected(self) -> bool:
        """The route leads into a dead end (its node has no hallway but the one the robot arrives by): with its
        tag missed, the wall ahead is the only sign of arrival."""
        state = self._mission()
        return state.expected_node is not None and set(self.map.nodes[state.expected_node].hallways) == {
            state.expected_side}

    # -------------------------------------------------------------------------------------- deciding
    def _junction_centre(self) -> Decision:
        state = self._mission()
        state.junction_since_tag = True
        if state.awaiting is not None:
            action, state.awaiting = state.awaiting, None
            return self._answer(Decision(action, message=f"at '{state.current_node}': {action}",
                                         commanded_already=True))
        if state.exploring is not None:
            state.exploring = None
            return Decision(FOLLOW, message="junction at the end of an explored hallway without a tag: lost; "
                                            "the hallway stays unexplored")
        if state.expected_node is None or not self.recover_missed_tags:
            return Decision(FOLLOW, message="junction without a tag read and no expectation: following on")
        early = self._too_early()
        if early:
            return Decision(FOLLOW, message=f"a junction {early}")
        return self._assume_arrival("missed tag, assumed by the route")

    def _too_early(self) -> str:
        """Why the junction (or wall) just met cannot be the expected node, or "" when it can be: fewer metres
        driven since the expectation was set than the map's distance to it, less the margin."""
        state = self._mission()
        if self.odometry_m is None or state.leg_expected_m is None:
            return ""
        driven = self.odometry_m - state.leg_from_m
        margin = max(EARLY_MARGIN[0], EARLY_MARGIN[1] * state.leg_expected_m)
        if driven >= state.leg_expected_m - margin:
            return ""
        return (f"after {driven:.1f} m of the {state.leg_expected_m:.1f} m to '{state.expected_node}': an opening "
                "not on the map, followed on")

    def _leg_length(self, node: str, arrival: str, departure: str, at_centre: bool) -> float | None:
        """The map's distance from where the robot is (at ``node``'s centre, or at its tag ``tag_to_node_m``
        before it on the hallway it arrived by) to the expected node, leaving by ``departure`` through the nodes
        passed; None if a length is not known. A U-turn at the tag (leaving by the side arrived from) starts
        ``tag_to_node_m`` along the hallway it leaves by, not before the node."""
        state = self._mission()
        if state.expected_node == UNKNOWN:
            return None
        legs = [(node, departure), *((passed, opposite(side)) for passed, side in state.passing)]
        lengths = [self.map.known_length_m(*leg) for leg in legs]
        if any(length is None for length in lengths):
            return None
        tag_offset = 0.0 if at_centre else self.map.tag_to_node_m * (-1.0 if departure == arrival else 1.0)
        return tag_offset + sum(length for length in lengths if length is not None)

    def _assume_arrival(self, how: str) -> Decision:
        """A tag was missed: the robot is where the route leads next (the nodes passed on the way are visited)."""
        state = self._mission()
        state.tags_missed += 1
        ahead = self._ahead()
        node, side = ahead[-1]
        self._passed(ahead[:-1])
        if node == UNKNOWN:
            state.expected_node = state.expected_side = None
            return Decision(FOLLOW, message="passed the goal with its tag missed into an unmapped hallway: lost")
        return self._answer(self._arrive(node, side, how, at_centre=True))

    def _no_opening(self) -> Decision:
        state = self._mission()
        state.replans += 1
        refused = state.commanded
        if refused is not None and refused != STRAIGHT:
            state.awaiting = refused
            return self._answer(Decision(STRAIGHT, message=f"no opening for '{refused}': taken for a junction "
                                                           "not on the map; the turn waits for the next one"))
        state.awaiting = state.expected_node = state.expected_side = state.exploring = None
        return self._answer(Decision(BACK, message="no way on: turning back, lost until the next tag"))

    def _arrive(self, node: str, side: str, how: str, at_centre: bool) -> Decision:
        """Localized at ``node``, entered by ``side`` (``at_centre``: at its junction's centre, else at its tag):
        stop at the goal, or turn to leave by the route's side."""
        state = self._mission()
        state.current_node, state.arrival_side = node, side
        state.nodes_visited.append(node)
        if state.first_arrival is None:
            state.first_arrival = (node, side)
        state.expected_node = state.expected_side = state.exploring = None
        state.passing = ()
        opening = self.map.has_side_opening(node, side)
        if node == state.goal:
            drive_on = 0.0 if at_centre else self.map.tag_to_node_m * (2.0 if opening else 1.0)
            state.outcome = Decision(STOP, finished=True, success=True, drive_on_m=drive_on,
                                     message=f"{how}: at the goal '{node}' after {len(state.nodes_visited)} nodes")
            return state.outcome
        departure = self._departure(node)
        if departure is None:
            state.outcome = Decision(STOP, finished=True, success=False,
                                     message=f"{how}: at '{node}', no mapped route to '{state.goal}' and no "
                                             f"unexplored '{UNKNOWN}' hallway to look for one")
            return state.outcome
        action = turn(side, departure)
        neighbour = self.map.nodes[node].hallways[departure].neighbour
        if neighbour == UNKNOWN:
            state.exploring = (node, departure)
            goes = f"exploring the '{UNKNOWN}' hallway {departure}"
        else:
            state.expected_node, state.expected_side, state.passing = self._next_sensed(node, departure)
            state.leg_from_m = self.odometry_m or 0.0
            state.leg_expected_m = self._leg_length(node, side, departure, at_centre)
            goes = f"for '{state.expected_node}'"
        message = f"{how}: at '{node}' from {side}; {action}, leaving {departure} {goes}"
        if action == STRAIGHT and not opening:
            return Decision(FOLLOW, message=message + " (no junction to sense here)")
        return self._answer(Decision(action, message=message))

    def _ahead(self) -> list[tuple[str, str]]:
        """The (node, arrival side) the robot meets next in order, up to the first junction it will sense: the
        nodes it passes straight through, the expected node, and, if that is the goal with no junction to sense,
        those beyond it (its tag missed, the robot drives past it). The last may be ``("?", "")``: an unmapped
        hallway."""
        state = self._mission()
        ahead = [*state.passing, (state.expected_node, state.expected_side)]
        node, side = ahead[-1]
        if not self.map.has_side_opening(node, side) and opposite(side) in self.map.nodes[node].hallways:
            beyond, beyond_side, passing = self._next_sensed(node, opposite(side), beyond_goal=True)
            ahead += [*passing, (beyond, beyond_side)]
        return ahead

    def _passed(self, passing: tuple[tuple[str, str], ...]) -> None:
        """Nodes without a side opening passed (their tags missed) on the way to where the robot is now."""
        self._mission().nodes_visited.extend(node for node, _ in passing)

    def _next_sensed(self, node: str, departure: str,
                     beyond_goal: bool = False) -> tuple[str, str, tuple[tuple[str, str], ...]]:
        """The next node (and its arrival side) leaving ``node`` by ``departure`` whose junction the robot will
        sense or where it must stop (the goal, unless ``beyond_goal``), and the (node, arrival side) passed
        straight through on the way: nodes without a side opening. ``?`` as the node: into an unmapped
        hallway."""
        goal = None if beyond_goal else self._mission().goal
        passing: list[tuple[str, str]] = []
        neighbour = self.map.nodes[node].hallways[departure].neighbour
        if neighbour == UNKNOWN:
            return UNKNOWN, "", ()
        side = self._far_side(node, departure)
        while (neighbour != goal and neighbour != node and (neighbour, side) not in passing
               and not self.map.has_side_opening(neighbour, side)):
            ahead = self.map.nodes[neighbour].hallways.get(opposite(side))
            if ahead is None or ahead.neighbour == UNKNOWN:
                break
            passing.append((neighbour, side))
            neighbour, side = ahead.neighbour, self._far_side(neighbour, opposite(side))
        return neighbour, side, tuple(passing)

    def _departure(self, node: str) -> str | None:
        """The side to leave ``node`` by: along the route to the goal; without one, towards (or into) the nearest
        unexplored ``?`` hallway; None when there is neither."""
        goal = self._mission().goal
        try:
            path = self.map.route(node, goal, self.weight)
            return self.map.departure_direction(node, path[1], self.weight)
        except RouteError:
            pass
        best: list[str] | None = None
        for name in self.map.nodes:
            if not self._unexplored(name):
                continue
            try:
                path = self.map.route(node, name, self.weight)
            except RouteError:
                continue
            if best is None or len(path) < len(best):
                best = path
        if best is None:
            return None
        if len(best) > 1:
            return self.map.departure_direction(node, best[1], self.weight)
        return self._unexplored(node)[0]

    def _unexplored(self, node: str) -> list[str]:
        """The ``?`` sides of ``node`` not yet tried in vain, clockwise from North."""
        hallways = self.map.nodes[node].hallways
        return [side for side in DIRECTIONS
                if side in hallways and hallways[side].neighbour == UNKNOWN and (node, side) not in self.explored]

    def _far_side(self, node: str, side: str) -> str:
        """The side of the hallway's far end that leads back: the opposite one on a checked map; a learned
        hallway may bend."""
        far_end = self.map.nodes[self.map.nodes[node].hallways[side].neighbour]
        back = far_end.hallways.get(opposite(side))
        if back is not None and back.neighbour == node:
            return opposite(side)
        return next(s for s, h in far_end.hallways.items() if h.neighbour == node)

    def _learn(self, exploring: tuple[str, str], node: str, side: str) -> None:
        """Map the explored ``?`` hallway at both ends if the far end's arrival side is unmapped too."""
        state = self._mission()
        origin, origin_side = exploring
        if (node, side) == exploring:
            self.explored.add(exploring)
            self.dead_ends = state.dead_ends = (*self.dead_ends, exploring)
            return
        far_end = self.map.nodes[node].hallways.get(side)
        if far_end is None or far_end.neighbour != UNKNOWN:
            self.explored.add(exploring)
            return
        self.map = self.map.with_hallway(origin, origin_side, node, side)
        self.learned = state.learned_edges = (*self.learned, LearnedEdge(origin, origin_side, node, side))

    # --------------------------------------------------------------------------------------- helpers
    def _answer(self, decision: Decision) -> Decision:
        if decision.action in TURNS:
            self._mission().commanded = decision.action
        return decision

    def _current(self) -> Decision:
        """What stands while nothing new is known: the turn waiting for the junction ahead, else following."""
        awaiting = self._mission().awaiting
        return Decision(awaiting) if awaiting is not None else Decision(FOLLOW)

    def _mission(self) -> MissionState:
        if self.state is None:
            raise RuntimeError("no mission: call start(goal_node) first")
        return self.state
