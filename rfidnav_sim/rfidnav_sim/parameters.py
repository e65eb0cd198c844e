"""Parameters of the simulator nodes: typed, with defaults and descriptions, importable without rclpy.

The nodes declare them (rfidnav_common.ros.declare_parameters) and the orchestrator validates
parameter files against them before any process starts. config/params/*.yaml document them.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections import Counter
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from rfidnav_common.config import (
    DBM,
    DURATION_S,
    FRACTION,
    MAX_DURATION_S,
    NON_NEGATIVE,
    POSITIVE,
    PROBABILITY,
    RATE_HZ,
    READ_RANGE_M,
    SEED,
    SPEED_MPS,
    YAW_DEG,
    Limits,
    param,
)
from rfidnav_common.errors import ParameterError
from rfidnav_common.frames import (
    BASE_FRAME,
    FACINGS,
    MAP_FRAME,
    ODOM_FRAME,
    Frame,
    antenna_frames,
    frame_prefix,
    prefixed,
)
from rfidnav_common.inputs import RSS_DBM
from rfidnav_common.node_registry import LimitsSpeed, NodeRegistration, PublishesAntennaPorts
from rfidnav_common.polling import PollClock, Polling
from rfidnav_common.seeding import rng_for, robot_seed
from rfidnav_sim.compass_model import CompassModel
from rfidnav_sim.kinematics import BaseLimits, DiffDriveBase, OdometryDrift, Pose2D
from rfidnav_sim.rfid_model import Antenna, PolledReader, ReaderModel, ReaderSimulator, budget_range_m
from rfidnav_sim.rig import ScheduledSensor
from rfidnav_sim.sonar_model import PAPER_LAYOUT, SonarModel
from rfidnav_sim.wifi_model import RssReading, WifiModel
from rfidnav_sim.world import World

SCALE_ERROR = Limits(-1.0, 1.0, low_open=True, high_open=True)   # -1: a wheel (or the track) that measures nothing
HALF_ANGLE_DEG = Limits(0.0, 180.0, low_open=True)                 # 180: all round


ROBOT_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")    # a robot's name is its namespace: one ROS name token


@dataclass(frozen=True)
class RobotSimParameters(LimitsSpeed):
    world_file: str = param("world YAML (ground truth: tags, walls)", "")
    start_x: float = param("start position x in the map frame [m]", 0.0)
    start_y: float = param("start position y in the map frame [m]", 0.0)
    start_yaw_deg: float = param("start heading, CCW from the map's x axis [deg]", 0.0, YAW_DEG)
    step_s: float = param("fixed physics step [s]", 0.01, Limits(0.0, 1.0, low_open=True))
    rtf: float = param("real-time factor: sim seconds per wall second; with the stepped clock a ceiling, and .inf "
                       "(the command line's max) none: as fast as the participants answer", 1.0,
                       Limits(0.0, low_open=True, unbounded=True))
    step_participants: list[str] = param(
        "stepped clock: the fully qualified names of the nodes whose answers on /sim/step_ack each step waits "
        "for (rfidnav_common.stepped_node); set by the orchestrator", [])
    start_paused: bool = param("hold the clock at zero until ~/start is called", False)
    map_to_odom_at_start: bool = param(
        "publish map -> odom on /tf_static as the start pose (where odometry starts, known to the robot): for "
        "missions without a localizer, so that viewers can place odom in the map; leave it off where a localizer "
        "publishes map -> odom", False)
    odom_rate_hz: float = param("rate of /clock, /odom and /sim/ground_truth [Hz, sim time]", 50.0, RATE_HZ)
    seed: int = param("run seed; the odometry slip stream derives from it", 0, SEED)
    track_width_m: float = param("distance between the wheels [m]", 0.30, POSITIVE)
    max_wheel_speed_mps: float = param("wheel speed limit [m/s]", 0.5, SPEED_MPS)
    max_wheel_accel_mps2: float = param("wheel acceleration limit [m/s^2]", 1.0, POSITIVE)
    command_timeout_s: float = param("stop when no /cmd_vel arrived for this long [s, sim time]", 0.5, DURATION_S)
    odom_left_scale_error: float = param("left wheel travel error of the odometry (0.01 = +1%)", 0.0, SCALE_ERROR)
    odom_right_scale_error: float = param("right wheel travel error of the odometry", 0.0, SCALE_ERROR)
    odom_track_scale_error: float = param("track width error of the odometry", 0.0, SCALE_ERROR)
    odom_slip_std: float = param("random relative wheel travel error per step", 0.0, FRACTION)
    footprint_radius_m: float = param("radius of the round base: closer than this to a wall it stalls and "
                                      "bumps [m]", 0.17, POSITIVE)
    walls_stop_base: bool = param("false: the walls only echo sonar and the base drives through them (for a "
                                  "navigator that cannot get round a wall, see two_tier_home)", True)
    robots: list[str] = param(
        "several robots in one world: their names, each its ROS namespace (r1: /r1/cmd_vel, /r1/odom, "
        "/r1/sim/ground_truth, r1/odom -> r1/base_link on /tf), each a base of these parameters at its entry of "
        "robot_starts and an obstacle to the others; empty: one robot at start_x, start_y, start_yaw_deg in the "
        "root namespace. Set by the orchestrator from a scenario's robots:", [])
    robot_starts: list[float] = param("x [m], y [m] and yaw [deg] of each of robots, in their order", [])

    def base(self, walls: np.ndarray | None = None) -> DiffDriveBase:
        """The base these parameters describe, at the start pose, its odometry slip stream seeded from ``seed``,
        stopped by ``walls`` (the world's N x 4 segments): the one robot_sim steps and the in-process runners
        step alike."""
        return DiffDriveBase(
            Pose2D(self.start_x, self.start_y, math.radians(self.start_yaw_deg)),
            BaseLimits(self.track_width_m, self.max_wheel_speed_mps, self.max_wheel_accel_mps2, self.command_timeout_s,
                       self.footprint_radius_m),
            OdometryDrift(self.odom_left_scale_error, self.odom_right_scale_error, self.odom_track_scale_error,
                          self.odom_slip_std),
            rng_for(self.seed, "robot_sim.odometry"), walls if self.walls_stop_base else None)

    def fleet(self, walls: np.ndarray | None = None) -> dict[str, DiffDriveBase]:
        """The bases of the world by robot name ('' for the one robot of the root namespace): each at its start with
        its own odometry stream (rfidnav_common.seeding.robot_seed), the others its obstacles."""
        if not self.robots:
            return {"": self.base(walls)}
        bases = {name: dataclasses.replace(self, start_x=x, start_y=y, start_yaw_deg=yaw_deg,
                                           seed=robot_seed(self.seed, name)).base(walls)
                 for name, (x, y, yaw_deg) in zip(self.robots, self.starts(), strict=True)}
        for name, base in bases.items():
            base.others = [other for other_name, other in bases.items() if other_name != name]
        return bases

    def starts(self) -> list[tuple[float, float, float]]:
        """Each robot's (x, y, yaw_deg), in the order of robots."""
        values = self.robot_starts
        return [(values[i], values[i + 1], values[i + 2]) for i in range(0, len(values), 3)]

    def start_frames(self) -> list[Frame]:
        """map -> odom at each robot's start, its odom prefixed with its name (r1/odom)."""
        if not self.robots:
            return [self.start_frame()]
        return [prefixed(Frame.planar(MAP_FRAME, ODOM_FRAME, (x, y, math.radians(yaw_deg))), frame_prefix(name))
                for name, (x, y, yaw_deg) in zip(self.robots, self.starts(), strict=True)]

    def speed_limit(self) -> tuple[str, float]:
        """The parameter that bounds the forward speed the base drives, and its value: no node may command more."""
        return "max_wheel_speed_mps", self.max_wheel_speed_mps

    def start_frame(self) -> Frame:
        return Frame.planar(MAP_FRAME, ODOM_FRAME, (self.start_x, self.start_y, math.radians(self.start_yaw_deg)))

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML to simulate)")
        if len(self.robot_starts) != 3 * len(self.robots):
            raise ParameterError("robot_starts", f"{len(self.robot_starts)} values for {len(self.robots)} robots: "
                                                 "x, y and yaw_deg of each")
        for name in self.robots:
            if not ROBOT_NAME.fullmatch(name):
                raise ParameterError("robots", f"'{name}' is no robot name (a ROS namespace token: a letter, then "
                                               "letters, digits or _)")
        if len(set(self.robots)) != len(self.robots):
            raise ParameterError("robots", f"a name given twice: {self.robots}")
        for (one, (x1, y1, _)), (other, (x2, y2, _)) in combinations(zip(self.robots, self.starts()), 2):
            if math.hypot(x2 - x1, y2 - y1) < 2.0 * self.footprint_radius_m:
                raise ParameterError("robot_starts", f"{one} and {other} start overlapping "
                                                     f"({math.hypot(x2 - x1, y2 - y1):.2f} m apart)")


