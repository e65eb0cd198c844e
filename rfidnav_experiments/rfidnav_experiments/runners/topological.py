"""In-process topological navigation (paper 004): the mission executor and the sonar wall follower driving the
simulated base through a simulated building, for the paper's run and statistics.

The robot is the base robot_sim steps (shipped config/params/robot_sim.yaml: wheel speed and acceleration limits,
drifting wheel odometry, walls as obstacles with the bumper), stepped at its ``step_s`` under the wall
follower's (linear, angular) command, which the follower computes at its control rate from the sonar and the
ODOMETRY pose, as over DDS. Every control step the sonar model's ranges (shipped sonar_sim.yaml: noise,
specular loss; one per transducer, measured from where it is mounted) are turned into distances from the
robot's centre, as the follower expects, by adding the offsets of the shipped wall_follower parameters, as the
node does; the wall-tag reader (default induction
area: antenna at the centre, facing left, 40 x 100 cm) reads with the given miss probability, decided once per
tag PASSAGE (the paper's read failure: a tag not read while the robot passes it) when the tag comes into reach,
and drawn anew once it has left reach (per inventory round a tag in reach for ~40 rounds would practically never
be missed). Each round's reads go to ``MissionExecutor.on_reads``, the follower's events to ``on_junction``, and the
decisions' ``follower_command`` to the follower (``command_turn``, ``command_stop``); the mission ends with the
follower's ``stopped``. The mission_executor and wall_follower nodes do the same over DDS. A robot that drives
into a wall stalls there with its bumper pressed (counted in ``MissionRun.bumps``) until it turns free; the walls
its true track crossed all the same (``MissionRun.wall_crossings``, sampled every control step) make the mission no
success.

Floors are the in-tree ones (``FLOORS``: a map file and a world file) or generated ones by name
(``generated_SEED``: rfidnav_sim.floor_generator's floor of SEED, drawn again in whichever process runs the
mission). Besides the figures, a run records what classifies a failure (reproduce topological's taxonomy): whether
the follower stopped, where the executor believed the robot was, the map node nearest to where it ended, how long it
stood still before the end, whether the bumper was pressed at the end, and the tag passages the reader missed
(ground truth: in reach, then out of it, with no read), noticed by the executor or not.

Missions start where a robot would be put down: ``before_m`` before one of the floor's wall tags, at the
follower's set distance from the wall the tag is on, heading along it — taken from the world (the simulator's
ground truth, which the navigation never sees), so a floor whose corridors are not the map's grid places the
robot in its corridor all the same.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfidnav_common.topological_map import UNKNOWN, TopologicalMap, load_topological_map
from rfidnav_common.wall_tags import InductionArea
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
from rfidnav_scenario.metrics import GOAL_RADIUS_M, ground_truth_objection, topological_shortest_m, wall_crossings
from rfidnav_scenario.scenario import CONFIG_DIR
from rfidnav_sim.floor_generator import generated_floor
from rfidnav_sim.parameters import RobotSimParameters, SonarParameters
from rfidnav_sim.rig import Rig, ScheduledSensor, steps_per_sample
from rfidnav_sim.sonar_model import SonarModel
from rfidnav_sim.wall_tag_model import WallTagReader
from rfidnav_sim.world import World, load_world

FOLLOWER_EVENTS = (JUNCTION_CENTRE, NO_OPENING, TURN_DONE, OBSTACLE)
FIG5_MAP = CONFIG_DIR / "maps" / "building_fig5.yaml"
FIG5_WORLD = CONFIG_DIR / "worlds" / "building_fig5.yaml"
LARGE_MAP = CONFIG_DIR / "maps" / "building_large.yaml"
LARGE_WORLD = CONFIG_DIR / "worlds" / "building_large.yaml"
EVAL_MAP = CONFIG_DIR / "maps" / "building_eval.yaml"
EVAL_WORLD = CONFIG_DIR / "worlds" / "building_eval.yaml"
RING_MAP = CONFIG_DIR / "maps" / "building_ring.yaml"
RING_WORLD = CONFIG_DIR / "worlds" / "building_ring.yaml"
FOLLOWER = shipped_parameters(WallFollowerParameters, "wall_follower")   # its sonar topics, offsets, settings
ROBOT = shipped_parameters(RobotSimParameters, "robot_sim", world_file="-")   # the base: limits, odometry drift
SONAR = shipped_parameters(SonarParameters, "sonar_sim", world_file="-")     # noise, rays, specular loss
WALL_TAGS, SONAR_SENSOR = "wall_tags", "sonar_sim"    # the rig's sensors
START_BEFORE_TAG_M = 1.2                # a mission starts this far before its first tag
STILL_M = 0.5                           # MissionRun.still_s: within this of the final position


@dataclass(frozen=True)
class MissionStep:
    """What one control step of a mission gave: the truth, the odometry, the wall tags read and the node the
    executor believes the robot is at (for a localizer run beside it: rfidnav_experiments.reproduce.fused)."""
    time_s: float
    truth: tuple[float, float, float]
    odom: tuple[float, float, float]
    wall_reads: tuple[str, ...]
    current_node: str | None


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
    bumps: int = 0                         # times the base's bumper was pressed against a wall
    arrived: bool = False                  # the executor's success, wherever the robot stopped
    goal_distance_m: float = math.nan      # from where it stopped to the goal node's position
    wall_crossings: int = 0                # rfidnav_scenario.metrics.wall_crossings of the true track
    # What a failure is classified by (reproduce topological's failure taxonomy):
    stopped: bool = False                  # the follower stopped (else the mission ran out of time)
    believed_node: str | None = None       # where the executor last took the robot to be
    nearest_node: str | None = None        # the map node nearest to where it stopped (its position, ground truth)
    still_s: float = 0.0                   # how long before the end the robot stayed within STILL_M of its end
    bumped_at_end: bool = False            # the bumper was pressed when the mission ended
    goal_node: str | None = None
    passages_missed: int = 0               # ground truth: tag passages (in reach, then out) with no read at all


def follower_offsets(parameters: WallFollowerParameters = FOLLOWER) -> dict[str, float]:
    """Per rangefinder (``/sonar/NAME``: NAME) that feeds the follower, the offset the wall_follower node adds to
    its readings."""
    return {topic.rsplit("/", 1)[-1]: offset for topic, offset in zip(parameters.sonar_topics,
                                                                     parameters.sonar_offsets_m)}


def sonar_feeds(names: Sequence[str], offsets: dict[str, float],
                parameters: WallFollowerParameters = FOLLOWER) -> list[tuple[str, int, float]]:
    """Per field of the follower's Sonar, as the wall_follower node feeds it from ``parameters.sonar_topics``: the
    position in a reading of the rangefinders ``names`` of the one that feeds it, and the offset added."""
    feeding = [topic.rsplit("/", 1)[-1] for topic in parameters.sonar_topics]
    return [(field, names.index(name), offsets[name]) for field, name in zip(SONAR_FIELDS, feeding)]


def centre_sonar(readings: Sequence[float], feeds: list[tuple[str, int, float]]) -> Sonar:
    """The follower's Sonar (distances from the robot's centre) from the rangefinders' readings (inf stays inf)."""
    return Sonar(**{field: readings[index] + offset for field, index, offset in feeds})


