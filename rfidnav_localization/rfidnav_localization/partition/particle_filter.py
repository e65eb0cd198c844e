"""The particle filter method of the partition localizer (beyond paper 000).

Particles over (x, y, yaw) of the robot's centre in the map frame. The floor antenna may read
``antenna_offset_m`` ahead of the rotation axis: then a turn on the spot sweeps it over partition boundaries
and reveals the heading without driving anywhere (the navigator's spin localization); the paper method keeps
the antenna on the axis. Particles are initialised with their antennas uniformly in the first partition's
region and a uniform yaw, predicted with the odometry increment in the robot frame (noise relative to the
motion plus floors), weighted by a soft read model P(read | d) = eps + (1 - 2 eps) * sigmoid((r - d) / softness)
for each tag of the observed partition (read) and for each tag near the particles that was not read, resampled
(systematic, with a little roughening) when the effective sample size falls below half. ``eps``
(``read_error_probability``) bounds what one missed or spurious read can cost.

A partition change that no particle explains (too few particles where the robot is, typically while the
heading is unknown) redraws the worst fifth of the particles (sensor resetting): as poses that explain this
crossing and an earlier one together (the odometry's displacement between them fitted onto the two crossing
arcs, which fixes the heading: see ``FilterTracker._paired_proposals``), or, without an earlier crossing far
enough away, on this crossing's arc headed within the paper's bounds when the stretch has them. When no
particle has explained the recent rounds (the best one keeps contradicting tags: a kidnapped robot, or
persistently bad reads) the tracker says so and its owner restarts it from the current partition. An empty
round is a prediction step only (the robot moved; a missed round says nothing about where).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Coordinate, Deployment
from rfidnav_localization.motion_model import odometry_increment, sampled_increments
from rfidnav_localization.partition.estimate import LocalizerSettings, YawEstimate
from rfidnav_localization.partition.geometry import CIRCLE_SAMPLES, PartitionGeometry, Region, orientation_bounds
from rfidnav_localization.partition.stretch import Stretch
from rfidnav_localization.read_model import soft_read_log_likelihood

ROUGHENING = 0.2                 # Gordon et al.'s K: jitter = K * spread * N^(-1/3) per dimension
# The filter re-initialises when its best particle's recent evidence amounts to this many contradicted tags:
# its round log-likelihood summed with weights COLLAPSE_MEMORY^age. Two contradictions a round trip it on
# the second round, one a round on the fourth; an isolated missed or spurious read never does.
COLLAPSE_CONTRADICTIONS = 2.5
COLLAPSE_MEMORY = 0.7
# Sensor resetting: when no particle gives a partition crossing a likelihood above 1/4 (at a crossing the
# true pose gives each changed tag at least about 1/2), the worst fifth of the particles are redrawn on it.
RESET_LOG_LIKELIHOOD = math.log(0.25)
RESET_FRACTION = 0.2
# Paired proposals (see FilterTracker._paired_proposals): the crossings remembered since the filter
# started (about a turn on the spot at r = 2 cm), the shortest odometry baseline paired with, in r, and how
# many of the longest baselines the proposals spread over (one bad crossing cannot capture them all).
CROSSING_MEMORY = 64
PAIR_MIN_BASELINE_R = 1.0
PAIR_CHOICES = 8


@dataclass(frozen=True)
class _Crossing:
    """A partition boundary crossed: where in the map (the crossing arc) and where in the odometry frame
    (the antenna at the round before and at the round that saw the new partition: it crossed in between)."""
    arc: np.ndarray
    antenna_before: np.ndarray
    antenna_after: np.ndarray

    def antenna_at(self, fractions: np.ndarray) -> np.ndarray:
        """Odometry-frame antenna positions (count x 2) at these fractions of the round's motion."""
        return self.antenna_before + fractions[:, None] * (self.antenna_after - self.antenna_before)



