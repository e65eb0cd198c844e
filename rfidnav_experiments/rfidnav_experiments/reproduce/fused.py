"""``./rfidnav reproduce fused``: the fused localizer (rfidnav_localization.fused) beside each paper's own
localizer, on the same runs, paired.

Worlds: paper 003's homes (HOMES of reproduce two_tier: the in-tree flat and two of ours), the mixed floor (ours:
every kind of tag on one floor), paper 000's field, paper 004's ring and paper 001's hallway. On the homes and the
mixed floor each run is the two-tier navigator's mission from the scenario's start to its goal, its legs planned
round the map's walls, driven by the paper's localizer (WiFi fingerprints, then floor tag groups, dead reckoning
between) with the scenario's reader; the fused localizers ride beside it on what the same sensors gave in each
reader round (every antenna's reads, the location server's answers to the navigator's locate calls, the compass, the
odometry). On paper 000's field (``partition_field``) each run is a 3 m task of the partition navigator on the
paper's localizer, the fused localizers beside it on the same rounds (its robot has no compass and no WiFi). On
paper 004's ring (``building_ring``) each run is one of the mission executor's missions, the fused localizers beside
it on the side antenna's wall tags and the odometry, scored with the node the executor believes the robot is at. On
paper 001's hallway (Figs. 12/13) each run is the tag route follower's whole route under the seven ceiling tags, the
fused localizers beside it on the two receiving antennas' phases, the floor tags under the ceiling tags and the
odometry; the follower keeps no pose, so the robot's own idea of where it is, scored as the paper's, is its odometry
from the known start. Two worlds where the fused localizer drives: ``partition_field_fused``, the same tasks as paper
000's field, the partition navigator driving on the fused estimate (rfid_localizer's status, through the same
conversions as over DDS: runners.fused.FusedPartitions) with its settings for a pose estimate, paper 000's localizer
beside; and ``mixed_floor_fused``, pose_navigator driving on it across the mixed floor. The fused settings are
those of the robot's rfid_localizer parameter file (the filter's the same for every robot and world). Every fused
localizer starts, as the paper's does, knowing only the map: global localization from its first evidence.

Localizers: ``fused`` (every kind of evidence), on the mixed floor also the same filter given one kind of evidence
and the compass (``floor_only``: lattice and tag-group reads, paper 000's and 003's tier two; ``phase_only``:
ceiling tags, paper 001; ``wall_only``: wall tags, paper 004; ``wifi_only``: paper 003's tier one), and ``paper``
(the two-tier navigator's own estimate). A ``kidnap`` run of the fused filter is told at KIDNAP_AT_S, confidently,
that the robot stands half the floor away in x and in y, facing the other way (a wrong /initialpose:
runners.fused.kidnapped); the figures give how long it takes to find the robot again. A ``late`` one starts at
LATE_START_S, mid-mission, with no idea where the robot is (a second global localization, away from the start).

Per run and localizer: the position and heading RMSE over the rounds it had an estimate, the fix rate (the share
of rounds it had one), the share of rounds whose NEES lies in its two-sided 95 % chi-square band (consistency);
the time global localization took (error below 0.5 m for 5 s, from the start) and the kidnap's recovery time (the
same, from the kidnap). A localizer that reports a heading only some of the time (paper 000's, after a straight
stretch) is also set beside the others on its own rounds: the heading RMSE over the rounds the paper had one. Per
world: means with 95 % intervals over the runs, and the paired difference of each localizer less the fused one.

The conditions first (:func:`conditions`): every physical setting of the runs with where it comes from, read from
the parameter objects the runs use: the fused filter of each robot's rfid_localizer file (one column per robot), the
readers the runs read through (one column per reader file, each field's source per reader), paper 003's navigator,
sensors, matcher and base as reproduce two_tier lists them, pose_navigator's, what each world runs, and the
experiment's own settings.

Development and evaluation apart: the code and its settings were chosen on DEVELOPMENT_SEED; the command reports
EVALUATION_SEED, the seed of the evaluation set the ledger (rfidnav_experiments.evaluation) holds for fused, never
used to tune anything (seed 401, reported before issue 31, is a development set since a model change was made after
its figures were seen). The report and the conditions' ``runs.seed`` row say which set the seed belongs to.

With ``--json`` (and always in ``fused_rows.json``) the rows ``{"experiment", "setting", "metric", "ours",
"paper"}``, the conditions first (metric "condition"); each figure's setting names its ``world`` and ``localizer``
(``fused``, a single kind, ``paper``, or a paired difference ``NAME-fused``), the seed and the runs; "paper" is null
(no paper reports these figures).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scipy import stats

from rfidnav_common.errors import ConfigError
from rfidnav_common.robot_map import RouteMap, load_route_map
from rfidnav_common.seeding import derive_seed, rng_for
from rfidnav_common.tag_lattice import Deployment
from rfidnav_common.topological_map import load_topological_map
from rfidnav_experiments import evaluation
from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce import two_tier
from rfidnav_experiments.reproduce.partitions import FILTER, PAPER, headline_level, robot_speeds
from rfidnav_experiments.reproduce.partitions import localizer_settings as partition_localizer_settings
from rfidnav_experiments.reproduce.partitions import navigator_settings as partition_navigator_settings
from rfidnav_experiments.reproduce.tables import (
    Condition,
    Interval,
    condition_json_rows,
    condition_lines,
    paired_interval,
    table,
)
from rfidnav_experiments.reproduce.two_tier import HOMES, Home, home
from rfidnav_experiments.runners.fused import (
    CONVERGED_FOR_S,
    CONVERGED_M,
    Beside,
    FusedPartitions,
    PartitionBeside,
    PartitionDriving,
    Rider,
    RouteBeside,
    TopologicalBeside,
    Track,
    drive_on_fused,
)
from rfidnav_experiments.runners.partitions import random_task, run_navigation
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_experiments.runners.tag_route import controller_parameters, run_tag_route
from rfidnav_experiments.runners.topological import FLOORS, mission_tasks, run_mission, start_pose_before_tag
from rfidnav_experiments.runners.topological import FOLLOWER as TOPOLOGICAL_FOLLOWER
from rfidnav_experiments.runners.topological import ROBOT as TOPOLOGICAL_ROBOT
from rfidnav_experiments.runners.topological import SONAR as TOPOLOGICAL_SONAR
from rfidnav_experiments.runners.two_tier import SETTINGS, run_two_tier
from rfidnav_localization.fused.filter import FusedSettings
from rfidnav_localization.fused.localizer import FusedLocalizer
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.parameters import RfidLocalizerParameters
from rfidnav_localization.partition import PartitionLocalizer
from rfidnav_planning.parameters import PoseNavigatorParameters
from rfidnav_planning.pose_navigation import PoseNavigator
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario
from rfidnav_sim.parameters import ReaderParameters, WifiSimParameters
from rfidnav_sim.world import load_world

EXPERIMENT = "fused"
RUNS = 10
DEVELOPMENT_SEED = 1
EVALUATION = evaluation.current(EXPERIMENT)   # the ledger's one evaluation set of this reproduction...
EVALUATION_SEED = EVALUATION.seeds[0]         # ...its seed: what the command reports, never used to tune
MIXED = "mixed_floor"
PARTITIONS = "partition_field"
RING = "building_ring"
HALLWAY = "hallway"
DRIVING = "mixed_floor_fused"      # the fused pose drives the robot (pose_navigator), in-process
PARTITION_DRIVING = "partition_field_fused"   # the fused pose drives paper 000's partition navigator
TIER_ONE = tuple(f"{name}_fused" for name in HOMES)   # paper 003's navigator takes tier one from the fused pose
DRIVING_WORLDS = (*TIER_ONE, PARTITION_DRIVING, DRIVING)   # the fused pose in the loop (none kidnapped nor late)
WORLDS = (*HOMES, MIXED, PARTITIONS, RING, HALLWAY, *DRIVING_WORLDS)
# Their figures include arrival and the true final error: the paper's navigators on their own localizers, and each
# navigator with the fused localizer in the loop, on the same missions.
ARRIVING_WORLDS = (*HOMES, PARTITIONS, *DRIVING_WORLDS)
UHF_2ANT_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_uhf_2ant.yaml"
WALL_SIDE_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_wall_side.yaml"
# Paper 000: the partition navigator with the paper's localizer drives tasks of this length across the field (the
# scenario's world, r = 20 cm), with this much relative odometry noise (the fused filter's motion model needs
# some; the paper's simulated motion is exact).
PARTITION_TASK_M = 3.0
PARTITION_ODOMETRY_NOISE = 0.02
FLOOR_LATTICE_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_floor_lattice.yaml"
# Paper 003's robot: its rfid_localizer file where the scenario runs none (the homes).
HF_FLOOR_LOCALIZER = CONFIG_DIR / "params" / "rfid_localizer_hf_floor.yaml"
SINGLE_EVIDENCE = {"floor_only": ("floor", "compass"), "phase_only": ("phase", "compass"),
                   "wall_only": ("wall", "compass"), "wifi_only": ("wifi", "compass")}
KIDNAP_AT_S = 30.0
PARTITION_KIDNAP_AT_S = 5.0        # a 3 m task takes ~20 s
PARTITION_LATE_START_S = 3.0
LATE_START_S = 20.0        # a second global localization, out of the start's room (a mission takes 50-250 s)
NEES_BAND = 0.95


# ---------------------------------------------------------------------------------------- conditions

PARAMS = CONFIG_DIR / "params"
# The fused filter's columns: each robot's rfid_localizer file, and the readers the runs read through (paper 000's
# field and paper 004's ring run their runners' own read models: see world.*).
LOCALIZER_FILES = {robot: PARAMS / f"rfid_localizer_{robot}.yaml"
                   for robot in ("hf_floor", "mixed", "floor_lattice", "wall_side", "uhf_2ant")}
READER_FILES = {robot: PARAMS / f"reader_{robot}.yaml" for robot in ("hf_floor", "mixed", "uhf_2ant")}
OURS_FILTER = "ours: the fused filter's"
LOCALIZER_SOURCES: dict[str, tuple[str, str]] = {
    "initial_pose": ("ours", "empty: every localizer starts knowing only the map, as the papers' do"),
    "initial_sd": ("ours", "unused without an initial_pose (a kidnap is told 10 cm / 0.05 rad)"),
    "particles": ("ours", "1,000: a round with every kind of evidence within 5 ms (bench fused)"),
    "odometry_noise_m": ("ours", "the motion model's random walk over a metre (its spread independent of the rate)"),
    "turn_noise_fraction": ("ours", "of a turn"),
    "heading_noise_rad": ("ours", "heading drift over a metre"),
    "odometry_scale_sd": ("paper", "paper 003 sec. 4.1: 1 m off per 20 m with a load (5 %): the prior's sd"),
    "odometry_scale_walk": ("ours", "a scale that never moves collapses after a few resamplings"),
    "antenna_positions": ("ours", "the robot's reader's own (its file: a test checks each against it)"),
    "antenna_phase_offset_rad": ("ours", "the reader's own"),
    "phase_noise_rad_per_m": ("ours", "the reader's own (paper 001's calibrated)"),
    "floor_antenna": ("ours", "the reader's floor port; 0: none"),
    "floor_softness_m": ("ours", "a floor tag's soft read edge"),
    "tag_group_read_range_m": ("ours", "the floor antenna's reach over a group's tags (paper 003: about 5 cm)"),
    "phase_antennas": ("ours", "the two receiving ports under a ceiling tag (paper 001's robot)"),
    "phase_floor_rad": ("ours", "phase noise besides the distance's (multipath)"),
    "wall_antenna": ("ours", "the side antenna's port (paper 004's robot); 0: none"),
    "wall_area_bearing_rad": ("ours", "the side antenna faces left"),
    "wall_area_width_m": ("paper", "paper 004: a 40 cm wide induction area"),
    "wall_area_depth_m": ("paper", "paper 004: 100 cm deep (the mixed reader's 1.2 m: ours)"),
    "wall_softness_m": ("ours", "the area's soft edge"),
    "use_wifi": ("ours", "weigh the location server's fix where the robot has WiFi"),
    "wifi_sd_floor_m": ("ours", "a WiFi fix is never trusted closer than this"),
    "wifi_min_travel_m": ("ours", "weighed once per this distance: its errors are spatially correlated"),
    "use_compass": ("ours", "weigh the compass where the robot has one"),
    "compass_sd_rad": ("ours", "compass_sim's 2 degree noise"),
    "compass_bias_sd_rad": ("ours", "the prior of each particle's compass bias"),
    "compass_bias_walk_rad": ("ours", "as odometry_scale_walk"),
    "eps": ("ours", "one reading never costs more: an outlier does not wipe out the particles near the truth"),
    "reset_threshold": ("ours", "sensor resetting (Lenser and Veloso) below this average likelihood"),
    "resample_threshold": ("ours", "effective sample size share"),
}
LOCALIZER_NOT_READ = {name: "over DDS only (topics, frames, services, tf)" for name in (
    "map_frame", "pose_topic", "status_topic", "initial_pose_topic", "publish_tf", "locate_service")} | {
    "map_file": "the world's robot map (world.*)", "seed": "each localizer's stream derives from runs.seed"}
READER_NOT_READ = {"world_file": "the world's", "seed": "the reader's streams derive from runs.seed"}
POSE_NAVIGATOR_SOURCES: dict[str, tuple[str, str]] = {
    "control_rate_hz": ("ours", "as paper 003's navigator"),
    "pose_timeout_s": ("ours", "a pose older than this: stand still"),
    "max_position_sd_m": ("ours", "stand still while the pose is less certain"),
    "replan_jump_m": ("ours", "plan again when the pose jumps this far"),
    "wall_clearance_m": ("ours", "as paper 003's navigator's planned legs"),
    "waypoint_tolerance_m": ("ours", "as above"),
    "speed_mps": ("ours", "as paper 003's navigator"),
    "turn_rate_radps": ("ours", "as above"),
    "heading_gain_per_s": ("ours", "as above"),
    "goal_tolerance_m": ("ours", "as above"),
}
POSE_NAVIGATOR_NOT_READ = {"map_file": "the world's robot map", "pose_topic": "over DDS only",
                           "map_frame": "over DDS only"}
# Paper 003's robot on the homes and the mixed floor: the navigator, sensors, matcher and base as reproduce two_tier
# lists them (its rows, its sources).
TWO_TIER_PREFIXES = ("two_tier_navigator.", "compass_sim.", "wifi_sim.", "location_server.", "robot_sim.",
                     "robot.", "world.wifi.")
WORLD_SOURCES: dict[str, tuple[str, str]] = {
    "world.two_tier_home": ("ours", "paper 003's field is not given in numbers: reproduce two_tier's flat"),
    "world.two_tier_flat": ("ours", "a flat of ours (reproduce two_tier's homes)"),
    "world.two_tier_corridor": ("ours", "as above"),
    "world.mixed_floor": ("ours", "every kind of tag on one floor"),
    "world.partition_field": ("paper", "paper 000's field and robot (r = 20 cm, reproduce partitions' paper "
                                       "configuration); 3 m tasks and 2 % odometry noise: ours"),
    "world.building_ring": ("ours", "a generated floor of ours with paper 004's robot (reproduce topological)"),
    "world.hallway": ("paper", "paper 001's hallway route, Figs. 12/13 (reproduce flc)"),
    "world.two_tier_home_fused": ("ours", "two_tier_home's mission, tier one from the fused pose"),
    "world.two_tier_flat_fused": ("ours", "as above"),
    "world.two_tier_corridor_fused": ("ours", "as above"),
    "world.partition_field_fused": ("ours", "partition_field's tasks, the partition navigator on the fused estimate"),
    "world.mixed_floor_fused": ("ours", "pose_navigator driving on the fused pose across the mixed floor"),
}
RUN_SOURCES: dict[str, tuple[str, str]] = {
    "runs.seed": ("ours", "the seed every stream of the runs derives from, and the ledger's set it belongs to"),
    "runs.per_world": ("ours", "missions (tasks, routes) per world"),
    "runs.single_evidence": ("ours", "on the mixed floor: the same filter given one kind of evidence and the compass"),
    "runs.kidnap_at_s": ("ours", "told, confidently, that the robot stands half the floor away, facing back "
                                 "(paper 000's field: 5 s into a 3 m task)"),
    "runs.late_start_s": ("ours", "a second global localization mid-mission (paper 000's field: 3 s)"),
    "runs.converged": ("ours", "global localization and recovery: the error below this for this long"),
    "runs.nees_band": ("ours", "the two-sided chi-square band a consistent filter's NEES lies in this often"),
    "runs.partition_task_m": ("ours", "paper 000's field: task length"),
    "runs.partition_odometry_noise": ("ours", "paper 000's motion is exact; the fused filter's model needs some"),
    "runs.partition_settings": ("paper", "paper 000's localizer and navigator from reproduce partitions (its "
                                         "conditions); driving on the fused estimate, the filter's settings"),
    "runs.topological": ("paper", "paper 004's wall follower, sonar and base as reproduce topological runs them"),
    "runs.tag_route": ("ours", "paper 001's route follower with the hallway scenario's controller file (flc_tuned, "
                               "ours: reproduce flc's conditions)"),
}


def localizer_file(world: str) -> Path:
    """The rfid_localizer file a world's fused localizers are set from."""
    if world in (PARTITIONS, PARTITION_DRIVING):
        return FLOOR_LATTICE_LOCALIZER
    if world == RING:
        return WALL_SIDE_LOCALIZER
    if world == HALLWAY:
        return UHF_2ANT_LOCALIZER
    spec = home(world).scenario.nodes.get("rfid_localizer")
    return spec.param_files[0] if spec is not None else HF_FLOOR_LOCALIZER


