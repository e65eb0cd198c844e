"""Parameters of the simulator nodes: typed, with defaults and descriptions, importable without rclpy.

The nodes declare them (rfidnav_common.ros.declare_parameters) and the orchestrator validates
parameter files against them before any process starts. config/params/*.yaml document them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfidnav_common.config import param, require_positive
from rfidnav_common.errors import ParameterError
from rfidnav_common.frames import BASE_FRAME, FACINGS, MAP_FRAME, ODOM_FRAME, Frame, antenna_frames
from rfidnav_common.polling import PollClock, Polling
from rfidnav_common.seeding import rng_for
from rfidnav_sim.compass_model import CompassModel
from rfidnav_sim.kinematics import BaseLimits, DiffDriveBase, OdometryDrift, Pose2D
from rfidnav_sim.rfid_model import Antenna, PolledReader, ReaderModel, ReaderSimulator
from rfidnav_sim.sonar_model import PAPER_LAYOUT, SonarModel
from rfidnav_sim.world import World


@dataclass(frozen=True)
class RobotSimParameters:
    world_file: str = param("world YAML (ground truth: tags, walls)", "")
    start_x: float = param("start position x in the map frame [m]", 0.0)
    start_y: float = param("start position y in the map frame [m]", 0.0)
    start_yaw_deg: float = param("start heading, CCW from the map's x axis [deg]", 0.0)
    step_s: float = param("fixed physics step [s]", 0.01)
    rtf: float = param("real-time factor: sim seconds per wall second; with the stepped clock a ceiling, and 0 "
                       "as fast as the participants answer", 1.0)
    step_participants: list[str] = param(
        "stepped clock: the fully qualified names of the nodes whose answers on /sim/step_ack each step waits "
        "for (rfidnav_common.stepped_node); set by the orchestrator", [])
    start_paused: bool = param("hold the clock at zero until ~/start is called", False)
    map_to_odom_at_start: bool = param(
        "publish map -> odom on /tf_static as the start pose (where odometry starts, known to the robot): for "
        "missions without a localizer, so that viewers can place odom in the map; leave it off where a localizer "
        "publishes map -> odom", False)
    odom_rate_hz: float = param("rate of /clock, /odom and /sim/ground_truth [Hz, sim time]", 50.0)
    seed: int = param("run seed; the odometry slip stream derives from it", 0)
    track_width_m: float = param("distance between the wheels [m]", 0.30)
    max_wheel_speed_mps: float = param("wheel speed limit [m/s]", 0.5)
    max_wheel_accel_mps2: float = param("wheel acceleration limit [m/s^2]", 1.0)
    command_timeout_s: float = param("stop when no /cmd_vel arrived for this long [s, sim time]", 0.5)
    odom_left_scale_error: float = param("left wheel travel error of the odometry (0.01 = +1%)", 0.0)
    odom_right_scale_error: float = param("right wheel travel error of the odometry", 0.0)
    odom_track_scale_error: float = param("track width error of the odometry", 0.0)
    odom_slip_std: float = param("random relative wheel travel error per step", 0.0)
    footprint_radius_m: float = param("radius of the round base: closer than this to a wall it stalls and "
                                      "bumps [m]", 0.17)
    walls_stop_base: bool = param("false: the walls only echo sonar and the base drives through them (for a "
                                  "navigator that cannot get round a wall, see two_tier_home)", True)

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

    def start_frame(self) -> Frame:
        return Frame.planar(MAP_FRAME, ODOM_FRAME, (self.start_x, self.start_y, math.radians(self.start_yaw_deg)))

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML to simulate)")
        if not self.rtf >= 0.0:
            raise ParameterError("rtf", f"must be positive, or 0 for as fast as the stepped graph answers: "
                                        f"got {self.rtf}")
        require_positive(self, "step_s", "odom_rate_hz", "track_width_m", "max_wheel_speed_mps",
                         "max_wheel_accel_mps2", "command_timeout_s", "footprint_radius_m")
        if self.odom_slip_std < 0.0:
            raise ParameterError("odom_slip_std", "must not be negative")



SIDE_BEARINGS = {"left": math.pi / 2.0, "right": -math.pi / 2.0}


@dataclass(frozen=True)
class ReaderParameters:
    world_file: str = param("world YAML (ground truth: tag ids and positions)", "")
    seed: int = param("run seed; the noise and miss streams derive from it", 0)
    rate_hz: float = param("inventory rounds per second [Hz, sim time]; a polled reader's fastest", 25.0)
    round_jitter_s: float = param(
        "a polled reader: each round comes 1/rate_hz plus a uniform 0..this after the one before [s] (paper 003's HF "
        "reader: 500-600 ms); 0: rounds on the 1/rate_hz grid of sim time", 0.0)
    round_failure_probability: float = param("probability that a whole round reads nothing, whatever is in range "
                                             "(a failed poll)", 0.0)
    frame_id: str = param("frame of the reader; antenna positions are given in it", "base_link")
    antenna_frame_prefix: str = param("frame of antenna port N: PREFIX + N, published on /tf_static in frame_id "
                                      "(x along the boresight)", "rfid_antenna_")
    antenna_positions: list[float] = param(
        "x, y, z of each antenna in the reader frame [m], concatenated; antenna ports are 1, 2, ... in order",
        [0.0, 0.03, 0.30, 0.0, -0.03, 0.30, 0.0, 0.0, 0.05])
    antenna_facing: list[str] = param("boresight of each antenna: up (ceiling tags), down (floor tags), or left / "
                                      "right (wall tags, in an induction area)", ["up", "up", "down"])
    antenna_max_range_m: list[float] = param("read range of each antenna [m]; side antennas: the induction "
                                             "area's depth", [12.0, 12.0, 0.10])
    antenna_half_angle_deg: list[float] = param("beam cone half-angle of each antenna [deg]", [85.0, 85.0, 60.0])
    antenna_phase_offset_rad: list[float] = param("phase delay of each antenna port and cable [rad]",
                                                  [0.0, 0.0, 0.0])
    channels_mhz: list[float] = param("channel frequencies [MHz]; more than one hops between them", [915.25])
    hop_dwell_s: float = param("time on each channel when hopping [s]", 0.2)
    phase_noise_rad_per_m: float = param("phase noise standard deviation per metre of distance [rad/m]", 0.02)
    miss_probability: float = param("probability that a readable tag is missed in a round", 0.0)
    rssi_at_1m_dbm: float = param("RSSI of a tag 1 m away on boresight [dBm]", -40.0)
    sensitivity_dbm: float = param("weakest RSSI the reader decodes [dBm]", -90.0)
    pattern_exponent: float = param("antenna gain pattern cos(angle)^n, one way", 1.0)
    side_area_width_m: float = param("side antennas: width of the induction area [m] (paper 004: 40 cm)", 0.40)
    passage_miss_probability: float = param("side antennas: probability that a wall tag is missed for a whole "
                                            "passage through the induction area (paper 004's read failure)", 0.0)
    unreadable_tags: list[str] = param("side antennas: wall tag ids never read (broken or covered plates: forced "
                                       "read failures)", [])

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML whose tags are read)")
        count = len(self.antenna_facing)
        if count == 0:
            raise ParameterError("antenna_facing", "at least one antenna is needed")
        if len(self.antenna_positions) != 3 * count:
            raise ParameterError("antenna_positions", f"expected 3 numbers per antenna ({3 * count}), "
                                 f"got {len(self.antenna_positions)}")
        for name in ("antenna_max_range_m", "antenna_half_angle_deg", "antenna_phase_offset_rad"):
            if len(getattr(self, name)) != count:
                raise ParameterError(name, f"expected one value per antenna ({count}), got {len(getattr(self, name))}")
        for facing in self.antenna_facing:
            if facing not in FACINGS:
                raise ParameterError("antenna_facing", f"'{facing}' is not one of {', '.join(FACINGS)}")
        if self.rate_hz <= 0.0 or self.hop_dwell_s <= 0.0:
            raise ParameterError("", "rate_hz and hop_dwell_s must be positive")
        if not self.channels_mhz or min(self.channels_mhz) <= 0.0:
            raise ParameterError("channels_mhz", "at least one positive frequency is needed")
        if not 0.0 <= self.miss_probability < 1.0:
            raise ParameterError("miss_probability", f"must be in [0, 1), got {self.miss_probability}")
        if not (math.isfinite(self.round_jitter_s) and self.round_jitter_s >= 0.0):
            raise ParameterError("round_jitter_s",
                                 f"must be a finite number of seconds >= 0, got {self.round_jitter_s}")
        if not 0.0 <= self.round_failure_probability < 1.0:
            raise ParameterError("round_failure_probability",
                                 f"must be in [0, 1), got {self.round_failure_probability}")
        if not 0.0 <= self.passage_miss_probability <= 1.0:
            raise ParameterError("passage_miss_probability", f"must be in [0, 1], got {self.passage_miss_probability}")
        if self.phase_noise_rad_per_m < 0.0:
            raise ParameterError("phase_noise_rad_per_m", "must not be negative")

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
                           sensitivity_dbm=self.sensitivity_dbm, pattern_exponent=self.pattern_exponent,
                           side_area_width_m=self.side_area_width_m,
                           passage_miss_probability=self.passage_miss_probability,
                           unreadable_tags=tuple(self.unreadable_tags))


@dataclass(frozen=True)
class CompassParameters:
    seed: int = param("run seed; the compass noise stream derives from it", 0)
    rate_hz: float = param("readings per second [Hz, sim time]", 10.0)
    frame_id: str = param("frame of the compass: /compass readings are in it; other than base_link, it is "
                          "published on /tf_static at the base's centre", "compass")
    noise_sd_deg: float = param("reading-to-reading noise, standard deviation [deg]", 2.0)
    bias_deg: float = param("constant heading offset for the whole run [deg]", 0.0)

    def validate(self) -> None:
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0.0):
            raise ParameterError("rate_hz", f"must be positive, got {self.rate_hz}")
        self.model().validate()

    def frames(self) -> list[Frame]:
        return [] if self.frame_id == BASE_FRAME else [Frame(BASE_FRAME, self.frame_id, (0.0, 0.0, 0.0))]

    def model(self) -> CompassModel:
        return CompassModel(noise_sd_rad=math.radians(self.noise_sd_deg), bias_rad=math.radians(self.bias_deg))


@dataclass(frozen=True)
class WifiSimParameters:
    world_file: str = param("world YAML (ground truth: access points, walls, the building's propagation)", "")
    seed: int = param("run seed; the scan noise stream derives from it (the building's shadowing does not)", 0)
    scan_period_s: float = param("time between scans [s, sim time]; a real full-channel scan takes 2-4 s", 2.0)
    frame_id: str = param("frame of the WiFi antenna", "base_link")
    interface: str = param("interface name reported in each scan", "sim")
    scan_noise_sd_db: float = param("per-reading noise of the receiver, standard deviation [dB]", 2.0)
    sensitivity_dbm: float = param("weakest RSS the receiver reports [dBm]", -90.0)

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML to simulate)")
        if not (math.isfinite(self.scan_period_s) and self.scan_period_s > 0.0):
            raise ParameterError("scan_period_s", f"must be positive, got {self.scan_period_s}")
        if not (math.isfinite(self.scan_noise_sd_db) and self.scan_noise_sd_db >= 0.0):
            raise ParameterError("scan_noise_sd_db",
                                 f"must be a finite non-negative number, got {self.scan_noise_sd_db}")
        if not math.isfinite(self.sensitivity_dbm):
            raise ParameterError("sensitivity_dbm", f"must be finite, got {self.sensitivity_dbm}")


@dataclass(frozen=True)
class SonarParameters:
    world_file: str = param("world YAML (ground truth: the walls the sonar echoes from)", "")
    seed: int = param("run seed; the sonar noise stream derives from it", 0)
    rate_hz: float = param("sonar sweeps per second: every rangefinder fires once a sweep [Hz, sim time]", 10.0)
    frame_prefix: str = param("frame of rangefinder NAME: PREFIX + NAME (its pose in base_link: sonar_model)",
                              "sonar_")
    noise_sd_m: float = param("range noise, constant part [m]", 0.01)
    noise_fraction: float = param("range noise, part proportional to the range", 0.01)
    rays_per_beam: int = param("rays spread over each 25-degree cone; the nearest echo is reported", 5)
    specular_angle_deg: float = param("specular loss: a ray meeting a wall further than this from the wall's "
                                      "normal reflects away and gives no echo; 90 = every wall echoes [deg]", 90.0)

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

    def validate(self) -> None:
        if not self.world_file:
            raise ParameterError("world_file", "required (the world YAML whose walls echo)")
        if not (math.isfinite(self.specular_angle_deg) and 0.0 < self.specular_angle_deg <= 90.0):
            raise ParameterError("specular_angle_deg", f"must be in (0, 90], got {self.specular_angle_deg}")
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0.0):
            raise ParameterError("rate_hz", f"must be positive, got {self.rate_hz}")
        for name in ("noise_sd_m", "noise_fraction"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0.0):
                raise ParameterError(name, f"must be a finite non-negative number, got {getattr(self, name)}")
        if self.rays_per_beam < 1:
            raise ParameterError("rays_per_beam", f"must be at least 1, got {self.rays_per_beam}")
