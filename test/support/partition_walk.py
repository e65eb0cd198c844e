"""The in-process partition navigation as it was before issue 19's faster cores: every step of a straight drive
walked on its own segment with ``partitions_along_segment`` (candidates from the lattice's row arithmetic), every
round's partition from ``partition_at``, and the particle filter's round arithmetic (FILTER_ROUND). The reference
the faster runner must equal."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.tag_lattice import Deployment, partitions_along_segment
from rfidnav_experiments.runners.partitions import (
    DEFAULT_ROUND_SPACING_M,
    INSIDE_M,
    NODE_DEFAULT_SPEEDS,
    IdealRobot,
    NavigationRun,
    RobotSpeeds,
    turn_observing,
)
from rfidnav_localization.partition import LocalizerSettings, PartitionLocalizer
from rfidnav_planning.partition_navigation import FORWARD, ROTATE, Decision, NavigatorSettings, PartitionNavigator


def run_navigation(deployment: Deployment, start: tuple[float, float, float], goal: tuple[float, float],
                   localizer_settings: LocalizerSettings, navigator_settings: NavigatorSettings,
                   rng: np.random.Generator, odometry_noise: float = 0.0,
                   speeds: RobotSpeeds = NODE_DEFAULT_SPEEDS) -> NavigationRun:
    robot = IdealRobot(*start, odometry_noise, rng, speeds, localizer_settings.antenna_offset_m)
    localizer = PartitionLocalizer(localizer_settings, rng)
    navigator = PartitionNavigator(navigator_settings, deployment.area)
    lattice = deployment.lattice
    spacing = min(deployment.read_range_m / 2.0, DEFAULT_ROUND_SPACING_M)

    def observe() -> Decision:
        tags = deployment.partition_at(*robot.antenna())
        estimate = localizer.update(robot.time_s, [lattice.tag_id(c) for c in tags], robot.odometry())
        return navigator.on_estimate(estimate, robot.travelled_m)

    decision = navigator.start(goal)
    decision = observe()
    while not decision.finished:
        if decision.motion.kind == ROTATE:
            turn_observing(deployment, robot, decision.motion.rotate_by_rad, observe)
            decision = navigator.rotation_done()
            if decision.motion.kind == FORWARD:
                decision = observe()
            continue
        decision = drive_until_decision(deployment, robot, spacing, observe)
    robot.trajectory.append((robot.x, robot.y))
    state = navigator.state
    return NavigationRun(decision.success, decision.message, (start[0], start[1]), goal, robot.travelled_m,
                         math.dist(start[:2], goal), robot.turned_rad, speeds, (robot.x, robot.y), state.replans,
                         state.partitions_entered, np.array(robot.trajectory))


def drive_until_decision(deployment: Deployment, robot: IdealRobot, spacing: float,
                         observe: Callable[[], Decision]) -> Decision:
    while True:
        start = (robot.x, robot.y)
        antenna = robot.antenna()
        end = (antenna[0] + spacing * math.cos(robot.yaw), antenna[1] + spacing * math.sin(robot.yaw))
        pieces = partitions_along_segment(deployment, antenna, end)
        for piece in pieces[1:]:
            robot.drive(piece.t_start * spacing + INSIDE_M - math.dist(start, (robot.x, robot.y)))
            decision = observe()
            if decision.motion.kind != FORWARD:
                robot.trajectory.append((robot.x, robot.y))
                return decision
        robot.drive(spacing - math.dist(start, (robot.x, robot.y)))
        decision = observe()
        if decision.motion.kind != FORWARD:
            robot.trajectory.append((robot.x, robot.y))
            return decision


# The particle filter's per-round arithmetic before issue 19 (out of place, headings' cos and sin taken anew by the
# prediction and the estimate): patched onto ParticleFilter for a reference run.

def predict(self, forward: float, lateral: float, rotation: float) -> None:
    distance = math.hypot(forward, lateral)
    if distance == 0.0 and rotation == 0.0:
        return
    s = self.settings
    translation_sd = s.motion_noise_fraction * distance + s.motion_noise_floor_m
    rotation_sd = s.motion_noise_fraction * abs(rotation) + s.motion_noise_yaw_rad_per_m * distance
    noise = self.rng.standard_normal((3, self.states.shape[1]))
    dx = forward + translation_sd * noise[0]
    dy = lateral + translation_sd * noise[1]
    x, y, yaw = self.states
    cos_yaw, sin_yaw = np.cos(yaw), np.sin(yaw)
    x += cos_yaw * dx - sin_yaw * dy
    y += sin_yaw * dx + cos_yaw * dy
    yaw += rotation + rotation_sd * noise[2]
    self._moved()


def log_likelihood(self, antennas: np.ndarray, read: np.ndarray, unread: np.ndarray,
                   read_range_m: float) -> np.ndarray:
    s = self.settings
    tags = np.concatenate((read, unread))
    sign = np.concatenate((np.ones(len(read)), -np.ones(len(unread))))
    dx = antennas[0][:, None] - tags[:, 0]
    dy = antennas[1][:, None] - tags[:, 1]
    distance = np.sqrt(dx * dx + dy * dy)
    margin = sign * ((read_range_m - distance) / s.boundary_softness_m)
    eps = s.read_error_probability
    return np.log(eps + (1.0 - 2.0 * eps) * 0.5 * (1.0 + np.tanh(0.5 * margin))).sum(axis=1)


def estimate(self) -> tuple[tuple[float, float], tuple[float, float, float], float, float]:
    w = self.weights
    x, y, yaw = self.states
    mean_x, mean_y = float(w @ x), float(w @ y)
    dx, dy = x - mean_x, y - mean_y
    sin_mean, cos_mean = float(w @ np.sin(yaw)), float(w @ np.cos(yaw))
    resultant = min(math.hypot(sin_mean, cos_mean), 1.0)
    yaw_sd = math.sqrt(-2.0 * math.log(resultant)) if resultant > 1e-12 else math.pi
    return ((mean_x, mean_y), (float(w @ (dx * dx)), float(w @ (dx * dy)), float(w @ (dy * dy))),
            wrap_angle(math.atan2(sin_mean, cos_mean)), yaw_sd)


FILTER_ROUND = {"predict": predict, "log_likelihood": log_likelihood, "estimate": estimate}
