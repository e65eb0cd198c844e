"""Archimedean spiral search of paper 003 (Sec. 3.3): tier-two localization by finding a floor tag group.

From where tier-one localization left it (the spiral origin) the robot drives r = d theta, theta >= 0, whose
turns are 2 pi d apart along every ray from the origin, until its reader reads a tag of a group
(:mod:`rfidnav_common.tag_groups`). The spiral leaves the origin along ``start_heading`` h and turns CCW (REP
103): the point at angle theta is ``origin + d theta (cos(theta + h), sin(theta + h))``, the heading there
``h + theta + atan(theta)``, the curvature ``(2 + theta^2) / (d (1 + theta^2)^(3/2))`` (2/d at the start).

Lemma 1 is :func:`spiral_length`, Theorem 1 :func:`expected_search_length`; :class:`SpiralSearch` is the motion
primitive; :func:`simulate_search` (with a reader that reads continuously or is polled, :class:`SearchPolls`) and
:func:`simulate_crossing` walk the ideal spiral against tags or outlines for the papers' statistics. Pure module:
numpy and scipy, no ROS.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike
from scipy import integrate
from scipy.spatial import cKDTree

from rfidnav_common.polling import PollClock
from rfidnav_common.tag_groups import minimum_width

WIDTH_OVER_SEPARATION = math.pi / (2.0 * math.sqrt(2.0))
"""Minimum width of a non-circular group over the turn separation 2 pi d: the paper's cross (L = pi^2 d, width
L / sqrt(2)) has this 11 % margin, and :func:`separation_for_group` gives the triangle and square the same."""

GUARANTEE_DISTANCE_IN_D = MappingProxyType({"circle": 0.0, "cross": 8.0, "triangle": 0.0, "square": 0.0})
"""Distance from the spiral origin to the group centre, in units of d, beyond which a group sized by
:func:`separation_for_group` is crossed by the ideal spiral at every bearing and rotation (read range 0).
Everything scales with d, so one number per shape holds for every d. Circle: proven (see
:func:`separation_for_group`). Cross: the farthest miss a grid search over distance, bearing and rotation,
refined around its worst case, found is 7.59 d (bearing 5.378 rad, rotation 1.309 rad), rounded up to 8 d.
Triangle and square: the same search and 10^6 random placements within 12 d found no miss at any distance (a
numerical finding, not a proof)."""


def _scalar_or_array(value: np.ndarray) -> float | np.ndarray:
    return float(value) if np.ndim(value) == 0 else value


def _positive(value: float, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name}: expected a positive finite number, got {value!r}")
    return float(value)


def _rotation(angle: float) -> np.ndarray:
    """Matrix turning row vectors CCW by ``angle`` (``points @ _rotation(a)``)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, s], [-s, c]])


def spiral_length(theta: ArrayLike, d: float) -> float | np.ndarray:
    """Lemma 1: arc length of r = d theta from the origin to angle theta, (d/2)[theta sqrt(1+theta^2) +
    ln(theta + sqrt(1+theta^2))] (the logarithm is asinh(theta), which stays accurate near 0)."""
    theta = np.asarray(theta, dtype=float)
    return _scalar_or_array(0.5 * d * (theta * np.sqrt(1.0 + theta * theta) + np.arcsinh(theta)))


def length_to_radius(radius_m: ArrayLike, d: float) -> float | np.ndarray:
    """Arc length from the origin until the spiral first reaches ``radius_m`` (Lemma 1 with theta = E / d)."""
    return spiral_length(np.asarray(radius_m, dtype=float) / d, d)


def theta_at_length(length_m: ArrayLike, d: float) -> float | np.ndarray:
    """Spiral angle after ``length_m`` of arc from the origin (inverse of :func:`spiral_length`), vectorized.

    Newton's method from min(length/d, sqrt(2 length/d)): the arc length is increasing and convex in theta with
    slope d sqrt(1+theta^2) >= max(d, d theta), so both guesses lie at or above the root and Newton descends to
    it monotonically, without bracketing.
    """
    length = np.asarray(length_m, dtype=float)
    if np.any(length < 0.0) or not np.all(np.isfinite(length)):
        raise ValueError(f"length_m: expected finite lengths >= 0, got {length_m!r}")
    ratio = length / d
    theta = np.minimum(ratio, np.sqrt(2.0 * ratio))
    for _ in range(100):
        step = (np.asarray(spiral_length(theta, d)) - length) / (d * np.sqrt(1.0 + theta * theta))
        theta = theta - step
        if np.all(np.abs(step) <= 1e-13 * (1.0 + theta)):
            break
    return _scalar_or_array(theta)


