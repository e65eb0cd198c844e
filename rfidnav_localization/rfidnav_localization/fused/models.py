"""The fused localizer's measurement models: log-likelihoods of one kind of evidence for many robot poses (pure).

Every model takes the poses as ``states`` (3 x n: x, y, yaw of the robot's centre in the map frame) and returns
log P(evidence | pose) per pose, *scaled so that the best possible agreement scores 0* (a Gaussian's peak, a
certain read): the constants a density would add do not change a filter's weights, and the scale lets the
filter compare how well its particles explain a round from one round to the next (kidnap detection:
rfidnav_localization.fused.filter). Each model has a floor (``eps``) on what one reading can cost, so that one
outlier -- a reflection, a wrong WiFi fix -- never wipes out the particles near the truth.

The sensor geometry and noise are the simulator's and the drivers' parameters (rfidnav_sim.rfid_model,
rfidnav_common.wall_tags, rfidnav_sim.compass_model), taken from the same parameter files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rfidnav_common.geometry import wrap_angles
from rfidnav_common.rf import wavelength_m
from rfidnav_common.wall_tags import InductionArea, WallTag, area_margins
from rfidnav_localization.read_model import soft_read_log_likelihood

SQRT_2PI = math.sqrt(2.0 * math.pi)


def mounted(states: np.ndarray, offset: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Map-frame (x, y) of a point mounted at ``offset`` (base_link, metres) on each pose."""
    x, y, yaw = states
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    return x + cos_yaw * offset[0] - sin_yaw * offset[1], y + sin_yaw * offset[0] + cos_yaw * offset[1]


def robust_gaussian(residual: np.ndarray, sd: np.ndarray | float, eps: float) -> np.ndarray:
    """log(eps + (1 - eps) exp(-residual^2 / (2 sd^2))): a Gaussian with a floor, 0 at residual 0. For an sd that
    is the same for every particle (its normalising 1 / sd would not change the weights)."""
    return np.log(eps + (1.0 - eps) * np.exp(-0.5 * np.square(residual / sd)))


def robust_phase(residual: np.ndarray, sd: np.ndarray, sd_best: float, eps: float) -> np.ndarray:
    """A phase reading whose sd differs from particle to particle (it grows with their distance to the tag): the
    wrapped residual's Gaussian density, its 1 / sd kept, mixed with a share ``eps`` of outliers uniform over the
    circle, relative to the density of a perfect reading at the smallest sd ``sd_best`` (so at most 0). Without the
    1 / sd, a particle farther from the tags would be blamed less for the same residual: on the mixed floor that
    pulled the estimate 8 cm away from a row of ceiling tags, against 800 readings that placed it on the truth."""
    density = eps / (2.0 * math.pi) + (1.0 - eps) * np.exp(-0.5 * np.square(residual / sd)) / (SQRT_2PI * sd)
    return np.log(density / (eps / (2.0 * math.pi) + (1.0 - eps) / (SQRT_2PI * sd_best)))


@dataclass(frozen=True)
class FloorModel:
    """The downward antenna over floor tags (lattice tags of paper 000, tag groups of paper 003): the soft read
    model (rfidnav_localization.read_model) of the tags it read and of known tags near the particles it did not."""
    antenna_xy: tuple[float, float]          # in base_link [m]
    softness_m: float = 0.004
    eps: float = 0.01

    def log_likelihood(self, states: np.ndarray, read: np.ndarray, unread: np.ndarray,
                       read_range_m: float) -> np.ndarray:
        antennas = np.vstack(mounted(states, self.antenna_xy))
        # Each tag's read or no-read is at best 1 - eps likely (a tag under the antenna, or far from it): that
        # much per tag is taken off, so that the best case scores 0 however many tags were weighed.
        best = (len(read) + len(unread)) * math.log1p(-self.eps)
        return soft_read_log_likelihood(antennas, read, unread, read_range_m, self.softness_m, self.eps) - best


