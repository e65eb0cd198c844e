"""reproduce partitions: the navigations as engine tasks (one job a navigation: method, r, level, run, seed), the
task each job drives, and the whole grid of Figs. 12-14 timed for ``bench partitions``."""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from dataclasses import dataclass

from rfidnav_common.geometry import wrap_angle
from rfidnav_common.seeding import rng_for
from rfidnav_experiments.engine import engine_workers, run_tasks
from rfidnav_experiments.reproduce.partitions.settings import (
    DEVELOPMENT_SEED,
    DISTANCES_M,
    EVALUATION_SEED,
    LEVELS,
    METHODS,
    NAVIGATION_RANGES_M,
    ODOMETRY_NOISE,
    PAPER,
    RUNS_PER_CURVE,
    TRAJECTORY_DISTANCE_M,
    TRAJECTORY_RANGE_M,
    deployment,
    headline_level,
    localizer_settings,
    method_levels,
    navigator_settings,
    robot_speeds,
)
from rfidnav_experiments.runners.partitions import NavigationRun, random_task, run_navigation
from rfidnav_scenario.metrics import extra_time_cost_pct


@dataclass(frozen=True)
class NavigationJob:
    method: str
    read_range_m: float
    level: int
    index: int                   # run number within the curve; fixes the task
    seed: int

    @property
    def distance_m(self) -> float:
        return DISTANCES_M[self.index % len(DISTANCES_M)]


@dataclass(frozen=True)
class NavigationResult:
    job: NavigationJob
    success: bool
    message: str
    extra_cost_pct: float
    extra_time_cost_pct: float
    extra_cost_to_goal_pct: float
    final_error_m: float
    replans: int

    @classmethod
    def of(cls, job: NavigationJob, run: NavigationRun) -> NavigationResult:
        return cls(job, run.success, run.message, run.extra_cost_pct, run.extra_time_cost_pct,
                   run.extra_cost_to_goal_pct, run.final_error_m, run.replans)


def navigation_jobs(runs: int, methods: Iterable[str] = METHODS, ranges: Iterable[float] | None = None,
                    levels: Iterable[int] | None = None, seed: int = DEVELOPMENT_SEED) -> list[NavigationJob]:
    """Every (r, level, method, run); ``ranges`` default to the paper's, ``levels`` to each method's."""
    return [NavigationJob(method, r, level, index, seed)
            for r in (ranges or NAVIGATION_RANGES_M) for method in methods
            for level in (levels or method_levels(method)) for index in range(runs)]


def task_of(job: NavigationJob) -> tuple[tuple[float, float, float], tuple[float, float]]:
    """Start pose and goal of a job. They depend on (seed, r, run) only: every level and method faces the same."""
    return random_task(deployment(job.read_range_m), job.distance_m,
                       rng_for(job.seed, f"task:{job.read_range_m}:{job.index}"))


def navigate(job: NavigationJob) -> NavigationRun:
    start, goal = task_of(job)
    return run_navigation(deployment(job.read_range_m), start, goal, localizer_settings(job.method),
                          navigator_settings(job.method, job.level),
                          rng_for(job.seed, f"run:{job.method}:{job.read_range_m}:{job.level}:{job.index}"),
                          odometry_noise=ODOMETRY_NOISE, speeds=robot_speeds(job.method))


def run_navigation_job(job: NavigationJob) -> NavigationResult:
    """One navigation (an engine task)."""
    return NavigationResult.of(job, navigate(job))


def oracle_time_cost_pct(job: NavigationJob) -> float:
    """The time cost of a robot that knows its pose: one turn on the spot towards the goal, then the straight line.
    A reference for the time cost on this task, as 0 is for the translational one."""
    (x, y, yaw), goal = task_of(job)
    turn = abs(wrap_angle(math.atan2(goal[1] - y, goal[0] - x) - yaw))
    straight = math.dist((x, y), goal)
    speeds = robot_speeds(job.method)
    return extra_time_cost_pct(straight, turn, straight, speeds.speed_mps, speeds.turn_rate_radps)


def evaluation_jobs(runs: int) -> list[NavigationJob]:
    return navigation_jobs(runs, seed=EVALUATION_SEED)


def example_job(method: str, seed: int) -> NavigationJob:
    """The first task at TRAJECTORY_DISTANCE_M and TRAJECTORY_RANGE_M, at the headline level."""
    return NavigationJob(method, TRAJECTORY_RANGE_M, headline_level(), DISTANCES_M.index(TRAJECTORY_DISTANCE_M), seed)


def benchmark(runs: int = RUNS_PER_CURVE, method: str = PAPER) -> dict[str, float]:
    """The whole grid of Figs. 12-14 for one method (3 ranges x 8 levels x ``runs``) on the command's engine
    (its cluster started before the clock starts)."""
    jobs = navigation_jobs(runs, methods=(method,), levels=LEVELS)
    started = time.perf_counter()
    results = run_tasks(run_navigation_job, jobs, f"bench partitions {method}")
    wall = time.perf_counter() - started
    return {"navigations": len(jobs), "workers": engine_workers(), "wall_s": round(wall, 2),
            "navigations_per_s": round(len(jobs) / wall, 1),
            "success_pct": round(100.0 * sum(r.success for r in results) / len(results), 2)}