def reader_file(world: str) -> Path | None:
    """The reader file a world's runs read through (None: its runner's own read model)."""
    if world in (PARTITIONS, PARTITION_DRIVING, RING):
        return None
    return load_scenario(world).nodes["rfid_reader"].param_files[0]


def world_text(world: str) -> str:
    reader = reader_file(world)
    return (f"{driver_of(world)}; localizer {localizer_file(world).name}; reader "
            f"{reader.name if reader is not None else 'its runner own read model'}")


def conditions(seed: int = EVALUATION_SEED, runs: int = RUNS) -> dict[str, list[Condition]]:
    """The conditions table in four parts, each with its columns (:func:`condition_columns`): the fused filter by
    robot, the readers by file, the settings that are the same everywhere, and the worlds."""
    localizers = {robot: file_parameters(RfidLocalizerParameters, path, "rfid_localizer", map_file="the world's")
                  for robot, path in LOCALIZER_FILES.items()}
    filter_rows = [Condition(f"rfid_localizer.{name}", {robot: getattr(p, name) for robot, p in localizers.items()},
                             source, note) for name, (source, note) in LOCALIZER_SOURCES.items()]
    readers = {robot: file_parameters(ReaderParameters, path, "rfid_reader_sim", world_file="unused")
               for robot, path in READER_FILES.items()}
    reader_rows = []
    for key, (source, note) in two_tier.READER_SOURCES.items():
        name = key.removeprefix("rfid_reader_sim.")
        sources = {"hf_floor": f"{source} (paper 003: reproduce two_tier)", "mixed": "ours",
                   "uhf_2ant": "paper 001's robot: reproduce flc's conditions"}
        reader_rows.append(Condition(f"reader.{name}", {robot: getattr(r, name) for robot, r in readers.items()},
                                     source, f"paper 003's reader: {note}", sources))
    for name in ("side_area_width_m", "passage_miss_probability", "unreadable_tags"):
        reader_rows.append(Condition(f"reader.{name}", {robot: getattr(r, name) for robot, r in readers.items()},
                                     "ours", "side antennas: the mixed reader's left one"))
    tier_rows = {row.setting: row for row in two_tier.conditions(seed=seed)}
    same_rows = [Condition(key, {"value": row.values[two_tier.OURS]}, row.source, row.note)
                 for key, row in tier_rows.items() if key.startswith(TWO_TIER_PREFIXES)]
    navigation = file_parameters(PoseNavigatorParameters, PARAMS / "pose_navigator.yaml", "pose_navigator",
                                 map_file="unused")
    same_rows += [Condition(f"pose_navigator.{name}", {"value": getattr(navigation, name)}, source, note)
                  for name, (source, note) in POSE_NAVIGATOR_SOURCES.items()]
    run_values: dict[str, Any] = {
        "runs.seed": f"{seed} ({evaluation.seed_set(EXPERIMENT, seed, DEVELOPMENT_SEED)})",
        "runs.per_world": runs,
        "runs.single_evidence": {label: list(kinds) for label, kinds in SINGLE_EVIDENCE.items()},
        "runs.kidnap_at_s": {"default": KIDNAP_AT_S, PARTITIONS: PARTITION_KIDNAP_AT_S},
        "runs.late_start_s": {"default": LATE_START_S, PARTITIONS: PARTITION_LATE_START_S},
        "runs.converged": f"{CONVERGED_M:g} m for {CONVERGED_FOR_S:g} s",
        "runs.nees_band": NEES_BAND,
        "runs.partition_task_m": PARTITION_TASK_M,
        "runs.partition_odometry_noise": PARTITION_ODOMETRY_NOISE,
        "runs.partition_settings": {"localizer": repr(partition_localizer_settings(PAPER)),
                                    "navigator (paper's)": repr(partition_navigator_settings(PAPER, headline_level())),
                                    "navigator (on the fused estimate)":
                                        repr(partition_navigator_settings(FILTER, headline_level())),
                                    "speeds": repr(robot_speeds(PAPER))},
        "runs.topological": {"follower": repr(TOPOLOGICAL_FOLLOWER), "robot": repr(TOPOLOGICAL_ROBOT),
                             "sonar": repr(TOPOLOGICAL_SONAR)},
        "runs.tag_route": str(load_scenario(HALLWAY).nodes["heading_controller"].param_files[0].name),
    }
    same_rows += [Condition(key, {"value": run_values[key]}, source, note)
                  for key, (source, note) in RUN_SOURCES.items()]
    world_rows = [Condition(key, {"value": world_text(key.removeprefix("world."))}, source, note)
                  for key, (source, note) in WORLD_SOURCES.items()]
    return {"the fused filter (rfid_localizer, by robot)": filter_rows,
            "the readers (by file)": reader_rows,
            "paper 003's robot (the homes, the mixed floor), pose_navigator and the runs": same_rows,
            "the worlds": world_rows}