SIDE_BEARINGS = {"left": math.pi / 2.0, "right": -math.pi / 2.0}
PER_ANTENNA = ("antenna_max_range_m", "antenna_half_angle_deg", "antenna_phase_offset_rad")


def check_one_per_antenna(counts: dict[str, int]) -> None:
    """The per-antenna lists (``counts``: name -> antennas it describes) describe as many antennas: the lists that
    disagree with the most of them are the ones in error (a ParameterError naming the first)."""
    agreed, _ = Counter(counts.values()).most_common(1)[0]
    for name, count in counts.items():
        if count != agreed:
            others = ", ".join(other for other, value in counts.items() if value == agreed)
            raise ParameterError(name, f"describes {count} antenna{'s' if count != 1 else ''}, but {others} "
                                       f"describe {agreed} (one entry per antenna; antenna_positions: 3 numbers)")


@dataclass(frozen=True)
class ReaderParameters(PublishesAntennaPorts):
    world_file: str = param("world YAML (ground truth: tag ids and positions)", "")
    seed: int = param("run seed; the noise and miss streams derive from it", 0, SEED)
    rate_hz: float = param("inventory rounds per second [Hz, sim time]; a polled reader's fastest", 25.0, RATE_HZ)
    round_jitter_s: float = param(
        "a polled reader: each round comes 1/rate_hz plus a uniform 0..this after the one before [s] (paper 003's HF "
        "reader: 500-600 ms); 0: rounds on the 1/rate_hz grid of sim time", 0.0, Limits(0.0, MAX_DURATION_S))
    round_failure_probability: float = param("probability that a whole round reads nothing, whatever is in range "
                                             "(a failed poll)", 0.0, PROBABILITY)
    frame_id: str = param("frame of the reader; antenna positions are given in it", "base_link")
    antenna_frame_prefix: str = param("frame of antenna port N: PREFIX + N, published on /tf_static in frame_id "
                                      "(x along the boresight)", "rfid_antenna_")
    antenna_positions: list[float] = param(
        "x, y, z of each antenna in the reader frame [m], concatenated; antenna ports are 1, 2, ... in order",
        [0.0, 0.03, 0.30, 0.0, -0.03, 0.30, 0.0, 0.0, 0.05])
    antenna_facing: list[str] = param("boresight of each antenna: up (ceiling tags), down (floor tags), or left / "
                                      "right (wall tags, in an induction area)", ["up", "up", "down"],
                                      Limits(choices=FACINGS))
    antenna_max_range_m: list[float] = param(
        "cap on each antenna's slant read range [m], at most the link budget's boresight range (the budget, "
        "rfid_model.reach_m, decides how far a tag is heard); side antennas: the induction area's depth",
        [12.0, 12.0, 0.10], READ_RANGE_M)
    antenna_half_angle_deg: list[float] = param("beam cone half-angle of each antenna [deg]", [85.0, 85.0, 60.0],
                                                HALF_ANGLE_DEG)
    antenna_phase_offset_rad: list[float] = param("phase delay of each antenna port and cable [rad]",
                                                  [0.0, 0.0, 0.0], Limits(-2.0 * math.pi, 2.0 * math.pi))
    channels_mhz: list[float] = param("channel frequencies [MHz]; more than one hops between them", [915.25], POSITIVE)
    hop_dwell_s: float = param("time on each channel when hopping [s]", 0.2, DURATION_S)
    phase_noise_rad_per_m: float = param("phase noise standard deviation per metre of distance [rad/m]", 0.02,
                                         NON_NEGATIVE)
    miss_probability: float = param("probability that a readable tag is missed in a round", 0.0, PROBABILITY)
    rssi_at_1m_dbm: float = param("RSSI of a tag 1 m away on boresight [dBm]", -40.0, DBM)
    sensitivity_dbm: float = param("weakest RSSI the reader decodes [dBm]", -90.0, DBM)
    max_rssi_dbm: float = param(
        "strongest RSSI the reader reports [dBm]: its receiver saturates, so a tag on the antenna reads no stronger "
        "(the link budget alone gives +50 dBm 2 mm from the HF floor antenna; every consumer refuses a read above "
        "+30 dBm, rfidnav_common.inputs.RSS_DBM)", -10.0, Limits(RSS_DBM[0], RSS_DBM[1]))
    pattern_exponent: float = param("antenna gain pattern cos(angle)^n, one way", 1.0, Limits(0.0, 100.0))
    side_area_width_m: float = param("side antennas: width of the induction area [m] (paper 004: 40 cm)", 0.40,
                                     READ_RANGE_M)
    passage_miss_probability: float = param("side antennas: probability that a wall tag is missed for a whole "
                                            "passage through the induction area (paper 004's read failure)", 0.0,
                                            FRACTION)
    unreadable_tags: list[str] = param("side antennas: wall tag ids never read (broken or covered plates: forced "
                                       "read failures)", [])

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML whose tags are read)")
        if not self.antenna_facing:
            raise ParameterError("antenna_facing", "at least one antenna is needed")
        if len(self.antenna_positions) % 3:
            raise ParameterError("antenna_positions", f"expected 3 numbers (x, y, z) per antenna, got "
                                                      f"{len(self.antenna_positions)}")
        check_one_per_antenna({"antenna_facing": len(self.antenna_facing),
                               "antenna_positions": len(self.antenna_positions) // 3,
                               **{name: len(getattr(self, name)) for name in PER_ANTENNA}})
        if not self.channels_mhz:
            raise ParameterError("channels_mhz", "at least one frequency is needed")
        if self.max_rssi_dbm <= self.sensitivity_dbm:
            raise ParameterError("max_rssi_dbm", f"{self.max_rssi_dbm:g} dBm is not above sensitivity_dbm "
                                                 f"{self.sensitivity_dbm:g}: no read could be reported")
        self.check_range_caps()

    def check_range_caps(self) -> None:
        """No antenna that reads by the link budget (up, down) claims a range beyond the budget's boresight range:
        the budget decides the reach (rfid_model.reach_m), ``antenna_max_range_m`` can only cap it."""
        budget = budget_range_m(self.reader_model())
        for index, (facing, cap) in enumerate(zip(self.antenna_facing, self.antenna_max_range_m)):
            if facing not in SIDE_BEARINGS and cap > budget:
                raise ParameterError(
                    f"antenna_max_range_m[{index}]",
                    f"{cap:g} m is more than the link budget reaches: {budget:.2f} m on boresight (rssi_at_1m_dbm "
                    f"{self.rssi_at_1m_dbm:g}, sensitivity_dbm {self.sensitivity_dbm:g}, 40 dB per decade), less "
                    f"off it; the budget decides the reach, this only caps it")

    def published_antenna_ports(self) -> tuple[str, tuple[int, ...]]:
        """The parameter that gives the antennas (ports 1, 2, ... in order) and their ports, as the LLRP driver's
        (the scenario checks the nodes reading /rfid/reads against them)."""
        return "antenna_facing", tuple(range(1, len(self.antenna_facing) + 1))

    def polling(self) -> Polling:
        return Polling(1.0 / self.rate_hz, self.round_jitter_s, self.round_failure_probability)

    def simulated_reader(self, world: World, seed: int) -> PolledReader:
        """The reader these parameters describe among ``world``'s tags, its streams seeded from ``seed``: the one
        the rfid_reader_sim node runs and the in-process runners run alike."""
        return PolledReader(ReaderSimulator.for_world(self.reader_model(), world, rng_for(seed, "rfid_reader_sim")),
                            PollClock(self.polling(), rng_for(seed, "rfid_reader_sim.rounds")))

    def antenna_frames(self) -> list[Frame]:
        """Each antenna's frame in the reader's, its x axis along the boresight (REP 103 for a sensor)."""
        ports = range(1, len(self.antenna_facing) + 1)
        return antenna_frames(self.frame_id, self.antenna_frame_prefix, ports, self.antenna_positions,
                              self.antenna_facing)

    def reader_model(self) -> ReaderModel:
        positions = np.reshape(self.antenna_positions, (-1, 3))
        antennas = tuple(
            Antenna(port=index + 1, position=(float(p[0]), float(p[1]), float(p[2])), facing_up=facing == "up",
                    max_range_m=rng, half_angle_rad=math.radians(angle), phase_offset_rad=offset,
                    side_bearing_rad=SIDE_BEARINGS.get(facing))
            for index, (p, facing, rng, angle, offset) in enumerate(zip(
                positions, self.antenna_facing, self.antenna_max_range_m, self.antenna_half_angle_deg,
                self.antenna_phase_offset_rad)))
        return ReaderModel(antennas=antennas, channels_hz=tuple(f * 1e6 for f in self.channels_mhz),
                           hop_dwell_s=self.hop_dwell_s, phase_noise_rad_per_m=self.phase_noise_rad_per_m,
                           miss_probability=self.miss_probability, rssi_at_1m_dbm=self.rssi_at_1m_dbm,
                           sensitivity_dbm=self.sensitivity_dbm, max_rssi_dbm=self.max_rssi_dbm,
                           pattern_exponent=self.pattern_exponent,
                           side_area_width_m=self.side_area_width_m,
                           passage_miss_probability=self.passage_miss_probability,
                           unreadable_tags=tuple(self.unreadable_tags))


