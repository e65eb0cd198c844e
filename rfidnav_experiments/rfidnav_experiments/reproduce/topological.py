"""``./rfidnav reproduce topological``: paper 004, in-process (rfidnav_experiments.runners.topological).

* The conditions: every setting the runs read and where it comes from (``paper``, with the section; ``paper,
  interpreted: ...`` where the value reads the paper one way of several; ``ours``, and why; one source per method
  where the methods differ; nothing here is fitted).
* The paper's run (section 5): from before tag 23 to tag 19 with a right turn, a 1.6 m passage, about 8 m.
* Missions between random (start tag, goal node) pairs at tag read-miss probabilities 0, 10, 20 and 30 % (per
  tag passage), on floors kept apart by their role in the evaluation ledger (``rfidnav_experiments.evaluation``):

  - EVALUATION: three floors of new layouts, ``generated_SEED`` for the ledger's three drawn seeds
    (``current("topological").seeds``), each drawn by ``rfidnav_sim.floor_generator`` from its seed and built by
    ``rfidnav_sim.building``; each floor's missions are drawn from the same seed. Nobody looked at them while
    designing; they are the result, per floor and pooled.
  - DEVELOPMENT, reported beside with fewer missions: ``building_eval`` (hand-drawn, seed 1001: the odometry gate
    was written after looking at six of its missions), ``building_ring`` (generated, seed 1802: three executor
    faults were fixed on it), ``building_large`` (the floor the stack was developed on, seed 7, at two rates).

  Every floor, miss rate and method faces the same missions with the same sensor and odometry draws (paired).
  "paper" is the paper's loop on the paper's knowledge: routes by fewest hallways (the paper's robot knows no
  lengths) and no recovery from a missed tag (it follows on until the next tag re-localizes it). "ours" routes
  by the map's lengths and carries the route's expectation through a junction passed without its tag, gated by
  the odometry distance (mission_executor). Both use our wall follower, the simulated base (walls stop it: a
  bump is counted) with drifting odometry, sonar with specular loss, and stop at the goal junction's centre.

Success: the executor arrived and the robot stopped within 0.5 m of the goal node (``GOAL_RADIUS_M``); every
rate with its 95 % Wilson interval, and beside it the success within 0.25, 0.5, 0.75 and 1.0 m of the same
missions. Path over shortest: ground-truth path length over the shortest path on the map (by length) from the
start, mean over the successful missions with its 95 % t-interval. The paired difference (ours minus the paper's
loop, mission by mission) of success and of mission time with its 95 % interval. Every failed evaluation mission
is put in one class of :func:`failure_cause` (what the run recorded: where it stopped, whether it stopped, the
bumper, the executor's belief), counted per method, with how many of them had missed a tag.

Nothing here asserts the targets: the command reports, the person reads. The exit code is 0 when ours meets the
evaluation's targets (pooled over the evaluation floors: >= 95 % success at 20 % misses, path <= 1.15 x
shortest), else 1.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from rfidnav_common.errors import ConfigError  # noqa: E402
from rfidnav_common.floor_plan import HALLWAY_WIDTH_M, TAG_SETBACK_M  # noqa: E402
from rfidnav_common.topological_map import UNKNOWN  # noqa: E402
from rfidnav_common.wall_tags import InductionArea  # noqa: E402
from rfidnav_experiments.engine import run_tasks  # noqa: E402
from rfidnav_experiments.evaluation import current  # noqa: E402
from rfidnav_experiments.reproduce.tables import (  # noqa: E402
    Condition,
    Interval,
    condition_json_rows,
    condition_lines,
    interpreted,
    paired_interval,
    save,
    table,
)
from rfidnav_experiments.runners.shipped import shipped_parameters  # noqa: E402
from rfidnav_experiments.runners.topological import (  # noqa: E402
    FOLLOWER,
    METHODS,
    ROBOT,
    SONAR,
    START_BEFORE_TAG_M,
    MissionRun,
    generated_name,
    load_floor,
    paper_run,
    random_missions,
)
from rfidnav_planning.mission_executor import EARLY_MARGIN  # noqa: E402
from rfidnav_planning.parameters import MissionExecutorParameters  # noqa: E402
from rfidnav_scenario.metrics import GOAL_RADIUS_M  # noqa: E402
from rfidnav_sim.floor_generator import RULES, write_floor  # noqa: E402

EXPERIMENT = "topological"
MISS_RATES = (0.0, 0.1, 0.2, 0.3)
MISSIONS = 100                          # per method and miss rate on each evaluation floor
EVALUATION_SET = current(EXPERIMENT)    # the ledger's fresh set: three drawn seeds, a floor and its missions each
EVALUATION_FLOORS = tuple(generated_name(seed) for seed in EVALUATION_SET.seeds)
EVALUATION = EVALUATION_FLOORS[0]       # the first evaluation floor (bench topological's)
LARGE, HAND_DRAWN, RING = "building_large", "building_eval", "building_ring"
DEVELOPMENT_FLOORS = (HAND_DRAWN, RING, LARGE)
FLOOR_ORDER = (*EVALUATION_FLOORS, *DEVELOPMENT_FLOORS)     # the order of runs, tables and rows
POOLED = "pooled"                       # the evaluation floors' missions together (rows' floor)
RATES = {**dict.fromkeys(EVALUATION_FLOORS, MISS_RATES), HAND_DRAWN: MISS_RATES, RING: MISS_RATES,
         LARGE: (0.0, 0.2)}
ROLES = {**dict.fromkeys(EVALUATION_FLOORS, "evaluation"), **dict.fromkeys(DEVELOPMENT_FLOORS, "development")}
HISTORY = {HAND_DRAWN: "drawn by hand; the evaluation floor until issue 31 (the odometry gate was written after "
                       "looking at six of its missions)",
           RING: "generated, a ring of our own (issue 18); three executor faults were fixed on it",
           LARGE: "generated from its map; the stack was developed and tuned on its missions of seed 7"}
SEEDS = {**dict(zip(EVALUATION_FLOORS, EVALUATION_SET.seeds)), HAND_DRAWN: 1001, RING: 1802, LARGE: 7}
# The development floors are reported beside at a fifth of the missions (the large floor at a tenth and two
# rates: its missions are long); before issue 31 they had 100 (building_large 50) and were the result.
MISSION_SHARE = {**dict.fromkeys(EVALUATION_FLOORS, 1), HAND_DRAWN: 5, RING: 5, LARGE: 10}
RADII_M = (0.25, 0.5, 0.75, 1.0)        # success within each of these of the goal node, from the same missions
CHUNK = 10                              # missions per task
TARGET_RATE, TARGET_SUCCESS_PCT, PATH_TARGET = 0.2, 95.0, 1.15   # ours, pooled evaluation (issue targets)
MAX_TIME_S = 900.0                      # run_mission's default: a mission not stopped by then failed
PAPER_RUN_SEED = 7


@dataclass(frozen=True)
class RateSummary:
    floor: str                          # a floor, or POOLED
    method: str
    miss_rate: float
    success: Interval                   # percent, Wilson
    path_ratio: Interval                # path / shortest over the successful missions
    duration_s: Interval                # over the successful missions
    mean_tags_missed: float             # by the executor's count (the paper's loop counts none)
    mean_replans: float
    bumps: int                          # bumper presses over all missions
    wall_crossings: int                 # of the missions' true tracks, over all missions
    arrived: Interval                   # percent: the executor's success wherever the robot stopped
    stop_distance_m: float | None       # median distance from the goal node where the arrived missions stopped
    within: tuple[Interval, ...] = ()   # success within each of RADII_M (percent, Wilson)
    mean_passages_missed: float = 0.0   # ground truth: tag passages with no read

    @property
    def missions(self) -> int:
        return self.success.n


# ---------------------------------------------------------------------------------------- conditions

# Where every setting the runs read comes from: every field of the parameters of the nodes the runs use (the base,
# the sonar, the follower, the executor; test_reproduce_topological checks each has a row), the wall-tag reader's
# model, the floors and the missions. (source, note); a source of None is given per method in PER_METHOD.
SOURCES: dict[str, tuple[str, str]] = {
    "mission_executor.weight": ("ours", "paper: fewest hallways (sec. 3: the robot knows the topology, no "
                                        "lengths); ours: the map's lengths (between node positions)"),
    "mission_executor.recover_missed_tags": ("ours", "paper: none (sec. 3's loop: follow on to the next tag); "
                                                     "ours: the route's expectation through an untagged junction"),
    "mission_executor.early_margin": ("ours", "ours only: a junction within max(1 m, 10 %) of the expected "
                                              "distance can be the expected node (odometry drift, node positions)"),
    "mission_executor.tag_to_node_m": ("ours", "the maps' tagging convention: 2.0 m on the generated floors (tags "
                                               "1 m before a 1.6 m junction square, read up to 0.2 m early), "
                                               "1.6-2.4 m in fact on the hand-drawn floor"),
    "mission_executor.map_file": ("ours", "each floor's topological map (world.floors)"),
    "wall_tag_reader.induction_area_m": ("paper", "Fig. 3: the reader's 40 x 100 cm induction area"),
    "wall_tag_reader.antenna": (interpreted("the area reaches 1 m from the robot's centre, to its left (the "
                                "followed wall)"), "sec. 4: 'the robot must move along the wall at a distance of "
                                "less than 1 m'; [x m, y m, bearing rad] in base_link"),
    "wall_tag_reader.miss_model": ("ours", "paper 004 does not mention read failures: a tag missed for its whole "
                                           "passage (drawn when it comes into reach), with missions.miss_rates"),
    "wall_tag_reader.round_miss_probability": ("ours", "no per-round misses: a tag in reach for ~40 rounds is "
                                                       "practically never missed by them"),
    "wall_tag_reader.unreadable_tags": ("ours", "none broken"),
    "robot_sim.world_file": ("ours", "each floor's world (world.floors), in memory for the generated ones"),
    "robot_sim.start_x": ("ours", "per mission: missions.start_before_tag_m (the world's ground truth)"),
    "robot_sim.start_y": ("ours", "as start_x"),
    "robot_sim.start_yaw_deg": ("ours", "as start_x: heading along the tag's wall, the wall on the left"),
    "robot_sim.seed": ("ours", "per mission, from the floor's seed and the mission's index (missions.seed)"),
    "robot_sim.rtf": ("ours", "DDS only: in-process the base is stepped as fast as it goes"),
    "robot_sim.step_participants": ("ours", "DDS only (the stepped clock)"),
    "robot_sim.start_paused": ("ours", "DDS only"),
    "robot_sim.map_to_odom_at_start": ("ours", "DDS only: the executor reads the odometry's distances, not poses"),
    "robot_sim.step_s": ("ours", "10 ms physics step, as over DDS"),
    "robot_sim.odom_rate_hz": ("ours", "unused in-process (the follower reads the odometry every control step)"),
    "robot_sim.track_width_m": ("ours", "a small differential-drive base"),
    "robot_sim.max_wheel_speed_mps": ("ours", "above every commanded speed"),
    "robot_sim.max_wheel_accel_mps2": ("ours", "a small base's"),
    "robot_sim.command_timeout_s": ("ours", "never reached: a command every control step"),
    "robot_sim.odom_left_scale_error": ("ours", "wheel odometry drift, as over DDS: the follower turns and "
                                                "measures by odometry, the executor's gate counts metres by it"),
    "robot_sim.odom_right_scale_error": ("ours", "as above"),
    "robot_sim.odom_track_scale_error": ("ours", "as above"),
    "robot_sim.odom_slip_std": ("ours", "as above"),
    "robot_sim.footprint_radius_m": ("ours", "a 34 cm round base (the paper's platform is 35 cm square, sec. 4); "
                                             "walls stop it and press its bumper"),
    "robot_sim.walls_stop_base": ("ours", "walls are obstacles"),
    "sonar_sim.world_file": ("ours", "as robot_sim.world_file"),
    "sonar_sim.seed": ("ours", "per mission, as robot_sim.seed"),
    "sonar_sim.rate_hz": ("ours", "in-process the sonar is read every control step (20 Hz)"),
    "sonar_sim.frame_prefix": ("ours", "names only"),
    "sonar_sim.noise_sd_m": ("ours", "timing jitter"),
    "sonar_sim.noise_fraction": ("ours", "speed-of-sound error"),
    "sonar_sim.rays_per_beam": ("ours", "rays over each 25-degree cone (Polaroid 6500-class, sec. 4: 5 m range)"),
    "sonar_sim.specular_angle_deg": ("ours", "smooth walls echo only near their normal (Leonard & Durrant-Whyte); "
                                             "40 degrees: painted plaster, chosen, not fitted"),
    "wall_follower.control_rate_hz": ("ours", "20 control steps a second"),
    "wall_follower.sonar_topics": ("ours", "five of the seven sonars (sec. 4, Fig. 8(a): seven at the front)"),
    "wall_follower.sonar_offsets_m": ("ours", "the layout's mounting offsets (rfidnav_sim.sonar_model)"),
    "wall_follower.sonar_timeout_s": ("ours", "DDS only"),
    "wall_follower.recover_after_s": ("ours", "blocked this long: turn away"),
    "wall_follower.wall_distance_m": ("paper", "sec. 4: 0.8 m from the left wall"),
    "wall_follower.speed_mps": ("ours", "0.2 m/s: the paper gives no speed"),
    "wall_follower.realign_every_m": ("paper", "sec. 4, Fig. 9: realign every 1 m"),
    "wall_follower.stop_distance_m": ("ours", "emergency stop"),
    "wall_follower.diagonal_stop_distance_m": ("ours", "emergency stop, diagonal sonars"),
    "wall_follower.opening_threshold_m": ("ours", "a side reading beyond this is an opening"),
    "wall_follower.junction_half_width_m": (interpreted("half the 1.6 m passage of sec. 5 taken as every "
                                            "junction's half width"), "sec. 5 gives one passage's width"),
    "wall_follower.turn_rate_radps": ("ours", "the base's yaw rate"),
    "wall_follower.heading_gain_per_s": ("ours", "heading hold"),
    "wall_follower.distance_gain": ("ours", "approach to the set distance"),
    "wall_follower.max_fit_residual_m": ("ours", "a line fit over each stretch (the paper: two readings)"),
    "wall_follower.sonar_half_angle_rad": ("ours", "the cone's half angle"),
    "world.floors": ("ours", "evaluation: floors of new layouts drawn by the ledger's seeds; development: the "
                             "in-tree floors (see their history)"),
    "world.generator": ("ours", "rfidnav_sim.floor_generator's rules: an irregular grid, a random spanning tree and "
                                "loops, '?' dead ends, tags as paper 004 places them (sec. 4, Fig. 4)"),
    "world.hallway_width_m": ("paper", "sec. 5: a 1.6 m-wide passage (the generated floors' every hallway)"),
    "world.tag_setback_m": (interpreted("sec. 4's tags 'near the junction' placed 1 m before its square, on the "
                            "arriving robot's left wall"), "generated floors; Fig. 4"),
    "missions.per_rate": ("ours", "the same missions for every rate and method; the development floors at a "
                                  "fifth (building_large a tenth) of the evaluation floors'"),
    "missions.seed": ("ours", "evaluation: the ledger's drawn seeds (the floor and its missions); development: "
                              "chosen by hand"),
    "missions.start_before_tag_m": ("ours", "put down in the corridor, before a wall tag, at 0.8 m from its wall"),
    "missions.max_time_s": ("ours", "a mission not stopped by then failed"),
    "missions.miss_rates": ("ours", "paper 004 does not mention read failures: the rates are ours"),
    "missions.success_radius_m": ("ours", "rfidnav_scenario.metrics.GOAL_RADIUS_M: the paper stops where the "
                                          "goal's tag is read and gives no radius; stopped within this of the goal "
                                          "node's position, and the executor arrived"),
    "missions.reported_radii_m": ("ours", "success within each of these radii, from the same missions"),
}
# Rows whose methods' values come from different places.
PER_METHOD = {"mission_executor.weight": {"paper": interpreted("fewest hallways, as the paper's map has no lengths "
                                                               "(sec. 3)"), "ours": "ours"},
              "mission_executor.recover_missed_tags": {"paper": "paper (sec. 3)", "ours": "ours"},
              "mission_executor.early_margin": {"paper": "paper (none)", "ours": "ours"}}
FILES = {"robot_sim": ROBOT, "sonar_sim": SONAR, "wall_follower": FOLLOWER}


def conditions(missions: int) -> list[Condition]:
    executors = {name: shipped_parameters(MissionExecutorParameters, "mission_executor", map_file="-",
                                          weight=method.weight, recover_missed_tags=method.recover_missed_tags)
                 for name, method in METHODS.items()}
    maps = {floor: load_floor(floor)[0] for floor in FLOOR_ORDER}
    area = InductionArea()
    same = {"world.floors": {floor: ROLES[floor] + ("" if floor not in HISTORY else f": {HISTORY[floor]}")
                             for floor in FLOOR_ORDER},
            "world.generator": {field.name: getattr(RULES, field.name) for field in dataclasses.fields(RULES)},
            "world.hallway_width_m": HALLWAY_WIDTH_M, "world.tag_setback_m": TAG_SETBACK_M,
            "missions.per_rate": {floor: missions_on(floor, missions) for floor in FLOOR_ORDER},
            "missions.seed": SEEDS, "missions.start_before_tag_m": START_BEFORE_TAG_M,
            "missions.max_time_s": MAX_TIME_S,
            "missions.miss_rates": {floor: list(RATES[floor]) for floor in FLOOR_ORDER},
            "missions.success_radius_m": GOAL_RADIUS_M, "missions.reported_radii_m": list(RADII_M),
            "wall_tag_reader.induction_area_m": [area.width_m, area.depth_m],
            "wall_tag_reader.antenna": [*area.position, area.bearing_rad],
            "wall_tag_reader.miss_model": "per passage", "wall_tag_reader.round_miss_probability": 0.0,
            "wall_tag_reader.unreadable_tags": [],
            "mission_executor.tag_to_node_m": {floor: maps[floor].tag_to_node_m for floor in FLOOR_ORDER},
            "mission_executor.map_file": "each floor's map",
            "robot_sim.world_file": "each floor's world", "sonar_sim.world_file": "each floor's world",
            "robot_sim.start_x": "per mission", "robot_sim.start_y": "per mission",
            "robot_sim.start_yaw_deg": "per mission", "robot_sim.seed": "per mission", "sonar_sim.seed": "per mission"}
    rows = []
    for key, (source, note) in SOURCES.items():
        node, field = key.split(".", 1)
        if key == "mission_executor.early_margin":
            values: dict[str, Any] = {"paper": None, "ours": list(EARLY_MARGIN)}
        elif key in same:
            values = dict.fromkeys(METHODS, same[key])
        elif node == "mission_executor":
            values = {name: getattr(executors[name], field) for name in METHODS}
        else:
            values = dict.fromkeys(METHODS, getattr(FILES[node], field))
        rows.append(Condition(key, values, source, note, PER_METHOD.get(key)))
    return rows


# ---------------------------------------------------------------------------------------------- runs

def missions_on(floor: str, missions: int) -> int:
    return max(1, missions // MISSION_SHARE[floor])


def missions_chunk(job: tuple[str, str, float, int, int]) -> tuple[str, str, float, int, list[MissionRun]]:
    """One task: ``count`` missions of a floor's list from ``first``."""
    floor, method, rate, first, count = job
    return floor, method, rate, first, random_missions(count, rate, SEEDS[floor], floor, METHODS[method],
                                                       first=first)


