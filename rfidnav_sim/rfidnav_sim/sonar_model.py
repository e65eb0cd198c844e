"""Ultrasonic rangefinders (paper 004 section 4): seven sonars at the front of a ~35 cm robot, range up to 5 m.

A sonar sends a burst into a cone and times the first echo, so a beam reports the nearest wall anywhere in its
cone, not the wall straight ahead: that is why a beam is cast as ``rays_per_beam`` rays spread evenly over the
cone, edges included, and the shortest wins. Specular loss: a smooth wall reflects a burst that meets it far from
its normal away from the transducer (Leonard & Durrant-Whyte's "regions of constant depth"), so a ray whose first
wall it meets more than ``specular_angle_rad`` off that wall's normal gives no echo (it does not pass through to a
farther wall); a beam all of whose rays are lost reads nothing, +inf. Multipath (the lost burst's echo from a
second wall, a range too long) is not modelled.

Readings follow sensor_msgs/Range: an echo beyond ``max_range_m`` (or none) is +inf, "no detection within
range" (REP 117); an echo closer than ``min_range_m`` is reported as ``min_range_m``, as a sonar's blanking
interval does (it cannot time an echo that returns while the transducer still rings, but something is there).
Gaussian noise with sd ``noise_sd_m + noise_fraction * range`` (timing jitter plus a speed-of-sound error that
grows with the distance) is added to echoes within range, and the result is clipped back into [min, max].
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rfidnav_sim.nearby import NearbyGrid

ON_WALL_TOLERANCE_M = 1e-9      # a ray origin this far "behind" a wall is on it (rotated mounting points round off)
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]*")      # a valid last token of a ROS topic name
ROBOT_HALF_SIZE_M = 0.175       # paper 004: the platform is approx. 35 cm square; base_link at its centre


@dataclass(frozen=True)
class Rangefinder:
    name: str                                 # topic suffix: /sonar/<name>, frame sonar_<name>
    position: tuple[float, float]             # in base_link [m]
    bearing_rad: float                        # boresight, CCW from the robot's forward (+x) axis
    beam_half_angle_rad: float = math.radians(12.5)   # Polaroid 6500-style 25 deg cone
    max_range_m: float = 5.0                  # paper 004: "sensitivity range is up to 5 meters"
    min_range_m: float = 0.15                 # blanking distance of a Polaroid-style transducer

    def __post_init__(self) -> None:
        if not NAME_PATTERN.fullmatch(self.name):
            raise ValueError(f"name: {self.name!r} is not a valid topic name token (letter, then [A-Za-z0-9_])")
        if len(self.position) != 2 or not all(math.isfinite(v) for v in self.position):
            raise ValueError(f"{self.name}: position: {self.position} is not a finite (x, y)")
        if not math.isfinite(self.bearing_rad):
            raise ValueError(f"{self.name}: bearing_rad: {self.bearing_rad} is not finite")
        if not 0.0 <= self.beam_half_angle_rad < math.pi / 2.0:
            raise ValueError(f"{self.name}: beam_half_angle_rad: {self.beam_half_angle_rad} is not in [0, pi/2)")
        if not (math.isfinite(self.max_range_m) and 0.0 <= self.min_range_m < self.max_range_m):
            raise ValueError(f"{self.name}: ranges: need 0 <= min_range_m < max_range_m finite, got "
                             f"{self.min_range_m}, {self.max_range_m}")


# Paper 004 Fig. 8(a) shows seven sonars at the front "for forward and lateral sensing"; it gives no angles. The
# paper measures the wall angle with ONE lateral sonar read at two points L apart along the path (Fig. 8(b)),
# so one sonar per side at 90 deg suffices: they sit just behind the front corners, looking straight out. Front
# (0), the +-45 pair and the +-60 pair at the bevelled corners cover the way ahead for obstacle stops and see
# the far wall of a junction early when the robot turns; 45 and 60 with 25 deg cones overlap, so nothing
# between 32.5 and 72.5 deg off the axis is missed on either side.
PAPER_LAYOUT: tuple[Rangefinder, ...] = (
    Rangefinder("front", (ROBOT_HALF_SIZE_M, 0.0), 0.0),
    Rangefinder("front_left_45", (ROBOT_HALF_SIZE_M, 0.10), math.radians(45.0)),
    Rangefinder("front_right_45", (ROBOT_HALF_SIZE_M, -0.10), math.radians(-45.0)),
    Rangefinder("left_60", (0.16, 0.16), math.radians(60.0)),
    Rangefinder("right_60", (0.16, -0.16), math.radians(-60.0)),
    Rangefinder("left", (0.15, ROBOT_HALF_SIZE_M), math.radians(90.0)),
    Rangefinder("right", (0.15, -ROBOT_HALF_SIZE_M), math.radians(-90.0)),
)


def centre_offsets(layout: tuple[Rangefinder, ...] = PAPER_LAYOUT) -> dict[str, float]:
    """Per rangefinder, its position's component along its bearing: added to a reading, the distance from the
    robot's centre (what wall_follower's ``sonar_offsets_m`` hold for the paper's layout)."""
    return {r.name: r.position[0] * math.cos(r.bearing_rad) + r.position[1] * math.sin(r.bearing_rad)
            for r in layout}


