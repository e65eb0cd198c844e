"""reproduce two_tier: where every physical setting of the runs comes from (``paper`` and the section, or
``ours`` and why; one source per method where they differ), the fields no in-process run reads, and the conditions
table's rows, their values read from the settings the runs use."""

from __future__ import annotations

from typing import Any

from rfidnav_experiments import evaluation
from rfidnav_experiments.reproduce.tables import Condition, interpreted
from rfidnav_experiments.reproduce.two_tier.conditions import (
    DELAYS,
    DEVELOPMENT_SEED,
    DISTANCES_TO,
    EVALUATION_SEED,
    EXPERIMENT,
    FIG10_BEYOND_M,
    FIG10_DISTANCES_M,
    FIG10_RUNS,
    FIG10_SIZE_M,
    FIG11_SPACINGS_M,
    GRID_SCANS_PER_POINT,
    GRID_SPACING_M,
    HOMES,
    LONG_ROUTE,
    METHODS,
    OURS,
    PAPER,
    ROBOT_SURVEY_SPACING_M,
    ROUTES,
    TEST_POINTS,
    WORLD_FILE,
    delay_text,
    spiral_methods,
)
from rfidnav_experiments.reproduce.two_tier.navigations import home
from rfidnav_experiments.runners.shipped import shipped_parameters
from rfidnav_experiments.runners.two_tier import (
    FLOOR_READER,
    FOOTPRINT_RADIUS_M,
    LOCATION_SERVER,
    NAVIGATOR,
    ODOMETRY_SCALE_ERROR,
    STEP_S,
)
from rfidnav_planning.two_tier_survey import SURVEY_FRESH_M
from rfidnav_sim.parameters import CompassParameters, WifiSimParameters
from rfidnav_sim.world import World, load_world

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
    "rfid_reader_sim.max_rssi_dbm": ("ours", "a receiver saturates; nothing reads the RSSI"),
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
    "location_server.load_radio_map": "the experiment builds each radio map itself (the grid survey, the robot's)",
    "location_server.map_file": "the experiment's map",
    **{f"robot_sim.{name}": "in-process the robot is an ideal unicycle (robot.motion) whose odometry is off by "
                            "robot.odometry_scale_error (the scenario's robot_sim: a test checks it)"
       for name in ("world_file", "start_x", "start_y", "start_yaw_deg", "step_s", "rtf", "step_participants",
                    "start_paused", "map_to_odom_at_start", "odom_rate_hz", "seed", "track_width_m",
                    "max_wheel_speed_mps", "max_wheel_accel_mps2", "command_timeout_s", "odom_left_scale_error",
                    "odom_right_scale_error", "odom_track_scale_error", "odom_slip_std", "walls_stop_base")},
    "robot_sim.robots": "one robot: several in one world are scenarios over DDS only (robots:)",
    "robot_sim.robot_starts": "as above",
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
