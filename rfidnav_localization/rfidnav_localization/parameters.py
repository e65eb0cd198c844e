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

from rfidnav_common.config import AT_LEAST_ONE, DBM, NON_NEGATIVE, PORT, POSITIVE, SEED, Limits, param
from rfidnav_common.errors import ParameterError
from rfidnav_common.robot_map import load_route_map
from rfidnav_localization.fingerprint import WEIGHTINGS, LocateSettings
from rfidnav_localization.partition import LocalizerSettings
from rfidnav_localization.partition.estimate import METHODS


@dataclass(frozen=True)
class PartitionLocalizerParameters:
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
        self.locate_settings().validate()

    def database_path(self) -> Path:
        return Path(self.run_dir) / self.database_file     # an absolute database_file stays as it is

    def locate_settings(self) -> LocateSettings:
        return LocateSettings(k=self.k, missing_rss_dbm=self.missing_rss_dbm, min_common_aps=self.min_common_aps,
                              weighting=self.weighting)