class ParticleFilter:
    """Particles over (x, y, yaw) in the map frame, with normalised weights. Headings are not wrapped: every
    use of them is circular (sin, cos)."""

    def __init__(self, settings: LocalizerSettings, rng: np.random.Generator) -> None:
        self.settings = settings
        self.rng = rng
        self.states = np.zeros((3, settings.particles))   # rows x, y, yaw: contiguous per coordinate
        self.weights = np.full(settings.particles, 1.0 / settings.particles)
        self.evidence = 0.0   # the best particle's recent log-likelihood (see COLLAPSE_MEMORY)
        self._antennas: np.ndarray | None = None
        self._headings: tuple[np.ndarray, np.ndarray] | None = None
        self.resets = 0       # sensor resettings (see weigh)

    def _moved(self) -> None:
        """The states changed: what was computed from them is stale."""
        self._antennas = None
        self._headings = None

    def headings(self) -> tuple[np.ndarray, np.ndarray]:
        """cos and sin of the particles' headings, computed once per change of the states: a round's estimate and
        the next round's prediction both use them."""
        if self._headings is None:
            yaw = self.states[2]
            self._headings = (np.cos(yaw), np.sin(yaw))
        return self._headings

    def initialise(self, origin: np.ndarray, region: Region) -> None:
        """Antennas uniform in the partition's region, headings uniform; the centres behind the antennas."""
        count = self.settings.particles
        self.states[:2] = (origin + region.sample(self.rng, count)).T
        self.states[2] = self.rng.uniform(-math.pi, math.pi, count)
        self.states[:2] -= self.settings.antenna_offset_m * np.vstack((np.cos(self.states[2]), np.sin(self.states[2])))
        self._moved()
        self.weights.fill(1.0 / count)
        self.evidence = 0.0

    def predict(self, forward: float, lateral: float, rotation: float) -> None:
        """Move every particle by the odometry increment (robot frame of the previous pose), with noise."""
        s = self.settings
        increments = sampled_increments(forward, lateral, rotation, self.states.shape[1], self.rng,
                                        s.motion_noise_fraction, s.motion_noise_floor_m, s.motion_noise_yaw_rad_per_m)
        if increments is None:
            return
        dx, dy, dyaw = increments
        x, y, yaw = self.states
        cos_yaw, sin_yaw = self.headings()
        x += cos_yaw * dx - sin_yaw * dy
        y += sin_yaw * dx + cos_yaw * dy
        yaw += dyaw
        self._moved()

    def antenna(self, states: np.ndarray) -> np.ndarray:
        """Where each state's floor antenna reads (2 x count): ``antenna_offset_m`` ahead of the robot's centre."""
        offset = self.settings.antenna_offset_m
        if offset == 0.0:
            return states[:2]
        return states[:2] + offset * np.vstack((np.cos(states[2]), np.sin(states[2])))

    def antennas(self) -> np.ndarray:
        """The particles' antennas, computed once per change of the states (several uses a round)."""
        if self._antennas is None:
            self._antennas = self.antenna(self.states)
        return self._antennas

    def bounding_circle(self) -> tuple[float, float, float]:
        """(x, y, radius) of a circle holding every particle's antenna: the centre and half-diagonal of their box."""
        antennas = self.antennas()
        (x_low, y_low), (x_high, y_high) = antennas.min(axis=1).tolist(), antennas.max(axis=1).tolist()
        return (x_low + x_high) / 2.0, (y_low + y_high) / 2.0, float(np.hypot(x_high - x_low, y_high - y_low)) / 2.0

    def log_likelihood(self, antennas: np.ndarray, read: np.ndarray, unread: np.ndarray,
                       read_range_m: float) -> np.ndarray:
        """log P(this round's reads | particle) for antennas (2 x count) under the soft read model."""
        s = self.settings
        return soft_read_log_likelihood(antennas, read, unread, read_range_m, s.boundary_softness_m,
                                        s.read_error_probability)

    def weigh(self, read: np.ndarray, unread: np.ndarray, read_range_m: float,
              proposals: Callable[[int], np.ndarray] | None = None) -> bool:
        """Bayes update with the soft read model; False (weights untouched) when no particle has explained the
        recent rounds.

        ``proposals(count)`` (3 x count states consistent with this round) is for a partition boundary just
        crossed: when no particle explains the crossing (starvation: too few particles where the robot is,
        typically while the heading is still unknown), the worst RESET_FRACTION are replaced by proposals
        (sensor resetting, Lenser and Veloso 2000). A filter that tracks well is left alone."""
        eps = self.settings.read_error_probability
        log_likelihood = self.log_likelihood(self.antennas(), read, unread, read_range_m)
        if proposals is not None and log_likelihood.max() < RESET_LOG_LIKELIHOOD:
            count = round(RESET_FRACTION * len(self.weights))
            worst = np.argpartition(log_likelihood, count)[:count]
            self.states[:, worst] = proposals(count)
            self._moved()
            self.weights[worst] = 1.0 / len(self.weights)
            log_likelihood[worst] = self.log_likelihood(self.antennas()[:, worst], read, unread, read_range_m)
            self.resets += 1
        best = float(log_likelihood.max())
        self.evidence = COLLAPSE_MEMORY * self.evidence + best
        if self.evidence < COLLAPSE_CONTRADICTIONS * math.log(eps):
            return False
        weights = self.weights * np.exp(log_likelihood - best)
        self.weights = weights / weights.sum()
        if 1.0 / float(self.weights @ self.weights) < 0.5 * len(self.weights):
            self.resample()
        return True

    def resample(self) -> None:
        """Systematic resampling, then roughening (Gordon et al. 1993) so duplicates spread apart again."""
        count = len(self.weights)
        positions = (self.rng.random() + np.arange(count)) / count
        cumulative = np.cumsum(self.weights)
        cumulative[-1] = 1.0
        self.states = self.states[:, np.searchsorted(cumulative, positions)]
        yaw = self.states[2]
        yaw_mean = math.atan2(np.sin(yaw).mean(), np.cos(yaw).mean())
        yaw_offsets = np.remainder(yaw - yaw_mean + math.pi, 2.0 * math.pi) - math.pi
        spread = np.array((np.ptp(self.states[0]), np.ptp(self.states[1]), np.ptp(yaw_offsets)))
        self.states += self.rng.standard_normal((3, count)) * (ROUGHENING * count ** (-1.0 / 3.0) * spread)[:, None]
        self._moved()
        self.weights.fill(1.0 / count)

    def estimate(self) -> tuple[tuple[float, float], tuple[float, float, float], float, float]:
        """(position, (var_x, cov_xy, var_y), circular mean yaw, circular sd of yaw)."""
        w = self.weights
        x, y, _ = self.states
        mean_x, mean_y = float(w @ x), float(w @ y)
        dx, dy = x - mean_x, y - mean_y
        cos_yaw, sin_yaw = self.headings()
        sin_mean, cos_mean = float(w @ sin_yaw), float(w @ cos_yaw)
        resultant = min(math.hypot(sin_mean, cos_mean), 1.0)
        yaw_sd = math.sqrt(-2.0 * math.log(resultant)) if resultant > 1e-12 else math.pi
        return ((mean_x, mean_y), (float(w @ (dx * dx)), float(w @ (dx * dy)), float(w @ (dy * dy))),
                wrap_angle(math.atan2(sin_mean, cos_mean)), yaw_sd)