def mission_jobs(missions: int, floors: tuple[str, ...] = FLOOR_ORDER) -> list[tuple[str, str, float, int, int]]:
    """The tasks of ``missions`` per (floor, method, miss rate): chunks of CHUNK missions of each floor's list."""
    return [(floor, method, rate, first, min(CHUNK, missions_on(floor, missions) - first))
            for floor in floors for method in METHODS for rate in RATES[floor]
            for first in range(0, missions_on(floor, missions), CHUNK)]


def run_all(missions: int, floors: tuple[str, ...] = FLOOR_ORDER,
            label: str = "reproduce topological") -> dict[tuple[str, str, float], list[MissionRun]]:
    """Every mission, by (floor, method, miss rate), in the floor's mission order."""
    chunks: dict[tuple[str, str, float], list[tuple[int, list[MissionRun]]]] = {}
    for floor, method, rate, first, runs in run_tasks(missions_chunk, mission_jobs(missions, floors), label):
        chunks.setdefault((floor, method, rate), []).append((first, runs))
    return {key: [run for _, runs in sorted(parts, key=lambda part: part[0]) for run in runs]
            for key, parts in chunks.items()}


def with_pooled(results: dict[tuple[str, str, float], list[MissionRun]]) \
        -> dict[tuple[str, str, float], list[MissionRun]]:
    """The results with the evaluation floors' missions together under POOLED (floor by floor, in order)."""
    pooled = {(POOLED, method, rate): [run for floor in EVALUATION_FLOORS for run in results[(floor, method, rate)]]
              for method in METHODS for rate in MISS_RATES}
    return {**results, **pooled}