@dataclass(frozen=True)
class PhaseDifferenceModel:
    """Paper 001's two receiving antennas under a ceiling tag. Each antenna's phase of a backscatter is
    4 pi d / lambda + its port's offset + the tag's own, mod 2 pi, with noise of ``noise_rad_per_m`` per metre of its
    distance d to the tag (the simulator's model; ``floor_rad`` adds quantisation and multipath; it must be positive:
    a reading's likelihood is relative to one at that sd). Two readings:

    * the phase difference of one backscatter on both antennas, 4 pi (d1 - d2) / lambda + (offset1 - offset2), where
      the tag's own phase cancels: the tag's bearing across the robot (paper 001's steering signal), which cannot
      tell a tag ahead from one behind;
    * each antenna's phase change since the previous round on the same channel, 4 pi (d_now - d_before) / lambda,
      where both offsets cancel: the range rate, which can (closing in or moving away), and, with the
      odometry, how far the robot went."""
    antenna1: tuple[float, float, float]     # in base_link [m]
    antenna2: tuple[float, float, float]
    offset1_rad: float = 0.0                 # cable and port delays (reader parameters)
    offset2_rad: float = 0.0
    noise_rad_per_m: float = 0.02
    floor_rad: float = 0.02
    eps: float = 0.01

    def antennas(self, states: np.ndarray) -> Antennas:
        """Both receiving antennas on each pose, in the map frame: a round weighs all its tags from them."""
        cos_yaw, sin_yaw = np.cos(states[2]), np.sin(states[2])
        return tuple(_mounted_at(states, cos_yaw, sin_yaw, antenna) for antenna in (self.antenna1, self.antenna2))

    def log_likelihood(self, states: np.ndarray, tag: tuple[float, float, float], dphi_rad: float,
                       frequency_hz: float) -> np.ndarray:
        """The phase difference phi1 - phi2 of one backscatter."""
        return self.log_likelihoods_at(self.antennas(states), PhaseTags.of([(tag, frequency_hz)]),
                                       np.array([dphi_rad]))[0]

    def log_likelihoods_at(self, antennas: Antennas, tags: PhaseTags, dphi_rad: np.ndarray) -> np.ndarray:
        """:meth:`log_likelihood` of several backscatters (one row each, ``dphi_rad`` one each) with the antennas on
        the poses (:meth:`antennas`): a round's tags in one pass, each row what :meth:`log_likelihood` gives."""
        d1, d2 = (tags.distances(antenna) for antenna in antennas)
        predicted = 4.0 * math.pi * (d1 - d2) / tags.wavelengths_m + (self.offset1_rad - self.offset2_rad)
        return robust_phase(wrap_angles(dphi_rad[:, None] - predicted), self._sd(d1, d2), self.floor_rad, self.eps)

    def range_change_log_likelihood(self, previous: np.ndarray, states: np.ndarray,
                                    tag: tuple[float, float, float], changes_rad: tuple[float, float],
                                    frequency_hz: float) -> np.ndarray:
        """Each antenna's phase change (``changes_rad``: antenna 1, antenna 2) since the previous round, the
        particles there (``previous``) and here (``states``)."""
        return self.range_change_log_likelihoods_at(self.antennas(previous), self.antennas(states),
                                                    PhaseTags.of([(tag, frequency_hz)]), np.array([changes_rad]))[0]

    def range_change_log_likelihoods_at(self, previous: Antennas, antennas: Antennas, tags: PhaseTags,
                                        changes_rad: np.ndarray) -> np.ndarray:
        """:meth:`range_change_log_likelihood` of several tags (one row each; ``changes_rad`` one row of antenna 1's
        and antenna 2's change each) with the antennas on the poses then and now (:meth:`antennas`)."""
        total = np.zeros((len(changes_rad), antennas[0][0].shape[0]))
        for then, now_at, change in zip(previous, antennas, changes_rad.T, strict=True):
            before, now = tags.distances(then), tags.distances(now_at)
            predicted = 4.0 * math.pi * (now - before) / tags.wavelengths_m
            total += robust_phase(wrap_angles(change[:, None] - predicted), self._sd(before, now), self.floor_rad,
                                  self.eps)
        return total

    def _sd(self, first: np.ndarray, second: np.ndarray) -> np.ndarray:
        """The sd of the difference of two phases read at these distances."""
        return np.sqrt(np.square(self.noise_rad_per_m * first) + np.square(self.noise_rad_per_m * second)
                       + self.floor_rad ** 2)


