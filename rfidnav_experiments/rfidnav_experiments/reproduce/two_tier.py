"""``./rfidnav reproduce two_tier``: paper 003 section 4.2, in-process, beside the paper's figures.

Every run reads the floor tags through the HF reader of config/params/reader_hf_floor.yaml, the rfid_reader_sim
node's over DDS: polled every 500-600 ms (paper 003 sec. 4.1), one poll in ten failing (ours), so a tag the
robot passes between two polls is never read and a fix is known only when a poll reads it.

* The conditions first: every physical setting that shapes the figures, with where it comes from (``paper``
  and the section, or ``ours`` and why; nothing is calibrated: the paper's first experiment, Fig. 10, needs no
  fitted setting), for the paper's method and ours.
* Fig. 10: spiral search distance against the robot's initial distance from a 29 x 29 cm cross, the paper's
  search (d = L / pi^2, at the robot's speed) and ours (d widened by the reader's range on both sides, at the
  navigator's search speed) on the SAME placements (seed -> bearing, group rotation, start heading, the
  reader's polls and failures), each point with its n and 95 % interval, the paired difference with its
  interval, and the paper's two figures at its distances: about 120 cm at 40 cm ("less than 40 cm: no more
  than one spiral"), about 300 cm at 50 cm ("larger than 40 cm: two spirals"). Its sensitivity, on the same
  placements: the initial distance measured to the group's centre or to its nearest tag (the paper does not say),
  and the reader's 500-600 ms taken as the time between two polls (the main figure) or as the latency of each
  result of a reader polled at its base rate. Beside it Theorem 1 against simulated searches from a Gaussian
  start, with the continuous reader the theorem assumes.
* Fig. 11: direct moving (dead reckoning all the way) against indirect moving (through intermediate landmarks
  by geographic forwarding): the accumulated error at the target.
* Fig. 12: at each turning point of two routes, the error of WiFi fingerprinting alone against the two-tier
  scheme (tier one, then the landmark, a spiral search if needed, the tag fix): ours, and the same polls taken
  the paper's way (the position of the tags read), paired. Our target: the median tag-fix error at the turning
  points at most 3 cm with the reader's delay and failures, reported met or not met, never tuned to.
* The radio map: a site survey on a 1 m grid against the robot's own survey (fingerprints at its tier-two
  fixes, paper 003's automatic radio map construction): the tier-one error at random points.
* Homes (ours): each two-tier scenario of HOMES (the in-tree flat and two flats of ours whose origin is at their
  centre) run in-process from its start to its goal, with the radio map its map names (the location server's
  over DDS), its legs straight as the paper drives them or planned round the map's walls, on the same streams:
  how many arrive, the final error, the path length and the steps the walls stopped (bumps).

Development and evaluation apart: every random draw comes from ``rng_for(seed, stream)``. The code was developed
and its settings chosen on DEVELOPMENT_SEED; the command reports EVALUATION_SEED, the seed of the evaluation set
the ledger (rfidnav_experiments.evaluation) holds for two_tier, never used to tune anything; seed 301, the set
reported before issue 31, is a development set since the navigator was redesigned after its figures were seen.
The report and the conditions' ``runs.seed`` row say which set the seed belongs to.

With ``--json`` the rows ``{"experiment", "setting", "metric", "ours", "paper"}`` (DESIGN.md), the conditions
first; where the paper gives no number "paper" is null. Plots: ``two_tier_figs10_12.png`` in the output folder.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import statistics
import sys
from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FixedLocator, NullLocator  # noqa: E402
from scipy import stats  # noqa: E402

from rfidnav_common.errors import ConfigError  # noqa: E402
from rfidnav_common.polling import PollClock, Polling  # noqa: E402
from rfidnav_common.robot_map import load_route_map  # noqa: E402
from rfidnav_common.seeding import derive_seed, rng_for  # noqa: E402
from rfidnav_common.tag_groups import TagGroup  # noqa: E402
from rfidnav_control.spiral import (  # noqa: E402
    SearchPolls,
    expected_search_length,
    separation_for_group,
    simulate_search,
)
from rfidnav_experiments import evaluation  # noqa: E402
from rfidnav_experiments.engine import run_tasks  # noqa: E402
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
from rfidnav_experiments.runners.two_tier import (  # noqa: E402
    FLOOR_READER,
    FOOTPRINT_RADIUS_M,
    LOCATE_SETTINGS,
    LOCATION_SERVER,
    NAVIGATOR,
    ODOMETRY_SCALE_ERROR,
    SETTINGS,
    STEP_S,
    SURVEY_FRESH_M,
    Site,
    floor_extent,
    grid_radio_map,
    robot_survey,
    run_two_tier,
    survey_grid,
)
from rfidnav_localization.fingerprint import RadioMap  # noqa: E402
from rfidnav_localization.radio_map_file import load_radio_map  # noqa: E402
from rfidnav_planning.wall_paths import WallMap  # noqa: E402
from rfidnav_scenario.scenario import CONFIG_DIR, Scenario, load_scenario  # noqa: E402
from rfidnav_sim.parameters import CompassParameters, ReaderParameters, WifiSimParameters  # noqa: E402
from rfidnav_sim.world import World, load_world  # noqa: E402

EXPERIMENT = "two_tier"
METHODS = ("paper", "ours")
PAPER, OURS = METHODS
DEVELOPMENT_SEED = 1                    # every figure looked at while the code and its settings were chosen
EVALUATION = evaluation.current(EXPERIMENT)   # the ledger's one evaluation set of this reproduction...
EVALUATION_SEED = EVALUATION.seeds[0]         # ...its seed: what the command reports, never used to tune

WORLD_FILE = CONFIG_DIR / "worlds" / "two_tier_home.yaml"
MAP_FILE = CONFIG_DIR / "maps" / "two_tier_home.yaml"       # the landmarks as the robot knows them: its goals

FIG10_SIZE_M = 0.29                     # paper 003 sec. 4.2: a 29 x 29 cm cross
FIG10_DISTANCES_M = tuple(round(0.1 * k, 1) for k in range(11))
FIG10_RUNS = 200
FIG10_BEYOND_M = 0.5                    # a search ends this far beyond the group's distance: its turns have passed it
PAPER_FIG10_M = {0.4: 1.20, 0.5: 3.00}  # sec. 4.2: ~120 cm within 40 cm, a jump to ~300 cm beyond
# Fig. 10's sensitivity, on the same placements: the initial distance measured to the group's centre (the main
# figure) or to its nearest tag; and the reader's 500-600 ms taken as the time between two polls (the main figure:
# the tags read where the reply comes) or as the latency of each result of a reader polled at its base rate (the
# tags read where the poll was, the robot told 500-600 ms later, having driven on).
CENTRE, NEAREST = DISTANCES_TO = ("group_centre", "nearest_tag")
PERIOD, LATENCY = DELAYS = ("period", "latency")
LATENCY_POLL_RATE_HZ = ReaderParameters().rate_hz      # the reader's base rate: its parameter's default
THEOREM_SIGMAS_M = (0.25, 0.5, 1.0)
ROUTES = {"route 1": ((1.0, 1.0, 0.3), ("T1", "T2", "T3", "T4", "T5")),
          "route 2": ((1.5, 2.0, 1.2), ("R1", "R2", "R3"))}
# West to east through the door in x = 6 (y 3.0-4.2): the straight line the direct run drives meets no wall
# (the walls stop the robot; the old route along y = 1 drove through the x = 6 wall).
LONG_ROUTE = ((1.0, 3.6, 0.0), (11.0, 3.6))
FIG11_SPACINGS_M = {"direct": 0.1, "indirect": 4.0}    # geographic forwarding's reach: no landmark helps at 0.1 m
RUNS = 20
GRID_SPACING_M = 1.0
GRID_SCANS_PER_POINT = 3
ROBOT_SURVEY_SPACING_M = 0.5            # the robot's own survey: a scan this often while fresh from a tag fix
TEST_POINTS = 300
TARGET_FIX_ERROR_M = 0.03               # ours: median tag-fix error at the turning points
HOMES = ("two_tier_home", "two_tier_flat", "two_tier_corridor")    # scenarios: start, goal, world, map, radio map
LEGS = {"straight": "the paper's: straight to each landmark", "planned": "ours: round the map's walls"}


def floor_range_m() -> float:
    """The reader's range on the floor: its 5 cm antenna range less the antenna's height above the tags."""
    height = FLOOR_READER.antenna_positions[2]
    return math.sqrt(FLOOR_READER.antenna_max_range_m[0] ** 2 - height ** 2)


@dataclass(frozen=True)
class SpiralMethod:
    d_m: float
    speed_mps: float


def spiral_methods() -> dict[str, SpiralMethod]:
    """The paper's search (d = L / pi^2, at the robot's driving speed: the paper gives no other) and ours, the
    navigator's (the band the reader reads around the cross crossed, at its search speed)."""
    return {PAPER: SpiralMethod(separation_for_group("cross", FIG10_SIZE_M), SETTINGS.go_to.speed_mps),
            OURS: SpiralMethod(separation_for_group("cross", FIG10_SIZE_M, SETTINGS.read_range_m),
                               SETTINGS.search_speed_mps)}


