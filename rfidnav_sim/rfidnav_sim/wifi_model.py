"""WiFi received signal strength of fixed access points, for the fingerprinting tier of paper 003.

Mean RSS of access point a at point p (dBm), the multi-wall model (Motley-Keenan, COST 231):

    RSS = P_tx - PL(d0) - 10 n log10(d / d0) - W(p) L_w + S_a(p),   d0 = 1 m, d = max(|p - a|, d_min),

where PL(d0) is the free-space (Friis) loss at the AP's frequency, W(p) the number of walls the straight
ray a-p crosses, L_w the loss per wall and S_a a shadowing field fixed per world. Walls are counted
explicitly, so the exponent between them stays near free space (n = 2). A scan adds independent Gaussian
noise per reading (fast fading, receiver noise) and keeps the APs heard at or above the sensitivity.

Shadowing is a stationary Gaussian random field per AP, continuous in space, so a location's fingerprint
is stable between visits as in a real building (Gudmundson 1991 measured such spatial correlation). It is
drawn by random Fourier features (Rahimi & Recht 2007): sd sqrt(2/K) sum_k cos(w_k . p + b_k), with w_k
from the spectral density of the squared-exponential kernel, N(0, I / L^2), and b_k uniform. Its
covariance is sd^2 exp(-|r|^2 / (2 L^2)) in expectation; the spatial variance of one draw is sd^2. The
squared exponential (rather than Gudmundson's exponential) is smooth and trivial to sample; its
correlation is 0.61 at L and 1/e at sqrt(2) L. The seed comes from (world seed, BSSID) through SHA-256, so
the same world and AP give the same field in every process.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from rfidnav_common.errors import ParameterError
from rfidnav_common.rf import SPEED_OF_LIGHT_MPS
from rfidnav_common.seeding import derive_seed

SHADOWING_FEATURES = 256       # one draw's covariance departs from the kernel by ~1/sqrt(K), about 6 %
BLOCK_ROWS = 256               # points per block: the block x K and block x N temporaries stay in cache
BSSID_PATTERN = re.compile(r"[0-9a-fA-F]{2}(:[0-9a-fA-F]{2}){5}")


def channel_frequency_hz(channel: int) -> float:
    """Centre frequency of an IEEE 802.11 channel: 2.4 GHz channels 1..14, 5 GHz channels 36..165."""
    if channel == 14:
        return 2484e6                                  # Japan's channel 14 sits off the 5 MHz grid
    if 1 <= channel <= 13:
        return 2407e6 + 5e6 * channel
    if 36 <= channel <= 165:
        return 5000e6 + 5e6 * channel
    raise ValueError(f"channel: {channel} is not a 2.4 GHz (1..14) or 5 GHz (36..165) channel")


def free_space_loss_db(distance_m: float, frequency_hz: float) -> float:
    """Friis free-space path loss 20 log10(4 pi d f / c): 40.2 dB at 1 m on channel 6."""
    return 20.0 * math.log10(4.0 * math.pi * distance_m * frequency_hz / SPEED_OF_LIGHT_MPS)


@dataclass(frozen=True)
class AccessPoint:
    bssid: str                          # "aa:bb:cc:dd:ee:ff"; compared case-insensitively
    ssid: str
    position: tuple[float, float]       # world frame [m]
    tx_power_dbm: float                 # EIRP
    channel: int

    def __post_init__(self) -> None:
        if not BSSID_PATTERN.fullmatch(self.bssid):
            raise ValueError(f"bssid: {self.bssid!r} is not six colon-separated hex bytes")
        if len(self.position) != 2 or not all(math.isfinite(v) for v in self.position):
            raise ValueError(f"{self.bssid}: position: {self.position} is not a finite (x, y)")
        if not math.isfinite(self.tx_power_dbm):
            raise ValueError(f"{self.bssid}: tx_power_dbm: {self.tx_power_dbm} is not a finite number")
        channel_frequency_hz(self.channel)

    @property
    def frequency_hz(self) -> float:
        return channel_frequency_hz(self.channel)


@dataclass(frozen=True)
class PropagationSettings:
    path_loss_exponent: float = 2.0          # free-space-like between walls; walls are counted separately
    reference_loss_db: float | None = None   # loss at d0 = 1 m; None: Friis at each AP's frequency
    wall_loss_db: float = 5.0                # per wall crossed (COST 231 multi-wall, light internal walls)
    shadowing_sd_db: float = 4.0
    shadowing_correlation_m: float = 2.0     # length scale L of the shadowing field
    scan_noise_sd_db: float = 2.0            # independent per reading, per scan
    sensitivity_dbm: float = -90.0           # readings below are not reported
    min_distance_m: float = 0.5              # standing on an AP does not give infinite RSS

    def validate(self) -> None:
        """Raise a ParameterError naming the first bad field."""
        for field in fields(self):
            value = getattr(self, field.name)
            if value is not None and not math.isfinite(value):
                raise ParameterError(field.name, f"{value} is not a finite number")
        for name in ("wall_loss_db", "shadowing_sd_db", "scan_noise_sd_db"):
            if getattr(self, name) < 0.0:
                raise ParameterError(name, f"{getattr(self, name)} must not be negative")
        for name in ("path_loss_exponent", "shadowing_correlation_m", "min_distance_m"):
            if getattr(self, name) <= 0.0:
                raise ParameterError(name, f"{getattr(self, name)} must be positive")


@dataclass(frozen=True)
class RssReading:
    bssid: str
    ssid: str
    channel: int
    frequency_hz: float
    rssi_dbm: float


@dataclass(frozen=True, eq=False)
class ShadowingField:
    """One AP's shadowing [dB] over the plane: a fixed draw of random Fourier features.

    Features are float32: numpy's float32 cosine is SIMD-vectorized (~30x faster than float64 here), and
    a phase of 1e3 rad (a point 1 km away) rounds by ~1e-4 rad, a change of ~1e-4 dB in the field.
    """

    wave_vectors: np.ndarray    # 2 x K [rad/m], float32
    phases: np.ndarray          # K [rad], float32
    sd_db: float

    @classmethod
    def for_access_point(cls, world_seed: int, bssid: str, sd_db: float, correlation_m: float,
                         features: int = SHADOWING_FEATURES) -> ShadowingField:
        rng = np.random.default_rng(derive_seed(world_seed, f"wifi-shadowing/{bssid.lower()}"))
        wave_vectors = rng.normal(0.0, 1.0 / correlation_m, (2, features)).astype(np.float32)
        return cls(wave_vectors, rng.uniform(0.0, 2.0 * math.pi, features).astype(np.float32), sd_db)

    def db(self, points: np.ndarray) -> np.ndarray:
        """Shadowing at each row of ``points`` (M x 2)."""
        phase = points.astype(np.float32) @ self.wave_vectors
        phase += self.phases
        np.cos(phase, out=phase)
        return self.sd_db * math.sqrt(2.0 / len(self.phases)) * phase.sum(axis=1, dtype=float)


def walls_crossed(points: np.ndarray, source: tuple[float, float], walls: np.ndarray) -> np.ndarray:
    """How many walls (N x 4 rows x1, y1, x2, y2) the segment source-point crosses, per point (M x 2).

    A wall counts when source and point lie strictly on opposite sides of its line (a point on a wall is
    not behind it) and the wall's ends lie on opposite sides of the ray. A wall end exactly on the ray
    counts as lying on the ray's left, the crossing-number rule of point-in-polygon tests: a ray through a
    wall's end counts that wall at most once, and through the joint of a continuous wall drawn as two
    segments exactly once. A wall collinear with the ray has both ends on it and counts 0 (it blocks
    only a ray running inside it, a case of measure zero).
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    walls = np.asarray(walls, dtype=float).reshape(-1, 4)
    if len(walls) == 0:
        return np.zeros(len(points), dtype=int)
    sx, sy = float(source[0]), float(source[1])
    ax, ay, bx, by = (walls[:, i] for i in range(4))
    wx, wy = bx - ax, by - ay
    source_side = wx * (sy - ay) - wy * (sx - ax)                                            # N
    point_side = wx * (points[:, 1:2] - ay) - wy * (points[:, 0:1] - ax)                     # M x N
    rx, ry = points[:, 0:1] - sx, points[:, 1:2] - sy                                        # M x 1
    # Elementwise ufuncs (not a matmul) so an end shared by two walls gets the same, bitwise, orientation.
    a_left = rx * (ay - sy) - ry * (ax - sx) >= 0.0
    b_left = rx * (by - sy) - ry * (bx - sx) >= 0.0
    crossing = (source_side * point_side < 0.0) & (a_left != b_left)
    return np.count_nonzero(crossing, axis=1)


