"""WiFi fingerprint matching of the location server (paper 003, tier one): k nearest neighbours in signal space.

The radio map holds fingerprints: a position and the RSS of every access point (BSSID) heard there. A robot's
scan is placed where the fingerprints most like it were taken (RADAR, Bahl & Padmanabhan 2000):

* Signal distance: Euclidean, in dB, over the union of the scan's access points that the map knows and the
  fingerprint's access points. An access point heard on one side only counts as heard at ``missing_rss_dbm``
  on the other, a level below any receiver's sensitivity: "not heard" is a very weak signal, so a fingerprint
  that hears a strong AP the scan misses is far from it. Scan BSSIDs the map never saw carry no information
  about position (a new or mobile AP) and are ignored and reported, never an error.
* Candidates: fingerprints sharing at least ``min_common_aps`` access points with the scan, so a fingerprint
  matching only on "not heard" cannot win.
* Estimate: the mean of the k nearest candidates' positions, weighted by 1 / (signal distance + 1e-6) or
  uniformly. Ties in signal distance go to the fingerprint added first, so results are reproducible.
* Uncertainty: the weighted RMS distance of the neighbours from the estimate, floored at half the map's
  spacing (the median distance from a fingerprint position to its nearest other one). A fingerprint map
  cannot place the robot finer than its own grid, and without the floor a lone (k = 1) or exact match would
  claim zero error and shrink the robot's tier-two search to nothing.

The fingerprints are held as a (fingerprints x access points) matrix, built once after fingerprints are added,
so a scan costs a few vectorised passes over it (well under a millisecond on a 2,000-fingerprint map).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

from rfidnav_common import inputs
from rfidnav_common.errors import ParameterError
from rfidnav_localization.errors import LocateError

SOURCES = ("grid", "survey", "robot")   # a generated grid, a manual survey, the robot's own automatic survey
WEIGHTINGS = ("inverse_distance", "uniform")
_EPSILON_DB = 1e-6                      # keeps an exact match's inverse-distance weight finite
# A fingerprint further than this outside what the map covers (its tag groups, deployment area and fingerprints) is
# refused: no scan taken there can be of this map. A survey still grows the map, a margin at a time.
MAP_MARGIN_M = 10.0
_SPACING_CHUNK = 256                    # rows per block of the pairwise spacing computation (bounds memory)


@dataclass(frozen=True)
class Fingerprint:
    """RSS readings taken at one position of the map frame [m].

    ``rss`` may be given as a mapping BSSID -> dBm (or as pairs); it is stored as a tuple of (BSSID, dBm)
    pairs sorted by BSSID so fingerprints compare equal and hash. BSSIDs are compared exactly as given.
    """

    position: tuple[float, float]
    rss: tuple[tuple[str, float], ...]
    source: str = "survey"

    def __post_init__(self) -> None:
        x, y = inputs.point(*self.position, "position")
        if self.source not in SOURCES:
            raise ValueError(f"source: '{self.source}' is not one of {', '.join(SOURCES)}")
        pairs = self.rss.items() if isinstance(self.rss, Mapping) else self.rss
        readings: dict[str, float] = {}
        for bssid, value in pairs:
            if not isinstance(bssid, str) or not bssid:
                raise ValueError(f"rss: a BSSID must be a non-empty string, got {bssid!r}")
            if bssid in readings:
                raise ValueError(f"rss[{bssid}]: given twice")
            readings[bssid] = inputs.rss_dbm(value, f"rss[{bssid}]")
        if not readings:
            raise ValueError("rss: a fingerprint needs at least one access point")
        object.__setattr__(self, "position", (x, y))
        object.__setattr__(self, "rss", tuple(sorted(readings.items())))


@dataclass(frozen=True)
class Extent:
    """An axis-aligned rectangle of the map frame [m]: where the location server's map lies."""
    x_min: float
    y_min: float
    x_max: float
    y_max: float

    @classmethod
    def around(cls, points: Iterable[tuple[float, float]]) -> Extent | None:
        """The smallest extent holding ``points``; None without any."""
        listed = list(points)
        if not listed:
            return None
        xs, ys = zip(*listed)
        return cls(min(xs), min(ys), max(xs), max(ys))

    def including(self, x: float, y: float) -> Extent:
        return Extent(min(self.x_min, x), min(self.y_min, y), max(self.x_max, x), max(self.y_max, y))

    def grown(self, margin_m: float) -> Extent:
        return Extent(self.x_min - margin_m, self.y_min - margin_m, self.x_max + margin_m, self.y_max + margin_m)

    def contains(self, x: float, y: float) -> bool:
        return self.x_min <= x <= self.x_max and self.y_min <= y <= self.y_max

    def __str__(self) -> str:
        return f"[{self.x_min:g}, {self.x_max:g}] x [{self.y_min:g}, {self.y_max:g}] m"