@dataclass(frozen=True)
class CompassParameters:
    seed: int = param("run seed; the compass noise stream derives from it", 0, SEED)
    rate_hz: float = param("readings per second [Hz, sim time]", 10.0, RATE_HZ)
    frame_id: str = param("frame of the compass: /compass readings are in it; other than base_link, it is "
                          "published on /tf_static at the base's centre", "compass")
    noise_sd_deg: float = param("reading-to-reading noise, standard deviation [deg]", 2.0, Limits(0.0, 180.0))
    bias_deg: float = param("constant heading offset for the whole run [deg]", 0.0, Limits(-180.0, 180.0))

    def validate(self) -> None:
        self.model().validate()

    def frames(self) -> list[Frame]:
        return [] if self.frame_id == BASE_FRAME else [Frame(BASE_FRAME, self.frame_id, (0.0, 0.0, 0.0))]

    def model(self) -> CompassModel:
        return CompassModel(noise_sd_rad=math.radians(self.noise_sd_deg), bias_rad=math.radians(self.bias_deg))

    def sensor(self) -> ScheduledSensor[float]:
        """The compass compass_sim samples (a heading [rad] every 1/rate_hz), its stream seeded from ``seed``."""
        model = self.model()
        return ScheduledSensor(1.0 / self.rate_hz, lambda truth, rng: model.measure(truth[2], rng),
                               rng_for(self.seed, "compass_sim"))