def cast_rays(origins: np.ndarray, directions: np.ndarray, walls: np.ndarray,
              specular_angle_rad: float = math.pi / 2.0) -> np.ndarray:
    """Distance along each ray (K origins, K unit directions, K x 2 each) to the nearest wall (N x 4 rows
    x1, y1, x2, y2) it hits, inf where it hits none, or where it meets that wall more than
    ``specular_angle_rad`` from the wall's normal; see :meth:`Walls.cast`."""
    origins = np.asarray(origins, dtype=float).reshape(-1, 2)
    directions = np.asarray(directions, dtype=float).reshape(-1, 2)
    rays = np.concatenate((origins[:, 0], origins[:, 1], directions[:, 0], directions[:, 1]))
    return Walls(walls, len(origins)).cast(rays, specular_angle_rad)


class Walls:
    """Walls (N x 4 rows x1, y1, x2, y2) as ``rays`` rays at a time are cast against them: each wall's start a,
    direction w = b - a and length, worked out once (a sonar casts at the same few walls thousands of times),
    and laid out ray by ray (K x N, flat): numpy's elementwise ops over whole arrays of a few hundred numbers take
    about a third of the time of the same ops broadcast from K x 1 and N."""

    def __init__(self, walls: np.ndarray, rays: int) -> None:
        self.segments = np.asarray(walls, dtype=float).reshape(-1, 4)
        self.rays = rays
        count = len(self.segments)
        ax, ay = self.segments[:, 0], self.segments[:, 1]
        wx, wy = self.segments[:, 2] - ax, self.segments[:, 3] - ay
        self.ax, self.ay, self.wx, self.wy = (np.tile(values, rays) for values in (ax, ay, wx, wy))   # K x N
        self.length = np.hypot(wx, wy)                                                               # N
        self.spread = np.repeat(np.arange(4 * rays), count)   # a ray's ox, oy, dx, dy beside each of the walls
        self.firsts = np.arange(rays) * count                 # where each ray's walls start in K x N

    def __len__(self) -> int:
        return len(self.segments)

    def cast(self, rays: np.ndarray, specular_angle_rad: float = math.pi / 2.0) -> np.ndarray:
        """Distance along each ray (``rays``: the K origins' x, then their y, then the K unit directions' x, then
        their y) to the nearest wall it hits, inf where it hits none, or where it meets that wall more than
        ``specular_angle_rad`` from the wall's normal (the unit direction's |d x w| / |w| is the cosine of that
        angle); distances are in multiples of the directions' lengths.

        Ray o + t d meets wall a + s w where t = ((a - o) x w) / (d x w) and s = ((a - o) x d) / (d x w); a hit
        needs t >= 0 and 0 <= s <= 1 (a wall's ends belong to it, so a ray through the joint of two walls hits).
        A ray parallel to a wall (d x w = 0) misses it, even one running inside it: that wall shows the sonar no
        face to echo from (dividing by NaN there makes t and s NaN, which no test passes). A ray whose origin
        lies on a wall hits that wall at 0 whichever way it points (t down to -ON_WALL_TOLERANCE_M counts,
        reported as 0): a transducer against a wall, or a robot overlapping one, reads the minimum range rather
        than seeing through it.
        """
        count = len(self.segments)
        if count == 0:
            return np.full(self.rays, np.inf)
        ox, oy, dx, dy = rays.take(self.spread).reshape(4, -1)                # K x N each
        relative_x, relative_y = ox - self.ax, oy - self.ay                     # o - a
        denominator = dx * self.wy - dy * self.wx                               # d x w
        safe = np.where(denominator == 0.0, np.nan, denominator)
        t = (self.wx * relative_y - self.wy * relative_x) / safe                # (a - o) x w / (d x w)
        s = (dx * relative_y - dy * relative_x) / safe                          # (a - o) x d / (d x w)
        hit = (t >= -ON_WALL_TOLERANCE_M) & (s >= 0.0) & (s <= 1.0)
        distances = np.where(hit, np.maximum(t, 0.0), np.inf)
        if specular_angle_rad >= math.pi / 2.0:
            return distances.reshape(self.rays, count).min(axis=1)
        nearest = distances.reshape(self.rays, count).argmin(axis=1)
        flat = self.firsts + nearest
        cos_incidence = np.abs(denominator.take(flat)) / self.length.take(nearest)
        return np.where(cos_incidence >= math.cos(specular_angle_rad), distances.take(flat), np.inf)