@dataclass(frozen=True)
class LocateSettings:
    k: int = 3
    missing_rss_dbm: float = -100.0     # RSS assumed for an AP heard on one side only (below sensitivity)
    min_common_aps: int = 1             # fewer shared APs with the scan: not a candidate
    weighting: str = "inverse_distance"

    def validate(self) -> None:
        if isinstance(self.k, bool) or not isinstance(self.k, int) or self.k < 1:
            raise ParameterError("k", f"must be a whole number of at least 1, got {self.k}")
        if not math.isfinite(self.missing_rss_dbm):
            raise ParameterError("missing_rss_dbm", f"must be a finite dBm value, got {self.missing_rss_dbm}")
        if isinstance(self.min_common_aps, bool) or not isinstance(self.min_common_aps, int) \
                or self.min_common_aps < 1:
            raise ParameterError("min_common_aps", f"must be a whole number of at least 1, got {self.min_common_aps}")
        if self.weighting not in WEIGHTINGS:
            raise ParameterError("weighting", f"'{self.weighting}' is not one of {', '.join(WEIGHTINGS)}")


@dataclass(frozen=True)
class LocateResult:
    position: tuple[float, float]                   # map frame [m]
    uncertainty_m: float                            # weighted RMS spread of the neighbours, >= half the spacing
    neighbours: tuple[tuple[float, float], ...]     # the k nearest fingerprints' positions, nearest first
    signal_distance_db: float                       # signal distance of the nearest fingerprint
    known_aps: int                                  # scan BSSIDs the radio map knows (the ones that were used)
    ignored_bssids: tuple[str, ...]                 # scan BSSIDs the radio map never saw, sorted


@dataclass(frozen=True)
class _Matrix:
    bssids: tuple[str, ...]
    column: dict[str, int]
    positions: np.ndarray       # (fingerprints, 2)
    rss: np.ndarray             # (fingerprints, access points) [dBm], 0 where not heard
    heard: np.ndarray           # (fingerprints, access points) bool
    spacing_m: float