def condition_columns(rows: list[Condition]) -> list[str]:
    return list(rows[0].values)


def conditions_report(parts: dict[str, list[Condition]]) -> list[str]:
    lines = []
    for title, rows in parts.items():
        lines += [f"{title}:", *condition_lines(rows, condition_columns(rows)), ""]
    return lines


def all_condition_rows(parts: dict[str, list[Condition]]) -> list[Condition]:
    return [row for rows in parts.values() for row in rows]


def driver_of(world: str) -> str:
    if world == DRIVING:
        return "pose_navigator driving on the fused localizer's pose: no other localizer, no kidnap, no late start"
    if world == PARTITION_DRIVING:
        return ("the partition navigator driving on the fused localizer (its settings for a pose estimate) on "
                f"{PARTITIONS}'s tasks, paper 000's localizer beside: no kidnap, no late start")
    if world in TIER_ONE:
        return ("the two-tier navigator with tier one from the fused localizer's pose, on the mission of "
                f"{world.removesuffix('_fused')}; 'paper' is its dead reckoning between fixes: no kidnap, no late "
                "start")
    if world == HALLWAY:
        return ("paper 001's tag route follower driving; it keeps no pose, so its 'paper' pose is the wheel "
                "odometry from the known start")
    if world == RING:
        return "paper 004's mission executor driving; its 'paper' position is the node it believes it is at"
    return ("the partition navigator driving with paper 000's localizer" if world == PARTITIONS
            else "the two-tier navigator driving with paper 003's localizer")