# ---------------------------------------------------------------------------------------- conditions

# Where every physical setting of the reproduction comes from. The parameters of the nodes the runs use (the floor
# reader, the navigator, the compass, the WiFi receiver, the location server's matcher, the base's footprint, the
# world's WiFi) are listed field by field: a field of their parameter classes with neither a row here nor a reason
# in NOT_READ fails test_reproduce_two_tier.
DELAY_AS_PERIOD = interpreted("the 500-600 ms delay as the poll period")
READER_SOURCES: dict[str, tuple[str, str]] = {
    "rfid_reader_sim.rate_hz": (DELAY_AS_PERIOD, "sec. 4.1 item 1's 'communication delay' of 500-600 ms over RS-232 "
                                                 "at 19,200 bps taken as the time between two polls, the tags read "
                                                 "where the reply comes: at most 2 polls/s (Fig. 10 sensitivity: "
                                                 "the delay as a latency instead)"),
    "rfid_reader_sim.round_jitter_s": (DELAY_AS_PERIOD, "sec. 4.1 item 1: 500-600 ms (uniform between: ours)"),
    "rfid_reader_sim.round_failure_probability": ("ours", "sec. 4.1 item 3: negotiations with a tag fail, no rate "
                                                          "given; one poll in ten reads nothing"),
    "rfid_reader_sim.frame_id": ("ours", "the robot's frame; no effect on the figures"),
    "rfid_reader_sim.antenna_frame_prefix": ("ours", "the antennas' frames on /tf_static; no effect on the figures"),
    "rfid_reader_sim.antenna_positions": ("ours", "at the robot's centre, 5 mm above the floor: the paper gives "
                                                  "no geometry"),
    "rfid_reader_sim.antenna_facing": ("paper", "sec. 3.3, 4.1: a reader scanning the tags on the ground"),
    "rfid_reader_sim.antenna_max_range_m": ("paper", "sec. 4.1: 13.56 MHz, a reading range of about 5 cm"),
    "rfid_reader_sim.antenna_half_angle_deg": ("ours", "near field: every tag within the range is read"),
    "rfid_reader_sim.antenna_phase_offset_rad": ("ours", "HF phase: nothing reads it"),
    "rfid_reader_sim.channels_mhz": ("paper", "sec. 4.1: 13.56 MHz"),
    "rfid_reader_sim.hop_dwell_s": ("ours", "unused with one channel"),
    "rfid_reader_sim.phase_noise_rad_per_m": ("ours", "HF phase: nothing reads it"),
    "rfid_reader_sim.miss_probability": ("ours", "a poll fails whole (round_failure_probability), never tag by tag"),
    "rfid_reader_sim.rssi_at_1m_dbm": ("ours", "only decides what is heard: every tag within 5 cm is"),
    "rfid_reader_sim.sensitivity_dbm": ("ours", "as above"),
    "rfid_reader_sim.pattern_exponent": ("ours", "no pattern within 5 cm"),
}
NAVIGATOR_SOURCES: dict[str, tuple[str, str]] = {
    "two_tier_navigator.floor_antenna": ("ours", "the reader's one port; no effect on the figures"),
    "two_tier_navigator.control_rate_hz": ("ours", "20 control steps/s: the in-process step"),
    "two_tier_navigator.service_timeout_s": ("ours", "unused in-process: the server answers at once"),
    "two_tier_navigator.map_frame": ("ours", "no effect on the figures"),
    "two_tier_navigator.publish_tf": ("ours", "map -> odom on /tf over DDS; no effect on the figures"),
    "two_tier_navigator.tier_one_from": ("paper", "the location server's fingerprint locate (reproduce fused also "
                                                  "runs tier one from the fused localizer)"),
    "two_tier_navigator.landmark_spacing_m": ("ours", "Fig. 4's tolerable distance to the next landmark: none given"),
    "two_tier_navigator.calibration_distance_m": ("ours", "A5's 'after moving a certain distance': none given"),
    "two_tier_navigator.deviation_threshold_m": ("ours", "A5's 'a certain threshold': none given"),
    "two_tier_navigator.tag_map_radius_m": ("ours", "A1's local tag map: the whole flat"),
    "two_tier_navigator.search_radius_sigmas": ("ours", "the spiral's extent: the paper gives none"),
    "two_tier_navigator.search_min_radius_m": ("ours", "as above"),
    "two_tier_navigator.max_searches": ("ours", "the paper's robot searches until it finds a tag"),
    "two_tier_navigator.search_speed_mps": ("ours", "polls at most 8.4 cm apart, inside the 8.7 cm band a tag line "
                                                    "5 cm apart is read across; the paper searches at its speed"),
    "two_tier_navigator.read_range_m": ("paper", "sec. 4.1: about 5 cm"),
    "two_tier_navigator.drift_per_m": ("paper", "sec. 4.1 item 2: 1 m of error after 20 m with 1 kg on board"),
    "two_tier_navigator.wall_clearance_m": ("ours", "the paper's robot drives straight: legs round the map's walls "
                                                    "keep the 17 cm base this far off"),
    "two_tier_navigator.waypoint_tolerance_m": ("ours", "as above"),
    "two_tier_navigator.search_wall_clearance_m": ("ours", "a spiral ends this near a map wall or the map's edge"),
    "two_tier_navigator.stall_steps": ("ours", "the paper's robot has no wall handling: odometry that does not follow "
                                               "the command for 0.5 s is a stall"),
    "two_tier_navigator.back_off_m": ("ours", "a stalled robot backs off this far, then asks tier one"),
    "two_tier_navigator.max_stalls": ("ours", "as above: it gives up after this many"),
    "two_tier_navigator.speed_mps": ("ours", "the paper gives none (the Create drives up to 0.5 m/s): 10-12 cm "
                                             "between two polls"),
    "two_tier_navigator.turn_rate_radps": ("ours", "the paper gives none"),
    "two_tier_navigator.heading_gain_per_s": ("ours", "the paper gives none"),
    "two_tier_navigator.goal_tolerance_m": ("ours", "the paper gives none"),
}
SENSOR_SOURCES: dict[str, tuple[str, str]] = {
    "compass_sim.rate_hz": ("ours", "the paper gives none"),
    "compass_sim.frame_id": ("ours", "no effect on the figures"),
    "compass_sim.noise_sd_deg": ("ours", "an e-compass's jitter: the paper gives none"),
    "compass_sim.bias_deg": ("ours", "an uncorrected declination: the paper gives none"),
    "wifi_sim.scan_period_s": ("ours", "unused here (a scan whenever tier one asks); reproduce fused's *_fused runs "
                                       "locate a scan this often"),
    "wifi_sim.frame_id": ("ours", "no effect on the figures"),
    "wifi_sim.interface": ("ours", "no effect on the figures"),
    "wifi_sim.scan_noise_sd_db": ("ours", "RSS at a fixed spot varies by 2-6 dB from scan to scan: mid-range"),
    "wifi_sim.sensitivity_dbm": ("ours", "a laptop-class receiver"),
    "world.wifi.path_loss_exponent": ("ours", "free space between walls (COST 231 multi-wall): the paper gives no "
                                              "building"),
    "world.wifi.wall_loss_db": ("ours", "light internal walls"),
    "world.wifi.shadowing_sd_db": ("ours", "typical indoor shadowing"),
    "world.wifi.shadowing_correlation_m": ("ours", "as above"),
    "world.wifi.shadowing_seed": ("ours", "one fixed building"),
    "world.wifi.reference_loss_db": ("ours", "Friis at each AP's frequency at 1 m (null: computed)"),
    "world.wifi.min_distance_m": ("ours", "standing under an AP does not give infinite RSS"),
    "world.access_points": ("ours", "four APs in a 12 x 8 m flat: the paper's field is not given in numbers"),
    "location_server.k": ("ours", "the fingerprint matcher: weighted k nearest neighbours in signal space (RADAR); "
                                  "the paper names fingerprinting, no matcher"),
    "location_server.missing_rss_dbm": ("ours", "an AP heard on one side only (scan or fingerprint) counts as this: "
                                                "below the receiver's sensitivity"),
    "location_server.min_common_aps": ("ours", "a fingerprint sharing fewer APs with the scan is no candidate"),
    "location_server.weighting": ("ours", "neighbours weighted by 1 / signal distance (RADAR)"),
    "robot_sim.footprint_radius_m": ("ours", "a round base 34 cm across (the Create's): the walls stop it this far "
                                             "off; the paper gives no size"),
}
WORLD_SOURCES: dict[str, tuple[str, str]] = {
    "world.tag_groups": ("paper", "sec. 4.1: 30 x 30 cm crosses at the turning points (Fig. 12); the tags 5 cm "
                                  "apart (ours: no gap the 5 cm reader slips through) and the flat are ours"),
    "robot.odometry_scale_error": ("paper", "sec. 4.1 item 2: 1 m of error per 20 m driven"),
    "robot.motion": ("ours", "an ideal unicycle stepped at the control rate (no wheel limits)"),
    "fig10.group": ("paper", "sec. 4.2: a 29 x 29 cm cross"),
    "fig10.distances_m": ("paper", "sec. 4.2 compares at 40 cm (~120 cm) and 50 cm (~300 cm); the rest: ours"),
    "fig10.distance_to": ("ours", "the group's centre: the paper does not say"),
    "fig10.placements": ("ours", "bearing, group rotation and start heading uniform, the same for both methods"),
    "fig10.max_radius": ("ours", "the search gives up 0.5 m beyond the group: its turns have passed it"),
    "fig10.spiral_d_m": ("paper", "paper: sec. 3.3, d = L / pi^2; ours: the read band crossed, (L + 2 sqrt(2) r) "
                                  "/ pi^2"),
    "fig10.speed_mps": ("ours", "paper: the robot's speed (none given); ours: the navigator's search speed"),
    "theorem1.reader": ("ours", "continuous: the theorem assumes the group found where the spiral reaches it"),
    "fig12.tag_fix": ("paper", "paper: sec. 3.2 A7, the position of the tag read (the mean of the tags one poll "
                               "reads); ours: within range of them, out of range of their neighbours"),
    "fig12.routes": ("ours", "the paper's Fig. 12 paths are not given in numbers"),
    "radio_map.grid": ("ours", "a 1 m grid, each fingerprint the mean of 3 scans"),
    "radio_map.robot_survey": ("paper", "the paper's automatic radio map construction (scans at the robot's tier-two "
                                        "positions); ours: a scan every 0.5 m while within 2 m of a tag fix, at the "
                                        "position it believes, docked at the first landmark"),
    "radio_map.test_points": ("ours", "tier one's error at random points of the flat, 20 cm inside its extent"),
    "fig10.delay": ("ours", "the main figure reads at the poll's reply (rate_hz, round_jitter_s); the sensitivity "
                            "also polls at the reader's base rate with the 500-600 ms as each result's latency"),
    "fig10.sensitivity_distance_to": ("ours", "the sensitivity also measures the distance to the group's nearest tag "
                                              "(same bearing, rotation, heading and reader seed)"),
    "fig11.route": ("ours", "the paper's Fig. 11 route is not given in numbers: 10 m through the x = 6 door"),
    "fig11.landmark_spacing_m": ("ours", "direct: no landmark within reach (dead reckoning all the way), indirect: "
                                         "the navigator's; no tier-one check on the way in either"),
    "homes.worlds": ("ours", "the homes of HOMES: their worlds, APs, groups and radio maps (fingerprints)"),
    "homes.legs": ("paper", "the paper's robot drives straight to each landmark; ours plans round the map's walls"),
    "runs.seed": ("ours", "the seed every stream of the runs derives from, and the ledger's set it belongs to"),
}
SOURCES = {**READER_SOURCES, **NAVIGATOR_SOURCES, **SENSOR_SOURCES, **WORLD_SOURCES}
# Where the two methods' values come from different places: the source of each (the row's own source is the
# paper method's).
METHOD_SOURCES: dict[str, dict[str, str]] = {
    "fig10.spiral_d_m": {PAPER: "paper (sec. 3.3)", OURS: "ours"},
    "fig12.tag_fix": {PAPER: "paper (sec. 3.2 A7)", OURS: "ours"},
    "homes.legs": {PAPER: "paper (straight legs)", OURS: "ours (planned round the walls)"},
}
# The fields of those nodes' parameter classes that no in-process run reads, and why: with SOURCES they cover every
# field (test_reproduce_two_tier).
NOT_READ: dict[str, str] = {
    "rfid_reader_sim.world_file": "the experiment's world",
    "rfid_reader_sim.seed": "each run's reader seed derives from runs.seed",
    "rfid_reader_sim.side_area_width_m": "side antennas: the floor reader has none",
    "rfid_reader_sim.passage_miss_probability": "side antennas: the floor reader has none",
    "rfid_reader_sim.unreadable_tags": "side antennas: the floor reader has none",
    "two_tier_navigator.map_file": "the experiment's map (MAP_FILE, each home's)",
    "compass_sim.seed": "the compass stream derives from runs.seed",
    "wifi_sim.world_file": "the experiment's world",
    "wifi_sim.seed": "the scan stream derives from runs.seed",
    "world.wifi.scan_noise_sd_db": "the receiver's: wifi_sim.scan_noise_sd_db",
    "world.wifi.sensitivity_dbm": "the receiver's: wifi_sim.sensitivity_dbm",
    "location_server.database_file": "in-process the radio map and the tag map are held in memory",
    "location_server.run_dir": "as above",
    "location_server.create_database": "as above",
    "location_server.map_file": "the experiment's map",
    **{f"robot_sim.{name}": "in-process the robot is an ideal unicycle (robot.motion) whose odometry is off by "
                            "robot.odometry_scale_error (the scenario's robot_sim: a test checks it)"
       for name in ("world_file", "start_x", "start_y", "start_yaw_deg", "step_s", "rtf", "step_participants",
                    "start_paused", "map_to_odom_at_start", "odom_rate_hz", "seed", "track_width_m",
                    "max_wheel_speed_mps", "max_wheel_accel_mps2", "command_timeout_s", "odom_left_scale_error",
                    "odom_right_scale_error", "odom_track_scale_error", "odom_slip_std", "walls_stop_base")},
}