def within(run: MissionRun, radius_m: float) -> bool:
    """Success against ``radius_m``: the executor arrived, within the radius of the goal node, no wall crossed
    (at GOAL_RADIUS_M, ``run.success``)."""
    return run.arrived and run.goal_distance_m <= radius_m and run.wall_crossings == 0


def summarise(floor: str, method: str, rate: float, runs: list[MissionRun]) -> RateSummary:
    ok = [run for run in runs if run.success]
    return RateSummary(floor, method, rate, Interval.of_proportion(len(ok), len(runs)),
                       Interval.of([run.path_length_m / run.shortest_path_m for run in ok]),
                       Interval.of([run.duration_s for run in ok]),
                       float(np.mean([run.tags_missed for run in runs])), float(np.mean([run.replans for run in runs])),
                       sum(run.bumps for run in runs), sum(run.wall_crossings for run in runs),
                       Interval.of_proportion(sum(run.arrived for run in runs), len(runs)),
                       float(np.median([run.goal_distance_m for run in runs if run.arrived]))
                       if any(run.arrived for run in runs) else None,
                       tuple(Interval.of_proportion(sum(within(run, radius) for run in runs), len(runs))
                             for radius in RADII_M),
                       float(np.mean([run.passages_missed for run in runs])))


def paired(results: dict[tuple[str, str, float], list[MissionRun]], floor: str, rate: float,
           figure: str) -> Interval:
    """Ours minus the paper's loop, mission by mission: success (percentage points) or time [s, both succeeded]."""
    def values(method: str) -> dict[int, float | None]:
        runs = results[(floor, method, rate)]
        if figure == "success":
            return {index: 100.0 * run.success for index, run in enumerate(runs)}
        return {index: run.duration_s if run.success else None for index, run in enumerate(runs)}
    return paired_interval(values("ours"), values("paper"))