# An antenna on each pose: its map-frame x and y (n each) and its height [m].
Mounted = tuple[np.ndarray, np.ndarray, float]
Antennas = tuple[Mounted, ...]


def _mounted_at(states: np.ndarray, cos_yaw: np.ndarray, sin_yaw: np.ndarray,
                antenna: tuple[float, float, float]) -> Mounted:
    """:func:`mounted` with the poses' cos and sin of yaw computed once for several antennas (the same sums)."""
    x, y, _ = states
    return (x + cos_yaw * antenna[0] - sin_yaw * antenna[1], y + sin_yaw * antenna[0] + cos_yaw * antenna[1],
            antenna[2])


@dataclass(frozen=True)
class PhaseTags:
    """Ceiling tags weighed together (one per row), each with the wavelength it was read at."""
    x: np.ndarray                 # t x 1 [m], map frame
    y: np.ndarray
    z: np.ndarray                 # t values: the tags' heights [m]
    wavelengths_m: np.ndarray     # t x 1

    @classmethod
    def of(cls, tags: Sequence[tuple[tuple[float, float, float], float]]) -> PhaseTags:
        """From (tag position, frequency [Hz]) pairs."""
        return cls(np.array([[tag[0]] for tag, _ in tags]), np.array([[tag[1]] for tag, _ in tags]),
                   np.array([tag[2] for tag, _ in tags]),
                   np.array([[wavelength_m(frequency_hz)] for _, frequency_hz in tags]))

    def distances(self, antenna: Mounted) -> np.ndarray:
        """t x n: the distance from the antenna mounted on each pose to each tag [m]."""
        x, y, height = antenna
        # The height term per tag as Python floats, as it was computed one tag at a time (the same bits).
        rises = np.array([[(z - height) ** 2] for z in self.z.tolist()])
        return np.sqrt(np.square(self.x - x) + np.square(self.y - y) + rises)

    def rows(self, indices: Sequence[int]) -> PhaseTags:
        """These tags only, in this order."""
        return PhaseTags(self.x[indices], self.y[indices], self.z[indices], self.wavelengths_m[indices])


@dataclass(frozen=True)
class WallTagModel:
    """Paper 004's side antenna: a wall tag read lies in its induction area (rfidnav_common.wall_tags), up to a
    soft edge. Only reads are evidence: a tag *not* read says little, since read failures miss whole passages
    (paper 004), and a model that counted them would drive the particles off the truth at every failure."""
    area: InductionArea
    softness_m: float = 0.02
    eps: float = 0.01

    def log_likelihood(self, states: np.ndarray, tag: WallTag) -> np.ndarray:
        margin = area_margins(self.area, states, tag)
        inside = 0.5 * (1.0 + np.tanh(0.5 * margin / self.softness_m))   # sigmoid(margin / softness); 0 facing away
        return np.log(self.eps + (1.0 - self.eps) * inside)


@dataclass(frozen=True)
class WifiModel:
    """A fingerprint fix (the location server's weighted k-nearest neighbours) with its uncertainty: a circular
    Gaussian of sd max(scale * uncertainty, floor) about the fix."""
    sd_scale: float = 1.0
    sd_floor_m: float = 1.0
    eps: float = 0.01

    def sd_m(self, uncertainty_m: float) -> float:
        return max(self.sd_scale * uncertainty_m, self.sd_floor_m)

    def log_likelihood(self, states: np.ndarray, fix: tuple[float, float], uncertainty_m: float) -> np.ndarray:
        distance = np.hypot(states[0] - fix[0], states[1] - fix[1])
        return robust_gaussian(distance, self.sd_m(uncertainty_m), self.eps)


@dataclass(frozen=True)
class CompassModel:
    """An e-compass heading: a wrapped Gaussian of the reading-to-reading noise about the particle's heading plus
    its compass bias (a per-particle state: the bias stays put for a run, paper 003's robot calibrates it away,
    and counting it as noise would make a thousand readings claim a heading they cannot know)."""
    sd_rad: float = math.radians(2.0)
    eps: float = 0.01

    def log_likelihood(self, states: np.ndarray, biases: np.ndarray, yaw_rad: float) -> np.ndarray:
        return robust_gaussian(wrap_angles(yaw_rad - states[2] - biases), self.sd_rad, self.eps)