def conditions(world: World | None = None, seed: int = EVALUATION_SEED) -> list[Condition]:
    """The table's rows, their values read from the settings the runs use (``seed``: the runs')."""
    world = world or load_world(WORLD_FILE)
    compass = shipped_parameters(CompassParameters, "compass_sim")
    receiver = shipped_parameters(WifiSimParameters, "wifi_sim", world_file="unused")
    methods = spiral_methods()
    groups = sorted({(group.shape, group.size_m, group.tag_spacing_m) for group in world.tag_groups})
    same: dict[str, Any] = {
        "world.wifi.shadowing_seed": world.wifi_seed,
        "world.access_points": len(world.access_points),
        "world.tag_groups": f"{len(world.tag_groups)} x " + ", ".join(f"{shape} {size:g} m, tags {spacing:g} m apart"
                                                                      for shape, size, spacing in groups),
        "robot_sim.footprint_radius_m": FOOTPRINT_RADIUS_M,
        "robot.odometry_scale_error": ODOMETRY_SCALE_ERROR,
        "robot.motion": f"unicycle, {STEP_S:g} s steps",
        "fig10.group": f"cross {FIG10_SIZE_M:g} m",
        "fig10.distances_m": list(FIG10_DISTANCES_M),
        "fig10.distance_to": "group centre",
        "fig10.placements": f"{FIG10_RUNS} per distance",
        "fig10.max_radius": f"distance + {FIG10_BEYOND_M:g} m",
        "fig10.delay": {delay: delay_text(delay) for delay in DELAYS},
        "fig10.sensitivity_distance_to": list(DISTANCES_TO),
        "theorem1.reader": "continuous",
        "fig11.route": f"{LONG_ROUTE[0][:2]} -> {LONG_ROUTE[1]}",
        "fig11.landmark_spacing_m": dict(FIG11_SPACINGS_M),
        "fig12.routes": {name: list(points) for name, (_, points) in ROUTES.items()},
        "radio_map.grid": f"{GRID_SPACING_M:g} m, {GRID_SCANS_PER_POINT} scans",
        "radio_map.robot_survey": f"every {ROBOT_SURVEY_SPACING_M:g} m within {SURVEY_FRESH_M:g} m of a fix",
        "radio_map.test_points": TEST_POINTS,
        "homes.worlds": {name: home_world_text(name) for name in HOMES},
        "runs.seed": f"{seed} ({evaluation.seed_set(EXPERIMENT, seed, DEVELOPMENT_SEED)})",
    }
    differing: dict[str, dict[str, Any]] = {
        "fig10.spiral_d_m": {method: round(spiral.d_m, 5) for method, spiral in methods.items()},
        "fig10.speed_mps": {method: spiral.speed_mps for method, spiral in methods.items()},
        "fig12.tag_fix": {PAPER: "the tags read", OURS: "region left by the reads"},
        "homes.legs": {PAPER: "straight", OURS: "planned"},
    }
    nodes: dict[str, Any] = {"rfid_reader_sim": FLOOR_READER, "two_tier_navigator": NAVIGATOR, "compass_sim": compass,
                             "wifi_sim": receiver, "location_server": LOCATION_SERVER}
    rows = []
    for key, (source, note) in SOURCES.items():
        node, field = key.split(".", 1)
        if key in differing:
            values = differing[key]
        elif key in same:
            values = dict.fromkeys(METHODS, same[key])
        elif node in nodes:
            values = dict.fromkeys(METHODS, getattr(nodes[node], field))
        else:                                   # world.wifi.*: the building's propagation
            values = dict.fromkeys(METHODS, getattr(world.wifi, field.removeprefix("wifi.")))
        rows.append(Condition(key, values, source, note, METHOD_SOURCES.get(key)))
    return rows