def kidnap_times_of(world: str) -> tuple[float, float]:
    """(late start, kidnap) [s] of the world's runs (none where the fused pose drives)."""
    return (PARTITION_LATE_START_S, PARTITION_KIDNAP_AT_S) if world == PARTITIONS else (LATE_START_S, KIDNAP_AT_S)


def localizers_of(world: str) -> tuple[str, ...]:
    if world == DRIVING:
        return ("fused",)
    return ("fused", *(SINGLE_EVIDENCE if world == MIXED else ()), "paper")


def localizer_parameters(place: Home) -> RfidLocalizerParameters:
    """The scenario's rfid_localizer parameters, or paper 003's robot's file for a scenario without one."""
    spec = place.scenario.nodes.get("rfid_localizer")
    path = spec.param_files[0] if spec is not None else HF_FLOOR_LOCALIZER
    return file_parameters(RfidLocalizerParameters, path, "rfid_localizer", map_file=str(place.scenario.map_file))


def reader_parameters(place: Home) -> ReaderParameters:
    """The reader of the scenario's rfid_reader role: the robot's sensors, as the DDS run has them."""
    return file_parameters(ReaderParameters, place.scenario.nodes["rfid_reader"].param_files[0], "rfid_reader_sim",
                           world_file=str(place.scenario.world_file))


