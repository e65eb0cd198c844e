"""Planar geometry helpers shared by the simulator, the controllers and the metrics (REP 103: radians, CCW)."""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle: float) -> float:
    """Wrap an angle to (-pi, pi]: exact for any finite angle, however large (IEEE remainder); a ValueError
    naming the value for NaN or an infinity, which have no direction."""
    if not math.isfinite(angle):
        raise ValueError(f"wrap_angle: {angle} is not a finite angle")
    wrapped = math.remainder(angle, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


def wrap_angles(angles: np.ndarray) -> np.ndarray:
    """Vectorized :func:`wrap_angle`."""
    wrapped = np.remainder(angles + np.pi, 2.0 * np.pi) - np.pi
    return np.where(wrapped == -np.pi, np.pi, wrapped)


def yaw_to_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``yaw`` about z."""
    return 0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)


def quaternion_to_yaw(x: float, y: float, z: float, w: float) -> float:
    """Yaw of a quaternion (rotation about z; roll and pitch ignored)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def point_segment_distance(points: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Distance of each row of ``points`` (N x 2) from the segment start-end, clamped to the segment."""
    direction = end - start
    length_sq = float(direction @ direction)
    if length_sq == 0.0:
        return np.linalg.norm(points - start, axis=1)
    t = np.clip(((points - start) @ direction) / length_sq, 0.0, 1.0)
    return np.linalg.norm(points - (start + t[:, None] * direction), axis=1)


def closest_on_segments(point: tuple[float, float] | np.ndarray, segments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distance from ``point`` to each of ``segments`` (N x 4 rows x1, y1, x2, y2) and the closest point on
    each (N x 2)."""
    start, direction = segments[:, 0:2], segments[:, 2:4] - segments[:, 0:2]
    length_sq = np.einsum("ij,ij->i", direction, direction)
    offset = np.asarray(point, dtype=float) - start
    t = np.clip(np.einsum("ij,ij->i", offset, direction) / np.where(length_sq > 0.0, length_sq, 1.0), 0.0, 1.0)
    closest = start + t[:, None] * direction
    return np.linalg.norm(closest - np.asarray(point, dtype=float), axis=1), closest


def nearest_on_segments(point: tuple[float, float], segments: np.ndarray) -> tuple[float, np.ndarray]:
    """The distance from ``point`` to the nearest of ``segments`` (N x 4 rows x1, y1, x2, y2; N >= 1) and the
    nearest point on it."""
    distances, closest = closest_on_segments(point, segments)
    nearest = int(np.argmin(distances))
    return float(distances[nearest]), closest[nearest]