def home_world_text(name: str) -> str:
    place = home(name)
    world = place.scenario.world
    return (f"{place.scenario.world_file.name}: {len(world.access_points)} APs, {len(world.tag_groups)} groups, "
            f"{len(place.site.radio_map)} fingerprints")


# --------------------------------------------------------------------------------------------- Fig. 10

@dataclass(frozen=True)
class Placement:
    """One random placement of Fig. 10: where the group lies, how it is turned, where the spiral leaves; and the
    seed of the reader's polls. A function of (seed, distance, index) alone, so both methods search the same."""
    distance_m: float
    index: int
    bearing_rad: float
    rotation_rad: float
    heading_rad: float
    reader_seed: int

    def group(self, distance_to: str = CENTRE) -> TagGroup:
        """The group, its centre or (``NEAREST``) its nearest tag ``distance_m`` from the start, along the same
        bearing and turned alike."""
        along = self.distance_m if distance_to == CENTRE else \
            centre_for_nearest_tag(self.distance_m, self.bearing_rad, self.rotation_rad)
        centre = (along * math.cos(self.bearing_rad), along * math.sin(self.bearing_rad))
        return TagGroup("G", "cross", centre, FIG10_SIZE_M, self.rotation_rad)


def centre_for_nearest_tag(distance_m: float, bearing_rad: float, rotation_rad: float) -> float:
    """How far along ``bearing_rad`` the centre of the Fig. 10 cross (turned by ``rotation_rad``) lies when its
    nearest tag is ``distance_m`` from the start (bisection; the cross has a tag at its centre, so 0 at 0)."""
    offsets = TagGroup("G", "cross", (0.0, 0.0), FIG10_SIZE_M, rotation_rad).tag_positions()
    direction = np.array([math.cos(bearing_rad), math.sin(bearing_rad)])

    def nearest(along: float) -> float:
        return float(np.min(np.linalg.norm(offsets + along * direction, axis=1)))

    low, high = 0.0, distance_m + FIG10_SIZE_M            # nearest(low) <= distance_m < nearest(high)
    if nearest(low) >= distance_m:
        return 0.0
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if nearest(middle) < distance_m else (low, middle)
    return 0.5 * (low + high)


def fig10_placement(seed: int, distance_m: float, index: int) -> Placement:
    stream = f"fig10:{distance_m:g}:{index}"
    bearing, rotation, heading = rng_for(seed, stream).uniform(-math.pi, math.pi, 3)
    return Placement(distance_m, index, float(bearing), float(rotation), float(heading),
                     derive_seed(seed, f"{stream}:reader"))


@dataclass(frozen=True)
class Search:
    method: str
    placement: Placement
    length_m: float | None                # None: no poll read a tag before the spiral passed the group
    distance_to: str = CENTRE             # a key of DISTANCES_TO: what the placement's distance is measured to
    delay: str = PERIOD                   # a key of DELAYS: the reader's 500-600 ms as its period or its latency


def latency_polling() -> Polling:
    """The reader polled at its base rate (ReaderParameters' default rate_hz), failing as the floor reader does."""
    return Polling(1.0 / LATENCY_POLL_RATE_HZ, 0.0, FLOOR_READER.round_failure_probability)


def delay_text(delay: str) -> str:
    polling = FLOOR_READER.polling()
    delay_ms = f"{polling.interval_s * 1000:.0f}-{polling.max_interval_s * 1000:.0f} ms"
    if delay == PERIOD:
        return f"a poll every {delay_ms}, the tags read where its reply comes"
    return (f"a poll every {latency_polling().interval_s * 1000:.0f} ms, each result {delay_ms} late (the robot "
            "drives on meanwhile)")


def spiral_search(method: str, placement: Placement, distance_to: str = CENTRE, delay: str = PERIOD) -> Search:
    """One search of Fig. 10 with the floor reader's polls and failures: read where the poll's reply comes
    (``PERIOD``), or polled at the base rate and told of a read 500-600 ms after its poll (``LATENCY``: the length
    driven until the robot knows)."""
    spiral = spiral_methods()[method]
    group = placement.group(distance_to)
    polling = FLOOR_READER.polling() if delay == PERIOD else latency_polling()
    polls = SearchPolls(spiral.speed_mps, PollClock(polling, rng_for(placement.reader_seed, "polls")))
    reach = placement.distance_m if distance_to == CENTRE else math.hypot(*group.centre)
    length = simulate_search(group.tag_positions(), (0.0, 0.0), placement.heading_rad, spiral.d_m,
                             floor_range_m(), reach + FIG10_BEYOND_M, polls=polls)
    if length is not None and delay == LATENCY:
        reader = FLOOR_READER.polling()
        late_s = float(rng_for(placement.reader_seed, "latency").uniform(reader.interval_s, reader.max_interval_s))
        length += spiral.speed_mps * late_s
    return Search(method, placement, length, distance_to, delay)


def fig10_search(job: tuple[str, Placement]) -> Search:
    """One search of Fig. 10 (a task of the engine): the distance to the group's centre, read at each poll's
    reply."""
    method, placement = job
    return spiral_search(method, placement)


def sensitivity_search(job: tuple[str, Placement, str, str]) -> Search:
    """One search of Fig. 10's sensitivity (a task of the engine): (method, placement, distance_to, delay)."""
    return spiral_search(*job)


@dataclass(frozen=True)
class SpiralPoint:
    """Fig. 10 at one distance for one method."""
    found: Interval                       # percent of the placements where a tag was read
    length: Interval                      # [m] over the placements where one was


def fig10(runs: int, seed: int) -> dict[str, dict[float, list[Search]]]:
    """Every search, by method and distance, sorted by placement index."""
    placements = [fig10_placement(seed, distance, index) for distance in FIG10_DISTANCES_M for index in range(runs)]
    searches = run_tasks(fig10_search, [(method, placement) for placement in placements for method in METHODS],
                        "reproduce two_tier: Fig. 10")
    by_method: dict[str, dict[float, list[Search]]] = {method: {d: [] for d in FIG10_DISTANCES_M} for method in METHODS}
    for search in sorted(searches, key=lambda s: s.placement.index):
        by_method[search.method][search.placement.distance_m].append(search)
    return by_method


Variant = tuple[str, str]                 # (distance_to, delay)
SENSITIVITY_VARIANTS: tuple[Variant, ...] = ((NEAREST, PERIOD), (CENTRE, LATENCY), (NEAREST, LATENCY))
MAIN_VARIANT: Variant = (CENTRE, PERIOD)  # the main figure's


def fig10_sensitivity(runs: int, seed: int) -> dict[Variant, dict[str, dict[float, list[Search]]]]:
    """Every search of the sensitivity's variants (not the main figure's), on Fig. 10's placements: by variant,
    method and distance, sorted by placement index."""
    placements = [fig10_placement(seed, distance, index) for distance in FIG10_DISTANCES_M for index in range(runs)]
    jobs = [(method, placement, *variant) for variant in SENSITIVITY_VARIANTS for placement in placements
            for method in METHODS]
    searches = run_tasks(sensitivity_search, jobs, "reproduce two_tier: Fig. 10 sensitivity")
    out: dict[Variant, dict[str, dict[float, list[Search]]]] = {
        variant: {method: {d: [] for d in FIG10_DISTANCES_M} for method in METHODS} for variant in SENSITIVITY_VARIANTS}
    for search in sorted(searches, key=lambda s: s.placement.index):
        out[(search.distance_to, search.delay)][search.method][search.placement.distance_m].append(search)
    return out


def variant_difference(variant: dict[str, dict[float, list[Search]]], main: dict[str, dict[float, list[Search]]],
                       method: str, distance: float) -> Interval:
    """A variant's search length less the main figure's [m], paired on the placements both found."""
    def lengths(spiral: dict[str, dict[float, list[Search]]]) -> dict[Hashable, float | None]:
        return {s.placement.index: s.length_m for s in spiral[method][distance]}

    return paired_interval(lengths(variant), lengths(main))


def spiral_point(searches: list[Search]) -> SpiralPoint:
    lengths = [s.length_m for s in searches if s.length_m is not None]
    return SpiralPoint(Interval.of_proportion(len(lengths), len(searches)), Interval.of(lengths))


def paired_difference(spiral: dict[str, dict[float, list[Search]]], distance: float) -> Interval:
    """Ours minus the paper's search length [m] on the placements both found."""
    def lengths(method: str) -> dict[Hashable, float | None]:
        return {s.placement.index: s.length_m for s in spiral[method][distance]}

    return paired_interval(lengths(OURS), lengths(PAPER))