# ------------------------------------------------------------------------------------- failure causes

# The causes, by the code the rows carry (a quoted figure selects a row by it), and what each means.
WRONG_JUNCTION, NEAR_GOAL, FAR_FROM_GOAL, GAVE_UP = "wrong_junction", "near_goal", "far_from_goal", "gave_up"
HELD_AT_WALL, STANDING, LOST, DRIVING, CROSSED_WALL = "held_at_wall", "standing", "lost", "driving", "crossed_wall"
CAUSE_TEXT = {
    WRONG_JUNCTION: "arrived by its account at the wrong junction",
    NEAR_GOAL: f"arrived, stopped {GOAL_RADIUS_M:g}-{max(RADII_M):g} m from the goal node",
    FAR_FROM_GOAL: f"arrived, stopped beyond {max(RADII_M):g} m of the goal node, nearest to it",
    GAVE_UP: "stopped, the executor giving up (no mapped route)",
    HELD_AT_WALL: "timed out, held at a wall (bumper pressed at the end)",
    STANDING: "timed out, standing still (no bumper)",
    LOST: "timed out, driving on, lost (believed elsewhere than the nearest node)",
    DRIVING: "timed out, driving on",
    CROSSED_WALL: "crossed a wall (ground truth)",
}
CAUSES = tuple(CAUSE_TEXT)
STANDING_S = 60.0                       # a timed-out robot within STILL_M of its end for this long stood still


