"""Paths round a home's known walls (paper 003's legs between landmarks, ours: the paper drives straight).

The robot's map may carry the home's floor plan (``walls`` and ``extent``, rfidnav_common.robot_map). A leg is
planned on a visibility graph: its nodes are the start, the goal and three points round each free wall end (straight
past it and diagonally past it on either side, ``clearance_m`` out, where the robot can turn round a door jamb or a
wall's end); an edge joins two nodes whose straight segment stays ``clearance_m`` from every wall and inside the
extent. The shortest path on that graph (networkx's Dijkstra) is the leg's waypoints. The clearance is the robot's
radius and a margin for dead reckoning: a door narrower than twice of it is closed to the planner.

A start (or goal) already closer than the clearance to a wall (dead reckoning put it there, or a landmark by a
wall) may leave (or be reached) along edges that keep the distance it has, and one outside the extent is planned
from the nearest point inside it: the robot is not trapped where it believes it stands.

Pure module: numpy and networkx, no ROS.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx
import numpy as np

from rfidnav_common.geometry import closest_on_segments, point_segment_distance
from rfidnav_common.robot_map import Rectangle, RouteMap, Wall, contains

Point = tuple[float, float]
NODE_OFFSET = 1.05            # wall-end nodes sit this much beyond the clearance: their own edges are clear of it


def segment_distances(a: np.ndarray, b: np.ndarray, walls: np.ndarray) -> np.ndarray:
    """Distance from the segment a-b to each wall segment (N x 4): 0 where they cross."""
    if len(walls) == 0:
        return np.zeros(0)
    c, d = walls[:, :2], walls[:, 2:]
    crossing = _properly_crossing(a, b, c, d)
    distances = np.minimum.reduce([closest_on_segments(a, walls)[0], closest_on_segments(b, walls)[0],
                                   point_segment_distance(c, a, b), point_segment_distance(d, a, b)])
    return np.where(crossing, 0.0, distances)


def _cross(o: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (q[..., 0] - o[..., 0])


def _properly_crossing(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray:
    d1, d2 = _cross(c, d, a[None, :]), _cross(c, d, b[None, :])
    d3, d4 = _cross(a[None, :], b[None, :], c), _cross(a[None, :], b[None, :], d)
    return (d1 * d2 < 0.0) & (d3 * d4 < 0.0)


@dataclass(frozen=True)
class WallMap:
    """What a robot map says of the home's geometry: its walls and the extent the robot may drive in."""

    walls: tuple[Wall, ...] = ()
    extent: Rectangle | None = None

    @classmethod
    def of(cls, robot_map: RouteMap) -> WallMap:
        return cls(robot_map.walls, robot_map.extent)

    @property
    def empty(self) -> bool:
        return not self.walls and self.extent is None

    def refusal(self, target: Sequence[float]) -> str | None:
        """Why ``target`` cannot be navigated to (not a finite point, outside the extent), None if it can."""
        if not all(math.isfinite(v) for v in target):
            return f"target ({target[0]}, {target[1]}) is not a finite point"
        if self.extent is not None and not contains(self.extent, target[0], target[1]):
            return (f"target ({target[0]:g}, {target[1]:g}) is outside the map's extent [x_min, y_min, x_max, "
                    f"y_max] = {list(self.extent)}")
        return None