def theorem1(runs: int, seed: int) -> list[tuple[float, float, float, float]]:
    """(sigma, Theorem 1 as printed, Rayleigh form, simulated) [m] for our spiral around a cross group, read
    continuously as the theorem assumes."""
    rng = rng_for(seed, "theorem1")
    d = spiral_methods()[OURS].d_m
    rows = []
    for sigma in THEOREM_SIGMAS_M:
        lengths = []
        for _ in range(runs):
            offset = rng.normal(0.0, sigma, 2)
            group = TagGroup("G", "cross", (float(offset[0]), float(offset[1])), FIG10_SIZE_M,
                             float(rng.uniform(-math.pi, math.pi)))
            length = simulate_search(group.tag_positions(), (0.0, 0.0), float(rng.uniform(-math.pi, math.pi)), d,
                                     floor_range_m(), 10.0 * sigma)
            lengths.append(math.inf if length is None else length)
        rows.append((sigma, expected_search_length(sigma, d, as_printed=True),
                     expected_search_length(sigma, d, as_printed=False), statistics.fmean(lengths)))
    return rows


# ------------------------------------------------------------------------------------ Figs. 11 and 12

@functools.cache
def grid_site(seed: int) -> Site:
    """The flat with the grid survey's radio map, built once per process (the pool's workers too)."""
    world = load_world(WORLD_FILE)
    grid = survey_grid(world, GRID_SPACING_M, ROUTES["route 1"][0][:2])
    return Site.of(world, grid_radio_map(world, grid.points, rng_for(seed, "grid survey"), GRID_SCANS_PER_POINT))


@dataclass(frozen=True)
class Leg:
    """One navigation to a turning point of Fig. 12."""
    route: str
    run: int
    point: str
    fingerprint_m: float                  # tier one alone at the turning point
    fix_m: float | None                   # ours: the last tag fix on arriving (None: the leg failed)
    tag_position_m: float | None          # the same poll taken the paper's way
    all_fixes_m: tuple[float, ...]        # every tag fix of the leg, ours
    all_tag_positions_m: tuple[float, ...]
    wall_crossings: int                   # of the leg's true track (a leg that crossed a wall did not arrive)


@functools.cache
def floor_plan() -> WallMap:
    """The flat's walls and extent as the robot's map gives them (its legs are planned round the walls)."""
    return WallMap.of(load_route_map(MAP_FILE))


def fig12_route(job: tuple[str, int, int]) -> list[Leg]:
    """One run of a route, leg by leg (one navigation per turning point, as in the paper)."""
    name, run, seed = job
    site = grid_site(seed)
    landmarks = {group.group_id: group for group in load_route_map(MAP_FILE).tag_groups}
    start, points = ROUTES[name]
    rng = rng_for(seed, f"fig12:{name}:{run}")
    pose = start
    legs = []
    for point in points:
        centre = landmarks[point].centre
        scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(*centre, rng)}
        fingerprint = math.dist(site.radio_map.locate(scan, LOCATE_SETTINGS).position, centre)
        result = run_two_tier(site, pose, centre, SETTINGS, rng, derive_seed(seed, f"fig12:{name}:{run}:{point}"),
                              floor=floor_plan())
        arrived = result.success and bool(result.fix_errors_m)
        legs.append(Leg(name, run, point, fingerprint, result.fix_errors_m[-1] if arrived else None,
                        result.tag_position_errors_m[-1] if arrived else None, result.fix_errors_m,
                        result.tag_position_errors_m, result.wall_crossings))
        heading = math.atan2(centre[1] - pose[1], centre[0] - pose[0])
        pose = (result.final_position[0], result.final_position[1], heading)
    return legs


def fig12(runs: int, seed: int) -> list[Leg]:
    results = run_tasks(fig12_route, [(name, run, seed) for name in ROUTES for run in range(runs)],
                       "reproduce two_tier: Fig. 12")
    return sorted((leg for legs in results for leg in legs), key=lambda leg: (leg.route, leg.run))


def fig11_run(job: tuple[str, int, int]) -> tuple[str, int, float | None, int]:
    """Direct or indirect moving along LONG_ROUTE: the final position error [m], None if the run failed, and its
    wall crossings. Both kinds of run ``run`` draw the same compass, WiFi and reader streams."""
    kind, run, seed = job
    start, target = LONG_ROUTE
    settings = dataclasses.replace(SETTINGS, landmark_spacing_m=FIG11_SPACINGS_M[kind], calibration_distance_m=1000.0)
    result = run_two_tier(grid_site(seed), start, target, settings, rng_for(seed, f"fig11:{run}"),
                          derive_seed(seed, f"fig11:{run}:reader"), floor=floor_plan())
    return kind, run, result.final_error_m if result.success else None, result.wall_crossings


def fig11(runs: int, seed: int) -> tuple[dict[str, dict[int, float | None]], int]:
    """Per kind of moving, each run's final error (None: it failed); and the runs' wall crossings in all."""
    results = run_tasks(fig11_run, [(kind, run, seed) for run in range(runs) for kind in FIG11_SPACINGS_M],
                       "reproduce two_tier: Fig. 11")
    errors: dict[str, dict[int, float | None]] = {kind: {} for kind in FIG11_SPACINGS_M}
    for kind, run, error, _ in sorted(results, key=lambda result: result[1]):
        errors[kind][run] = error
    return errors, sum(result[3] for result in results)


# -------------------------------------------------------------------------------------------- homes

@dataclass(frozen=True)
class Home:
    scenario: Scenario
    floor: WallMap                        # its map's walls and extent
    site: Site                            # its world with the radio map its map names (the location server's)


@functools.cache
def home(name: str) -> Home:
    scenario = load_scenario(name)
    robot_map = scenario.route_map
    if robot_map is None or robot_map.radio_map_file is None:
        raise ConfigError(str(scenario.map_file), "radio_map", "a two-tier home's map names its radio map")
    site = Site.of(scenario.world, RadioMap(load_radio_map(robot_map.radio_map_file)))
    return Home(scenario, WallMap.of(robot_map), site)


@dataclass(frozen=True)
class HomeRun:
    home: str
    legs: str                             # a key of LEGS
    run: int
    success: bool
    final_error_m: float
    path_length_m: float
    bumps: int
    wall_crossings: int


def home_run(job: tuple[str, str, int, int]) -> HomeRun:
    """One navigation of a home's scenario, from its start to its goal within its timeout; both kinds of legs of
    run ``run`` draw the same compass, WiFi and reader streams."""
    name, legs, run, seed = job
    place = home(name)
    x, y, yaw_deg = place.scenario.robot
    target = place.scenario.mission.goal["target"]
    result = run_two_tier(place.site, (x, y, math.radians(yaw_deg)), (target["x"], target["y"]), SETTINGS,
                          rng_for(seed, f"homes:{name}:{run}"), derive_seed(seed, f"homes:{name}:{run}:reader"),
                          max_time_s=place.scenario.mission.timeout_s,
                          floor=place.floor if legs == "planned" else WallMap())
    return HomeRun(name, legs, run, result.success, result.final_error_m, result.path_length_m, result.bumps,
                   result.wall_crossings)


def homes(runs: int, seed: int) -> list[HomeRun]:
    results = run_tasks(home_run, [(name, legs, run, seed) for name in HOMES for legs in LEGS for run in range(runs)],
                       "reproduce two_tier: homes")
    return sorted(results, key=lambda result: (HOMES.index(result.home), list(LEGS).index(result.legs), result.run))


@dataclass(frozen=True)
class HomeFigures:
    arrived: Interval                     # percent of the runs
    final_error: Median                   # [m] of the runs that arrived
    path_length: Median                   # [m] of every run
    bumps: int                            # in all the runs
    runs_without_bumps: int
    wall_crossings: int                   # in all the runs (ground truth)


def home_figures(results: list[HomeRun], home: str, legs: str) -> HomeFigures:
    here = [result for result in results if result.home == home and result.legs == legs]
    arrived = [result for result in here if result.success]
    return HomeFigures(Interval.of_proportion(len(arrived), len(here)),
                       Median.of([result.final_error_m for result in arrived]),
                       Median.of([result.path_length_m for result in here]), sum(result.bumps for result in here),
                       sum(result.bumps == 0 for result in here), sum(result.wall_crossings for result in here))


def tier_one_errors(site: Site, radio_map: RadioMap, seed: int) -> list[float]:
    rng = rng_for(seed, "test points")
    x_min, y_min, x_max, y_max = floor_extent(site.world)
    errors = []
    for _ in range(TEST_POINTS):
        point = (float(rng.uniform(x_min + 0.2, x_max - 0.2)), float(rng.uniform(y_min + 0.2, y_max - 0.2)))
        scan = {r.bssid: r.rssi_dbm for r in site.wifi.scan(*point, rng)}
        errors.append(math.dist(radio_map.locate(scan, LOCATE_SETTINGS).position, point))
    return errors


# ---------------------------------------------------------------------------------------- aggregate

@dataclass(frozen=True)
class Crossings:
    """The wall crossings of the navigations' true tracks (rfidnav_scenario.metrics.wall_crossings), in all."""
    navigations: int
    count: int