def spiral_point(theta: ArrayLike, d: float, origin: Sequence[float] = (0.0, 0.0),
                 start_heading: float = 0.0) -> np.ndarray:
    """Point(s) of the spiral at angle(s) ``theta``: shape (2,) for a scalar, (M, 2) for M angles."""
    theta = np.asarray(theta, dtype=float)
    angle = theta + start_heading
    return np.stack([origin[0] + d * theta * np.cos(angle), origin[1] + d * theta * np.sin(angle)], axis=-1)


def spiral_curvature(theta: ArrayLike, d: float) -> float | np.ndarray:
    """Curvature of r = d theta at angle theta: (2 + theta^2) / (d (1 + theta^2)^(3/2)), decreasing from 2/d."""
    theta = np.asarray(theta, dtype=float)
    return _scalar_or_array((2.0 + theta * theta) / (d * (1.0 + theta * theta) ** 1.5))


def separation_for_group(shape: str, size_m: float, read_range_m: float = 0.0) -> float:
    """The spiral constant d (turns 2 pi d apart) for which a group of ``shape`` and ``size_m`` is crossed; with
    ``read_range_m`` > 0 (ours) for which the band a reader of that range reads around the outline is crossed.

    * circle (diameter D): d = D / (2 pi), the paper's basis, crossed wherever it lies: on the ray from the
      origin through its centre the disc covers a closed interval of length 2 pi d, which holds a crossing of
      the ray by the spiral (or the origin), and from inside the disc the outward spiral must cross the outline.
    * cross (bars L): d = L / pi^2, the paper's; crossed once its centre is :data:`GUARANTEE_DISTANCE_IN_D` (8) d
      or more from the origin; nearer, a few placements nest between the tightly curved first turns (Fig. 6(c)).
    * triangle, square (side s): d making the minimum width (s sqrt(3)/2, s) :data:`WIDTH_OVER_SEPARATION` times
      2 pi d, as for the cross; no miss was found at any distance. The paper's same-perimeter sides (2 pi^2 d / 3,
      pi^2 d / 2) are narrower than the turn separation (5.70 d, 4.93 d < 6.28 d): lying along the turns they
      miss at every distance (2 % and 3 % of random placements), as Fig. 6(c) shows, hence this denser spiral.

    Away from the origin the turns look locally like parallel lines at most 2 pi d apart, so a connected group
    wider than that in every direction cannot fit between two. A reader of range r widens every group by 2r:
    these guarantees, for range 0 (the paper's sizing), hold a fortiori for a real reader; ``read_range_m`` = r
    spends that margin on turns 2r / (2 pi margin) further apart (the cross: d = (L + 2 sqrt(2) r) / pi^2), so
    the spiral reaches far placements sooner, and is crossed only where the reader reads out to r.
    """
    if not math.isfinite(read_range_m) or read_range_m < 0.0:
        raise ValueError(f"read_range_m: expected a finite range >= 0, got {read_range_m!r}")
    width = minimum_width(shape, _positive(size_m, "size_m")) + 2.0 * read_range_m
    margin = 1.0 if shape == "circle" else WIDTH_OVER_SEPARATION
    return width / (2.0 * math.pi * margin)


def expected_search_length(sigma_m: float, d: float, as_printed: bool) -> float:
    """Theorem 1: the expected spiral length len(E / d) until the spiral reaches the tier-one error distance E.

    ``as_printed=True`` integrates the paper's density literally, f(E) = exp(-E^2 / 2 sigma^2) / sqrt(2 pi
    sigma^2) on [0, inf): a normal density cut at 0 integrates to 1/2, so this is half the expectation under the
    half-normal distance it evidently meant (a factor 2 is missing). ``as_printed=False`` uses the distance the
    paper's own model implies: a 2-D Gaussian error of per-axis deviation sigma (Fig. 5(a)) has a Rayleigh
    distance, f(E) = E / sigma^2 exp(-E^2 / 2 sigma^2); as len(E/d) ~ E^2 / (2 d), this is about sigma^2 / d.
    Both count the length to radius E, the paper's proxy: the group is met within about a turn of it.
    """
    _positive(d, "d")
    variance = _positive(sigma_m, "sigma_m") ** 2

    def integrand(e: float) -> float:
        gaussian = math.exp(-e * e / (2.0 * variance))
        density = gaussian / math.sqrt(2.0 * math.pi * variance) if as_printed else e / variance * gaussian
        return float(length_to_radius(e, d)) * density

    return integrate.quad(integrand, 0.0, math.inf)[0]


