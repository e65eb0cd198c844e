"""Planar geometry helpers shared by the simulator, the controllers and the metrics (REP 103: radians, CCW)."""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle: float) -> float:
    """Wrap an angle to (-pi, pi]."""
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
