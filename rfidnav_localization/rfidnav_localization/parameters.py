"""Parameters of the localization nodes (partition_localizer, location_server): typed, with defaults and
descriptions, importable without rclpy so the orchestrator and the in-process runner validate parameter files
against the same class.

The partition localizer's defaults are the paper-000 set; config/params/partition_localizer_paper.yaml repeats
them and config/params/partition_localizer_filter.yaml selects the particle filter.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

from rfidnav_common.config import (
    AT_LEAST_ONE,
    DBM,
    MAX_PORT,
    NON_NEGATIVE,
    PORT,
    POSITIVE,
    READ_RANGE_M,
    SEED,
    Limits,
    param,
)
from rfidnav_common.errors import ParameterError
from rfidnav_common.node_registry import NodeRegistration, ReadsAntennaPorts
from rfidnav_common.robot_map import load_route_map
from rfidnav_common.wall_tags import InductionArea
from rfidnav_localization.fingerprint import WEIGHTINGS, LocateSettings
from rfidnav_localization.fused.filter import Ports
from rfidnav_localization.fused.models import (
    CompassModel,
    FloorModel,
    PhaseDifferenceModel,
    WifiModel,
)
from rfidnav_localization.fused.settings import FusedSettings
from rfidnav_localization.partition import LocalizerSettings
from rfidnav_localization.partition.estimate import METHODS


@dataclass(frozen=True)
class PartitionLocalizerParameters(ReadsAntennaPorts):
    # The orchestrator gives every non-sim node a map_file. Positions need none (they come from the tag ids); an
    # empty default cannot be declared, as parameter strings must be non-empty (rfidnav_common.config).
    map_file: str = param("robot map: its deployment_area tells the filter where tags exist ('unused': no map)",
                          "unused")
    method: str = param("paper (partition centre, sec. 4.2 orientation bounds) or filter (particle filter)", "paper",
                        Limits(choices=METHODS))
    antenna: int = param("reader port of the downward antenna that reads the floor tags", 1, PORT)
    map_frame: str = param("frame of the published pose", "map")
    publish_tf: bool = param("publish map -> odom on /tf from each estimate with a heading (REP 105); turn it off "
                             "where another localizer's estimate drives the mission", True)
    seed: int = param("run seed; the node draws its own random stream from it", 0, SEED)
    turn_threshold_rad: float = param(
        "odometry heading change that ends a straight stretch (the partitions traversed start again) [rad]", 0.05,
        Limits(0.0, math.pi, low_open=True))
    particles: int = param("filter: number of particles", 500, Limits(10, 1_000_000))
    motion_noise_fraction: float = param("filter: odometry translation and rotation noise, relative", 0.02,
                                         Limits(0.0, 1.0))
    motion_noise_floor_m: float = param("filter: translation noise added to each step that moves [m]", 0.001,
                                        NON_NEGATIVE)
    motion_noise_yaw_rad_per_m: float = param("filter: heading noise per metre travelled [rad/m]", 0.02,
                                              NON_NEGATIVE)
    boundary_softness_m: float = param(
        "filter: width of the soft read/no-read edge of a tag's disc (about the distance moved per round) [m]",
        0.004, POSITIVE)
    read_error_probability: float = param(
        "filter: chance that a tag's read or no-read contradicts the disc geometry (missed or spurious read)", 0.01,
        Limits(0.0, 0.5, low_open=True, high_open=True))
    rogue_distance_factor: float = param(
        "tags read in one round lie within this factor times the read range of each other; others are rogue", 2.0,
        POSITIVE)
    antenna_offset_m: float = param(
        "filter: how far ahead of the rotation axis the floor antenna reads [m] (paper method: 0 only)", 0.0)

    def validate(self) -> None:
        self.settings().validate()

    def antenna_ports_read(self) -> dict[str, int]:
        """The reader ports this node takes reads of, by parameter: the reader must publish each of them."""
        return {"antenna": self.antenna}

    def settings(self) -> LocalizerSettings:
        # Every localizer setting is a node parameter of the same name, but the tagged area: the map's.
        values = {field.name: getattr(self, field.name) for field in dataclasses.fields(LocalizerSettings)
                  if field.name != "deployment_area"}
        area = load_route_map(Path(self.map_file)).deployment_area if self.map_file != "unused" else None
        return LocalizerSettings(**values, deployment_area=area)


@dataclass(frozen=True)
class LocationServerParameters:
    """The location server of paper 003: radio map and tag map in an SQLite database file."""

    database_file: str = param("the location database (SQLite): radio map and tag map; a relative path is taken "
                               "from run_dir", "location.db")
    run_dir: str = param("where a relative database_file lives (the orchestrator sets the run's folder)", ".")
    create_database: bool = param("create the database when the file is missing (else: one error at start)",
                                  False)
    map_file: str = param("robot map: its tag_groups, and its radio_map when the database has no fingerprints, are "
                          "loaded at start ('unused': none)", "unused")
    load_radio_map: bool = param("load the map's radio_map into a database without fingerprints at start; false: "
                                 "start without any, for the robot's own survey (/survey) to build them", True)
    k: int = param("neighbours averaged by the fingerprint matcher (k-nearest neighbours, RADAR)", 3,
                   Limits(1, 10_000))
    missing_rss_dbm: float = param(
        "RSS substituted for an AP heard on one side only (scan or fingerprint) [dBm]: below any sensitivity", -100.0,
        DBM)
    min_common_aps: int = param("a fingerprint sharing fewer APs with the scan is not a candidate", 1, AT_LEAST_ONE)
    weighting: str = param("inverse_distance (1 / signal distance) or uniform", "inverse_distance",
                           Limits(choices=WEIGHTINGS))

    def validate(self) -> None:
        if not self.database_file:
            raise ParameterError("database_file", "required")
        # A folder is refused here, before the node starts (as the node it would fail at start, be restarted and
        # fail again): a name ending in a separator, ".", "..", or an absolute path to a folder.
        named = Path(self.database_file)
        if self.database_file.endswith("/") or named.name in ("", ".", "..") or (named.is_absolute()
                                                                               and named.is_dir()):
            raise ParameterError("database_file", f"names a folder, not a file: {self.database_file}")
        self.locate_settings().validate()

    def database_path(self) -> Path:
        return Path(self.run_dir) / self.database_file     # an absolute database_file stays as it is

    def locate_settings(self) -> LocateSettings:
        return LocateSettings(k=self.k, missing_rss_dbm=self.missing_rss_dbm, min_common_aps=self.min_common_aps,
                              weighting=self.weighting)


@dataclass(frozen=True)
class RfidLocalizerParameters(ReadsAntennaPorts):
    """rfid_localizer (the fused localizer): what the robot map declares decides which evidence it weighs; the
    reader's geometry and noise are the reader's own parameters under the same names (antenna_positions,
    antenna_phase_offset_rad, phase_noise_rad_per_m: copy them from the reader's file), so one file describes
    the robot for the simulator, the driver and the localizer."""

    map_file: str = param("robot map: extent, tag_groups, deployment_area, ceiling_tags, wall_tags (required)",
                          "unused")
    map_frame: str = param("frame of the published pose and the parent of map -> odom", "map")
    pose_topic: str = param("where the pose goes (AMCL's is amcl_pose)", "localization/pose")
    status_topic: str = param("where LocalizationStatus goes", "localization/status")
    initial_pose_topic: str = param("a PoseWithCovarianceStamped in map_frame restarts the filter about it",
                                    "initialpose")
    publish_tf: bool = param("publish map -> odom on /tf from each estimate (REP 105)", True)
    seed: int = param("run seed; the node draws its own random stream from it", 0, SEED)
    initial_pose: list[float] = param("x, y, yaw [m, m, rad] of a known start; empty: unknown (global "
                                      "localization from the first evidence)", [])
    initial_sd: list[float] = param("sd of x, y, yaw about initial_pose [m, m, rad]", [0.1, 0.1, 0.05])
    particles: int = param("particles of the filter", 1000, Limits(10, 1_000_000))
    odometry_noise_m: float = param("sd of the odometry's distance error over a metre travelled, growing with the "
                                    "square root of the distance (a random walk) [m]", 0.05, NON_NEGATIVE)
    turn_noise_fraction: float = param("sd of a turn's odometry error, relative to the turn", 0.05, Limits(0.0, 1.0))
    heading_noise_rad: float = param("sd of the heading drift over a metre travelled (wheel slip), growing with the "
                                     "square root of the distance [rad]", 0.02, NON_NEGATIVE)
    odometry_scale_sd: float = param("prior sd of the odometry's distance scale about 1 (per particle)", 0.05,
                                     NON_NEGATIVE)
    odometry_scale_walk: float = param("random walk of each particle's odometry scale [per sqrt(m) travelled]: it "
                                       "drifts, and a parameter that never moves collapses to one value", 0.005,
                                       NON_NEGATIVE)
    antenna_positions: list[float] = param("x, y, z of each reader port 1, 2, ... in base_link [m] (the reader's "
                                           "parameter)", [0.0, 0.0, 0.05])
    antenna_phase_offset_rad: list[float] = param("each port's phase offset [rad] (the reader's parameter)", [0.0])
    phase_noise_rad_per_m: float = param("phase noise per metre of tag distance [rad/m] (the reader's parameter)",
                                         0.02, NON_NEGATIVE)
    floor_antenna: int = param("reader port of the downward antenna over floor tags; 0: none", 1,
                               Limits(0, MAX_PORT))
    floor_softness_m: float = param("width of a floor tag disc's soft read edge [m]", 0.004, POSITIVE)
    tag_group_read_range_m: float = param("the floor antenna's reach over a tag group's tags [m]", 0.05,
                                          READ_RANGE_M)
    phase_antennas: list[int] = param("the two receiving ports whose phase difference locates a ceiling tag "
                                      "(paper 001); empty: none", [])
    phase_floor_rad: float = param("phase difference noise besides the distance's (multipath) [rad]", 0.02,
                                   POSITIVE)
    wall_antenna: int = param("reader port of the side antenna reading wall tags (paper 004); 0: none", 0,
                              Limits(0, MAX_PORT))
    wall_area_bearing_rad: float = param("the side antenna's bearing, CCW from forward [rad]", math.pi / 2.0,
                                         Limits(-math.pi, math.pi))
    wall_area_width_m: float = param("its induction area's width [m]", 0.40, POSITIVE)
    wall_area_depth_m: float = param("its induction area's depth from the antenna [m]", 1.00, POSITIVE)
    wall_softness_m: float = param("width of the induction area's soft edge [m]", 0.02, POSITIVE)
    use_wifi: bool = param("ask the location server to locate each /wifi/scan and weigh its answer", False)
    locate_service: str = param("the location server's Locate service", "/location_server/locate")
    wifi_sd_floor_m: float = param("a WiFi fix is never trusted closer than this [m]", 1.0, POSITIVE)
    wifi_min_travel_m: float = param("odometry distance between WiFi fixes weighed (their errors are spatially "
                                     "correlated) [m]", 2.0, NON_NEGATIVE)
    use_compass: bool = param("weigh /compass headings", True)
    compass_sd_rad: float = param("compass noise from reading to reading [rad]", math.radians(2.0), POSITIVE)
    compass_bias_sd_rad: float = param("prior sd of the compass's constant bias (per particle) [rad]",
                                       math.radians(4.0), NON_NEGATIVE)
    compass_bias_walk_rad: float = param("random walk of each particle's compass bias [rad per sqrt(m) travelled]",
                                         math.radians(0.5), NON_NEGATIVE)
    eps: float = param("the most one reading can cost: its likelihood never falls below this", 0.01,
                       Limits(0.0, 0.5, low_open=True, high_open=True))
    reset_threshold: float = param("the average likelihood of a kind's evidence below which particles are "
                                   "redrawn from it (0: never)", 0.1, Limits(0.0, 1.0, high_open=True))
    resample_threshold: float = param("resample when the effective sample size falls below this share", 0.5,
                                      Limits(0.0, 1.0, low_open=True))

    def validate(self) -> None:
        if self.map_file == "unused":
            raise ParameterError("map_file", "required: the robot map says which tags exist and where")
        if len(self.initial_pose) not in (0, 3):
            raise ParameterError("initial_pose", f"x, y, yaw or empty, got {len(self.initial_pose)} numbers")
        if len(self.initial_sd) != 3 or min(self.initial_sd) <= 0.0:
            raise ParameterError("initial_sd", f"three positive numbers, got {self.initial_sd}")
        ports = len(self.antenna_positions) // 3
        if len(self.antenna_positions) % 3 or ports == 0:
            raise ParameterError("antenna_positions", "x, y, z per port: a positive multiple of 3 numbers")
        if len(self.antenna_phase_offset_rad) != ports:
            raise ParameterError("antenna_phase_offset_rad", f"one per port ({ports}), got "
                                                             f"{len(self.antenna_phase_offset_rad)}")
        if self.phase_antennas and (len(self.phase_antennas) != 2 or len(set(self.phase_antennas)) != 2):
            raise ParameterError("phase_antennas", f"two different ports or none, got {self.phase_antennas}")
        for name, port in [("floor_antenna", self.floor_antenna), ("wall_antenna", self.wall_antenna),
                           *(("phase_antennas", p) for p in self.phase_antennas)]:
            if port > ports:
                raise ParameterError(name, f"port {port} has no antenna_positions entry ({ports} ports)")

    def antenna_ports_read(self) -> dict[str, int]:
        """The reader ports this node takes reads of, by parameter: the reader must publish each of them."""
        ports = {"floor_antenna": self.floor_antenna, "wall_antenna": self.wall_antenna}
        ports.update({f"phase_antennas[{i}]": port for i, port in enumerate(self.phase_antennas)})
        return {name: port for name, port in ports.items() if port}

    def ports(self) -> Ports:
        first_and_second = (self.phase_antennas[0], self.phase_antennas[1]) if self.phase_antennas else None
        return Ports(self.floor_antenna, first_and_second, self.wall_antenna)

    def antenna(self, port: int) -> tuple[float, float, float]:
        x, y, z = self.antenna_positions[3 * (port - 1):3 * port]
        return x, y, z

    def settings(self) -> FusedSettings:
        floor = self.antenna(self.floor_antenna) if self.floor_antenna else (0.0, 0.0, 0.0)
        phase = None
        if self.phase_antennas:
            first, second = self.phase_antennas
            phase = PhaseDifferenceModel(self.antenna(first), self.antenna(second),
                                         self.antenna_phase_offset_rad[first - 1],
                                         self.antenna_phase_offset_rad[second - 1], self.phase_noise_rad_per_m,
                                         self.phase_floor_rad, self.eps)
        walls = {}
        if self.wall_antenna:
            x, y, _ = self.antenna(self.wall_antenna)
            walls[self.wall_antenna] = InductionArea((x, y), self.wall_area_bearing_rad, self.wall_area_width_m,
                                                     self.wall_area_depth_m)
        return FusedSettings(
            particles=self.particles, odometry_noise_m=self.odometry_noise_m,
            turn_noise_fraction=self.turn_noise_fraction, heading_noise_rad=self.heading_noise_rad,
            floor=FloorModel((floor[0], floor[1]), self.floor_softness_m, self.eps),
            tag_group_read_range_m=self.tag_group_read_range_m, phase=phase, wall_areas=walls,
            wall_softness_m=self.wall_softness_m, wifi=WifiModel(sd_floor_m=self.wifi_sd_floor_m, eps=self.eps),
            wifi_min_travel_m=self.wifi_min_travel_m, compass=CompassModel(self.compass_sd_rad, self.eps),
            compass_bias_sd_rad=self.compass_bias_sd_rad, odometry_scale_sd=self.odometry_scale_sd,
            odometry_scale_walk=self.odometry_scale_walk, compass_bias_walk_rad=self.compass_bias_walk_rad,
            eps=self.eps,
            reset_threshold=self.reset_threshold, resample_threshold=self.resample_threshold)


# The node executables of this package, as the rfidnav.nodes entry points of its setup.py register them
# (rfidnav_common.node_registry).
PARTITION_LOCALIZER = NodeRegistration("partition_localizer", PartitionLocalizerParameters, stepped=True)
LOCATION_SERVER = NodeRegistration("location_server", LocationServerParameters, stepped=True)
RFID_LOCALIZER = NodeRegistration("rfid_localizer", RfidLocalizerParameters, stepped=True)