class WallPlanner:
    """Shortest paths round a floor plan's walls, within its extent, ``clearance_m`` from the walls (see the
    module's docstring)."""

    def __init__(self, plan: WallMap, clearance_m: float) -> None:
        if not (math.isfinite(clearance_m) and clearance_m > 0.0):
            raise ValueError(f"clearance_m: expected a positive distance, got {clearance_m}")
        self.plan = plan
        self.clearance_m = clearance_m
        self.walls = np.array(plan.walls, dtype=float).reshape(-1, 4)
        self.graph = nx.Graph()
        corners = [point for point in self._corner_candidates() if self.clearance(point) >= clearance_m]
        for index, point in enumerate(corners):
            self.graph.add_node(index, point=point)
            for other in range(index):
                if self.segment_clear(point, corners[other]):
                    self.graph.add_edge(index, other, weight=math.dist(point, corners[other]))

    def _corner_candidates(self) -> list[Point]:
        """Three points round each wall end: past it, and past it and out to either side (where another wall meets
        the end, those inside its clearance are dropped by the caller)."""
        offset = NODE_OFFSET * self.clearance_m
        ends = np.concatenate([self.walls[:, :2], self.walls[:, 2:]])
        others = np.concatenate([self.walls[:, 2:], self.walls[:, :2]])
        candidates: list[Point] = []
        for end, other in zip(ends, others):
            length = float(np.linalg.norm(end - other))
            if length == 0.0:
                continue
            along = (end - other) / length
            across = np.array([-along[1], along[0]])
            for step in (along, along + across, along - across):
                point = end + offset * step
                candidates.append((float(point[0]), float(point[1])))
        return candidates

    def inside(self, point: Sequence[float]) -> bool:
        """Within the extent (everywhere when the plan has none)."""
        return self.plan.extent is None or contains(self.plan.extent, point[0], point[1])

    def clamped(self, point: Point) -> Point:
        """The point moved into the extent (dead reckoning may put the robot a little outside it)."""
        extent = self.plan.extent
        if extent is None:
            return point
        return min(max(point[0], extent[0]), extent[2]), min(max(point[1], extent[1]), extent[3])

    def clearance(self, point: Sequence[float]) -> float:
        """Distance to the nearest wall, and to the extent's edge (negative outside it)."""
        x, y = float(point[0]), float(point[1])
        distance = float(closest_on_segments((x, y), self.walls)[0].min()) if len(self.walls) else math.inf
        extent = self.plan.extent
        if extent is not None:
            distance = min(distance, x - extent[0], extent[2] - x, y - extent[1], extent[3] - y)
        return distance

    def segment_clear(self, a: Sequence[float], b: Sequence[float], clearance_m: float | None = None) -> bool:
        """The robot's centre can drive from a to b keeping ``clearance_m`` (the planner's) from every wall, inside
        the extent."""
        need = self.clearance_m if clearance_m is None else clearance_m
        if not (self.inside(a) and self.inside(b)):
            return False
        distances = segment_distances(np.asarray(a, dtype=float), np.asarray(b, dtype=float), self.walls)
        return bool(np.all(distances >= need - 1e-9))

    def path(self, start: Point, goal: Point) -> list[Point] | None:
        """The waypoints from ``start`` to ``goal`` (the goal last, the start left out), None when the walls close
        every way. A start or goal nearer a wall than the clearance keeps the distance it has on its own edges."""
        start, goal = self.clamped(start), self.clamped(goal)
        start_need = min(self.clearance_m, max(self.clearance(start), 0.0))
        goal_need = min(self.clearance_m, max(self.clearance(goal), 0.0))
        if self.segment_clear(start, goal, min(start_need, goal_need)):
            return [goal]
        graph = self.graph.copy()
        graph.add_node("start", point=start)
        graph.add_node("goal", point=goal)
        for node, point in self.graph.nodes(data="point"):
            if self.segment_clear(start, point, start_need):
                graph.add_edge("start", node, weight=math.dist(start, point))
            if self.segment_clear(point, goal, goal_need):
                graph.add_edge(node, "goal", weight=math.dist(point, goal))
        try:
            nodes = nx.dijkstra_path(graph, "start", "goal")
        except nx.NetworkXNoPath:
            return None
        return [graph.nodes[node]["point"] for node in nodes[1:]]

    def length(self, start: Point, goal: Point) -> float:
        """The length of :meth:`path` (infinite when there is none)."""
        waypoints = self.path(start, goal)
        if waypoints is None:
            return math.inf
        points = [start, *waypoints]
        return sum(math.dist(a, b) for a, b in zip(points, points[1:]))