@functools.lru_cache(maxsize=8)
def sonar_model_among(sonar: SonarParameters, walls: bytes) -> SonarModel:
    """The sonar model among ``walls`` (an N x 4 float array's bytes), made once for a floor's missions: its
    readings depend on the pose and the generator alone, and its grid of nearby walls takes a while to lay out."""
    return sonar.model(np.frombuffer(walls).reshape(-1, 4))


def start_pose_before_tag(world: World, tag_id: str, before_m: float = START_BEFORE_TAG_M,
                          wall_distance_m: float = FOLLOWER.wall_distance_m) -> tuple[float, float, float]:
    """A pose ``before_m`` before wall tag ``tag_id``, ``wall_distance_m`` out from its wall, heading so that the
    wall is on the left (tags are on the arriving robot's left wall): the robot then reads the tag first."""
    tag = next((tag for tag in world.wall_tags if tag.tag_id == tag_id), None)
    if tag is None:
        raise ValueError(f"tag '{tag_id}' is not on a wall of world '{world.name}'")
    heading = math.atan2(tag.normal[1], tag.normal[0]) + math.pi / 2.0     # the normal points to the robot's right
    x = tag.position[0] + wall_distance_m * tag.normal[0] - before_m * math.cos(heading)
    y = tag.position[1] + wall_distance_m * tag.normal[1] - before_m * math.sin(heading)
    return (x, y, math.remainder(heading, 2.0 * math.pi))