@dataclass(frozen=True)
class Median:
    """A median with its distribution-free 95 % interval (order statistics: the ranks a binomial(n, 1/2) puts
    2.5 % outside on each side; at least 95 % coverage; none below 6 values)."""
    value: float | None
    bounds: tuple[float, float] | None
    n: int

    @classmethod
    def of(cls, values: Sequence[float]) -> Median:
        ordered = sorted(values)
        n = len(ordered)
        if n == 0:
            return cls(None, None, 0)
        low_rank = int(stats.binom.ppf(0.025, n, 0.5))     # 1-based rank of the lower bound
        bounds = (ordered[low_rank - 1], ordered[n - low_rank]) if low_rank >= 1 else None
        return cls(float(statistics.median(ordered)), bounds, n)

    def text(self, scale: float = 100.0, digits: int = 1) -> str:
        if self.value is None:
            return "-"
        interval = "" if self.bounds is None else \
            f" [{self.bounds[0] * scale:.{digits}f}, {self.bounds[1] * scale:.{digits}f}]"
        return f"{self.value * scale:.{digits}f}{interval} (n={self.n})"


@dataclass(frozen=True)
class FixFigures:
    """Fig. 12's tag fixes: ours and the paper's way on the same polls."""
    at_turning_points: dict[str, Median]      # by method: the last fix of each leg
    all_fixes: dict[str, Median]              # by method: every fix of every leg
    paired_m: Interval                        # ours minus the paper's, the last fix of each leg
    failed_legs: int

    @property
    def target_met(self) -> bool | None:
        value = self.at_turning_points[OURS].value
        return None if value is None else value <= TARGET_FIX_ERROR_M


def fix_figures(legs: list[Leg]) -> FixFigures:
    done = [leg for leg in legs if leg.fix_m is not None and leg.tag_position_m is not None]
    ours: dict[Hashable, float | None] = {(leg.route, leg.run, leg.point): leg.fix_m for leg in legs}
    paper: dict[Hashable, float | None] = {(leg.route, leg.run, leg.point): leg.tag_position_m for leg in legs}
    return FixFigures(
        {OURS: Median.of([leg.fix_m for leg in done if leg.fix_m is not None]),
         PAPER: Median.of([leg.tag_position_m for leg in done if leg.tag_position_m is not None])},
        {OURS: Median.of([e for leg in legs for e in leg.all_fixes_m]),
         PAPER: Median.of([e for leg in legs for e in leg.all_tag_positions_m])},
        paired_interval(ours, paper), len(legs) - len(done))


def legs_at(legs: list[Leg], route: str, point: str) -> list[Leg]:
    return [leg for leg in legs if leg.route == route and leg.point == point]


# ------------------------------------------------------------------------------------------- report

def _cm(value_m: float | None, digits: int = 0) -> str:
    return "-" if value_m is None else f"{value_m * 100:.{digits}f}"


def fig10_lines(spiral: dict[str, dict[float, list[Search]]], runs: int) -> list[str]:
    methods = spiral_methods()
    lines = [f"Fig. 10: spiral search length [cm] from a {FIG10_SIZE_M * 100:g} cm cross, {runs} random placements "
             "per distance, the same for both; mean ± 95 % interval over the placements where a poll read a tag (n), "
             "the share found [Wilson 95 %]; difference paired, ours minus the paper's, on the placements both found",
             "  " + "; ".join(f"{method}: d = {spiral.d_m * 100:.2f} cm at {spiral.speed_mps:g} m/s"
                              for method, spiral in methods.items())]
    rows = []
    for distance in FIG10_DISTANCES_M:
        points = {method: spiral_point(spiral[method][distance]) for method in METHODS}
        paper = PAPER_FIG10_M.get(distance)
        rows.append([f"{distance * 100:g}", "-" if paper is None else f"~{paper * 100:.0f}",
                     *(points[m].length.text(100.0, 0) for m in METHODS),
                     *(points[m].found.text(1.0, 1) for m in METHODS),
                     paired_difference(spiral, distance).text(100.0, 0)])
    lines += table(["distance cm", "paper's figure", PAPER, OURS, f"{PAPER} found %", f"{OURS} found %",
                    "difference"], rows)
    return lines


def sensitivity_lines(sensitivity: dict[Variant, dict[str, dict[float, list[Search]]]],
                      main: dict[str, dict[float, list[Search]]], runs: int) -> list[str]:
    """Fig. 10 under each distance definition and each reading of the reader's delay, the same placements."""
    variants = (MAIN_VARIANT, *SENSITIVITY_VARIANTS)
    lines = [f"Fig. 10 sensitivity: search length [cm], mean ± 95 % interval (n found of {runs}); the distance to the "
             "group's centre or to its nearest tag; the reader's delay as its period (" + delay_text(PERIOD) + ") or "
             "as a latency (" + delay_text(LATENCY) + "); the same placements (bearing, rotation, heading, reader "
             "seed). Paired: the variant less the main figure (group_centre, period), on the placements both found"]
    for method in METHODS:
        rows = []
        for distance in FIG10_DISTANCES_M:
            paper = PAPER_FIG10_M.get(distance)
            cells = [f"{distance * 100:g}", "-" if paper is None else f"~{paper * 100:.0f}"]
            for variant in variants:
                spiral = main if variant == MAIN_VARIANT else sensitivity[variant]
                cells.append(spiral_point(spiral[method][distance]).length.text(100.0, 0))
            cells += [variant_difference(sensitivity[variant], main, method, distance).text(100.0, 0)
                      for variant in SENSITIVITY_VARIANTS]
            rows.append(cells)
        lines += [f"{method}'s search:"]
        lines += table(["distance cm", "paper's figure", *(f"{to}, {delay}" for to, delay in variants),
                        *(f"{to}, {delay} - main" for to, delay in SENSITIVITY_VARIANTS)], rows)
    return lines


def fig10_against_paper(spiral: dict[str, dict[float, list[Search]]]) -> list[str]:
    lines = ["Fig. 10 at the paper's distances (sec. 4.2):"]
    for distance, paper in PAPER_FIG10_M.items():
        points = {method: spiral_point(spiral[method][distance]) for method in METHODS}
        parts = []
        for method in METHODS:
            mean = points[method].length.mean
            off = "-" if mean is None else f"{(mean / paper - 1.0) * 100:+.0f} %"
            parts.append(f"{method} {points[method].length.text(100.0, 0)} cm ({off})")
        lines.append(f"  {distance * 100:g} cm: paper ~{paper * 100:.0f} cm; " + "; ".join(parts)
                     + f"; ours minus paper {paired_difference(spiral, distance).text(100.0, 0)} cm")
    return lines


def fix_lines(legs: list[Leg], fixes: FixFigures) -> list[str]:
    lines = ["Fig. 12: position error [cm] at the turning points: median [95 % interval] (n); fingerprinting "
             "alone, the two-tier scheme's last tag fix on arriving, ours and the paper's way on the same polls"]
    for route, (_, points) in ROUTES.items():
        lines += [f"{route}:"]
        lines += table(["turning point", "fingerprinting", f"two-tier {OURS}", f"two-tier {PAPER}"],
                       [[point, Median.of([leg.fingerprint_m for leg in legs_at(legs, route, point)]).text(100.0, 0),
                         Median.of([leg.fix_m for leg in legs_at(legs, route, point) if leg.fix_m is not None]).text(),
                         Median.of([leg.tag_position_m for leg in legs_at(legs, route, point)
                                    if leg.tag_position_m is not None]).text()] for point in points])
    met = fixes.target_met
    verdict = "-" if met is None else ("met" if met else "not met")
    fingerprinting = Median.of([leg.fingerprint_m for leg in legs])
    lines += [f"all turning points: fingerprinting median {fingerprinting.text(100.0, 0)} cm (RADAR: 2-3 m)",
              f"  tag fix, ours: {fixes.at_turning_points[OURS].text()} cm; the paper's way (the tags read): "
              f"{fixes.at_turning_points[PAPER].text()} cm; ours minus the paper's, paired: {fixes.paired_m.text()} cm",
              f"  every tag fix on the way: ours {fixes.all_fixes[OURS].text()} cm, the paper's way "
              f"{fixes.all_fixes[PAPER].text()} cm; legs that did not arrive with a fix: {fixes.failed_legs}",
              f"target (ours, median tag-fix error at the turning points <= {TARGET_FIX_ERROR_M * 100:g} cm with the "
              f"reader's delay and failures): {verdict}"]
    return lines


