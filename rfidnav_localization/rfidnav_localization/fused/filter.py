"""The fused localizer's particle filter: Monte Carlo localization (as AMCL does for laser scans) over every kind
of tag evidence a robot map declares, WiFi fixes and the compass, moved by the wheel odometry (pure, no rclpy).

* Motion: each odometry increment (robot frame of the previous pose) with the noise of a random walk, its spread
  over a metre the same whatever the odometry's rate (rfidnav_localization.motion_model.walked_increments: drawn
  per step, relative to each step, it made the filter overconfident on paper 001's hallway, NEES inside its band
  8 % of the rounds on the development seed, 75 % with the walk), its distance times the particle's own odometry
  scale: wheel odometry is off by a scale that stays put (paper 003: about 1 m per
  20 m with a load), which noise drawn afresh each step would understate by an order of magnitude.
* Each particle also carries a compass bias (rfidnav_localization.fused.models.CompassModel).
* Both walk a little with the distance travelled (a random walk of sd ``*_walk`` per square root of a metre):
  they do drift (a load, a floor's grip, the steel near the compass), and a parameter with no dynamics collapses
  to one value after a few resamplings (sample impoverishment; Liu and West 2001), after which the filter can
  neither correct it nor know it is wrong: on paper 001's hallway every particle came to share one scale 7 %
  short within 5 s of its first floor tag, and the estimate fell half a metre behind the truth while claiming 4 cm.
* Weights: the sum of the log-likelihoods of the evidence present (rfidnav_localization.fused.models); a kind
  absent this round costs nothing. A ceiling tag heard on the same channel in the previous round also gives its
  range rate, weighed against each particle's pose then (kept from that round, after its resampling) and now.
  Resampling (systematic) when the effective sample size falls below half.
* Global localization and kidnap recovery: sensor resetting (Lenser and Veloso 2000), in the spirit of
  augmented MCL (Thrun, Burgard and Fox, *Probabilistic Robotics*, table 8.3). Each model scores 0 at best
  agreement, so the weight-averaged likelihood of a round's evidence of one kind says how well the particles
  explain it (1: perfectly). For each kind that can propose poses -- a floor tag read, a wall tag read, a WiFi
  fix -- a running average of it is kept (a tag read counts at once; WiFi fixes, whose errors run to metres,
  over several), restarted at 1 after every reset; when it falls below ``reset_threshold``, that share of the
  particles is redrawn at resampling from poses the evidence allows: over the floor tag, in the wall tag's
  induction area, about the WiFi fix, headed as the compass says less each new particle's bias. An unknown
  start is all particles uniform over the map's extent, whose averages start at 0: its first fix or read resets
  it.
* WiFi fixes are weighed only after the robot has travelled ``wifi_min_travel_m`` since the last one used:
  their errors are spatially correlated (the building's shadowing) and would otherwise be counted again and
  again, making the filter overconfident.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Generic, Protocol, TypeVar

import numpy as np
from scipy.spatial import cKDTree

from rfidnav_common.errors import ParameterError
from rfidnav_common.geometry import wrap_angle, wrap_angles
from rfidnav_common.wall_tags import InductionArea
from rfidnav_localization.fused.models import (
    CompassModel,
    FloorModel,
    PhaseDifferenceModel,
    WallTagModel,
    WifiModel,
    mounted,
)
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.motion_model import walked_increments

Reading = TypeVar("Reading")
# Readings of a kind held for the next round (HeldReadings): a compass at 10 Hz between rounds at 2 Hz holds 5.
HELD_READINGS = 16
EVIDENCE_KINDS = ("lattice", "tag_group", "ceiling_phase", "ceiling_range_rate", "wall_tag", "wifi", "compass")
# The kinds that can propose poses, and how much of their running average of the likelihood a new round
# replaces: a tag read no particle explains resets at once, a WiFi fix only after several (see the docstring).
RESET_MEMORY = {"lattice": 1.0, "tag_group": 1.0, "wall_tag": 1.0, "wifi": 0.5}
# Negative floor evidence (known tags near the particles that were not read) is weighed only while the cloud is
# this compact: a wide cloud would need thousands of lattice tags a round, and is placed by the reads anyway.
NEGATIVE_FLOOR_RADIUS_M = 0.5
# An unread tag farther than the read range plus this many soft edges from every particle's antenna scores
# 1 - eps for all of them (to within e^-6): it cannot change the weights, and weighing it costs particles x tags.
UNREAD_REACH_SOFTNESS = 6.0


@dataclass(frozen=True)
class FusedSettings:
    particles: int = 1000
    odometry_noise_m: float = 0.05                # sd of the distance error over a metre travelled (a random walk) [m]
    turn_noise_fraction: float = 0.05             # sd of a turn's error, relative
    heading_noise_rad: float = 0.02               # sd of the heading drift over a metre travelled (wheel slip) [rad]
    floor: FloorModel = FloorModel((0.0, 0.0))
    tag_group_read_range_m: float = 0.05          # the floor antenna's reach over a tag group's tags [m]
    phase: PhaseDifferenceModel | None = None     # None: no pair of receiving antennas
    wall_areas: dict[int, InductionArea] = field(default_factory=dict)   # side antenna port -> induction area
    wall_softness_m: float = 0.02
    wifi: WifiModel = WifiModel()
    wifi_min_travel_m: float = 2.0
    compass: CompassModel = CompassModel()
    compass_bias_sd_rad: float = math.radians(4.0)   # prior of the compass's constant bias
    odometry_scale_sd: float = 0.05                  # prior of the odometry's distance scale, about 1
    odometry_scale_walk: float = 0.005               # its random walk [per sqrt(m) travelled]
    compass_bias_walk_rad: float = math.radians(0.5)   # the compass bias's random walk [rad per sqrt(m)]
    eps: float = 0.01
    reset_threshold: float = 0.1                  # the average likelihood below which particles are redrawn
    resample_threshold: float = 0.5               # resample when the effective sample size falls below this share

    def validate(self) -> None:
        if self.particles < 10:
            raise ParameterError("particles", f"at least 10 needed, got {self.particles}")
        for name in ("odometry_noise_m", "turn_noise_fraction", "heading_noise_rad",
                     "wifi_min_travel_m", "compass_bias_sd_rad", "odometry_scale_sd", "odometry_scale_walk",
                     "compass_bias_walk_rad"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ParameterError(name, f"must be a non-negative number, got {value}")
        if not 0.0 <= self.reset_threshold < 1.0:
            raise ParameterError("reset_threshold", f"must lie in [0, 1), got {self.reset_threshold}")
        if not 0.0 < self.resample_threshold <= 1.0:
            raise ParameterError("resample_threshold", f"must lie in (0, 1], got {self.resample_threshold}")


@dataclass(frozen=True)
class PhaseReading:
    """One backscatter of a ceiling tag received on both antennas: the phase on each."""
    tag_id: str
    phase1_rad: float
    phase2_rad: float
    frequency_hz: float

    @property
    def dphi_rad(self) -> float:
        return self.phase1_rad - self.phase2_rad


WifiFix = tuple[tuple[float, float], float]      # the location server's answer: (position, uncertainty [m])


@dataclass(frozen=True)
class Evidence:
    """What one round of the sensors says; each kind is optional."""
    floor_tag_ids: Sequence[str] = ()                      # read by the downward antenna
    phase: Sequence[PhaseReading] = ()
    wall_tag_ids: Sequence[tuple[int, str]] = ()           # (side antenna port, tag id)
    wifi_fix: WifiFix | None = None
    compass_yaw_rad: float | None = None


class RoundRead(Protocol):
    """One read of an inventory round, as the node checks it (rfidnav_common.inputs.TagRead) and as the simulator
    makes it (rfidnav_sim.rfid_model.Read); a measurement not reported is NaN."""

    @property
    def tag_id(self) -> str: ...

    @property
    def antenna(self) -> int: ...

    @property
    def phase_rad(self) -> float: ...

    @property
    def frequency_hz(self) -> float: ...


@dataclass(frozen=True)
class Ports:
    """Which reader port gives which evidence; 0 or None: no such antenna."""
    floor: int = 0                          # downward: floor tags
    phase: tuple[int, int] | None = None    # the two receiving antennas under ceiling tags
    wall: int = 0                           # side: wall tags


def round_evidence(reads: Sequence[RoundRead], ports: Ports, wifi_fix: WifiFix | None,
                   compass_yaw_rad: float | None) -> Evidence:
    """One round's evidence: the floor antenna's tags, the side antenna's wall tags, and the phases of each
    ceiling tag heard on both receiving antennas on one channel (the last read of it on each), with the
    latest WiFi fix and compass heading. The node and the in-process runners both build it here."""
    phase: list[PhaseReading] = []
    if ports.phase is not None:
        heard: dict[int, dict[str, RoundRead]] = {port: {} for port in ports.phase}
        for read in reads:
            if read.antenna in heard and not (math.isnan(read.phase_rad) or math.isnan(read.frequency_hz)):
                heard[read.antenna][read.tag_id] = read
        first, second = (heard[port] for port in ports.phase)
        phase = [PhaseReading(tag_id, first[tag_id].phase_rad, second[tag_id].phase_rad, first[tag_id].frequency_hz)
                 for tag_id in first if tag_id in second and first[tag_id].frequency_hz == second[tag_id].frequency_hz]
    return Evidence(floor_tag_ids=[read.tag_id for read in reads if ports.floor and read.antenna == ports.floor],
                    phase=phase,
                    wall_tag_ids=[(read.antenna, read.tag_id) for read in reads
                                  if ports.wall and read.antenna == ports.wall],
                    wifi_fix=wifi_fix, compass_yaw_rad=compass_yaw_rad)


@dataclass
class HeldReadings(Generic[Reading]):
    """Readings of one kind (the compass's headings, the location server's fixes) held by their stamps for the
    reader rounds: a round weighs the latest stamped before it, once, and never one of its own step. Over DDS the
    messages of one step arrive in no fixed order (a round before or after that step's compass reading, or the
    answer to that step's scan); by the stamps a stepped run weighs the same readings whichever came first, so it
    follows its seed. The node and the in-process runners both hold WiFi fixes here. It holds the latest
    HELD_READINGS, so that a node whose reader has gone quiet does not keep every compass reading since."""
    readings: list[tuple[float, Reading]] = field(default_factory=list)     # (stamp [s], reading), oldest first

    def hold(self, reading: Reading, time_s: float) -> None:
        self.readings.append((time_s, reading))
        del self.readings[:-HELD_READINGS]

    def take(self, round_time_s: float) -> Reading | None:
        """The latest reading stamped before ``round_time_s``, or None; it and those before it are then dropped."""
        before = [held for held in self.readings if held[0] < round_time_s]
        if not before:
            return None
        self.readings = self.readings[len(before):]
        return before[-1][1]


@dataclass(frozen=True)
class Update:
    """What an update weighed, the tag ids it ignored (unknown to the map) and the particles it redrew."""
    used: tuple[str, ...]
    ignored_tag_ids: tuple[str, ...]
    injected: int


@dataclass(frozen=True)
class PoseEstimate:
    x: float
    y: float
    yaw: float
    covariance: np.ndarray           # 3 x 3 over (x, y, yaw) [m^2, m rad, rad^2]


class FusedFilter:
    def __init__(self, settings: FusedSettings, fused_map: FusedMap, rng: np.random.Generator) -> None:
        settings.validate()
        self.settings = settings
        self.map = fused_map
        self.rng = rng
        count = settings.particles
        self.states = np.zeros((3, count))
        self.scales = np.ones(count)        # per particle: the odometry's distance scale
        self.biases = np.zeros(count)       # per particle: the compass's bias [rad]
        self.weights = np.full(count, 1.0 / count)
        self.wall_models = {port: WallTagModel(area, settings.wall_softness_m, settings.eps)
                            for port, area in settings.wall_areas.items()}
        # Per kind that can reset: the running average of how well the particles explain its rounds.
        self.explained: dict[str, float] = {}
        self.travel_since_wifi_m = math.inf
        self.initialised = False
        # The particles at the previous round and its ceiling tag phases: the range rate's other end.
        self.previous_states: np.ndarray | None = None
        self.previous_phase: dict[str, PhaseReading] = {}

    # ------------------------------------------------------------------------------------ initialisation
    def initialise_global(self) -> None:
        """An unknown start: poses uniform over the map's extent, headings uniform."""
        self.states = self._uniform(self.settings.particles)
        self._draw_biases(np.arange(self.settings.particles))
        self.explained = dict.fromkeys(RESET_MEMORY, 0.0)    # an unknown start explains nothing yet
        self.weights.fill(1.0 / self.settings.particles)
        self.initialised = True
        self.previous_states, self.previous_phase = None, {}

    def initialise_at(self, x: float, y: float, yaw: float, covariance: np.ndarray) -> None:
        """A known start (``/initialpose``): a Gaussian about (x, y, yaw) with the 3 x 3 ``covariance``."""
        count = self.settings.particles
        mean = np.array((x, y, yaw))
        self.states = self.rng.multivariate_normal(mean, covariance, size=count, method="cholesky").T
        self._draw_biases(np.arange(count))
        self.explained = {}                                   # a given start: trusted until contradicted
        self.weights.fill(1.0 / count)
        self.initialised = True
        self.previous_states, self.previous_phase = None, {}

    def _draw_biases(self, rows: np.ndarray) -> None:
        """Fresh odometry scales and compass biases from their priors for these particles."""
        s = self.settings
        self.scales[rows] = 1.0 + s.odometry_scale_sd * self.rng.standard_normal(len(rows))
        self.biases[rows] = s.compass_bias_sd_rad * self.rng.standard_normal(len(rows))

    def _uniform(self, count: int) -> np.ndarray:
        x_min, y_min, x_max, y_max = self.map.extent
        return np.vstack((self.rng.uniform(x_min, x_max, count), self.rng.uniform(y_min, y_max, count),
                          self.rng.uniform(-math.pi, math.pi, count)))

    # -------------------------------------------------------------------------------------------- motion
    def predict(self, forward: float, lateral: float, rotation: float) -> None:
        """Move every particle by the odometry increment (robot frame of the previous pose), with noise, its
        distance times the particle's own odometry scale; the scales and compass biases walk with the distance."""
        s = self.settings
        increments = walked_increments(forward, lateral, rotation, self.states.shape[1], self.rng,
                                       s.odometry_noise_m, s.turn_noise_fraction, s.heading_noise_rad, self.scales)
        if increments is None:
            return
        dx, dy, dyaw = increments
        x, y, yaw = self.states
        cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
        x += cos_yaw * dx - sin_yaw * dy
        y += sin_yaw * dx + cos_yaw * dy
        yaw += dyaw
        distance = math.hypot(forward, lateral)
        self.travel_since_wifi_m += distance
        if distance > 0.0:
            root = math.sqrt(distance)
            count = len(self.scales)
            self.scales += s.odometry_scale_walk * root * self.rng.standard_normal(count)
            self.biases += s.compass_bias_walk_rad * root * self.rng.standard_normal(count)

    # -------------------------------------------------------------------------------------------- update
    def update(self, evidence: Evidence) -> Update:
        """Weigh the particles by this round's evidence; resample (with recovery particles) when due."""
        by_kind, ignored = self._log_likelihoods(self.states, evidence)
        update = self._weigh(by_kind, evidence) if by_kind else Update((), ignored, 0)
        self.previous_states = self.states.copy()
        self.previous_phase = {reading.tag_id: reading for reading in evidence.phase}
        return dataclasses.replace(update, ignored_tag_ids=ignored)

    def _weigh(self, by_kind: dict[str, np.ndarray], evidence: Evidence) -> Update:
        s = self.settings
        redraw = 0.0
        log_likelihood = np.zeros(self.states.shape[1])
        for kind, values in by_kind.items():
            log_likelihood += values
            memory = RESET_MEMORY.get(kind)
            if memory is None:
                continue
            # How well the prior particles explain this kind (each model scores 0 at best agreement).
            explained = float(self.weights @ np.exp(values))
            average = self.explained.get(kind, 1.0)
            self.explained[kind] = average = average + memory * (explained - average)
            if s.reset_threshold > 0.0:
                redraw = max(redraw, 1.0 - average / s.reset_threshold)
        best = float(log_likelihood.max())
        weights = self.weights * np.exp(log_likelihood - best)
        self.weights = weights / weights.sum()
        injected = 0
        if redraw > 0.0 or 1.0 / float(self.weights @ self.weights) < s.resample_threshold * len(self.weights):
            injected = self._resample(redraw, evidence)
        if injected:
            self.explained = {}      # the new particles are trusted until contradicted, by any kind
        return Update(tuple(by_kind), (), injected)

    def _log_likelihoods(self, states: np.ndarray, evidence: Evidence) -> tuple[dict[str, np.ndarray],
                                                                                 tuple[str, ...]]:
        """Per kind of evidence present, its log-likelihood per particle (kinds in EVIDENCE_KINDS' order); the
        ids of tags the map does not know, ignored."""
        by_kind: dict[str, np.ndarray] = {}
        ignored: list[str] = []
        self._floor_log_likelihoods(states, evidence.floor_tag_ids, by_kind, ignored)
        phase_model = self.settings.phase
        for reading in evidence.phase:
            ceiling_tag = self.map.ceiling_tags.get(reading.tag_id)
            if ceiling_tag is None or phase_model is None:
                ignored.append(reading.tag_id)
                continue
            _add(by_kind, "ceiling_phase",
                 phase_model.log_likelihood(states, ceiling_tag, reading.dphi_rad, reading.frequency_hz))
            before = self.previous_phase.get(reading.tag_id)
            if before is not None and before.frequency_hz == reading.frequency_hz and self.previous_states is not None:
                changes = (reading.phase1_rad - before.phase1_rad, reading.phase2_rad - before.phase2_rad)
                _add(by_kind, "ceiling_range_rate", phase_model.range_change_log_likelihood(
                    self.previous_states, states, ceiling_tag, changes, reading.frequency_hz))
        for port, tag_id in evidence.wall_tag_ids:
            wall_tag = self.map.wall_tags.get(tag_id)
            model = self.wall_models.get(port)
            if wall_tag is None or model is None:
                ignored.append(tag_id)
                continue
            _add(by_kind, "wall_tag", model.log_likelihood(states, wall_tag))
        if evidence.wifi_fix is not None and self.travel_since_wifi_m >= self.settings.wifi_min_travel_m:
            fix, uncertainty = evidence.wifi_fix
            _add(by_kind, "wifi", self.settings.wifi.log_likelihood(states, fix, uncertainty))
            self.travel_since_wifi_m = 0.0
        if evidence.compass_yaw_rad is not None:
            _add(by_kind, "compass", self.settings.compass.log_likelihood(states, self.biases,
                                                                          evidence.compass_yaw_rad))
        return {kind: by_kind[kind] for kind in EVIDENCE_KINDS if kind in by_kind}, tuple(ignored)

    def _floor_log_likelihoods(self, states: np.ndarray, tag_ids: Sequence[str], by_kind: dict[str, np.ndarray],
                               ignored: list[str]) -> None:
        """Lattice tags and tag-group tags read by the floor antenna, and the known ones near that were not."""
        lattice_read: list[tuple[float, float]] = []
        group_read: list[tuple[float, float]] = []
        read_range = None
        for tag_id in tag_ids:
            group_tag = self.map.floor_tags.get(tag_id)
            if group_tag is not None:
                group_read.append(group_tag)
                continue
            lattice_tag = self.map.lattice_position(tag_id)
            if lattice_tag is None:
                ignored.append(tag_id)
                continue
            lattice_read.append(lattice_tag[0])
            read_range = lattice_tag[1]
        if not lattice_read and not group_read:
            return           # an empty round says nothing: a failed inventory looks the same
        model = self.settings.floor
        antennas = np.vstack(mounted(states, model.antenna_xy))
        centre_x, centre_y = (float(v) for v in antennas @ self.weights)
        spread = float(np.sqrt(self.weights @ (np.square(antennas[0] - centre_x) + np.square(antennas[1] - centre_y))))
        compact = spread <= NEGATIVE_FLOOR_RADIUS_M
        margin_m = UNREAD_REACH_SOFTNESS * model.softness_m
        if lattice_read and read_range is not None and self.map.deployment is not None:
            unread = np.zeros((0, 2))
            if compact:
                deployment = self.map.deployment
                read_set = {tuple(p) for p in lattice_read}
                near = [c for c in deployment.lattice.within(centre_x, centre_y, 3.0 * spread + read_range + margin_m)
                        if deployment.is_deployed(c) and deployment.lattice.position(c) not in read_set]
                if near:
                    unread = _within_reach(deployment.lattice.positions(np.array(near, dtype=float)), antennas,
                                           read_range + margin_m)
            _add(by_kind, "lattice", model.log_likelihood(states, np.array(lattice_read), unread, read_range))
        if group_read:
            range_m = self.settings.tag_group_read_range_m
            unread_tags = np.zeros((0, 2))
            if compact:
                read_set = set(group_read)
                unread_tags = _within_reach(np.array([
                    position for _, position in self.map.floor_tags_near(centre_x, centre_y,
                                                                         3.0 * spread + range_m + margin_m)
                    if position not in read_set]).reshape(-1, 2), antennas, range_m + margin_m)
            _add(by_kind, "tag_group", model.log_likelihood(states, np.array(group_read), unread_tags, range_m))

    # ---------------------------------------------------------------------------------------- resampling
    def _resample(self, redraw: float, evidence: Evidence) -> int:
        """Systematic resampling; ``redraw`` of the particles replaced by poses the evidence allows."""
        count = len(self.weights)
        positions = (self.rng.random() + np.arange(count)) / count
        cumulative = np.cumsum(self.weights)
        cumulative[-1] = 1.0
        chosen = np.searchsorted(cumulative, positions)
        self.states, self.scales, self.biases = self.states[:, chosen], self.scales[chosen], self.biases[chosen]
        injected = int(self.rng.binomial(count, min(redraw, 1.0))) if redraw > 0.0 else 0
        if injected:
            rows = self.rng.choice(count, size=injected, replace=False)
            self._draw_biases(rows)
            self.states[:, rows] = self._proposals(injected, evidence, self.biases[rows])
        self.weights.fill(1.0 / count)
        return injected

    def _proposals(self, count: int, evidence: Evidence, biases: np.ndarray) -> np.ndarray:
        """Poses (3 x count) the round's evidence allows, the most telling kind first; uniform without any.
        Headings from the compass reading less each new particle's bias, when there is one."""
        yaw = (evidence.compass_yaw_rad - biases + self.settings.compass.sd_rad * self.rng.standard_normal(count)
               if evidence.compass_yaw_rad is not None else self.rng.uniform(-math.pi, math.pi, count))
        for port, tag_id in evidence.wall_tag_ids:
            tag, area = self.map.wall_tags.get(tag_id), self.settings.wall_areas.get(port)
            if tag is not None and area is not None:
                # The antenna somewhere in front of the plate, within the area's depth and half its width.
                depth = self.rng.uniform(0.0, area.depth_m, count)
                across = self.rng.uniform(-area.width_m / 2.0, area.width_m / 2.0, count)
                bearing = yaw + area.bearing_rad
                antenna_x = tag.position[0] - depth * np.cos(bearing) + across * np.sin(bearing)
                antenna_y = tag.position[1] - depth * np.sin(bearing) - across * np.cos(bearing)
                return _centres(antenna_x, antenna_y, yaw, area.position)
        for tag_id in evidence.floor_tag_ids:
            position = self.map.floor_tags.get(tag_id)
            range_m = self.settings.tag_group_read_range_m
            if position is None:
                lattice_tag = self.map.lattice_position(tag_id)
                if lattice_tag is None:
                    continue
                position, range_m = lattice_tag
            radius = range_m * np.sqrt(self.rng.random(count))
            angle = self.rng.uniform(-math.pi, math.pi, count)
            return _centres(position[0] + radius * np.cos(angle), position[1] + radius * np.sin(angle), yaw,
                            self.settings.floor.antenna_xy)
        if evidence.wifi_fix is not None:
            (fix_x, fix_y), uncertainty = evidence.wifi_fix
            sd = self.settings.wifi.sd_m(uncertainty)
            return np.vstack((fix_x + sd * self.rng.standard_normal(count),
                              fix_y + sd * self.rng.standard_normal(count), yaw))
        uniform = self._uniform(count)
        uniform[2] = yaw
        return uniform

    # ------------------------------------------------------------------------------------------ estimate
    def estimate(self) -> PoseEstimate:
        w = self.weights
        x, y, yaw = self.states
        mean_x, mean_y = float(w @ x), float(w @ y)
        mean_yaw = math.atan2(float(w @ np.sin(yaw)), float(w @ np.cos(yaw)))
        offsets = np.vstack((x - mean_x, y - mean_y, wrap_angles(yaw - mean_yaw)))
        covariance = (offsets * w) @ offsets.T
        covariance = 0.5 * (covariance + covariance.T)    # symmetric to the bit, as a covariance message must be
        return PoseEstimate(mean_x, mean_y, wrap_angle(mean_yaw), covariance)


def _within_reach(tags: np.ndarray, antennas: np.ndarray, reach_m: float) -> np.ndarray:
    """The rows of ``tags`` (k x 2) within ``reach_m`` of at least one of the ``antennas`` (2 x n)."""
    if len(tags) == 0:
        return tags
    distance, _ = cKDTree(antennas.T).query(tags, distance_upper_bound=reach_m)
    return tags[np.isfinite(distance)]


def _add(by_kind: dict[str, np.ndarray], kind: str, values: np.ndarray) -> None:
    by_kind[kind] = by_kind[kind] + values if kind in by_kind else values


def _centres(antenna_x: np.ndarray, antenna_y: np.ndarray, yaw: np.ndarray,
             offset: tuple[float, float]) -> np.ndarray:
    """Robot poses (3 x n) whose antenna mounted at ``offset`` is at (antenna_x, antenna_y) with heading ``yaw``."""
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    return np.vstack((antenna_x - cos_yaw * offset[0] + sin_yaw * offset[1],
                      antenna_y - sin_yaw * offset[0] - cos_yaw * offset[1], yaw))