def run_mission(world: World, topological_map: TopologicalMap, start_pose: tuple[float, float, float],
                goal_node: str, rng: np.random.Generator, miss_probability: float = 0.0,
                max_time_s: float = 900.0, settings: WallFollowerSettings = FOLLOWER.settings(),
                weight: str = "length", recover_missed_tags: bool = True, robot: RobotSimParameters = ROBOT,
                sonar: SonarParameters = SONAR, observer: Callable[[MissionStep], None] | None = None) -> MissionRun:
    """One mission from ``start_pose`` (true pose) to ``goal_node``. ``observer`` is told of every control step
    (:class:`MissionStep`; it draws nothing)."""
    walls = world.wall_segments()
    sonar_model = sonar_model_among(sonar, walls.tobytes())
    feeds = sonar_feeds([r.name for r in sonar_model.rangefinders], follower_offsets())
    reader = WallTagReader(InductionArea(), world.wall_tags, passage_miss_probability=miss_probability)
    follower = WallFollower(settings)
    executor = MissionExecutor(topological_map, weight, recover_missed_tags)
    executor.start(goal_node)
    x, y, yaw = start_pose
    base = dataclasses.replace(robot, start_x=x, start_y=y, start_yaw_deg=math.degrees(yaw),
                               seed=int(rng.integers(2**31))).base(walls)
    control_period_s = 1.0 / FOLLOWER.control_rate_hz
    rig = Rig(base, robot.step_s, steps_per_sample(robot.step_s, FOLLOWER.control_rate_hz), {
        WALL_TAGS: ScheduledSensor(control_period_s, lambda truth, draw: reader.read(*truth, draw), rng),
        SONAR_SENSOR: ScheduledSensor(control_period_s, lambda truth, draw: sonar_model.readings(*truth, draw), rng)})
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

    tag_ids = [tag.tag_id for tag in reader.tags]
    in_passage = np.zeros(len(tag_ids), dtype=bool)
    read_in_passage = np.zeros(len(tag_ids), dtype=bool)
    passages_missed = 0
    for _ in range(int(round(max_time_s * FOLLOWER.control_rate_hz))):
        seen = rig.sample()
        truth, odom = seen.truth, seen.odom
        at_dead_end = executor.on_odometry(odom[0], odom[1])
        if at_dead_end is not None:
            apply(at_dead_end, False)
        reach = reader.in_reach(*truth)          # ground truth: the passages the reader missed
        reads = seen.readings[WALL_TAGS]
        ended = in_passage & ~reach
        passages_missed += int(np.count_nonzero(ended & ~read_in_passage))
        read_in_passage[~reach] = False
        for tag_id in reads:
            read_in_passage[tag_ids.index(tag_id)] = True
        in_passage = reach
        for decision in executor.on_reads(reads):
            apply(decision, False)
        if observer is not None:
            observer(MissionStep(seen.time_s, truth, odom, tuple(reads), executor.state.current_node))
        command = follower.step(centre_sonar(seen.readings[SONAR_SENSOR], feeds), OdomPose(*odom))
        if command.event == STOPPED:
            finished = True
            break
        if command.event in FOLLOWER_EVENTS:
            apply(executor.on_junction(command.event), True)
        rig.command(command.linear, command.angular, seen.time_s)
        rig.step()

    x, y = base.truth.x, base.truth.y
    t = rig.now_s
    state = executor.state
    outcome = state.outcome
    first_node = state.nodes_visited[0] if state.nodes_visited else None
    goal_xy = topological_map.nodes[goal_node].position
    near = goal_xy is not None and math.dist((x, y), goal_xy) <= GOAL_RADIUS_M
    # One position per control step, and the end's: a stop's counts twice (its control step's, and the end's).
    track = rig.positions + [(x, y)] if finished else rig.positions
    crossings = wall_crossings(np.array(track), walls)
    success = bool(outcome is not None and outcome.success and near and crossings == 0)
    if not finished:
        message = f"no stop within {max_time_s:.0f} s (last: {message})"
    elif outcome is not None and outcome.success and not near:
        message += f"; but stopped {math.dist((x, y), goal_xy):.2f} m from the goal node"
    if crossings:
        message += f"; but it {ground_truth_objection({'wall_crossings': crossings})}"
    # On the map as learned by the end: a goal reached through an explored "?" hallway has a route.
    shortest = (topological_shortest_m(executor.map, start_pose[:2], *state.first_arrival, goal_node)
                if state.first_arrival is not None else math.nan)
    arrived = bool(outcome is not None and outcome.success)
    positions = {name: node.position for name, node in topological_map.nodes.items() if node.position is not None}
    nearest = min(positions, key=lambda name: math.dist((x, y), positions[name]), default=None)
    away = [index for index, point in enumerate(track) if math.dist(point, (x, y)) > STILL_M]
    still_s = (len(track) - 1 - (away[-1] + 1 if away else 0)) * rig.sample_every * robot.step_s
    return MissionRun(success, message, base.distance_travelled_m, shortest, state.tags_missed, state.replans,
                      tuple(state.nodes_visited), t, (x, y), tuple(turns), first_node, base.bumps, arrived,
                      math.dist((x, y), goal_xy) if goal_xy is not None else math.nan, crossings, finished,
                      state.current_node, nearest, still_s, bool(base.bumped), goal_node,
                      passages_missed)