def report_lines(condition_rows: list[Condition], spiral, sensitivity, theorem, moving, legs: list[Leg],
                 fixes: FixFigures, radio, crossings: Crossings, grid_count: int, survey_count: int, runs: int,
                 fig10_runs: int, seed: int) -> list[str]:
    lines = [f"reproduce two_tier: paper 003 section 4.2, in-process; seed {seed}: "
             f"{evaluation.seed_set(EXPERIMENT, seed, DEVELOPMENT_SEED)} "
             f"(the ledger's evaluation set is '{EVALUATION.name}', "
             f"seed {EVALUATION_SEED}; development seed {DEVELOPMENT_SEED}); {runs} runs per route",
             "", *condition_lines(condition_rows, METHODS), "", *fig10_lines(spiral, fig10_runs), "",
             *fig10_against_paper(spiral), "", *sensitivity_lines(sensitivity, spiral, fig10_runs), "",
             "Theorem 1: expected search length [cm] for a Gaussian tier-one error sd sigma (our spiral, a reader that "
             "reads continuously, as the theorem assumes)"]
    lines += table(["sigma cm", "as printed", "Rayleigh form", "simulated", "simulated / Rayleigh"],
                   [[f"{s * 100:g}", f"{p * 100:.0f}", f"{r * 100:.0f}", f"{m * 100:.0f}", f"{m / r:.2f}"]
                    for s, p, r, m in theorem])
    lines += ["", f"Fig. 11: final position error [cm] from {LONG_ROUTE[0][:2]} to {LONG_ROUTE[1]}: median [95 % "
                  "interval] (n); paper: indirect moving accumulates less error"]
    lines += table(["moving", "median", "mean", "max", "failed"],
                   [[kind, Median.of(done(errors)).text(), Interval.of(done(errors)).text(100.0, 1),
                     _cm(max(done(errors), default=None), 1), str(len(errors) - len(done(errors)))]
                    for kind, errors in moving.items()])
    difference = paired_interval(moving["indirect"], moving["direct"])
    lines += [f"indirect minus direct, paired (same streams): {difference.text(100.0, 1)} cm", ""]
    lines += fix_lines(legs, fixes)
    lines += [f"wall crossings (ground truth) in the {crossings.navigations} navigations of Figs. 11 and 12: "
              f"{crossings.count}"]
    lines += ["", f"radio map: tier-one error [cm] at {TEST_POINTS} random points"]
    lines += table(["radio map", "fingerprints", "median", "mean", "p90"],
                   [[kind, str(count), Median.of(v).text(100.0, 0), f"{statistics.fmean(v) * 100:.0f}",
                     f"{np.percentile(v, 90) * 100:.0f}"]
                    for (kind, v), count in zip(radio.items(), (grid_count, survey_count))])
    return lines


def home_lines(results: list[HomeRun], runs: int) -> list[str]:
    lines = [f"homes (ours): each scenario from its start to its goal in-process, {runs} runs each, the same streams "
             "for both kinds of legs; arrived [Wilson 95 %], the final error of those that arrived and the path of "
             "all: median [95 % interval] (n); bumps: steps the walls stopped, in all (runs with none); wall "
             "crossings of the true tracks, in all"]
    rows = []
    for home in HOMES:
        for legs, note in LEGS.items():
            figures = home_figures(results, home, legs)
            rows.append([home, note, figures.arrived.text(1.0, 0), figures.final_error.text(),
                         figures.path_length.text(1.0, 1), f"{figures.bumps} ({figures.runs_without_bumps})",
                         str(figures.wall_crossings)])
    return lines + table(["home", "legs", "arrived %", "final error cm", "path m", "bumps", "crossings"], rows)


def sensitivity_json_rows(sensitivity: dict[Variant, dict[str, dict[float, list[Search]]]],
                          main: dict[str, dict[float, list[Search]]], seed: int) -> list[dict[str, Any]]:
    """Fig. 10's sensitivity: each variant's search length (metrics ``sensitivity_*``: the main figure's are
    fig10_spiral's), and its difference from the main figure on the same placements."""
    rows = []
    for (distance_to, delay), spiral in sensitivity.items():
        for method in METHODS:
            for distance in FIG10_DISTANCES_M:
                searched = spiral_point(spiral[method][distance])
                setting = {"method": method, "distance_m": distance, "distance_to": distance_to, "delay": delay,
                           "seed": seed, "placements": searched.found.n, "found": searched.length.n}
                difference = variant_difference(spiral, main, method, distance)
                against = {**setting, "against": "_".join(MAIN_VARIANT), "pairs": difference.n}
                rows += [row("fig10_sensitivity", setting, "sensitivity_search_length_m", searched.length.mean,
                             PAPER_FIG10_M.get(distance)),
                         row("fig10_sensitivity", setting, "sensitivity_search_length_ci95_m",
                             searched.length.half_width),
                         row("fig10_sensitivity", setting, "sensitivity_found_pct", searched.found.mean),
                         row("fig10_sensitivity", against, "sensitivity_difference_m", difference.mean),
                         row("fig10_sensitivity", against, "sensitivity_difference_ci95_m", difference.half_width)]
    return rows


def home_json_rows(results: list[HomeRun], seed: int) -> list[dict[str, Any]]:
    rows = []
    for home in HOMES:
        for legs in LEGS:
            figures = home_figures(results, home, legs)
            setting = {"home": home, "legs": legs, "seed": seed, "runs": figures.arrived.n}
            low, high = figures.arrived.bounds or (None, None)
            rows += [row("homes", setting, "arrived_pct", figures.arrived.mean),
                     row("homes", setting, "arrived_pct_low", low), row("homes", setting, "arrived_pct_high", high),
                     row("homes", {**setting, "n": figures.final_error.n}, "final_error_median_m",
                         figures.final_error.value),
                     row("homes", setting, "path_length_median_m", figures.path_length.value),
                     row("homes", setting, "bumps", figures.bumps),
                     row("homes", setting, "runs_without_bumps", figures.runs_without_bumps),
                     row("homes", setting, "wall_crossings", figures.wall_crossings)]
    return rows


def done(errors: dict[int, float | None]) -> list[float]:
    return [error for error in errors.values() if error is not None]


# --------------------------------------------------------------------------------------------- JSON

def row(experiment: str, setting: dict[str, Any], metric: str, ours: Any, paper: Any = None) -> dict[str, Any]:
    return {"experiment": experiment, "setting": setting, "metric": metric, "ours": ours, "paper": paper}


def median_rows(experiment: str, setting: dict[str, Any], metric: str, median: Median) -> list[dict[str, Any]]:
    """A median and the bounds of its 95 % interval (``METRIC_low``, ``METRIC_high``; null below 6 values)."""
    low, high = median.bounds or (None, None)
    return [row(experiment, setting, metric, median.value), row(experiment, setting, f"{metric}_low", low),
            row(experiment, setting, f"{metric}_high", high)]


def json_rows(condition_rows: list[Condition], spiral, theorem, moving, legs: list[Leg], fixes: FixFigures,
              radio, crossings: Crossings, seed: int) -> list[dict[str, Any]]:
    rows = condition_json_rows(EXPERIMENT, condition_rows)
    for method in METHODS:
        for distance in FIG10_DISTANCES_M:
            searched = spiral_point(spiral[method][distance])
            setting = {"method": method, "distance_m": distance, "seed": seed, "placements": searched.found.n,
                       "found": searched.length.n}
            rows += [row("fig10_spiral", setting, "search_length_m", searched.length.mean,
                         PAPER_FIG10_M.get(distance)),
                     row("fig10_spiral", setting, "search_length_ci95_m", searched.length.half_width),
                     row("fig10_spiral", setting, "found_pct", searched.found.mean)]
    for distance in FIG10_DISTANCES_M:
        difference = paired_difference(spiral, distance)
        setting = {"method": f"{OURS}-{PAPER}", "distance_m": distance, "seed": seed, "pairs": difference.n}
        rows += [row("fig10_spiral", setting, "paired_difference_m", difference.mean),
                 row("fig10_spiral", setting, "paired_difference_ci95_m", difference.half_width)]
    for sigma, printed, rayleigh, simulated in theorem:
        rows += [row("theorem1", {"sigma_m": sigma, "seed": seed}, "search_length_m", simulated, printed),
                 row("theorem1", {"sigma_m": sigma, "seed": seed}, "rayleigh_expectation_m", rayleigh)]
    for kind, errors in moving.items():
        median = Median.of(done(errors))
        rows += median_rows("fig11_moving", {"moving": kind, "seed": seed, "n": median.n}, "median_error_m", median)
    moved = paired_interval(moving["indirect"], moving["direct"])
    setting = {"moving": "indirect-direct", "seed": seed, "pairs": moved.n}
    rows += [row("fig11_moving", setting, "paired_difference_m", moved.mean),
             row("fig11_moving", setting, "paired_difference_ci95_m", moved.half_width)]
    everywhere = Median.of([leg.fingerprint_m for leg in legs])
    rows += median_rows("fig12_turning_points", {"route": "all", "point": "all", "method": "fingerprinting",
                                                 "seed": seed, "n": everywhere.n}, "median_error_m", everywhere)
    for route, (_, points) in ROUTES.items():
        for point in points:
            here = legs_at(legs, route, point)
            for method, values in (("fingerprinting", [leg.fingerprint_m for leg in here]),
                                   (f"two_tier_{OURS}", [leg.fix_m for leg in here if leg.fix_m is not None]),
                                   (f"two_tier_{PAPER}", [leg.tag_position_m for leg in here
                                                          if leg.tag_position_m is not None])):
                median = Median.of(values)
                rows.append(row("fig12_turning_points", {"route": route.replace(" ", "_"), "point": point,
                                                         "method": method, "seed": seed, "n": median.n},
                                "median_error_m", median.value))
    for method in METHODS:
        median = fixes.at_turning_points[method]
        # the paper claims centimetres, no number
        rows += [*median_rows("tag_fix", {"method": method, "fixes": "turning_points", "seed": seed, "n": median.n},
                              "median_error_m", median),
                 row("tag_fix", {"method": method, "fixes": "turning_points", "seed": seed, "n": median.n},
                     "median_error_ci95_m", None if median.bounds is None else list(median.bounds)),
                 *median_rows("tag_fix", {"method": method, "fixes": "all", "seed": seed,
                                          "n": fixes.all_fixes[method].n}, "median_error_m", fixes.all_fixes[method])]
    paired = {"method": f"{OURS}-{PAPER}", "fixes": "turning_points", "seed": seed, "pairs": fixes.paired_m.n}
    rows += [row("tag_fix", paired, "paired_difference_m", fixes.paired_m.mean),
             row("tag_fix", paired, "paired_difference_ci95_m", fixes.paired_m.half_width),
             row("tag_fix", {"method": OURS, "seed": seed, "target_m": TARGET_FIX_ERROR_M}, "target_met",
                 fixes.target_met)]
    for kind, errors in radio.items():
        rows += median_rows("radio_map", {"map": kind, "seed": seed, "n": len(errors)}, "median_error_m",
                            Median.of(errors))
    rows.append(row("navigations", {"figures": "11,12", "seed": seed, "n": crossings.navigations}, "wall_crossings",
                    crossings.count))
    return rows