@dataclass(frozen=True)
class SpiralSearch:
    """The spiral as a motion primitive: velocity commands as a function of the distance travelled.

    The state is the distance travelled (odometry): searching while the spiral is inside ``max_radius_m``,
    exhausted beyond (``command`` returns None). At constant speed v, omega is v times the spiral's curvature.

    The curvature is 2/d at the start: the robot first turns on a circle of radius d/2 (1.5 cm for the 29 cm
    cross). With ``max_angular_speed`` (for a minimum turn radius R, v / R) omega is clipped while v * 2/d
    exceeds it. The curvature only decreases, so only a first stretch is clipped; after it the robot turns as
    the spiral does, and as a curve is fixed up to a rigid motion by its curvature along its length, the rest
    is the ideal spiral turned and shifted by a fixed amount (of the order of the clipped stretch): the
    guarantees hold about that displaced origin, and :meth:`path` is not what the robot drives near the start.
    """

    d: float
    speed_m_s: float
    max_radius_m: float
    origin: tuple[float, float] = (0.0, 0.0)
    start_heading: float = 0.0
    max_angular_speed: float | None = None

    def __post_init__(self) -> None:
        for name in ("d", "speed_m_s", "max_radius_m"):
            _positive(getattr(self, name), name)
        if self.max_angular_speed is not None:
            _positive(self.max_angular_speed, "max_angular_speed")
        if len(self.origin) != 2 or not all(map(math.isfinite, self.origin)):
            raise ValueError(f"origin: expected two finite numbers (x, y), got {self.origin!r}")
        if not math.isfinite(self.start_heading):
            raise ValueError(f"start_heading: expected a finite angle, got {self.start_heading!r}")
        object.__setattr__(self, "origin", (float(self.origin[0]), float(self.origin[1])))

    @property
    def max_length_m(self) -> float:
        """Arc length at which the spiral reaches ``max_radius_m`` and the search gives up."""
        return float(length_to_radius(self.max_radius_m, self.d))

    def command(self, travelled_m: float) -> tuple[float, float] | None:
        """(v, omega) after ``travelled_m`` along the spiral, or None once it would leave ``max_radius_m``."""
        if not math.isfinite(travelled_m) or travelled_m < 0.0:
            raise ValueError(f"travelled_m: expected a finite distance >= 0, got {travelled_m!r}")
        if travelled_m > self.max_length_m:
            return None
        omega = self.speed_m_s * float(spiral_curvature(theta_at_length(travelled_m, self.d), self.d))
        if self.max_angular_speed is not None:
            omega = min(omega, self.max_angular_speed)
        return self.speed_m_s, omega

    def path(self, step_m: float) -> np.ndarray:
        """The ideal spiral (M x 2, this search's frame) at arc-length steps ``step_m``, out to ``max_radius_m``."""
        _, points = _spiral_polyline(self.d, self.max_radius_m, _positive(step_m, "step_m"))
        return points @ _rotation(self.start_heading) + np.asarray(self.origin)