class FilterTracker:
    """The filter method over a localizer's rounds: a ParticleFilter started on a partition, moved by the
    odometry, weighed by each round's tags, and given proposals at a crossing no particle explains (module
    docstring). The localizer owns the straight stretch and restarts the tracker when it is lost."""

    def __init__(self, settings: LocalizerSettings, rng: np.random.Generator, geometry: PartitionGeometry,
                 deployment: Deployment | None) -> None:
        self.settings = settings
        self.rng = rng
        self.geometry = geometry
        self.lattice = geometry.lattice
        self.read_range_m = geometry.read_range_m
        self.deployment = deployment
        self.particles = ParticleFilter(settings, rng)
        self._changes_since_start = 0
        self._crossings: deque[_Crossing] = deque(maxlen=CROSSING_MEMORY)   # since the tracker (re)started

    def start(self, partition: frozenset[Coordinate]) -> None:
        """(Re)start in ``partition``: antennas uniform in its region, headings uniform, no crossing seen."""
        self.particles.initialise(*self.geometry.region(partition))
        self._changes_since_start = 0
        self._crossings.clear()

    def track(self, previous_odom: tuple[float, float, float], odom: tuple[float, float, float],
              previous_partition: frozenset[Coordinate], partition: frozenset[Coordinate],
              rejected: frozenset[Coordinate], stretch: Stretch) -> bool:
        """One round after the start: predict with the odometry's increment, then weigh the tags read (none:
        prediction only). False when no particle has explained the recent rounds: the robot is lost."""
        self.particles.predict(*odometry_increment(previous_odom, odom))
        if not partition:
            return True
        proposals = None
        if partition != previous_partition:
            self._changes_since_start += 1
            arc = self.geometry.crossing_arc(previous_partition, partition)
            if arc is not None:
                crossing = _Crossing(arc, self._odom_antenna(previous_odom), self._odom_antenna(odom))
                travelled = math.hypot(odom[0] - previous_odom[0], odom[1] - previous_odom[1])
                proposals = partial(self._crossing_proposals, crossing, travelled, odom, stretch)
                self._crossings.append(crossing)
        read, unread = self._tags(partition, rejected)
        return self.particles.weigh(read, unread, self.read_range_m, proposals)

    def estimate(self) -> tuple[tuple[float, float], tuple[float, float, float], YawEstimate | None]:
        """(position, (var_x, cov_xy, var_y), heading or None until a partition boundary has been crossed)."""
        position, covariance, yaw, yaw_sd = self.particles.estimate()
        if self._changes_since_start == 0:
            return position, covariance, None   # a uniform heading has no meaningful mean
        return position, covariance, (yaw, (yaw - 2.0 * yaw_sd, yaw + 2.0 * yaw_sd), yaw_sd)

    def _odom_antenna(self, odom: tuple[float, float, float]) -> np.ndarray:
        offset = self.settings.antenna_offset_m
        return np.array((odom[0] + offset * math.cos(odom[2]), odom[1] + offset * math.sin(odom[2])))

    def _crossing_proposals(self, crossing: _Crossing, step_m: float, odom: tuple[float, float, float],
                            stretch: Stretch, count: int) -> np.ndarray:
        """States (3 x count) of a robot that has just crossed ``crossing``: paired with earlier crossings where
        it can be, the rest from this crossing alone."""
        paired = self._paired_proposals(crossing, odom, count)
        if paired.shape[1] == count:
            return paired
        single = self._single_crossing_proposals(crossing.arc, step_m, odom[2], stretch, count - paired.shape[1])
        return np.hstack((paired, single))

    def _paired_proposals(self, crossing: _Crossing, odom: tuple[float, float, float], count: int) -> np.ndarray:
        """Up to ``count`` states (3 x n) that explain this crossing and an earlier one together.

        The odometry knows the antenna's displacement between the two crossings in its own frame; the map
        frame differs from it by a rotation and a translation only. So a point p_then on the earlier arc and
        a point p_now on this arc at the odometry's distance from it fix the whole pose: the rotation turns
        the odometry's displacement onto p_now - p_then. Sampling p_then along its arc leaves one degree of
        freedom where a single crossing leaves two (a point on the arc and any heading), which is what finds
        the heading of a robot turning on the spot: its antenna's crossings lie up to twice the antenna
        offset apart. Crossings are paired with the ones furthest away by odometry (a longer baseline
        gives a finer heading), at least PAIR_MIN_BASELINE_R * r."""
        earlier = list(self._crossings)
        if not earlier:
            return np.zeros((3, 0))
        baselines = np.array([math.dist(c.antenna_after, crossing.antenna_after) for c in earlier])
        usable = np.flatnonzero(baselines >= PAIR_MIN_BASELINE_R * self.read_range_m)
        if not len(usable):
            return np.zeros((3, 0))
        chosen = usable[np.argsort(baselines[usable])[-PAIR_CHOICES:]]
        picks = self.rng.choice(chosen, size=count)
        rng = self.rng
        now_odom = crossing.antenna_at(rng.random(count))
        then_odom = np.empty((count, 2))
        then_map = np.empty((count, 2))
        for index in np.unique(picks):
            rows = np.flatnonzero(picks == index)
            then = earlier[index]
            then_odom[rows] = then.antenna_at(rng.random(len(rows)))
            then_map[rows] = then.arc[rng.integers(len(then.arc), size=len(rows))]
        baseline = np.linalg.norm(now_odom - then_odom, axis=1)
        # Points of this arc at the baseline's distance from p_then, within the arc's sampling step.
        arc = crossing.arc
        mismatch = np.abs(np.linalg.norm(arc[None, :, :] - then_map[:, None, :], axis=2) - baseline[:, None])
        tolerance = 2.0 * math.pi / CIRCLE_SAMPLES * self.read_range_m
        keys = np.where(mismatch <= tolerance, rng.random(mismatch.shape), -1.0)
        found = keys.max(axis=1) >= 0.0
        now_map = arc[keys.argmax(axis=1)[found]]
        then_map, then_odom, now_odom = then_map[found], then_odom[found], now_odom[found]
        map_chord, odom_chord = now_map - then_map, now_odom - then_odom
        rotation = np.arctan2(map_chord[:, 1], map_chord[:, 0]) - np.arctan2(odom_chord[:, 1], odom_chord[:, 0])
        # The robot's centre now, carried from the odometry frame into the map by that rotation about p_now.
        from_antenna = np.array(odom[:2]) - now_odom
        cos_r, sin_r = np.cos(rotation), np.sin(rotation)
        x = now_map[:, 0] + cos_r * from_antenna[:, 0] - sin_r * from_antenna[:, 1]
        y = now_map[:, 1] + sin_r * from_antenna[:, 0] + cos_r * from_antenna[:, 1]
        return np.vstack((x, y, odom[2] + rotation))

    def _single_crossing_proposals(self, arc: np.ndarray, step_m: float, odom_yaw: float, stretch: Stretch,
                                   count: int) -> np.ndarray:
        """States (3 x count) of a robot that crossed ``arc`` during its last step of ``step_m``: the heading
        within the paper's bounds for the current stretch when it has them (turned by the odometry since),
        else any."""
        bounds = orientation_bounds(self.lattice, self.read_range_m, stretch.partitions) \
            if len(stretch.partitions) >= 3 else None
        if bounds is not None:
            yaw = self.rng.uniform(*bounds, count) + wrap_angle(odom_yaw - stretch.mean_odom_yaw)
        else:
            yaw = self.rng.uniform(-math.pi, math.pi, count)
        crossed = arc[self.rng.integers(len(arc), size=count)]
        travelled = self.rng.uniform(0.0, step_m, count) - self.settings.antenna_offset_m   # the arc is the antenna's
        return np.vstack((crossed[:, 0] + travelled * np.cos(yaw), crossed[:, 1] + travelled * np.sin(yaw), yaw))

    def _tags(self, partition: frozenset[Coordinate],
                     rejected: frozenset[Coordinate]) -> tuple[np.ndarray, np.ndarray]:
        """Positions of the tags read and of the tags near the particles that were not read."""
        r = self.read_range_m
        x, y, spread = self.particles.bounding_circle()
        # Any tag within r (plus the soft edge) of any particle could have been read. A cloud wider than a few r
        # is lost anyway (the collapse test will restart it): its far side is left out to bound the cost.
        radius = r + min(spread, 4.0 * r) + 4.0 * self.settings.boundary_softness_m
        nearby = [c for c in self.lattice.within(x, y, radius) if c not in partition and c not in rejected
                  and (self.deployment is None or self.deployment.is_deployed(c))]
        read = self.lattice.positions(np.array(sorted(partition)))
        unread = self.lattice.positions(np.array(nearby)) if nearby else np.zeros((0, 2))
        return read, unread
