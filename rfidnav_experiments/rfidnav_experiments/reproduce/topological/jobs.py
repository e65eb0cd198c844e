"""reproduce topological: the missions as engine tasks, chunk by chunk, and their results by (floor, method,
miss rate)."""

from __future__ import annotations

from rfidnav_experiments.engine import run_tasks
from rfidnav_experiments.reproduce.topological.conditions import (
    CHUNK,
    EVALUATION_FLOORS,
    FLOOR_ORDER,
    MISS_RATES,
    POOLED,
    RATES,
    SEEDS,
    missions_on,
)
from rfidnav_experiments.runners.topological import METHODS, MissionRun, random_missions


def missions_chunk(job: tuple[str, str, float, int, int]) -> tuple[str, str, float, int, list[MissionRun]]:
    """One task: ``count`` missions of a floor's list from ``first``."""
    floor, method, rate, first, count = job
    return floor, method, rate, first, random_missions(count, rate, SEEDS[floor], floor, METHODS[method],
                                                       first=first)


def mission_jobs(missions: int, floors: tuple[str, ...] = FLOOR_ORDER) -> list[tuple[str, str, float, int, int]]:
    """The tasks of ``missions`` per (floor, method, miss rate): chunks of CHUNK missions of each floor's list."""
    return [(floor, method, rate, first, min(CHUNK, missions_on(floor, missions) - first))
            for floor in floors for method in METHODS for rate in RATES[floor]
            for first in range(0, missions_on(floor, missions), CHUNK)]


def run_all(missions: int, floors: tuple[str, ...] = FLOOR_ORDER,
            label: str = "reproduce topological") -> dict[tuple[str, str, float], list[MissionRun]]:
    """Every mission, by (floor, method, miss rate), in the floor's mission order."""
    chunks: dict[tuple[str, str, float], list[tuple[int, list[MissionRun]]]] = {}
    for floor, method, rate, first, runs in run_tasks(missions_chunk, mission_jobs(missions, floors), label):
        chunks.setdefault((floor, method, rate), []).append((first, runs))
    return {key: [run for _, runs in sorted(parts, key=lambda part: part[0]) for run in runs]
            for key, parts in chunks.items()}


def with_pooled(results: dict[tuple[str, str, float], list[MissionRun]]) \
        -> dict[tuple[str, str, float], list[MissionRun]]:
    """The results with the evaluation floors' missions together under POOLED (floor by floor, in order)."""
    pooled = {(POOLED, method, rate): [run for floor in EVALUATION_FLOORS for run in results[(floor, method, rate)]]
              for method in METHODS for rate in MISS_RATES}
    return {**results, **pooled}