def failure_cause(run: MissionRun) -> str | None:
    """The one class of a failed mission (None for a success), from what the run recorded, first match: a wall
    crossed; arrived by the executor's account (at a junction other than the goal's, or too far from the goal's
    node); stopped without arriving; not stopped within the time (held at a wall, standing still, lost, or driving
    on)."""
    if run.success:
        return None
    if run.wall_crossings:
        return CROSSED_WALL
    if run.arrived:
        if run.nearest_node != run.goal_node:
            return WRONG_JUNCTION
        return NEAR_GOAL if run.goal_distance_m <= max(RADII_M) else FAR_FROM_GOAL
    if run.stopped:
        return GAVE_UP
    if run.bumped_at_end:
        return HELD_AT_WALL
    if run.still_s >= STANDING_S:
        return STANDING
    return LOST if run.believed_node != run.nearest_node else DRIVING


def failure_counts(results: dict[tuple[str, str, float], list[MissionRun]], floors: tuple[str, ...]) \
        -> dict[str, dict[str, tuple[int, int]]]:
    """Per method, per cause: (failures, of them with a tag passage missed: ground truth, whether the executor
    noticed or not), over every mission of ``floors`` at every rate; every cause listed (zeros too)."""
    counts: dict[str, dict[str, tuple[int, int]]] = {}
    for method in METHODS:
        runs = [run for (floor, name, _), runs in results.items() if floor in floors and name == method
                for run in runs]
        causes = Counter(failure_cause(run) for run in runs)
        missed = Counter(failure_cause(run) for run in runs if run.passages_missed)
        counts[method] = {cause: (causes[cause], missed[cause]) for cause in CAUSES}
    return counts


