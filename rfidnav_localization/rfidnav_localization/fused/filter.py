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
* Weights: the sum of the log-likelihoods of the evidence present; a kind absent this round costs nothing. The
  filter knows no kind of evidence: each is a measurement (rfidnav_localization.fused.measurement, the extension
  point), those shipped registered in rfidnav_localization.fused.kinds.MEASUREMENTS (floor tags, the ceiling
  tags' phases and range rates, wall tags, WiFi fixes -- weighed once per ``wifi_min_travel_m`` travelled --, the
  compass), their models in rfidnav_localization.fused.models. Resampling (systematic) when the effective sample
  size falls below half.
* Global localization and kidnap recovery: sensor resetting (Lenser and Veloso 2000), in the spirit of
  augmented MCL (Thrun, Burgard and Fox, *Probabilistic Robotics*, table 8.3). Each model scores 0 at best
  agreement, so the weight-averaged likelihood of a round's evidence of one kind says how well the particles
  explain it (1: perfectly). For each kind that can propose poses -- a floor tag read, a wall tag read, a WiFi
  fix -- a running average of it is kept (a tag read counts at once; WiFi fixes, whose errors run to metres,
  over several: each measurement's ``reset_memory``), restarted at 1 after every reset; when it falls below
  ``reset_threshold``, that share of the particles is redrawn at resampling from poses the evidence allows (the
  measurements' proposals): over the floor tag, in the wall tag's induction area, about the WiFi fix, headed as
  the compass says less each new particle's bias. An unknown start is all particles uniform over the map's
  extent, whose averages start at 0: its first fix or read resets it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Generic, Protocol, TypeVar

import numpy as np

from rfidnav_common.geometry import wrap_angle, wrap_angles
from rfidnav_localization.fused.kinds import MEASUREMENTS, PhaseReading, WifiFix
from rfidnav_localization.fused.measurement import Evidence, MeasurementFactory, Particles
from rfidnav_localization.fused.settings import FusedSettings
from rfidnav_localization.fused.tag_map import FusedMap
from rfidnav_localization.motion_model import walked_increments

Reading = TypeVar("Reading")
# Readings of a kind held for the next round (HeldReadings): a compass at 10 Hz between rounds at 2 Hz holds 5.
HELD_READINGS = 16


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
    """One round's evidence, the readings of the kinds rfidnav_localization.fused.kinds ships: the floor antenna's
    tags, the side antenna's wall tags, and the phases of each ceiling tag heard on both receiving antennas on one
    channel (the last read of it on each), with the latest WiFi fix and compass heading. The node and the
    in-process runners both build it here."""
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
    def __init__(self, settings: FusedSettings, fused_map: FusedMap, rng: np.random.Generator,
                 measurements: Sequence[MeasurementFactory] = MEASUREMENTS) -> None:
        """``measurements``: the kinds of evidence it weighs, in the order it weighs them and reports their
        likelihoods (rfidnav_localization.fused.measurement)."""
        settings.validate()
        self.settings = settings
        self.map = fused_map
        self.rng = rng
        count = settings.particles
        self.states = np.zeros((3, count))
        self.scales = np.ones(count)        # per particle: the odometry's distance scale
        self.biases = np.zeros(count)       # per particle: the compass's bias [rad]
        self.weights = np.full(count, 1.0 / count)
        self.measurements = [make(settings, fused_map) for make in measurements]
        kinds = [kind for measurement in self.measurements for kind in measurement.kinds]
        if len(set(kinds)) != len(kinds):     # Update.used would merge two measurements' likelihoods
            raise ValueError(f"each kind of likelihood must be one measurement's, got {kinds}")
        # The kinds that can reset, and how much of their running average a round replaces.
        self.reset_memory = {kind: memory for measurement in self.measurements
                             for kind, memory in measurement.reset_memory.items()}
        # The measurements that can propose poses for redrawn particles, the lowest rank first.
        ranked = [(measurement.proposal_rank, index) for index, measurement in enumerate(self.measurements)
                  if measurement.proposal_rank is not None]
        self.proposers = [self.measurements[index] for _, index in sorted(ranked)]
        # Per kind that can reset: the running average of how well the particles explain its rounds.
        self.explained: dict[str, float] = {}
        self.initialised = False

    # ------------------------------------------------------------------------------------ initialisation
    def initialise_global(self) -> None:
        """An unknown start: poses uniform over the map's extent, headings uniform."""
        self.states = self._uniform(self.settings.particles)
        self._draw_biases(np.arange(self.settings.particles))
        self.explained = dict.fromkeys(self.reset_memory, 0.0)    # an unknown start explains nothing yet
        self.weights.fill(1.0 / self.settings.particles)
        self.initialised = True
        for measurement in self.measurements:
            measurement.restart()

    def initialise_at(self, x: float, y: float, yaw: float, covariance: np.ndarray) -> None:
        """A known start (``/initialpose``): a Gaussian about (x, y, yaw) with the 3 x 3 ``covariance``."""
        count = self.settings.particles
        mean = np.array((x, y, yaw))
        self.states = self.rng.multivariate_normal(mean, covariance, size=count, method="cholesky").T
        self._draw_biases(np.arange(count))
        self.explained = {}                                   # a given start: trusted until contradicted
        self.weights.fill(1.0 / count)
        self.initialised = True
        for measurement in self.measurements:
            measurement.restart()

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
        for measurement in self.measurements:
            measurement.moved(distance)
        if distance > 0.0:
            root = math.sqrt(distance)
            count = len(self.scales)
            self.scales += s.odometry_scale_walk * root * self.rng.standard_normal(count)
            self.biases += s.compass_bias_walk_rad * root * self.rng.standard_normal(count)

    # -------------------------------------------------------------------------------------------- update
    def update(self, evidence: Evidence) -> Update:
        """Weigh the particles by this round's evidence; resample (with recovery particles) when due."""
        by_kind, ignored = self._log_likelihoods(evidence)
        update = self._weigh(by_kind, evidence) if by_kind else Update((), ignored, 0)
        particles = Particles(self.states, self.weights, self.biases)
        for measurement in self.measurements:
            measurement.end_round(evidence.get(measurement.name), particles)
        return dataclasses.replace(update, ignored_tag_ids=ignored)

    def _weigh(self, by_kind: dict[str, np.ndarray], evidence: Evidence) -> Update:
        s = self.settings
        redraw = 0.0
        log_likelihood = np.zeros(self.states.shape[1])
        for kind, values in by_kind.items():
            log_likelihood += values
            memory = self.reset_memory.get(kind)
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

    def _log_likelihoods(self, evidence: Evidence) -> tuple[dict[str, np.ndarray], tuple[str, ...]]:
        """Per kind of likelihood present, its log-likelihood per particle (in the measurements' order, each's kinds
        in its order); the ids of tags the map does not know, ignored."""
        particles = Particles(self.states, self.weights, self.biases)
        by_kind: dict[str, np.ndarray] = {}
        ignored: list[str] = []
        for measurement in self.measurements:
            reading = evidence.get(measurement.name)
            if reading is None:
                continue
            result = measurement.log_likelihoods(reading, particles)
            reported = [kind for kind in measurement.kinds if kind in result.by_kind]
            if len(reported) != len(result.by_kind):
                raise ValueError(f"{type(measurement).__name__} reported {list(result.by_kind)}, not all of its "
                                 f"kinds {measurement.kinds}")
            by_kind.update((kind, result.by_kind[kind]) for kind in reported)
            ignored.extend(result.ignored)
        return by_kind, tuple(ignored)

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
        """Poses (3 x count) the round's evidence allows, from the first proposer (by rank) whose reading allows
        some; uniform without any. Headings from the first measurement whose reading gives them (the compass
        reading less each new particle's bias), uniform without."""
        yaw = None
        for measurement in self.measurements:
            reading = evidence.get(measurement.name)
            yaw = measurement.headings(reading, biases, self.rng) if reading is not None else None
            if yaw is not None:
                break
        if yaw is None:
            yaw = self.rng.uniform(-math.pi, math.pi, count)
        for measurement in self.proposers:
            reading = evidence.get(measurement.name)
            poses = measurement.poses(reading, yaw, self.rng) if reading is not None else None
            if poses is not None:
                return poses
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