class RadioMap:
    """The location server's radio map: fingerprints, and the scan matcher over them."""

    def __init__(self, fingerprints: Iterable[Fingerprint] = ()) -> None:
        self._fingerprints: list[Fingerprint] = list(fingerprints)
        self._matrix: _Matrix | None = None
        self._filled_rss: tuple[float, np.ndarray] | None = None    # (missing_rss_dbm, filled matrix)

    def add(self, *fingerprints: Fingerprint) -> None:
        self._fingerprints.extend(fingerprints)
        self._matrix = None     # rebuilt on next use, so a survey adding one at a time costs one build
        self._filled_rss = None

    def __len__(self) -> int:
        return len(self._fingerprints)

    @property
    def fingerprints(self) -> tuple[Fingerprint, ...]:
        return tuple(self._fingerprints)

    @property
    def bssids(self) -> tuple[str, ...]:
        return self._built().bssids

    @property
    def spacing_m(self) -> float:
        """Median distance from a fingerprint position to the nearest other one (0 with fewer than two)."""
        return self._built().spacing_m

    def locate(self, scan: Mapping[str, float], settings: LocateSettings = LocateSettings()) -> LocateResult:
        """Where ``scan`` (BSSID -> RSS [dBm]) was taken; LocateError says why when the map cannot tell."""
        settings.validate()
        readings = _checked_scan(scan)
        if not self._fingerprints:
            raise LocateError("the radio map is empty: no fingerprint to match the scan against")
        matrix = self._built()
        known = sorted(bssid for bssid in readings if bssid in matrix.column)
        ignored = tuple(sorted(bssid for bssid in readings if bssid not in matrix.column))
        if not known:
            raise LocateError(f"none of the scan's {len(readings)} access points is in the radio map "
                              f"({', '.join(ignored)})")
        columns = np.array([matrix.column[bssid] for bssid in known])
        missing = settings.missing_rss_dbm
        query = np.full(len(matrix.bssids), missing)
        query[columns] = [readings[bssid] for bssid in known]
        # APs heard on neither side are 'missing' on both and add nothing, so the sum over every column of
        # the map equals the documented sum over the union of the two sides' APs.
        filled = self._filled(missing)
        distance = np.sqrt(np.square(filled - query).sum(axis=1))
        common = matrix.heard[:, columns].sum(axis=1)
        candidates = np.flatnonzero(common >= settings.min_common_aps)
        if candidates.size == 0:
            raise LocateError(f"no fingerprint shares {settings.min_common_aps} access points with the scan "
                              f"(the best shares {int(common.max())} of its {len(known)} known ones)")
        nearest = candidates[np.lexsort((candidates, distance[candidates]))][:settings.k]
        if settings.weighting == "inverse_distance":
            weights = 1.0 / (distance[nearest] + _EPSILON_DB)
        else:
            weights = np.ones(len(nearest))
        points = matrix.positions[nearest]
        estimate = weights @ points / weights.sum()
        spread = math.sqrt(float(weights @ np.square(points - estimate).sum(axis=1) / weights.sum()))
        return LocateResult(
            position=(float(estimate[0]), float(estimate[1])),
            uncertainty_m=max(spread, 0.5 * matrix.spacing_m),
            neighbours=tuple((float(x), float(y)) for x, y in points),
            signal_distance_db=float(distance[nearest[0]]),
            known_aps=len(known),
            ignored_bssids=ignored)

    def _built(self) -> _Matrix:
        if self._matrix is None:
            self._matrix = _build_matrix(self._fingerprints)
        return self._matrix

    def _filled(self, missing_rss_dbm: float) -> np.ndarray:
        """The map's RSS matrix with ``missing_rss_dbm`` where an AP is not heard: built once per map and setting,
        not on every locate (the server answers many scans against one map)."""
        if self._filled_rss is None or self._filled_rss[0] != missing_rss_dbm:
            matrix = self._built()
            self._filled_rss = (missing_rss_dbm, np.where(matrix.heard, matrix.rss, missing_rss_dbm))
        return self._filled_rss[1]


def _checked_scan(scan: Mapping[str, float]) -> dict[str, float]:
    if not scan:
        raise LocateError("the scan is empty: no access point was heard")
    readings: dict[str, float] = {}
    for bssid, value in scan.items():
        try:
            readings[bssid] = inputs.rss_dbm(float(value) if isinstance(value, numbers.Real) else value,
                                             f"access point {bssid}: RSS")
        except inputs.BadInput as error:
            raise LocateError(str(error)) from None
    return readings


def _build_matrix(fingerprints: list[Fingerprint]) -> _Matrix:
    bssids = tuple(sorted({bssid for fingerprint in fingerprints for bssid, _ in fingerprint.rss}))
    column = {bssid: index for index, bssid in enumerate(bssids)}
    rss = np.zeros((len(fingerprints), len(bssids)))
    heard = np.zeros(rss.shape, dtype=bool)
    for row, fingerprint in enumerate(fingerprints):
        columns = [column[bssid] for bssid, _ in fingerprint.rss]
        rss[row, columns] = [value for _, value in fingerprint.rss]
        heard[row, columns] = True
    positions = np.array([fingerprint.position for fingerprint in fingerprints], dtype=float).reshape(-1, 2)
    return _Matrix(bssids, column, positions, rss, heard, _median_spacing(positions))


def _median_spacing(positions: np.ndarray) -> float:
    # Repeated surveys of one spot are one position: they say nothing about the map's resolution.
    unique = np.unique(positions, axis=0)
    if len(unique) < 2:
        return 0.0
    nearest_squared = np.empty(len(unique))
    for start in range(0, len(unique), _SPACING_CHUNK):
        block = unique[start:start + _SPACING_CHUNK]
        squared = np.square(block[:, :1] - unique[:, 0]) + np.square(block[:, 1:] - unique[:, 1])
        squared[np.arange(len(block)), np.arange(start, start + len(block))] = np.inf
        nearest_squared[start:start + len(block)] = squared.min(axis=1)
    return float(np.sqrt(np.median(nearest_squared)))
