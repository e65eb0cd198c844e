"""reproduce partitions: where every physical setting of the navigations comes from, and the value each
configuration runs with (the conditions table)."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments.reproduce.partitions.settings import (
    ACCURACY_SAMPLES,
    COUNT_AREAS_M,
    COUNT_RANGE_M,
    DEVELOPMENT_SEED,
    DISTANCES_M,
    EVALUATION_SEED,
    FIELD,
    FIG11_RUNS,
    METHODS,
    NAVIGATION_RANGES_M,
    ODOMETRY_NOISE,
    RUNS_PER_CURVE,
    localizer_parameters,
    method_levels,
    navigator_parameters,
)
from rfidnav_experiments.reproduce.tables import Condition
from rfidnav_experiments.runners.partitions import DEFAULT_ROUND_SPACING_M

# Where every physical setting of the navigations comes from. Every key of the localizer's and the navigator's
# files of every method is listed (a key added to one without a row here fails test_reproduce_partitions); so is
# what the in-process robot, the field and the tasks fix. The source is the paper method's; the note says where the
# others differ.
SOURCES: dict[str, tuple[str, str]] = {
    "partition_localizer.method": ("paper", "paper: sec. 4.1 (mean of the tags read) and 4.2 (orientation bounds); "
                                            "filter, filter_boom_spin: ours, a particle filter"),
    "partition_localizer.antenna_offset_m": ("paper", "sec. 4.1, 6.2: the agent reads the partition it stands in "
                                                      "(on its rotation axis); filter the same; filter_boom_spin: "
                                                      "ours, 25 cm ahead (the ablation)"),
    "partition_localizer.antenna": ("ours", "the reader port of that antenna over DDS; in-process the robot has the "
                                            "one antenna"),
    "partition_localizer.turn_threshold_rad": ("ours", "the heading change in odometry that ends a straight stretch "
                                                       "(sec. 5.2 re-estimates after each turn; the threshold is "
                                                       "ours)"),
    "partition_localizer.particles": ("ours", "filter only"),
    "partition_localizer.motion_noise_fraction": ("ours", "filter only: the noise it assumes, not the robot's"),
    "partition_localizer.motion_noise_floor_m": ("ours", "filter only: as above"),
    "partition_localizer.motion_noise_yaw_rad_per_m": ("ours", "filter only: as above"),
    "partition_localizer.boundary_softness_m": ("ours", "filter only: about the distance between rounds"),
    "partition_localizer.read_error_probability": ("ours", "filter only: the read errors it assumes (there are "
                                                           "none)"),
    "partition_localizer.rogue_distance_factor": ("ours", "rogue-tag rejection; no rogue tags here"),
    "partition_localizer.map_file": ("ours", "unused in-process: the tagged area is world.field_m"),
    "partition_localizer.map_frame": ("ours", "no effect on the figures"),
    "partition_localizer.publish_tf": ("ours", "map -> odom on /tf over DDS; no effect on the figures"),
    "partition_localizer.seed": ("ours", "the node's; in-process each run draws from runs.seed, method, r, level "
                                         "and run"),
    "partition_navigator.approximation_level": ("paper", "sec. 6.3.2: N = 1-8 (Figs. 12-14); the headline at 4, the "
                                                         "files' N; fewer levels for ours (runtime)"),
    "partition_navigator.localized_yaw_sd_rad": ("paper", "paper: none, N partitions only (sec. 4.2, 6.3); "
                                                          "filter: ours, also once the heading sd is below 20 deg"),
    "partition_navigator.spin_quarter_turns": ("paper", "sec. 4.2, 5.2: the agent localizes by driving straight and "
                                                        "turns only towards the goal; filter the same; "
                                                        "filter_boom_spin: ours, up to 8 quarter turns (the "
                                                        "ablation)"),
    "partition_navigator.deviation_check": ("paper", "paper: re-plan on a partition off the plan (sec. 5.2); "
                                                     "filter: ours, when the pose estimate would miss the goal"),
    "partition_navigator.pose_miss_tolerance_r": ("ours", "the pose check's allowed miss (filter only)"),
    "partition_navigator.arrival": ("paper", "paper: stop on entering the goal's partition (sec. 6.2); filter: "
                                             "ours, the estimate within r/4 of the goal"),
    "partition_navigator.position_tolerance_r": ("ours", "the position arrival's tolerance (filter only)"),
    "partition_navigator.max_path_factor": ("ours", "a give-up rule; the paper states none"),
    "partition_navigator.max_localization_m": ("ours", "a give-up rule (a floor too small for N partitions in a "
                                                       "line)"),
    "partition_navigator.lost_distance_m": ("ours", "a give-up rule (off the tagged floor)"),
    "partition_navigator.max_replans": ("ours", "a give-up rule"),
    "partition_navigator.forward_speed_mps": ("ours", "the paper gives no speed (paper 001's 0.2 m/s); the time cost "
                                                      "depends on it through speed / turn rate only"),
    "partition_navigator.turn_rate_radps": ("ours", "the paper gives no turn rate: a small base's; the time cost "
                                                    "charges every turn at it"),
    "partition_navigator.turn_gain_per_s": ("ours", "DDS node only: the in-process robot turns exactly"),
    "partition_navigator.turn_tolerance_rad": ("ours", "DDS node only: as above"),
    "partition_navigator.unheard_timeout_s": ("ours", "DDS node only: no message is lost in-process"),
    "robot.motion": ("paper", "sec. 6.2: a simulated agent; exact straight drives at constant speed and exact turns "
                              "on the spot (sec. 5.2: it rotates towards the goal)"),
    "robot.odometry_noise": ("ours", "exact odometry, as the simulated motion is exact; the filter predicts with it, "
                                     "the paper method sees turns in it and carries the heading through them"),
    "robot.read_rounds": ("ours", "the paper's agent sees every partition it enters; we also read inside one, at "
                                  "most this far apart"),
    "world.field_m": ("paper", "sec. 6.2: a 500 x 500 cm area"),
    "world.read_ranges_m": ("paper", "sec. 6.2: r = 2, 20 and 50 cm"),
    "world.read_model": ("paper", "sec. 3.1: a disc of radius r; no missed, spurious or rogue reads (sec. 7 leaves "
                                  "noise to future work)"),
    "world.layout": ("paper", "sec. 3.1: Kershner's lattice, side r*sqrt(3). Sec. 6.4.3's 'we used this improved "
                              "deployment in our experiments' may mean the compressed one (side 1.5 r) for Figs. "
                              "12-14: not run"),
    "world.deployment": ("ours", "every lattice vertex whose disc reaches the field"),
    "tasks.start": ("paper", "sec. 6.2: a random location; the heading uniform is ours (the paper gives none)"),
    "tasks.distances_m": ("paper", "Figs. 12-14's axis, 100-500 cm; equal runs at each distance: ours"),
    "runs.per_curve": ("paper", "sec. 6.2: 250 runs per curve (at the headline level: per method and r)"),
    "runs.seed": ("ours", f"the evaluation tasks, chosen once; development (tuning, tests): seed {DEVELOPMENT_SEED}"),
    "runs.fig11_lines": ("ours", "the paper does not say how many lines Fig. 11 averages"),
    "runs.accuracy_samples": ("ours", "random points and moves per layout and r (Figs. 16-20); the paper gives no "
                                      "count"),
    "world.count_read_range_m": ("ours", "Figs. 15 and 18 give no r; tag ratios hardly depend on it"),
    "world.count_areas_m": ("paper", "sec. 6.4.1: 5 x 5 to 30 x 30 m"),
}


def condition_value(method: str, key: str, runs: int) -> Any:
    """The value a navigation of ``method`` runs with for the setting ``key`` (as the files and runner have it)."""
    node, field = key.split(".", 1)
    if node == "partition_localizer":
        return getattr(localizer_parameters(method), field)
    if key == "partition_navigator.approximation_level":
        return list(method_levels(method))
    if node == "partition_navigator":
        return getattr(navigator_parameters(method), field)
    fixed: dict[str, Any] = {
        "robot.motion": "exact drives, exact turns on the spot",
        "robot.odometry_noise": ODOMETRY_NOISE,
        "robot.read_rounds": f"entering a partition; every min(r/2, {DEFAULT_ROUND_SPACING_M * 100:g} cm)",
        "world.field_m": list(FIELD),
        "world.read_ranges_m": list(NAVIGATION_RANGES_M),
        "world.read_model": "disc of radius r, exact",
        "world.layout": "triangular (Kershner)",
        "world.deployment": "vertices whose disc reaches the field",
        "tasks.start": "uniform position and heading",
        "tasks.distances_m": list(DISTANCES_M),
        "runs.per_curve": runs,
        "runs.seed": EVALUATION_SEED,
        "runs.fig11_lines": FIG11_RUNS,
        "runs.accuracy_samples": ACCURACY_SAMPLES,
        "world.count_read_range_m": COUNT_RANGE_M,
        "world.count_areas_m": list(COUNT_AREAS_M),
    }
    return fixed[key]


def conditions(runs: int = RUNS_PER_CURVE) -> list[Condition]:
    return [Condition(key, {method: condition_value(method, key, runs) for method in METHODS}, source, note)
            for key, (source, note) in SOURCES.items()]