class WifiModel:
    """Mean and scanned RSS of a world's access points; the shadowing is fixed by ``world_seed``."""

    def __init__(self, access_points: Sequence[AccessPoint], walls: np.ndarray, settings: PropagationSettings,
                 world_seed: int) -> None:
        settings.validate()
        walls = np.asarray(walls, dtype=float)
        if walls.size == 0:
            walls = walls.reshape(0, 4)
        if walls.ndim != 2 or walls.shape[1] != 4 or not np.all(np.isfinite(walls)):
            raise ValueError(f"walls: expected finite N x 4 rows [x1, y1, x2, y2], got shape {walls.shape}")
        seen: set[str] = set()
        for ap in access_points:
            if ap.bssid.lower() in seen:
                raise ValueError(f"bssid: {ap.bssid} appears twice")
            seen.add(ap.bssid.lower())
        self.access_points = tuple(access_points)
        self.walls = walls
        self.settings = settings
        self.world_seed = world_seed
        self.reference_loss_db = np.array([free_space_loss_db(1.0, ap.frequency_hz)
                                           if settings.reference_loss_db is None else settings.reference_loss_db
                                           for ap in self.access_points])
        self.shadowing = tuple(ShadowingField.for_access_point(world_seed, ap.bssid, settings.shadowing_sd_db,
                                                               settings.shadowing_correlation_m)
                               for ap in self.access_points)

    def shadowing_db(self, points: np.ndarray) -> np.ndarray:
        """Shadowing (M x n_aps) [dB] at each row of ``points`` (M x 2)."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.column_stack([field.db(points) for field in self.shadowing] or [np.empty((len(points), 0))])

    def mean_rss_dbm(self, points: np.ndarray) -> np.ndarray:
        """Noise-free RSS (M x n_aps) [dBm] at each row of ``points`` (M x 2): the world's radio map."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        rss = np.empty((len(points), len(self.access_points)))
        for start in range(0, len(points), BLOCK_ROWS):        # 3-4x faster than whole-array temporaries
            rss[start:start + BLOCK_ROWS] = self.block_rss_dbm(points[start:start + BLOCK_ROWS])
        return rss

    def block_rss_dbm(self, points: np.ndarray) -> np.ndarray:
        """:meth:`mean_rss_dbm` of one block of points."""
        s = self.settings
        rss = np.empty((len(points), len(self.access_points)))
        for i, ap in enumerate(self.access_points):
            distance = np.maximum(np.hypot(points[:, 0] - ap.position[0], points[:, 1] - ap.position[1]),
                                  s.min_distance_m)
            rss[:, i] = (ap.tx_power_dbm - self.reference_loss_db[i] - 10.0 * s.path_loss_exponent * np.log10(distance)
                         - s.wall_loss_db * walls_crossed(points, ap.position, self.walls))
        return rss + self.shadowing_db(points)

    def scan(self, x: float, y: float, rng: np.random.Generator) -> list[RssReading]:
        """One scan at (x, y): every AP heard at or above the sensitivity, with independent noise, in AP order."""
        mean = self.mean_rss_dbm(np.array([[x, y]]))[0]
        # Noise is drawn for every AP, heard or not, so the stream consumed does not depend on the position.
        rssi = mean + rng.normal(0.0, self.settings.scan_noise_sd_db, mean.size)
        return [RssReading(ap.bssid, ap.ssid, ap.channel, ap.frequency_hz, float(value))
                for ap, value in zip(self.access_points, rssi) if value >= self.settings.sensitivity_dbm]