# ------------------------------------------------------------------------------------------- report

def pooled_ours(summaries: list[RateSummary]) -> RateSummary:
    return next(s for s in summaries if (s.floor, s.method, s.miss_rate) == (POOLED, "ours", TARGET_RATE))


def target_met(summaries: list[RateSummary]) -> bool:
    ours = pooled_ours(summaries)
    return (ours.success.mean is not None and ours.success.mean >= TARGET_SUCCESS_PCT
            and ours.path_ratio.mean is not None and ours.path_ratio.mean <= PATH_TARGET)


def floor_title(floor: str) -> str:
    if floor == POOLED:
        return f"the {len(EVALUATION_FLOORS)} evaluation floors pooled ({', '.join(EVALUATION_FLOORS)})"
    return f"{floor} ({ROLES[floor]}, seed {SEEDS[floor]}{'' if floor not in HISTORY else '; ' + HISTORY[floor]})"


def floor_table(floor: str, summaries: list[RateSummary],
                results: dict[tuple[str, str, float], list[MissionRun]]) -> list[str]:
    rows = []
    for s in summaries:
        if s.floor != floor:
            continue
        difference = paired(results, floor, s.miss_rate, "success") if s.method == "ours" else None
        rows.append([s.method, f"{s.miss_rate * 100:g} %", s.success.text(1.0, 0),
                     s.path_ratio.text(1.0, 3), s.duration_s.text(1.0, 0),
                     f"{s.mean_passages_missed:.2f} / {s.mean_tags_missed:.2f}",
                     f"{s.mean_replans:.2f}", str(s.bumps), str(s.wall_crossings),
                     "-" if difference is None else difference.text(1.0, 1),
                     s.arrived.text(1.0, 0), "-" if s.stop_distance_m is None else f"{s.stop_distance_m:.2f}",
                     " / ".join("-" if w.mean is None else f"{w.mean:.0f}" for w in s.within)])
    return [f"{floor_title(floor)}: success % [95 % Wilson interval] (stopped within {GOAL_RADIUS_M} m of the goal "
            "node), path / shortest and time over the successful missions (± 95 %); ours minus paper, paired by "
            "mission; tag passages missed (truth) / missed tags the executor noticed, a mission; arrived: the "
            "executor's success wherever it stopped, and the median distance from the node "
            f"where those stopped; success within {' / '.join(f'{r:g}' for r in RADII_M)} m",
            *table(["method", "tag misses", "success %", "path / shortest", "time s", "missed / noticed", "replans",
                    "bumps", "wall crossings", "success: ours - paper", "arrived %", "stop m", "within radii %"],
                   rows)]


def failure_lines(counts: dict[str, dict[str, tuple[int, int]]], missions: dict[str, int]) -> list[str]:
    rows = [[CAUSE_TEXT[cause], *(f"{counts[method][cause][0]} ({counts[method][cause][1]})" for method in METHODS)]
            for cause in CAUSES]
    rows.append(["all failures", *(f"{sum(c for c, _ in counts[method].values())} of {missions[method]}"
                                   for method in METHODS)])
    return ["failures of the evaluation missions (every floor and rate) by cause: count (of them with a tag passage "
            "missed)",
            *table(["cause", *METHODS], rows)]


def report_lines(paper: MissionRun, summaries: list[RateSummary], results,
                 condition_rows: list[Condition]) -> list[str]:
    turns = ", ".join(f"{action} at {node}" for node, action in paper.turns) or "none"
    ours = pooled_ours(summaries)
    lines = ["reproduce topological: paper 004, in-process", "", *condition_lines(condition_rows, list(METHODS)), "",
             f"The paper's run (tag 23 -> tag 19, building_fig5, ours): {'success' if paper.success else 'FAILED'} "
             f"({paper.message}); turns: {turns}; driven {paper.path_length_m:.1f} m, shortest "
             f"{paper.shortest_path_m:.1f} m (paper: a right turn, 1.6 m passage, about 8 m)", ""]
    for floor in (POOLED, *FLOOR_ORDER):
        lines += [*floor_table(floor, summaries, results), ""]
    counts = failure_counts(results, EVALUATION_FLOORS)
    evaluated = {method: sum(len(runs) for (floor, name, _), runs in results.items()
                             if floor in EVALUATION_FLOORS and name == method) for method in METHODS}
    lines += [*failure_lines(counts, evaluated), ""]
    met = "met" if target_met(summaries) else "NOT met"
    lines.append(f"target (ours, evaluation floors pooled, {TARGET_RATE * 100:g} % misses: success >= "
                 f"{TARGET_SUCCESS_PCT:g} %, path <= {PATH_TARGET} x shortest): {met} — success "
                 f"{ours.success.text(1.0, 0)}, path {ours.path_ratio.text(1.0, 3)}")
    return lines