@dataclass(frozen=True)
class Method:
    """How the mission executor routes and what it does about a junction passed without its tag."""
    weight: str                            # "edges": fewest hallways (all the paper's robot knows); "length"
    recover_missed_tags: bool              # False: the paper's loop (follow on until the next tag)


METHODS = {"paper": Method("edges", False), "ours": Method("length", True)}


@dataclass(frozen=True)
class Floor:
    """A floor to run missions on: what the robot knows (the map) and the simulator's ground truth (the world)."""
    map_path: Path
    world_path: Path


FLOORS = {"building_large": Floor(LARGE_MAP, LARGE_WORLD), "building_eval": Floor(EVAL_MAP, EVAL_WORLD),
          "building_ring": Floor(RING_MAP, RING_WORLD)}
GENERATED_PREFIX = "generated_"         # a floor named generated_SEED is rfidnav_sim.floor_generator's of SEED


def generated_name(seed: int) -> str:
    return f"{GENERATED_PREFIX}{seed}"


@functools.lru_cache(maxsize=16)
def load_floor(floor: Floor | str) -> tuple[TopologicalMap, World]:
    """The map and world of a floor: an in-tree one (a :class:`Floor`, or its name in FLOORS), or a generated one
    by its name (``generated_SEED``: drawn again from the seed wherever it runs, so a worker needs no file)."""
    if isinstance(floor, str):
        if floor.startswith(GENERATED_PREFIX) and floor not in FLOORS:
            generated = generated_floor(int(floor.removeprefix(GENERATED_PREFIX)))
            return generated.topological_map, generated.world
        floor = FLOORS[floor]
    return load_topological_map(floor.map_path), load_world(floor.world_path)


def paper_run(rng: np.random.Generator, miss_probability: float = 0.0, method: Method = METHODS["ours"]) \
        -> MissionRun:
    """Paper 004 section 5: from before tag 23 (arriving at h from the West) to g (tag 19), a right turn at h."""
    return run_mission(load_world(FIG5_WORLD), load_topological_map(FIG5_MAP),
                       start_pose_before_tag(load_world(FIG5_WORLD), "23"), "g", rng, miss_probability,
                       weight=method.weight, recover_missed_tags=method.recover_missed_tags)


def mission_tasks(topological_map: TopologicalMap, count: int, seed: int) -> list[tuple[str, str]]:
    """``count`` (start tag, goal node) pairs, seeded: a tag on a mapped hallway and a node other than the tag's."""
    tags = sorted(tag for node in topological_map.nodes.values() for hallway in node.hallways.values()
                  if hallway.neighbour != UNKNOWN for tag in hallway.tags)
    choose = np.random.default_rng([seed, 0])
    tasks = []
    for _ in range(count):
        tag = tags[int(choose.integers(len(tags)))]
        start_node = topological_map.locate_tag(tag)[0]
        goals = [name for name in topological_map.nodes if name != start_node]
        tasks.append((tag, goals[int(choose.integers(len(goals)))]))
    return tasks


def random_missions(count: int, miss_probability: float, seed: int, floor: Floor | str = FLOORS["building_large"],
                    method: Method = METHODS["ours"], first: int = 0) -> list[MissionRun]:
    """Missions ``first`` .. ``first + count - 1`` of the floor's seeded task list (so a pool can share them out),
    each with its own generator: every method and miss rate meets the same starts, goals and sensor draws.
    ``floor``: a :class:`Floor` or a name (:func:`load_floor`)."""
    topological_map, world = load_floor(floor)
    tasks = mission_tasks(topological_map, first + count, seed)
    return [run_mission(world, topological_map, start_pose_before_tag(world, tag), goal,
                        np.random.default_rng([seed, index + 1]), miss_probability, weight=method.weight,
                        recover_missed_tags=method.recover_missed_tags)
            for index, (tag, goal) in enumerate(tasks) if index >= first]