def _spiral_polyline(d: float, max_radius_m: float, step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Arc lengths (M,) and points (M x 2) of the spiral from the origin along +x, ending exactly at max radius."""
    total = float(length_to_radius(max_radius_m, d))
    lengths = np.append(np.arange(0.0, total, step_m), total)
    return lengths, spiral_point(theta_at_length(lengths, d), d)


def _to_spiral_frame(points: np.ndarray, start: Sequence[float], heading: float) -> np.ndarray:
    """World points (N x 2) in the frame where the spiral starts at the origin along +x."""
    return (np.asarray(points, dtype=float).reshape(-1, 2) - np.asarray(start, dtype=float)) @ _rotation(-heading)


@dataclass
class SearchPolls:
    """A polled reader on a simulated search: the robot drives the spiral at ``speed_m_s`` and reads only at the
    rounds of ``clock`` that read (rfidnav_common.polling; paper 003's HF reader: every 500-600 ms, some failing),
    its time counted from the start of the search."""
    speed_m_s: float
    clock: PollClock

    def __post_init__(self) -> None:
        _positive(self.speed_m_s, "speed_m_s")

    def lengths(self, max_length_m: float, chunk: int = 64) -> Iterator[np.ndarray]:
        """Arc lengths of the rounds that read, ascending, ``chunk`` rounds at a time, up to ``max_length_m``."""
        while True:
            lengths, time_s = [], 0.0
            for _ in range(chunk):
                time_s = self.clock.next_poll_s
                self.clock.due(time_s)
                if self.clock.reads():          # drawn at every round: paired runs fail at the same rounds
                    lengths.append(self.speed_m_s * time_s)
            along = np.array(lengths)
            yield along[along <= max_length_m]
            if self.speed_m_s * time_s > max_length_m:
                return


def simulate_search(group_tags: np.ndarray, start: Sequence[float], heading: float, d: float,
                    read_range_m: float, max_radius_m: float, step_m: float = 0.005,
                    polls: SearchPolls | None = None) -> float | None:
    """Length driven along the ideal spiral from ``start`` (leaving along ``heading``) until the antenna, at the
    robot centre, is within ``read_range_m`` of a tag of ``group_tags`` (N x 2) when the reader reads; None if
    none is read within ``max_radius_m``.

    Without ``polls`` the reader reads continuously: the spiral is sampled every ``step_m``, so the length is
    late by less than one step. With ``polls`` it reads only at those rounds, exactly where the robot is then: a
    group the spiral crosses between two rounds that read is not seen there.
    """
    for name, value in (("d", d), ("max_radius_m", max_radius_m), ("step_m", step_m)):
        _positive(value, name)
    if not math.isfinite(read_range_m) or read_range_m < 0.0:
        raise ValueError(f"read_range_m: expected a finite range >= 0, got {read_range_m!r}")
    tags = _to_spiral_frame(group_tags, start, heading)
    if len(tags) == 0:
        return None
    tree = cKDTree(tags)
    if polls is None:
        lengths, points = _spiral_polyline(d, max_radius_m, step_m)
        hits = np.flatnonzero(tree.query(points)[0] <= read_range_m)
        return float(lengths[hits[0]]) if len(hits) else None
    for lengths in polls.lengths(float(length_to_radius(max_radius_m, d))):
        if len(lengths) == 0:
            continue
        hits = np.flatnonzero(tree.query(spiral_point(theta_at_length(lengths, d), d))[0] <= read_range_m)
        if len(hits):
            return float(lengths[hits[0]])
    return None


def simulate_crossing(outline: Sequence[np.ndarray], start: Sequence[float], heading: float, d: float,
                      max_radius_m: float, step_m: float = 0.005) -> float | None:
    """Length driven along the ideal spiral until it first crosses or touches a polyline of ``outline`` (pieces
    of K x 2, e.g. :meth:`TagGroup.outline_segments`), or None within ``max_radius_m``: the search with read
    range 0 and a continuous tag line, the setting of the paper's crossing argument. The spiral is a chord
    polygon of step ``step_m``; the crossing length is interpolated along the chord.
    """
    for name, value in (("d", d), ("max_radius_m", max_radius_m), ("step_m", step_m)):
        _positive(value, name)
    pieces = [_to_spiral_frame(piece, start, heading) for piece in outline]
    if not pieces:
        raise ValueError("outline: expected at least one polyline piece")
    q0 = np.vstack([piece[:-1] for piece in pieces])
    q1 = np.vstack([piece[1:] for piece in pieces])
    lengths, points = _spiral_polyline(d, max_radius_m, step_m)
    p0, p1 = points[:-1], points[1:]
    low, high = np.minimum(q0, q1).min(axis=0), np.maximum(q0, q1).max(axis=0)
    near = np.flatnonzero(np.all((np.maximum(p0, p1) >= low) & (np.minimum(p0, p1) <= high), axis=1))
    if len(near) == 0:
        return None
    a0, a1 = p0[near][:, None, :], p1[near][:, None, :]
    r, s = a1 - a0, (q1 - q0)[None, :, :]
    offset = q0[None, :, :] - a0
    denominator = r[..., 0] * s[..., 1] - r[..., 1] * s[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (offset[..., 0] * s[..., 1] - offset[..., 1] * s[..., 0]) / denominator
        u = (offset[..., 0] * r[..., 1] - offset[..., 1] * r[..., 0]) / denominator
    # Parallel pairs (denominator 0) give NaN or inf and drop out; only an exactly collinear overlap is lost.
    crossing = (t >= 0.0) & (t <= 1.0) & (u >= 0.0) & (u <= 1.0)
    rows, cols = np.nonzero(crossing)
    if len(rows) == 0:
        return None
    along = lengths[near][rows] + t[rows, cols] * np.diff(lengths)[near][rows]
    return float(along.min())