def json_rows(paper: MissionRun, summaries: list[RateSummary], results,
              condition_rows: list[Condition]) -> list[dict[str, Any]]:
    rows = condition_json_rows(EXPERIMENT, condition_rows)
    rows.append({"experiment": "paper_run", "setting": {"from_tag": "23", "goal": "g"}, "metric": "path_length_m",
                 "ours": paper.path_length_m, "paper": 8.0, "success": paper.success})
    for s in summaries:
        setting = {"floor": s.floor, "role": "evaluation" if s.floor == POOLED else ROLES[s.floor],
                   "seed": list(EVALUATION_SET.seeds) if s.floor == POOLED else SEEDS[s.floor], "method": s.method,
                   "miss_rate": s.miss_rate, "missions": s.missions}
        figures: list[tuple[str, Any]] = [
            ("missions", s.missions),
            ("success_pct", s.success.mean), ("success_ci95_pct", list(s.success.bounds or ())),
            ("success_ci95_low_pct", s.success.bounds[0] if s.success.bounds else None),
            ("success_ci95_high_pct", s.success.bounds[1] if s.success.bounds else None),
            ("path_over_shortest", s.path_ratio.mean), ("path_over_shortest_ci95", s.path_ratio.half_width),
            ("mean_duration_s", s.duration_s.mean), ("mean_tags_missed", s.mean_tags_missed),
            ("mean_passages_missed", s.mean_passages_missed),
            ("bumps", s.bumps), ("wall_crossings", s.wall_crossings),
            ("arrived_pct", s.arrived.mean), ("median_stop_distance_m", s.stop_distance_m)]
        if s.method == "ours":
            for figure in ("success", "time"):
                difference = paired(results, s.floor, s.miss_rate, figure)
                figures += [(f"paired_{figure}_difference", difference.mean),
                            (f"paired_{figure}_difference_ci95", difference.half_width)]
        rows += [{"experiment": "random_missions", "setting": dict(setting), "metric": metric, "ours": value,
                  "paper": None} for metric, value in figures]
        for radius, success in zip(RADII_M, s.within):
            rows += [{"experiment": "success_radius", "setting": {**setting, "radius_m": radius}, "metric": metric,
                      "ours": value, "paper": None}
                     for metric, value in (("success_within_pct", success.mean),
                                           ("success_within_ci95_pct", list(success.bounds or ())),
                                           ("success_within_ci95_low_pct",
                                            success.bounds[0] if success.bounds else None),
                                           ("success_within_ci95_high_pct",
                                            success.bounds[1] if success.bounds else None))]
    # The failures by cause: over the evaluation (set "evaluation"), and on each development floor apart.
    for name, floors in (("evaluation", EVALUATION_FLOORS), *((floor, (floor,)) for floor in DEVELOPMENT_FLOORS)):
        for method, causes in failure_counts(results, floors).items():
            for cause, (count, missed) in causes.items():
                setting = {"set": name, "method": method, "cause": cause, "means": CAUSE_TEXT[cause]}
                rows += [{"experiment": "failures", "setting": dict(setting), "metric": metric, "ours": value,
                          "paper": None}
                         for metric, value in (("failures", count), ("failures_with_missed_tag", missed))]
            missions = [run for key, runs in results.items() if key[0] in floors and key[1] == method
                        for run in runs]
            rows += [{"experiment": "failures", "setting": {"set": name, "method": method}, "metric": metric,
                      "ours": value, "paper": None}
                     for metric, value in (("missions", len(missions)),
                                           ("failures_total", sum(not run.success for run in missions)))]
    rows += floor_rows()
    return rows


def floor_rows() -> list[dict[str, Any]]:
    """What each floor is: junctions, hallways, mapped dead ends (junctions with one hallway), '?' dead ends,
    nodes with no side opening (hallways only ahead and behind), tags, and the hallways' length."""
    rows = []
    for floor in FLOOR_ORDER:
        robot_map, world = load_floor(floor)
        mapped = {name: [side for side, hallway in node.hallways.items() if hallway.neighbour != UNKNOWN]
                  for name, node in robot_map.nodes.items()}
        figures = {"junctions": len(robot_map.nodes), "hallways": len(robot_map.edges()),
                   "dead_end_nodes": sum(len(sides) == 1 for sides in mapped.values()),
                   "unknown_sides": sum(hallway.neighbour == UNKNOWN for node in robot_map.nodes.values()
                                        for hallway in node.hallways.values()),
                   "straight_through_nodes": sum(len(node.hallways) == 2 and set(node.hallways) in ({"N", "S"},
                                                                                                  {"E", "W"})
                                                 for node in robot_map.nodes.values()),
                   "wall_tags": len(world.wall_tags),
                   "hallway_length_m": sum(robot_map.hallway_length_m(edge.node_a, edge.side_a)
                                           for edge in robot_map.edges()),
                   "north_deg": robot_map.north_deg}
        setting = {"floor": floor, "role": ROLES[floor], "seed": SEEDS[floor]}
        rows += [{"experiment": "floors", "setting": dict(setting), "metric": metric, "ours": value, "paper": None}
                 for metric, value in figures.items()]
    return rows


# -------------------------------------------------------------------------------------------- plots

