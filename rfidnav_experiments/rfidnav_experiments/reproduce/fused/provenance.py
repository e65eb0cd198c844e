"""reproduce fused: where every setting the runs read comes from, and the conditions table in four parts (the fused
filter by robot, the readers by file, the settings that are the same everywhere, the worlds)."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce import two_tier
from rfidnav_experiments.reproduce.fused.conditions import (
    DEVELOPMENT_SEED,
    EVALUATION_SEED,
    EXPERIMENT,
    HALLWAY,
    KIDNAP_AT_S,
    LATE_START_S,
    NEES_BAND,
    PARTITION_KIDNAP_AT_S,
    PARTITION_LATE_START_S,
    PARTITION_ODOMETRY_NOISE,
    PARTITION_TASK_M,
    PARTITIONS,
    RUNS,
    SINGLE_EVIDENCE,
    driver_of,
    localizer_file,
    reader_file,
)
from rfidnav_experiments.reproduce.partitions import FILTER, PAPER, headline_level, robot_speeds
from rfidnav_experiments.reproduce.partitions import localizer_settings as partition_localizer_settings
from rfidnav_experiments.reproduce.partitions import navigator_settings as partition_navigator_settings
from rfidnav_experiments.reproduce.tables import Condition
from rfidnav_experiments.runners.fused import CONVERGED_FOR_S, CONVERGED_M
from rfidnav_experiments.runners.shipped import file_parameters
from rfidnav_experiments.runners.topological import FOLLOWER as TOPOLOGICAL_FOLLOWER
from rfidnav_experiments.runners.topological import ROBOT as TOPOLOGICAL_ROBOT
from rfidnav_experiments.runners.topological import SONAR as TOPOLOGICAL_SONAR
from rfidnav_localization.parameters import RfidLocalizerParameters
from rfidnav_planning.parameters import PoseNavigatorParameters
from rfidnav_scenario.scenario import CONFIG_DIR, load_scenario
from rfidnav_sim.parameters import ReaderParameters

PARAMS = CONFIG_DIR / "params"
# The fused filter's columns: each robot's rfid_localizer file, and the readers the runs read through (paper 000's
# field and paper 004's ring run their runners' own read models: see world.*).
LOCALIZER_FILES = {robot: PARAMS / f"rfid_localizer_{robot}.yaml"
                   for robot in ("hf_floor", "mixed", "floor_lattice", "wall_side", "uhf_2ant")}
READER_FILES = {robot: PARAMS / f"reader_{robot}.yaml" for robot in ("hf_floor", "mixed", "uhf_2ant")}
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


def world_text(world: str) -> str:
    reader = reader_file(world)
    return (f"{driver_of(world)}; localizer {localizer_file(world).name}; reader "
            f"{reader.name if reader is not None else 'its runner own read model'}")


def conditions(seed: int = EVALUATION_SEED, runs: int = RUNS) -> dict[str, list[Condition]]:
    """The conditions table in four parts, each with its columns (:func:`.report.condition_columns`): the fused
    filter by robot, the readers by file, the settings that are the same everywhere, and the worlds."""
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


def all_condition_rows(parts: dict[str, list[Condition]]) -> list[Condition]:
    return [row for rows in parts.values() for row in rows]