class SonarModel:
    """Readings of a set of rangefinders on a robot among fixed walls."""

    def __init__(self, rangefinders: Sequence[Rangefinder], walls: np.ndarray, noise_sd_m: float = 0.01,
                 noise_fraction: float = 0.01, rays_per_beam: int = 5,
                 specular_angle_rad: float = math.pi / 2.0) -> None:
        names = [r.name for r in rangefinders]
        if len(set(names)) != len(names):
            raise ValueError(f"rangefinders: names must be unique, got {names}")
        for field, value in (("noise_sd_m", noise_sd_m), ("noise_fraction", noise_fraction)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{field}: {value} is not a finite non-negative number")
        if rays_per_beam < 1:
            raise ValueError(f"rays_per_beam: {rays_per_beam} must be at least 1")
        if not 0.0 < specular_angle_rad <= math.pi / 2.0:
            raise ValueError(f"specular_angle_rad: {specular_angle_rad} is not in (0, pi/2]")
        walls = np.asarray(walls, dtype=float)
        if walls.size == 0:
            walls = walls.reshape(0, 4)
        if walls.ndim != 2 or walls.shape[1] != 4 or not np.all(np.isfinite(walls)):
            raise ValueError(f"walls: expected finite N x 4 rows [x1, y1, x2, y2], got shape {walls.shape}")
        self.rangefinders = tuple(rangefinders)
        self.walls = walls
        self.noise_sd_m = noise_sd_m
        self.noise_fraction = noise_fraction
        self.rays_per_beam = rays_per_beam
        self.specular_angle_rad = specular_angle_rad
        # Every ray of every beam, beam-major (K = beams x rays_per_beam): base_link origin and bearing.
        spread = np.linspace(-1.0, 1.0, rays_per_beam) if rays_per_beam > 1 else np.zeros(1)
        origins = np.repeat(np.array([r.position for r in self.rangefinders], dtype=float).reshape(-1, 2),
                            rays_per_beam, axis=0)
        self.ray_x, self.ray_y = origins[:, 0], origins[:, 1]
        self.ray_bearings = np.concatenate([r.bearing_rad + r.beam_half_angle_rad * spread
                                            for r in self.rangefinders] or [np.empty(0)])
        self.min_range_m = [r.min_range_m for r in self.rangefinders]
        self.max_range_m = [r.max_range_m for r in self.rangefinders]
        # No echo from farther than this from the robot's centre is in range: only the walls within it are cast
        # against (on a floor of 110 walls about 7 lie within 5 m of a robot in a corridor). The readings are
        # those cast against every wall: an echo within a beam's range comes from a wall within reach, which the
        # cell lists, and the nearest of the walls left out would read as no echo too, specular or not.
        self.reach_m = (max(self.max_range_m, default=0.0)
                        + float(np.hypot(origins[:, 0], origins[:, 1]).max(initial=0.0)))
        self.nearby = NearbyGrid(walls, self.reach_m, lambda indices: Walls(walls[indices], len(origins)))

    def echo_distances(self, x: float, y: float, yaw: float) -> list[float]:
        """Noise-free distance of the first echo of each beam (nearest wall in its cone), in order; inf for none,
        and for one from a wall farther than ``reach_m`` from the robot (beyond every beam's range)."""
        c, s = math.cos(yaw), math.sin(yaw)
        bearings = yaw + self.ray_bearings
        rays = np.concatenate((x + c * self.ray_x - s * self.ray_y, y + s * self.ray_x + c * self.ray_y,
                               np.cos(bearings), np.sin(bearings)))
        distances = self.nearby.near(x, y).cast(rays, self.specular_angle_rad).tolist()
        per_beam = self.rays_per_beam
        return [min(distances[first:first + per_beam]) for first in range(0, len(distances), per_beam)]

    def readings(self, x: float, y: float, yaw: float, rng: np.random.Generator) -> list[float]:
        """One reading per rangefinder, in order, with the robot at (x, y, yaw): metres in [min, max], or +inf.
        (Seven numbers: plain floats are quicker than arrays here.)"""
        # Noise is drawn for every beam, echo or not, so the stream consumed does not depend on the pose.
        noise = rng.standard_normal(len(self.rangefinders)).tolist()
        readings = []
        for echo, low, high, z in zip(self.echo_distances(x, y, yaw), self.min_range_m, self.max_range_m, noise):
            if echo > high:
                readings.append(math.inf)
                continue
            true_range = max(echo, low)
            readings.append(min(max(true_range + z * (self.noise_sd_m + self.noise_fraction * true_range), low), high))
        return readings

    def ranges(self, x: float, y: float, yaw: float, rng: np.random.Generator) -> dict[str, float]:
        """:meth:`readings` by rangefinder name."""
        return {r.name: value for r, value in zip(self.rangefinders, self.readings(x, y, yaw, rng))}