def plot_summaries(summaries: list[RateSummary], out_dir: Path) -> Path:
    """Success and path ratio against the miss rate (the pooled evaluation solid, the development floors dashed),
    success against the radius (pooled evaluation), 95 % intervals, n on the legend; the evaluation floors below,
    walls, tags and maps to scale."""
    figure, axes = plt.subplots(2, 3, figsize=(17, 10))
    labels = {"paper": "paper's loop (edges, no recovery)", "ours": "ours (lengths, recovery)"}
    styles = {POOLED: "-", HAND_DRAWN: "--", RING: "-.", LARGE: ":"}
    for floor, style in styles.items():
        for method, label in labels.items():
            mine = [s for s in summaries if s.floor == floor and s.method == method]
            if not mine:
                continue
            rates = np.array([s.miss_rate * 100 for s in mine]) + (0.6 if method == "ours" else -0.6)
            success = np.array([s.success.mean for s in mine], dtype=float)
            bounds = np.array([s.success.bounds for s in mine], dtype=float)
            yerr = np.maximum(0.0, [success - bounds[:, 0], bounds[:, 1] - success])
            name = "evaluation (pooled)" if floor == POOLED else f"{floor} (development)"
            axes[0, 0].errorbar(rates, success, yerr=yerr, fmt="o", linestyle=style, capsize=3,
                                label=f"{label}, {name} (n={mine[0].missions})")
            ratio = np.array([np.nan if s.path_ratio.mean is None else s.path_ratio.mean for s in mine])
            width = np.array([0.0 if s.path_ratio.half_width is None else s.path_ratio.half_width for s in mine])
            axes[0, 1].errorbar(rates, ratio, yerr=width, fmt="o", linestyle=style, capsize=3,
                                label=f"{label}, {name}")
    axes[0, 0].axhline(TARGET_SUCCESS_PCT, color="grey", linestyle="--", linewidth=0.8)
    axes[0, 0].set(xlabel="tag read misses per passage [%]", ylabel="missions reaching the goal [%] (95 % Wilson)",
                   ylim=(0, 105), title="Success against read failures")
    axes[0, 0].legend(fontsize=6, loc="lower left")
    axes[0, 1].axhline(PATH_TARGET, color="grey", linestyle="--", linewidth=0.8, label=f"target {PATH_TARGET}")
    axes[0, 1].set(xlabel="tag read misses per passage [%]", ylabel="path / shortest, successful (± 95 %)",
                   title="Path length")
    axes[0, 1].legend(fontsize=6)
    for method, label in labels.items():
        for rate in MISS_RATES:
            s = next(s for s in summaries if (s.floor, s.method, s.miss_rate) == (POOLED, method, rate))
            axes[0, 2].plot(RADII_M, [w.mean for w in s.within], marker="o",
                            linestyle="-" if method == "ours" else "--",
                            label=f"{label}, {rate * 100:g} %")
    axes[0, 2].axvline(GOAL_RADIUS_M, color="grey", linewidth=0.8)
    axes[0, 2].set(xlabel="success radius [m]", ylabel="missions reaching the goal [%]", ylim=(0, 105),
                   title="Success against the radius (evaluation, pooled)")
    axes[0, 2].legend(fontsize=6, loc="lower right")
    for axis, floor in zip(axes[1], EVALUATION_FLOORS):
        robot_map, world = load_floor(floor)
        for x1, y1, x2, y2 in world.walls:
            axis.plot([x1, x2], [y1, y2], color="black", linewidth=1.0)
        positions = {name: node.position for name, node in robot_map.nodes.items() if node.position is not None}
        for edge in robot_map.edges():
            if edge.node_a in positions and edge.node_b in positions:
                (xa, ya), (xb, yb) = positions[edge.node_a], positions[edge.node_b]
                axis.plot([xa, xb], [ya, yb], color="tab:blue", linestyle="--", linewidth=0.6)
        for name, (x, y) in positions.items():
            axis.annotate(name, (x, y), textcoords="offset points", xytext=(3, 3), color="tab:blue", fontsize=7)
        for tag in world.wall_tags:
            axis.plot(*tag.position, "s", color="tab:orange", markersize=2)
        axis.set_aspect("equal", adjustable="datalim")
        axis.set_title(f"{floor} (evaluation; North {robot_map.north_deg:g} deg)", fontsize=9)
    return save(figure, out_dir / "topological_missions.png", dpi=100)


# --------------------------------------------------------------------------------------------- verb

def write_floors(out_dir: Path) -> Path:
    """The evaluation floors' map and world files, for the record (the runs draw them again from their seeds)."""
    folder = out_dir / "topological_floors"
    folder.mkdir(parents=True, exist_ok=True)
    for floor in EVALUATION_FLOORS:
        write_floor(SEEDS[floor], folder / f"{floor}_map.yaml", folder / f"{floor}_world.yaml")
    return folder


def reproduce_topological(missions: int, out_dir: Path, as_json: bool) -> int:
    """Run, report and plot; 0 when ours meets the evaluation's target, else 1."""
    if missions < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {missions}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    condition_rows = conditions(missions)
    paper = paper_run(np.random.default_rng(PAPER_RUN_SEED))
    results = with_pooled(run_all(missions))
    summaries = [summarise(floor, method, rate, results[(floor, method, rate)])
                 for floor in (POOLED, *FLOOR_ORDER) for method in METHODS
                 for rate in (MISS_RATES if floor == POOLED else RATES[floor])]
    rows = json_rows(paper, summaries, results, condition_rows)
    (out_dir / "topological_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    plot = plot_summaries(summaries, out_dir)
    floors = write_floors(out_dir)
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join(report_lines(paper, summaries, results, condition_rows)))
    print(f"plot: {plot}; rows: {out_dir / 'topological_rows.json'}; evaluation floors: {floors}", file=notes)
    return 0 if target_met(summaries) else 1