@dataclass(frozen=True)
class WifiSimParameters:
    world_file: str = param("world YAML (ground truth: access points, walls, the building's propagation)", "")
    seed: int = param("run seed; the scan noise stream derives from it (the building's shadowing does not)", 0, SEED)
    scan_period_s: float = param("time between scans [s, sim time]; a real full-channel scan takes 2-4 s", 2.0,
                                 DURATION_S)
    frame_id: str = param("frame of the WiFi antenna", "base_link")
    interface: str = param("interface name reported in each scan", "sim")
    scan_noise_sd_db: float = param("per-reading noise of the receiver, standard deviation [dB]", 2.0,
                                    Limits(0.0, 100.0))
    sensitivity_dbm: float = param("weakest RSS the receiver reports [dBm]", -90.0, DBM)

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML to simulate)")

    def sensor(self, world: World) -> ScheduledSensor[list[RssReading]]:
        """The receiver wifi_sim samples among ``world``'s access points (a scan every scan_period_s), its noise
        stream seeded from ``seed`` (the building's shadowing from the world's own seed)."""
        receiver = dataclasses.replace(world.wifi, scan_noise_sd_db=self.scan_noise_sd_db,
                                       sensitivity_dbm=self.sensitivity_dbm)
        model = WifiModel(world.access_points, world.wall_segments(), receiver, world.wifi_seed)
        return ScheduledSensor(self.scan_period_s, lambda truth, rng: model.scan(truth[0], truth[1], rng),
                               rng_for(self.seed, "wifi_sim"))