@dataclass(frozen=True)
class TrackFigures:
    position_rmse_m: float | None
    heading_rmse_deg: float | None
    fix_rate: float
    consistent: float | None          # share of rounds with an estimate whose NEES is in its 95 % band
    heading_rmse_paper_rounds_deg: float | None   # heading RMSE over the rounds the paper's localizer had a heading

    @classmethod
    def of(cls, track: Track, paper_heading_times_s: Collection[float] = ()) -> TrackFigures:
        bands = {dof: stats.chi2.ppf(((1 - NEES_BAND) / 2, (1 + NEES_BAND) / 2), dof) for dof in set(track.nees_dofs)}
        inside = [bool(bands[dof][0] <= value <= bands[dof][1]) for value, dof in zip(track.nees, track.nees_dofs,
                                                                                      strict=True)]
        return cls(_rms(track.position_errors_m), _rms_deg(track.heading_errors_rad), track.fix_rate,
                   sum(inside) / len(inside) if inside else None,
                   _rms_deg(track.heading_errors_at(frozenset(paper_heading_times_s))))


@dataclass(frozen=True)
class FusedRun:
    world: str
    run: int
    success: bool                     # the paper's mission arrived
    figures: dict[str, TrackFigures]  # per localizer of localizers_of(world)
    global_s: float | None            # the fused localizer's global localization from the start [s]; None: never
    late_global_s: float | None       # the same, for one started at LATE_START_S (mid-mission) [s]
    kidnap_recovery_s: float | None   # [s] from the kidnap; None: not found again (or the run ended first)
    duration_s: float
    final_error_m: float | None = None   # ARRIVING_WORLDS: the true distance from the target at the end


def _rms(values: list[float]) -> float | None:
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else None


def _rms_deg(radians: list[float]) -> float | None:
    return _rms([math.degrees(e) for e in radians])


def riders_for(world: str, run: int, seed: int, settings: FusedSettings, fused_map: FusedMap) -> dict[str, Rider]:
    """The fused localizers of one run: ``fused``, on the mixed floor the single-evidence ones, ``kidnap`` and
    ``late``; each with its own copy of the map (it learns the lattice from the first id read) and random stream."""
    late_s, kidnap_s = kidnap_times_of(world)

    def localizer(label: str) -> FusedLocalizer:
        return FusedLocalizer(settings, dataclasses.replace(fused_map), rng_for(seed, f"fused:{world}:{run}:{label}"))

    riders = {"fused": Rider(localizer("fused"))}
    if world == MIXED:
        riders.update({label: Rider(localizer(label), kinds) for label, kinds in SINGLE_EVIDENCE.items()})
    riders["kidnap"] = Rider(localizer("kidnap"), kidnap_at_s=kidnap_s, extent=fused_map.extent)
    riders["late"] = Rider(localizer("late"), joins_at_s=late_s)
    return riders


def fused_run(world: str, run: int, success: bool, riders: dict[str, Rider], paper: Track,
              duration_s: float) -> FusedRun:
    """The figures of one run's tracks."""
    late_s, kidnap_s = kidnap_times_of(world)
    figures = {label: TrackFigures.of(riders[label].track, paper.heading_times_s)
               for label in localizers_of(world) if label != "paper"}
    figures["paper"] = TrackFigures.of(paper, paper.heading_times_s)
    recovery = riders["kidnap"].track.settled_after(kidnap_s) if duration_s > kidnap_s else None
    found = riders["late"].track.settled_after(late_s) if duration_s > late_s else None
    return FusedRun(world, run, success, figures, riders["fused"].track.settled_after(0.0), found, recovery,
                    duration_s)


def mission_of(place: Home) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """The scenario's start pose (x, y, yaw [rad]) and its point goal."""
    x, y, yaw_deg = place.scenario.robot
    target = place.scenario.mission.goal["target"]
    return (x, y, math.radians(yaw_deg)), (target["x"], target["y"])


def home_map(place: Home) -> FusedMap:
    """What the fused localizer knows of a home: its robot map and its radio map."""
    robot_map = place.scenario.route_map
    assert robot_map is not None                       # home() refuses a home without its map
    return FusedMap.of_route_map(robot_map, place.site.radio_map)


def driving_rider(place: Home, name: str, run: int, seed: int) -> Rider:
    """The fused localizer of a run where it is in the loop: the scenario's rfid_localizer settings, its own
    random stream, starting knowing only the map as the node does."""
    return Rider(FusedLocalizer(localizer_parameters(place).settings(), home_map(place),
                                rng_for(seed, f"fused:{name}:{run}:fused")))


def scan_period_s(place: Home) -> float:
    """The scenario's WiFi scan period: how often the in-loop localizer asks the server to locate a scan."""
    return file_parameters(WifiSimParameters, place.scenario.nodes["wifi"].param_files[0], "wifi_sim",
                           world_file=str(place.scenario.world_file)).scan_period_s


def paired_figures(fused: Track, paper: Track) -> dict[str, TrackFigures]:
    """The figures of the fused localizer in the loop and of the paper's beside it, headings also on the paper's
    rounds."""
    return {"fused": TrackFigures.of(fused, paper.heading_times_s),
            "paper": TrackFigures.of(paper, paper.heading_times_s)}


