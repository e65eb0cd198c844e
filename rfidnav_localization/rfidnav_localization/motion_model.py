"""The odometry motion model the particle filters share (the partition filter of paper 000, the fused localizer):
an odometry increment in the robot frame of the previous pose, drawn per particle with noise (pure).

Two ways to size the noise. :func:`sampled_increments` (the partition filter's) draws noise relative to each
increment plus a floor per step: over a stretch the drawn errors grow with the square root of the number of steps,
so its spread depends on how finely the odometry slices the motion (at 25 rounds a second, 0.02 rad per metre
drawn step by step spreads the heading by 0.1 degree a metre). :func:`walked_increments` (the fused localizer's)
draws a random walk whose variance grows with the distance travelled, the same spread over a metre whatever the
rate."""

from __future__ import annotations

import math

import numpy as np

from rfidnav_common.geometry import wrap_angle


def odometry_increment(previous: tuple[float, float, float],
                       odom: tuple[float, float, float]) -> tuple[float, float, float]:
    """(forward, lateral, rotation) from odometry pose ``previous`` to ``odom``, in the robot frame of ``previous``
    (the odom frame's own drift never enters)."""
    dx, dy = odom[0] - previous[0], odom[1] - previous[1]
    cos_yaw, sin_yaw = math.cos(previous[2]), math.sin(previous[2])
    return cos_yaw * dx + sin_yaw * dy, -sin_yaw * dx + cos_yaw * dy, wrap_angle(odom[2] - previous[2])


def sampled_increments(forward: float, lateral: float, rotation: float, count: int, rng: np.random.Generator,
                       noise_fraction: float, noise_floor_m: float, yaw_noise_per_m: float,
                       scales: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Per particle, the increment (dx, dy in the robot frame, dyaw) the odometry's (``forward``, ``lateral``,
    ``rotation``) stands for: translation noise ``noise_fraction`` of the distance plus ``noise_floor_m``, rotation
    noise ``noise_fraction`` of the turn plus ``yaw_noise_per_m`` per metre (wheel slip); the distance times each
    particle's odometry scale (``scales``) where the filter estimates one. None when standing still: odometry adds
    no uncertainty then (and draws nothing)."""
    distance = math.hypot(forward, lateral)
    if distance == 0.0 and rotation == 0.0:
        return None
    translation_sd = noise_fraction * distance + noise_floor_m
    rotation_sd = noise_fraction * abs(rotation) + yaw_noise_per_m * distance
    return _drawn(forward, lateral, rotation, translation_sd, rotation_sd, count, rng, scales)


def walked_increments(forward: float, lateral: float, rotation: float, count: int, rng: np.random.Generator,
                      distance_sd_m: float, turn_fraction: float, heading_sd_rad: float,
                      scales: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Per particle, the increment (dx, dy in the robot frame, dyaw) the odometry's (``forward``, ``lateral``,
    ``rotation``) stands for, with the errors of a random walk: ``distance_sd_m`` along and across, and
    ``heading_sd_rad`` in heading, over a metre travelled (growing with the square root of the distance), and
    ``turn_fraction`` of the turn; the distance times each particle's odometry scale (``scales``). None when
    standing still."""
    distance = math.hypot(forward, lateral)
    if distance == 0.0 and rotation == 0.0:
        return None
    root = math.sqrt(distance)
    return _drawn(forward, lateral, rotation, distance_sd_m * root,
                  turn_fraction * abs(rotation) + heading_sd_rad * root, count, rng, scales)


def _drawn(forward: float, lateral: float, rotation: float, translation_sd: float, rotation_sd: float, count: int,
           rng: np.random.Generator, scales: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    noise = rng.standard_normal((3, count))
    along, across = (forward, lateral) if scales is None else (forward * scales, lateral * scales)
    return along + translation_sd * noise[0], across + translation_sd * noise[1], rotation + rotation_sd * noise[2]