@dataclass(frozen=True)
class SonarParameters:
    world_file: str = param("world YAML (ground truth: the walls the sonar echoes from)", "")
    seed: int = param("run seed; the sonar noise stream derives from it", 0, SEED)
    rate_hz: float = param("sonar sweeps per second: every rangefinder fires once a sweep [Hz, sim time]", 10.0,
                           RATE_HZ)
    frame_prefix: str = param("frame of rangefinder NAME: PREFIX + NAME (its pose in base_link: sonar_model)",
                              "sonar_")
    noise_sd_m: float = param("range noise, constant part [m]", 0.01, NON_NEGATIVE)
    noise_fraction: float = param("range noise, part proportional to the range", 0.01, FRACTION)
    rays_per_beam: int = param("rays spread over each 25-degree cone; the nearest echo is reported", 5,
                               Limits(1, 1000))
    specular_angle_deg: float = param("specular loss: a ray meeting a wall further than this from the wall's "
                                      "normal reflects away and gives no echo; 90 = every wall echoes [deg]", 90.0,
                                      Limits(0.0, 90.0, low_open=True))

    def frames(self) -> list[Frame]:
        """Each rangefinder's frame in base_link, x along its boresight (at the height of base_link: the paper
        gives none, and the walls are vertical)."""
        return [Frame.mounted(BASE_FRAME, self.frame_prefix + r.name, (r.position[0], r.position[1], 0.0),
                              yaw=r.bearing_rad) for r in PAPER_LAYOUT]

    def model(self, walls: np.ndarray) -> SonarModel:
        """paper 004's seven rangefinders among ``walls`` with these settings: the model sonar_sim fires and the
        in-process runner fires alike."""
        return SonarModel(PAPER_LAYOUT, walls, self.noise_sd_m, self.noise_fraction, self.rays_per_beam,
                          math.radians(self.specular_angle_deg))

    def sensor(self, world: World) -> ScheduledSensor[dict[str, float]]:
        """The sweeps sonar_sim samples among ``world``'s walls (every 1/rate_hz, each rangefinder's range by
        name), the noise stream seeded from ``seed``."""
        model = self.model(world.wall_segments())
        return ScheduledSensor(1.0 / self.rate_hz, lambda truth, rng: model.ranges(*truth, rng),
                               rng_for(self.seed, "sonar_sim"))

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML whose walls echo)")


# The node executables of this package, as the rfidnav.nodes entry points of its setup.py register them
# (rfidnav_common.node_registry).
ROBOT_SIM = NodeRegistration("robot_sim", RobotSimParameters, stepped=True)
RFID_READER_SIM = NodeRegistration("rfid_reader_sim", ReaderParameters, stepped=True)
COMPASS_SIM = NodeRegistration("compass_sim", CompassParameters, stepped=True)
WIFI_SIM = NodeRegistration("wifi_sim", WifiSimParameters, stepped=True)
SONAR_SIM = NodeRegistration("sonar_sim", SonarParameters, stepped=True)