# -------------------------------------------------------------------------------------------- plots

COLOURS = {PAPER: "tab:blue", OURS: "tab:red"}
FIG12_TICKS_CM = (1, 3, 10, 30, 100, 300)


def plot_fig10(axes: plt.Axes, difference_axes: plt.Axes, spiral: dict[str, dict[float, list[Search]]],
               runs: int) -> None:
    for offset, method in zip((-0.6, 0.6), METHODS):
        points = [spiral_point(spiral[method][d]) for d in FIG10_DISTANCES_M]
        x = [d * 100 + offset for d in FIG10_DISTANCES_M]
        means = [np.nan if p.length.mean is None else p.length.mean * 100 for p in points]
        half = [0.0 if p.length.half_width is None else p.length.half_width * 100 for p in points]
        axes.errorbar(x, means, yerr=half, fmt="o-", color=COLOURS[method], capsize=3, markersize=4,
                      label=f"{method} (mean, 95 % interval)")
        for xi, mean, point in zip(x, means, points):
            if math.isfinite(mean):
                axes.annotate(str(point.length.n), (xi, mean), textcoords="offset points", fontsize=6,
                              xytext=(-12 if method == PAPER else 4, 4), color=COLOURS[method])
    axes.plot([d * 100 for d in PAPER_FIG10_M], [v * 100 for v in PAPER_FIG10_M.values()], "k*", markersize=11,
              label="paper, sec. 4.2")
    axes.set(xlabel="initial distance to the group's centre [cm]", ylabel="search length [cm]",
             title=f"Fig. 10: {runs} placements per distance (numbers: n found)")
    axes.legend(fontsize=8)
    axes.grid(True, alpha=0.3)
    differences = [paired_difference(spiral, d) for d in FIG10_DISTANCES_M]
    difference_axes.errorbar([d * 100 for d in FIG10_DISTANCES_M],
                             [np.nan if i.mean is None else i.mean * 100 for i in differences],
                             yerr=[0.0 if i.half_width is None else i.half_width * 100 for i in differences],
                             fmt="o-", color="tab:purple", capsize=3, markersize=4)
    for distance, interval in zip(FIG10_DISTANCES_M, differences):
        if interval.mean is not None:
            difference_axes.annotate(str(interval.n), (distance * 100, interval.mean * 100), fontsize=6,
                                     textcoords="offset points", xytext=(4, 4))
    difference_axes.axhline(0.0, color="0.5", linewidth=0.8)
    difference_axes.set(xlabel="initial distance [cm]", ylabel="ours - paper [cm]",
                        title="Fig. 10, paired: ours minus the paper's (numbers: pairs)")
    difference_axes.grid(True, alpha=0.3)


def plot_fig11(axes: plt.Axes, moving: dict[str, dict[int, float | None]]) -> None:
    values = [[e * 100 for e in done(errors)] for errors in moving.values()]
    axes.boxplot(values, tick_labels=[f"{kind}\nn={len(v)}" for kind, v in zip(moving, values)])
    axes.set(ylabel="final error [cm]", title="Fig. 11: direct vs indirect moving")
    axes.grid(True, axis="y", alpha=0.3)


def plot_fig12(axes: plt.Axes, legs: list[Leg]) -> None:
    points = [(route, point) for route, (_, route_points) in ROUTES.items() for point in route_points]
    x = np.arange(len(points))
    series = {"fingerprinting": lambda leg: leg.fingerprint_m, f"two-tier {OURS}": lambda leg: leg.fix_m,
              f"two-tier {PAPER}": lambda leg: leg.tag_position_m}
    for offset, (label, value) in zip((-0.27, 0.0, 0.27), series.items()):
        medians = [Median.of([v for v in map(value, legs_at(legs, route, point)) if v is not None])
                   for route, point in points]
        centres = np.array([np.nan if m.value is None else m.value * 100 for m in medians])
        low = [0.0 if m.bounds is None or m.value is None else (m.value - m.bounds[0]) * 100 for m in medians]
        high = [0.0 if m.bounds is None or m.value is None else (m.bounds[1] - m.value) * 100 for m in medians]
        axes.errorbar(x + offset, centres, yerr=[low, high], fmt="o", capsize=3, markersize=4, label=label)
    counts = [len([leg for leg in legs_at(legs, route, point) if leg.fix_m is not None]) for route, point in points]
    axes.set_xticks(x, [f"{point}\nn={n}" for (_, point), n in zip(points, counts)], fontsize=8)
    axes.set_yscale("log")
    axes.yaxis.set_major_locator(FixedLocator(FIG12_TICKS_CM))
    axes.yaxis.set_minor_locator(NullLocator())
    axes.set_yticklabels([str(tick) for tick in FIG12_TICKS_CM])
    axes.set(ylabel="error [cm], median and 95 % interval", title="Fig. 12: error at the turning points")
    axes.legend(fontsize=8)
    axes.grid(True, axis="y", alpha=0.3)


def plot_figures(spiral, moving, legs: list[Leg], runs: int, out_dir: Path) -> Path:
    figure, axes = plt.subplots(2, 2, figsize=(14, 10))
    plot_fig10(axes[0][0], axes[1][0], spiral, runs)
    plot_fig11(axes[0][1], moving)
    plot_fig12(axes[1][1], legs)
    return save(figure, out_dir / "two_tier_figs10_12.png", dpi=110)


# --------------------------------------------------------------------------------------------- verb

def reproduce_two_tier(runs: int, out_dir: Path, as_json: bool, seed: int = EVALUATION_SEED,
                       fig10_runs: int = FIG10_RUNS) -> int:
    """Run, report and plot; 0 when our median tag-fix error at the turning points meets the target, else 1."""
    if runs < 1 or fig10_runs < 1:
        raise ConfigError("--runs", "", f"must be at least 1, got {min(runs, fig10_runs)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    world = load_world(WORLD_FILE)
    condition_rows = conditions(world, seed)
    site = grid_site(seed)
    spiral = fig10(fig10_runs, seed)
    sensitivity = fig10_sensitivity(fig10_runs, seed)
    theorem = theorem1(fig10_runs, seed)
    moving, moving_crossings = fig11(runs, seed)
    legs = fig12(runs, seed)
    fixes = fix_figures(legs)
    crossings = Crossings(2 * runs + len(legs), moving_crossings + sum(leg.wall_crossings for leg in legs))
    survey_map = RadioMap(robot_survey(Site.of(world, RadioMap()), load_route_map(MAP_FILE), seed,
                                      ROBOT_SURVEY_SPACING_M))
    radio = {"grid": tier_one_errors(site, site.radio_map, seed), "survey": tier_one_errors(site, survey_map, seed)}
    home_runs = homes(runs, seed)
    rows = [*json_rows(condition_rows, spiral, theorem, moving, legs, fixes, radio, crossings, seed),
            *sensitivity_json_rows(sensitivity, spiral, seed), *home_json_rows(home_runs, seed)]
    (out_dir / "two_tier_rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    plot = plot_figures(spiral, moving, legs, fig10_runs, out_dir)
    # Only the JSON goes to stdout with --json, so a program can parse it whole.
    notes = sys.stderr if as_json else sys.stdout
    if as_json:
        print(json.dumps(rows, indent=1))
    else:
        print("\n".join([*report_lines(condition_rows, spiral, sensitivity, theorem, moving, legs, fixes, radio,
                                        crossings, len(site.radio_map), len(survey_map), runs, fig10_runs, seed),
                         "", *home_lines(home_runs, runs)]))
    print(f"plot: {plot}; rows: {out_dir / 'two_tier_rows.json'}", file=notes)
    return 0 if fixes.target_met else 1
