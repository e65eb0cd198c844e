"""In-process topological navigation (paper 004): the mission executor and the sonar wall follower driving an
idealised robot through a simulated building, for the paper's run and statistics.

The robot is a unicycle stepped at ``step_s`` with the wall follower's (linear, angular) command (no motor
dynamics; odometry is the true pose). Every step the sonar model's ranges (one per transducer, measured from
where it is mounted) are turned into distances from the robot's centre, as the follower expects, by adding
the offsets of the shipped wall_follower parameters, as the node does; the wall-tag reader (default induction
area: antenna at the centre, facing left, 40 x 100 cm) reads with the given miss probability, decided once per
tag PASSAGE (the paper's read failure: a tag not read while the robot passes it) when the tag comes into reach,
and drawn anew once it has left reach (per inventory round a tag in reach for ~40 rounds would practically never
be missed). Each round's reads go to ``MissionExecutor.on_reads``, the follower's events to ``on_junction``, and the
decisions' ``follower_command`` to the follower (``command_turn``, ``command_stop``); the mission ends with the
follower's ``stopped``. The mission_executor and wall_follower nodes do the same over DDS. Walls only reflect
sonar: a robot driving into one is not stopped by the simulation (the follower's emergency stop is all there is).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_bringup.metrics import GOAL_RADIUS_M, topological_shortest_m
from rfidnav_bringup.scenario import CONFIG_DIR
from rfidnav_common.topological_map import UNKNOWN, TopologicalMap, load_topological_map, opposite
from rfidnav_control.parameters import SONAR_FIELDS, WallFollowerParameters
from rfidnav_control.wall_following import (
    JUNCTION_CENTRE,
    NO_OPENING,
    OBSTACLE,
    STOPPED,
    TURN_DONE,
    OdomPose,
    Sonar,
    WallFollower,
    WallFollowerSettings,
)
from rfidnav_experiments.runners.shipped import shipped_parameters
from rfidnav_planning.mission_executor import STOP, TURNS, Decision, MissionExecutor
from rfidnav_sim.kinematics import unicycle_step
from rfidnav_sim.sonar_model import PAPER_LAYOUT, SonarModel
from rfidnav_sim.wall_tag_model import InductionArea, WallTagReader
from rfidnav_sim.world import World, load_world

FOLLOWER_EVENTS = (JUNCTION_CENTRE, NO_OPENING, TURN_DONE, OBSTACLE)
FIG5_MAP = CONFIG_DIR / "maps" / "building_fig5.yaml"
FIG5_WORLD = CONFIG_DIR / "worlds" / "building_fig5.yaml"
LARGE_MAP = CONFIG_DIR / "maps" / "building_large.yaml"
LARGE_WORLD = CONFIG_DIR / "worlds" / "building_large.yaml"
FOLLOWER = shipped_parameters(WallFollowerParameters, "wall_follower")   # its sonar topics, offsets, settings


@dataclass(frozen=True)
class MissionRun:
    success: bool                          # the executor's success AND within GOAL_RADIUS_M of the goal node
    message: str
    path_length_m: float                   # true distance driven
    shortest_path_m: float                 # start pose -> first tag's node (straight) + shortest route to the goal
    tags_missed: int
    replans: int
    nodes_visited: tuple[str, ...]
    duration_s: float
    final_position: tuple[float, float]
    turns: tuple[tuple[str, str], ...] = ()   # (node, turn) made at junction centres, and U-turns, in order
    first_node: str | None = None


def follower_offsets(parameters: WallFollowerParameters = FOLLOWER) -> dict[str, float]:
    """Per rangefinder (``/sonar/NAME``: NAME) that feeds the follower, the offset the wall_follower node adds to
    its readings."""
    return {topic.rsplit("/", 1)[-1]: offset for topic, offset in zip(parameters.sonar_topics,
                                                                     parameters.sonar_offsets_m)}


def centre_sonar(ranges: dict[str, float], offsets: dict[str, float],
                 parameters: WallFollowerParameters = FOLLOWER) -> Sonar:
    """The follower's Sonar (distances from the robot's centre) from the rangefinders' readings (inf stays inf),
    fed as the wall_follower node feeds it: field by field from ``parameters.sonar_topics``."""
    names = [topic.rsplit("/", 1)[-1] for topic in parameters.sonar_topics]
    return Sonar(**{field: ranges[name] + offsets[name] for field, name in zip(SONAR_FIELDS, names)})


def start_pose_for(topological_map: TopologicalMap, tag_id: str | int,
                   before_m: float = 3.0, wall_distance_m: float = 0.8,
                   hallway_width_m: float = 1.6) -> tuple[float, float, float]:
    """A pose ``before_m`` before the node of ``tag_id`` (its centre, along the hallway the tag is read in),
    ``wall_distance_m`` from the left wall, heading towards the node: the robot then reads the tag before the
    junction. The hallway's centre line is taken to run through the node's position."""
    located = topological_map.locate_tag(tag_id)
    if located is None:
        raise ValueError(f"tag '{tag_id}' is not in map '{topological_map.name}'")
    node, arrival_side = located
    position = topological_map.nodes[node].position
    if position is None:
        raise ValueError(f"node '{node}' of map '{topological_map.name}' has no position")
    back = topological_map.direction_angle_rad(arrival_side)        # from the node into the arrival hallway
    heading = topological_map.direction_angle_rad(opposite(arrival_side))
    # The left wall is at +90 deg from the heading, half a hallway off the centre line.
    lateral = hallway_width_m / 2.0 - wall_distance_m                # towards the left wall
    x = position[0] + before_m * math.cos(back) + lateral * math.cos(heading + math.pi / 2.0)
    y = position[1] + before_m * math.sin(back) + lateral * math.sin(heading + math.pi / 2.0)
    return (x, y, heading)


def run_mission(world: World, topological_map: TopologicalMap, start_pose: tuple[float, float, float],
                goal_node: str, rng: np.random.Generator, miss_probability: float = 0.0, step_s: float = 0.05,
                max_time_s: float = 900.0, settings: WallFollowerSettings = FOLLOWER.settings(),
                weight: str = "length", recover_missed_tags: bool = True) -> MissionRun:
    sonar_model = SonarModel(PAPER_LAYOUT, world.wall_segments())
    offsets = follower_offsets()
    reader = WallTagReader(InductionArea(), world.wall_tags, passage_miss_probability=miss_probability)
    follower = WallFollower(settings)
    executor = MissionExecutor(topological_map, weight, recover_missed_tags)
    executor.start(goal_node)
    x, y, yaw = start_pose
    path = 0.0
    t = 0.0
    turns: list[tuple[str, str]] = []
    message = "timeout"
    finished = False

    def apply(decision: Decision, at_junction: bool) -> None:
        nonlocal message
        if decision.message:
            message = decision.message
        if decision.action in TURNS and (at_junction or decision.action == "back"):
            turns.append((executor.state.current_node or "?", decision.action))   # a tag's turn waits for it
        command = executor.follower_command(decision)
        if command is None:
            return
        if command.action == STOP:
            follower.command_stop(command.within_m)
        else:
            follower.command_turn(command.action)

    for _ in range(int(round(max_time_s / step_s))):
        for decision in executor.on_reads(reader.read(x, y, yaw, rng)):
            apply(decision, False)
        command = follower.step(centre_sonar(sonar_model.ranges(x, y, yaw, rng), offsets), OdomPose(x, y, yaw))
        if command.event == STOPPED:
            finished = True
            break
        if command.event in FOLLOWER_EVENTS:
            apply(executor.on_junction(command.event), True)
        dx, dy, dyaw = unicycle_step(yaw, command.linear, command.angular, step_s)
        x, y = x + dx, y + dy
        yaw = math.atan2(math.sin(yaw + dyaw), math.cos(yaw + dyaw))
        path += math.hypot(dx, dy)
        t += step_s

    state = executor.state
    outcome = state.outcome
    first_node = state.nodes_visited[0] if state.nodes_visited else None
    goal_xy = topological_map.nodes[goal_node].position
    near = goal_xy is not None and math.dist((x, y), goal_xy) <= GOAL_RADIUS_M
    success = bool(outcome is not None and outcome.success and near)
    if not finished:
        message = f"no stop within {max_time_s:.0f} s (last: {message})"
    elif outcome is not None and outcome.success and not near:
        message += f"; but stopped {math.dist((x, y), goal_xy):.2f} m from the goal node"
    # On the map as learned by the end: a goal reached through an explored "?" hallway has a route.
    shortest = (topological_shortest_m(executor.map, start_pose[:2], *state.first_arrival, goal_node)
                if state.first_arrival is not None else math.nan)
    return MissionRun(success, message, path, shortest, state.tags_missed, state.replans,
                      tuple(state.nodes_visited), t, (x, y), tuple(turns), first_node)


def paper_run(rng: np.random.Generator, miss_probability: float = 0.0) -> MissionRun:
    """Paper 004 section 5: from before tag 23 (arriving at h from the West) to g (tag 19), a right turn at h."""
    topological_map = load_topological_map(FIG5_MAP)
    return run_mission(load_world(FIG5_WORLD), topological_map, start_pose_for(topological_map, "23"), "g", rng,
                       miss_probability)


def random_missions(count: int, miss_probability: float, seed: int, map_path: Path = LARGE_MAP,
                    world_path: Path = LARGE_WORLD, recover_missed_tags: bool = True) -> list[MissionRun]:
    """``count`` missions on the large floor: a random start tag (on a mapped hallway) and a random goal node other
    than the start tag's node, seeded; each mission gets its own generator."""
    topological_map = load_topological_map(map_path)
    world = load_world(world_path)
    tags = sorted(tag for node in topological_map.nodes.values() for side, hallway in node.hallways.items()
                  if hallway.neighbour != UNKNOWN for tag in hallway.tags)
    choose = np.random.default_rng([seed, 0])
    runs = []
    for index in range(count):
        tag = tags[int(choose.integers(len(tags)))]
        start_node = topological_map.locate_tag(tag)[0]
        goals = [name for name in topological_map.nodes if name != start_node]
        goal = goals[int(choose.integers(len(goals)))]
        runs.append(run_mission(world, topological_map, start_pose_for(topological_map, tag), goal,
                                np.random.default_rng([seed, index + 1]), miss_probability,
                                recover_missed_tags=recover_missed_tags))
    return runs