def home_run(job: tuple[str, int, int]) -> FusedRun:
    """One two-tier mission of a world with the fused localizers beside; the same streams as reproduce two_tier's
    planned-legs run of that home and run number."""
    name, run, seed = job
    place = home(name)
    parameters = localizer_parameters(place)
    riders = riders_for(name, run, seed, parameters.settings(), home_map(place))
    beside = Beside(riders, parameters.ports())
    start, target = mission_of(place)
    result = run_two_tier(place.site, start, target, SETTINGS,
                          rng_for(seed, f"homes:{name}:{run}"), derive_seed(seed, f"homes:{name}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s, floor=place.floor, observe=beside,
                          reader_parameters=reader_parameters(place))
    return dataclasses.replace(fused_run(name, run, result.success, riders, beside.paper, result.duration_s),
                               final_error_m=result.final_error_m)


def tier_one_run(job: tuple[str, int, int]) -> FusedRun:
    """One mission of a home's ``*_fused`` scenario in-process: the two-tier navigator (paper 003's legs, tier two
    and searches) with tier one from the fused localizer's latest pose rather than the location server's
    fingerprint locate, as two_tier_navigator's ``tier_one_from`` has it over DDS; the localizer asks the server
    to locate each scan itself (the scenario's WiFi scan period), as rfid_localizer does. The same mission and
    random streams' seeds as the paper's runs of that home (home_run)."""
    name, run, seed = job
    paper_home = name.removesuffix("_fused")
    place = home(name)
    rider = driving_rider(place, name, run, seed)
    beside = Beside({"fused": rider}, localizer_parameters(place).ports())
    start, target = mission_of(place)
    result = run_two_tier(place.site, start, target, SETTINGS, rng_for(seed, f"homes:{paper_home}:{run}"),
                          derive_seed(seed, f"homes:{paper_home}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s, floor=place.floor, observe=beside,
                          reader_parameters=reader_parameters(place), tier_one=rider.tier_one,
                          scan_period_s=scan_period_s(place))
    return FusedRun(name, run, result.success, paired_figures(rider.track, beside.paper),
                    rider.track.settled_after(0.0), None, None, result.duration_s, result.final_error_m)


@dataclass(frozen=True)
class PartitionTask:
    """Run ``run``'s task on paper 000's field, the same whoever drives (partition_run, partition_driving_run): the
    field, a start and a goal PARTITION_TASK_M apart, the fused localizer's settings for the paper's robot."""
    route_map: RouteMap
    deployment: Deployment
    settings: FusedSettings
    start: tuple[float, float, float]
    goal: tuple[float, float]

    @classmethod
    def of(cls, run: int, seed: int) -> PartitionTask:
        scenario = load_scenario(PARTITIONS)
        assert scenario.route_map is not None and scenario.world.deployments
        field_deployment = scenario.world.deployments[0]
        settings = file_parameters(RfidLocalizerParameters, FLOOR_LATTICE_LOCALIZER, "rfid_localizer",
                                   map_file=str(scenario.map_file)).settings()
        start, goal = random_task(field_deployment, PARTITION_TASK_M,
                                  rng_for(seed, f"fused:{PARTITIONS}:{run}:task"))
        return cls(scenario.route_map, field_deployment, settings, start, goal)

    def fused_map(self) -> FusedMap:
        """A fresh map for each localizer (it learns the lattice from the first id read)."""
        return FusedMap.of_route_map(self.route_map)


def partition_run(job: tuple[str, int, int]) -> FusedRun:
    """One paper 000 navigation across the field: the partition navigator driving on the paper's localizer, the
    fused localizers beside on the same rounds (the floor antenna's tags and the odometry: the robot has nothing
    else)."""
    name, run, seed = job
    task = PartitionTask.of(run, seed)
    riders = riders_for(name, run, seed, task.settings, task.fused_map())
    beside = PartitionBeside(riders)
    result = run_navigation(task.deployment, task.start, task.goal, partition_localizer_settings(PAPER),
                            partition_navigator_settings(PAPER, headline_level()),
                            rng_for(seed, f"fused:{name}:{run}:robot"), odometry_noise=PARTITION_ODOMETRY_NOISE,
                            speeds=robot_speeds(PAPER), observer=beside)
    return dataclasses.replace(fused_run(name, run, result.success, riders, beside.paper, result.travel_time_s),
                               final_error_m=result.final_error_m)


def partition_driving_run(job: tuple[str, int, int]) -> FusedRun:
    """The same paper 000 task as partition_run's of that run number, the partition navigator driving on the fused
    localizer (with the navigator's settings for a pose estimate, as beside paper 000's particle filter:
    partition_navigator_filter_paper_robot.yaml) and paper 000's localizer beside it on the same rounds."""
    name, run, seed = job
    task = PartitionTask.of(run, seed)
    driving = FusedPartitions(FusedLocalizer(task.settings, task.fused_map(),
                                             rng_for(seed, f"fused:{name}:{run}:fused")))
    score = PartitionDriving(driving, PartitionLocalizer(partition_localizer_settings(PAPER),
                                                         rng_for(seed, f"fused:{name}:{run}:paper")))
    result = run_navigation(task.deployment, task.start, task.goal, partition_localizer_settings(PAPER),
                            partition_navigator_settings(FILTER, headline_level()),
                            rng_for(seed, f"fused:{name}:{run}:robot"), odometry_noise=PARTITION_ODOMETRY_NOISE,
                            speeds=robot_speeds(FILTER), observer=score, driving=driving)
    return FusedRun(name, run, result.success, paired_figures(score.fused, score.beside.paper),
                    score.fused.settled_after(0.0), None, None, result.travel_time_s, result.final_error_m)


def topological_run(job: tuple[str, int, int]) -> FusedRun:
    """One paper 004 mission on a generated floor (the mission executor's own task list), the fused localizers
    beside on the same control steps: the side antenna's wall tags and the odometry. Their map is the floor's tag
    survey (every plate, within the walls' bounding box), the robot map the scenario gives rfid_localizer over
    DDS."""
    name, run, seed = job
    floor = FLOORS[name]
    topological_map, world = load_topological_map(floor.map_path), load_world(floor.world_path)
    survey = load_scenario(name).nodes["rfid_localizer"].map_file
    assert survey is not None
    parameters = file_parameters(RfidLocalizerParameters, WALL_SIDE_LOCALIZER, "rfid_localizer",
                                 map_file=str(survey))
    riders = riders_for(name, run, seed, parameters.settings(), FusedMap.of_route_map(load_route_map(survey)))
    nodes = {node_name: node.position for node_name, node in topological_map.nodes.items()
             if node.position is not None}
    beside = TopologicalBeside(riders, parameters.wall_antenna, nodes)
    tag, goal = mission_tasks(topological_map, run + 1, seed)[run]
    result = run_mission(world, topological_map, start_pose_before_tag(world, tag), goal,
                         rng_for(seed, f"fused:{name}:{run}:mission"), observer=beside)
    return fused_run(name, run, result.success, riders, beside.paper, result.duration_s)


def route_run(job: tuple[str, int, int]) -> FusedRun:
    """One run of paper 001's hallway route (Figs. 12/13): the tag route follower steering by the ceiling tags'
    phase difference, the fused localizers beside on the same reader rounds and odometry. Their map is the
    hallway's tag survey in the scenario's robot map, as rfid_localizer has it over DDS: the ceiling tags and the
    floor tags under them, within the walls' bounding box."""
    name, run, seed = job
    scenario = load_scenario(name)
    parameters = file_parameters(RfidLocalizerParameters, UHF_2ANT_LOCALIZER, "rfid_localizer",
                                 map_file=str(scenario.map_file))
    assert scenario.route_map is not None
    riders = riders_for(name, run, seed, parameters.settings(), FusedMap.of_route_map(scenario.route_map))
    x, y, yaw_deg = scenario.robot
    beside = RouteBeside(riders, parameters.ports(), (x, y, math.radians(yaw_deg)))
    run_seed = derive_seed(seed, f"fused:{name}:{run}:route")
    result = run_tag_route(scenario, controller_parameters(scenario, None, run_seed), run_seed, observer=beside)
    return fused_run(name, run, result.success, riders, beside.paper, result.sim_duration_s)


def driving_run(job: tuple[str, int, int]) -> FusedRun:
    """One mission of ``mixed_floor_fused`` in-process: pose_navigator driving on the fused localizer's pose from
    the scenario's start to its goal, with the scenario's reader, WiFi scan period, navigator and localizer files.
    The localizer starts knowing only the map, as the node does."""
    name, run, seed = job
    place = home(name)
    rider = driving_rider(place, name, run, seed)
    navigation = file_parameters(PoseNavigatorParameters, place.scenario.nodes["pose_navigator"].param_files[0],
                                 "pose_navigator", map_file=str(place.scenario.map_file))
    start, target = mission_of(place)
    result = drive_on_fused(place.site, start, target, rider, localizer_parameters(place).ports(),
                            PoseNavigator(navigation.settings(), place.floor),
                            reader_parameters(place), rng_for(seed, f"fused:{name}:{run}:sensors"),
                            derive_seed(seed, f"fused:{name}:{run}:reader"), 1.0 / navigation.control_rate_hz,
                            scan_period_s(place), place.scenario.mission.timeout_s)
    return FusedRun(name, run, result.success, {"fused": TrackFigures.of(rider.track)},
                    rider.track.settled_after(0.0), None, None, result.duration_s, result.final_error_m)


def world_run(job: tuple[str, int, int]) -> FusedRun:
    if job[0] == DRIVING:
        return driving_run(job)
    if job[0] == PARTITION_DRIVING:
        return partition_driving_run(job)
    if job[0] in TIER_ONE:
        return tier_one_run(job)
    if job[0] == HALLWAY:
        return route_run(job)
    if job[0] == PARTITIONS:
        return partition_run(job)
    return topological_run(job) if job[0] == RING else home_run(job)


def fused_runs(runs: int, seed: int, worlds: Sequence[str] = WORLDS) -> list[FusedRun]:
    results = run_tasks(world_run, [(name, run, seed) for name in WORLDS if name in worlds for run in range(runs)],
                        "reproduce fused: worlds")
    return sorted(results, key=lambda r: (WORLDS.index(r.world), r.run))


METRICS = {"position_rmse_m": ("position RMSE [m]", 1.0, 3),
           "heading_rmse_deg": ("heading RMSE [deg]", 1.0, 2),
           "fix_rate": ("fix rate [%]", 100.0, 1),
           "consistent": ("NEES in its 95 % band [%]", 100.0, 1),
           "heading_rmse_paper_rounds_deg": ("heading RMSE where the paper has one [deg]", 1.0, 2)}


def figures(results: list[FusedRun], world: str) -> dict[str, dict[str, Interval]]:
    """Per metric: each localizer's mean over the runs and the paired difference of each other one less fused."""
    mine = [r for r in results if r.world == world]
    out: dict[str, dict[str, Interval]] = {}
    for metric in METRICS:
        values = {name: {r.run: getattr(r.figures[name], metric) for r in mine} for name in localizers_of(world)}
        out[metric] = {name: Interval.of([v for v in values[name].values() if v is not None])
                       for name in localizers_of(world)}
        for name in localizers_of(world)[1:]:
            out[metric][f"{name} - fused"] = paired_interval(values[name], values["fused"])
    return out


def recovery_keys(world: str) -> tuple[str, ...]:
    """The FusedRun fields of a world's recovery figures (the fused pose that drives is neither started late nor
    kidnapped: the robot would drive off with it)."""
    return ("global_s",) if world in DRIVING_WORLDS else ("global_s", "late_global_s", "kidnap_recovery_s")


def recovery_figures(results: list[FusedRun], world: str) -> dict[str, tuple[Interval, int]]:
    """Global localization and kidnap recovery [s]: the mean over the runs where it happened, and how many did."""
    mine = [r for r in results if r.world == world]
    out = {}
    for key in recovery_keys(world):
        found = [getattr(r, key) for r in mine if getattr(r, key) is not None]
        out[key] = (Interval.of(found), len(found))
    return out


def report_lines(results: list[FusedRun], runs: int) -> list[str]:
    lines = [f"reproduce fused: the fused localizer beside each paper's own, same runs ({runs} per world)", ""]
    for world in dict.fromkeys(r.world for r in results):
        arrived = sum(r.success for r in results if r.world == world)
        names = localizers_of(world)
        lines += [f"{world} ({driver_of(world)}; {arrived}/{runs} arrived)"]
        world_figures = figures(results, world)
        rows = [[label, *(_text(world_figures[metric][name], scale, digits) for name in names)]
                for metric, (label, scale, digits) in METRICS.items()]
        lines += table(["metric", *names], rows)
        if len(names) > 1:
            rows = [[label, _text(world_figures[metric][f"{name} - fused"], scale, digits)]
                    for metric, (label, scale, digits) in METRICS.items() for name in names[1:]
                    for label in (f"{METRICS[metric][0]}: {name} - fused",)]
            lines += table(["paired difference", "mean [95 % interval]"], rows)
        if world in ARRIVING_WORLDS:
            arrival = Arrival.of(results, world)
            low, high = arrival.rate.bounds or (0.0, 0.0)
            lines += [f"arrived {arrival.arrived}/{arrival.runs} (95 % interval {low:.0f}-{high:.0f} %); true "
                      f"distance from the target at the end {arrival.final_error_m.text(1.0, 3)} m"]
        recovery = recovery_figures(results, world)
        found = [f"from the start {recovery['global_s'][0].text(1.0, 1)} s in {recovery['global_s'][1]}/{runs} runs"]
        if "kidnap_recovery_s" in recovery:
            late_s, kidnap_s = kidnap_times_of(world)
            found += [f"started at {late_s:g} s {recovery['late_global_s'][0].text(1.0, 1)} s in "
                      f"{recovery['late_global_s'][1]}/{runs}",
                      f"kidnapped at {kidnap_s:g} s, found again after "
                      f"{recovery['kidnap_recovery_s'][0].text(1.0, 1)} s in {recovery['kidnap_recovery_s'][1]}/{runs}"]
        lines += [f"global localization (error below {CONVERGED_M:g} m for {CONVERGED_FOR_S:g} s): {'; '.join(found)}",
                  ""]
    return lines


@dataclass(frozen=True)
class Arrival:
    """How a world's missions ended: arrivals, and the true distance from the target at the end."""
    driver: str                        # the localizer the navigator drove on
    arrived: int
    runs: int
    rate: Interval                     # [%]
    final_error_m: Interval

    @classmethod
    def of(cls, results: list[FusedRun], world: str) -> Arrival:
        mine = [r for r in results if r.world == world]
        arrived = sum(r.success for r in mine)
        return cls("paper" if world in (*HOMES, PARTITIONS) else "fused", arrived, len(mine),
                   Interval.of_proportion(arrived, len(mine)),
                   Interval.of([r.final_error_m for r in mine if r.final_error_m is not None]))


def _text(interval: Interval, scale: float, digits: int) -> str:
    return interval.text(scale, digits) if interval.n else "-"     # a localizer without such a figure


def json_rows(results: list[FusedRun], seed: int, condition_rows: list[Condition] | None = None) \
        -> list[dict[str, Any]]:
    """The conditions (metric "condition"), then per world: each localizer's mean over the runs of each metric
    and its 95 % half-width (``METRIC_ci95``), the paired differences (localizer ``NAME-fused``), the fused
    localizer's global localization and recovery times (with how many runs it happened in) and the arrivals."""
    rows = condition_json_rows(EXPERIMENT, condition_rows or [])
    for world in dict.fromkeys(r.world for r in results):
        runs = sum(r.world == world for r in results)
        base = {"world": world, "seed": seed, "runs": runs}
        for metric, figure in figures(results, world).items():
            for name, interval in figure.items():
                setting = {**base, "localizer": name.replace(" - ", "-"), "n": interval.n}
                rows += [_row(setting, metric, interval.mean), _row(setting, f"{metric}_ci95", interval.half_width)]
        for key, (interval, count) in recovery_figures(results, world).items():
            setting = {**base, "localizer": "fused", "n": interval.n}
            rows += [_row(setting, key, interval.mean), _row(setting, f"{key}_ci95", interval.half_width),
                     _row(setting, f"{key}_runs_found", count)]
        if world in ARRIVING_WORLDS:
            arrival = Arrival.of(results, world)
            setting = {**base, "localizer": arrival.driver}
            low, high = arrival.rate.bounds or (None, None)
            rows += [_row(setting, "arrived", arrival.arrived), _row(setting, "arrived_pct", arrival.rate.mean),
                     _row(setting, "arrived_pct_low", low), _row(setting, "arrived_pct_high", high),
                     _row({**setting, "n": arrival.final_error_m.n}, "final_error_m", arrival.final_error_m.mean),
                     _row({**setting, "n": arrival.final_error_m.n}, "final_error_m_ci95",
                          arrival.final_error_m.half_width)]
    return rows


def _row(setting: dict[str, Any], metric: str, ours: Any) -> dict[str, Any]:
    return {"experiment": EXPERIMENT, "setting": setting, "metric": metric, "ours": ours, "paper": None}


def reproduce_fused(runs: int, out_dir: Path, as_json: bool, seed: int = EVALUATION_SEED,
                    worlds: Sequence[str] = WORLDS) -> int:
    """Run and report ``runs`` runs of each of ``worlds`` (all by default; fewer for a quick subset)."""
    if runs < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {runs}")
    unknown = [world for world in worlds if world not in WORLDS]
    if unknown or not worlds:
        raise ConfigError("worlds", "", f"expected some of {', '.join(WORLDS)}, got {list(worlds)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    parts = conditions(seed, runs)
    results = fused_runs(runs, seed, worlds)
    rows = json_rows(results, seed, all_condition_rows(parts))
    (out_dir / "fused_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        which = evaluation.seed_set(EXPERIMENT, seed, DEVELOPMENT_SEED)
        print("\n".join([f"reproduce fused: seed {seed}: {which} (the "
                          f"ledger's evaluation set is '{EVALUATION.name}', seed {EVALUATION_SEED}; development seed "
                          f"{DEVELOPMENT_SEED})", "", *conditions_report(parts), *report_lines(results, runs)]))
    print(f"rows: {out_dir / 'fused_rows.json'}", file=sys.stderr if as_json else sys.stdout)
    return 0
