"""The in-process partition navigation as it was before issue 19's faster walk: every step of a straight drive
walked on its own segment with ``partitions_along_segment`` (candidates from the lattice's row arithmetic), every
round's partition from ``partition_at``. The reference the faster runner must equal."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

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
